//! The `shadespace` command line: parse, call the library, print.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use shadespace::bench::{self, BenchSetup};
use shadespace::charts::{self, ChartCache, SceneCharts, TextureSizing};
use shadespace::gpu::{GpuContext, GpuOptions};
use shadespace::render::objectspace::{DebugView, MAX_PAGE_SIZE, ObjectSpaceOptions};
use shadespace::render::{PipelineKind, RenderOptions, Renderer};
use shadespace::scene::{self, Camera, CameraPath, Light, LightSpec, Scene, lights, path};

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
    /// List the GPU adapters, and the features and limits of the chosen one.
    Info(GpuArgs),
    /// Print, per object, where its unique UV layout (chart) comes from, its
    /// overlap, surface area, texel density and shading-texture size.
    Charts(ChartsArgs),
    /// Compare two images: mean FLIP error, PSNR, largest channel difference.
    Compare(CompareArgs),
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

#[derive(Args)]
#[command(next_help_heading = "GPU")]
struct GpuArgs {
    /// Use the first adapter whose name contains this text (case-insensitive);
    /// also read from SHADESPACE_ADAPTER. Default: the fastest kind available.
    #[arg(long)]
    adapter: Option<String>,
}

#[derive(Args)]
struct SceneArgs {
    /// `atrium` (default), `voxels`, or a path: a .gltf/.glb file, an .obj file,
    /// or a folder of .obj files (e.g. ../shared/scenes/sponza-thesis).
    #[arg(long, default_value = "atrium")]
    scene: String,
    /// Shading pipeline.
    #[arg(long, value_enum, default_value = "forward")]
    pipeline: PipelineKind,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// `path` (the scene's camera path; from cameras.json beside a shared scene,
    /// an orbit for other scenes) or `fixed:K` (fixed camera K, from 0).
    #[arg(long, default_value = "path")]
    camera: String,
    /// Lights besides the ambient and directional light that every set has:
    /// `small:N` (each covers 0.25-5% of the screen), `big:N` (20-100%),
    /// `shadowed:N` (big, casting shadows), `mixed:N:R` (N shadowed big lights,
    /// R small ones per big one), `none`, several joined with `+`
    /// (`small:100+shadowed:2`), or the path of a JSON light file.
    #[arg(long, default_value = "small:32")]
    lights: String,
    /// Seed of the light placement (same seed, same lights).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Exposure multiplier applied before tone mapping.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Forward: skip the depth pre-pass (shade every rasterized fragment).
    #[arg(long)]
    no_depth_prepass: bool,
    #[command(flatten)]
    objectspace: ObjectSpaceArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
#[command(next_help_heading = "Object-space shading (--pipeline objectspace)")]
struct ObjectSpaceArgs {
    /// Tile side in texels: 8, 16, 32 or 64.
    #[arg(long, default_value_t = 8, value_parser = parse_tile_size)]
    tile_size: u32,
    /// Re-shade a visible tile when its shade is N frames old (1 = every frame).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    reuse: u32,
    /// Shading texels per metre of surface; an object's texture side is its
    /// charted area times this, rounded up to a power of two.
    #[arg(long, default_value_t = 256.0)]
    texel_density: f32,
    /// Give every object an S x S shading texture instead (the reference study used 4096).
    #[arg(long)]
    texture_size: Option<u32>,
    /// Added to every pixel's mip level (positive: coarser shading).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    mip_bias: f32,
    /// Variable rate: shade up to this many mip levels coarser where a
    /// triangle's normals do not vary (0 = off).
    #[arg(long, default_value_t = 0.0)]
    variable_rate: f32,
    /// Atlas budget in Mi texels (all objects, mip chains included; 12 bytes
    /// each with the triangle maps); texture sizes are halved until they fit.
    #[arg(long, default_value_t = 64)]
    atlas_budget: u64,
    /// Skip the depth pre-pass before the visibility (id) pass (with it, each
    /// pixel's ids are written once; measured faster on the H100).
    #[arg(long)]
    no_visibility_prepass: bool,
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
    /// Object space: write a debug view instead of the shaded image.
    #[arg(help_heading = "Frame and output", long, value_enum, default_value = "shade")]
    view: DebugView,
    /// Object space: also write mip 0 of one object's shading texture here.
    #[arg(help_heading = "Frame and output", long)]
    atlas_out: Option<PathBuf>,
    /// Object space: the object (index, see `shadespace charts`) for --atlas-out.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    atlas_object: usize,
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
}

fn setup(a: &SceneArgs) -> Result<Setup, Failure> {
    let mut scene = input(scene::load(&a.scene))?;
    for name in &a.objectspace.forward_only {
        let Some(o) = scene.objects.iter_mut().find(|o| &o.name == name) else {
            let known: Vec<_> = scene.objects.iter().map(|o| o.name.as_str()).collect();
            return input(Err(anyhow::anyhow!("--forward-only: no object '{name}' (objects: {})", known.join(", "))));
        };
        o.forward_only = true;
    }
    let bounds = scene.bounds();
    let choice: path::CameraChoice = input(a.camera.parse())?;
    let cameras = input(path::cameras_for_scene(&a.scene, &bounds))?;
    let path = input(cameras.select(choice))?;
    let spec: LightSpec = input(a.lights.parse())?;
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let reference: Camera = path.camera_at(0);
    let lights = input(lights::build_lights(&spec, &bounds, &reference, aspect, a.seed))?;
    let (scene, texture_sizes) = if a.pipeline == PipelineKind::ObjectSpace {
        let (charted, charts) = chart(&scene, &a.objectspace)?;
        (charted, Some(charts.texture_sizes()))
    } else {
        (scene, None)
    };
    Ok(Setup { scene, texture_sizes, path, camera_label: a.camera.clone(), lights, lights_spec: spec.to_string() })
}

/// Renderer options from the command line and, for object space, the
/// texture sizes the charts gave.
fn render_options(
    a: &SceneArgs,
    texture_sizes: &Option<Vec<Option<u32>>>,
    view: DebugView,
) -> Result<RenderOptions, Failure> {
    let objectspace = (a.pipeline == PipelineKind::ObjectSpace)
        .then(|| -> Result<_, Failure> {
            Ok(ObjectSpaceOptions {
                tile_size: a.objectspace.tile_size,
                reuse: a.objectspace.reuse,
                mip_bias: a.objectspace.mip_bias,
                variable_rate: a.objectspace.variable_rate,
                view,
                texture_sizes: texture_sizes.clone().unwrap_or_default(),
                atlas_budget_texels: a.objectspace.atlas_budget << 20,
                visibility_prepass: !a.objectspace.no_visibility_prepass,
            })
        })
        .transpose()?;
    Ok(RenderOptions {
        pipeline: a.pipeline,
        width: a.size.0,
        height: a.size.1,
        depth_prepass: !a.no_depth_prepass,
        objectspace,
    })
}

/// The texture sizing the options ask for.
fn sizing(a: &ObjectSpaceArgs) -> Result<TextureSizing, Failure> {
    match a.texture_size {
        Some(size) if size.is_power_of_two() && size >= 8 => Ok(TextureSizing::Fixed(size)),
        Some(size) => input(Err(anyhow::anyhow!("--texture-size {size} is not a power of two of at least 8"))),
        None if a.texel_density > 0.0 && a.texel_density.is_finite() => {
            Ok(TextureSizing::Density { texels_per_metre: a.texel_density, min: 64, max: MAX_PAGE_SIZE })
        }
        None => input(Err(anyhow::anyhow!("--texel-density must be a positive number"))),
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

fn render(a: RenderArgs) -> Result<(), Failure> {
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer = Renderer::new(&ctx, &s.scene, &render_options(&a.scene, &s.texture_sizes, a.view)?)?;
    renderer.exposure = a.scene.exposure;
    for f in a.frame.saturating_sub(a.history)..a.frame {
        renderer.render(&ctx, &s.path.camera_at(f), &s.lights, f as u64)?;
    }
    let camera = s.path.camera_at(a.frame);
    let stats = renderer.render(&ctx, &camera, &s.lights, a.frame as u64)?;
    let image = renderer.read_image(&ctx)?;
    let this_frame = |f: u64| f == a.frame as u64;
    let timings: Vec<_> = renderer.collect_timings(&ctx, true).into_iter().filter(|t| this_frame(t.frame)).collect();
    let counters: Vec<_> = renderer.collect_counters(&ctx, true).into_iter().filter(|c| this_frame(c.frame)).collect();
    save_png(&image, &a.out)?;
    if let Some(path) = &a.atlas_out {
        let Some(os) = renderer.objectspace() else {
            return input(Err(anyhow::anyhow!("--atlas-out needs --pipeline objectspace")));
        };
        save_png(&input(os.read_atlas(&ctx, a.atlas_object, 0))?, path)?;
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
    for t in &timings {
        for (name, ms) in &t.passes {
            println!("  {name:<16} {ms:8.3} ms GPU");
        }
    }
    for c in &counters {
        println!(
            "  tiles: {} visible, {} shaded, {} reused, {} new; {:.2} visible texels per pixel",
            c.visible_tiles,
            c.shaded_tiles,
            c.reused_tiles,
            c.new_tiles,
            c.visible_texels as f64 / stats.screen_pixels as f64
        );
    }
    if let Some(path) = &a.stats {
        let json = serde_json::json!({
            "adapter": ctx.adapter_summary(),
            "scene": s.scene.name,
            "pipeline": renderer.pipeline_name(),
            "lights": s.lights_spec,
            "light_count": s.lights.len(),
            "camera": s.camera_label,
            "stats": stats,
            "gpu": timings,
            "shading": counters,
            "memory": renderer.memory(),
        });
        write_file(path, serde_json::to_string_pretty(&json)?.as_bytes())?;
    }
    Ok(())
}

fn run_bench(a: BenchArgs) -> Result<(), Failure> {
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer = Renderer::new(&ctx, &s.scene, &render_options(&a.scene, &s.texture_sizes, DebugView::Shade)?)?;
    renderer.exposure = a.scene.exposure;
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
    let setup = BenchSetup {
        scene_name: &s.scene.name,
        objects: s.scene.objects.len(),
        lights_spec: &s.lights_spec,
        seed: a.scene.seed,
        camera: &s.camera_label,
    };
    let plan =
        bench::BenchPlan { path: &s.path, lights: &s.lights, warmup: a.warmup, frames: a.frames, step: a.frame_step };
    let result = bench::run(&ctx, &mut renderer, &plan, &setup, |i| bar.set_position(i as u64))?;
    bar.finish_and_clear();
    write_file(&a.out, serde_json::to_string_pretty(&result)?.as_bytes())?;
    println!(
        "{} {} {}x{} lights {} ({}): GPU frame median {:.3} ms, p95 {:.3} ms; CPU {:.3} ms  -> {}",
        result.pipeline,
        result.scene,
        w,
        h,
        result.lights_spec,
        result.light_count,
        result.gpu_frame.median_ms,
        result.gpu_frame.p95_ms,
        result.cpu_frame.median_ms,
        a.out.display()
    );
    for (name, s) in &result.gpu_passes {
        println!("  {name:<16} median {:8.3} ms  p95 {:8.3} ms", s.median_ms, s.p95_ms);
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
    println!("FLIP mean {:.4}  PSNR {:.2} dB  max channel difference {}", err.flip_mean, err.psnr_db, err.max_abs);
    if let Some(path) = &a.flip_map {
        let mut bytes = Vec::new();
        map.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).context("encoding PNG")?;
        write_file(path, &bytes)?;
    }
    Ok(())
}

fn info(a: GpuArgs) -> Result<(), Failure> {
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

/// Writes through a temporary file and a rename, so that a failed run never
/// leaves a truncated result behind.
fn write_file(path: &Path, bytes: &[u8]) -> Result<(), Failure> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let tmp = dir.join(format!(".{}.tmp", path.file_name().and_then(|n| n.to_str()).unwrap_or("out")));
    let result = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    input(result.with_context(|| format!("{}: cannot write", path.display())))
}
