//! `shadespace bench`: render a camera path for many frames and summarise GPU
//! time per pass and per frame (median, p95 after warm-up) and CPU frame time.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::gpu::GpuContext;
use crate::gpu::timing::FrameTimings;
use crate::render::objectspace::MemoryReport;
use crate::render::{FrameStats, RenderError, Renderer, ShadingCounters};
use crate::scene::{CameraPath, Light};

/// Median and 95th percentile of a series, in milliseconds.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Summary {
    pub median_ms: f64,
    pub p95_ms: f64,
    pub mean_ms: f64,
    pub samples: usize,
}

impl Summary {
    /// Nearest-rank percentiles of `values` (empty gives zeros).
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let rank = |p: f64| v[(((p * v.len() as f64).ceil() as usize).max(1) - 1).min(v.len() - 1)];
        Summary {
            median_ms: rank(0.5),
            p95_ms: rank(0.95),
            mean_ms: v.iter().sum::<f64>() / v.len() as f64,
            samples: v.len(),
        }
    }
}

/// What the run measured; written as the bench JSON.
#[derive(Clone, Debug, Serialize)]
pub struct BenchResult {
    pub adapter: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    pub features: Vec<String>,
    pub scene: String,
    pub triangles: u64,
    pub objects: usize,
    pub width: u32,
    pub height: u32,
    pub pipeline: String,
    pub lights_spec: String,
    pub light_count: usize,
    pub seed: u64,
    pub camera: String,
    pub frames: u32,
    pub warmup: u32,
    pub frame_step: u32,
    /// GPU time per pass over the measured frames.
    pub gpu_passes: BTreeMap<String, Summary>,
    /// GPU time from the first pass's start to the last pass's end.
    pub gpu_frame: Summary,
    /// CPU time to cull, upload, record and submit a frame.
    pub cpu_frame: Summary,
    /// Per measured frame: GPU frame milliseconds (for plots).
    pub gpu_frame_ms: Vec<f64>,
    pub mean_light_assignments: f64,
    /// Object-space pipelines: tile statistics over the measured frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shading: Option<ShadingSummary>,
    /// Object-space pipelines: memory in total and per object.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<MemoryReport>,
}

/// Medians (and means) over measured frames of the object-space counters.
#[derive(Clone, Debug, Serialize)]
pub struct ShadingSummary {
    pub screen_pixels: u64,
    pub median_visible_tiles: f64,
    pub median_shaded_tiles: f64,
    pub median_reused_tiles: f64,
    pub median_new_tiles: f64,
    /// new tiles / visible tiles, per frame, median.
    pub median_new_fraction: f64,
    pub median_shaded_texels: f64,
    /// Texels of all visible tiles / screen pixels: what shading every visible
    /// tile costs (the study's overshading), median.
    pub median_overshading: f64,
    /// Shaded texels / screen pixels (after reuse), median.
    pub median_shaded_per_pixel: f64,
    pub mean_shaded_tiles: f64,
    pub frames: usize,
}

impl ShadingSummary {
    pub fn of(counters: &[ShadingCounters], screen_pixels: u64) -> Option<Self> {
        if counters.is_empty() {
            return None;
        }
        let med =
            |f: &dyn Fn(&ShadingCounters) -> f64| Summary::of(&counters.iter().map(f).collect::<Vec<_>>()).median_ms;
        let px = screen_pixels.max(1) as f64;
        Some(Self {
            screen_pixels,
            median_visible_tiles: med(&|c| c.visible_tiles as f64),
            median_shaded_tiles: med(&|c| c.shaded_tiles as f64),
            median_reused_tiles: med(&|c| c.reused_tiles as f64),
            median_new_tiles: med(&|c| c.new_tiles as f64),
            median_new_fraction: med(&|c| c.new_tiles as f64 / c.visible_tiles.max(1) as f64),
            median_shaded_texels: med(&|c| c.shaded_texels as f64),
            median_overshading: med(&|c| c.visible_texels as f64 / px),
            median_shaded_per_pixel: med(&|c| c.shaded_texels as f64 / px),
            mean_shaded_tiles: counters.iter().map(|c| c.shaded_tiles as f64).sum::<f64>() / counters.len() as f64,
            frames: counters.len(),
        })
    }
}

/// What to render: the path, the lights, and how many frames.
pub struct BenchPlan<'a> {
    pub path: &'a CameraPath,
    pub lights: &'a [Light],
    /// Frames rendered first and not measured.
    pub warmup: u32,
    /// Measured frames.
    pub frames: u32,
    /// Frame `i` shows path frame `i * step` (mod the path length).
    pub step: u32,
}

/// Descriptive fields of a run that the renderer does not know.
pub struct BenchSetup<'a> {
    pub scene_name: &'a str,
    pub objects: usize,
    pub lights_spec: &'a str,
    pub seed: u64,
    pub camera: &'a str,
}

/// Renders `warmup + frames` frames along `path` (frame `i` uses the path's
/// camera `i * step mod path length`), then waits for the GPU timings and summarises
/// the measured frames. `progress` is called after each frame.
pub fn run(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    plan: &BenchPlan,
    setup: &BenchSetup,
    mut progress: impl FnMut(u32),
) -> Result<BenchResult, RenderError> {
    let BenchPlan { path, lights, warmup, frames, step } = *plan;
    let total = warmup + frames;
    let measured = |frame: u64| frame >= warmup as u64;
    let mut stats: Vec<FrameStats> = Vec::with_capacity(total as usize);
    let mut timings: Vec<FrameTimings> = Vec::with_capacity(total as usize);
    let mut counters: Vec<ShadingCounters> = Vec::with_capacity(total as usize);
    let path_len = path.frame_count().max(1);
    for i in 0..total {
        let camera = path.camera_at((i as u64 * step as u64 % path_len as u64) as u32);
        stats.push(renderer.render(ctx, &camera, lights, i as u64)?);
        timings.extend(renderer.collect_timings(ctx, false));
        counters.extend(renderer.collect_counters(ctx, false));
        progress(i + 1);
    }
    timings.extend(renderer.collect_timings(ctx, true));
    counters.extend(renderer.collect_counters(ctx, true));
    counters.retain(|c| measured(c.frame));
    ctx.check_errors()?;

    let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut gpu_frame_ms = Vec::new();
    for t in timings.iter().filter(|t| measured(t.frame)) {
        for (name, ms) in &t.passes {
            per_pass.entry(name.clone()).or_default().push(*ms);
        }
        gpu_frame_ms.push(t.total_ms);
    }
    let cpu: Vec<f64> = stats.iter().filter(|s| measured(s.frame)).map(|s| s.cpu_ms).collect();
    let assignments: Vec<f64> =
        stats.iter().filter(|s| measured(s.frame)).map(|s| s.light_assignments as f64).collect();
    Ok(BenchResult {
        adapter: ctx.info.name.clone(),
        backend: format!("{:?}", ctx.info.backend),
        driver: ctx.info.driver.clone(),
        driver_info: ctx.info.driver_info.clone(),
        features: ctx.features.iter_names().map(|(n, _)| n.to_string()).collect(),
        scene: setup.scene_name.to_string(),
        triangles: renderer.scene.triangle_count,
        objects: setup.objects,
        width: renderer.targets.width,
        height: renderer.targets.height,
        pipeline: renderer.pipeline_name().to_string(),
        lights_spec: setup.lights_spec.to_string(),
        light_count: lights.len(),
        seed: setup.seed,
        camera: setup.camera.to_string(),
        frames,
        warmup,
        frame_step: step,
        gpu_passes: per_pass.iter().map(|(k, v)| (k.clone(), Summary::of(v))).collect(),
        gpu_frame: Summary::of(&gpu_frame_ms),
        cpu_frame: Summary::of(&cpu),
        gpu_frame_ms,
        mean_light_assignments: Summary::of(&assignments).mean_ms,
        shading: ShadingSummary::of(&counters, renderer.targets.width as u64 * renderer.targets.height as u64),
        memory: renderer.memory(),
    })
}

#[cfg(test)]
mod tests {
    use super::Summary;

    #[test]
    fn summary_percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Summary::of(&v);
        assert_eq!(s.median_ms, 50.0);
        assert_eq!(s.p95_ms, 95.0);
        assert_eq!(s.mean_ms, 50.5);
        assert_eq!(Summary::of(&[3.0]).p95_ms, 3.0);
        assert_eq!(Summary::of(&[]).samples, 0);
    }
}
