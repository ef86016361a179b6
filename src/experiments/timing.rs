//! Frame times of shading configurations over light sets, for the timing
//! studies (`lights`, `speedup`). One renderer per configuration is kept
//! across all its light sets: a new set is uploaded by the renderer's own
//! light-change path (lists, shadow maps), nothing else is rebuilt. Each
//! point runs `bench`'s loop ([`crate::bench::run`]): GPU-timestamp medians
//! over the frames after a warm-up. Points of a scenario above a
//! configuration's frame-time cap are skipped and recorded as such.

use std::time::Instant;

use indicatif::ProgressBar;
use serde::Serialize;

use super::ExperimentError;
use super::census::StudyScene;
use super::plot::Series;
use super::report::{Section, f3};
use super::scenarios::Scenario;
use crate::bench::{self, BenchPlan, BenchSetup};
use crate::gpu::GpuContext;
use crate::gpu::timing::GpuTiming;
use crate::render::{
    ClusteredConfig, DeferredComputeConfig, DeferredConfig, ForwardConfig, ForwardMultipassConfig, ObjectSpaceConfig,
    PipelineConfig, RenderOptions, Renderer, VisibilityMethod,
};
use crate::scene::lights::build_lights;
use crate::scene::path::SceneCameras;
use crate::scene::{Aabb, CameraPath, Light};

/// A pipeline and the settings it is measured with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    Forward,
    ForwardMultipass,
    Clustered,
    Deferred,
    DeferredCompute,
    /// Object space with reuse N (1: shade every visible tile every frame)
    /// and variable-rate strength (0: off).
    ObjectSpace {
        reuse: u32,
        variable_rate: f32,
    },
}

impl Shading {
    /// The conventional pipelines the fastest baseline is chosen from.
    pub const CONVENTIONAL: [Shading; 5] =
        [Shading::Forward, Shading::ForwardMultipass, Shading::Clustered, Shading::Deferred, Shading::DeferredCompute];

    /// Object space as `--pipeline objectspace` runs by default.
    pub const OBJECT_SPACE: Shading = Shading::ObjectSpace { reuse: 1, variable_rate: 0.0 };

    /// Every pipeline at its default settings.
    pub fn pipelines() -> Vec<Shading> {
        let mut all = Self::CONVENTIONAL.to_vec();
        all.push(Self::OBJECT_SPACE);
        all
    }

    /// The label of tables, plots and the CSV: the pipeline's name, and for
    /// object space its non-default settings (`objectspace-reuse2`, `objectspace-vr1`).
    pub fn label(&self) -> String {
        match *self {
            Shading::ObjectSpace { reuse, variable_rate } => {
                let mut label = "objectspace".to_string();
                if reuse != 1 {
                    label += &format!("-reuse{reuse}");
                }
                if variable_rate != 0.0 {
                    label += &format!("-vr{variable_rate}");
                }
                label
            }
            other => other.config(&[], VisibilityMethod::Raster).name().to_string(),
        }
    }

    pub fn is_conventional(&self) -> bool {
        !matches!(self, Shading::ObjectSpace { .. })
    }

    /// Its pipeline configuration: object space shades the objects at
    /// `texture_sizes`; object space and deferred-compute find surfaces with
    /// `visibility`.
    pub fn config(&self, texture_sizes: &[Option<u32>], visibility: VisibilityMethod) -> PipelineConfig {
        match *self {
            Shading::Forward => PipelineConfig::Forward(ForwardConfig::default()),
            Shading::ForwardMultipass => PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
            Shading::Clustered => PipelineConfig::Clustered(ClusteredConfig::default()),
            Shading::Deferred => PipelineConfig::Deferred(DeferredConfig::default()),
            Shading::DeferredCompute => {
                PipelineConfig::DeferredCompute(DeferredComputeConfig { visibility, ..Default::default() })
            }
            Shading::ObjectSpace { reuse, variable_rate } => PipelineConfig::ObjectSpace(ObjectSpaceConfig {
                reuse,
                variable_rate,
                texture_sizes: texture_sizes.to_vec(),
                visibility,
                ..Default::default()
            }),
        }
    }
}

impl Serialize for Shading {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.label())
    }
}

/// One scenario at several light counts, in increasing order.
#[derive(Clone, Debug, Serialize)]
pub struct Sweep {
    pub scenario: Scenario,
    pub counts: Vec<u32>,
}

/// What a timing study measures, and how.
#[derive(Clone, Debug, Serialize)]
pub struct TimingGrid {
    pub width: u32,
    pub height: u32,
    /// Frames rendered before each point's measured frames (the new light
    /// set's shadow maps and, in object space, its first shading fall here).
    pub warmup: u32,
    /// Measured frames per point.
    pub frames: u32,
    /// Path frame of each point's first rendered frame (frames step by one).
    pub first_frame: u32,
    /// A configuration whose median frame time exceeds this at a light count
    /// skips the larger counts of that scenario.
    pub cap_ms: f64,
    /// Seed of the light placement (as `bench --seed`).
    pub seed: u64,
    /// What the GPU timestamps time (default: the whole frame, so that
    /// pipelines of more passes pay no more for being timed).
    pub timing: GpuTiming,
    pub shadings: Vec<Shading>,
    pub sweeps: Vec<Sweep>,
    /// MSAA samples per pixel, an axis of the quality experiment's grid
    /// (the other timing studies render one sample per pixel).
    pub msaa: Vec<u32>,
    /// The quality and layers experiments: only these configurations
    /// (labels, e.g. `objectspace`; empty: all of its grid's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub configs: Vec<String>,
    /// The quality experiment: only these texture settings (`file`,
    /// `detailed`; empty: all of its grid's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub textures: Vec<String>,
    /// The layers experiment: only these layer counts (empty: its own,
    /// `layers::layer_counts`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub layers: Vec<usize>,
    /// The quality experiment: split each cell's error and flicker by pixel
    /// class (`experiments::breakdown`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub breakdown: bool,
    /// The quality experiment: object space's atlas budget, Mi texels
    /// (`ObjectSpaceConfig::atlas_budget_texels`; none: its default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub atlas_budget_mi: Option<u64>,
}

impl TimingGrid {
    /// `shadings` over `sweeps` at the timing studies' defaults: 1920x1080,
    /// 5 warm-up and 20 measured frames a point from path frame 0, a 200 ms
    /// cap, seed 1. Quick: 160x90, 1 + 2 frames, and a 10 s cap (a CPU
    /// driver takes over 100 ms for a small frame, and quick runs should
    /// measure every point).
    pub fn new(quick: bool, shadings: Vec<Shading>, sweeps: Vec<Sweep>) -> Self {
        let ((width, height), warmup, frames, cap_ms) =
            if quick { ((160, 90), 1, 2, 10_000.0) } else { ((1920, 1080), 5, 20, 200.0) };
        Self {
            width,
            height,
            warmup,
            frames,
            first_frame: 0,
            cap_ms,
            seed: 1,
            timing: GpuTiming::Frame,
            shadings,
            sweeps,
            msaa: vec![1],
            configs: Vec::new(),
            textures: Vec::new(),
            layers: Vec::new(),
            breakdown: false,
            atlas_budget_mi: None,
        }
    }

    /// Points per configuration.
    pub fn points(&self) -> usize {
        self.sweeps.iter().map(|s| s.counts.len()).sum()
    }

    /// Frames rendered in all, if nothing is skipped.
    pub fn total_frames(&self) -> u64 {
        (self.shadings.len() * self.points()) as u64 * u64::from(self.warmup + self.frames)
    }
}

/// Whether a point was measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status {
    Measured,
    /// A smaller count of the scenario was above the frame-time cap, or failed.
    Skipped,
    /// The GPU could not render it (the note says why).
    Failed,
}

/// One configuration at one light set: a row of `data.csv`.
#[derive(Clone, Debug, Serialize)]
pub struct Measurement {
    pub shading: Shading,
    pub scenario: Scenario,
    /// Generated lights (the ambient and the sun every set has are not counted).
    pub lights: u32,
    /// The set as `--lights` takes it.
    pub lights_spec: String,
    pub status: Status,
    /// Measured frames (0 when skipped).
    pub frames: u32,
    /// GPU frame time over the measured frames, milliseconds.
    pub median_ms: Option<f64>,
    pub p95_ms: Option<f64>,
    pub mean_ms: Option<f64>,
    /// 1000 / median.
    pub fps: Option<f64>,
    /// Median CPU time to record and submit a frame.
    pub cpu_ms: Option<f64>,
    /// Wall-clock seconds to build the light set and render the point's
    /// frames, warm-up included (what a run's length is estimated from).
    pub wall_s: f64,
    /// Why a point has no time: the cap, or the GPU's error.
    pub note: String,
}

impl Measurement {
    /// `shading` at `count` lights of `scenario`, not measured.
    pub fn skipped(shading: Shading, scenario: Scenario, lights: u32) -> Self {
        Self {
            shading,
            scenario,
            lights,
            lights_spec: scenario.spec(lights).to_string(),
            status: Status::Skipped,
            frames: 0,
            median_ms: None,
            p95_ms: None,
            mean_ms: None,
            fps: None,
            cpu_ms: None,
            wall_s: 0.0,
            note: String::new(),
        }
    }

    /// The point measured: GPU frame times `gpu`, median CPU time `cpu_ms`.
    /// A point of `scenario` at `lights` measured at `ms` (skipped for `None`), for tests.
    #[cfg(test)]
    pub fn for_test(shading: Shading, scenario: Scenario, lights: u32, ms: Option<f64>) -> Self {
        let row = Self::skipped(shading, scenario, lights);
        ms.map_or(row.clone(), |ms| row.measured(&bench::Summary { median: ms, p95: ms, mean: ms, samples: 1 }, 0.0))
    }

    pub fn measured(self, gpu: &bench::Summary, cpu_ms: f64) -> Self {
        Self {
            status: Status::Measured,
            frames: gpu.samples as u32,
            median_ms: Some(gpu.median),
            p95_ms: Some(gpu.p95),
            mean_ms: Some(gpu.mean),
            fps: Some(1000.0 / gpu.median),
            cpu_ms: Some(cpu_ms),
            ..self
        }
    }
}

/// The scene, camera path and light placement every point shares.
pub struct Bench<'a> {
    ctx: &'a GpuContext,
    scene: &'a StudyScene,
    path: CameraPath,
    camera_label: String,
    region: Aabb,
    visibility: VisibilityMethod,
    pub grid: &'a TimingGrid,
    progress: &'a ProgressBar,
}

impl<'a> Bench<'a> {
    pub fn new(
        ctx: &'a GpuContext,
        scene: &'a StudyScene,
        cameras: &SceneCameras,
        grid: &'a TimingGrid,
        progress: &'a ProgressBar,
    ) -> Self {
        Self {
            ctx,
            scene,
            path: cameras.path.clone(),
            camera_label: format!("path from frame {}", grid.first_frame),
            region: cameras.light_region(&scene.render.bounds()),
            visibility: VisibilityMethod::preferred(ctx.device.features()),
            grid,
            progress,
        }
    }

    pub fn ctx(&self) -> &GpuContext {
        self.ctx
    }

    /// How object space and deferred-compute find surfaces on this adapter.
    pub fn visibility(&self) -> VisibilityMethod {
        self.visibility
    }

    /// The light set of `count` lights of `scenario`, placed as `bench` places
    /// `--lights` with the grid's seed.
    fn lights(&self, scenario: Scenario, count: u32) -> Result<Vec<Light>, ExperimentError> {
        let g = self.grid;
        let aspect = g.width as f32 / g.height as f32;
        let reference = self.path.camera_at(0);
        Ok(build_lights(&scenario.spec(count), &self.region, &reference, aspect, g.seed)?)
    }

    /// A renderer for `shading`. Object space shades the charted scene; the
    /// others draw the same triangles without the charts, as `bench` does.
    fn renderer(&self, shading: Shading) -> Result<Renderer, ExperimentError> {
        let g = self.grid;
        let scene = if shading.is_conventional() { &self.scene.render } else { self.scene.charted() };
        let options = RenderOptions::new(g.width, g.height, shading.config(&self.scene.density_sizes, self.visibility));
        let mut renderer = Renderer::new(self.ctx, scene, &options)?;
        renderer.timing = g.timing;
        if !renderer.timing_enabled() {
            return Err(ExperimentError::NoTimestamps(self.ctx.info.name.clone()));
        }
        Ok(renderer)
    }

    /// Renders `row`'s point with `renderer` and returns it measured.
    fn point(&self, renderer: &mut Renderer, row: Measurement) -> Result<Measurement, ExperimentError> {
        let g = self.grid;
        let start = Instant::now();
        let lights = self.lights(row.scenario, row.lights)?;
        let plan = BenchPlan {
            path: &self.path,
            lights: &lights,
            warmup: g.warmup,
            frames: g.frames,
            first: g.first_frame,
            step: 1,
        };
        let setup = BenchSetup {
            scene_name: &self.scene.name,
            objects: self.scene.render.objects.len(),
            lights_spec: &row.lights_spec,
            seed: g.seed,
            camera: &self.camera_label,
        };
        let report = bench::run(self.ctx, renderer, &plan, &setup, |_| self.progress.inc(1))?;
        let mut row = row.measured(&report.summary.gpu_frame_ms, report.summary.cpu_frame_ms.median);
        row.wall_s = start.elapsed().as_secs_f64();
        Ok(row)
    }

    /// Measures `shading` at every point of the grid, in sweep order, with
    /// one renderer; `after` sees each measured point and the renderer with
    /// its last frame (for reading the image back).
    ///
    /// A point the GPU cannot render (for example a shadow atlas larger
    /// than its memory) is recorded as failed, the larger counts of its
    /// scenario as skipped, and the next scenario gets a new renderer, since
    /// the failure may have left this one's resources invalid.
    pub fn measure(
        &self,
        shading: Shading,
        mut after: impl FnMut(&Measurement, &Renderer) -> Result<(), ExperimentError>,
    ) -> Result<Vec<Measurement>, ExperimentError> {
        let g = self.grid;
        let label = shading.label();
        let per_point = u64::from(g.warmup + g.frames);
        let mut renderer = None;
        let mut rows = Vec::new();
        for sweep in &g.sweeps {
            // Why the rest of this sweep is skipped, once it is.
            let mut skip: Option<String> = None;
            for &count in &sweep.counts {
                let row = Measurement::skipped(shading, sweep.scenario, count);
                if let Some(why) = &skip {
                    self.progress.inc(per_point);
                    rows.push(Measurement { note: why.clone(), ..row });
                    continue;
                }
                let built = match renderer.take() {
                    Some(r) => r,
                    None => {
                        self.progress.set_message(format!("{label}: building"));
                        self.renderer(shading)?
                    }
                };
                let r = renderer.insert(built);
                self.progress.set_message(format!("{label} {}", row.lights_spec));
                match self.point(r, row.clone()) {
                    Ok(measured) => {
                        after(&measured, r)?;
                        let median = measured.median_ms.unwrap_or_default();
                        if median > g.cap_ms {
                            skip = Some(format!("{median:.1} ms at {count} lights is above the {} ms cap", g.cap_ms));
                        }
                        rows.push(measured);
                    }
                    Err(ExperimentError::Render(e)) => {
                        tracing::warn!("{label} {}: {e}", row.lights_spec);
                        self.progress.inc(per_point);
                        let first_line = e.to_string().lines().next().unwrap_or_default().to_string();
                        rows.push(Measurement { status: Status::Failed, note: first_line, ..row });
                        skip = Some(format!("{count} lights failed"));
                        renderer = None;
                    }
                    Err(e) => return Err(e),
                }
            }
        }
        Ok(rows)
    }
}

/// The setup section of a timing study's report.
pub fn setup_section(
    grid: &TimingGrid,
    scene: &StudyScene,
    camera_source: &str,
    visibility: VisibilityMethod,
    quick: bool,
) -> Section {
    let shadings: Vec<String> = grid.shadings.iter().map(Shading::label).collect();
    let sweeps: Vec<String> = grid.sweeps.iter().map(|s| format!("{} at {:?}", s.scenario, s.counts)).collect();
    let text = format!(
        "Scene `{}` ({} objects{}), camera path from {camera_source}, path frames {} to {} (one step a frame), \
         {}x{}; {}. Each point: {} warm-up frames, then {} measured frames; the figure is the median of the GPU \
         frame time (timestamps around every pass, as `shadespace bench` reports it), fps = 1000 / median. A \
         configuration whose median passes {} ms skips the larger counts of that scenario. Lights placed with \
         seed {} (as `bench --lights SPEC --seed {}`), plus the ambient light and the sun every set has. \
         Visibility of object space and deferred-compute: {}; object space at {} texels per metre.\n\n\
         Configurations: {}.\n\nSweeps: {}.\n",
        scene.name,
        scene.render.objects.len(),
        if scene.excluded.is_empty() { String::new() } else { format!("; left out: {}", scene.excluded.join(", ")) },
        grid.first_frame,
        grid.first_frame + grid.warmup + grid.frames - 1,
        grid.width,
        grid.height,
        if quick { "quick mode (a reduced grid)" } else { "the full grid" },
        grid.warmup,
        grid.frames,
        grid.cap_ms,
        grid.seed,
        grid.seed,
        visibility.name(),
        scene.texel_density,
        shadings.join(", "),
        sweeps.join("; "),
    );
    Section { heading: "Setup".into(), text, ..Default::default() }
}

/// Where every timing study's figures differ from what its source's method
/// would give.
pub fn differences() -> Vec<String> {
    vec![
        "Frame time: the GPU time from the first pass's start to the last pass's end (timestamp queries), \
         median over the measured frames; the sources timed whole frames on the CPU, presentation included."
            .into(),
        "Shadow maps are rendered when the lights change (here: in each point's warm-up), not every frame: \
         the lights are static, so the measured frames hold the shadow look-ups but not the map renders that \
         a renderer re-rendering every frame would add."
            .into(),
        "Shadow faces: the shadow atlas holds as many faces as the adapter has texture array layers; beyond \
         that, shadowed lights cast no shadow (the run warns), which makes the largest shadowed counts cheaper."
            .into(),
        "Failures: a point the GPU cannot render (a shadow atlas of thousands of faces beyond its memory) is \
         recorded as failed, with the error in data.csv's note, and the larger counts of its scenario as skipped."
            .into(),
        "Light culling: forward and multi-pass forward get per-object light lists (per (object, light) pairs) \
         culled on the CPU, sphere or cone against boxes, as the study did; deferred draws light volumes; \
         clustered, deferred-compute and object space build their light grids on the GPU."
            .into(),
    ]
}

/// Frame-time series of every shading in `scenario` up to `max` lights.
pub fn series(rows: &[Measurement], shadings: &[Shading], scenario: Scenario, max: u32) -> Vec<Series> {
    shadings
        .iter()
        .map(|&s| Series {
            label: s.label(),
            points: rows
                .iter()
                .filter(|r| r.shading == s && r.scenario == scenario && r.lights <= max)
                .filter_map(|r| r.median_ms.map(|ms| (f64::from(r.lights), ms)))
                .collect(),
        })
        .collect()
}

/// A table cell: the median in ms, or why there is none.
pub fn ms_cell(r: Option<&Measurement>) -> String {
    match r {
        Some(Measurement { median_ms: Some(ms), fps: Some(fps), .. }) => format!("{} ({fps:.0})", f3(*ms)),
        Some(Measurement { status: Status::Failed, .. }) => "failed".into(),
        Some(_) => "skipped".into(),
        None => "-".into(),
    }
}

/// The measured median frame time of `shading` at `scenario` and `count`.
pub fn median_of(rows: &[Measurement], shading: Shading, scenario: Scenario, count: u32) -> Option<f64> {
    rows.iter().find(|r| r.shading == shading && r.scenario == scenario && r.lights == count).and_then(|r| r.median_ms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_name_the_pipeline_and_object_space_settings() {
        let labels: Vec<String> = Shading::pipelines().iter().map(Shading::label).collect();
        assert_eq!(
            labels,
            ["forward", "forward-multipass", "clustered", "deferred", "deferred-compute", "objectspace"]
        );
        assert_eq!(Shading::ObjectSpace { reuse: 3, variable_rate: 0.0 }.label(), "objectspace-reuse3");
        assert_eq!(Shading::ObjectSpace { reuse: 1, variable_rate: 2.0 }.label(), "objectspace-vr2");
        assert!(Shading::CONVENTIONAL.iter().all(Shading::is_conventional) && !Shading::OBJECT_SPACE.is_conventional());
    }
}
