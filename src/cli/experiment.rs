//! `shadespace experiment NAME`: one of the studies behind the project, run
//! reproducibly into a folder (data, summary, plots, report).

use std::path::PathBuf;
use std::str::FromStr;

use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use shadespace::experiments::marking::Marking;
use shadespace::experiments::quality::{self, Shard};
use shadespace::experiments::scenarios::Scenario;
use shadespace::experiments::timing::{Sweep, TimingGrid};
use shadespace::experiments::{self, ExperimentName, ExperimentOptions, Grid};
use shadespace::gpu::timing::GpuTiming;
use shadespace::render::objectspace::MAX_ATLAS_BUDGET_MI;

use super::options::GpuArgs;
use super::output::command_line;
use super::parse;
use super::setup::open_gpu;
use super::{Failure, input};

/// The command's long help: what each study writes and measures.
pub const ABOUT: &str = "\
Run one of the studies behind the project as a reproducible experiment. Each writes, into --out:
  data.csv       one row per measurement
  summary.json   the grid, the setup, and per cell median, std, mean, p10, p90
  *.png, *.svg   the plots (ratio over frames, overlap heat maps, reuse over frames)
  report.md      the tables and plots, with the adapter, driver, date, commit and command

The tile studies render each view's visibility buffer with the renderer's own visibility pass and
mark tiles on the CPU in three variants: the reference study's rule at 4096x4096 per object
(--marking study: one tile per pixel at level floor(log2(4096 x the largest |dUV/dx|, |dUV/dy|
component))), ours at the same textures (--marking bilinear: the bilinear footprint at the rounded
level, as the object-space pipeline marks), and ours at our texel density (with bilinear).
Cameras: the scene's path (600 frames, the study's stepping) and its five fixed cameras, all
with the study's projection (60 degrees, near 0.3, far 1000).

  overshading  tiles needed x tile area / screen pixels, per path frame
  overlap      per pair of fixed cameras: tiles both need / tiles camera a needs, and IoU;
               the saving of one atlas shared by the five views
  reuse        per pair of consecutive path frames: previous tiles still needed, new tiles;
               over all frames and the windows 100-120, 300-320, 500-520

The timing studies run every pipeline over light sets with `bench`'s loop (GPU-timestamp
medians over --frames frames after --warmup frames, one renderer per configuration kept across
light sets) at --size:

  lights       every pipeline, scenarios small, big, shadowed, mixed-1:5, mixed-1:10, counts
               1-10, 12-20 by 2, 30-100 by 10, 200, 500, 1000, 2000, 5000, 10000; frame time,
               fps, and the cost per light (slope of a least-squares line)
  speedup      forward, the other conventional pipelines, object space with reuse 1-4 and
               variable rate 1 and 2; shadowed lights 0-30, big unshadowed lights 0-1000;
               speed-up over forward and over the fastest conventional pipeline, the fixed
               overhead at 0 and 1 light, image error against forward (FLIP, PSNR, SSIM)

  layers       every material with K layers (--materials layered:K, K = 1, 2, 4, 8, 12, 16):
               every pipeline (per-layer lighting) and object space (reuse 1, 30 Hz of 60 spread,
               variable rate 1) with 1 and 1000 small lights and 30 shadowed lights; frame time,
               the last frame's error against a 4x4 supersampled reference and against forward,
               object space's speed-up over the fastest conventional pipeline

A configuration slower than --cap-ms at a count skips the larger counts of that scenario.

The study's Sponza run: shadespace experiment overshading --scene ../shared/scenes/sponza-thesis \\
  --exclude sponza_plantsA,sponza_plantsB --out results/overshading";

/// The experiments, for `experiment NAME`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExperimentChoice {
    /// Shaded texels per screen pixel along the camera path (tiles x tile area / pixels).
    Overshading,
    /// Tiles two of the five fixed cameras both need; one shared atlas against one per view.
    Overlap,
    /// Share of the previous path frame's tiles still needed, and of new tiles.
    Reuse,
    /// GPU frame time of every pipeline against the light count, four scenarios; cost per light.
    Lights,
    /// Object space (reuse 1-4, variable rate) against forward and the fastest conventional pipeline.
    Speedup,
    /// Every pipeline's error and flicker against supersampled references, against its cost (Pareto front).
    Quality,
    /// Every pipeline's frame time and error (against supersampled references) as every material gets 1 to 16 layers.
    Layers,
    /// Merge shards (`--shard K/N` runs) given as DIR... into --out: the summary, plots and report of one run.
    Merge,
}

/// `experiment`'s options.
#[derive(Args)]
pub struct ExperimentArgs {
    /// The experiment to run.
    #[arg(value_enum)]
    pub name: ExperimentChoice,
    /// `merge`: the shard folders to merge.
    #[arg(value_name = "DIR")]
    pub shards: Vec<PathBuf>,
    /// Run only the K-th of N disjoint parts of the grid (1 <= K <= N;
    /// `quality` only); `experiment merge DIR...` joins the parts.
    #[arg(long, value_name = "K/N", value_parser = Shard::from_str)]
    pub shard: Option<Shard>,
    /// `atrium` (default), `voxels`, or a path (see `render --help`), e.g.
    /// ../shared/scenes/sponza-thesis.
    #[arg(long, default_value = "atrium")]
    pub scene: String,
    /// Output folder (created; files in it are replaced). Default: experiment-NAME.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A reduced grid (two small resolutions, tiles of 8 and 32, a few
    /// frames): under a minute on a CPU driver, for CI.
    #[arg(long)]
    pub quick: bool,
    /// Marking rules to count with, comma-separated: `study` (the reference
    /// study's, at 4096x4096 textures) and/or `bilinear` (ours, at 4096 and
    /// at our texel density).
    #[arg(long, value_delimiter = ',', default_value = "study,bilinear", value_parser = Marking::from_str)]
    pub marking: Vec<Marking>,
    /// Leave these objects out (comma-separated names; `shadespace charts`
    /// lists them). The study ran Sponza without sponza_plantsA,sponza_plantsB.
    #[arg(long, value_delimiter = ',')]
    pub exclude: Vec<String>,
    /// Tile sizes, comma-separated, instead of the grid's (8,16,32,64; quick: 8,32).
    #[arg(long, value_delimiter = ',', value_parser = parse::tile_size)]
    pub tile_sizes: Vec<u32>,
    /// Resolutions, comma-separated WIDTHxHEIGHT, instead of the grid's
    /// (800x600,1024x768,1920x1080,3840x2160; quick: 320x240,480x270).
    #[arg(long, value_delimiter = ',', value_parser = parse::size)]
    pub resolutions: Vec<(u32, u32)>,
    /// Our texel density (texels per metre) for the density variant.
    #[arg(long, default_value_t = 256.0, value_parser = parse::texel_density)]
    pub texel_density: f32,
    /// Measure every K-th path frame (overshading) or frame pair (reuse's
    /// all-frames statistics; its windows stay whole) instead of all 600:
    /// K times less work, the same distribution sampled more thinly.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=600))]
    pub frame_step: Option<u32>,
    /// Layered materials for every scene rendered, as `render --materials`:
    /// `none` (default), `layered:K`, `bands` or a material file; e.g. the
    /// quality experiment's cost against error with 8 layers a material.
    /// Not for `layers`, which gives every material its K layers itself.
    #[arg(long, value_name = "none|layered:K|bands|FILE", default_value = "none")]
    pub materials: shadespace::materials::MaterialsSpec,
    #[command(flatten)]
    pub timing: TimingArgs,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub gpu: GpuArgs,
}

/// The timing studies' grid changes.
#[derive(Args)]
#[command(next_help_heading = "Timing studies (lights, speedup)")]
pub struct TimingArgs {
    /// Image size, WIDTHxHEIGHT (default 1920x1080; quick: 160x90).
    #[arg(long, value_parser = parse::size)]
    pub size: Option<(u32, u32)>,
    /// Measured frames per point (default 20; quick: 2).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: Option<u32>,
    /// Frames rendered before each point's measured ones (default 5, speedup
    /// 4; quick: 1). For speedup keep warm-up + frames a multiple of 12, so
    /// that the compared last frame shows every reuse N of 1-4 at its oldest shades.
    #[arg(long)]
    pub warmup: Option<u32>,
    /// Light counts, comma-separated, instead of the grid's (for `speedup`: in every sweep).
    #[arg(long, value_delimiter = ',')]
    pub counts: Vec<u32>,
    /// Scenarios, comma-separated, instead of the grid's: small, big, shadowed, mixed-1:R.
    #[arg(long, value_delimiter = ',', value_parser = Scenario::from_str)]
    pub scenarios: Vec<Scenario>,
    /// A configuration whose median frame time passes this many ms at a
    /// count skips the larger counts of that scenario (default 200; quick: 10000).
    #[arg(long, value_parser = parse::cap_ms)]
    pub cap_ms: Option<f64>,
    /// `quality`: MSAA samples per pixel, comma-separated (1, 2, 4, 8;
    /// default 1,4,8; quick: 1,4). Pipelines without MSAA are measured at 1 only.
    #[arg(long, value_delimiter = ',', value_parser = parse::msaa)]
    pub msaa: Vec<u32>,
    /// `quality` and `layers`: only these configurations, comma-separated
    /// labels as the report names them (e.g.
    /// deferred-compute,objectspace,objectspace-hz30). `layers` also takes
    /// object space's trade-offs, measured only when named:
    /// objectspace-hz30-vr1, objectspace-hz30-vr2, objectspace-hz30-bias0.5,
    /// objectspace-hz30-vr1-bias0.5, objectspace-hz30-bias1,
    /// objectspace-hz30-vr1-bias1 (30 Hz shading
    /// with variable rate and coarser levels; the report sets them against
    /// the fastest conventional pipeline's image and the reference).
    #[arg(long, value_delimiter = ',')]
    pub configs: Vec<String>,
    /// `quality`: only these texture settings, comma-separated (file, detailed).
    #[arg(long, value_delimiter = ',')]
    pub textures: Vec<String>,
    /// `layers`: only these layer counts, comma-separated (1 to 16; default
    /// 1,2,4,8,12,16): a run that finishes a grid another run left short.
    #[arg(long, value_delimiter = ',', value_parser = parse::layer_count)]
    pub layers: Vec<usize>,
    /// `quality`: split each cell's error and flicker by pixel class (MSAA
    /// edge, object space's level, texels per pixel, chart-border taps,
    /// shade age, the reference's gradient) into breakdown.csv and the
    /// report; object space's classes come from a second, untimed run of
    /// each cell's frames, so the timed frames read nothing back.
    #[arg(long)]
    pub breakdown: bool,
    /// `quality`: object space's physical atlas budget in Mi texels, as
    /// `render --atlas-budget` (default: 1 texel per pixel at 1920x1080,
    /// growing as the square root of the pixels). `--os-aniso` and finer
    /// levels need several times the default's pages; with too small an
    /// atlas the budget biases their levels coarser.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_ATLAS_BUDGET_MI))]
    pub atlas_budget: Option<u64>,
    /// What the GPU timestamps time (as `bench --timing`; default `frame`:
    /// two a frame, so that a pipeline of more passes pays nothing more
    /// for being timed).
    #[arg(long, value_enum)]
    pub timing: Option<GpuTiming>,
}

/// Runs the experiment and prints its headline and report path.
pub fn run(a: ExperimentArgs) -> Result<(), Failure> {
    let name = match a.name {
        ExperimentChoice::Overshading => ExperimentName::Overshading,
        ExperimentChoice::Overlap => ExperimentName::Overlap,
        ExperimentChoice::Reuse => ExperimentName::Reuse,
        ExperimentChoice::Lights => ExperimentName::Lights,
        ExperimentChoice::Speedup => ExperimentName::Speedup,
        ExperimentChoice::Quality => ExperimentName::Quality,
        ExperimentChoice::Layers => ExperimentName::Layers,
        ExperimentChoice::Merge => return merge_shards(&a),
    };
    if !a.shards.is_empty() {
        let dirs: Vec<String> = a.shards.iter().map(|d| d.display().to_string()).collect();
        return input(Err(anyhow::anyhow!(
            "unexpected arguments {}: only `experiment merge` takes folders",
            dirs.join(" ")
        )));
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from(format!("experiment-{}", name.name())));
    if out.exists() && !out.is_dir() {
        return input(Err(anyhow::anyhow!("--out {}: exists and is not a folder", out.display())));
    }
    let mut grid = if a.quick { Grid::quick() } else { Grid::full() };
    if !a.tile_sizes.is_empty() {
        grid.tile_sizes = a.tile_sizes.clone();
    }
    if !a.resolutions.is_empty() {
        grid.resolutions = a.resolutions.clone();
    }
    if let Some(step) = a.frame_step {
        grid.sample_frames(step);
    }
    if !a.timing.msaa.is_empty() && name != ExperimentName::Quality {
        return input(Err(anyhow::anyhow!("--msaa: only the quality experiment has an MSAA axis")));
    }
    if name != ExperimentName::Layers && !a.timing.layers.is_empty() {
        return input(Err(anyhow::anyhow!("--layers: only the layers experiment takes it")));
    }
    if !matches!(name, ExperimentName::Quality | ExperimentName::Layers) && !a.timing.configs.is_empty() {
        return input(Err(anyhow::anyhow!("--configs: only the quality and layers experiments take it")));
    }
    if name != ExperimentName::Quality {
        let quality_only = [
            ("--textures", !a.timing.textures.is_empty()),
            ("--breakdown", a.timing.breakdown),
            ("--atlas-budget", a.timing.atlas_budget.is_some()),
        ];
        if let Some((flag, _)) = quality_only.iter().find(|(_, given)| *given) {
            return input(Err(anyhow::anyhow!("{flag}: only the quality experiment takes it")));
        }
    }
    let timing = name.timing_grid(a.quick).map(|g| timing_grid(g, &a.timing));
    if let (ExperimentName::Quality, Some(grid)) = (name, &timing) {
        input(check_quality_choice(grid, a.quick))?;
    }
    if let (ExperimentName::Layers, Some(grid)) = (name, &timing) {
        let labels: Vec<String> = experiments::layers::nameable_configs(grid).iter().map(|c| c.label()).collect();
        if let Some(bad) = grid.configs.iter().find(|c| !labels.contains(c)) {
            let message = format!("--configs: '{bad}' is not a configuration of this grid ({})", labels.join(", "));
            return input(Err(anyhow::anyhow!(message)));
        }
    }
    let options = ExperimentOptions {
        name,
        scene: a.scene.clone(),
        exclude: a.exclude.clone(),
        markings: a.marking.clone(),
        grid,
        timing,
        quick: a.quick,
        texel_density: a.texel_density,
        out,
        command: command_line(),
        chart_cache: None,
        shard: a.shard,
        materials: a.materials.clone(),
    };
    let ctx = open_gpu(&a.gpu)?;
    let bar = if a.quiet { ProgressBar::hidden() } else { ProgressBar::new(0) };
    let unit = if name.is_timing() { "frames" } else { "views" };
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{msg}} [{{bar:40}}] {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, eta {{eta}}"
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    let written = match experiments::run(&ctx, &options, &bar) {
        Ok(w) => w,
        Err(e) if e.is_input() => return input(Err(e)),
        Err(e) => return Err(e.into()),
    };
    bar.finish_and_clear();
    println!("{}: {} -> {}", name.name(), written.headline, written.report.display());
    Ok(())
}

/// `experiment merge DIR...`: the shards' rows as one run's outputs in --out.
fn merge_shards(a: &ExperimentArgs) -> Result<(), Failure> {
    if a.shards.is_empty() {
        return input(Err(anyhow::anyhow!("experiment merge: name the shard folders (DIR...)")));
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("experiment-quality"));
    if out.exists() && !out.is_dir() {
        return input(Err(anyhow::anyhow!("--out {}: exists and is not a folder", out.display())));
    }
    let written = input(quality::merge(&a.shards, &out, &command_line()))?;
    println!("quality (merged): {} -> {}", written.headline, written.report.display());
    Ok(())
}

/// `--configs` and `--textures` name what the quality grid has.
fn check_quality_choice(grid: &TimingGrid, quick: bool) -> anyhow::Result<()> {
    let labels: Vec<String> = quality::nameable_configs(grid).iter().map(|c| c.label()).collect();
    if let Some(bad) = grid.configs.iter().find(|c| !labels.contains(c)) {
        anyhow::bail!("--configs: '{bad}' is not a configuration of this grid ({})", labels.join(", "));
    }
    let textures = quality::texture_settings(quick);
    if let Some(bad) = grid.textures.iter().find(|t| !textures.contains(&t.as_str())) {
        anyhow::bail!("--textures: '{bad}' is not a texture setting of this grid ({})", textures.join(", "));
    }
    Ok(())
}

/// A timing study's grid with the command line's changes.
fn timing_grid(mut grid: TimingGrid, a: &TimingArgs) -> TimingGrid {
    if let Some((w, h)) = a.size {
        (grid.width, grid.height) = (w, h);
    }
    grid.frames = a.frames.unwrap_or(grid.frames);
    grid.warmup = a.warmup.unwrap_or(grid.warmup);
    grid.cap_ms = a.cap_ms.unwrap_or(grid.cap_ms);
    grid.timing = a.timing.unwrap_or(grid.timing);
    if !a.scenarios.is_empty() {
        // Keep each listed scenario's own counts where the grid has it (speedup's sweeps differ).
        let counts = |s: Scenario| {
            grid.sweeps.iter().find(|w| w.scenario == s).or(grid.sweeps.first()).map(|w| w.counts.clone())
        };
        grid.sweeps =
            a.scenarios.iter().map(|&s| Sweep { scenario: s, counts: counts(s).unwrap_or_default() }).collect();
    }
    if !a.msaa.is_empty() {
        let mut msaa = a.msaa.clone();
        msaa.sort_unstable();
        msaa.dedup();
        grid.msaa = msaa;
    }
    grid.configs = a.configs.clone();
    grid.textures = a.textures.clone();
    let mut layers = a.layers.clone();
    layers.sort_unstable();
    layers.dedup();
    grid.layers = layers;
    grid.breakdown = a.breakdown;
    grid.atlas_budget_mi = a.atlas_budget;
    if !a.counts.is_empty() {
        let mut counts = a.counts.clone();
        counts.sort_unstable();
        counts.dedup();
        for sweep in &mut grid.sweeps {
            sweep.counts = counts.clone();
        }
    }
    grid
}
