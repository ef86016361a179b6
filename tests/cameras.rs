//! Cameras of scenes that bring no camera path: models framed and lit with no
//! flags, whatever their size; the glTF file's own cameras. Runs the command
//! line on glTF models written by the test (lavapipe, small images).
mod common;

use std::path::Path;
use std::process::Command;

use common::gltf::{Placement, teapot, write_gltf};
use glam::Vec3;

const SIZE: &str = "160x90";

/// Runs `shadespace render --out OUT ARGS` and returns the exit status,
/// stderr and (on success) the image.
fn render(out: &Path, args: &[&str]) -> (i32, String, Option<image::RgbImage>) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shadespace"));
    cmd.args(["render", "--out", out.to_str().unwrap()]).args(args);
    // Charts of generated models stay in the test's folder.
    cmd.env("SHADESPACE_CACHE_DIR", out.parent().unwrap().join("charts"));
    let result = cmd.output().expect("run shadespace");
    let stderr = String::from_utf8_lossy(&result.stderr).to_string();
    assert!(!stderr.contains("panicked"), "panic on {args:?}:\n{stderr}");
    let code = result.status.code().unwrap_or(-1);
    let image = (code == 0).then(|| image::open(out).unwrap().to_rgb8());
    (code, stderr, image)
}

/// What a frame shows of a model on the black background: the share of
/// pixels it covers, the share of the frame its extent (the rectangle around
/// its pixels) covers, whether it touches the border, and over its pixels
/// the mean value (0 to 255, max of R, G, B) and the share that is white
/// (every channel 250+).
#[derive(Debug)]
struct Exposure {
    coverage: f32,
    extent: f32,
    touches_border: bool,
    mean: f32,
    white: f32,
}

fn exposure(image: &image::RgbImage) -> Exposure {
    let (w, h) = image.dimensions();
    let model: Vec<(u32, u32, &image::Rgb<u8>)> =
        image.enumerate_pixels().filter(|(_, _, p)| p.0.iter().any(|&c| c > 0)).collect();
    let n = model.len().max(1) as f32;
    let (mut lo, mut hi) = ((w, h), (0, 0));
    for &(x, y, _) in &model {
        (lo, hi) = ((lo.0.min(x), lo.1.min(y)), (hi.0.max(x), hi.1.max(y)));
    }
    let extent = if model.is_empty() { 0 } else { (hi.0 - lo.0 + 1) * (hi.1 - lo.1 + 1) };
    Exposure {
        coverage: model.len() as f32 / (w * h) as f32,
        extent: extent as f32 / (w * h) as f32,
        touches_border: model.iter().any(|&(x, y, _)| x == 0 || y == 0 || x == w - 1 || y == h - 1),
        mean: model.iter().map(|(_, _, p)| *p.0.iter().max().unwrap() as f32).sum::<f32>() / n,
        white: model.iter().filter(|(_, _, p)| p.0.iter().all(|&c| c >= 250)).count() as f32 / n,
    }
}

/// A 5 cm teapot off the origin and a 200 m one far from it are seen whole,
/// their extent filling 30-90 % of the frame, lit (not black, not white),
/// with no camera or light flags; so are other frames of the turntable.
///
/// The model's own pixels cover less (about 14 % here): a compact model seen
/// whole from every side of the turn, with a margin, in a 16:9 frame leaves
/// the sides empty. Its extent is what framing controls.
#[test]
fn tiny_and_huge_models_are_framed_and_lit_with_no_flags() {
    let dir = tempfile::tempdir().unwrap();
    let models = [
        ("tiny", Placement { scale: 0.015, translation: Vec3::new(0.1, 0.0, -0.05), ..Default::default() }),
        ("huge", Placement { scale: 60.0, translation: Vec3::new(1000.0, 0.0, -500.0), ..Default::default() }),
    ];
    for (name, placement) in models {
        let scene = write_gltf(dir.path(), name, &teapot(), &placement);
        for frame in ["0", "200"] {
            let out = dir.path().join(format!("{name}-{frame}.png"));
            let (code, err, image) =
                render(&out, &["--scene", scene.to_str().unwrap(), "--size", SIZE, "--frame", frame]);
            assert_eq!(code, 0, "{name}: {err}");
            let image = image.unwrap();
            image.save(common::out_dir().join(format!("framed-{name}-{frame}.png"))).unwrap();
            let e = exposure(&image);
            eprintln!("{name} frame {frame}: {e:?}");
            assert!(!e.touches_border, "{name} frame {frame}: cut by the border: {e:?}");
            assert!((0.3..=0.9).contains(&e.extent), "{name} frame {frame}: framed too loose or tight: {e:?}");
            assert!(e.coverage > 0.1, "{name} frame {frame}: too small: {e:?}");
            assert!((50.0..=220.0).contains(&e.mean), "{name} frame {frame}: too dark or bright: {e:?}");
            assert!(e.white < 0.05, "{name} frame {frame}: blown out: {e:?}");
        }
    }
}

/// A model with cameras of its own is seen through the first by default;
/// `--camera gltf:K` picks another; a K out of range is an input error
/// naming the file.
#[test]
fn gltf_cameras_are_used_when_present() {
    let dir = tempfile::tempdir().unwrap();
    let cameras = vec![Vec3::new(0.0, 1.3, 6.0), Vec3::new(0.8, 1.0, 3.5)];
    let scene = write_gltf(dir.path(), "posed", &teapot(), &Placement { cameras, ..Default::default() });
    let scene = scene.to_str().unwrap();
    let shot = |camera: Option<&str>| {
        let out = dir.path().join(format!("posed-{}.png", camera.unwrap_or("default").replace(':', "-")));
        let mut args = vec!["--scene", scene, "--size", SIZE];
        if let Some(c) = camera {
            args.extend(["--camera", c]);
        }
        render(&out, &args)
    };
    let (default, first, second) = (shot(None), shot(Some("gltf:0")), shot(Some("gltf:1")));
    for (code, err, _) in [&default, &first, &second] {
        assert_eq!(*code, 0, "{err}");
    }
    assert_eq!(default.2, first.2, "the default camera is the file's first");
    let (near, far) = (exposure(second.2.as_ref().unwrap()), exposure(first.2.as_ref().unwrap()));
    assert!(near.coverage > 1.5 * far.coverage, "camera 1 is nearer: {near:?} vs {far:?}");

    let (code, err, _) = shot(Some("gltf:2"));
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("posed.gltf") && err.contains("gltf:2") && err.contains("2 cameras"), "{err}");
    let (code, err, _) = render(&dir.path().join("x.png"), &["--scene", "atrium", "--camera", "gltf:0"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("atrium has no cameras of its own"), "{err}");
}
