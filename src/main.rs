//! The `shadespace` command line: parse, call the library, print.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;

use anyhow::Context;
use clap::{Args, Parser, Subcommand, ValueEnum};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use shadespace::bench::{self, BenchPlan, BenchSetup, RunReport};
use shadespace::charts::{self, ChartCache, SceneCharts, TextureSizing};
use shadespace::experiments::marking::Marking;
use shadespace::experiments::scenarios::Scenario;
use shadespace::experiments::timing::{Sweep, TimingGrid};
use shadespace::experiments::{self, ExperimentName, ExperimentOptions, Grid};
use shadespace::gpu::{GpuContext, GpuOptions};
use shadespace::render::objectspace::atlas::MAX_TEXTURE_SIZE;
use shadespace::render::objectspace::atlas_view::AtlasPages;
use shadespace::render::objectspace::{
    DEFAULT_PAGE_SIZE, DebugView, ExtraViews, MAX_ATLAS_BUDGET_MI, MAX_DENSITY_SIZE, ObjectSpace,
};
use shadespace::render::{
    ClusteredConfig, DeferredComputeConfig, DeferredConfig, Exposure, ForwardConfig, ForwardMultipassConfig,
    ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, ShadingModel, ShadowRefresh, VisibilityMethod,
};
use shadespace::scene::bookmarks::BookmarkRef;
use shadespace::scene::free_camera::{self, LookAt, OrbitSpec};
use shadespace::scene::path::SceneCameras;
use shadespace::scene::{self, Aabb, Camera, CameraPath, Light, LightSpec, Scene, lights, path};

#[derive(Parser)]
#[command(name = "shadespace", version, about = "Object-space shading renderer and testbed", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame to a PNG image (and optionally its statistics to JSON).
    Render(RenderArgs),
    /// Render many frames along a camera path and report GPU time per pass
    /// (median and p95 after warm-up) as JSON.
    Bench(BenchArgs),
    /// List the pipelines, the GPU adapters, and the features and limits of the chosen adapter.
    Info(GpuArgs),
    /// Print, per object, where its unique UV layout (chart) comes from, its
    /// overlap, surface area, texel density and shading-texture size.
    Charts(ChartsArgs),
    /// Compare two images: mean FLIP error, PSNR, SSIM, largest channel difference.
    Compare(CompareArgs),
    /// Run one of the studies behind the project (overshading, overlap,
    /// reuse, lights, speedup) and write its data, summary, plots and report
    /// into a folder.
    #[command(long_about = EXPERIMENT_ABOUT)]
    Experiment(ExperimentArgs),
    /// Open a window that renders the scene with the same options as
    /// `render`: fly, orbit or path camera, pipelines and options switched
    /// from a panel, live GPU timings, screenshots (F12). With --script,
    /// --frames or --screenshot it plays, saves and exits (for tests).
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
}

const EXPERIMENT_ABOUT: &str = "\
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

A configuration slower than --cap-ms at a count skips the larger counts of that scenario.

The study's Sponza run: shadespace experiment overshading --scene ../shared/scenes/sponza-thesis \\
  --exclude sponza_plantsA,sponza_plantsB --out results/overshading";

/// The experiments, for `experiment NAME`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ExperimentChoice {
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
    /// Merge shards (`--shard K/N` runs) given as DIR... into --out: the summary, plots and report of one run.
    Merge,
}

#[derive(Args)]
struct ExperimentArgs {
    /// The experiment to run.
    #[arg(value_enum)]
    name: ExperimentChoice,
    // --- Sharded sweeps (src/experiments/quality.rs) ---
    /// `merge`: the shard folders to merge.
    #[arg(value_name = "DIR")]
    shards: Vec<PathBuf>,
    /// Run only the K-th of N disjoint parts of the grid (1 <= K <= N;
    /// `quality` only); `experiment merge DIR...` joins the parts.
    #[arg(long, value_name = "K/N", value_parser = shadespace::experiments::quality::Shard::from_str)]
    shard: Option<shadespace::experiments::quality::Shard>,
    /// `atrium` (default), `voxels`, or a path (see `render --help`), e.g.
    /// ../shared/scenes/sponza-thesis.
    #[arg(long, default_value = "atrium")]
    scene: String,
    /// Output folder (created; files in it are replaced). Default: experiment-NAME.
    #[arg(long)]
    out: Option<PathBuf>,
    /// A reduced grid (two small resolutions, tiles of 8 and 32, a few
    /// frames): under a minute on a CPU driver, for CI.
    #[arg(long)]
    quick: bool,
    /// Marking rules to count with, comma-separated: `study` (the reference
    /// study's, at 4096x4096 textures) and/or `bilinear` (ours, at 4096 and
    /// at our texel density).
    #[arg(long, value_delimiter = ',', default_value = "study,bilinear", value_parser = Marking::from_str)]
    marking: Vec<Marking>,
    /// Leave these objects out (comma-separated names; `shadespace charts`
    /// lists them). The study ran Sponza without sponza_plantsA,sponza_plantsB.
    #[arg(long, value_delimiter = ',')]
    exclude: Vec<String>,
    /// Tile sizes, comma-separated, instead of the grid's (8,16,32,64; quick: 8,32).
    #[arg(long, value_delimiter = ',', value_parser = parse_tile_size)]
    tile_sizes: Vec<u32>,
    /// Resolutions, comma-separated WIDTHxHEIGHT, instead of the grid's
    /// (800x600,1024x768,1920x1080,3840x2160; quick: 320x240,480x270).
    #[arg(long, value_delimiter = ',', value_parser = parse_size)]
    resolutions: Vec<(u32, u32)>,
    /// Our texel density (texels per metre) for the density variant.
    #[arg(long, default_value_t = 256.0, value_parser = texel_density)]
    texel_density: f32,
    /// Measure every K-th path frame (overshading) or frame pair (reuse's
    /// all-frames statistics; its windows stay whole) instead of all 600:
    /// K times less work, the same distribution sampled more thinly.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=600))]
    frame_step: Option<u32>,
    #[command(flatten)]
    timing: TimingArgs,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
#[command(next_help_heading = "Timing studies (lights, speedup)")]
struct TimingArgs {
    /// Image size, WIDTHxHEIGHT (default 1920x1080; quick: 160x90).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Measured frames per point (default 20; quick: 2).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// Frames rendered before each point's measured ones (default 5, speedup
    /// 4; quick: 1). For speedup keep warm-up + frames a multiple of 12, so
    /// that the compared last frame shows every reuse N of 1-4 at its oldest shades.
    #[arg(long)]
    warmup: Option<u32>,
    /// Light counts, comma-separated, instead of the grid's (for `speedup`: in every sweep).
    #[arg(long, value_delimiter = ',')]
    counts: Vec<u32>,
    /// Scenarios, comma-separated, instead of the grid's: small, big, shadowed, mixed-1:R.
    #[arg(long, value_delimiter = ',', value_parser = Scenario::from_str)]
    scenarios: Vec<Scenario>,
    /// A configuration whose median frame time passes this many ms at a
    /// count skips the larger counts of that scenario (default 200; quick: 10000).
    #[arg(long, value_parser = cap_ms)]
    cap_ms: Option<f64>,
}

#[derive(Args)]
struct CompareArgs {
    /// The reference image (e.g. forward shading).
    reference: PathBuf,
    /// The image under test (e.g. object-space shading).
    test: PathBuf,
    /// Also write the FLIP error map here.
    #[arg(long)]
    flip_map: Option<PathBuf>,
}

#[derive(Args)]
struct ChartsArgs {
    /// `atrium`, `voxels`, or a path (see `render --help`).
    #[arg(long, default_value = "atrium")]
    scene: String,
    #[command(flatten)]
    objectspace: ObjectSpaceArgs,
}

#[derive(Args, Clone)]
#[command(next_help_heading = "GPU")]
struct GpuArgs {
    /// Use the first adapter whose name contains this text (case-insensitive);
    /// also read from SHADESPACE_ADAPTER. Default: the fastest kind available.
    #[arg(long)]
    adapter: Option<String>,
}

/// `--textures`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum TextureChoice {
    File,
    Detailed,
}

#[derive(Args, Clone)]
struct SceneArgs {
    /// `atrium` (default), `voxels`, or a path: a .gltf/.glb file, an .obj file,
    /// or a folder of .obj files (e.g. ../shared/scenes/sponza-thesis).
    #[arg(long, default_value = "atrium")]
    scene: String,
    /// Shading pipeline.
    #[arg(long, value_enum, default_value = "forward")]
    pipeline: PipelineName,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// `path`: the scene's camera path (from cameras.json beside a shared
    /// scene; an orbit for atrium and voxels; for other scenes the file's
    /// first camera, or else a turntable framing the whole scene), `fixed:K`
    /// (fixed camera K, from 0; framed views for other scenes), `gltf:K`
    /// (camera K of the glTF file) or `bookmark:FILE:NAME` (the view saved as
    /// NAME, the text after the last colon, in the viewer's bookmark file FILE).
    #[arg(long, default_value = "path")]
    camera: String,
    /// Lights besides the ambient and directional light that every set has:
    /// `small:N` (each covers 0.25-5% of the screen), `big:N` (20-100%),
    /// `shadowed:N` (big lights that cast shadows: a quarter are spots),
    /// `mixed:N:R` (N such big lights, R small ones per big one), `none`,
    /// several joined with `+` (`small:100+big:2`), or a JSON light file.
    #[arg(long, default_value = "small:32")]
    lights: String,
    /// Seed of the light placement (same seed, same lights).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Exposure before tone mapping: a multiplier (positive, finite), or
    /// `auto`: computed on the GPU every frame, the HDR frame's log-average
    /// luminance over the pixels any light reached, mapped to mid-grey 0.18.
    /// Default: `auto` for a model seen from outside (a glTF or OBJ file
    /// framed automatically or seen through its own camera), 1 for scenes
    /// the camera moves through (the generated scenes, scenes with a camera
    /// file), as the studies and goldens use.
    #[arg(long, value_parser = parse_exposure)]
    exposure: Option<Exposure>,
    /// Bloom strength, 0 to 1: the fraction of the HDR image replaced by its
    /// glow (an average of blurs from half to 1/64 of the image size) before
    /// tone mapping; 0 (default) turns bloom off.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = bloom_strength)]
    bloom: f32,
    /// When shadow maps are rendered: `on-change` (default: a face again only
    /// when its view changes, i.e. its light changed or, for the sun's
    /// cascades, the camera moved; objects never move) or `every-frame` (the
    /// cost dynamic casters would have).
    #[arg(long, default_value = "on-change", value_parser = ShadowRefresh::from_str)]
    shadow_refresh: ShadowRefresh,
    /// `on`: the directional light (the sun) casts cascaded shadows (4
    /// cascades of 2048x2048 fitted to the view, 64 MiB, re-rendered when
    /// the camera moves). Default `off`: the generated sets' sun is a dim fill.
    #[arg(long, default_value = "off", value_parser = on_off, action = clap::ArgAction::Set)]
    sun_shadow: bool,
    /// Lighting model, the same in every pipeline: `phong` (default, the
    /// studies' model: materials' specular strength and exponent) or `pbr`
    /// (GGX metallic-roughness, as glTF 2.0 defines it: the materials'
    /// metallic and roughness factors; OBJ materials get roughness from `Ns`).
    #[arg(long, value_enum, default_value = "phong")]
    shading: ShadingModel,
    /// `file` (default): the scene's own textures (generated scenes: UV
    /// checkers); `detailed`: every material gets a procedural high-frequency
    /// albedo (bricks and grain down to 4 texels, tinted with its old
    /// texture's mean colour) and the matching normal map, 512x512 per
    /// repeat of its `uv0`: texture detail that shows what object-space
    /// shading blurs.
    #[arg(long, value_enum, default_value = "file")]
    textures: TextureChoice,
    /// Cull back faces in every pipeline (the compute rasterizer too), for
    /// scenes whose meshes are closed or seen from the front only: about
    /// half the rasterization work on Sponza. Default: both faces drawn.
    #[arg(long)]
    cull_back_faces: bool,
    /// Forward, deferred, deferred-compute: skip the depth pre-pass (shade or
    /// write the G-buffer for every rasterized fragment).
    #[arg(long)]
    no_depth_prepass: bool,
    /// Objectspace, deferred-compute: how pixels find their surface:
    /// `raster` (hardware visibility or G-buffer pass), `compute` (software
    /// rasterizer with 64-bit atomics; surfaces rebuilt from triangle ids) or
    /// `auto` (default: compute where the adapter has 64-bit atomics, which
    /// on the H100 is 1.7x (object space) to 2.2x (deferred-compute) faster
    /// at 1920x1080, else raster).
    #[arg(long, default_value = "auto", value_parser = visibility_choice)]
    visibility: VisibilityChoice,
    /// Compute visibility: count the rasterizer's work every frame
    /// (triangles per path, 32x32 tiles, 8x8 squares that pass the edge test,
    /// pixels tested, atomics per pixel) into the `--stats`/`bench`
    /// counters. Adds atomics: for profiling, not for timing.
    #[arg(long)]
    count_visibility: bool,
    // --- Material override (src/scene/gloss.rs) ---
    /// `default`: the scene's materials; `high`: every material with Phong
    /// exponent 1500, GGX roughness 0.05 and specular strength at least 1, to
    /// provoke specular aliasing (normal maps: the file's or --textures detailed).
    #[arg(long, value_enum, default_value = "default")]
    gloss: scene::gloss::Gloss,
    #[command(flatten)]
    free_camera: FreeCameraArgs,
    #[command(flatten)]
    objectspace: ObjectSpaceArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Clone)]
#[command(next_help_heading = "Free cameras (instead of --camera)")]
struct FreeCameraArgs {
    /// Place the camera at X,Y,Z (world metres, +y up) looking at --target;
    /// the near and far planes hold the whole scene.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_point,
          group = "free", requires = "target", conflicts_with = "camera")]
    eye: Option<Vec3>,
    /// The point --eye looks at, or --orbit circles (default for --orbit: the
    /// centre of the scene's bounds).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_point, requires = "free")]
    target: Option<Vec3>,
    /// Camera path circling --target: the eye RADIUS metres from it
    /// horizontally and HEIGHT metres above it, one turn in PERIOD frames
    /// (from the +x side towards +z).
    #[arg(long, value_name = "RADIUS,HEIGHT,PERIOD", allow_hyphen_values = true, value_parser = parse_orbit,
          group = "free", conflicts_with = "camera")]
    orbit: Option<OrbitArg>,
    /// Vertical field of view of --eye or --orbit, degrees (above 0, below 180).
    #[arg(long, value_name = "DEG", default_value_t = free_camera::DEFAULT_FOV_DEG, value_parser = fov_degrees,
          requires = "free")]
    fov: f32,
}

/// `--orbit RADIUS,HEIGHT,PERIOD`.
#[derive(Clone, Copy, Debug)]
struct OrbitArg {
    radius: f32,
    height: f32,
    frames: u32,
}

#[derive(Args, Clone)]
#[command(next_help_heading = "Object-space shading (--pipeline objectspace)")]
struct ObjectSpaceArgs {
    /// Tile side in texels: 8, 16, 32 or 64.
    #[arg(long, default_value_t = 8, value_parser = parse_tile_size)]
    tile_size: u32,
    /// Re-shade a visible tile when its shade is N frames old (1 = every frame).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    reuse: u32,
    /// Decoupled shading rate: shade each visible tile S times a second at
    /// --frame-hz frames a second (every R/S frames, rounded), spread evenly
    /// over the frames so that each frame shades about the same number of
    /// tiles. Replaces --reuse.
    #[arg(long, value_parser = hertz, conflicts_with = "reuse")]
    shade_hz: Option<f64>,
    /// The frame rate --shade-hz divides (frames a second).
    #[arg(long, default_value_t = 60.0, value_parser = hertz, requires = "shade_hz")]
    frame_hz: f64,
    /// Shading texels per metre of surface (above 0, at most 65536); an
    /// object's texture side is its charted area times this, rounded up to a
    /// power of two.
    #[arg(long, default_value_t = 256.0, value_parser = texel_density)]
    texel_density: f32,
    /// Give every object an S x S shading texture instead (the reference study used 4096).
    #[arg(long)]
    texture_size: Option<u32>,
    /// Added to every pixel's mip level (positive: coarser shading; -16 to 16).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = mip_bias)]
    mip_bias: f32,
    /// Most texels shaded per frame, in millions: above it every pixel's mip
    /// level is biased coarser (up to 8 levels, on top of --mip-bias) until
    /// the shading fits, and the bias falls back when there is room; the
    /// counters report it as `budget_bias`. Default: no limit.
    #[arg(long, value_parser = shade_budget)]
    shade_budget: Option<f64>,
    /// Variable rate: shade up to this many mip levels coarser where a
    /// triangle's normals do not vary (0 = off; at most 16).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = variable_rate)]
    variable_rate: f32,
    /// Most texels of the physical atlas, in Mi (12 bytes each with the
    /// triangle maps): the pages that back the objects' virtual textures
    /// where visible tiles need them. The atlas starts at this size, then
    /// follows the pages the frames need (in 32 steps, about 1.4 times
    /// them); when a frame needs more than the budget, the mip bias rises
    /// until it fits (the counters report `budget_bias` and `atlas_pages`).
    /// Default: 1 texel per pixel at 1920x1080 (2.1 Mi), growing as the
    /// square root of the pixels (4.1 Mi at 3840x2160), at least 1 Mi.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=MAX_ATLAS_BUDGET_MI))]
    atlas_budget: Option<u64>,
    /// Page side of the virtual textures in texels (a power of two, at most
    /// four times the tile size; raised to the tile size). Larger pages
    /// make a smaller page table but hold more texels no pixel needs.
    #[arg(long, default_value_t = DEFAULT_PAGE_SIZE)]
    page_size: u32,
    /// Skip the depth pre-pass before the visibility (id) pass (with it, each
    /// pixel's ids are written once; measured faster on the H100).
    #[arg(long)]
    no_visibility_prepass: bool,
    /// More views marking into the same atlas in each frame, each tile shaded
    /// once for all (compute visibility): `stereo:D` (a right eye D scene
    /// units to the right of the camera) or `fixed` (the scene's fixed
    /// cameras other than --camera's). `render` writes view K beside --out
    /// as NAME-viewK.png.
    #[arg(long, value_parser = parse_views)]
    views: Option<ViewsArg>,
    /// Shade these objects (comma-separated names) forward instead of in object space.
    #[arg(long, value_delimiter = ',')]
    forward_only: Vec<String>,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Frame index on the camera path (frames are numbered, never timed).
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    frame: u32,
    /// Output image (PNG).
    #[arg(help_heading = "Frame and output", long, default_value = "shadespace.png")]
    out: PathBuf,
    /// Also write the frame's statistics (and GPU pass times) as JSON here.
    #[arg(help_heading = "Frame and output", long)]
    stats: Option<PathBuf>,
    /// Render the K path frames before --frame first (not saved), so that
    /// reuse and the tile-mask and cache-age views have a history.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    history: u32,
    /// Object space: write a debug view instead of the shaded image: `shade`,
    /// `chart-uv`, `mip-level`, `tile-mask` (red: shaded this frame, green:
    /// reused), `cache-age`, `atlas-pages` (level --atlas-level of object
    /// --atlas-object's shading texture, found through the page table as
    /// the frame left it: backed pages show their shades, the others a dark
    /// checker; a square frame of the level's size shows a texel per pixel).
    #[arg(help_heading = "Frame and output", long, default_value = "shade", value_parser = DebugView::from_str)]
    view: DebugView,
    /// Object space: also write one mip level (--atlas-level) of one object's
    /// shading texture here (pages with no physical page magenta).
    #[arg(help_heading = "Frame and output", long)]
    atlas_out: Option<PathBuf>,
    /// Object space: the object (index, see `shadespace charts`) for
    /// --atlas-out and --view atlas-pages.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    atlas_object: usize,
    /// Object space: the mip level (0 the finest) for --atlas-out and --view atlas-pages.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    atlas_level: usize,
    /// Also write the frame's GPU pass times as a Chrome trace (open in
    /// chrome://tracing or ui.perfetto.dev).
    #[arg(help_heading = "Frame and output", long)]
    trace: Option<PathBuf>,
    // --- Reference images (src/reference/) ---
    /// Write the frame's supersampled reference instead: forward shading at
    /// N x N sub-pixel offsets per pixel (N from 4 to 32), averaged in linear
    /// HDR before tone mapping with --exposure; cached in
    /// $SHADESPACE_CACHE_DIR/references.
    #[arg(help_heading = "Reference", long, value_name = "N", value_parser = clap::value_parser!(u32).range(4..=32))]
    reference: Option<u32>,
}

/// The shading pipelines, for `--pipeline`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum PipelineName {
    /// Single-pass forward: one draw per object, fragments loop over its CPU light list (the reference).
    Forward,
    /// Multi-pass forward: depth pre-pass, then one additive pass per light over the objects it reaches.
    ForwardMultipass,
    /// Clustered forward: fragments lit by GPU-built view-space light clusters.
    Clustered,
    /// Deferred shading: G-buffer, then light volumes (spheres, cones) blended per light.
    Deferred,
    /// Tiled deferred shading: G-buffer, then one compute pass culls and shades 16x16 tiles.
    DeferredCompute,
    /// Object-space (texel) shading: visible tiles shaded by compute into an atlas, reused, gathered.
    Objectspace,
}

#[derive(Args)]
struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Measured frames (the camera path repeats if it is shorter).
    #[arg(help_heading = "Frames and output", long, default_value_t = 600)]
    frames: u32,
    /// Frames rendered first and not measured.
    #[arg(help_heading = "Frames and output", long, default_value_t = 60)]
    warmup: u32,
    /// Measured frame i shows path frame i x STEP (mod the path length): a
    /// shorter run that still covers the whole path. Reuse between frames
    /// shrinks as the step grows.
    #[arg(help_heading = "Frames and output", long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    frame_step: u32,
    /// Result JSON.
    #[arg(help_heading = "Frames and output", long, default_value = "bench.json")]
    out: PathBuf,
    /// No progress bar.
    #[arg(help_heading = "Frames and output", long)]
    quiet: bool,
}

/// A finite number in `range`, for a flag whose meaning needs one.
fn finite_in(s: &str, range: std::ops::RangeInclusive<f32>, what: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && range.contains(&v) => Ok(v),
        Ok(_) => Err(format!("'{s}' is not {what}")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

fn parse_exposure(s: &str) -> Result<Exposure, String> {
    if s.trim() == "auto" {
        return Ok(Exposure::Auto);
    }
    let what = "auto or a positive finite number";
    finite_in(s, f32::MIN_POSITIVE..=f32::MAX, what).map(Exposure::Fixed).map_err(|_| format!("'{s}' is not {what}"))
}

/// Comma-separated finite numbers, exactly `N` of them.
fn numbers<const N: usize>(s: &str, form: &str) -> Result<[f32; N], String> {
    let values: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || format!("'{s}' is not {form} ({N} finite numbers separated by commas)");
    if values.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(values) {
        *o = v.parse::<f32>().ok().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(out)
}

fn parse_point(s: &str) -> Result<Vec3, String> {
    numbers::<3>(s, "X,Y,Z").map(Vec3::from)
}

fn parse_orbit(s: &str) -> Result<OrbitArg, String> {
    let [radius, height, period] = numbers::<3>(s, "RADIUS,HEIGHT,PERIOD")?;
    if radius <= 0.0 {
        return Err(format!("'{s}': the radius {radius} is not positive"));
    }
    if period < 1.0 || period.fract() != 0.0 || period > u32::MAX as f32 {
        return Err(format!("'{s}': the period {period} is not a whole number of frames of at least 1"));
    }
    Ok(OrbitArg { radius, height, frames: period as u32 })
}

fn fov_degrees(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 && v < 180.0 => Ok(v),
        Ok(_) => Err(format!("'{s}' is not a field of view above 0 and below 180 degrees")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

fn on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{s}' is not on or off")),
    }
}

/// `--visibility`: a method, or `auto` (`None`: chosen once the adapter is known).
#[derive(Clone, Copy, Debug)]
struct VisibilityChoice(Option<VisibilityMethod>);

fn visibility_choice(s: &str) -> Result<VisibilityChoice, String> {
    match s {
        "auto" => Ok(VisibilityChoice(None)),
        _ => VisibilityMethod::from_str(s)
            .map(|m| VisibilityChoice(Some(m)))
            .map_err(|_| format!("'{s}' is not auto, raster or compute")),
    }
}

fn bloom_strength(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=1.0, "a strength from 0 to 1")
}

/// `--views`: the extra views that share the atlas.
#[derive(Clone, Copy, Debug)]
enum ViewsArg {
    Stereo(f32),
    Fixed,
}

fn parse_views(s: &str) -> Result<ViewsArg, String> {
    if s == "fixed" {
        return Ok(ViewsArg::Fixed);
    }
    let d = s.strip_prefix("stereo:").ok_or_else(|| format!("'{s}': expected 'stereo:D' or 'fixed'"))?;
    match d.parse::<f32>() {
        Ok(d) if d.is_finite() && d > 0.0 => Ok(ViewsArg::Stereo(d)),
        _ => Err(format!("'{d}': the eye distance must be a number above 0")),
    }
}

fn hertz(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1000.0 {
        Ok(v)
    } else {
        Err(format!("{s} is not a rate above 0 and at most 1000"))
    }
}

fn texel_density(s: &str) -> Result<f32, String> {
    finite_in(s, f32::MIN_POSITIVE..=65536.0, "a density above 0 and at most 65536 texels per metre")
}

fn shade_budget(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0e6 {
        Ok(v)
    } else {
        Err(format!("'{s}' is not a number of millions of texels above 0 and at most 1e6"))
    }
}

fn mip_bias(s: &str) -> Result<f32, String> {
    finite_in(s, -16.0..=16.0, "a bias from -16 to 16 levels")
}

fn variable_rate(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=16.0, "a strength from 0 to 16 levels")
}

fn cap_ms(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a frame time above 0 ms")),
    }
}

fn parse_tile_size(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(t @ (8 | 16 | 32 | 64)) => Ok(t),
        _ => Err(format!("'{s}' is not one of 8, 16, 32, 64")),
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT (e.g. 1920x1080)"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|v| (1..=16384).contains(v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("'{s}': width and height must be whole numbers from 1 to 16384")),
    }
}

#[cfg(feature = "viewer")]
mod view;

/// Errors caused by the user's input exit with status 2; others with 1.
struct InputError(anyhow::Error);

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,wgpu_hal=error,wgpu_core=error,naga=error".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render(a),
        Command::Bench(a) => run_bench(a),
        Command::Info(a) => info(a),
        Command::Charts(a) => print_charts(a),
        Command::Compare(a) => compare(a),
        Command::Experiment(a) => experiment(a),
        #[cfg(feature = "viewer")]
        Command::View(a) => view::view(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(InputError(e))) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
        Err(Failure::Other(e)) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

enum Failure {
    Input(InputError),
    Other(anyhow::Error),
}

impl<E: Into<anyhow::Error>> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure::Other(e.into())
    }
}

fn input<T, E: Into<anyhow::Error>>(r: Result<T, E>) -> Result<T, Failure> {
    r.map_err(|e| Failure::Input(InputError(e.into())))
}

/// The scene, its cameras and its lights, as the options describe them.
struct Setup {
    scene: Scene,
    /// Object space: shading-texture side per object.
    texture_sizes: Option<Vec<Option<u32>>>,
    path: CameraPath,
    camera_label: String,
    lights: Vec<Light>,
    lights_spec: String,
    /// Object space: views besides the camera's.
    extra_views: ExtraViews,
    /// `--exposure`, or its default for how the scene is seen.
    exposure: Exposure,
}

fn setup(a: &SceneArgs) -> Result<Setup, Failure> {
    let os = &a.objectspace;
    let (page, tile) = (os.page_size, os.tile_size);
    if !page.is_power_of_two() || page > 4 * tile {
        return input(Err(anyhow::anyhow!(
            "--page-size {page}: expected a power of two at most four times the tile size ({tile})"
        )));
    }
    if os.views.is_some() && a.visibility.0 == Some(VisibilityMethod::Raster) {
        return input(Err(anyhow::anyhow!("--views needs compute visibility, not --visibility raster")));
    }
    let mut scene = input(scene::load(&a.scene))?;
    scene.cull_back_faces = a.cull_back_faces;
    if a.textures == TextureChoice::Detailed {
        scene::detail::add_detailed_textures(&mut scene);
    }
    scene::gloss::apply(&mut scene, a.gloss);
    for name in &a.objectspace.forward_only {
        let Some(o) = scene.objects.iter_mut().find(|o| &o.name == name) else {
            let known: Vec<_> = scene.objects.iter().map(|o| o.name.as_str()).collect();
            return input(Err(anyhow::anyhow!("--forward-only: no object '{name}' (objects: {})", known.join(", "))));
        };
        o.forward_only = true;
    }
    let bounds = scene.bounds();
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let cameras = input(path::cameras_for_scene(&a.scene, &scene, aspect))?;
    let (path, camera_label) = camera_path(a, &cameras, &bounds)?;
    let extra_views = match a.objectspace.views {
        None => ExtraViews::None,
        Some(ViewsArg::Stereo(eye_distance)) => ExtraViews::Stereo { eye_distance },
        Some(ViewsArg::Fixed) => {
            let own = match a.camera.parse() {
                Ok(path::CameraChoice::Fixed(k)) => Some(k),
                _ => None,
            };
            let others = cameras.fixed.iter().enumerate().filter(|(k, _)| Some(*k) != own).map(|(_, c)| *c);
            ExtraViews::Cameras(others.collect())
        }
    };
    let (lights, lights_spec) = light_set(a, &cameras.light_region(&bounds), &path)?;
    let (scene, texture_sizes) = if a.pipeline == PipelineName::Objectspace {
        let (charted, charts) = chart(&scene, &a.objectspace)?;
        (charted, Some(charts.texture_sizes()))
    } else {
        (scene, None)
    };
    let exposure =
        a.exposure.unwrap_or(if cameras.source.seen_from_outside() { Exposure::Auto } else { Exposure::default() });
    Ok(Setup { scene, texture_sizes, path, camera_label, lights, lights_spec, extra_views, exposure })
}

/// The `--lights` set placed in `region` for the path's first camera, and
/// its spec as text.
fn light_set(a: &SceneArgs, region: &Aabb, path: &CameraPath) -> Result<(Vec<Light>, String), Failure> {
    let spec: LightSpec = input(a.lights.parse())?;
    let reference: Camera = path.camera_at(0);
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let lights = input(lights::build_lights(&spec, region, &reference, aspect, a.seed))?;
    Ok((lights, spec.to_string()))
}

/// The camera path the options ask for, and its label for reports: a free
/// camera (`--eye`, `--orbit`) or one of the scene's (`--camera`).
fn camera_path(a: &SceneArgs, cameras: &SceneCameras, bounds: &Aabb) -> Result<(CameraPath, String), Failure> {
    let f = &a.free_camera;
    let fov = f.fov;
    if let (Some(eye), Some(target)) = (f.eye, f.target) {
        let camera = LookAt { eye, target, fov_deg: fov }.camera(bounds);
        let camera = input(camera.context("--eye, --target"))?;
        let label = format!("eye {} target {} fov {fov}", xyz(eye), xyz(target));
        return Ok((CameraPath::Fixed(camera), label));
    }
    if let Some(o) = f.orbit {
        let spec = OrbitSpec { radius: o.radius, height: o.height, frames: o.frames, target: f.target, fov_deg: fov };
        let turntable = input(spec.turntable(bounds).context("--orbit"))?;
        let label = format!("orbit {},{},{} target {} fov {fov}", o.radius, o.height, o.frames, xyz(turntable.target));
        return Ok((CameraPath::Turntable(turntable), label));
    }
    if let Some(mark) = input(BookmarkRef::from_camera_arg(&a.camera).context("--camera"))? {
        let look = input(mark.find().context("--camera"))?;
        let camera = input(look.camera(bounds).with_context(|| format!("--camera {mark}")))?;
        return Ok((CameraPath::Fixed(camera), a.camera.clone()));
    }
    let choice: path::CameraChoice = input(a.camera.parse().context("--camera"))?;
    Ok((input(cameras.select(choice).context("--camera"))?, a.camera.clone()))
}

fn xyz(v: Vec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

impl Setup {
    fn bench_setup<'a>(&'a self, a: &SceneArgs) -> BenchSetup<'a> {
        BenchSetup {
            scene_name: &self.scene.name,
            objects: self.scene.objects.len(),
            lights_spec: &self.lights_spec,
            seed: a.seed,
            camera: &self.camera_label,
        }
    }
}

/// Renderer options from the command line, for object space the texture
/// sizes the charts gave, and for `--visibility auto` the adapter's features.
fn render_options(a: &SceneArgs, s: &Setup, view: DebugView, features: wgpu::Features) -> RenderOptions {
    let visibility = a.visibility.0.unwrap_or_else(|| VisibilityMethod::preferred(features));
    let pipeline = match a.pipeline {
        PipelineName::Forward => PipelineConfig::Forward(ForwardConfig { depth_prepass: !a.no_depth_prepass }),
        PipelineName::ForwardMultipass => PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineName::Clustered => PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineName::Objectspace => PipelineConfig::ObjectSpace(ObjectSpaceConfig {
            tile_size: a.objectspace.tile_size,
            reuse: match a.objectspace.shade_hz {
                Some(hz) => (a.objectspace.frame_hz / hz).round().max(1.0) as u32,
                None => a.objectspace.reuse,
            },
            spread_reshading: a.objectspace.shade_hz.is_some(),
            page_size: a.objectspace.page_size,
            mip_bias: a.objectspace.mip_bias,
            shade_budget_texels: a.objectspace.shade_budget.map(|m| (m * 1.0e6) as u64),
            variable_rate: a.objectspace.variable_rate,
            view,
            texture_sizes: s.texture_sizes.clone().unwrap_or_default(),
            extra_views: s.extra_views.clone(),
            atlas_budget_texels: a.objectspace.atlas_budget.map(|m| m << 20),
            visibility_prepass: !a.objectspace.no_visibility_prepass,
            visibility,
            count_visibility: a.count_visibility,
        }),
        PipelineName::Deferred => PipelineConfig::Deferred(DeferredConfig { depth_prepass: !a.no_depth_prepass }),
        PipelineName::DeferredCompute => PipelineConfig::DeferredCompute(DeferredComputeConfig {
            depth_prepass: !a.no_depth_prepass,
            visibility,
            count_visibility: a.count_visibility,
        }),
    };
    RenderOptions { width: a.size.0, height: a.size.1, pipeline }
}

/// The texture sizing the options ask for.
fn sizing(a: &ObjectSpaceArgs) -> Result<TextureSizing, Failure> {
    match a.texture_size {
        Some(size) if size.is_power_of_two() && (8..=MAX_TEXTURE_SIZE).contains(&size) => {
            Ok(TextureSizing::Fixed(size))
        }
        Some(size) => {
            input(Err(anyhow::anyhow!("--texture-size {size} is not a power of two from 8 to {MAX_TEXTURE_SIZE}")))
        }
        // The value parser has checked the density.
        None => Ok(TextureSizing::Density { texels_per_metre: a.texel_density, min: 64, max: MAX_DENSITY_SIZE }),
    }
}

/// Charts every object shaded in object space; returns the scene with its
/// charts in `uv1` and the charts (texture sizes, sources).
fn chart(scene: &Scene, a: &ObjectSpaceArgs) -> Result<(Scene, SceneCharts), Failure> {
    let charts = charts::chart_scene(scene, &sizing(a)?, &ChartCache::from_env())?;
    Ok((charts.apply(scene), charts))
}

fn open_gpu(a: &GpuArgs) -> Result<GpuContext, Failure> {
    Ok(GpuContext::new(&GpuOptions { adapter: a.adapter.clone() })?)
}

/// The renderer settings the scene options choose (besides the pipeline).
fn configure(renderer: &mut Renderer, a: &SceneArgs, s: &Setup) {
    renderer.exposure = s.exposure;
    renderer.bloom = a.bloom;
    renderer.shadow_refresh = a.shadow_refresh;
    renderer.sun_shadow = a.sun_shadow;
    renderer.shading = a.shading;
}

fn render(a: RenderArgs) -> Result<(), Failure> {
    if let Some(n) = a.reference {
        return render_reference(&a, n);
    }
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer = Renderer::new(&ctx, &s.scene, &render_options(&a.scene, &s, a.view, ctx.device.features()))?;
    configure(&mut renderer, &a.scene, &s);
    if a.atlas_out.is_some() || a.view == DebugView::AtlasPages {
        let Some(os) = renderer.pipeline_mut::<ObjectSpace>() else {
            return input(Err(anyhow::anyhow!("--atlas-out and --view atlas-pages need --pipeline objectspace")));
        };
        input(os.set_atlas_pages(AtlasPages { object: a.atlas_object, level: a.atlas_level }))?;
    }
    // The history frames are the warm-up of a one-frame run.
    let history = a.history.min(a.frame);
    let plan =
        BenchPlan { path: &s.path, lights: &s.lights, warmup: history, frames: 1, first: a.frame - history, step: 1 };
    let report = bench::run(&ctx, &mut renderer, &plan, &s.bench_setup(&a.scene), |_| {})?;
    let image = renderer.read_image(&ctx)?;
    save_png(&image, &a.out)?;
    if let Some(os) = renderer.pipeline::<ObjectSpace>() {
        // --views: each extra view's image beside the first, as NAME-viewK.png.
        for k in 1..=os.extra_view_count() {
            let stem = a.out.file_stem().and_then(|s| s.to_str()).unwrap_or("shadespace");
            save_png(&input(os.read_extra_view(&ctx, k))?, &a.out.with_file_name(format!("{stem}-view{k}.png")))?;
        }
    }
    if let (Some(path), Some(os)) = (&a.atlas_out, renderer.pipeline::<ObjectSpace>()) {
        save_png(&input(os.read_atlas(&ctx, a.atlas_object, a.atlas_level))?, path)?;
    }
    if let Some(path) = &a.trace {
        write_trace(&renderer, path)?;
    }
    println!(
        "{}: {} ({} objects, {} triangles), {} lights, {}x{}, {} -> {}",
        renderer.pipeline_name(),
        s.scene.name,
        s.scene.objects.len(),
        s.scene.triangle_count(),
        s.lights.len(),
        w,
        h,
        ctx.info.name,
        a.out.display()
    );
    if renderer.exposure == Exposure::Auto {
        println!("  exposure auto: {:.4}", renderer.read_exposure(&ctx)?);
    }
    for f in &report.per_frame {
        for p in &f.gpu_passes {
            println!("  {:<16} {:8.3} ms GPU", p.pass, p.ms);
        }
        let c = |name: &str| f.counters.get(name).copied();
        if let (Some(visible), Some(shaded), Some(reused), Some(new), Some(overshading)) =
            (c("visible_tiles"), c("shaded_tiles"), c("reused_tiles"), c("new_tiles"), c("overshading"))
        {
            println!(
                "  tiles: {visible} visible, {shaded} shaded, {reused} reused, {new} new; {overshading:.2} visible texels per pixel"
            );
        }
    }
    if let Some(path) = &a.stats {
        write_report(&report, path)?;
    }
    Ok(())
}

// --- Reference images (src/reference/) ---

/// `render --reference N`: the frame's supersampled reference, from the cache
/// when it holds it.
fn render_reference(a: &RenderArgs, n: u32) -> Result<(), Failure> {
    use shadespace::reference::{ReferenceCache, ReferenceSettings, ReferenceView, References};
    if a.scene.pipeline != PipelineName::Forward {
        return input(Err(anyhow::anyhow!("--reference renders with forward shading: leave out --pipeline")));
    }
    if a.scene.bloom != 0.0 {
        return input(Err(anyhow::anyhow!("--reference is resolved before bloom: leave out --bloom")));
    }
    if a.stats.is_some() || a.trace.is_some() || a.history != 0 || a.atlas_out.is_some() {
        return input(Err(anyhow::anyhow!(
            "--reference writes an image only (no --stats, --trace, --history, --atlas-out)"
        )));
    }
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (width, height) = a.scene.size;
    let settings = ReferenceSettings {
        width,
        height,
        shading: a.scene.shading,
        sun_shadow: a.scene.sun_shadow,
        exposure: s.exposure,
    };
    let mut references = References::new(&ctx, &s.scene, settings, ReferenceCache::from_env());
    let camera = s.path.camera_at(a.frame);
    let (reference, cached) = references
        .get(&ReferenceView { camera: &camera, lights: &s.lights, samples: n })
        .map_err(anyhow::Error::new)?;
    save_png(&reference.image(), &a.out)?;
    println!(
        "reference {n}x{n}: {} ({} objects), {} lights, {width}x{height}, exposure {:.4}, {} -> {} ({})",
        s.scene.name,
        s.scene.objects.len(),
        s.lights.len(),
        reference.exposure,
        ctx.info.name,
        a.out.display(),
        if cached { "from the cache" } else { "rendered" }
    );
    Ok(())
}

fn write_report(report: &RunReport, path: &Path) -> Result<(), Failure> {
    write_file(path, serde_json::to_string_pretty(report)?.as_bytes())
}

/// Writes the GPU trace through a temporary file, like every other output.
fn write_trace(renderer: &Renderer, path: &Path) -> Result<(), Failure> {
    let tmp = temp_path(path);
    match renderer.write_trace(&tmp) {
        Ok(true) => input(std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))),
        Ok(false) => {
            tracing::warn!("--trace: the adapter has no timestamp queries; no trace written");
            Ok(())
        }
        Err(e) => input(Err(anyhow::Error::new(e).context(format!("{}: cannot write", path.display())))),
    }
}

fn run_bench(a: BenchArgs) -> Result<(), Failure> {
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer =
        Renderer::new(&ctx, &s.scene, &render_options(&a.scene, &s, DebugView::Shade, ctx.device.features()))?;
    configure(&mut renderer, &a.scene, &s);
    if !renderer.timing_enabled() {
        tracing::warn!("{} has no timestamp queries: the result has CPU times only", ctx.info.name);
    }
    let total = (a.warmup + a.frames) as u64;
    let bar = if a.quiet { ProgressBar::hidden() } else { ProgressBar::new(total) };
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} frames, {elapsed} elapsed, eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(format!("{} {}", renderer.pipeline_name(), s.scene.name));
    let plan = BenchPlan {
        path: &s.path,
        lights: &s.lights,
        warmup: a.warmup,
        frames: a.frames,
        first: 0,
        step: a.frame_step,
    };
    let result = bench::run(&ctx, &mut renderer, &plan, &s.bench_setup(&a.scene), |i| bar.set_position(i as u64))?;
    bar.finish_and_clear();
    write_report(&result, &a.out)?;
    let summary = &result.summary;
    println!(
        "{} {} {}x{} lights {} ({}): GPU frame median {:.3} ms, p95 {:.3} ms; CPU {:.3} ms  -> {}",
        renderer.pipeline_name(),
        result.scene,
        w,
        h,
        result.lights_spec,
        result.light_count,
        summary.gpu_frame_ms.median,
        summary.gpu_frame_ms.p95,
        summary.cpu_frame_ms.median,
        a.out.display()
    );
    for (name, s) in &summary.gpu_passes_ms {
        println!("  {name:<16} median {:8.3} ms  p95 {:8.3} ms", s.median, s.p95);
    }
    Ok(())
}

fn print_charts(a: ChartsArgs) -> Result<(), Failure> {
    let scene = input(scene::load(&a.scene))?;
    let (_, charts) = chart(&scene, &a.objectspace)?;
    print!("{charts}");
    Ok(())
}

fn compare(a: CompareArgs) -> Result<(), Failure> {
    let load = |p: &Path| {
        input(image::open(p).map(|i| i.to_rgba8()).with_context(|| format!("{}: cannot read image", p.display())))
    };
    let (reference, test) = (load(&a.reference)?, load(&a.test)?);
    if reference.dimensions() != test.dimensions() {
        return input(Err(anyhow::anyhow!(
            "{} is {:?} but {} is {:?}",
            a.reference.display(),
            reference.dimensions(),
            a.test.display(),
            test.dimensions()
        )));
    }
    let (err, map) = shadespace::metrics::compare(&reference, &test);
    println!(
        "FLIP mean {:.4}  PSNR {:.2} dB  SSIM {:.4}  max channel difference {}",
        err.flip_mean, err.psnr_db, err.ssim, err.max_abs
    );
    if let Some(path) = &a.flip_map {
        let mut bytes = Vec::new();
        map.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).context("encoding PNG")?;
        write_file(path, &bytes)?;
    }
    Ok(())
}

fn experiment(a: ExperimentArgs) -> Result<(), Failure> {
    let name = match a.name {
        ExperimentChoice::Overshading => ExperimentName::Overshading,
        ExperimentChoice::Overlap => ExperimentName::Overlap,
        ExperimentChoice::Reuse => ExperimentName::Reuse,
        ExperimentChoice::Lights => ExperimentName::Lights,
        ExperimentChoice::Speedup => ExperimentName::Speedup,
        ExperimentChoice::Quality => ExperimentName::Quality,
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
    let timing = name.timing_grid(a.quick).map(|g| timing_grid(g, &a.timing));
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

// --- Sharded sweeps (src/experiments/quality.rs) ---

/// `experiment merge DIR...`: the shards' rows as one run's outputs in --out.
fn merge_shards(a: &ExperimentArgs) -> Result<(), Failure> {
    if a.shards.is_empty() {
        return input(Err(anyhow::anyhow!("experiment merge: name the shard folders (DIR...)")));
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("experiment-quality"));
    if out.exists() && !out.is_dir() {
        return input(Err(anyhow::anyhow!("--out {}: exists and is not a folder", out.display())));
    }
    let written = input(shadespace::experiments::quality::merge(&a.shards, &out, &command_line()))?;
    println!("quality (merged): {} -> {}", written.headline, written.report.display());
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
    if !a.scenarios.is_empty() {
        // Keep each listed scenario's own counts where the grid has it (speedup's sweeps differ).
        let counts = |s: Scenario| {
            grid.sweeps.iter().find(|w| w.scenario == s).or(grid.sweeps.first()).map(|w| w.counts.clone())
        };
        grid.sweeps =
            a.scenarios.iter().map(|&s| Sweep { scenario: s, counts: counts(s).unwrap_or_default() }).collect();
    }
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

/// The command line as typed, arguments with spaces or quotes single-quoted.
fn command_line() -> String {
    std::env::args().map(|a| shell_quote(&a)).collect::<Vec<_>>().join(" ")
}

/// A word as a shell reads it back: single-quoted when it holds spaces or quotes.
fn shell_quote(s: &str) -> String {
    if s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@".contains(c)) {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

fn info(a: GpuArgs) -> Result<(), Failure> {
    println!("pipelines (--pipeline):");
    for p in PipelineName::value_variants().iter().filter_map(|v| v.to_possible_value()) {
        println!("  {:<18} {}", p.get_name(), p.get_help().map(|h| h.to_string()).unwrap_or_default());
    }
    println!("adapters:");
    for line in shadespace::gpu::list_adapters() {
        println!("  {line}");
    }
    let ctx = open_gpu(&a)?;
    print!("{}", ctx.report());
    Ok(())
}

fn save_png(image: &image::RgbaImage, path: &Path) -> Result<(), Failure> {
    let mut bytes = Vec::new();
    image.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).context("encoding PNG")?;
    write_file(path, &bytes)
}

/// The temporary file an output is written to before its rename.
fn temp_path(path: &Path) -> PathBuf {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    dir.join(format!(".{}.tmp", path.file_name().and_then(|n| n.to_str()).unwrap_or("out")))
}

/// Writes through a temporary file and a rename, so that a failed run never
/// leaves a truncated result behind.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    let tmp = temp_path(path);
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    input(result.with_context(|| format!("{}: cannot write", path.display())))
}
