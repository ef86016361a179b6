//! Cameras of scenes that bring no camera path: models framed and lit with no
//! flags, whatever their size; the glTF file's own cameras. Runs the command
//! line on glTF models written by the test (lavapipe, small images).

use crate::common;
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
/// The model's own pixels cover less (23-28 % here): a compact model seen
/// whole from every side of the turn, with a margin, in a 16:9 frame leaves
/// the sides empty. Its extent is what framing controls.
///
/// The generated lights reach either model: four big lights brighten over a
/// fifth of its pixels (with lights placed in metres, none on the 5 cm model
/// and a ninth of the 200 m one).
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
        let lit = |lights: &str| {
            let out = dir.path().join(format!("{name}-{}.png", lights.replace(':', "-")));
            let (code, err, image) =
                render(&out, &["--scene", scene.to_str().unwrap(), "--size", SIZE, "--lights", lights]);
            assert_eq!(code, 0, "{name}: {err}");
            image.unwrap()
        };
        let (unlit, big) = (lit("none"), lit("big:4"));
        let model = unlit.pixels().zip(big.pixels()).filter(|(u, _)| u.0.iter().any(|&c| c > 0));
        let value = |p: &image::Rgb<u8>| *p.0.iter().max().unwrap() as i32;
        let (n, brighter) = model.fold((0, 0), |(n, b), (u, l)| (n + 1, b + (value(l) > value(u) + 10) as u32));
        let share = brighter as f32 / n as f32;
        eprintln!("{name}: big:4 brightens {:.1} % of the model", 100.0 * share);
        assert!(share > 0.2, "{name}: the generated lights hardly reach the model ({:.1} %)", 100.0 * share);
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

/// The centroid (x, y, in pixels) and the radius (from its area) of the
/// model's pixels, for a sphere seen as a disc.
fn disc(image: &image::RgbImage) -> (f32, f32, f32) {
    let pixels: Vec<(u32, u32)> =
        image.enumerate_pixels().filter(|(_, _, p)| p.0.iter().any(|&c| c > 0)).map(|(x, y, _)| (x, y)).collect();
    let n = pixels.len() as f32;
    let x = pixels.iter().map(|p| p.0 as f32).sum::<f32>() / n;
    let y = pixels.iter().map(|p| p.1 as f32).sum::<f32>() / n;
    (x, y, (n / std::f32::consts::PI).sqrt())
}

/// Pixel radius of the disc a sphere of `radius` at `distance` covers in a
/// `size`-pixel-high image of vertical field of view `fov_deg`: its silhouette
/// cone has half-angle asin(radius / distance).
fn disc_radius(radius: f32, distance: f32, fov_deg: f32, size: u32) -> f32 {
    (radius / distance).asin().tan() / (0.5 * fov_deg.to_radians()).tan() * 0.5 * size as f32
}

/// `--eye`/`--target` and `--orbit` put a known point in the middle of the
/// image at the distance and field of view asked for: a unit sphere at
/// (3, 1, -2) shows as a centred disc of the predicted size.
#[test]
fn free_cameras_show_the_expected_view() {
    let dir = tempfile::tempdir().unwrap();
    let ball = [common::gltf::ellipsoid(Vec3::new(3.0, 1.0, -2.0), Vec3::ONE, 32, 48)];
    let scene = write_gltf(dir.path(), "ball", &ball, &Placement::default());
    let size = 128;
    let cases: [(&[&str], f32, f32); 4] = [
        // (flags, distance from the eye to the centre, field of view)
        (&["--eye", "3,1,2", "--target", "3,1,-2"], 4.0, 60.0),
        (&["--eye", "3,1,2", "--target", "3,1,-2", "--fov", "40"], 4.0, 40.0),
        // Frame 0 of the turn is on the +x side, frame 2 of 8 a quarter turn on.
        (&["--orbit", "3,4,8", "--target", "3,1,-2"], 5.0, 60.0),
        (&["--orbit", "3,4,8", "--target", "3,1,-2", "--frame", "2", "--fov", "45"], 5.0, 45.0),
    ];
    for (k, (flags, distance, fov)) in cases.into_iter().enumerate() {
        let out = dir.path().join(format!("free-{k}.png"));
        let mut args = vec!["--scene", scene.to_str().unwrap(), "--size", "128x128"];
        args.extend_from_slice(flags);
        let (code, err, image) = render(&out, &args);
        assert_eq!(code, 0, "{flags:?}: {err}");
        let image = image.unwrap();
        image.save(common::out_dir().join(format!("free-camera-{k}.png"))).unwrap();
        let (x, y, r) = disc(&image);
        let want = disc_radius(1.0, distance, fov, size);
        eprintln!("{flags:?}: disc at ({x:.2}, {y:.2}), radius {r:.2} px (expected {want:.2})");
        let middle = (size - 1) as f32 / 2.0;
        assert!((x - middle).abs() < 0.5 && (y - middle).abs() < 0.5, "{flags:?}: off centre at ({x}, {y})");
        assert!((r / want - 1.0).abs() < 0.03, "{flags:?}: radius {r} px, expected {want}");
    }
    // Looking at (2, 1, -2), 1 m left of the ball: the ball's centre is
    // atan(1/4) to the right of the view axis, its silhouette asin(1/4) wide
    // either side, so its left and right edges are at those angles' tangents
    // over tan(30 deg), in half-widths of 64 pixels from the middle.
    let out = dir.path().join("free-aside.png");
    let args = ["--scene", scene.to_str().unwrap(), "--size", "128x128", "--eye", "3,1,2", "--target", "2,1,-2"];
    let (code, err, image) = render(&out, &args);
    assert_eq!(code, 0, "{err}");
    let image = image.unwrap();
    let columns: Vec<u32> = image.enumerate_pixels().filter(|(_, _, p)| p.0[0] > 0).map(|(x, _, _)| x).collect();
    let (left, right) = (*columns.iter().min().unwrap() as f32, *columns.iter().max().unwrap() as f32);
    let (centre, half) = ((1.0f32 / 4.0).atan(), (1.0f32 / 4.0).asin());
    let edge = |angle: f32| 63.5 + angle.tan() / 30f32.to_radians().tan() * 64.0;
    let (want_left, want_right) = (edge(centre - half), edge(centre + half));
    eprintln!("aside: columns {left} to {right}, expected {want_left:.2} to {want_right:.2}");
    assert!((left - want_left).abs() < 1.0 && (right - want_right).abs() < 1.0, "columns {left} to {right}");
    assert!((disc(&image).1 - 63.5).abs() < 0.5, "still level");
}

/// Bad camera flags exit with status 2 and name the flag.
#[test]
fn bad_camera_flags_name_the_flag() {
    let cases: [(&[&str], &[&str]); 12] = [
        (&["--eye", "1,2"], &["--eye", "X,Y,Z"]),
        (&["--eye", "1,2,nan", "--target", "0,0,0"], &["--eye", "finite"]),
        (&["--eye", "1,2,3"], &["--target"]),
        (&["--target", "1,2,3"], &["--eye", "--orbit"]),
        (&["--fov", "40"], &["--eye", "--orbit"]),
        (&["--eye", "1,2,3", "--target", "1,2,3"], &["--eye", "--target", "same point"]),
        (&["--eye", "1,2,3", "--target", "0,0,0", "--fov", "180"], &["--fov", "below 180"]),
        (&["--eye", "1,2,3", "--target", "0,0,0", "--fov", "0"], &["--fov", "above 0"]),
        (&["--eye", "1,2,3", "--target", "0,0,0", "--orbit", "1,1,10"], &["--eye", "--orbit"]),
        (&["--eye", "1,2,3", "--target", "0,0,0", "--camera", "fixed:1"], &["--camera", "--eye"]),
        (&["--orbit", "0,1,10"], &["--orbit", "radius"]),
        (&["--orbit", "1,1,2.5"], &["--orbit", "period"]),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (flags, expected) in cases {
        let mut args = vec!["--size", "32x18"];
        args.extend_from_slice(flags);
        let (code, err, _) = render(&dir.path().join("x.png"), &args);
        assert_eq!(code, 2, "{flags:?} was accepted:\n{err}");
        for e in expected {
            assert!(err.contains(e), "{flags:?}: no '{e}' in {err}");
        }
    }
    let help = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for flag in [
        "--eye <X,Y,Z>",
        "--target <X,Y,Z>",
        "--orbit <RADIUS,HEIGHT,PERIOD>",
        "--fov <DEG>",
        "gltf:K",
        "bookmark:FILE:NAME",
    ] {
        assert!(help.contains(flag), "render --help lacks {flag}");
    }
}

/// `--camera bookmark:FILE:NAME` renders the view the viewer saved under
/// NAME exactly as `--eye --target --fov` of its numbers does, `bench` takes
/// it too, and a missing file, a file that is not a bookmark list or an
/// unknown name exit with status 2 naming the file and the problem.
#[test]
fn bookmarks_are_cameras_for_render_and_bench() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("views.json");
    let marks = r#"[{"name": "view-1", "eye": [2, 3, 9], "target": [0, 1, 0], "fov": 50},
                    {"name": "low", "eye": [-4, 0.5, 3], "target": [0, 1, 0], "fov": 70}]"#;
    std::fs::write(&file, marks).unwrap();
    let camera = |name: &str| format!("bookmark:{}:{name}", file.display());
    let base = ["--scene", "atrium", "--size", "64x36"];
    let (code, err, marked) =
        render(&dir.path().join("marked.png"), &[&base[..], &["--camera", &camera("low")]].concat());
    assert_eq!(code, 0, "{err}");
    let by_hand = ["--eye", "-4,0.5,3", "--target", "0,1,0", "--fov", "70"];
    let (code, err, free) = render(&dir.path().join("free.png"), &[&base[..], &by_hand].concat());
    assert_eq!(code, 0, "{err}");
    assert!(marked.unwrap() == free.unwrap(), "the bookmark renders another view than its numbers");

    let stats = dir.path().join("bench.json");
    let bench = Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["bench", "--quiet", "--frames", "1", "--warmup", "0", "--out", stats.to_str().unwrap()])
        .args([&base[..], &["--camera", &camera("view-1")]].concat())
        .output()
        .unwrap();
    assert!(bench.status.success(), "{}", String::from_utf8_lossy(&bench.stderr));
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(report["camera"], camera("view-1"));

    let broken = dir.path().join("broken.json");
    std::fs::write(&broken, r#"{"view-1": [2, 3, 9]}"#).unwrap();
    let cases = [
        (format!("bookmark:{}:view-1", dir.path().join("none.json").display()), "none.json", "cannot read"),
        (format!("bookmark:{}:view-1", broken.display()), "broken.json", "not a bookmark file"),
        (camera("view-2"), "views.json", "no bookmark named 'view-2' (the file has: view-1, low)"),
        ("bookmark:views.json".to_string(), "bookmark:FILE:NAME", "expected"),
    ];
    for (value, file, problem) in cases {
        let (code, err, _) = render(&dir.path().join("x.png"), &[&base[..], &["--camera", &value]].concat());
        assert_eq!(code, 2, "--camera {value} was accepted:\n{err}");
        assert!(err.contains("--camera") && err.contains(file) && err.contains(problem), "{value}: {err}");
    }
}
