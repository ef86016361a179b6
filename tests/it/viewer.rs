//! The viewer in a virtual X server (Xvfb) on whatever Vulkan driver is
//! present (lavapipe in CI): a scripted run's screenshot matches `render`
//! with the command its sidecar names, the panel is drawn when shown, and
//! many pipeline and option switches neither crash nor grow host memory.
//! Without Xvfb these tests print `skipped: Xvfb not installed` and pass;
//! the headless viewer's (`--headless`, no display at all) runs anyway.
#![cfg(feature = "viewer")]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Instant;

use shadespace::metrics;

/// Mean FLIP error allowed between the viewer's frame and `render`'s.
const VIEWER_FLIP: f32 = 0.02;
/// Pipeline and option switches of the switching test (18 per script
/// round, 5 of them renderer builds): seven rounds, the fewest that leave
/// two rounds of warm-up and a last third of three rounds after a gap;
/// `SHADESPACE_VIEWER_SWITCHES=1000` runs more by hand.
const SWITCHES: u32 = 7 * SWITCHES_PER_ROUND;
/// Setting changes per round of the switching script.
const SWITCHES_PER_ROUND: u32 = 18;
/// Host memory the switching run's floor may rise: the lowest RSS of its
/// last third of rounds against the lowest of rounds 2 and 3 (by then every
/// kind of renderer was built twice: the driver's and the allocator's
/// caches are warm). Floors, because single rounds spike (by up to 130 MiB
/// on lavapipe) while the memory is given back.
const RSS_GROWTH_KIB: u64 = 64 * 1024;
/// Wide enough that the frame shows beside the panel (about 330 pixels).
const SIZE: &str = "480x240";

/// A private X server, stopped on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM, so that it removes its socket and lock file (killed, it
        // leaves them behind).
        let terminated = Command::new("kill").arg(self.child.id().to_string()).status();
        if !terminated.is_ok_and(|s| s.success()) {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on a free display, or says why the test is skipped. With
/// `-displayfd` Xvfb picks the display itself and writes its number once it
/// accepts connections: waiting for a display's socket file instead was
/// fooled by stale files of servers killed earlier on the same machine.
fn xvfb() -> Option<Xvfb> {
    let found = std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join("Xvfb").is_file()));
    if !found {
        eprintln!("skipped: Xvfb not installed");
        return None;
    }
    let mut child = Command::new("Xvfb")
        .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start Xvfb");
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("piped")).read_line(&mut line).expect("read Xvfb's display");
    let number: u32 = line.trim().parse().unwrap_or_else(|_| panic!("Xvfb did not start (it wrote {line:?})"));
    Some(Xvfb { child, display: format!(":{number}") })
}

/// Runs `shadespace ARGS` on `display` (none: with no display in its
/// environment); panics with its output unless it exits 0.
fn shadespace(display: Option<&str>, args: &[&str]) -> String {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shadespace"));
    cmd.args(args);
    match display {
        Some(d) => cmd.env("DISPLAY", d),
        None => cmd.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY"),
    };
    // lavapipe's window-system code needs a runtime folder.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        cmd.env("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let out = cmd.output().expect("run shadespace");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "shadespace {args:?} failed ({}):\n{stdout}\n{stderr}", out.status);
    stdout.into_owned()
}

fn load(path: &Path) -> image::RgbaImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
}

/// The `render` command a screenshot's sidecar names, run with `--out`.
fn render_like(shot: &Path, out: &Path) {
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(shot.with_extension("json")).unwrap()).unwrap();
    let command = sidecar["render_command"].as_str().expect("sidecar has render_command");
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(words[..2], ["shadespace", "render"], "{command}");
    assert!(!command.contains('\''), "the test splits on spaces only: {command}");
    let mut args = words[1..].to_vec();
    args.extend(["--out", out.to_str().unwrap()]);
    shadespace(None, &args);
}

/// A scripted view in a window on `display` (none: headless): switches to
/// the environment `env` (the panel's control; `None` keeps the command
/// line's), moves and turns away from the path's first camera, then a
/// screenshot without the panel and one with it.
fn check_screenshot_matches_render(display: Option<&str>, pipeline: &str, env: Option<&str>) {
    let dir = tempfile::tempdir().unwrap();
    let (hidden, shown) = (dir.path().join("hidden.png"), dir.path().join("shown.png"));
    let env_step = env.map_or(serde_json::json!({"frames": 0}), |e| serde_json::json!({ "env": e }));
    let script = serde_json::json!({ "steps": [
        env_step,
        {"frames": 2},
        {"move": [0.4, 0.2, 1.0]},
        {"turn": [12.0, -4.0]},
        {"frames": 2},
        {"ui": false},
        {"screenshot": hidden},
        {"ui": true},
        {"frames": 2},
        {"screenshot": shown},
    ]});
    let script_path = dir.path().join("script.json");
    std::fs::write(&script_path, script.to_string()).unwrap();
    let report_path = dir.path().join("report.json");
    let mut args = vec!["view", "--scene", "atrium", "--pipeline", pipeline, "--size", SIZE];
    args.extend(["--script", script_path.to_str().unwrap(), "--report", report_path.to_str().unwrap()]);
    args.extend(if display.is_some() { ["--vsync", "off"].as_slice() } else { ["--headless"].as_slice() });
    let stdout = shadespace(display, &args);
    assert!(stdout.contains("GPU medians of the last"), "{stdout}");
    // The per-pass medians `scripts/viewer-vs-bench` sets beside bench's.
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report_path).unwrap()).unwrap();
    let passes = report["gpu_pass_ms"].as_array().unwrap_or_else(|| panic!("report has gpu_pass_ms: {report}"));
    assert!(passes.len() >= 2, "{pipeline}: too few passes timed: {report}");
    assert!(passes.iter().all(|p| p[1].as_f64().is_some_and(|ms| ms >= 0.0)), "{report}");
    assert!(passes.iter().any(|p| p[1].as_f64().is_some_and(|ms| ms > 0.0)), "{report}");
    let reference = dir.path().join("render.png");
    render_like(&hidden, &reference);
    let (viewer, render, with_ui) = (load(&hidden), load(&reference), load(&shown));
    let (err, map) = metrics::compare(&render, &viewer);
    eprintln!("{pipeline}: viewer against render: FLIP mean {:.5}, PSNR {:.2} dB", err.flip_mean, err.psnr_db);
    if err.flip_mean > VIEWER_FLIP {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer");
        std::fs::create_dir_all(&out).unwrap();
        for (name, path) in [("viewer.png", &hidden), ("render.png", &reference), ("ui.png", &shown)] {
            std::fs::copy(path, out.join(format!("{pipeline}-{name}"))).unwrap();
        }
        map.save(out.join(format!("{pipeline}-flip.png"))).unwrap();
        panic!("{pipeline}: the viewer's frame differs from render's: FLIP {} > {VIEWER_FLIP}", err.flip_mean);
    }
    // The panel sits on the left: there the shown UI must change the image.
    assert_eq!(with_ui.dimensions(), viewer.dimensions());
    let panel_width = viewer.width() / 3;
    let changed = (0..viewer.height())
        .flat_map(|y| (0..panel_width).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let (a, b) = (viewer.get_pixel(x, y).0, with_ui.get_pixel(x, y).0);
            a.iter().zip(b).any(|(a, b)| a.abs_diff(b) > 24)
        })
        .count();
    let share = changed as f64 / (panel_width * viewer.height()) as f64;
    eprintln!("{pipeline}: the panel changed {:.1}% of the left third", share * 100.0);
    assert!(share > 0.2, "the panel is not drawn: only {:.1}% of the left third changed", share * 100.0);
    // Beside the panel the window shows the frame itself, pixel for pixel
    // (the window has the image's size): egui must neither decode nor
    // encode its sRGB values again.
    let beside = (viewer.width() - 16..viewer.width()).flat_map(|x| (0..viewer.height()).map(move |y| (x, y)));
    let (sum, n) = beside.fold((0u64, 0u64), |(sum, n), (x, y)| {
        let (a, b) = (render.get_pixel(x, y).0, with_ui.get_pixel(x, y).0);
        (sum + (0..3).map(|c| a[c].abs_diff(b[c]) as u64).sum::<u64>(), n + 3)
    });
    let mean = sum as f64 / n as f64;
    eprintln!("{pipeline}: beside the panel, the window differs from render by {mean:.2} on average (8-bit)");
    assert!(mean < 2.0, "{pipeline}: the window shows the frame {mean:.2} off (8-bit mean) beside the panel");
}

#[test]
fn viewer_screenshot_matches_render_forward() {
    let Some(x) = xvfb() else { return };
    check_screenshot_matches_render(Some(&x.display), "forward", None);
}

#[test]
fn viewer_screenshot_matches_render_objectspace() {
    let Some(x) = xvfb() else { return };
    check_screenshot_matches_render(Some(&x.display), "objectspace", None);
}

/// `--headless` with nothing to end the run is refused before any work,
/// with status 2 and the reason.
#[test]
fn headless_without_frames_or_script_is_refused() {
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["view", "--scene", "atrium", "--headless"])
        .env_remove("DISPLAY")
        .output()
        .expect("run shadespace");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--headless needs --frames or --script"), "{stderr}");
}

/// With no display at all: the same frames, the panel painted offscreen,
/// and the per-pass GPU medians reported as in a window; the environment
/// switched to the sky from the script (the panel's control): the frame
/// matches `render --env sky`, which the sidecar's command asks for.
#[test]
fn headless_viewer_screenshot_matches_render() {
    check_screenshot_matches_render(None, "deferred-compute", Some("sky"));
}

#[test]
fn switching_pipelines_and_options_keeps_memory_flat() {
    let Some(x) = xvfb() else { return };
    let switches: u32 =
        std::env::var("SHADESPACE_VIEWER_SWITCHES").ok().and_then(|v| v.parse().ok()).unwrap_or(SWITCHES);
    let dir = tempfile::tempdir().unwrap();
    // Every pipeline, object space with other options (the atlas budget
    // sizes its atlas), lights, seeds, exposure.
    let rounds = switches.div_ceil(SWITCHES_PER_ROUND);
    let script = serde_json::json!({ "repeat": rounds, "steps": [
        {"pipeline": "deferred"}, {"lights": "small:64"}, {"frames": 1},
        {"pipeline": "objectspace"}, {"tile_size": 16}, {"view": "tile-mask"}, {"variable_rate": 1.0},
        {"atlas_budget": 2}, {"frames": 1},
        {"pipeline": "clustered"}, {"seed": 2}, {"frames": 1},
        {"pipeline": "deferred-compute"}, {"lights": "small:32"}, {"tile_size": 8}, {"view": "shade"},
        {"variable_rate": 0.0}, {"atlas_budget": null}, {"frames": 1},
        {"pipeline": "forward"}, {"seed": 1}, {"exposure": 1.25}, {"frames": 1},
    ]});
    let (script_path, report_path) = (dir.path().join("switch.json"), dir.path().join("report.json"));
    std::fs::write(&script_path, script.to_string()).unwrap();
    // The atrium: on lavapipe the voxels' 404 objects cost object space about
    // 6 s of triangle maps and shading per build (56 s of CPU for the test
    // against 12). Leaking each replaced renderer (`mem::forget`) still
    // raises the floor by 485 MiB here, against the 64 MiB bound.
    let started = Instant::now();
    let stdout = shadespace(
        Some(&x.display),
        &[
            "view",
            "--scene",
            "atrium",
            "--size",
            "160x120",
            "--vsync",
            "off",
            "--hide-ui",
            "--script",
            script_path.to_str().unwrap(),
            "--report",
            report_path.to_str().unwrap(),
        ],
    );
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report_path).unwrap()).unwrap();
    let kib = |k: &str| report[k].as_u64().unwrap_or_else(|| panic!("report has {k}: {report}"));
    let (first, end) = (kib("rss_kib_first_frame"), kib("rss_kib_end"));
    let rounds_rss: Vec<u64> =
        report["rss_kib_rounds"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect();
    assert_eq!(rounds_rss.len(), rounds as usize, "{report}");
    assert!(rounds_rss.len() >= 6, "too few rounds to tell warm-up from growth: {rounds_rss:?}");
    let warm = *rounds_rss[1..3].iter().min().unwrap();
    let late = *rounds_rss[rounds_rss.len() * 2 / 3..].iter().min().unwrap();
    eprintln!(
        "{} renderer builds in {:.0} s; RSS {} KiB at the start, {first} KiB after the first frame, {warm} KiB lowest of \
         rounds 2-3, {late} KiB lowest of the last third, {end} KiB at the end; per round {rounds_rss:?}\n{stdout}",
        kib("renderer_builds"),
        started.elapsed().as_secs_f64(),
        kib("rss_kib_start"),
    );
    assert_eq!(kib("renderer_builds"), 1 + 5 * rounds as u64, "{report}");
    assert!(
        late.saturating_sub(warm) < RSS_GROWTH_KIB,
        "host memory's floor rose {} KiB over {switches} switches (bound {RSS_GROWTH_KIB} KiB)",
        late.saturating_sub(warm)
    );
}
