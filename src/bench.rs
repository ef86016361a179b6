//! Running a pipeline over frames of a camera path and reporting what it
//! measured. `render --stats` (one frame, after `--history` frames) and
//! `bench` (many frames after a warm-up) both write a [`RunReport`]: one
//! typed schema, documented field by field here.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::gpu::GpuContext;
use crate::gpu::timing::{FrameTimings, GpuTiming};
use crate::render::{Counters, FrameStats, PipelineReport, RenderError, Renderer};
use crate::scene::{CameraPath, Light};

/// Version of the [`RunReport`] schema (bump on any change of its fields).
pub const SCHEMA_VERSION: u32 = 4;

/// Median, 95th percentile and mean of a series (in the series' unit: the
/// key it is stored under says which, e.g. `_ms`).
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Summary {
    pub median: f64,
    pub p95: f64,
    pub mean: f64,
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
        Summary { median: rank(0.5), p95: rank(0.95), mean: v.iter().sum::<f64>() / v.len() as f64, samples: v.len() }
    }
}

/// The GPU the run used.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterReport {
    pub name: String,
    pub backend: String,
    pub driver: String,
    pub driver_info: String,
    /// Optional features that were turned on.
    pub features: Vec<String>,
}

impl AdapterReport {
    pub fn of(ctx: &GpuContext) -> Self {
        Self {
            name: ctx.info.name.clone(),
            backend: format!("{:?}", ctx.info.backend),
            driver: ctx.info.driver.clone(),
            driver_info: ctx.info.driver_info.clone(),
            features: ctx.features.iter_names().map(|(n, _)| n.to_string()).collect(),
        }
    }
}

/// One pass's GPU time in one frame.
#[derive(Clone, Debug, Serialize)]
pub struct PassTime {
    pub pass: String,
    pub ms: f64,
}

/// One measured frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameReport {
    /// Render order, from 0 (warm-up frames included).
    pub frame: u64,
    /// The camera path frame it showed.
    pub path_frame: u32,
    /// CPU time to cull, upload, record and submit.
    pub cpu_ms: f64,
    pub visible_objects: u32,
    /// Sum over objects of the lights assigned to them.
    pub light_assignments: u64,
    /// GPU time from the first pass's start to the last pass's end; absent
    /// when the adapter has no timestamp queries.
    pub gpu_ms: Option<f64>,
    /// GPU time per pass, in recording order.
    pub gpu_passes: Vec<PassTime>,
    /// The pipeline's counters (see its `collect_counters`).
    pub counters: Counters,
}

/// Whether a pass belongs to the floor every pipeline pays on top of its
/// shading: visibility (the compute rasterizer's `vis: ...` passes, the
/// raster `visibility` or `depth prepass`, with cluster culling also
/// `depth prepass late` and culling's `cull`, `cull hiz` and `cull late`)
/// and the post-processing of the
/// HDR frame (`exposure`, `bloom`, `tonemap`). What a frame costs over the
/// floor is the pipeline's own work (for object space: marking, paging,
/// triangle maps, shading and gathering), so a regression in any of its
/// passes shows there.
pub fn is_floor_pass(name: &str) -> bool {
    name.starts_with("vis")
        || matches!(
            name,
            "depth prepass"
                | "depth prepass late"
                | "cull"
                | "cull hiz"
                | "cull late"
                | "exposure"
                | "bloom"
                | "tonemap"
        )
}

/// Medians over the measured frames.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunSummary {
    pub gpu_frame_ms: Summary,
    pub cpu_frame_ms: Summary,
    /// Per pass name, over the frames that ran the pass (a pass that runs
    /// in a few frames only, an atlas resize say, has few samples).
    pub gpu_passes_ms: BTreeMap<String, Summary>,
    /// Per pass name, its GPU time summed over the measured frames and
    /// divided by their count: what it adds to the average frame, whether
    /// it runs every frame or in a few.
    pub gpu_passes_per_frame_ms: BTreeMap<String, f64>,
    /// Per frame, the GPU time of the floor passes ([`is_floor_pass`]).
    pub floor_ms: Summary,
    /// Per frame, the GPU frame time less its floor: the pipeline's own work.
    pub over_floor_ms: Summary,
    /// Per counter name.
    pub counters: BTreeMap<String, Summary>,
    pub light_assignments: Summary,
}

/// The document `render --stats` and `bench --out` write.
#[derive(Clone, Debug, Serialize)]
pub struct RunReport {
    /// [`SCHEMA_VERSION`].
    pub schema: u32,
    pub adapter: AdapterReport,
    pub scene: String,
    pub objects: usize,
    pub triangles: u64,
    pub width: u32,
    pub height: u32,
    /// The pipeline, its settings, memory and setup.
    pub pipeline: PipelineReport,
    /// The `--lights` text, and the light count with the ambient and
    /// directional lights every set has.
    pub lights_spec: String,
    pub light_count: usize,
    pub seed: u64,
    pub camera: String,
    /// Frames rendered first and not measured.
    pub warmup: u32,
    /// Measured frames.
    pub frames: u32,
    /// Path frame of the first rendered frame, and the step between frames.
    pub first_path_frame: u32,
    pub frame_step: u32,
    /// What the GPU timestamps timed: every pass (`passes`: the breakdown,
    /// and a floor) or only the whole frame (`frame`: no breakdown and no
    /// floor, and none of the per-pass timestamps' own cost).
    pub timing: GpuTiming,
    pub summary: RunSummary,
    /// Every measured frame.
    pub per_frame: Vec<FrameReport>,
}

/// What to render: the path, the lights, and which frames.
pub struct BenchPlan<'a> {
    pub path: &'a CameraPath,
    pub lights: &'a [Light],
    /// Frames rendered first and not measured.
    pub warmup: u32,
    /// Measured frames.
    pub frames: u32,
    /// Rendered frame `i` shows path frame `first + i * step` (mod the path length).
    pub first: u32,
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

/// Adds a read-back's counters to their frames' (a pipeline's counters of
/// one frame may arrive in parts, from several read-backs).
fn merge_counters(into: &mut BTreeMap<u64, Counters>, arrived: Vec<(u64, Counters)>) {
    for (frame, c) in arrived {
        into.entry(frame).or_default().extend(c);
    }
}

/// Renders `warmup + frames` frames along the plan's path, then waits for
/// the GPU timings and counters and reports the measured frames. `progress`
/// is called after each frame.
pub fn run(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    plan: &BenchPlan,
    setup: &BenchSetup,
    mut progress: impl FnMut(u32),
) -> Result<RunReport, RenderError> {
    let BenchPlan { path, lights, warmup, frames, first, step } = *plan;
    let total = warmup + frames;
    let measured = |frame: u64| frame >= warmup as u64;
    let path_len = path.frame_count().max(1) as u64;
    let path_frame = |i: u64| ((first as u64 + i * step as u64) % path_len) as u32;
    let mut stats: Vec<FrameStats> = Vec::with_capacity(frames as usize);
    let mut timings: BTreeMap<u64, FrameTimings> = BTreeMap::new();
    let mut counters: BTreeMap<u64, Counters> = BTreeMap::new();
    for i in 0..total as u64 {
        let s = renderer.render(ctx, &path.camera_at(path_frame(i)), lights, i)?;
        // Warm-up frames are not reported: keep nothing of them, so that a
        // long warm-up (`render --history`) holds memory flat.
        if measured(i) {
            stats.push(s);
        }
        let arrived = renderer.collect_timings(ctx, false).into_iter().filter(|t| measured(t.frame));
        timings.extend(arrived.map(|t| (t.frame, t)));
        let arrived = renderer.collect_counters(ctx, false).into_iter().filter(|(f, _)| measured(*f)).collect();
        merge_counters(&mut counters, arrived);
        progress(i as u32 + 1);
    }
    timings.extend(renderer.collect_timings(ctx, true).into_iter().map(|t| (t.frame, t)));
    merge_counters(&mut counters, renderer.collect_counters(ctx, true));
    ctx.check_errors()?;

    let per_frame: Vec<FrameReport> = stats
        .into_iter()
        .filter(|s| measured(s.frame))
        .map(|s| {
            let t = timings.remove(&s.frame);
            FrameReport {
                frame: s.frame,
                path_frame: path_frame(s.frame),
                cpu_ms: s.cpu_ms,
                visible_objects: s.visible_objects,
                light_assignments: s.light_assignments,
                gpu_ms: t.as_ref().map(|t| t.total_ms),
                gpu_passes: t
                    .map(|t| t.passes.into_iter().map(|(pass, ms)| PassTime { pass, ms }).collect())
                    .unwrap_or_default(),
                counters: counters.remove(&s.frame).unwrap_or_default(),
            }
        })
        .collect();
    Ok(RunReport {
        schema: SCHEMA_VERSION,
        timing: renderer.timing,
        adapter: AdapterReport::of(ctx),
        scene: setup.scene_name.to_string(),
        objects: setup.objects,
        triangles: renderer.scene.triangle_count,
        width: renderer.targets.width,
        height: renderer.targets.height,
        pipeline: renderer.report(),
        lights_spec: setup.lights_spec.to_string(),
        light_count: lights.len(),
        seed: setup.seed,
        camera: setup.camera.to_string(),
        warmup,
        frames,
        first_path_frame: first,
        frame_step: step,
        summary: summarise(&per_frame),
        per_frame,
    })
}

/// Medians (and p95, means) over frames of every timed and counted quantity.
pub fn summarise(frames: &[FrameReport]) -> RunSummary {
    let of = |f: &dyn Fn(&FrameReport) -> Option<f64>| Summary::of(&frames.iter().filter_map(f).collect::<Vec<_>>());
    let mut passes: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let mut counters: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
    let floor = |f: &FrameReport| f.gpu_passes.iter().filter(|p| is_floor_pass(&p.pass)).map(|p| p.ms).sum::<f64>();
    for f in frames {
        for p in &f.gpu_passes {
            passes.entry(&p.pass).or_default().push(p.ms);
        }
        for (name, v) in &f.counters {
            counters.entry(name).or_default().push(*v);
        }
    }
    RunSummary {
        gpu_frame_ms: of(&|f| f.gpu_ms),
        cpu_frame_ms: of(&|f| Some(f.cpu_ms)),
        gpu_passes_per_frame_ms: passes
            .iter()
            .map(|(k, v)| (k.to_string(), v.iter().sum::<f64>() / frames.len() as f64))
            .collect(),
        gpu_passes_ms: passes.into_iter().map(|(k, v)| (k.to_string(), Summary::of(&v))).collect(),
        floor_ms: of(&|f| f.gpu_ms.map(|_| floor(f))),
        over_floor_ms: of(&|f| f.gpu_ms.map(|gpu| gpu - floor(f))),
        counters: counters.into_iter().map(|(k, v)| (k.to_string(), Summary::of(&v))).collect(),
        light_assignments: of(&|f| Some(f.light_assignments as f64)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Summary::of(&v);
        assert_eq!(s.median, 50.0);
        assert_eq!(s.p95, 95.0);
        assert_eq!(s.mean, 50.5);
        assert_eq!(Summary::of(&[3.0]).p95, 3.0);
        assert_eq!(Summary::of(&[]).samples, 0);
    }

    #[test]
    fn summarise_collects_passes_and_counters_by_name() {
        let frame = |gpu: f64, mark: f64, tiles: f64| FrameReport {
            frame: 0,
            path_frame: 0,
            cpu_ms: 1.0,
            visible_objects: 1,
            light_assignments: 2,
            gpu_ms: Some(gpu),
            gpu_passes: vec![PassTime { pass: "mark".into(), ms: mark }],
            counters: [("visible_tiles".to_string(), tiles)].into_iter().collect(),
        };
        let s = summarise(&[frame(2.0, 0.5, 10.0), frame(4.0, 0.7, 30.0), frame(3.0, 0.6, 20.0)]);
        assert_eq!(s.gpu_frame_ms.median, 3.0);
        assert_eq!(s.gpu_passes_ms["mark"].median, 0.6);
        assert_eq!(s.counters["visible_tiles"].median, 20.0);
        assert_eq!(s.counters["visible_tiles"].samples, 3);
    }

    /// The floor is the visibility and post passes of each frame; what is
    /// over it, the rest of the frame; a pass run in one frame of two adds
    /// half its time to the average frame.
    #[test]
    fn the_floor_and_what_a_frame_costs_over_it() {
        let pass = |pass: &str, ms: f64| PassTime { pass: pass.into(), ms };
        let frame = |gpu: f64, passes: Vec<PassTime>| FrameReport {
            frame: 0,
            path_frame: 0,
            cpu_ms: 1.0,
            visible_objects: 1,
            light_assignments: 0,
            gpu_ms: Some(gpu),
            gpu_passes: passes,
            counters: Counters::default(),
        };
        let frames = [
            frame(2.0, vec![pass("vis: raster", 0.5), pass("mark", 0.25), pass("tonemap", 0.25), pass("shade", 1.0)]),
            frame(1.5, vec![pass("vis: raster", 0.75), pass("mark", 0.25), pass("tonemap", 0.25)]),
        ];
        let s = summarise(&frames);
        assert_eq!((s.floor_ms.samples, s.floor_ms.mean), (2, 0.875));
        assert_eq!(s.over_floor_ms.mean, 0.875);
        assert_eq!(s.over_floor_ms.p95, 1.25);
        assert_eq!(s.gpu_passes_per_frame_ms["shade"], 0.5);
        assert_eq!(s.gpu_passes_ms["shade"].median, 1.0);
        assert!(["vis: clear", "visibility", "depth prepass", "bloom", "exposure"].iter().all(|p| is_floor_pass(p)));
        assert!(["cull", "cull hiz", "cull late", "depth prepass late"].iter().all(|p| is_floor_pass(p)));
        assert!(
            !["mark", "gather", "tiled lighting", "forward shade", "triangle maps"].iter().any(|p| is_floor_pass(p))
        );
    }
}
