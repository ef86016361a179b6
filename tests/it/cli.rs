//! The command line on bad input: a clear message naming the file or value,
//! exit status 2, and no panic. These fail before a GPU is opened (but the
//! warning test, which renders a tiny frame).

use std::process::Command;

fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(args).output().expect("run shadespace");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "panic on {args:?}:\n{stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

#[test]
fn missing_scene_names_the_path() {
    let (code, err) = run(&["render", "--scene", "no/such/scene.obj"]);
    assert_eq!(code, 2);
    assert!(err.contains("no/such/scene.obj") && err.contains("no such file"), "{err}");
}

#[test]
fn malformed_obj_names_the_file_and_problem() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let (code, err) = run(&["render", "--scene", path.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("broken.obj") && err.contains("out of range"), "{err}");
}

#[test]
fn unknown_format_and_bad_gltf_are_input_errors() {
    let dir = tempfile::tempdir().unwrap();
    let txt = dir.path().join("scene.txt");
    std::fs::write(&txt, "hello").unwrap();
    let (code, err) = run(&["render", "--scene", txt.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("scene.txt") && err.contains("unknown scene format"), "{err}");
    let gltf = dir.path().join("bad.gltf");
    std::fs::write(&gltf, "{ not json").unwrap();
    let (code, err) = run(&["render", "--scene", gltf.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("bad.gltf"), "{err}");
}

/// A malformed city size and a fly-over asked of a scene without one.
#[test]
fn bad_city_sizes_and_missing_flyovers_are_input_errors() {
    for bad in ["city:0", "city:65", "city:x", "city:2:y"] {
        let (code, err) = run(&["render", "--scene", bad]);
        assert_eq!(code, 2, "{bad}");
        assert!(err.contains(bad) && err.contains("city:N"), "{err}");
    }
    let (code, err) = run(&["render", "--scene", "atrium", "--camera", "flyover"]);
    assert_eq!(code, 2);
    assert!(err.contains("flyover") && err.contains("atrium has no fly-over path"), "{err}");
}

#[test]
fn bad_options_say_what_is_wrong() {
    let (code, err) = run(&["render", "--lights", "small:x"]);
    assert_eq!(code, 2);
    assert!(err.contains("'x' is not a number"), "{err}");
    let (code, err) = run(&["render", "--camera", "fixed:99"]);
    assert_eq!(code, 2);
    assert!(err.contains("fixed:99"), "{err}");
    for bad in ["3", "16", "0"] {
        let (code, err) = run(&["render", "--msaa", bad]);
        assert_eq!(code, 2);
        assert!(err.contains("is not one of 1, 2, 4, 8"), "{err}");
    }
    let (code, err) = run(&["experiment", "lights", "--quick", "--msaa", "4"]);
    assert_eq!(code, 2);
    assert!(err.contains("only the quality experiment has an MSAA axis"), "{err}");
    let (code, err) = run(&["experiment", "layers", "--quick", "--configs", "deferred-compute,fast"]);
    assert_eq!(code, 2);
    assert!(err.contains("'fast' is not a configuration") && err.contains("objectspace-hz30"), "{err}");
    assert!(err.contains("objectspace-hz30-vr1-bias0.5"), "the error lists the trade-offs too: {err}");
    let (code, err) = run(&["experiment", "lights", "--quick", "--configs", "forward"]);
    assert_eq!(code, 2);
    assert!(err.contains("only the quality and layers experiments take it"), "{err}");
    let (code, err) = run(&["experiment", "lights", "--quick", "--atlas-budget", "8"]);
    assert_eq!(code, 2);
    assert!(err.contains("--atlas-budget: only the quality experiment takes it"), "{err}");
    let (code, err) = run(&["experiment", "quality", "--quick", "--atlas-budget", "0"]);
    assert_eq!(code, 2);
    assert!(err.contains("--atlas-budget") && err.contains("0"), "{err}");
    let (code, err) = run(&["render", "--size", "12x"]);
    assert_eq!(code, 2);
    assert!(err.contains("12x"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--tile-size", "12"]);
    assert_eq!(code, 2);
    assert!(err.contains("8, 16, 32, 64"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--visibility", "software"]);
    assert_eq!(code, 2);
    assert!(err.contains("'software' is not auto, raster or compute"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--page-size", "64"]);
    assert_eq!(code, 2);
    assert!(err.contains("--page-size 64") && err.contains("four times the tile size"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--views", "fixed", "--visibility", "raster"]);
    assert_eq!(code, 2);
    assert!(err.contains("--views needs compute visibility"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--views", "stereo:abc"]);
    assert_eq!(code, 2);
    assert!(err.contains("eye distance"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--shade-hz", "30", "--reuse", "2"]);
    assert_eq!(code, 2);
    assert!(err.contains("--shade-hz") && err.contains("--reuse"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--os-trimap-lanes", "3"]);
    assert_eq!(code, 2);
    assert!(err.contains("--os-trimap-lanes") && err.contains("1, 2, 4 or 8"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--os-trimap-store", "3"]);
    assert_eq!(code, 2);
    assert!(err.contains("--os-trimap-store") && err.contains("power of two up to 2048"), "{err}");
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--os-gather", "record", "--msaa", "4"]);
    assert_eq!(code, 2);
    assert!(err.contains("--os-gather record") && err.contains("--msaa 4"), "{err}");
    // The records hold one chart point a pixel: no anisotropic taps.
    let (code, err) = run(&["render", "--pipeline", "objectspace", "--os-gather", "record", "--os-aniso", "4"]);
    assert_eq!(code, 2);
    assert!(err.contains("--os-gather record") && err.contains("--os-aniso 4"), "{err}");
    let (code, err) = run(&["bench", "--forward-only", "nothing-called-this"]);
    assert_eq!(code, 2);
    assert!(err.contains("nothing-called-this"), "{err}");
}

/// Numbers that would give NaN shading, an empty budget or overflowing
/// texture sizes are refused with the flag and the accepted range.
#[test]
fn numeric_flags_must_be_finite_and_in_range() {
    let cases: [(&[&str], &str); 13] = [
        (&["--mip-bias", "nan"], "-16 to 16"),
        (&["--mip-bias", "inf"], "-16 to 16"),
        (&["--exposure", "inf"], "positive finite"),
        (&["--exposure", "0"], "positive finite"),
        (&["--atlas-budget", "0"], "--atlas-budget"),
        (&["--texel-density", "1e30"], "at most 65536"),
        (&["--variable-rate", "-1"], "0 to 16"),
        (&["--level-blend", "1.5"], "from 0 to 1"),
        (&["--level-blend", "nan"], "from 0 to 1"),
        (&["--cull-plain-above", "1.5"], "from 0 to 1"),
        (&["--cull-plain-above", "nan"], "from 0 to 1"),
        (&["--os-aniso", "3"], "1, 2, 4, 8, 16"),
        (&["--os-aniso", "0"], "1, 2, 4, 8, 16"),
    ];
    for (flags, expected) in cases {
        let mut args = vec!["render", "--pipeline", "objectspace"];
        args.extend_from_slice(flags);
        let (code, err) = run(&args);
        assert_eq!(code, 2, "{flags:?} was accepted:\n{err}");
        assert!(err.contains(flags[1]) && err.contains(expected), "{flags:?}: {err}");
    }
    // A bench of no measured frames has nothing to report; the tile side
    // names its choices.
    for (args, expected) in [
        (&["bench", "--frames", "0"][..], "'0' for '--frames"),
        (&["bench", "--pipeline", "deferred-compute", "--dc-tile", "12"][..], "auto, 8, 16"),
    ] {
        let (code, err) = run(args);
        assert_eq!(code, 2, "{args:?} was accepted:\n{err}");
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}

/// `--bloom` takes a finite strength from 0 to 1, and says so.
#[test]
fn bloom_strength_must_be_from_0_to_1() {
    for value in ["nan", "inf", "-0.1", "1.5", "x"] {
        let (code, err) = run(&["render", "--bloom", value]);
        assert_eq!(code, 2, "--bloom {value} was accepted:\n{err}");
        assert!(err.contains("--bloom") && err.contains(value), "{value}: {err}");
        let expected = if value == "x" { "not a number" } else { "from 0 to 1" };
        assert!(err.contains(expected), "{value}: {err}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(["render", "--help"]).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("--bloom"));
}

#[test]
fn help_explains_every_command() {
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace")).arg("--help").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    // `view` is in every build: one without the viewer explains how to get it.
    for cmd in ["render", "bench", "info", "charts", "compare", "experiment", "view"] {
        assert!(text.contains(cmd), "--help lacks {cmd}");
        // A debug binary runs clap's checks of a command's definition when
        // it is built, so each subcommand's help also validates it.
        let sub = Command::new(env!("CARGO_BIN_EXE_shadespace")).args([cmd, "--help"]).output().unwrap();
        assert!(sub.status.success(), "{cmd} --help failed: {}", String::from_utf8_lossy(&sub.stderr));
        assert!(!sub.stdout.is_empty(), "{cmd} --help printed nothing");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(["render", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for flag in [
        "--scene",
        "--lights",
        "--camera",
        "--reuse",
        "--tile-size",
        "--view",
        "--atlas-out",
        "--shadow-refresh",
        "--sun-shadow",
    ] {
        assert!(text.contains(flag), "render --help lacks {flag}");
    }
}

/// Shadowed lights render with shadows: no warning any more, and the stats
/// carry the shadow maps' memory (one spot face or six cube faces of 4 MiB
/// each per shadowed light, the sun's cascades) and the settings; a bad
/// refresh is refused.
#[test]
fn shadowed_lights_render_shadow_maps() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.png");
    let stats = dir.path().join("stats.json");
    let (out_s, stats_s) = (out.to_str().unwrap(), stats.to_str().unwrap());
    let args = ["render", "--lights", "shadowed:2", "--size", "32x18", "--out", out_s, "--stats", stats_s];
    let (code, err) = run(&[&args[..], &["--shadow-refresh", "every-frame", "--sun-shadow", "on"]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("not implemented"), "{err}");
    assert!(out.is_file());
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let pipeline = &report["pipeline"];
    // Two lights of 1 or 6 faces, and the sun's 4 cascades of 16 MiB.
    let faces = pipeline["setup"]["shadow_faces"].as_u64().unwrap() - 4;
    assert!((2..=12).contains(&faces), "{pipeline}");
    assert!(pipeline["memory"]["shadow_maps"].as_u64().unwrap() >= (faces + 16) * (4 << 20), "{pipeline}");
    assert_eq!(pipeline["setup"]["shadow_refresh_every_frame"], 1);
    assert_eq!(pipeline["setup"]["sun_shadow"], 1);
    let (code, err) = run(&["render", "--shadow-refresh", "sometimes", "--size", "32x18", "--out", out_s]);
    assert_ne!(code, 0);
    assert!(err.contains("on-change or every-frame"), "{err}");
}

/// `render --views stereo:D` writes the second eye beside the first.
#[test]
fn stereo_views_write_both_eyes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.png");
    let args = ["render", "--pipeline", "objectspace", "--views", "stereo:0.1", "--size", "32x18"];
    let (code, err) = run(&[&args[..], &["--visibility", "compute", "--out", out.to_str().unwrap()]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(out.is_file() && dir.path().join("frame-view1.png").is_file());
}

/// `--view atlas-pages` and `--atlas-out` name an object and level that
/// exist, with object space; otherwise status 2 says what the scene has.
#[test]
fn atlas_pages_need_an_object_and_level_that_exist() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.png");
    let base = ["render", "--size", "32x18", "--out", out.to_str().unwrap(), "--view", "atlas-pages"];
    let cases: [(&[&str], &str); 3] = [
        (&["--pipeline", "forward"], "need --pipeline objectspace"),
        (&["--pipeline", "objectspace", "--atlas-object", "999"], "--atlas-object 999: the scene has"),
        (&["--pipeline", "objectspace", "--atlas-level", "40"], "--atlas-level 40: object 0's shading texture has"),
    ];
    for (flags, expected) in cases {
        let (code, err) = run(&[&base[..], flags].concat());
        assert_eq!(code, 2, "{flags:?} was accepted:\n{err}");
        assert!(err.contains(expected), "{flags:?}: {err}");
    }
    // At 32x18 the screen sizes object 0 at the least, 64 texels: one level;
    // at 256 texels per metre it has more.
    let level_1 = ["--pipeline", "objectspace", "--atlas-level", "1", "--texel-density", "256"];
    let (code, err) = run(&[&base[..], &level_1].concat());
    assert_eq!(code, 0, "{err}");
    assert!(out.is_file());
}

/// `render` prints the frame's GPU time and, for object space, how the frame
/// was shaded (tiles reused with `--reuse 2` after a frame of history); a flag
/// given again replaces the earlier value, as `scripts/render --pipeline
/// forward` needs.
#[test]
fn render_reports_object_space_shading_and_later_flags_win() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frame.png");
    let render = |flags: &[&str]| {
        let base = ["render", "--size", "48x27", "--out", out.to_str().unwrap(), "--pipeline", "objectspace"];
        let result = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(base).args(flags).output().unwrap();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(result.status.success(), "{flags:?}: {stderr}");
        String::from_utf8_lossy(&result.stdout).to_string()
    };
    let text = render(&["--reuse", "2", "--frame", "1", "--history", "1"]);
    assert!(text.starts_with("objectspace:"), "{text}");
    assert!(text.lines().any(|l| l.trim_start().starts_with("frame ") && l.ends_with(" ms GPU")), "{text}");
    assert!(text.contains(" visible texels per pixel, "), "{text}");
    let tiles = text.lines().find_map(|l| l.trim().strip_prefix("tiles: ")).expect("a tiles line");
    let count = |what: &str| -> u64 {
        let before = tiles.split(what).next().unwrap();
        before.rsplit([' ', ',']).find(|w| !w.is_empty()).unwrap().parse().unwrap()
    };
    assert!(count(" visible") > 0 && count(" reused") > 0, "{tiles}");
    assert_eq!(count(" visible"), count(" shaded") + count(" reused"), "{tiles}");
    let text = render(&["--pipeline", "forward", "--size", "32x18"]);
    assert!(text.starts_with("forward:") && text.contains(", 32x18,"), "{text}");
    assert!(!text.contains("texels per pixel"), "{text}");
}
