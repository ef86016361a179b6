//! The examples (`examples/`) as a program that embeds the library would
//! use them: `render_frame` renders a model at 160x90 on the test's adapter,
//! and its image is the one `shadespace render` draws with the same scene
//! and size (both light the model with the studio set and expose it
//! automatically). `cargo test` also builds every example.
//!
//! The example's code is compiled into this binary from its file rather than
//! run as `cargo run --example`: cargo holds the build folder's lock while
//! tests run, so building from a test would wait forever.

use std::path::Path;
use std::process::Command;

use shadespace::metrics;

#[allow(dead_code)] // Its `main` reads the process's arguments; the test calls `render_frame`.
#[path = "../../examples/render_frame.rs"]
mod render_frame;

/// Most mean FLIP between the example's image and the command line's: the
/// same frame, drawn by the same code, with the same lights and exposure.
const MAX_FLIP: f32 = 0.01;

#[test]
fn render_frame_draws_what_the_command_line_draws() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus/spot.obj");
    let scene = scene.to_str().unwrap();
    let (example, cli) = (dir.path().join("example.png"), dir.path().join("cli.png"));
    let args = [scene, "forward", example.to_str().unwrap(), "160x90"].map(String::from);
    render_frame::render_frame(&args).unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_shadespace"))
        .args(["render", "--scene", scene, "--size", "160x90", "--out"])
        .arg(&cli)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));

    let (example, cli) = (image::open(&example).unwrap().to_rgba8(), image::open(&cli).unwrap().to_rgba8());
    example.save(crate::common::out_dir().join("example-render_frame.png")).unwrap();
    let lit = example.pixels().filter(|p| p[0].max(p[1]).max(p[2]) > 20).count() as f32;
    assert!(lit > 0.1 * (160 * 90) as f32, "the model is hardly there: {lit} lit pixels");
    let flip = metrics::compare(&cli, &example).0.flip_mean;
    eprintln!("render_frame against shadespace render: FLIP {flip:.4}");
    assert!(flip <= MAX_FLIP, "the example's image is off the command line's: FLIP {flip:.4}");

    let bad = ["x.obj", "no-such-pipeline"].map(String::from);
    let err = render_frame::render_frame(&bad).unwrap_err().to_string();
    assert!(err.contains("no pipeline 'no-such-pipeline'"), "{err}");
}
