//! `shadespace render`: one frame to a PNG image, its GPU pass times and, for
//! object space, how the frame was shaded.

use std::path::PathBuf;
use std::str::FromStr;

use clap::Args;
use shadespace::bench::{self, BenchPlan, FrameReport};
use shadespace::render::Exposure;
use shadespace::render::objectspace::atlas_view::AtlasPages;
use shadespace::render::objectspace::{DebugView, ObjectSpace};

use super::options::{PipelineName, SceneArgs};
use super::output::{save_png, write_report, write_trace};
use super::setup::{configure, new_renderer, open_gpu, render_options, setup};
use super::{Failure, input};

/// `render`'s options: the scene's, then the frame and the outputs.
#[derive(Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Frame index on the camera path (frames are numbered, never timed).
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    pub frame: u32,
    /// Output image (PNG).
    #[arg(help_heading = "Frame and output", long, default_value = "shadespace.png")]
    pub out: PathBuf,
    /// Also write the frame's statistics (and GPU pass times) as JSON here.
    #[arg(help_heading = "Frame and output", long)]
    pub stats: Option<PathBuf>,
    /// Render the K path frames before --frame first (not saved), so that
    /// reuse and the tile-mask and cache-age views have a history.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    pub history: u32,
    /// Object space: write a debug view instead of the shaded image: `shade`,
    /// `chart-uv`, `mip-level`, `tile-mask` (red: shaded this frame, green:
    /// reused), `cache-age`, `atlas-pages` (level --atlas-level of object
    /// --atlas-object's shading texture, found through the page table as
    /// the frame left it: backed pages show their shades, the others a dark
    /// checker; a square frame of the level's size shows a texel per pixel).
    #[arg(help_heading = "Frame and output", long, default_value = "shade", value_parser = DebugView::from_str)]
    pub view: DebugView,
    /// Object space: also write one mip level (--atlas-level) of one object's
    /// shading texture here (pages with no physical page magenta).
    #[arg(help_heading = "Frame and output", long)]
    pub atlas_out: Option<PathBuf>,
    /// Object space: the object (index, see `shadespace charts`) for
    /// --atlas-out and --view atlas-pages.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    pub atlas_object: usize,
    /// Object space: the mip level (0 the finest) for --atlas-out and --view atlas-pages.
    #[arg(help_heading = "Frame and output", long, default_value_t = 0)]
    pub atlas_level: usize,
    /// Also write the frame's GPU pass times as a Chrome trace (open in
    /// chrome://tracing or ui.perfetto.dev).
    #[arg(help_heading = "Frame and output", long)]
    pub trace: Option<PathBuf>,
    /// Write the frame's supersampled reference instead: forward shading at
    /// N x N sub-pixel offsets per pixel (N from 4 to 32), averaged in linear
    /// HDR before tone mapping with --exposure; cached in
    /// $SHADESPACE_CACHE_DIR/references.
    #[arg(help_heading = "Reference", long, value_name = "N", value_parser = clap::value_parser!(u32).range(4..=32))]
    pub reference: Option<u32>,
}

/// Renders the frame, writes the outputs, prints what it cost.
pub fn run(a: RenderArgs) -> Result<(), Failure> {
    if let Some(n) = a.reference {
        return render_reference(&a, n);
    }
    let s = setup(&a.scene)?;
    let ctx = open_gpu(&a.scene.gpu)?;
    let (w, h) = a.scene.size;
    let mut renderer = new_renderer(&ctx, &s.scene, &render_options(&a.scene, &s, a.view, ctx.device.features()))?;
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
        "{}: {} ({} objects, {} triangles), {} lights, {}x{}{}, {} -> {}",
        renderer.pipeline_name(),
        s.scene.name,
        s.scene.objects.len(),
        s.scene.triangle_count(),
        s.lights.len(),
        w,
        h,
        if a.scene.msaa > 1 { format!(" with {}x MSAA", a.scene.msaa) } else { String::new() },
        ctx.info.name,
        a.out.display()
    );
    if renderer.exposure == Exposure::Auto {
        println!("  exposure auto: {:.4}", renderer.read_exposure(&ctx)?);
    }
    for f in &report.per_frame {
        for line in frame_lines(f) {
            println!("  {line}");
        }
    }
    if let Some(path) = &a.stats {
        write_report(&report, path)?;
    }
    Ok(())
}

/// What a frame cost and, for object space, how it was shaded: the GPU time
/// of each pass and of the frame, texels per pixel, tiles shaded and reused.
fn frame_lines(f: &FrameReport) -> Vec<String> {
    let width = f.gpu_passes.iter().map(|p| p.pass.len()).max().unwrap_or(0).max("frame".len());
    let mut lines: Vec<String> =
        f.gpu_passes.iter().map(|p| format!("{:<width$} {:8.3} ms GPU", p.pass, p.ms)).collect();
    lines.push(match f.gpu_ms {
        Some(ms) => format!("{:<width$} {ms:8.3} ms GPU", "frame"),
        None => "frame: no GPU time (the adapter has no timestamp queries)".to_string(),
    });
    let c = |name: &str| f.counters.get(name).copied();
    if let (Some(visible), Some(shaded), Some(reused), Some(new), Some(texels), Some(shaded_texels)) = (
        c("visible_tiles"),
        c("shaded_tiles"),
        c("reused_tiles"),
        c("new_tiles"),
        c("overshading"),
        c("shaded_texels_per_pixel"),
    ) {
        let share = |n: f64| 100.0 * n / visible.max(1.0);
        lines.push(format!("object space: {texels:.2} visible texels per pixel, {shaded_texels:.2} shaded this frame"));
        lines.push(format!(
            "tiles: {visible} visible, {shaded} shaded ({:.0} %), {reused} reused ({:.0} %), {new} new",
            share(shaded),
            share(reused)
        ));
    }
    lines
}

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

#[cfg(test)]
mod tests {
    use shadespace::bench::PassTime;

    use super::*;

    fn frame(counters: &[(&str, f64)]) -> FrameReport {
        FrameReport {
            frame: 0,
            path_frame: 0,
            cpu_ms: 1.0,
            visible_objects: 1,
            light_assignments: 0,
            gpu_ms: Some(2.5),
            gpu_passes: vec![
                PassTime { pass: "shade".into(), ms: 2.0 },
                PassTime { pass: "world grid: count".into(), ms: 0.5 },
            ],
            counters: counters.iter().map(|&(k, v)| (k.to_string(), v)).collect(),
        }
    }

    /// Object space's frames say how they were shaded; the others only what they cost.
    #[test]
    fn frame_lines_report_time_and_object_space_shading() {
        let lines = frame_lines(&frame(&[
            ("visible_tiles", 200.0),
            ("shaded_tiles", 50.0),
            ("reused_tiles", 150.0),
            ("new_tiles", 10.0),
            ("overshading", 1.234),
            ("shaded_texels_per_pixel", 0.3),
        ]));
        assert_eq!(
            lines,
            [
                "shade                2.000 ms GPU",
                "world grid: count    0.500 ms GPU",
                "frame                2.500 ms GPU",
                "object space: 1.23 visible texels per pixel, 0.30 shaded this frame",
                "tiles: 200 visible, 50 shaded (25 %), 150 reused (75 %), 10 new",
            ]
        );
        let forward = frame_lines(&FrameReport { gpu_ms: None, ..frame(&[]) });
        assert_eq!(forward.len(), 3);
        assert!(forward[2].starts_with("frame: no GPU time"), "{forward:?}");
    }
}
