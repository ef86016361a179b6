//! Shading density that follows the screen (issue 26, item 3): with no
//! flags, a 5 cm model filling the frame gets as many shading texels per
//! pixel as a large one, where the former fixed 256 texels per metre starved it.

use crate::common;
use std::path::Path;
use std::process::Command;

use common::gltf::{Placement, cuboid, write_gltf};
use glam::Vec3;

/// Runs `shadespace render ARGS` in object space at 128x128 and returns the
/// visible texels per pixel it prints.
fn visible_texels_per_pixel(dir: &Path, args: &[&str]) -> f64 {
    let out = dir.join("frame.png");
    let result = Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["render", "--pipeline", "objectspace", "--size", "128x128", "--out", out.to_str().unwrap()])
        .args(args)
        .env("SHADESPACE_CACHE_DIR", dir.join("cache"))
        .output()
        .expect("run shadespace");
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(result.status.success(), "{args:?}: {}", String::from_utf8_lossy(&result.stderr));
    let line = stdout.lines().find(|l| l.contains("visible texels per pixel")).expect("the object-space line");
    let value = line.trim().strip_prefix("object space: ").and_then(|l| l.split(' ').next());
    value.and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("no number in '{line}'"))
}

/// A 5 x 5 x 1 cm slab seen face-on from 3 cm, its face filling the frame:
/// with no sizing flags it is shaded at 0.9 visible texels per pixel or more
/// (lavapipe: 1.89; tiles of 8 texels count whole), while at the former default of
/// 256 texels per metre (a 16 texel face) it gets far fewer (0.06).
#[test]
fn a_5_cm_model_filling_the_frame_gets_a_texel_per_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let placement = Placement { scale: 0.01, ..Default::default() };
    let scene = write_gltf(dir.path(), "slab", &[cuboid(Vec3::ZERO, Vec3::new(5.0, 5.0, 1.0))], &placement);
    let camera = ["--eye", "0.025,0.025,0.04", "--target", "0.025,0.025,0.01"];
    let args: Vec<&str> = ["--scene", scene.to_str().unwrap()].into_iter().chain(camera).collect();
    let screen = visible_texels_per_pixel(dir.path(), &args);
    let fixed = visible_texels_per_pixel(dir.path(), &[args.as_slice(), &["--texel-density", "256"]].concat());
    eprintln!("5 cm slab: {screen:.2} visible texels per pixel (at 256 texels/m: {fixed:.2})");
    assert!(screen >= 0.9, "{screen:.2} visible texels per pixel");
    assert!(fixed < 0.5, "the fixed density no longer starves the slab ({fixed:.2}): the test shows nothing");
}
