//! `shadespace bench`: many frames along the camera path, GPU time per pass
//! (median and p95 after warm-up) as JSON.

use std::path::PathBuf;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use shadespace::bench::{self, BenchPlan};
use shadespace::gpu::timing::GpuTiming;
use shadespace::render::objectspace::DebugView;

use super::Failure;
use super::options::SceneArgs;
use super::output::write_report;
use super::setup::{configure, new_renderer, open_gpu, render_options, setup};

/// `bench`'s options: the scene's, then the frames and the output.
#[derive(Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Measured frames, at least 1 (the camera path repeats if it is shorter).
    #[arg(help_heading = "Frames and output", long, default_value_t = 600,
        value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Frames rendered first and not measured.
    #[arg(help_heading = "Frames and output", long, default_value_t = 60)]
    pub warmup: u32,
    /// Measured frame i shows path frame i x STEP (mod the path length): a
    /// shorter run that still covers the whole path. Reuse between frames
    /// shrinks as the step grows.
    #[arg(help_heading = "Frames and output", long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub frame_step: u32,
    /// Result JSON.
    #[arg(help_heading = "Frames and output", long, default_value = "bench.json")]
    pub out: PathBuf,
    /// No progress bar.
    #[arg(help_heading = "Frames and output", long)]
    pub quiet: bool,
    /// What the GPU timestamps time: `passes`, each pass (the per-pass
    /// table, the floor; each pass's timestamps add about 2-3 us to the
    /// frame on the H100), or `frame`, two timestamps around the frame
    /// (its time without that cost: use it to compare pipelines'
    /// frame times).
    #[arg(help_heading = "Frames and output", long, value_enum, default_value_t = GpuTiming::Passes)]
    pub timing: GpuTiming,
}

/// Runs the frames, writes the report, prints the medians.
pub fn run(a: BenchArgs) -> Result<(), Failure> {
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer =
        new_renderer(&ctx, &s.scene, &render_options(&a.scene, &s, DebugView::Shade, ctx.device.features()))?;
    configure(&mut renderer, &a.scene, &s);
    renderer.timing = a.timing;
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
    if a.timing == GpuTiming::Passes {
        println!(
            "  floor (visibility and post) median {:.3} ms; the pipeline's own passes over it: median {:.3} ms, p95 {:.3} ms",
            summary.floor_ms.median, summary.over_floor_ms.median, summary.over_floor_ms.p95
        );
    }
    println!("  {:<26} {:>9} {:>9} {:>10} {:>7}", "pass", "median", "p95", "per frame", "frames");
    for (name, s) in &summary.gpu_passes_ms {
        let floor = if shadespace::bench::is_floor_pass(name) { " (floor)" } else { "" };
        let per_frame = summary.gpu_passes_per_frame_ms[name];
        println!("  {name:<26} {:9.3} {:9.3} {per_frame:10.3} {:7}{floor}", s.median, s.p95, s.samples);
    }
    Ok(())
}
