//! The generated light sets of the existing scenes (atrium, voxels, the
//! shared Sponza) stay exactly what the goldens and the published benchmarks
//! were made with: each set is summarised (sums of positions, radii,
//! intensities, colours; spot and shadow counts) and compared with the
//! summary recorded before the generators became scale-aware. Sponza skips
//! with a message where the shared scenes are absent.

use crate::common;
use std::path::Path;

use shadespace::scene::{LightKind, lights};

/// The specs, image sizes and seeds the goldens (192x108, seed 7) and the
/// benchmark scripts (1920x1080, seed 1) use.
const CASES: [(&str, u32, u32, u64); 4] = [
    ("small:24+big:2", 192, 108, 7),
    ("small:100", 1920, 1080, 1),
    ("shadowed:4", 1920, 1080, 1),
    ("mixed:2:5", 1920, 1080, 1),
];

/// Sums over a set's lights: `[count, Σ position (x, y, z), Σ radius,
/// Σ intensity, Σ colour (r + g + b), spots, shadowed]`.
fn summary(set: &[lights::Light]) -> [f64; 9] {
    let mut s = [0.0f64; 9];
    s[0] = set.len() as f64;
    for l in set {
        s[1] += l.position.x as f64;
        s[2] += l.position.y as f64;
        s[3] += l.position.z as f64;
        s[4] += l.radius as f64;
        s[5] += l.intensity as f64;
        s[6] += l.color.element_sum() as f64;
        s[7] += (l.kind == LightKind::Spot) as u32 as f64;
        s[8] += l.casts_shadows as u32 as f64;
    }
    s
}

fn check(scene: &str, expected: &[[f64; 9]; 4]) {
    for ((spec, w, h, seed), want) in CASES.iter().zip(expected) {
        let frame = common::path_frame_seeded(scene, spec, *w, *h, *seed);
        let got = summary(&frame.lights);
        let same = got.iter().zip(want).all(|(g, w)| (g - w).abs() <= 1e-5 * w.abs().max(1.0));
        assert!(same, "{scene} {spec} at {w}x{h} seed {seed} changed:\n  got  {got:?}\n  want {want:?}");
    }
}

/// [`summary`] of each of [`CASES`], recorded with the generators as they
/// were before lights became scale-aware.
#[rustfmt::skip]
const ATRIUM: [[f64; 9]; 4] = [
    [28.0, -52.5279136, 158.831534, -35.457315, 47.9085911, 25.622507, 50.3815832, 1.0, 0.0],
    [102.0, 98.8077683, 688.83546, -36.669147, 120.829172, 83.8710385, 182.646204, 0.0, 0.0],
    [6.0, -11.5525007, 22.937835, 17.1320753, 41.8573565, 34.8732556, 12.1125095, 1.0, 4.0],
    [14.0, 5.95455933, 73.7902844, 40.9529071, 38.5795167, 18.0828999, 26.755741, 1.0, 2.0],
];
#[rustfmt::skip]
const VOXELS: [[f64; 9]; 4] = [
    [28.0, -448.238167, 610.890494, -605.138195, 599.909069, 6347.9413, 50.3815832, 1.0, 0.0],
    [102.0, 843.15958, 2649.36707, -625.820061, 1658.44945, 8379.32028, 182.646204, 0.0, 0.0],
    [6.0, -98.581337, 88.2224398, 292.387421, 405.615761, 9501.52773, 12.1125095, 1.0, 4.0],
    [14.0, 50.8122482, 283.808772, 698.929581, 369.116768, 4681.85271, 26.755741, 1.0, 2.0],
];
#[rustfmt::skip]
const SPONZA_THESIS: [[f64; 9]; 4] = [
    [28.0, -56.3936481, 102.803609, -21.6922314, 40.4537587, 23.0872038, 50.3815832, 1.0, 0.0],
    [102.0, 2.39500284, 443.840453, -4.4495132, 104.962563, 78.0906895, 182.646204, 0.0, 0.0],
    [6.0, -11.2063112, 14.8850825, 14.5552254, 33.564301, 14.6227199, 12.1125095, 1.0, 4.0],
    [14.0, -4.0150876, 47.7482597, 35.3929267, 33.8516451, 13.2035749, 26.755741, 1.0, 2.0],
];

#[test]
fn atrium_light_sets_are_unchanged() {
    check("atrium", &ATRIUM);
}

#[test]
fn voxels_light_sets_are_unchanged() {
    check("voxels", &VOXELS);
}

#[test]
fn sponza_light_sets_are_unchanged() {
    const SPONZA: &str = "../shared/scenes/sponza-thesis";
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    check(SPONZA, &SPONZA_THESIS);
}
