//! Each study of the sources as one named, reproducible experiment, writing
//! `data.csv`, `summary.json`, figures (PNG and SVG) and `report.md` into one
//! folder (`shadespace experiment NAME`).
//!
//! The tile studies (`overshading`, `overlap`, `reuse`) render the scene's
//! visibility buffer once per view and resolution with the renderer's own
//! visibility pass, read it back, and mark tiles on the CPU in every variant
//! ([`marking::Variant`]) and tile size at once ([`census::Census`]).
//!
//! The timing studies (`lights`, `speedup`) measure GPU frame times of
//! pipelines over light sets with `bench`'s run loop ([`timing::Bench`]);
//! `quality` also judges their images against supersampled references.

pub mod breakdown;
pub mod census;
pub mod layers;
pub mod lights;
pub mod marking;
pub mod overlap;
pub mod overshading;
pub mod plot;
pub mod quality;
pub mod report;
pub mod reuse;
pub mod scenarios;
pub mod speedup;
pub mod stats;
pub mod study_path;
pub mod tile_set;
pub mod timing;
pub mod visibility;

use std::path::{Path, PathBuf};

use indicatif::ProgressBar;
use serde::Serialize;

use crate::charts::ChartCache;
use crate::gpu::GpuContext;
use crate::materials::MaterialsSpec;
use crate::render::RenderError;
use crate::render::objectspace::atlas::AtlasError;
use crate::scene::Camera;
use crate::scene::lights::LightSetError;
use crate::scene::path::{SceneCameras, cameras_for_scene};
use census::{Census, StudyScene, StudySceneError};
use marking::{Marking, Variant};
use report::{Provenance, Section, Table};
use study_path::{PATH_FRAMES, StudyCameras};
use tile_set::TileSet;
use timing::TimingGrid;
use visibility::VisibilityRenderer;

/// The experiments (`shadespace experiment NAME`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExperimentName {
    /// Shaded texels per screen pixel along the camera path.
    Overshading,
    /// Tiles two of the five fixed cameras both need.
    Overlap,
    /// Tiles of the previous path frame still needed, and new ones.
    Reuse,
    /// Frame time of every pipeline against the light count, four scenarios.
    Lights,
    /// Object space's speed-up and image error against conventional shading.
    Speedup,
    /// Every pipeline's error and flicker against supersampled references, and its cost.
    Quality,
    /// Every pipeline's frame time and error as layered materials grow from 1 to 16 layers.
    Layers,
}

impl ExperimentName {
    pub fn name(self) -> &'static str {
        match self {
            Self::Overshading => "overshading",
            Self::Overlap => "overlap",
            Self::Reuse => "reuse",
            Self::Lights => "lights",
            Self::Speedup => "speedup",
            Self::Quality => "quality",
            Self::Layers => "layers",
        }
    }

    /// Whether it measures frame times (its grid is a [`TimingGrid`], its
    /// progress counts frames) rather than tiles (a [`Grid`], views).
    pub fn is_timing(self) -> bool {
        matches!(self, Self::Lights | Self::Speedup | Self::Quality | Self::Layers)
    }

    /// The timing grid of a timing study, full or quick; `None` for the tile studies.
    pub fn timing_grid(self, quick: bool) -> Option<TimingGrid> {
        match self {
            Self::Lights => Some(lights::grid(quick)),
            Self::Speedup => Some(speedup::grid(quick)),
            Self::Quality => Some(quality::grid(quick)),
            Self::Layers => Some(layers::grid(quick)),
            Self::Overshading | Self::Overlap | Self::Reuse => None,
        }
    }
}

/// What to measure: resolutions, tile sizes, frames.
#[derive(Clone, Debug, Serialize)]
pub struct Grid {
    pub resolutions: Vec<(u32, u32)>,
    pub tile_sizes: Vec<u32>,
    /// Path frames of `overshading`.
    pub path_frames: Vec<u32>,
    /// Windows of `reuse` (first and last frame, inclusive); `reuse` measures
    /// every frame of `path_frames` whose predecessor was measured too.
    pub reuse_windows: Vec<(u32, u32)>,
    /// Path frames of `reuse`.
    pub reuse_frames: Vec<u32>,
}

impl Grid {
    /// The study's grid: four resolutions from 800x600 to 3840x2160, tiles of
    /// 8 to 64, all 600 path frames, windows 100-120, 300-320, 500-520.
    pub fn full() -> Self {
        Self {
            resolutions: vec![(800, 600), (1024, 768), (1920, 1080), (3840, 2160)],
            tile_sizes: vec![8, 16, 32, 64],
            path_frames: (0..PATH_FRAMES).collect(),
            reuse_windows: vec![(100, 120), (300, 320), (500, 520)],
            reuse_frames: (0..PATH_FRAMES).collect(),
        }
    }

    /// Keeps every `step`-th path frame of `overshading` and, for `reuse`,
    /// every `step`-th frame with its predecessor (a pair) plus the whole
    /// windows.
    pub fn sample_frames(&mut self, step: u32) {
        let step = step.max(1) as usize;
        self.path_frames = (0..PATH_FRAMES).step_by(step).collect();
        let mut reuse: Vec<u32> = (1..PATH_FRAMES).step_by(step).flat_map(|f| [f - 1, f]).collect();
        reuse.extend(self.reuse_windows.iter().flat_map(|&(a, b)| a..=b));
        reuse.sort_unstable();
        reuse.dedup();
        self.reuse_frames = reuse;
    }

    /// A reduced grid for CI (well under a minute per experiment on a CPU
    /// driver): two small resolutions, tiles of 8 and 32, every 100th path
    /// frame, and the first 3 frame pairs of each reuse window.
    pub fn quick() -> Self {
        let reuse_windows = vec![(100, 103), (300, 303), (500, 503)];
        Self {
            resolutions: vec![(320, 240), (480, 270)],
            tile_sizes: vec![8, 32],
            path_frames: (0..PATH_FRAMES).step_by(100).collect(),
            reuse_frames: reuse_windows.iter().flat_map(|&(a, b)| a..=b).collect(),
            reuse_windows,
        }
    }
}

/// Everything an experiment run needs besides the GPU.
#[derive(Clone, Debug)]
pub struct ExperimentOptions {
    pub name: ExperimentName,
    /// `atrium`, `voxels`, or a path (as `render --scene`).
    pub scene: String,
    /// Objects left out (the study ran Sponza without its plants).
    pub exclude: Vec<String>,
    pub markings: Vec<Marking>,
    /// The tile studies' grid.
    pub grid: Grid,
    /// The timing studies' grid ([`ExperimentName::timing_grid`]); unused by the tile studies.
    pub timing: Option<TimingGrid>,
    pub quick: bool,
    /// Our texel density (texels per metre) for the density variant.
    pub texel_density: f32,
    pub out: PathBuf,
    /// The command line, for the report.
    pub command: String,
    /// Where generated charts are cached (`None`: `$SHADESPACE_CACHE_DIR` or the default).
    pub chart_cache: Option<PathBuf>,
    /// Measure only this part of the grid (`--shard K/N`; `quality` only).
    pub shard: Option<quality::Shard>,
    /// Layered materials for every scene the experiment renders
    /// (`--materials`, as `render --materials`; not `layers`, which sets
    /// its own).
    pub materials: MaterialsSpec,
}

/// Why an experiment failed.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    #[error(transparent)]
    Scene(#[from] StudySceneError),
    #[error("scene cameras: {0}")]
    Cameras(#[from] crate::scene::path::CameraFileError),
    #[error(transparent)]
    Atlas(#[from] AtlasError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("{path}: {message}")]
    Output { path: PathBuf, message: String },
    #[error(transparent)]
    Plot(#[from] plot::PlotError),
    #[error("light set: {0}")]
    Lights(#[from] LightSetError),
    #[error("{0} has no timestamp queries: the timing studies need GPU times")]
    NoTimestamps(String),
    #[error("experiment {0} needs a timing grid")]
    NoTimingGrid(&'static str),
    #[error("--shard: experiment {0} is not sharded (only quality is)")]
    NotSharded(&'static str),
    #[error("--frames {0}: quality needs at least 2 measured frames (flicker compares consecutive frames)")]
    TooFewFrames(u32),
    #[error("--materials: the {0} experiment sets every material's layers itself (layered:K)")]
    OwnMaterials(&'static str),
}

impl ExperimentError {
    /// Errors the user's input caused (a scene, an object name, an output
    /// folder), as opposed to failures of the GPU or the program.
    pub fn is_input(&self) -> bool {
        match self {
            Self::Scene(StudySceneError::Charts(_)) => false,
            Self::Scene(_)
            | Self::Cameras(_)
            | Self::Output { .. }
            | Self::Lights(_)
            | Self::NotSharded(_)
            | Self::TooFewFrames(_)
            | Self::OwnMaterials(_) => true,
            Self::Render(e) => e.is_bad_option(),
            Self::Atlas(_) | Self::Plot(_) | Self::NoTimestamps(_) | Self::NoTimingGrid(_) => false,
        }
    }

    fn output(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Output { path: path.to_path_buf(), message: e.to_string() }
    }
}

/// A run in progress: the prepared scene, its cameras, the marking spaces
/// and the visibility renderer.
pub struct Study<'a> {
    ctx: &'a GpuContext,
    pub scene: &'a StudyScene,
    pub cameras: StudyCameras,
    pub census: Census<'a>,
    renderer: VisibilityRenderer,
    pub grid: &'a Grid,
    pub output: Output<'a>,
    pub progress: &'a ProgressBar,
}

impl Study<'_> {
    /// The tiles `camera` needs at resolution `resolution` (an index into the
    /// grid's), one set per census space.
    pub fn tiles(&mut self, camera: &Camera, resolution: usize) -> Result<Vec<TileSet>, ExperimentError> {
        let image = self.renderer.render(self.ctx, camera, resolution)?;
        Ok(self.census.tiles(&image))
    }

    pub fn variants(&self) -> Vec<Variant> {
        let mut v: Vec<Variant> = self.census.spaces.iter().map(|s| s.variant).collect();
        v.dedup();
        v
    }
}

/// The output folder, where figures and `data.csv` are written as they are made.
#[derive(Clone, Copy)]
pub struct Output<'a> {
    pub dir: &'a Path,
}

impl Output<'_> {
    /// Writes a figure into the output folder as `stem.png` and `stem.svg`;
    /// returns the PNG's name for the report.
    pub fn figure(&self, stem: &str, figure: &impl plot::Figure) -> Result<PathBuf, ExperimentError> {
        figure.write(&self.dir.join(stem))?;
        Ok(PathBuf::from(format!("{stem}.png")))
    }

    /// Writes `data.csv`.
    pub fn write_rows<R: Serialize>(&self, rows: &[R]) -> Result<(), ExperimentError> {
        let path = self.dir.join("data.csv");
        report::write_csv(&path, rows).map_err(|e| ExperimentError::output(&path, e))
    }
}

/// What an experiment hands back: its results for `summary.json` and its
/// report sections.
pub struct Findings {
    pub results: serde_json::Value,
    pub sections: Vec<Section>,
}

/// The files a run wrote.
#[derive(Clone, Debug)]
pub struct Written {
    pub folder: PathBuf,
    pub report: PathBuf,
    /// One line of headline figures.
    pub headline: String,
}

/// What one kind of study hands back to [`run`].
struct Outcome {
    /// The keys of `summary.json` particular to the kind (its grid, its method).
    summary: serde_json::Value,
    /// The setup and the differences from the study's method.
    sections: Vec<Section>,
    findings: Findings,
}

/// Runs an experiment and writes its outputs into `options.out`.
pub fn run(ctx: &GpuContext, options: &ExperimentOptions, progress: &ProgressBar) -> Result<Written, ExperimentError> {
    if options.shard.is_some() && options.name != ExperimentName::Quality {
        return Err(ExperimentError::NotSharded(options.name.name()));
    }
    if let (ExperimentName::Quality, Some(grid)) = (options.name, &options.timing)
        && grid.frames < 2
    {
        return Err(ExperimentError::TooFewFrames(grid.frames));
    }
    let out = options.out.as_path();
    std::fs::create_dir_all(out).map_err(|e| ExperimentError::output(out, format!("cannot create the folder: {e}")))?;
    let provenance = Provenance::new(ctx, &options.command);
    progress.set_message(format!("{}: preparing {}", options.name.name(), options.scene));
    let cache = options.chart_cache.as_ref().map_or_else(ChartCache::from_env, ChartCache::in_dir);
    if options.name == ExperimentName::Layers && options.materials != MaterialsSpec::None {
        return Err(ExperimentError::OwnMaterials(options.name.name()));
    }
    let mut scene = StudyScene::load(&options.scene, &options.exclude, options.texel_density, &cache)?;
    scene.apply_materials(&options.materials)?;
    let output = Output { dir: out };
    let outcome = match options.name {
        ExperimentName::Overshading => tile_study(ctx, options, &scene, output, progress, overshading::run)?,
        ExperimentName::Overlap => tile_study(ctx, options, &scene, output, progress, overlap::run)?,
        ExperimentName::Reuse => tile_study(ctx, options, &scene, output, progress, reuse::run)?,
        ExperimentName::Lights => {
            timing_study(ctx, options, &scene, (output, progress), lights::run, lights::differences)?
        }
        ExperimentName::Speedup => {
            timing_study(ctx, options, &scene, (output, progress), speedup::run, speedup::differences)?
        }
        ExperimentName::Quality => quality::study(ctx, options, &scene, output, progress)?,
        ExperimentName::Layers => layers::study(ctx, options, &scene, output, progress)?,
    };
    let findings = outcome.findings;
    let headline = findings.results.get("headline").and_then(|h| h.as_str()).unwrap_or_default().to_string();

    let mut summary = serde_json::json!({
        "experiment": options.name,
        "scene": scene.name,
        "scene_spec": options.scene,
        "materials": options.materials.to_string(),
        "quick": options.quick,
        "provenance": provenance,
        "setup": {
            "excluded": scene.excluded,
            "texel_density": scene.texel_density,
            "objects": scene.objects,
        },
        "results": findings.results,
    });
    if let (Some(all), serde_json::Value::Object(own)) = (summary.as_object_mut(), outcome.summary) {
        all.extend(own);
    }
    let summary_path = out.join("summary.json");
    let text = serde_json::to_string_pretty(&summary).expect("the summary serializes");
    std::fs::write(&summary_path, text).map_err(|e| ExperimentError::output(&summary_path, e))?;

    let mut sections = outcome.sections;
    if options.materials != MaterialsSpec::None {
        let text = format!(
            "Every scene rendered (references too, where the experiment has them) with `--materials {}`: each material's layers lit \
             one by one with every light in every pipeline (`shadespace::layers`).\n",
            options.materials
        );
        sections.insert(0, Section { heading: "Materials".into(), text, tables: Vec::new(), figures: Vec::new() });
    }
    sections.extend(findings.sections);
    let title = format!("Experiment `{}`: {}", options.name.name(), scene.name);
    let report_path = out.join("report.md");
    std::fs::write(&report_path, report::markdown(&title, &provenance, &sections))
        .map_err(|e| ExperimentError::output(&report_path, e))?;
    Ok(Written { folder: out.to_path_buf(), report: report_path, headline })
}

/// `overshading`, `overlap`, `reuse`: tiles marked from read-back visibility buffers.
fn tile_study(
    ctx: &GpuContext,
    options: &ExperimentOptions,
    scene: &StudyScene,
    output: Output,
    progress: &ProgressBar,
    study_run: fn(&mut Study) -> Result<Findings, ExperimentError>,
) -> Result<Outcome, ExperimentError> {
    // Framing (for scenes without a camera path) fits the first resolution's aspect.
    let aspect = options.grid.resolutions.first().map_or(4.0 / 3.0, |&(w, h)| w as f32 / h as f32);
    let cameras = StudyCameras::for_scene(&options.scene, &scene.render, aspect)?;
    let variants = Variant::for_markings(&options.markings);
    let census = Census::new(scene, &variants, &options.grid.tile_sizes)?;
    let renderer = VisibilityRenderer::new(ctx, &scene.render, &options.grid.resolutions)?;
    let method = renderer.method;
    let mut study = Study { ctx, scene, cameras, census, renderer, grid: &options.grid, output, progress };
    progress.set_message(format!("{} {}", options.name.name(), scene.name));
    let findings = study_run(&mut study)?;
    Ok(Outcome {
        summary: serde_json::json!({
            "grid": options.grid,
            "markings": options.markings,
            "variants": variants,
            "visibility": method.name(),
            "camera_source": study.cameras.source,
        }),
        sections: vec![setup_section(options, &study, method.name()), differences_section(scene, &variants)],
        findings,
    })
}

/// `lights`, `speedup`: GPU frame times over light sets; `own` lists the
/// study's own differences from its source's method for a grid.
fn timing_study(
    ctx: &GpuContext,
    options: &ExperimentOptions,
    scene: &StudyScene,
    (output, progress): (Output, &ProgressBar),
    study_run: fn(&timing::Bench, Output) -> Result<Findings, ExperimentError>,
    own: fn(&TimingGrid) -> Vec<String>,
) -> Result<Outcome, ExperimentError> {
    let grid = options.timing.as_ref().ok_or(ExperimentError::NoTimingGrid(options.name.name()))?;
    let cameras: SceneCameras =
        cameras_for_scene(&options.scene, &scene.render, grid.width as f32 / grid.height as f32)?;
    let bench = timing::Bench::new(ctx, scene, &cameras, grid, progress);
    progress.set_length(grid.total_frames());
    let findings = study_run(&bench, output)?;
    let mut items = timing::differences();
    items.extend(own(grid));
    let source = cameras.source.to_string();
    Ok(Outcome {
        summary: serde_json::json!({
            "grid": grid,
            "visibility": bench.visibility().name(),
            "camera_source": source,
        }),
        sections: vec![
            timing::setup_section(grid, scene, &source, bench.visibility(), options.quick),
            differences(&items),
        ],
        findings,
    })
}

fn setup_section(options: &ExperimentOptions, study: &Study, visibility: &str) -> Section {
    let scene = study.scene;
    let g = &options.grid;
    let res: Vec<String> = g.resolutions.iter().map(|(w, h)| format!("{w}x{h}")).collect();
    let mut text = format!(
        "Scene `{}` ({} objects counted{}), cameras from {}, the study's projection (60° vertical field of view, \
         near 0.3, far 1000). Resolutions {}; tile sizes {:?}; {}. Visibility pass: {visibility}. {}\n\n\
         Variants: the study's marking at 4096 for every object (`study`, `4096`), ours at the same textures \
         (`bilinear`, `4096`: the renderer's `mark.wgsl` rule, levels down to 128), and ours as the renderer \
         shades by default (`bilinear`, `density`: {} texels per metre, virtual textures, no halving).\n",
        options.scene,
        scene.render.objects.len(),
        if scene.excluded.is_empty() { String::new() } else { format!("; left out: {}", scene.excluded.join(", ")) },
        study.cameras.source,
        res.join(", "),
        g.tile_sizes,
        if options.quick { "quick mode (a reduced grid)" } else { "the study's full grid" },
        if options.markings.len() < 2 {
            format!("Markings: {}.", options.markings.iter().map(|m| m.name()).collect::<Vec<_>>().join(", "))
        } else {
            String::new()
        },
        scene.texel_density,
    );
    text += "\nPer object: the UV layout the 4096 variants mark through, our chart, our texture side.\n";
    let mut t = Table::new(&["object", "4096 variants' UVs", "our chart", "our texture"]);
    for o in &scene.objects {
        let overlap = o.file_uv_overlap.map_or(String::new(), |f| format!(" ({:.2}% overlap)", 100.0 * f));
        let size = o.density_size.map_or("forward".to_string(), |s| s.to_string());
        t.rows.push(vec![o.name.clone(), format!("{}{overlap}", o.study_uvs), o.our_chart.clone(), size]);
    }
    Section { heading: "Setup".into(), text, tables: vec![(String::new(), t)], figures: Vec::new() }
}

/// Where these figures differ from what the study's method would give, and why.
fn differences_section(scene: &StudyScene, variants: &[Variant]) -> Section {
    let mut items = vec![
        "Derivatives: each pixel's chart-UV derivatives come from its triangle's plane one pixel to the right and \
         one down (the CPU twin of our marking pass), not from the 2x2 quad differences of a fragment shader; \
         they agree inside a triangle and differ at triangle edges, where quad differences mix neighbours."
            .to_string(),
        "Visibility: our visibility pass decides which triangle a pixel sees; the study's Unity pass may resolve \
         depth ties and thin geometry differently."
            .to_string(),
    ];
    if variants.iter().any(|v| v.marking == Marking::Bilinear) {
        items.push(
            "Marking: `bilinear` is our rule (level = round(log2(texture size x the longer derivative vector)), \
             the 2x2 bilinear footprint, which may cross into neighbouring tiles, and levels down to 128 texels), \
             so it marks more tiles than the study's one tile per pixel at the floored level of the largest \
             derivative component."
                .to_string(),
        );
    }
    let overlapping: Vec<&str> =
        scene.objects.iter().filter(|o| o.file_uv_overlap.is_some()).map(|o| o.name.as_str()).collect();
    if !overlapping.is_empty() {
        items.push(format!(
            "UV layouts: the 4096 variants mark through the file's own layouts, as the study did, although our \
             check finds overlaps in {} (where two surfaces share a texel they share a tile and count once); the \
             density variant uses our generated charts for them.",
            overlapping.join(", ")
        ));
    }
    if !scene.excluded.is_empty() {
        items.push(format!("Objects left out (--exclude): {}.", scene.excluded.join(", ")));
    }
    let names: Vec<&str> = scene.render.objects.iter().map(|o| o.name.as_str()).collect();
    if names.iter().any(|n| n.starts_with("sponza_")) && !names.contains(&"sponza_detailsA") {
        items.push(
            "Missing object: the study's Sponza had `sponza_detailsA`, which the shared copy lacks: its surfaces \
             are not counted and what they hid is visible here."
                .to_string(),
        );
    }
    if scene.name.contains("lost-empire") {
        items.push(
            "Lost Empire: the shared copy lacks `grass.obj` and `stone1.obj`; the ground's top faces are missing, so \
             fewer tiles are needed and the views see through the holes."
                .to_string(),
        );
    }
    differences(&items)
}

/// The report section listing where our figures differ from what the
/// study's method would give, and why.
fn differences(items: &[String]) -> Section {
    let text = items.iter().map(|i| format!("- {i}\n")).collect();
    Section { heading: "Differences from the study's method".into(), text, ..Default::default() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sampling keeps every 10th frame for overshading and, for reuse, pairs
    /// of consecutive frames every 10 frames plus the whole windows.
    #[test]
    fn sampled_frames_keep_pairs_and_windows() {
        let mut grid = Grid::full();
        grid.sample_frames(10);
        assert_eq!(grid.path_frames.len(), 60);
        assert_eq!(grid.path_frames[..3], [0, 10, 20]);
        let has = |f: u32| grid.reuse_frames.binary_search(&f).is_ok();
        for f in (1..PATH_FRAMES).step_by(10) {
            assert!(has(f - 1) && has(f), "pair ({}, {f}) missing", f - 1);
        }
        for &(a, b) in &grid.reuse_windows {
            assert!((a..=b).all(has), "window {a}-{b} incomplete");
        }
        assert!(!has(5), "frame 5 is neither sampled nor in a window");
    }
}
