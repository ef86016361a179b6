//! The studies in quick mode: each runs on the procedural atrium (and the
//! tile studies on the shared Sponza where `../shared/scenes` is present),
//! and its outputs are read back and checked: CSV columns and invariants of
//! the measures, JSON keys, valid PNG and SVG plots, a report naming the
//! command and commit. Timings are never asserted, only their presence.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use indicatif::ProgressBar;
use serde_json::Value;
use shadespace::experiments::census::{Census, StudyScene};
use shadespace::experiments::marking::{Marking, Variant};
use shadespace::experiments::report::GIT_COMMIT;
use shadespace::experiments::study_path::StudyCameras;
use shadespace::experiments::timing::Shading;
use shadespace::experiments::visibility::VisibilityRenderer;
use shadespace::experiments::{self, ExperimentName, ExperimentOptions, Grid, overlap, reuse};
use shadespace::materials::MaterialsSpec;

const SPONZA: &str = "../shared/scenes/sponza-thesis";

fn chart_cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("charts")
}

/// The options of a quick run of `name` on `scene` into `out`.
fn quick_options(name: ExperimentName, scene: &str, out: &Path) -> ExperimentOptions {
    ExperimentOptions {
        name,
        scene: scene.into(),
        exclude: Vec::new(),
        markings: Marking::ALL.to_vec(),
        grid: Grid::quick(),
        timing: name.timing_grid(true),
        quick: true,
        texel_density: 256.0,
        out: out.to_path_buf(),
        command: format!("shadespace experiment {} --quick --scene {scene}", name.name()),
        chart_cache: Some(chart_cache()),
        shard: None,
        materials: MaterialsSpec::None,
    }
}

/// Runs `name` in quick mode on `scene` into a fresh folder; returns the folder.
fn run_quick(name: ExperimentName, scene: &str, exclude: &[&str]) -> (tempfile::TempDir, Value) {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().unwrap();
    let options = ExperimentOptions {
        exclude: exclude.iter().map(|s| s.to_string()).collect(),
        ..quick_options(name, scene, dir.path())
    };
    experiments::run(&ctx, &options, &ProgressBar::hidden()).unwrap();
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap()).unwrap();
    check_common(dir.path(), &options, &summary);
    (dir, summary)
}

/// The checks every experiment's outputs pass.
fn check_common(dir: &Path, options: &ExperimentOptions, summary: &Value) {
    for key in ["experiment", "scene", "quick", "provenance", "grid", "visibility", "setup", "results"] {
        assert!(summary.get(key).is_some(), "summary.json lacks '{key}': {summary:#}");
    }
    assert_eq!(summary["experiment"], options.name.name());
    for key in ["adapter", "driver", "date", "commit", "command"] {
        assert!(summary["provenance"][key].as_str().is_some_and(|s| !s.is_empty()), "provenance.{key}");
    }
    if !options.name.is_timing() {
        assert_eq!(summary["variants"].as_array().unwrap().len(), 3);
    }
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains(&options.command), "the report does not state the command");
    assert!(report.contains(GIT_COMMIT) && GIT_COMMIT.len() >= 40, "the report does not state the commit");
    assert!(report.contains("Differences from the study"));
    // Every figure the report embeds exists as a whole SVG, with a valid PNG beside it.
    let figures: Vec<&str> = report.split("](").skip(1).filter_map(|s| s.split(')').next()).collect();
    let svgs: Vec<&&str> = figures.iter().filter(|f| f.ends_with(".svg")).collect();
    assert!(!svgs.is_empty(), "no figure in the report");
    assert!(!figures.iter().any(|f| f.ends_with(".png")), "the report links PNGs, which docs/ does not hold");
    for svg_path in svgs {
        let svg = std::fs::read_to_string(dir.join(svg_path)).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{svg_path}: SVG is not a whole document"
        );
        let png = Path::new(svg_path).with_extension("png");
        let image = image::open(dir.join(&png)).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert!(image.width() > 100 && image.height() > 100);
    }
}

/// `data.csv` as column name -> values, checking the header.
fn read_csv(dir: &Path, columns: &[&str]) -> Vec<BTreeMap<String, String>> {
    let mut r = csv::Reader::from_path(dir.join("data.csv")).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(header, columns, "data.csv columns");
    r.records().map(|rec| header.iter().cloned().zip(rec.unwrap().iter().map(String::from)).collect()).collect()
}

fn num(row: &BTreeMap<String, String>, key: &str) -> f64 {
    row[key].parse().unwrap_or_else(|_| panic!("{key} = '{}' is not a number", row[key]))
}

#[test]
fn overshading_quick() {
    let (dir, summary) = run_quick(ExperimentName::Overshading, "atrium", &[]);
    let rows = read_csv(
        dir.path(),
        &["frame", "width", "height", "tile_size", "marking", "texture", "tiles", "pixels", "ratio"],
    );
    let grid = Grid::quick();
    let spaces = 3 * grid.tile_sizes.len();
    assert_eq!(rows.len(), grid.path_frames.len() * grid.resolutions.len() * spaces);
    let mut by_key = BTreeMap::new();
    for r in &rows {
        let (tiles, t, pixels) = (num(r, "tiles"), num(r, "tile_size"), num(r, "pixels"));
        assert_eq!(pixels, num(r, "width") * num(r, "height"));
        assert!((num(r, "ratio") - tiles * t * t / pixels).abs() < 1e-9, "{r:?}");
        assert!(tiles > 0.0, "the atrium's path sees surfaces in every frame: {r:?}");
        by_key.insert(
            (r["frame"].clone(), r["width"].clone(), r["marking"].clone(), r["texture"].clone(), t as u32),
            num(r, "ratio"),
        );
    }
    // Our marking at 4096 (levels down to 128 at every tile size): every
    // 8-texel tile needed lies in a needed 32-texel tile, so the larger tiles
    // cover at least as many texels.
    for ((frame, width, marking, texture, t), ratio) in &by_key {
        if *t == 8 && marking == "bilinear" && texture == "4096" {
            let coarse = by_key[&(frame.clone(), width.clone(), marking.clone(), texture.clone(), 32)];
            assert!(coarse >= *ratio, "frame {frame} at width {width}: tiles of 32 {coarse} < tiles of 8 {ratio}");
        }
    }
    let cells = summary["results"]["cells"].as_array().unwrap();
    assert_eq!(cells.len(), spaces * grid.resolutions.len());
    for c in cells {
        let s = &c["ratio"];
        for key in ["median", "std", "mean", "p10", "p90"] {
            assert!(s[key].as_f64().is_some(), "cell lacks {key}: {c}");
        }
        assert!(s["p10"].as_f64() <= s["median"].as_f64() && s["median"].as_f64() <= s["p90"].as_f64(), "{c}");
        assert_eq!(s["samples"], grid.path_frames.len());
    }
}

#[test]
fn overlap_quick() {
    let (dir, summary) = run_quick(ExperimentName::Overlap, "atrium", &[]);
    let rows = read_csv(
        dir.path(),
        &[
            "width",
            "height",
            "tile_size",
            "marking",
            "texture",
            "camera_a",
            "camera_b",
            "tiles_a",
            "tiles_b",
            "tiles_both",
            "tiles_either",
            "overlap",
            "iou",
        ],
    );
    let grid = Grid::quick();
    assert_eq!(rows.len(), 25 * 3 * grid.tile_sizes.len() * grid.resolutions.len());
    for r in &rows {
        let (a, b, both) = (num(r, "tiles_a"), num(r, "tiles_b"), num(r, "tiles_both"));
        assert!(a > 0.0, "every fixed atrium camera sees surfaces: {r:?}");
        assert!((num(r, "overlap") - both / a).abs() < 1e-9);
        if r["camera_a"] == r["camera_b"] {
            // A camera with itself: everything overlaps.
            assert_eq!((num(r, "overlap"), num(r, "iou"), b), (1.0, 1.0, a), "{r:?}");
        } else {
            assert!(both <= a.min(b) && num(r, "iou") < 1.0, "{r:?}");
        }
    }
    for c in summary["results"]["cells"].as_array().unwrap() {
        let shared = &c["shared_atlas"];
        let (union, sum) = (shared["union"].as_u64().unwrap(), shared["sum"].as_u64().unwrap());
        let largest = c["tiles"].as_array().unwrap().iter().map(|t| t.as_u64().unwrap()).max().unwrap();
        assert!(largest <= union && union <= sum, "{c}");
        let saving = shared["saving"].as_f64().unwrap();
        assert!((0.0..1.0).contains(&saving), "{c}");
        // The IoU matrix is symmetric.
        let iou = c["iou"].as_array().unwrap();
        for (a, row) in iou.iter().enumerate() {
            for (b, v) in row.as_array().unwrap().iter().enumerate() {
                assert_eq!(v, &iou[b][a], "iou[{a}][{b}]");
            }
        }
    }
}

#[test]
fn reuse_quick() {
    let (dir, summary) = run_quick(ExperimentName::Reuse, "atrium", &[]);
    let rows = read_csv(
        dir.path(),
        &[
            "frame",
            "width",
            "height",
            "tile_size",
            "marking",
            "texture",
            "previous_tiles",
            "tiles",
            "kept",
            "reusable",
            "new",
            "windows",
        ],
    );
    let grid = Grid::quick();
    // Each quick window of 4 frames gives 3 pairs.
    assert_eq!(rows.len(), 3 * 3 * 3 * grid.tile_sizes.len() * grid.resolutions.len());
    for r in &rows {
        let (reusable, new) = (num(r, "reusable"), num(r, "new"));
        assert!((0.0..=1.0).contains(&reusable) && (0.0..=1.0).contains(&new), "{r:?}");
        assert!((reusable - num(r, "kept") / num(r, "previous_tiles")).abs() < 1e-9);
        assert!((new - (num(r, "tiles") - num(r, "kept")) / num(r, "tiles")).abs() < 1e-9);
        assert_eq!(r["windows"].split(' ').count(), 1, "quick windows do not overlap: {r:?}");
    }
    // The orbit moves a little each frame: most tiles stay.
    let cells = summary["results"]["cells"].as_array().unwrap();
    let windows: Vec<&str> = cells.iter().map(|c| c["window"].as_str().unwrap()).collect();
    for w in ["all", "100-103", "300-303", "500-503"] {
        assert!(windows.contains(&w), "no cell for window {w}");
    }
    for c in cells.iter().filter(|c| c["window"] == "all") {
        assert!(c["reusable"]["median"].as_f64().unwrap() > 0.5, "{c}");
    }
}

#[test]
fn a_static_camera_reuses_every_tile_and_overlaps_itself() {
    let ctx = common::gpu();
    let scene = StudyScene::load("atrium", &[], 256.0, &shadespace::charts::ChartCache::in_dir(chart_cache())).unwrap();
    let cameras = StudyCameras::for_scene("atrium", &scene.render, 200.0 / 150.0).unwrap();
    let census = Census::new(&scene, &Variant::for_markings(&Marking::ALL), &[8, 64]).unwrap();
    let mut renderer = VisibilityRenderer::new(&ctx, &scene.render, &[(200, 150)]).unwrap();
    let camera = cameras.path_camera(42);
    let first = census.tiles(&renderer.render(&ctx, &camera, 0).unwrap());
    let second = census.tiles(&renderer.render(&ctx, &camera, 0).unwrap());
    for (a, b) in first.iter().zip(&second) {
        assert!(a.count() > 0);
        assert_eq!(reuse::shares(a, b), (Some(1.0), Some(0.0)));
        assert_eq!(overlap::pair_overlap(a, b), (Some(1.0), Some(1.0)));
    }
    // A different frame shares some tiles, not all.
    let moved = census.tiles(&renderer.render(&ctx, &cameras.path_camera(142), 0).unwrap());
    let (reusable, new) = reuse::shares(&first[0], &moved[0]);
    assert!(reusable.unwrap() < 1.0 && new.unwrap() > 0.0, "{reusable:?} {new:?}");
}

#[test]
fn sponza_quick_without_its_plants() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let (_dir, summary) = run_quick(ExperimentName::Overshading, SPONZA, &["sponza_plantsA", "sponza_plantsB"]);
    let objects: Vec<&str> =
        summary["setup"]["objects"].as_array().unwrap().iter().map(|o| o["name"].as_str().unwrap()).collect();
    assert!(!objects.contains(&"sponza_plantsA") && !objects.contains(&"sponza_plantsB"), "{objects:?}");
    assert!(objects.contains(&"sponza_floor") || objects.len() >= 10, "{objects:?}");
    for c in summary["results"]["cells"].as_array().unwrap() {
        assert!(c["ratio"]["median"].as_f64().unwrap() > 0.0, "{c}");
    }
}

/// The columns every timing study's `data.csv` starts with.
const TIMING_COLUMNS: [&str; 13] = [
    "shading",
    "scenario",
    "lights",
    "lights_spec",
    "status",
    "frames",
    "median_ms",
    "p95_ms",
    "mean_ms",
    "fps",
    "cpu_ms",
    "wall_s",
    "note",
];

/// Checks a measured timing row: a positive median with fps its inverse, the
/// measured frames, and a light spec holding the count.
fn check_measured(r: &BTreeMap<String, String>, frames: u32) {
    assert_eq!(r["status"], "measured", "{r:?}");
    assert_eq!(num(r, "frames"), f64::from(frames), "{r:?}");
    let median = num(r, "median_ms");
    assert!(median > 0.0 && num(r, "p95_ms") >= median, "{r:?}");
    assert!((num(r, "fps") * median - 1000.0).abs() < 1e-6, "{r:?}");
    let count = num(r, "lights") as u64;
    let spec: shadespace::scene::LightSpec = r["lights_spec"].parse().unwrap();
    assert_eq!(spec.generated_count(), Some(count), "{r:?}");
}

#[test]
fn lights_quick() {
    let (dir, summary) = run_quick(ExperimentName::Lights, "atrium", &[]);
    let rows = read_csv(dir.path(), &TIMING_COLUMNS);
    let grid = ExperimentName::Lights.timing_grid(true).unwrap();
    assert_eq!(rows.len(), Shading::pipelines().len() * grid.points());
    for r in &rows {
        check_measured(r, grid.frames);
    }
    let labels: Vec<&str> = rows.iter().map(|r| r["shading"].as_str()).collect();
    for s in Shading::pipelines() {
        assert!(labels.contains(&s.label().as_str()), "no row of {}", s.label());
    }
    assert!(rows.iter().any(|r| r["lights_spec"] == "shadowed:3+small:13"), "mixed 1:5 at 16 lights");
    let per_light = summary["results"]["per_light"].as_array().unwrap();
    assert_eq!(per_light.len(), Shading::pipelines().len() * grid.sweeps.len());
    for p in per_light {
        let fit = &p["study_range"];
        for key in ["slope", "intercept", "r2", "points"] {
            assert!(fit[key].is_number(), "per-light fit lacks {key}: {p}");
        }
        assert_eq!(fit["points"], grid.sweeps[0].counts.len());
    }
    assert_eq!(summary["grid"]["frames"], grid.frames);
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(report.contains("## Cost per light") && report.contains("## Frame time: mixed-1:5"), "{report}");
}

#[test]
fn speedup_quick() {
    let (dir, summary) = run_quick(ExperimentName::Speedup, "atrium", &[]);
    let mut columns = TIMING_COLUMNS.to_vec();
    columns.extend(["flip_mean", "psnr_db", "ssim"]);
    let rows = read_csv(dir.path(), &columns);
    let grid = ExperimentName::Speedup.timing_grid(true).unwrap();
    assert_eq!(rows.len(), grid.shadings.len() * grid.points());
    assert_eq!(grid.shadings[0], Shading::Forward, "forward runs first: it is the reference");
    for r in &rows {
        check_measured(r, grid.frames);
        if r["shading"] == "forward" {
            assert!(r["flip_mean"].is_empty() && r["ssim"].is_empty(), "forward is the reference: {r:?}");
        } else {
            let (flip, ssim) = (num(r, "flip_mean"), num(r, "ssim"));
            assert!((0.0..=1.0).contains(&flip) && (-1.0..=1.0).contains(&ssim), "{r:?}");
            assert!(num(r, "psnr_db") > 10.0, "{r:?}");
        }
    }
    let results = &summary["results"];
    // The fastest conventional pipeline at each point is the minimum of the five.
    let fastest = results["fastest"].as_array().unwrap();
    assert_eq!(fastest.len(), grid.points());
    for f in fastest {
        let at = |r: &&BTreeMap<String, String>| r["scenario"] == f["scenario"] && num(r, "lights") == f["lights"];
        let conventional = rows.iter().filter(at).filter(|r| !r["shading"].starts_with("objectspace"));
        let min = conventional.map(|r| num(r, "median_ms")).fold(f64::MAX, f64::min);
        assert!((f["median_ms"].as_f64().unwrap() - min).abs() <= 1e-9 * min, "{f}");
    }
    // Overhead at 0 and 1 light in both sweeps, for every object-space configuration.
    let object_space = grid.shadings.iter().filter(|s| matches!(s, Shading::ObjectSpace { .. })).count();
    assert!(object_space >= 3, "quick keeps reuse and variable rate: {:?}", grid.shadings);
    assert_eq!(results["overhead"].as_array().unwrap().len(), object_space * 2 * 2);
    for q in results["quality"].as_array().unwrap() {
        assert!(q["flip_mean"]["median"].is_number() && q["ssim"]["median"].is_number(), "{q}");
    }
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    for heading in ["## Fixed overhead", "## Image error against forward", "## Frame time and speed-up: shadowed"] {
        assert!(report.contains(heading), "no '{heading}' in the report");
    }
}

/// A cap below every frame time measures the first count of each
/// configuration and records the larger ones as skipped; the command line's
/// grid options reach the run.
#[test]
fn timing_points_above_the_cap_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lights");
    let out = out.to_str().unwrap();
    let args = ["experiment", "lights", "--quick", "--scenarios", "small", "--counts", "2,1", "--cap-ms", "0.0001"];
    let (code, err) = run_cli(&[&args[..], &["--size", "64x36", "--frames", "1", "--quiet", "--out", out]].concat());
    assert_eq!(code, 0, "{err}");
    let rows = read_csv(Path::new(out), &TIMING_COLUMNS);
    assert_eq!(rows.len(), 2 * Shading::pipelines().len());
    for r in &rows {
        if r["lights"] == "1" {
            check_measured(r, 1);
        } else {
            assert_eq!((r["status"].as_str(), r["median_ms"].as_str(), r["frames"].as_str()), ("skipped", "", "0"));
            assert!(r["note"].contains("above the 0.0001 ms cap"), "{r:?}");
        }
    }
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("lights/summary.json")).unwrap()).unwrap();
    assert_eq!((summary["grid"]["width"].as_u64(), summary["grid"]["height"].as_u64()), (Some(64), Some(36)));
    assert_eq!(summary["results"]["skipped"], Shading::pipelines().len());
}

fn run_cli(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shadespace")).args(args).output().expect("run shadespace");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "panic on {args:?}:\n{stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

#[test]
fn bad_experiment_input_names_the_flag_or_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    let (code, err) = run_cli(&["experiment", "overlap", "--scene", "no/such/scene", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("no/such/scene"), "{err}");
    let (code, err) = run_cli(&["experiment", "overlap", "--quick", "--exclude", "no_such_object", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--exclude") && err.contains("no_such_object") && err.contains("floor"), "{err}");
    let (code, err) = run_cli(&["experiment", "overlap", "--tile-sizes", "8,12"]);
    assert_eq!(code, 2);
    assert!(err.contains("--tile-sizes") && err.contains("12"), "{err}");
    let (code, err) = run_cli(&["experiment", "overlap", "--marking", "nearest"]);
    assert_eq!(code, 2);
    assert!(err.contains("--marking") && err.contains("nearest"), "{err}");
    let file = dir.path().join("file");
    std::fs::write(&file, "x").unwrap();
    let (code, err) = run_cli(&["experiment", "reuse", "--out", file.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("--out") && err.contains("not a folder"), "{err}");
    let (code, err) = run_cli(&["experiment", "lights", "--scenarios", "huge"]);
    assert_eq!(code, 2);
    assert!(err.contains("--scenarios") && err.contains("huge"), "{err}");
    let (code, err) = run_cli(&["experiment", "speedup", "--cap-ms", "0"]);
    assert_eq!(code, 2);
    assert!(err.contains("--cap-ms"), "{err}");
    let (code, _) = run_cli(&["experiment", "speed"]);
    assert_eq!(code, 2);
    let (code, err) = run_cli(&["experiment", "quality", "--shard", "3/2"]);
    assert_eq!(code, 2);
    assert!(err.contains("--shard") && err.contains("3/2"), "{err}");
    let (code, err) = run_cli(&["experiment", "quality", "--quick", "--frames", "1", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--frames 1"), "{err}");
    let (code, err) = run_cli(&["experiment", "quality", "--quick", "--configs", "objectspace,deferred", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--configs") && err.contains("'deferred'") && err.contains("objectspace-hz30"), "{err}");
    let (code, err) = run_cli(&["experiment", "layers", "--layers", "17"]);
    assert_eq!(code, 2);
    assert!(err.contains("--layers") && err.contains("'17'"), "{err}");
    let (code, err) = run_cli(&["experiment", "lights", "--quick", "--layers", "2", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--layers") && err.contains("only the layers experiment"), "{err}");
    let (code, err) = run_cli(&["experiment", "layers", "--quick", "--materials", "layered:2", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--materials") && err.contains("layers"), "{err}");
    let (code, err) = run_cli(&["experiment", "lights", "--quick", "--materials", "no/such.json", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("no/such.json"), "{err}");
    let (code, err) = run_cli(&["experiment", "quality", "--quick", "--textures", "file", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--textures") && err.contains("'file'") && err.contains("detailed"), "{err}");
    let (code, err) = run_cli(&["experiment", "speedup", "--quick", "--breakdown", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--breakdown") && err.contains("only the quality experiment"), "{err}");
    let (code, err) = run_cli(&["experiment", "lights", "--quick", "--shard", "1/2", "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("--shard") && err.contains("lights"), "{err}");
    let (code, err) = run_cli(&["experiment", "merge"]);
    assert_eq!(code, 2);
    assert!(err.contains("merge"), "{err}");
    let (code, err) = run_cli(&["experiment", "merge", dir.path().to_str().unwrap(), "--out", out]);
    assert_eq!(code, 2);
    assert!(err.contains("summary.json"), "{err}");
}

/// `layers` quick: every configuration at each layer count and one of
/// object space's trade-offs (named as `--configs` names it), errors
/// against the reference, forward and the fastest conventional pipeline,
/// the speed-up table (without the trade-off) and the trade-off sections.
#[test]
fn layers_quick() {
    let start = std::time::Instant::now();
    let ctx = common::gpu();
    let dir = tempfile::tempdir().unwrap();
    let mut grid = ExperimentName::Layers.timing_grid(true).unwrap();
    let configs = experiments::layers::configs(&grid);
    let mut labels: Vec<String> = configs.iter().map(|c| c.label()).collect();
    labels.push("objectspace-hz30-bias1".into());
    grid.configs = labels.clone();
    let options =
        ExperimentOptions { timing: Some(grid), ..quick_options(ExperimentName::Layers, "atrium", dir.path()) };
    experiments::run(&ctx, &options, &ProgressBar::hidden()).unwrap();
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("summary.json")).unwrap()).unwrap();
    check_common(dir.path(), &options, &summary);
    eprintln!("layers quick: {:.1} s", start.elapsed().as_secs_f64());
    let ks = experiments::layers::layer_counts(true);
    let csv = std::fs::read_to_string(dir.path().join("data.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + ks.len() * labels.len(), "{csv}");
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for line in csv.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        let flip_reference: f64 = cells[column("flip_reference")].parse().unwrap();
        assert!(flip_reference > 0.0 && flip_reference < 0.2, "{line}");
        // Every row but the fastest conventional one's is judged against it.
        let against_fastest = cells[column("flip_fastest_conventional")];
        assert!(against_fastest.is_empty() == (cells[column("config")] == "deferred-compute"), "{line}");
    }
    assert_eq!(summary["layers"], serde_json::json!(ks));
    let speedups = summary["results"]["speedups"].as_array().unwrap();
    assert_eq!(speedups.len(), ks.len());
    assert!(speedups.iter().all(|s| s["object_space"] != "objectspace-hz30-bias1"), "the grid's own configurations");
    let trade = summary["results"]["trade_offs"].as_array().unwrap();
    assert_eq!(trade.len(), ks.len(), "a trade-off section per layer count");
    assert!(trade.iter().all(|t| t["fastest_conventional"] == "deferred-compute"), "{trade:?}");
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(report.contains("Where object space wins"), "{report}");
    assert!(report.contains("Object space's options at 4 layers: small:1"), "{report}");
    assert!(dir.path().join("layers-small-1.png").exists());
    assert!(dir.path().join("speedup.png").exists(), "the speed-up plot");
    assert!(dir.path().join("trade-offs-small-1-k4.png").exists(), "the cost-error plot");
}

/// The columns of `quality`'s `data.csv`.
const QUALITY_COLUMNS: [&str; 14] = [
    "cell",
    "textures",
    "gloss",
    "lights_spec",
    "msaa",
    "pipeline",
    "config",
    "frames",
    "median_ms",
    "p95_ms",
    "flip_mean",
    "psnr_db",
    "flicker_mean",
    "flicker_sum",
];

/// `quality` quick, run as two shards and merged (the way the H100 runs it):
/// the merged run holds every cell once, in order, and its results pass the
/// checks of a whole run; its last cell (object space at 30 Hz, 4 samples,
/// high gloss), measured alone as a shard of one cell, gives the row it gave
/// after the other cells, timings aside. With the unit test
/// `merged_shards_equal_the_whole_run` (merging gives a whole run's bytes),
/// this stands for comparing with an unsharded run, at a sixteenth of its
/// time.
#[test]
fn quality_quick() {
    let start = std::time::Instant::now();
    let ctx = common::gpu();
    let parts = tempfile::tempdir().unwrap();
    let grid = ExperimentName::Quality.timing_grid(true).unwrap();
    let cells = experiments::quality::cells(&grid, true);
    let mut shards = Vec::new();
    for index in 1..=2 {
        let out = parts.path().join(format!("shard{index}"));
        let options = ExperimentOptions {
            shard: Some(experiments::quality::Shard { index, count: 2 }),
            ..quick_options(ExperimentName::Quality, "atrium", &out)
        };
        experiments::run(&ctx, &options, &ProgressBar::hidden()).unwrap();
        let rows = read_csv(&out, &QUALITY_COLUMNS).len();
        assert!(rows > 0 && rows < cells.len(), "shard {index} measured {rows} of {} cells", cells.len());
        shards.push(out);
    }
    // The last cell alone: nothing a cell measures depends on the cells before it.
    let count = cells.len() as u32;
    let alone = parts.path().join("alone");
    let options = ExperimentOptions {
        shard: Some(experiments::quality::Shard { index: count, count }),
        ..quick_options(ExperimentName::Quality, "atrium", &alone)
    };
    experiments::run(&ctx, &options, &ProgressBar::hidden()).unwrap();
    let alone = read_csv(&alone, &QUALITY_COLUMNS);
    assert_eq!(alone.len(), 1);
    // The same cell with 4 layers a material (`--materials layered:4`): its
    // scene and reference are the layered ones, so its errors are others.
    let layered_dir = parts.path().join("layered");
    let options = ExperimentOptions {
        shard: Some(experiments::quality::Shard { index: count, count }),
        materials: MaterialsSpec::Layered(4),
        ..quick_options(ExperimentName::Quality, "atrium", &layered_dir)
    };
    experiments::run(&ctx, &options, &ProgressBar::hidden()).unwrap();
    let layered = read_csv(&layered_dir, &QUALITY_COLUMNS);
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(layered_dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["materials"], "layered:4");
    let report = std::fs::read_to_string(layered_dir.join("report.md")).unwrap();
    assert!(report.contains("`--materials layered:4`"), "the report does not say the materials");
    assert_eq!(layered[0]["config"], alone[0]["config"]);
    assert_ne!(layered[0]["flip_mean"], alone[0]["flip_mean"], "--materials layered:4 left the cell as it was");
    let dir = parts.path().join("merged");
    assert!(experiments::quality::merge(&shards[..1], &dir, "merge").is_err(), "one shard of two is not a run");
    let command = "shadespace experiment merge";
    experiments::quality::merge(&shards, &dir, command).unwrap();
    eprintln!("quality quick, two shards and merge: {:.1} s", start.elapsed().as_secs_f64());
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    let options =
        ExperimentOptions { command: command.into(), ..quick_options(ExperimentName::Quality, "atrium", &dir) };
    check_common(&dir, &options, &summary);
    assert_eq!(summary["grid"], serde_json::to_value(&grid).unwrap());

    let rows = read_csv(&dir, &QUALITY_COLUMNS);
    assert_eq!(rows.len(), cells.len());
    let order: Vec<String> = rows.iter().map(|r| r["cell"].clone()).collect();
    let expected: Vec<String> = (0..cells.len()).map(|i| i.to_string()).collect();
    assert_eq!(order, expected, "merged cells out of order or repeated");
    let timings_aside = |r: &BTreeMap<String, String>| {
        r.iter().filter(|(k, _)| !k.ends_with("_ms")).map(|(k, v)| (k.clone(), v.clone())).collect::<Vec<_>>()
    };
    assert_eq!(
        timings_aside(&alone[0]),
        timings_aside(rows.last().unwrap()),
        "a cell measured alone differs from the same cell after the others"
    );
    assert_eq!(alone[0]["config"], "objectspace-hz30");
    for r in &rows {
        assert_eq!(num(r, "frames"), f64::from(grid.frames), "{r:?}");
        assert!(num(r, "median_ms") > 0.0, "{r:?}");
        // Every pipeline is near the reference, none equal to it (one sample aliases).
        let flip = num(r, "flip_mean");
        assert!(flip > 0.0 && flip < 0.15, "{r:?}");
        assert!(num(r, "psnr_db") > 15.0, "{r:?}");
        let flicker = num(r, "flicker_mean");
        assert!(flicker >= 0.0 && (num(r, "flicker_sum") - flicker * f64::from(grid.frames - 1)).abs() < 1e-6, "{r:?}");
    }
    let row = |config: &str, gloss: &str, msaa: &str| {
        rows.iter().find(|r| r["config"] == config && r["gloss"] == gloss && r["msaa"] == msaa).unwrap()
    };
    // The gloss override reaches the pipelines: forward's error changes with it.
    assert_ne!(row("forward", "default", "1")["flip_mean"], row("forward", "high", "1")["flip_mean"]);
    // MSAA reaches the pipelines that have it: 4 samples are nearer the reference than one.
    for config in ["forward", "deferred-compute", "objectspace", "objectspace-hz30"] {
        for gloss in ["default", "high"] {
            let (one, four) = (num(row(config, gloss, "1"), "psnr_db"), num(row(config, gloss, "4"), "psnr_db"));
            eprintln!("quality quick, {config}, gloss {gloss}: PSNR {one:.2} dB at 1 sample, {four:.2} dB at 4");
            assert!(four > one, "{config}, gloss {gloss}: {four} dB at 4 samples against {one} dB at 1");
        }
    }
    for group in summary["results"]["pareto"].as_array().unwrap() {
        let front = group["front"].as_array().unwrap();
        assert!(!front.is_empty(), "{group}");
        // Cheapest first, each strictly less wrong than the one before.
        for pair in front.windows(2) {
            assert!(pair[0]["cost_ms"].as_f64() <= pair[1]["cost_ms"].as_f64(), "{group}");
            assert!(pair[0]["error"].as_f64() > pair[1]["error"].as_f64(), "{group}");
        }
    }
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("Cheapest configuration per error level"), "{report}");
}
