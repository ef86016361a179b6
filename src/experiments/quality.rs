//! Experiment `quality`: every pipeline (and object space's options: reuse,
//! decoupled shading rate, variable rate, mip bias) judged against the
//! supersampled reference (`crate::reference`) along the camera path, with
//! the scene's materials and with `--gloss high`: GPU frame time, each
//! frame's error against its reference (FLIP, PSNR), and flicker (the
//! pipeline's frame-to-frame change against the reference's,
//! `metrics::temporal`). The report plots error against cost, one curve per
//! pipeline and the Pareto front, and names the cheapest configuration for
//! each error level.
//!
//! The grid is a list of independent cells (textures x gloss x light set x
//! samples per pixel x configuration), each measured on its own renderer, so
//! that shards of a sweep can be measured apart and merged. The sample count
//! (MSAA) is an axis with 1 only until the pipelines have MSAA.

use std::collections::BTreeMap;

use image::RgbaImage;
use serde::{Deserialize, Serialize};

use super::breakdown::{self, BreakdownRow, PathSums};
use super::census::StudyScene;
use super::plot::{LinePlot, Series};
use super::report::{Section, Table, f3};
use super::scenarios::Scenario;
use super::timing::{Shading, Sweep, TimingGrid};
use super::{ExperimentError, ExperimentOptions, Findings, Outcome, Output, differences};
use crate::gpu::GpuContext;
use crate::metrics::temporal::{path_quality, path_quality_by};
use crate::reference::{ReferenceCache, ReferenceSettings, ReferenceView, References};
use crate::render::objectspace::GatherFilter;
use crate::render::objectspace::debug::PixelClass;
use crate::render::{Exposure, PipelineConfig, RenderOptions, Renderer, VisibilityMethod};
use crate::scene::gloss::{self, Gloss};
use crate::scene::lights::build_lights;
use crate::scene::path::{CameraPath, cameras_for_scene};
use crate::scene::{Light, Scene};

/// Samples per axis of the reference (16 per pixel: 4x4 differs from 8x8
/// far less than any pipeline differs from either on Sponza; README).
pub const REFERENCE_SAMPLES: u32 = 4;

/// The timing side of the grid (size, frames, light sets, the pipelines):
/// every pipeline, object space with reuse 2 and variable rate 1; the
/// quality axes are in [`axes`]. Full: 1920x1080, 30 shadowed lights, 4
/// warm-up and 30 measured consecutive path frames, MSAA 1, 4 and 8 samples
/// per pixel. Quick: forward, deferred-compute and object space only, 96x54,
/// 8 small lights, 1 + 3 frames, MSAA 1 and 4.
pub fn grid(quick: bool) -> TimingGrid {
    let mut shadings = Shading::pipelines();
    shadings.push(Shading::ObjectSpace { reuse: 2, variable_rate: 0.0 });
    shadings.push(Shading::ObjectSpace { reuse: 1, variable_rate: 1.0 });
    if quick {
        // Each cell builds a renderer (shaders compiled by the CPU driver):
        // forward, the compute-lit baseline and object space keep CI short.
        shadings = vec![Shading::Forward, Shading::DeferredCompute, Shading::OBJECT_SPACE];
    }
    let (sweep, grid) = if quick {
        let sweep = Sweep { scenario: Scenario::Small, counts: vec![8] };
        let quick = TimingGrid {
            width: 96,
            height: 54,
            warmup: 1,
            frames: 3,
            msaa: vec![1, 4],
            ..TimingGrid::new(true, vec![], vec![])
        };
        (sweep, quick)
    } else {
        let sweep = Sweep { scenario: Scenario::Shadowed, counts: vec![30] };
        (sweep, TimingGrid { warmup: 4, frames: 30, msaa: vec![1, 4, 8], ..TimingGrid::new(false, vec![], vec![]) })
    };
    TimingGrid { shadings, sweeps: vec![sweep], ..grid }
}

/// A configuration: a pipeline and, for object space, the options beyond
/// reuse and variable rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub shading: Shading,
    /// Object space: re-shade each tile on its own phase frame (`--shade-hz`).
    pub spread: bool,
    /// Object space: `--mip-bias`.
    pub mip_bias: f32,
    /// Object space: `--level-blend`.
    pub level_blend: f32,
    /// Object space: `--os-filter`.
    pub filter: GatherFilter,
    /// Anisotropic filtering's most taps (1: isotropic): object space's
    /// gather (`--os-aniso`), or for a conventional pipeline its material
    /// textures' sampler (`--aniso`, [`Renderer::texture_anisotropy`]).
    pub aniso: u32,
}

impl Config {
    pub(super) fn plain(shading: Shading) -> Self {
        Self { shading, spread: false, mip_bias: 0.0, level_blend: 0.0, filter: GatherFilter::Bilinear, aniso: 1 }
    }

    /// `objectspace-hz30` (shading at 30 Hz of 60, spread), `objectspace-bias1`,
    /// `objectspace-blend1` (level blend 1: trilinear), `objectspace-bspline`
    /// (the B-spline gather), `objectspace-aniso8` (`--os-aniso 8`),
    /// `deferred-compute-aniso16` (`--aniso 16`), ...
    pub fn label(&self) -> String {
        match self.shading {
            Shading::ObjectSpace { reuse, variable_rate } if self.spread => {
                let mut label = format!("objectspace-hz{}", 60 / reuse.max(1));
                if variable_rate != 0.0 {
                    label += &format!("-vr{variable_rate}");
                }
                label
            }
            s => s.label(),
        }
        .to_string()
            + &if self.mip_bias != 0.0 { format!("-bias{}", self.mip_bias) } else { String::new() }
            + &if self.level_blend != 0.0 { format!("-blend{}", self.level_blend) } else { String::new() }
            + match self.filter {
                GatherFilter::Bilinear => "",
                GatherFilter::Bspline => "-bspline",
                GatherFilter::Mitchell => "-mitchell",
            }
            + &if self.aniso > 1 { format!("-aniso{}", self.aniso) } else { String::new() }
    }

    /// The pipeline's name (a curve of the cost-error plot).
    pub fn pipeline(&self) -> &'static str {
        self.shading.config(&[], VisibilityMethod::Raster).name()
    }

    pub(super) fn render_config(&self, texture_sizes: &[Option<u32>], visibility: VisibilityMethod) -> PipelineConfig {
        let mut config = self.shading.config(texture_sizes, visibility);
        if let PipelineConfig::ObjectSpace(os) = &mut config {
            os.spread_reshading = self.spread;
            os.mip_bias = self.mip_bias;
            os.level_blend = self.level_blend;
            os.gather_filter = self.filter;
            os.aniso = self.aniso;
        }
        config
    }
}

/// The quality axes: textures, material setting, samples per pixel.
#[derive(Clone, Debug, Serialize)]
pub struct Axes {
    /// `file` (the scene's textures) and/or `detailed` (`--textures detailed`).
    pub textures: Vec<&'static str>,
    pub gloss: Vec<Gloss>,
    /// MSAA samples per pixel (the grid's [`TimingGrid::msaa`]).
    pub msaa: Vec<u32>,
    pub configs: Vec<String>,
}

/// The configurations of a grid: its shadings, then object space at 30 Hz
/// (reuse 2, spread over the frames) and, but in quick mode, with mip bias 1,
/// with level blend 1 (trilinear gathering), with the B-spline gather, with
/// both (the least flicker on lavapipe: BENCHMARKS.md), with mip bias -1
/// (finer levels) alone and with level blend 1, and with anisotropic
/// gathering (`--os-aniso` 4 and 8, and 8 with level blend 1); and, but in
/// quick mode, every conventional pipeline with `--aniso 16`. A quick run
/// may name the others with `--configs` ([`chosen_configs`]).
pub fn configs(grid: &TimingGrid, quick: bool) -> Vec<Config> {
    let mut all: Vec<Config> = grid.shadings.iter().map(|&s| Config::plain(s)).collect();
    if grid.shadings.iter().any(|s| !s.is_conventional()) {
        all.push(Config { spread: true, ..Config::plain(Shading::ObjectSpace { reuse: 2, variable_rate: 0.0 }) });
        if !quick {
            all.push(Config { mip_bias: 1.0, ..Config::plain(Shading::OBJECT_SPACE) });
            all.push(Config { level_blend: 1.0, ..Config::plain(Shading::OBJECT_SPACE) });
            let bspline = Config { filter: GatherFilter::Bspline, ..Config::plain(Shading::OBJECT_SPACE) };
            all.push(bspline);
            all.push(Config { level_blend: 1.0, ..bspline });
            // Finer levels (4x the texels): what it costs to bring object
            // space's flicker down to forward's (issue 24), alone and with
            // level blending.
            let finer = Config { mip_bias: -1.0, ..Config::plain(Shading::OBJECT_SPACE) };
            all.push(finer);
            all.push(Config { level_blend: 1.0, ..finer });
            // Anisotropic gathering: the level follows the footprint's
            // shorter axis, against the blur and crawl of grazing surfaces
            // (pixels of level 3 and coarser carry a third of object space's
            // extra error, BENCHMARKS.md).
            for aniso in [4, 8] {
                all.push(Config { aniso, ..Config::plain(Shading::OBJECT_SPACE) });
            }
            all.push(Config { level_blend: 1.0, aniso: 8, ..Config::plain(Shading::OBJECT_SPACE) });
            // Both: where the anisotropic gather alone leaves one sample per
            // pixel a few thousandths over forward's flicker (the file
            // textures), what finer levels add to close it, and cost.
            all.push(Config { aniso: 4, ..finer });
        }
    }
    if !quick {
        // The conventional pipelines with anisotropic texture filtering, as
        // engines ship them: the fair match for object space's
        // anisotropic gather.
        let conventional = grid.shadings.iter().filter(|s| s.is_conventional());
        all.extend(conventional.map(|&s| Config { aniso: CONVENTIONAL_ANISO, ..Config::plain(s) }));
    }
    all
}

/// The sampler anisotropy of the conventional pipelines' `-aniso` cells
/// (`--aniso 16`, the most hardware offers).
pub const CONVENTIONAL_ANISO: u32 = 16;

/// Object space's options that trade error for time on top of 30 Hz
/// shading: variable rate 1 and 2, mip bias 0.5 and 1 (about half and a
/// quarter of the texels), variable rate 1 with bias 0.5 and 1. Measured
/// only where `--configs` names them, here for their flicker and by the
/// layers experiment against the fastest conventional pipeline
/// (`layers::trade_offs`).
pub fn trade_offs() -> Vec<Config> {
    [(1.0, 0.0), (2.0, 0.0), (0.0, 0.5), (1.0, 0.5), (0.0, 1.0), (1.0, 1.0)]
        .into_iter()
        .map(|(variable_rate, mip_bias)| Config {
            spread: true,
            mip_bias,
            ..Config::plain(Shading::ObjectSpace { reuse: 2, variable_rate })
        })
        .collect()
}

/// Every configuration `--configs` may name: [`configs`] (in quick mode the
/// full grid's), then the [`trade_offs`] where the grid measures object space.
pub fn nameable_configs(grid: &TimingGrid) -> Vec<Config> {
    let mut all = configs(grid, false);
    if grid.shadings.iter().any(|s| !s.is_conventional()) {
        all.extend(trade_offs());
    }
    all
}

/// The configurations a run measures: [`configs`], or those the grid's
/// `configs` names where it names any ([`nameable_configs`]).
pub fn chosen_configs(grid: &TimingGrid, quick: bool) -> Vec<Config> {
    if grid.configs.is_empty() {
        return configs(grid, quick);
    }
    nameable_configs(grid).into_iter().filter(|c| grid.configs.contains(&c.label())).collect()
}

/// The texture settings of a grid (quick: the textured scene only), before `grid.textures` chooses.
pub fn texture_settings(quick: bool) -> Vec<&'static str> {
    if quick { vec!["detailed"] } else { vec!["file", "detailed"] }
}

/// The axes of a run: quick measures the textured scene only; the grid's
/// `configs` and `textures` keep only those they name.
pub fn axes(grid: &TimingGrid, quick: bool) -> Axes {
    let textures = texture_settings(quick)
        .into_iter()
        .filter(|t| grid.textures.is_empty() || grid.textures.iter().any(|g| g == t));
    Axes {
        textures: textures.collect(),
        gloss: vec![Gloss::Default, Gloss::High],
        msaa: grid.msaa.clone(),
        configs: chosen_configs(grid, quick).iter().map(Config::label).collect(),
    }
}

/// One cell of the grid: what one renderer measures along the path.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    pub textures: &'static str,
    pub gloss: Gloss,
    pub scenario: Scenario,
    pub lights: u32,
    pub msaa: u32,
    pub config: Config,
}

/// Every cell, in a fixed order (the order shards are cut from).
pub fn cells(grid: &TimingGrid, quick: bool) -> Vec<Cell> {
    let a = axes(grid, quick);
    let mut out = Vec::new();
    for &textures in &a.textures {
        for &gloss in &a.gloss {
            for sweep in &grid.sweeps {
                for &lights in &sweep.counts {
                    for &msaa in &a.msaa {
                        for config in chosen_configs(grid, quick) {
                            out.push(Cell { textures, gloss, scenario: sweep.scenario, lights, msaa, config });
                        }
                    }
                }
            }
        }
    }
    out
}

/// A row of `data.csv`: one cell measured along the path.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The cell's index in the grid's order ([`cells`]): shards are merged back in it.
    pub cell: usize,
    pub textures: String,
    pub gloss: String,
    pub lights_spec: String,
    pub msaa: u32,
    pub pipeline: String,
    pub config: String,
    pub frames: u32,
    /// GPU frame time over the measured frames (none without timestamps).
    pub median_ms: Option<f64>,
    pub p95_ms: Option<f64>,
    /// Mean over the frames of each frame's FLIP against its reference.
    pub flip_mean: f64,
    /// Mean over the frames of each frame's PSNR (dB).
    pub psnr_db: f64,
    /// Mean over the frame pairs of |change - reference change| (8-bit steps).
    pub flicker_mean: f64,
    pub flicker_sum: f64,
}

/// One scene variant: textures and gloss applied to the scene as drawn and as charted.
struct Variant {
    render: Scene,
    charted: Scene,
}

impl Variant {
    fn new(scene: &StudyScene, textures: &str, g: Gloss) -> Self {
        let prepare = |s: &Scene| {
            let mut s = s.clone();
            if textures == "detailed" {
                crate::scene::detail::add_detailed_textures(&mut s);
            }
            gloss::apply(&mut s, g);
            s
        };
        Self { render: prepare(&scene.render), charted: prepare(scene.charted()) }
    }
}

/// What [`measure`] hands back: a row per cell and, with the grid's
/// `breakdown`, each cell's rows of the error breakdown.
pub struct Measured {
    pub rows: Vec<Row>,
    pub breakdown: Vec<BreakdownRow>,
}

/// Cells of one textures, gloss, light set and sample count share their
/// references and, in the breakdown, the plain object-space run's pixel classes.
type CellKey = (&'static str, &'static str, String, u32);

/// Measures `cells` (a whole grid or a shard of it) and returns their rows.
pub fn measure(
    ctx: &GpuContext,
    options: &ExperimentOptions,
    scene: &StudyScene,
    grid: &TimingGrid,
    cells: &[(usize, Cell)],
    progress: &indicatif::ProgressBar,
) -> Result<Measured, ExperimentError> {
    let aspect = grid.width as f32 / grid.height as f32;
    let cameras = cameras_for_scene(&options.scene, &scene.render, aspect)?;
    let region = cameras.light_region(&scene.render.bounds());
    let path = &cameras.path;
    let features = ctx.device.features();
    let cache = options
        .chart_cache
        .as_ref()
        .map_or_else(ReferenceCache::from_env, |d| ReferenceCache::in_dir(d.join("references")));
    let first = grid.first_frame;
    let measured: Vec<u32> = (first + grid.warmup..first + grid.warmup + grid.frames).collect();
    let mut rows = Vec::new();
    let mut breakdown_rows = Vec::new();
    // Cells sharing a scene variant and light set share its references.
    let mut variants: BTreeMap<(&str, &str), Variant> = BTreeMap::new();
    let mut reference_images: BTreeMap<(&str, &str, String), Vec<RgbaImage>> = BTreeMap::new();
    // The breakdown: the plain object-space run's classes per measured frame,
    // which the conventional pipelines of its key are split by. Its cells go
    // first, so that a shard holding one runs it once.
    let plain = Config::plain(Shading::OBJECT_SPACE);
    let mut classes: BTreeMap<CellKey, Vec<Vec<PixelClass>>> = BTreeMap::new();
    let mut order: Vec<&(usize, Cell)> = cells.iter().collect();
    if grid.breakdown {
        order.sort_by_key(|(_, c)| c.config != plain);
    }
    for (index, cell) in order {
        let variant = variants
            .entry((cell.textures, cell.gloss.name()))
            .or_insert_with(|| Variant::new(scene, cell.textures, cell.gloss));
        let spec = cell.scenario.spec(cell.lights);
        let lights: Vec<Light> = build_lights(&spec, &region, &path.camera_at(0), aspect, grid.seed)?;
        let key = (cell.textures, cell.gloss.name(), spec.to_string());
        if !reference_images.contains_key(&key) {
            progress.set_message(format!("reference {} {} {spec}", cell.textures, cell.gloss.name()));
            let settings = ReferenceSettings {
                width: grid.width,
                height: grid.height,
                shading: Default::default(),
                sun_shadow: false,
                exposure: Exposure::default(),
            };
            let mut references = References::new(ctx, &variant.render, settings, cache.clone());
            let mut images = Vec::new();
            for &f in &measured {
                let camera = path.camera_at(f);
                let view = ReferenceView { camera: &camera, lights: &lights, samples: REFERENCE_SAMPLES };
                images.push(references.get(&view).map_err(reference_error)?.0.image());
            }
            reference_images.insert(key.clone(), images);
        }
        let label = cell.config.label();
        progress.set_message(format!("{label} {} {} {spec}", cell.textures, cell.gloss.name()));
        // As `--visibility auto` picks it.
        let visibility = VisibilityMethod::preferred_for(features, cell.msaa);
        let render_options = |config: &Config| {
            // Gloss and detail change materials, not geometry: the study scene's texture sizes hold.
            let mut pipeline = config.render_config(&scene.density_sizes, visibility);
            if let (PipelineConfig::ObjectSpace(os), Some(mi)) = (&mut pipeline, grid.atlas_budget_mi) {
                os.atlas_budget_texels = Some(mi << 20);
            }
            RenderOptions { width: grid.width, height: grid.height, pipeline, samples: cell.msaa }
        };
        let conventional = cell.config.shading.is_conventional();
        let shaded = if conventional { &variant.render } else { &variant.charted };
        let mut renderer = Renderer::new(ctx, shaded, &render_options(&cell.config))?;
        renderer.timing = grid.timing;
        if conventional {
            renderer.texture_anisotropy = cell.config.aniso as u16;
        }
        let mut images = Vec::new();
        for i in 0..grid.warmup + grid.frames {
            renderer.render(ctx, &path.camera_at(first + i), &lights, u64::from(i))?;
            if i >= grid.warmup {
                images.push(renderer.read_image(ctx)?);
            }
            progress.inc(1);
        }
        let mut times: Vec<f64> = renderer
            .collect_timings(ctx, true)
            .into_iter()
            .filter(|t| t.frame >= u64::from(grid.warmup))
            .map(|t| t.total_ms)
            .collect();
        times.sort_by(f64::total_cmp);
        drop(renderer);
        // Object space's pixel classes come from a second run of the same
        // frames, untimed, so that the timed frames read nothing back (with
        // the read-backs between them, two cells' medians were 1.7x and 2.5x
        // their neighbours' on the H200).
        let mut own_classes = Vec::new();
        if grid.breakdown && !conventional {
            progress.set_message(format!("pixel classes {label} {} {} {spec}", cell.textures, cell.gloss.name()));
            own_classes = pixel_classes(ctx, shaded, &render_options(&cell.config), path, first, grid, &lights)?;
        }
        let class_key = (cell.textures, cell.gloss.name(), spec.to_string(), cell.msaa);
        let references = &reference_images[&key];
        let q = if grid.breakdown {
            if conventional && !classes.contains_key(&class_key) {
                progress.set_message(format!("pixel classes {} {} {spec}", cell.textures, cell.gloss.name()));
                let found = pixel_classes(ctx, &variant.charted, &render_options(&plain), path, first, grid, &lights)?;
                classes.insert(class_key.clone(), found);
            }
            if cell.config == plain {
                classes.insert(class_key.clone(), std::mem::take(&mut own_classes));
            }
            let frames_classes: &[Vec<PixelClass>] =
                if conventional || cell.config == plain { &classes[&class_key] } else { &own_classes };
            let classes_from = if conventional { plain.label() } else { "own".to_string() };
            let (q, per_frame) = path_quality_by(&images, references, |t, flip| {
                let labels = breakdown::labels(&frames_classes[t], &references[t]);
                let mut sums = PathSums::new();
                sums.add_frame(&labels, (&images, references), t, flip).map(|()| sums)
            });
            let mut sums = PathSums::new();
            for frame in per_frame {
                sums.merge(
                    &frame.map_err(|e| ExperimentError::Output {
                        path: "pixel classes".into(),
                        message: e.to_string(),
                    })?,
                );
            }
            breakdown_rows.extend(sums.rows(&breakdown::CellKey {
                cell: *index,
                textures: cell.textures,
                gloss: cell.gloss.name(),
                lights_spec: &spec.to_string(),
                msaa: cell.msaa,
                config: &label,
                classes_from: &classes_from,
            }));
            q
        } else {
            path_quality(&images, references)
        };
        rows.push(Row {
            cell: *index,
            textures: cell.textures.to_string(),
            gloss: cell.gloss.name().to_string(),
            lights_spec: spec.to_string(),
            msaa: cell.msaa,
            pipeline: cell.config.pipeline().to_string(),
            config: label,
            frames: images.len() as u32,
            median_ms: (!times.is_empty()).then(|| super::stats::percentile(&times, 50.0)),
            p95_ms: (!times.is_empty()).then(|| super::stats::percentile(&times, 95.0)),
            flip_mean: q.flip_mean,
            psnr_db: q.psnr_db,
            flicker_mean: q.flicker.mean,
            flicker_sum: q.flicker.sum,
        });
    }
    // In the grid's order, whatever order the cells ran in.
    rows.sort_by_key(|r| r.cell);
    breakdown_rows.sort_by_key(|r| r.cell);
    Ok(Measured { rows, breakdown: breakdown_rows })
}

/// Object space's pixel classes at each measured frame of the path (after
/// the warm-up), from a renderer of `options` drawing the frames again:
/// untimed, so that the timed run reads nothing back between its frames.
fn pixel_classes(
    ctx: &GpuContext,
    scene: &Scene,
    options: &RenderOptions,
    path: &CameraPath,
    first: u32,
    grid: &TimingGrid,
    lights: &[Light],
) -> Result<Vec<Vec<PixelClass>>, ExperimentError> {
    let mut renderer = Renderer::new(ctx, scene, options)?;
    let mut found = Vec::new();
    for i in 0..grid.warmup + grid.frames {
        renderer.render(ctx, &path.camera_at(first + i), lights, u64::from(i))?;
        if i >= grid.warmup {
            found.push(renderer.read_pixel_classes(ctx)?.expect("object space classifies its pixels"));
        }
    }
    Ok(found)
}

fn reference_error(e: crate::reference::ReferenceError) -> ExperimentError {
    match e {
        crate::reference::ReferenceError::Render(r) => ExperimentError::Render(r),
        other => ExperimentError::Output { path: "reference".into(), message: other.to_string() },
    }
}
/// One measured configuration on the cost-error plane.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Point {
    pub config: String,
    pub cost_ms: f64,
    pub error: f64,
}

/// The Pareto front of `points`, cheapest first: the configurations no other
/// is at most as costly and at most as wrong as (and better in one). For
/// each error level, the cheapest configuration reaching it is on the front.
pub fn pareto_front(points: &[Point]) -> Vec<Point> {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.cost_ms.total_cmp(&b.cost_ms).then(a.error.total_cmp(&b.error)));
    let mut front: Vec<Point> = Vec::new();
    for p in sorted {
        if front.last().is_none_or(|best| p.error < best.error) {
            front.push(p);
        }
    }
    front
}

/// What the rows of one table and plot share: textures, gloss, light set, samples.
type GroupKey = (String, String, String, u32);

/// Rows of one group, in the grid's order.
fn groups(rows: &[Row]) -> Vec<(GroupKey, Vec<&Row>)> {
    let mut out: Vec<(GroupKey, Vec<&Row>)> = Vec::new();
    for r in rows {
        let key = (r.textures.clone(), r.gloss.clone(), r.lights_spec.clone(), r.msaa);
        match out.iter_mut().find(|(k, _)| *k == key) {
            Some((_, members)) => members.push(r),
            None => out.push((key, vec![r])),
        }
    }
    out
}

/// The tables, figures and results of measured rows (a whole run's, or
/// shards' merged).
pub fn summarize(setup: &Setup, rows: &[Row], output: Output) -> Result<Findings, ExperimentError> {
    let grid = setup;
    let mut sections = Vec::new();
    let mut fronts = Vec::new();
    let mut headline = Vec::new();
    for ((textures, gloss, lights, msaa), members) in groups(rows) {
        let what =
            format!("textures {textures}, gloss {gloss}, {lights}, {msaa} sample{}", if msaa == 1 { "" } else { "s" });
        let mut table = Table::new(&["configuration", "GPU ms (median)", "FLIP", "PSNR (dB)", "flicker"]);
        for r in &members {
            table.rows.push(vec![
                r.config.clone(),
                r.median_ms.map_or("-".into(), f3),
                format!("{:.4}", r.flip_mean),
                format!("{:.2}", r.psnr_db),
                format!("{:.3}", r.flicker_mean),
            ]);
        }
        let points: Vec<Point> = members
            .iter()
            .filter_map(|r| r.median_ms.map(|cost_ms| Point { config: r.config.clone(), cost_ms, error: r.flip_mean }))
            .collect();
        let front = pareto_front(&points);
        let mut cheapest = Table::new(&["FLIP at most", "cheapest configuration", "GPU ms"]);
        for p in &front {
            cheapest.rows.push(vec![format!("{:.4}", p.error), p.config.clone(), f3(p.cost_ms)]);
        }
        let mut pipelines: Vec<&str> = members.iter().map(|r| r.pipeline.as_str()).collect();
        pipelines.dedup();
        let mut series: Vec<Series> = pipelines
            .iter()
            .map(|&p| {
                let mut pts: Vec<(f64, f64)> = members
                    .iter()
                    .filter(|r| r.pipeline == p)
                    .filter_map(|r| Some((r.median_ms?, r.flip_mean)))
                    .collect();
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                Series { label: p.to_string(), points: pts }
            })
            .collect();
        series.push(Series {
            label: "Pareto front".into(),
            points: front.iter().map(|p| (p.cost_ms, p.error)).collect(),
        });
        let plot = LinePlot {
            title: format!("{}x{}, {what}: error against cost", grid.width, grid.height),
            x_label: "median GPU frame time (ms)".into(),
            y_label: "mean FLIP against the reference".into(),
            series,
        };
        let stem = format!("quality-{textures}-{gloss}-{}-msaa{msaa}", lights.replace([':', '+'], "-"));
        let figure = output.figure(&stem, &plot)?;
        let flicker = |config: &str| members.iter().find(|r| r.config == config).map(|r| r.flicker_mean);
        if let (Some(best), Some(os), Some(fw)) = (front.last(), flicker("objectspace"), flicker("forward")) {
            headline.push(format!(
                "{textures}/{gloss}/{msaa} spp: least error {} ({:.4}); flicker objectspace {os:.3}, forward {fw:.3}",
                best.config, best.error
            ));
        }
        fronts.push(serde_json::json!({
            "textures": textures, "gloss": gloss, "lights_spec": lights, "msaa": msaa, "front": front,
        }));
        sections.push(Section {
            heading: format!("Quality: {what}"),
            text: format!(
                "Each configuration along path frames {} to {} ({} measured after {} warm-up): median GPU frame \
                 time; mean over the frames of FLIP and PSNR against each frame's {REFERENCE_SAMPLES}x{REFERENCE_SAMPLES} \
                 supersampled reference; flicker, the mean over frame pairs of |the pipeline's change - the \
                 reference's change| per channel in 8-bit steps (0: it changes exactly as the reference does). \
                 The second table is the Pareto front: for each error level, the cheapest configuration that \
                 reaches it.",
                grid.first_frame + grid.warmup,
                grid.first_frame + grid.warmup + grid.frames - 1,
                grid.frames,
                grid.warmup,
            ),
            tables: vec![(String::new(), table), ("Cheapest configuration per error level:".into(), cheapest)],
            figures: vec![(format!("{what}: error against cost"), figure)],
        });
    }
    Ok(Findings {
        results: serde_json::json!({
            "rows": rows.len(),
            "pareto": fronts,
            "headline": headline.join("; "),
        }),
        sections,
    })
}

/// What a run measured, as `summary.json` keeps it (`quality`): enough to
/// summarize its rows again, so that shards can be merged without the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setup {
    pub scene: String,
    pub objects: usize,
    pub width: u32,
    pub height: u32,
    pub first_frame: u32,
    pub warmup: u32,
    pub frames: u32,
    pub seed: u64,
    pub lights: Vec<String>,
    pub textures: Vec<String>,
    pub gloss: Vec<String>,
    pub msaa: Vec<u32>,
    pub configs: Vec<String>,
    /// Cells of the whole grid (every shard's together).
    pub cells: usize,
    pub quick: bool,
    pub visibility: String,
    /// The error breakdown by pixel class was measured (`breakdown.csv`).
    #[serde(default)]
    pub breakdown: bool,
}

impl Setup {
    fn new(grid: &TimingGrid, quick: bool, scene: &StudyScene, visibility: VisibilityMethod) -> Self {
        let axes = axes(grid, quick);
        Self {
            scene: scene.name.clone(),
            objects: scene.render.objects.len(),
            width: grid.width,
            height: grid.height,
            first_frame: grid.first_frame,
            warmup: grid.warmup,
            frames: grid.frames,
            seed: grid.seed,
            lights: grid.sweeps.iter().flat_map(|s| s.counts.iter().map(|&n| s.scenario.spec(n).to_string())).collect(),
            textures: axes.textures.iter().map(|s| s.to_string()).collect(),
            gloss: axes.gloss.iter().map(|g| g.name().to_string()).collect(),
            msaa: axes.msaa,
            configs: axes.configs,
            cells: cells(grid, quick).len(),
            quick,
            visibility: visibility.name().to_string(),
            breakdown: grid.breakdown,
        }
    }
}

/// Which part of a grid a run measures: shard `index` (1-based) of `count`
/// takes every `count`-th cell from cell `index - 1`, so that the shards
/// are disjoint, cover the grid, and each gets a mix of pipelines.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// Whether cell `i` of the grid belongs to this shard.
    pub fn holds(self, i: usize) -> bool {
        i % self.count as usize == (self.index - 1) as usize
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N`, 1 <= K <= N.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("'{s}' is not K/N with 1 <= K <= N (the K-th of N parts)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (k.trim().parse::<u32>().map_err(|_| bad())?, n.trim().parse::<u32>().map_err(|_| bad())?);
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Self { index, count })
    }
}

/// `shadespace experiment quality`: measures the grid's cells (all, or the
/// shard `options` names) and writes `data.csv`, the figures and the findings.
pub(super) fn study(
    ctx: &GpuContext,
    options: &ExperimentOptions,
    scene: &StudyScene,
    output: Output,
    progress: &indicatif::ProgressBar,
) -> Result<Outcome, ExperimentError> {
    let grid = options.timing.as_ref().ok_or(ExperimentError::NoTimingGrid("quality"))?;
    // A sample count the adapter lacks for some pipeline's targets fails
    // before any cell is measured.
    let features = ctx.device.features();
    for &samples in &grid.msaa {
        for config in chosen_configs(grid, options.quick) {
            let pipeline = config.render_config(&[], VisibilityMethod::preferred_for(features, samples));
            crate::render::check_samples_for(ctx, samples, &pipeline)?;
        }
    }
    let cells: Vec<(usize, Cell)> = cells(grid, options.quick)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| options.shard.is_none_or(|s| s.holds(*i)))
        .collect();
    progress.set_length(cells.len() as u64 * u64::from(grid.warmup + grid.frames));
    let measured = measure(ctx, options, scene, grid, &cells, progress)?;
    output.write_rows(&measured.rows)?;
    let setup = Setup::new(grid, options.quick, scene, VisibilityMethod::preferred(ctx.device.features()));
    let mut findings = summarize(&setup, &measured.rows, output)?;
    if setup.breakdown {
        add_breakdown(&mut findings, &measured.breakdown, output)?;
    }
    let mut outcome = outcome(&setup, findings);
    if let serde_json::Value::Object(summary) = &mut outcome.summary {
        summary.insert("grid".into(), serde_json::json!(grid));
        if let Some(shard) = options.shard {
            summary.insert("shard".into(), serde_json::json!(shard));
        }
    }
    Ok(outcome)
}

/// Writes the breakdown's rows into `breakdown.csv` and adds its tables and
/// results (`breakdown`) to `findings`.
fn add_breakdown(findings: &mut Findings, rows: &[BreakdownRow], output: Output) -> Result<(), ExperimentError> {
    let path = output.dir.join("breakdown.csv");
    super::report::write_csv(&path, rows).map_err(|e| ExperimentError::output(&path, e))?;
    let (results, sections) = breakdown::summarize(rows);
    findings.results["breakdown"] = results;
    findings.sections.extend(sections);
    Ok(())
}

/// The summary keys, setup and differences of a run (or a merge).
fn outcome(setup: &Setup, findings: Findings) -> Outcome {
    let text = format!(
        "Scene `{}` ({} objects), {}x{}, {}; path frames {} to {} ({} warm-up); lights {} (seed {}); textures \
         {:?}; gloss {:?}; samples per pixel {:?}. Configurations: {}. References: forward at \
         {REFERENCE_SAMPLES}x{REFERENCE_SAMPLES} sub-pixel offsets per pixel, averaged in linear HDR, exposure 1 \
         (as every configuration). Visibility of object space and deferred-compute: {}.\n",
        setup.scene,
        setup.objects,
        setup.width,
        setup.height,
        if setup.quick { "quick mode (a reduced grid)" } else { "the full grid" },
        setup.first_frame,
        setup.first_frame + setup.warmup + setup.frames - 1,
        setup.warmup,
        setup.lights.join(", "),
        setup.seed,
        setup.textures,
        setup.gloss,
        setup.msaa,
        setup.configs.join(", "),
        setup.visibility,
    );
    let mut text = text;
    if setup.breakdown {
        text += "\nWith the error breakdown by pixel class (`--breakdown`: `breakdown.csv` and the \
                 \"Error by pixel class\" sections); object space's classes come from a second, untimed run of \
                 each cell's frames.\n";
    }
    let items = vec![
        "MSAA: forward, forward-multipass and clustered resolve hardware MSAA at the standard sample positions; \
         deferred and deferred-compute light a multisampled G-buffer, each pixel once or, on edges, sample by \
         sample (deferred's light volumes test each sample's depth in the shader); object space marks tiles per \
         pixel footprint (and per sample on edges) and gathers per sample on edges, so its shading does not grow \
         with the samples. Deferred-compute's and object space's visibility, at every sample count, is the one \
         the setup names (the compute rasterizer, where the adapter has it, writes each sample)."
            .to_string(),
        "Reference textures: each of the reference's N x N sub-pixel frames samples textures log2(N) levels \
         finer than a pixel's footprint (the footprint of its sample in a frame N times larger), so it resolves \
         texture detail as well as geometry, shading and specular aliasing; each sample's filter is the \
         hardware's trilinear one (no anisotropy)."
            .to_string(),
        "Flicker and error are of the tone-mapped 8-bit images; on a CPU driver the GPU times do not measure \
         every pass (README, lavapipe timestamps)."
            .to_string(),
    ];
    Outcome {
        summary: serde_json::json!({
            "quality": setup,
            "reference_samples": REFERENCE_SAMPLES,
            "visibility": setup.visibility,
        }),
        sections: vec![Section { heading: "Setup".into(), text, ..Default::default() }, differences(&items)],
        findings,
    }
}

/// Why shards cannot be merged.
fn merge_error(path: &std::path::Path, message: impl std::fmt::Display) -> ExperimentError {
    ExperimentError::Output { path: path.to_path_buf(), message: message.to_string() }
}

/// `shadespace experiment merge DIR...`: the shards' rows in the grid's
/// order, summarized, plotted and reported into `out` as one run would be.
/// Every shard must be of one run's grid, each of 1..=N exactly once.
pub fn merge(
    dirs: &[std::path::PathBuf],
    out: &std::path::Path,
    command: &str,
) -> Result<super::Written, ExperimentError> {
    use std::path::Path;
    let read_summary = |dir: &Path| -> Result<serde_json::Value, ExperimentError> {
        let path = dir.join("summary.json");
        let text = std::fs::read_to_string(&path).map_err(|e| merge_error(&path, e))?;
        serde_json::from_str(&text).map_err(|e| merge_error(&path, e))
    };
    let Some(first_dir) = dirs.first() else {
        return Err(merge_error(out, "no shard folders to merge"));
    };
    let first = read_summary(first_dir)?;
    let setup: Setup = serde_json::from_value(first["quality"].clone())
        .map_err(|e| merge_error(&first_dir.join("summary.json"), format!("not a quality run: {e}")))?;
    let mut seen = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    let mut breakdown_rows: Vec<BreakdownRow> = Vec::new();
    for dir in dirs {
        let summary = read_summary(dir)?;
        let path = dir.join("summary.json");
        let shard: Shard = serde_json::from_value(summary["shard"].clone())
            .map_err(|_| merge_error(&path, "not a shard (run with --shard K/N)"))?;
        if summary["quality"] != first["quality"]
            || summary["grid"] != first["grid"]
            || summary["scene_spec"] != first["scene_spec"]
        {
            return Err(merge_error(&path, format!("a shard of another grid than {}'s", first_dir.display())));
        }
        seen.push(shard);
        let csv_path = dir.join("data.csv");
        let mut reader = csv::Reader::from_path(&csv_path).map_err(|e| merge_error(&csv_path, e))?;
        for row in reader.deserialize() {
            rows.push(row.map_err(|e| merge_error(&csv_path, e))?);
        }
        if setup.breakdown {
            let csv_path = dir.join("breakdown.csv");
            let mut reader = csv::Reader::from_path(&csv_path).map_err(|e| merge_error(&csv_path, e))?;
            for row in reader.deserialize() {
                breakdown_rows.push(row.map_err(|e| merge_error(&csv_path, e))?);
            }
        }
    }
    let count = seen[0].count;
    let mut indices: Vec<u32> = seen.iter().map(|s| s.index).collect();
    indices.sort_unstable();
    if seen.iter().any(|s| s.count != count) || indices != (1..=count).collect::<Vec<_>>() {
        let got: Vec<String> = seen.iter().map(|s| format!("{}/{}", s.index, s.count)).collect();
        return Err(merge_error(
            first_dir,
            format!("the shards are {}: each of 1..={count} of {count} once is needed", got.join(", ")),
        ));
    }
    rows.sort_by_key(|r| r.cell);
    if rows.len() != setup.cells || rows.iter().enumerate().any(|(i, r)| r.cell != i) {
        return Err(merge_error(
            first_dir,
            format!("the shards hold {} rows of a grid of {} cells", rows.len(), setup.cells),
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| merge_error(out, format!("cannot create the folder: {e}")))?;
    let output = Output { dir: out };
    output.write_rows(&rows)?;
    let mut findings = summarize(&setup, &rows, output)?;
    if setup.breakdown {
        // Each cell's rows come from one shard, in order: a stable sort keeps them so.
        breakdown_rows.sort_by_key(|r| r.cell);
        add_breakdown(&mut findings, &breakdown_rows, output)?;
    }
    let outcome = outcome(&setup, findings);
    let mut provenance: super::report::Provenance = serde_json::from_value(first["provenance"].clone())
        .map_err(|e| merge_error(&first_dir.join("summary.json"), e))?;
    provenance.command = command.to_string();
    provenance.date = super::report::utc_now();
    let headline = outcome.findings.results["headline"].as_str().unwrap_or_default().to_string();
    let mut summary = first;
    if let Some(all) = summary.as_object_mut() {
        all.remove("shard");
        all.insert("provenance".into(), serde_json::json!(provenance));
        all.insert("results".into(), outcome.findings.results.clone());
        all.insert("merged_from".into(), serde_json::json!(dirs));
    }
    let summary_path = out.join("summary.json");
    let text = serde_json::to_string_pretty(&summary).expect("the summary serializes");
    std::fs::write(&summary_path, text).map_err(|e| merge_error(&summary_path, e))?;
    let mut sections = outcome.sections;
    sections.extend(outcome.findings.sections);
    let title = format!("Experiment `quality`: {}", setup.scene);
    let report_path = out.join("report.md");
    std::fs::write(&report_path, super::report::markdown(&title, &provenance, &sections))
        .map_err(|e| merge_error(&report_path, e))?;
    Ok(super::Written { folder: out.to_path_buf(), report: report_path, headline })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(config: &str, cost_ms: f64, error: f64) -> Point {
        Point { config: config.into(), cost_ms, error }
    }

    #[test]
    fn the_pareto_front_keeps_what_nothing_cheaper_beats() {
        let points = [p("a", 1.0, 0.05), p("b", 2.0, 0.06), p("c", 3.0, 0.02), p("d", 3.0, 0.01), p("e", 5.0, 0.01)];
        let front: Vec<String> = pareto_front(&points).into_iter().map(|p| p.config).collect();
        // b costs more than a and is worse; c ties d's cost but is worse; e
        // costs more than d for the same error.
        assert_eq!(front, ["a", "d"]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn configurations_and_cells_cover_the_axes() {
        let full = grid(false);
        let labels: Vec<String> = configs(&full, false).iter().map(Config::label).collect();
        assert_eq!(
            labels,
            [
                "forward",
                "forward-multipass",
                "clustered",
                "deferred",
                "deferred-compute",
                "objectspace",
                "objectspace-reuse2",
                "objectspace-vr1",
                "objectspace-hz30",
                "objectspace-bias1",
                "objectspace-blend1",
                "objectspace-bspline",
                "objectspace-blend1-bspline",
                "objectspace-bias-1",
                "objectspace-bias-1-blend1",
                "objectspace-aniso4",
                "objectspace-aniso8",
                "objectspace-blend1-aniso8",
                "objectspace-bias-1-aniso4",
                "forward-aniso16",
                "forward-multipass-aniso16",
                "clustered-aniso16",
                "deferred-aniso16",
                "deferred-compute-aniso16"
            ]
        );
        let all = cells(&full, false);
        assert_eq!(
            all.len(),
            labels.len() * 3 * 2 * 2,
            "full: two textures, two gloss settings, one light set, MSAA 1, 4, 8"
        );
        assert_eq!(all.iter().filter(|c| c.config.pipeline() == "objectspace").count(), 14 * 4 * 3);
        assert_eq!(all.iter().filter(|c| c.msaa == 8).count(), labels.len() * 4);
        let quick = grid(true);
        let labels: Vec<String> = configs(&quick, true).iter().map(Config::label).collect();
        assert_eq!(labels, ["forward", "deferred-compute", "objectspace", "objectspace-hz30"]);
        let cells = cells(&quick, true);
        assert_eq!(cells.len(), 4 * 2 * 2, "quick: detailed textures, two gloss settings, one light set, MSAA 1, 4");
        assert!(cells.iter().all(|c| c.textures == "detailed"));
        // A quick run may name the full grid's object-space cells.
        let named = TimingGrid { configs: vec!["objectspace-aniso8".into()], ..grid(true) };
        let labels: Vec<String> = chosen_configs(&named, true).iter().map(Config::label).collect();
        assert_eq!(labels, ["objectspace-aniso8"]);
        // And the conventional pipelines' anisotropic cells.
        let named = TimingGrid { configs: vec!["deferred-compute-aniso16".into()], ..grid(true) };
        let chosen = chosen_configs(&named, true);
        assert_eq!(chosen.len(), 1);
        assert_eq!((chosen[0].pipeline(), chosen[0].aniso), ("deferred-compute", CONVENTIONAL_ANISO));
        // The trade-offs only when named, as 30 Hz shading with coarser levels.
        assert!(!configs(&full, false).iter().any(|c| trade_offs().contains(c)));
        let named = TimingGrid { configs: vec!["objectspace-hz30-vr1-bias0.5".into()], ..grid(false) };
        let chosen = chosen_configs(&named, false);
        assert_eq!(chosen.len(), 1);
        let PipelineConfig::ObjectSpace(os) = chosen[0].render_config(&[], VisibilityMethod::Raster) else {
            panic!("object space")
        };
        assert!(os.reuse == 2 && os.spread_reshading && os.variable_rate == 1.0 && os.mip_bias == 0.5);
    }

    /// Every file of `dir` by name, for comparing two runs' outputs.
    fn files(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
            .collect()
    }

    /// Shards merged give the bytes one whole run gives: the same `data.csv`,
    /// figures and results, whatever order the shard folders come in. (The
    /// integration test `quality_quick` checks on the GPU that a cell
    /// measures the same alone as among the others; this checks the merge.)
    #[test]
    fn merged_shards_equal_the_whole_run() {
        let quick = grid(true);
        let all = cells(&quick, true);
        let setup = Setup {
            scene: "synthetic".into(),
            objects: 3,
            width: quick.width,
            height: quick.height,
            first_frame: quick.first_frame,
            warmup: quick.warmup,
            frames: quick.frames,
            seed: quick.seed,
            lights: vec!["small:8".into()],
            textures: vec!["detailed".into()],
            gloss: vec!["default".into(), "high".into()],
            msaa: vec![1, 4],
            configs: configs(&quick, true).iter().map(Config::label).collect(),
            cells: all.len(),
            quick: true,
            visibility: "compute".into(),
            breakdown: true,
        };
        // Distinct values per cell, one without a GPU time, so a row merged
        // into the wrong cell or summarized out of order changes the output.
        let rows: Vec<Row> = all
            .iter()
            .enumerate()
            .map(|(i, c)| Row {
                cell: i,
                textures: c.textures.into(),
                gloss: c.gloss.name().into(),
                lights_spec: c.scenario.spec(c.lights).to_string(),
                msaa: c.msaa,
                pipeline: c.config.pipeline().into(),
                config: c.config.label(),
                frames: quick.frames,
                median_ms: (i != 5).then(|| 1.0 + (i * 7 % 11) as f64 * 0.1),
                p95_ms: (i != 5).then_some(2.0 + i as f64 * 0.01),
                flip_mean: 0.01 + (i * 5 % 13) as f64 * 0.003,
                psnr_db: 30.0 + i as f64 * 0.25,
                flicker_mean: 0.1 * i as f64,
                flicker_sum: 0.1 * i as f64 * f64::from(quick.frames - 1),
            })
            .collect();
        // Breakdown rows: distinct sums per cell and class.
        let breakdown: Vec<BreakdownRow> = rows
            .iter()
            .flat_map(|r| {
                let mut sums = PathSums::new();
                for (f, factor) in sums.factors.iter_mut().enumerate() {
                    for (k, s) in factor.iter_mut().enumerate() {
                        s.pixels = (r.cell * 31 + f * 7 + k) as u64 % 17;
                        s.flip = s.pixels as f64 * 0.01 * (1 + r.cell % 3) as f64;
                        s.pair_pixels = s.pixels / 2;
                        s.flicker = s.pair_pixels as f64 * 0.3;
                    }
                }
                let from = if r.pipeline == "objectspace" { "own" } else { "objectspace" };
                sums.rows(&breakdown::CellKey {
                    cell: r.cell,
                    textures: &r.textures,
                    gloss: &r.gloss,
                    lights_spec: &r.lights_spec,
                    msaa: r.msaa,
                    config: &r.config,
                    classes_from: from,
                })
            })
            .collect();
        let root = tempfile::tempdir().unwrap();
        let whole = root.path().join("whole");
        std::fs::create_dir_all(&whole).unwrap();
        let output = Output { dir: &whole };
        output.write_rows(&rows).unwrap();
        let mut findings = summarize(&setup, &rows, output).unwrap();
        add_breakdown(&mut findings, &breakdown, output).unwrap();
        assert!(whole.join("breakdown.csv").exists());

        let provenance = serde_json::json!({
            "adapter": "test", "backend": "Vulkan", "driver": "test", "driver_info": "",
            "date": "2026-01-01T00:00:00Z", "commit": "0000000", "command": "shadespace experiment quality --quick",
        });
        let mut shards = Vec::new();
        for index in 1..=3 {
            let shard = Shard { index, count: 3 };
            let dir = root.path().join(format!("shard{index}"));
            std::fs::create_dir_all(&dir).unwrap();
            let part: Vec<Row> = rows.iter().filter(|r| shard.holds(r.cell)).cloned().collect();
            Output { dir: &dir }.write_rows(&part).unwrap();
            let part: Vec<BreakdownRow> = breakdown.iter().filter(|r| shard.holds(r.cell)).cloned().collect();
            super::super::report::write_csv(&dir.join("breakdown.csv"), &part).unwrap();
            let summary = serde_json::json!({
                "quality": setup, "grid": quick, "scene_spec": "synthetic", "shard": shard, "provenance": provenance,
            });
            std::fs::write(dir.join("summary.json"), summary.to_string()).unwrap();
            shards.push(dir);
        }
        for (name, order) in [("merged", [0, 1, 2]), ("reordered", [2, 0, 1])] {
            let out = root.path().join(name);
            let dirs: Vec<_> = order.iter().map(|&i| shards[i].clone()).collect();
            merge(&dirs, &out, "shadespace experiment merge").unwrap();
            let mut merged = files(&out);
            let summary: serde_json::Value = serde_json::from_slice(&merged.remove("summary.json").unwrap()).unwrap();
            assert!(merged.remove("report.md").is_some());
            // Through the same JSON text (serde_json parses floats to within an ULP).
            let expected: serde_json::Value = serde_json::from_str(&findings.results.to_string()).unwrap();
            assert_eq!(summary["results"], expected, "{name}: results");
            assert!(summary.get("shard").is_none(), "{name}: a merged run is not a shard");
            let expected = files(&whole);
            assert_eq!(merged.keys().collect::<Vec<_>>(), expected.keys().collect::<Vec<_>>(), "{name}: files");
            for (file, bytes) in &expected {
                assert!(merged[file] == *bytes, "{name}: {file} differs from the whole run's");
            }
        }
        // A shard given twice, or one missing, is not a run.
        let out = root.path().join("bad");
        assert!(merge(&[shards[0].clone(), shards[0].clone(), shards[1].clone()], &out, "m").is_err());
        assert!(merge(&shards[..2], &out, "m").is_err());
    }
}
