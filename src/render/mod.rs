//! Pipelines and the one seam they share: a [`PipelineConfig`] picks and
//! configures a pipeline, a [`Pipeline`] records a frame's passes into the
//! HDR target, and reports itself in one shape ([`PipelineReport`]). The
//! [`Renderer`] owns what every pipeline uses: the scene on the GPU, the
//! render targets, culling, tone mapping and GPU timing.
//!
//! Adding a pipeline takes one folder (its `mod.rs` composing shared passes
//! from [`passes`], its WGSL beside it), one [`PipelineConfig`] variant and
//! the line in [`Renderer::new`] that builds it.

pub mod clustered;
pub mod clusters;
pub mod culling;
pub mod deferred;
pub mod deferred_compute;
pub mod forward;
pub mod forward_multipass;
pub mod frame;
pub mod gpu_types;
pub mod mesh_memo;
pub mod objectspace;
pub mod passes;
pub mod report;
pub mod scene_gpu;
pub mod shader_set;
pub mod targets;

use std::any::Any;
use std::time::Instant;

use serde::Serialize;

use crate::gpu::timing::{FrameTimings, GpuTimer, GpuTiming};
use crate::gpu::{GpuContext, GpuError, readback};
use crate::hash::fnv1a;
use crate::scene::{Aabb, Camera, Light, LightKind, Scene};
use crate::shaders::{ShaderError, ShaderLibrary};
pub use clustered::ClusteredConfig;
pub use clusters::{ClusterDraws, Culling};
use culling::Frustum;
pub use deferred::DeferredConfig;
pub use deferred_compute::DeferredComputeConfig;
pub use forward::ForwardConfig;
pub use forward_multipass::ForwardMultipassConfig;
pub use frame::Frame;
pub use gpu_types::ShadingModel;
pub use objectspace::ObjectSpaceConfig;
use passes::bloom::{Bloom, bloom};
pub use passes::exposure::Exposure;
use passes::exposure::{AutoExposure, auto_exposure};
pub use passes::shadows::ShadowRefresh;
use passes::shadows::{ShadowMaps, SunView, shadow_maps};
use passes::tonemap::{Tonemap, tonemap};
pub use passes::visibility::VisibilityMethod;
pub use report::{Counters, PipelineReport};
use scene_gpu::SceneGpu;
use targets::Targets;

/// A shading pipeline and its settings.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "name")]
pub enum PipelineConfig {
    /// Single-pass forward shading (the reference image).
    #[serde(rename = "forward")]
    Forward(ForwardConfig),
    /// Multi-pass forward: a depth pre-pass, then one additive pass per light.
    #[serde(rename = "forward-multipass")]
    ForwardMultipass(ForwardMultipassConfig),
    /// Object-space (texel) shading: visible tiles shaded by compute into
    /// per-object atlas squares, reused across frames, gathered per pixel.
    #[serde(rename = "objectspace")]
    ObjectSpace(ObjectSpaceConfig),
    /// Clustered forward: a depth pre-pass, view-space clusters of lights
    /// built on the GPU, fragments lit by their cluster's lights.
    #[serde(rename = "clustered")]
    Clustered(ClusteredConfig),
    /// Deferred shading with light volumes (spheres, cones) blended per light.
    #[serde(rename = "deferred")]
    Deferred(DeferredConfig),
    /// Tiled deferred shading: one compute pass culls and shades per tile.
    #[serde(rename = "deferred-compute")]
    DeferredCompute(DeferredComputeConfig),
}

impl PipelineConfig {
    /// Every pipeline's name, as [`PipelineConfig::name`] gives it.
    pub const NAMES: [&'static str; 6] =
        ["forward", "forward-multipass", "objectspace", "clustered", "deferred", "deferred-compute"];

    /// The pipeline called `name` ([`PipelineConfig::NAMES`]) with its
    /// default settings; `None` for any other name.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "forward" => Self::Forward(ForwardConfig::default()),
            "forward-multipass" => Self::ForwardMultipass(ForwardMultipassConfig::default()),
            "objectspace" => Self::ObjectSpace(ObjectSpaceConfig::default()),
            "clustered" => Self::Clustered(ClusteredConfig::default()),
            "deferred" => Self::Deferred(DeferredConfig::default()),
            "deferred-compute" => Self::DeferredCompute(DeferredComputeConfig::default()),
            _ => return None,
        })
    }

    /// Whether under MSAA the pipeline draws into the multisampled HDR
    /// colour and resolves it ([`targets::Targets::hdr_msaa_view`]), as the
    /// forward family does; deferred-compute resolves in its lighting pass.
    fn resolves_msaa_colour(&self) -> bool {
        matches!(self, Self::Forward(_) | Self::ForwardMultipass(_) | Self::Clustered(_))
    }

    /// How the pipeline fills its visibility buffer, for the pipelines
    /// that have one (`--visibility`); `None` for the others.
    pub fn visibility(&self) -> Option<VisibilityMethod> {
        match self {
            Self::ObjectSpace(c) => Some(c.visibility),
            Self::DeferredCompute(c) => Some(c.visibility),
            _ => None,
        }
    }

    /// The name `--pipeline` takes and reports carry.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Forward(_) => "forward",
            Self::ForwardMultipass(_) => "forward-multipass",
            Self::ObjectSpace(_) => "objectspace",
            Self::Clustered(_) => "clustered",
            Self::Deferred(_) => "deferred",
            Self::DeferredCompute(_) => "deferred-compute",
        }
    }
}

/// How to build a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    pub pipeline: PipelineConfig,
    /// MSAA samples per pixel (`--msaa`): one of [`targets::SAMPLE_COUNTS`];
    /// 1 is no MSAA.
    pub samples: u32,
}

impl RenderOptions {
    /// Options for `pipeline` at `width` x `height`, one sample per pixel.
    pub fn new(width: u32, height: u32, pipeline: PipelineConfig) -> Self {
        Self { width, height, pipeline, samples: 1 }
    }
}

/// Why a renderer cannot take `samples` per pixel: a count MSAA does not
/// have, or a target format the adapter cannot multisample that often.
/// `Ok` for a count every target of the renderer can have.
pub fn check_samples(ctx: &GpuContext, samples: u32) -> Result<(), RenderError> {
    check_sample_formats(ctx, samples, &[targets::HDR_FORMAT, targets::DEPTH_FORMAT])
}

/// [`check_samples`] for a renderer of `pipeline`: also its own targets'
/// formats (the G-buffer's, the raster pass's visibility buffer's; the
/// compute rasterizer's samples are layers, not multisampled).
pub fn check_samples_for(ctx: &GpuContext, samples: u32, pipeline: &PipelineConfig) -> Result<(), RenderError> {
    check_samples(ctx, samples)?;
    if samples == 1 {
        return Ok(());
    }
    let formats: &[wgpu::TextureFormat] = match (pipeline, pipeline.visibility()) {
        (_, Some(VisibilityMethod::Compute)) => &[],
        (PipelineConfig::DeferredCompute(_) | PipelineConfig::Deferred(_), _) => &passes::gbuffer::BASE_FORMATS,
        (PipelineConfig::ObjectSpace(_), _) => &[passes::visibility::FORMAT],
        _ => &[],
    };
    check_sample_formats(ctx, samples, formats)
}

/// [`check_samples`] for render targets of `formats`.
fn check_sample_formats(ctx: &GpuContext, samples: u32, formats: &[wgpu::TextureFormat]) -> Result<(), RenderError> {
    if !targets::SAMPLE_COUNTS.contains(&samples) {
        return Err(RenderError::BadSamples(samples));
    }
    let adapter_specific = ctx.features.contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES);
    for &format in formats {
        // Without adapter-specific format features the device allows only
        // what WebGPU guarantees (1 and 4 samples).
        let flags = if adapter_specific {
            ctx.adapter.get_texture_format_features(format).flags
        } else {
            format.guaranteed_format_features(ctx.features).flags
        };
        unsupported_samples(flags, samples, format, &ctx.info.name)?;
    }
    Ok(())
}

/// [`RenderError::SamplesUnsupported`] when `flags` (a format's features on
/// adapter `adapter`) lack `samples` per pixel.
fn unsupported_samples(
    flags: wgpu::TextureFormatFeatureFlags,
    samples: u32,
    format: wgpu::TextureFormat,
    adapter: &str,
) -> Result<(), RenderError> {
    if flags.sample_count_supported(samples) {
        return Ok(());
    }
    let offered: Vec<String> =
        targets::SAMPLE_COUNTS.iter().filter(|&&n| flags.sample_count_supported(n)).map(|n| n.to_string()).collect();
    Err(RenderError::SamplesUnsupported {
        samples,
        format: format!("{format:?}"),
        adapter: adapter.to_string(),
        offered: offered.join(", "),
    })
}

/// A shading pipeline: records the passes that fill `targets.hdr` (and depth).
pub trait Pipeline: Any {
    /// Records the frame's passes, in order.
    fn encode(&mut self, frame: &mut Frame);
    /// Whether its shaders read the per-object light lists that the CPU
    /// culls every frame (`Object.light_offset/light_count`). Pipelines with
    /// a GPU light grid say no, and the renderer skips that culling.
    fn uses_object_light_lists(&self) -> bool {
        true
    }
    /// Builds cluster culling for its hardware raster passes
    /// ([`passes::cluster_draws`]); the renderer calls it before the first
    /// frame whose [`Renderer::culling`] is not none (building nothing for
    /// runs that never cull). Pipelines that cull no raster pass do nothing.
    fn enable_cluster_culling(
        &mut self,
        _device: &wgpu::Device,
        _shaders: &mut ShaderLibrary,
        _scene: &SceneGpu,
        _targets: &Targets,
    ) -> Result<(), ShaderError> {
        Ok(())
    }
    /// Called before recording a frame whose lights differ from the last
    /// frame's (and before the first), with its count of point and spot
    /// lights: pipelines whose passes are built for a light count
    /// (`deferred-compute`'s tile side under `--dc-tile auto`) build them
    /// again here. Others do nothing.
    fn lights_changed(
        &mut self,
        _device: &wgpu::Device,
        _shaders: &mut ShaderLibrary,
        _scene: &SceneGpu,
        _point_lights: usize,
    ) -> Result<(), ShaderError> {
        Ok(())
    }
    /// Called right after the frame's submit (to start read-backs).
    fn after_submit(&mut self) {}
    /// Counters of finished frames, by frame number, oldest first; `wait`
    /// waits for all. Pipelines that count nothing return none.
    fn collect_counters(&mut self, _device: &wgpu::Device, _wait: bool) -> Vec<(u64, Counters)> {
        Vec::new()
    }
    /// Settings, memory and setup facts.
    fn report(&self) -> PipelineReport;
}

/// Statistics of one frame. GPU timings and counters arrive a few frames
/// later (they are never waited for inside the frame loop).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub frame: u64,
    /// CPU time to record and submit the frame (culling, uploads, encoding).
    pub cpu_ms: f64,
    pub visible_objects: u32,
    /// Sum over objects of the lights assigned to them.
    pub light_assignments: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error("image size {0}x{1} is not supported (1..={2} per side)")]
    BadSize(u32, u32, u32),
    #[error(transparent)]
    ObjectSpace(#[from] objectspace::ObjectSpaceError),
    #[error(transparent)]
    ComputeVisibility(#[from] passes::visibility::compute::ComputeVisibilityError),
    #[error("bloom strength {0} is not a number from 0 to 1")]
    BadBloom(f32),
    #[error("bloom needs read-write Rgba16Float storage textures, which {0} does not offer")]
    BloomUnsupported(String),
    #[error("--aniso {0}: texture anisotropy takes 1, 2, 4, 8 or 16 taps")]
    BadAnisotropy(u16),
    #[error("--msaa {0}: MSAA takes 1, 2, 4 or 8 samples per pixel")]
    BadSamples(u32),
    #[error(
        "--msaa {samples}: {adapter} cannot render {format} targets with {samples} samples per pixel (it offers {offered})"
    )]
    SamplesUnsupported { samples: u32, format: String, adapter: String, offered: String },
}

impl RenderError {
    /// Whether the error is the options' fault (a size, sample count or
    /// bloom the adapter or pipeline cannot do), not the program's.
    pub fn is_bad_option(&self) -> bool {
        matches!(
            self,
            Self::BadSize(..)
                | Self::BadBloom(_)
                | Self::BloomUnsupported(_)
                | Self::BadAnisotropy(_)
                | Self::BadSamples(_)
                | Self::SamplesUnsupported { .. }
        )
    }
}

/// Renders frames of one scene at one size with one pipeline.
pub struct Renderer {
    pub scene: SceneGpu,
    pub targets: Targets,
    pipeline: Box<dyn Pipeline>,
    name: &'static str,
    tonemap: Tonemap,
    auto_exposure: AutoExposure,
    /// None where the adapter cannot run it ([`Bloom::supported`]).
    bloom_pass: Option<Bloom>,
    timer: GpuTimer,
    /// What the GPU timestamps time (default: every pass).
    pub timing: GpuTiming,
    /// How the HDR frame is scaled before tone mapping (default: fixed 1).
    pub exposure: Exposure,
    /// Bloom strength, 0..=1: the fraction of the light spread into the glow
    /// (0, the default, skips the pass).
    pub bloom: f32,
    /// When the shadow maps are re-rendered (default: when they change).
    pub shadow_refresh: ShadowRefresh,
    /// Whether the first directional light casts cascaded shadows (default
    /// off: the generated sets' sun is a dim fill meant to cost nothing, and
    /// the goldens are rendered without it).
    pub sun_shadow: bool,
    /// The lighting model every pass evaluates (default Phong, the studies').
    pub shading: ShadingModel,
    /// How the compute rasterizer culls the scene's clusters (default:
    /// two-pass occlusion; the visibility buffer is the same in every mode).
    pub culling: Culling,
    /// Whether the compute rasterizer reads each covered pixel before its
    /// 64-bit atomicMax and skips the atomic where the pixel already holds
    /// something nearer (default false: fewer atomics but, on the H200, a
    /// slower pass; the ids are the same either way).
    pub vis_depth_test: bool,
    /// Most pixels of a triangle's bounds that the compute rasterizer draws
    /// in the triangle's own thread (default
    /// [`scene_gpu::DEFAULT_SMALL_AREA`]); bigger ones are set up once and
    /// drawn by workgroups, a 32x32 tile each. The ids are the same whatever it is.
    pub vis_small_area: u32,
    /// Workgroups of the compute rasterizer's pass over big triangles' tiles
    /// (default [`scene_gpu::big_workgroups_for`] the adapter), which loop over them.
    /// The ids are the same whatever it is.
    pub vis_big_workgroups: u32,
    /// How the hardware raster passes draw the clusters culling keeps
    /// (default indexed, where the adapter can: [`passes::cluster_draws`]).
    /// Read when culling is first built, before the first frame that culls.
    pub cluster_draws: ClusterDraws,
    /// The hardware raster passes draw the plain way, every object in view,
    /// in a frame after one whose culling kept more than this share of the
    /// clusters it tested (default [`clusters::CULL_PLAIN_ABOVE`]; 1: always
    /// draw what culling keeps). The image is the same either way.
    pub cull_plain_above: f32,
    /// Sub-pixel offset of the projection, in pixels (x right, y down;
    /// default none): supersampled references (`crate::reference`) average
    /// frames rendered at a grid of such offsets.
    pub jitter: glam::Vec2,
    /// Added to the mip level of every material texture sample taken from a
    /// footprint, in every pipeline (default 0: the footprint's own level).
    /// References set `-log2(N)` so that N x N jittered samples filter
    /// textures as a frame N times larger would.
    pub texture_lod_bias: f32,
    /// The most anisotropic taps a material texture sample takes (`--aniso`,
    /// one of [`TEXTURE_ANISOTROPY`]; default 1: trilinear alone), in every
    /// pipeline that samples material textures per pixel or per sample with
    /// a footprint: forward, multi-pass, clustered, deferred, deferred-compute,
    /// their compute-visibility forms, and object space's objects shaded
    /// forward. Object space's texels are shaded at an explicit level (an
    /// isotropic footprint), so its shading does not change
    /// ([`SceneGpu::set_anisotropy`]). Applied at the next frame; an adapter
    /// without anisotropic filtering gets a warning and isotropic samples.
    pub texture_anisotropy: u16,
    shadows: ShadowMaps,
    /// The library the pipelines were built with (cluster culling builds
    /// its variants from it when first needed).
    shaders: ShaderLibrary,
    /// Whether [`Pipeline::enable_cluster_culling`] was called.
    cluster_culling_built: bool,
    /// Hash of the previous frame's lights, to tell when they change.
    lights_hash: Option<u64>,
    /// Submissions of the frames the GPU may still be working on.
    in_flight: std::collections::VecDeque<wgpu::SubmissionIndex>,
    /// Counters of finished frames that [`Renderer::render`] collected
    /// (so that object space's budget and residency follow them in every
    /// frame loop, whether or not its caller reads them), kept for
    /// [`Renderer::collect_counters`]: at most [`KEPT_COUNTERS`] frames.
    arrived: std::collections::VecDeque<(u64, Counters)>,
}

/// Most frames of counters a renderer keeps for a caller that never reads
/// them ([`Renderer::collect_counters`]): the oldest go first.
pub const KEPT_COUNTERS: usize = 256;

/// Adds `new` frames' counters to `into`, a frame's counters to its entry
/// where it has one (the shadow maps' culling counts join the pipeline's).
fn merge_counters(into: &mut std::collections::VecDeque<(u64, Counters)>, new: Vec<(u64, Counters)>) {
    for (frame, counters) in new {
        match into.iter_mut().rev().find(|(f, _)| *f == frame) {
            Some((_, c)) => c.extend(counters),
            None => into.push_back((frame, counters)),
        }
    }
}

/// The values [`Renderer::texture_anisotropy`] takes (`--aniso`).
pub const TEXTURE_ANISOTROPY: [u16; 5] = [1, 2, 4, 8, 16];

/// Most frames queued ahead of the GPU, as a swap chain allows: without a
/// limit the CPU runs arbitrarily far ahead (bench has no presentation), and
/// what the GPU reports back (counters driving the budget) arrives that many
/// frames late.
pub const MAX_FRAMES_IN_FLIGHT: usize = 3;

impl Renderer {
    pub fn new(ctx: &GpuContext, scene: &Scene, options: &RenderOptions) -> Result<Self, RenderError> {
        let (width, height) = (options.width, options.height);
        let max = ctx.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadSize(width, height, max));
        }
        let samples = options.samples;
        check_samples_for(ctx, samples, &options.pipeline)?;
        let mut shaders = crate::render::shader_set::library()?;
        shaders.keep_pipelines_in(&ctx.pipelines);
        let mut scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, scene);
        if let Some(env) = &scene.environment {
            let maps = passes::environment::prefilter(ctx, &mut shaders, env)?;
            scene_gpu.set_environment(&ctx.device, maps);
            shaders.define(crate::shaders::ENVIRONMENT);
        }
        if scene_gpu.material_textures {
            shaders.define(crate::shaders::MATERIAL_TEXTURES);
        }
        if scene_gpu.layers {
            shaders.define(crate::shaders::LAYERS);
            // The G-buffer then holds UV0 too, at every sample.
            if samples > 1
                && matches!(options.pipeline, PipelineConfig::Deferred(_) | PipelineConfig::DeferredCompute(_))
            {
                check_sample_formats(ctx, samples, &[passes::gbuffer::UV_LOD_FORMAT])?;
            }
        }
        if samples > 1 {
            // The passes reading ids or the G-buffer read every sample.
            shaders.define(crate::shaders::MSAA);
            if options.pipeline.visibility() == Some(VisibilityMethod::Compute) {
                shaders.define(crate::shaders::VISIBILITY_LAYERS);
            }
        }
        let targets = Targets::new(&ctx.device, width, height, samples, options.pipeline.resolves_msaa_colour());
        let (device, queue) = (&ctx.device, &ctx.queue);
        let pipeline: Box<dyn Pipeline> = match &options.pipeline {
            PipelineConfig::Forward(c) => {
                Box::new(forward::Forward::new(device, &mut shaders, &scene_gpu, &targets, *c)?)
            }
            PipelineConfig::ForwardMultipass(c) => {
                Box::new(forward_multipass::ForwardMultipass::new(device, &mut shaders, &scene_gpu, &targets, *c)?)
            }
            PipelineConfig::ObjectSpace(c) => {
                let os = objectspace::ObjectSpace::new(ctx, &mut shaders, scene, &scene_gpu, &targets, c.clone())?;
                Box::new(os)
            }
            PipelineConfig::Clustered(c) => {
                Box::new(clustered::Clustered::new(device, &mut shaders, &scene_gpu, &targets, *c)?)
            }
            PipelineConfig::Deferred(c) => {
                Box::new(deferred::Deferred::new(device, &mut shaders, &scene_gpu, &targets, *c)?)
            }
            PipelineConfig::DeferredCompute(c) => {
                Box::new(deferred_compute::DeferredCompute::new(device, &mut shaders, &scene_gpu, &targets, *c)?)
            }
        };
        let tonemap = Tonemap::new(device, &mut shaders, &targets)?;
        let auto_exposure = AutoExposure::new(device, &mut shaders, &targets, tonemap.exposure_buffer())?;
        let bloom_pass = Bloom::supported(ctx).then(|| Bloom::new(device, &mut shaders, &targets)).transpose()?;
        let shadows = ShadowMaps::new(device, &mut shaders, &scene_gpu)?;
        let timer = GpuTimer::new(device, queue);
        ctx.check_errors()?;
        Ok(Self {
            scene: scene_gpu,
            targets,
            pipeline,
            name: options.pipeline.name(),
            tonemap,
            auto_exposure,
            bloom_pass,
            timer,
            timing: GpuTiming::default(),
            exposure: Exposure::default(),
            bloom: 0.0,
            shadow_refresh: ShadowRefresh::default(),
            sun_shadow: false,
            shading: ShadingModel::Phong,
            culling: Culling::for_scene(scene.objects.len()),
            vis_depth_test: false,
            vis_small_area: scene_gpu::DEFAULT_SMALL_AREA,
            vis_big_workgroups: scene_gpu::big_workgroups_for(ctx.info.device_type),
            cluster_draws: ClusterDraws::default(),
            cull_plain_above: clusters::CULL_PLAIN_ABOVE,
            jitter: glam::Vec2::ZERO,
            texture_lod_bias: 0.0,
            texture_anisotropy: 1,
            shadows,
            shaders,
            cluster_culling_built: false,
            lights_hash: None,
            in_flight: Default::default(),
            arrived: Default::default(),
        })
    }

    pub fn pipeline_name(&self) -> &'static str {
        self.name
    }

    /// The pipeline as its concrete type, for its own debug read-backs (for
    /// example [`objectspace::ObjectSpace::read_atlas`]).
    pub fn pipeline<T: Pipeline>(&self) -> Option<&T> {
        (self.pipeline.as_ref() as &dyn Any).downcast_ref::<T>()
    }

    /// The pipeline as its concrete type, to change its live settings (for
    /// example [`objectspace::ObjectSpace::set_atlas_pages`]).
    pub fn pipeline_mut<T: Pipeline>(&mut self) -> Option<&mut T> {
        (self.pipeline.as_mut() as &mut dyn Any).downcast_mut::<T>()
    }

    /// Culls, uploads and records one frame, and submits it. Does not wait
    /// for the GPU.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        camera: &Camera,
        lights: &[Light],
        frame: u64,
    ) -> Result<FrameStats, RenderError> {
        while self.in_flight.len() >= MAX_FRAMES_IN_FLIGHT {
            let oldest = self.in_flight.pop_front().expect("not empty");
            let wait = wgpu::PollType::Wait { submission_index: Some(oldest), timeout: None };
            ctx.device
                .poll(wait)
                .map_err(|e| RenderError::Gpu(GpuError::Readback(format!("waiting for a frame: {e}"))))?;
        }
        // Counters of finished frames drive object space's budget and
        // residency as they are collected: a frame loop that never asked
        // for them (the quality experiment's did not) left the atlas at its
        // first size and the mip bias at 0, so that a view needing more
        // pages than the atlas holds had them shaded forward every frame.
        self.gather_counters(ctx, false);
        while self.arrived.len() > KEPT_COUNTERS {
            self.arrived.pop_front();
        }
        let start = Instant::now();
        if !(0.0..=1.0).contains(&self.bloom) {
            return Err(RenderError::BadBloom(self.bloom));
        }
        if self.texture_anisotropy != self.scene.anisotropy() {
            if !TEXTURE_ANISOTROPY.contains(&self.texture_anisotropy) {
                return Err(RenderError::BadAnisotropy(self.texture_anisotropy));
            }
            if self.texture_anisotropy > 1 && !ctx.has_anisotropic_filtering() {
                // wgpu then makes the sampler isotropic without a word.
                tracing::warn!(
                    "--aniso {}: {} has no anisotropic filtering (samplerAnisotropy); textures are filtered trilinearly",
                    self.texture_anisotropy,
                    ctx.info.name
                );
            }
            self.scene.set_anisotropy(&ctx.device, self.texture_anisotropy);
        }
        let bloom_pass = match &self.bloom_pass {
            _ if self.bloom == 0.0 => None,
            Some(pass) => Some(pass),
            None => return Err(RenderError::BloomUnsupported(ctx.info.name.clone())),
        };
        let (w, h) = (self.targets.width, self.targets.height);
        // Without an environment its lights add nothing: their shader code
        // is compiled only with one (`shaders::ENVIRONMENT`).
        let without_environment: Vec<Light>;
        let lights = if !self.scene.environment.is_set() && lights.iter().any(|l| l.kind == LightKind::Environment) {
            without_environment = lights.iter().filter(|l| l.kind != LightKind::Environment).copied().collect();
            &without_environment
        } else {
            lights
        };
        let (lights, global_lights) = scene_gpu::order_lights(lights);
        let mut view = scene_gpu::gpu_view(camera, w, h);
        if self.jitter != glam::Vec2::ZERO {
            // A shift in NDC after the projection (scaled by clip w): every
            // pass that rasterizes the camera's view moves by the same offset.
            let ndc = glam::Vec3::new(2.0 * self.jitter.x / w as f32, -2.0 * self.jitter.y / h as f32, 0.0);
            view.view_proj = glam::Mat4::from_translation(ndc) * view.view_proj;
        }
        view.light_count = lights.len() as u32;
        view.global_light_count = global_lights;
        view.shading = self.shading as u32;
        view.texture_lod_bias = self.texture_lod_bias;
        let frustum = Frustum::from_view_projection(view.view_proj);
        let lists = if self.pipeline.uses_object_light_lists() {
            culling::lights_per_object(&lights, &self.scene.object_bounds, Some(&frustum))
        } else if self.scene.has_blended() {
            // Deferred's and deferred-compute's blended passes light their
            // objects forward, from these lists.
            let bounds: Vec<Aabb> = (self.scene.object_bounds.iter().zip(&self.scene.blended))
                .map(|(b, &blended)| if blended { *b } else { Aabb::EMPTY })
                .collect();
            culling::lights_per_object(&lights, &bounds, Some(&frustum))
        } else {
            culling::LightLists::empty(self.scene.object_bounds.len())
        };
        // Blended objects are drawn by the pipelines' blended passes only.
        let visible: Vec<bool> = (self.scene.object_bounds.iter().zip(&self.scene.blended))
            .map(|(b, &blended)| !blended && frustum.intersects_aabb(b))
            .collect();
        let sun = self.sun_shadow.then(|| SunView {
            camera,
            aspect: w as f32 / h as f32,
            scene: self.scene.object_bounds.iter().fold(Aabb::EMPTY, |b, o| b.union(o)),
        });
        let shadow_plan = passes::shadows::plan(&lights, sun.as_ref(), ctx.limits.max_texture_array_layers);

        let gpu_lights: Vec<gpu_types::GpuLight> = lights
            .iter()
            .zip(&shadow_plan.lights)
            .map(|(l, &(shadow_face, shadow_faces))| gpu_types::GpuLight {
                shadow_face,
                shadow_faces,
                ..gpu_types::GpuLight::from(l)
            })
            .collect();
        let hash = fnv1a(bytemuck::cast_slice(&gpu_lights));
        let lights_changed = self.lights_hash != Some(hash);
        self.lights_hash = Some(hash);
        let changed = lights_changed.then_some(gpu_lights.as_slice());
        if lights_changed && shadow_plan.unshadowed > 0 {
            let max = ctx.limits.max_texture_array_layers;
            tracing::warn!("{} shadowed lights cast no shadow: the atlas holds {max} faces", shadow_plan.unshadowed);
        }
        self.shadows.set_plan(&ctx.device, &ctx.queue, &mut self.scene, &lights, &shadow_plan);
        if lights_changed {
            let point_lights = lights.len() - global_lights as usize;
            self.pipeline.lights_changed(&ctx.device, &mut self.shaders, &self.scene, point_lights)?;
        }
        self.scene.update_frame(&ctx.device, &ctx.queue, &view, changed, &lists);
        self.scene.culling = self.culling;
        self.scene.vis_depth_test = self.vis_depth_test;
        self.scene.vis_small_area = self.vis_small_area;
        self.scene.vis_big_workgroups = self.vis_big_workgroups;
        self.scene.cull_plain_above = self.cull_plain_above;
        if self.culling != Culling::None && !self.cluster_culling_built {
            self.scene.cluster_draws = passes::cluster_draws::draws_for(self.cluster_draws, &ctx.device, &self.scene);
            self.pipeline.enable_cluster_culling(&ctx.device, &mut self.shaders, &self.scene, &self.targets)?;
            if self.scene.cluster_draws == ClusterDraws::Indexed {
                self.shadows.enable_culling(&ctx.device, &mut self.shaders, &self.scene)?;
            }
            self.cluster_culling_built = true;
        }
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let time_passes = self.timing == GpuTiming::Passes;
        let frame_query = (!time_passes).then(|| self.timer.profiler().begin_query("frame", &mut encoder));
        {
            let mut f = Frame {
                device: &ctx.device,
                queue: &ctx.queue,
                scene: &self.scene,
                scene_group: self.scene.bind_group(),
                targets: &self.targets,
                camera,
                lights: &lights,
                view: &view,
                visible: &visible,
                number: frame,
                lights_changed,
                encoder: &mut encoder,
                profiler: self.timer.profiler(),
                time_passes,
            };
            shadow_maps(&mut f, &mut self.shadows, self.shadow_refresh == ShadowRefresh::EveryFrame);
            self.pipeline.encode(&mut f);
            if let Some(pass) = bloom_pass {
                bloom(&mut f, pass, self.bloom);
            }
            match self.exposure {
                Exposure::Fixed(e) => tonemap(&mut f, &self.tonemap, Some(e)),
                Exposure::Auto => {
                    auto_exposure(&mut f, &self.auto_exposure);
                    tonemap(&mut f, &self.tonemap, None);
                }
            }
        }
        if let Some(query) = frame_query {
            self.timer.profiler().end_query(&mut encoder, query);
        }
        self.timer.resolve(&mut encoder);
        self.in_flight.push_back(ctx.queue.submit([encoder.finish()]));
        self.timer.end_frame(frame);
        self.pipeline.after_submit();
        self.shadows.after_submit();
        ctx.check_errors()?;
        Ok(FrameStats {
            frame,
            cpu_ms: start.elapsed().as_secs_f64() * 1e3,
            visible_objects: visible.iter().filter(|v| **v).count() as u32,
            light_assignments: lists.indices.len() as u64,
        })
    }

    /// GPU timings of finished frames; `wait` blocks until all are in.
    pub fn collect_timings(&mut self, ctx: &GpuContext, wait: bool) -> Vec<FrameTimings> {
        self.timer.collect(&ctx.device, wait)
    }

    /// Pipeline counters of finished frames, with the shadow maps' culling
    /// counts ([`passes::shadows::cull::ShadowCull::collect_counts`]) in
    /// the frames that culled them; `wait` blocks until all are in.
    /// Those [`Renderer::render`] collected on its own come first (the last
    /// [`KEPT_COUNTERS`] frames of them).
    pub fn collect_counters(&mut self, ctx: &GpuContext, wait: bool) -> Vec<(u64, Counters)> {
        self.gather_counters(ctx, wait);
        std::mem::take(&mut self.arrived).into()
    }

    /// Moves the pipeline's and the shadow maps' counters that have arrived
    /// into `arrived` (collecting the pipeline's feeds its controllers).
    fn gather_counters(&mut self, ctx: &GpuContext, wait: bool) {
        let pipeline = self.pipeline.collect_counters(&ctx.device, wait);
        let shadows = self.shadows.collect_counts(&ctx.device, wait);
        merge_counters(&mut self.arrived, pipeline);
        merge_counters(&mut self.arrived, shadows);
    }

    /// The pipeline's settings, memory and setup, with what the renderer
    /// holds for every pipeline: the shadow maps (`shadow_maps` bytes,
    /// `shadow_faces`, the faces of the last frame's lights (the sun's
    /// cascades included), `shadow_refresh_every_frame` and `sun_shadow`,
    /// 1 when set), MSAA (`msaa_samples`, and `msaa_targets`: the bytes
    /// of the multisampled colour and depth, 0 at one sample), the
    /// environment (`environment`, 1 with `--env`; `environment_maps` bytes),
    /// the compute rasterizer's `culling` (0 none, 1 frustum, 2 occlusion),
    /// and the scene's own GPU data as setup facts ([`SceneGpu::memory`]: the
    /// same for every pipeline, so not in `memory`).
    pub fn report(&self) -> PipelineReport {
        let every_frame = self.shadow_refresh == ShadowRefresh::EveryFrame;
        let report = self.scene.memory().into_iter().fold(self.pipeline.report(), |r, (k, v)| r.setup(k, v));
        report
            .memory("shadow_maps", self.scene.shadow_atlas.bytes())
            .setup("shadow_faces", self.shadows.faces() as u64)
            .setup("shadow_refresh_every_frame", every_frame as u64)
            .setup("sun_shadow", self.sun_shadow as u64)
            .setup("culling", self.culling as u64)
            .setup("shadow_cluster_culling", self.shadows.culls() as u64)
            .memory("shadow_culling", self.shadows.cull_bytes())
            .setup(
                "cluster_draws_indexed",
                (self.cluster_culling_built && self.scene.cluster_draws == ClusterDraws::Indexed) as u64,
            )
            .setup("msaa_samples", u64::from(self.targets.samples))
            .memory("msaa_targets", self.targets.msaa_bytes())
            .setup("environment", self.scene.environment.is_set() as u64)
            .memory(
                "environment_maps",
                if self.scene.environment.is_set() { self.scene.environment.bytes() } else { 0 },
            )
    }

    /// Whether the adapter can time passes.
    pub fn timing_enabled(&self) -> bool {
        self.timer.enabled()
    }

    /// Writes the newest collected frame's GPU timings as a Chrome trace;
    /// false when none was collected.
    pub fn write_trace(&self, path: &std::path::Path) -> std::io::Result<bool> {
        self.timer.write_trace(path)
    }

    /// The exposure multiplier the last frame was tone-mapped with (blocks):
    /// the fixed one, or what automatic exposure found.
    pub fn read_exposure(&self, ctx: &GpuContext) -> Result<f32, RenderError> {
        let bytes = readback::read_whole_buffer(ctx, self.tonemap.exposure_buffer())?;
        Ok(f32::from_le_bytes(bytes[..4].try_into().expect("the exposure buffer holds a vec4")))
    }

    /// Object space only (`None` for the other pipelines): per pixel of the
    /// last frame, what its gather read ([`objectspace::ObjectSpace::read_pixel_classes`];
    /// a debug pass outside the frame, blocking).
    pub fn read_pixel_classes(
        &mut self,
        ctx: &GpuContext,
    ) -> Result<Option<Vec<objectspace::debug::PixelClass>>, RenderError> {
        let Some(os) = (self.pipeline.as_mut() as &mut dyn Any).downcast_mut::<objectspace::ObjectSpace>() else {
            return Ok(None);
        };
        os.read_pixel_classes(ctx, &mut self.shaders, &self.scene).map(Some)
    }

    /// Reads the last tone-mapped frame back (blocks).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<image::RgbaImage, RenderError> {
        let bytes = readback::read_texture_rgba8(ctx, &self.targets.ldr)?;
        Ok(image::RgbaImage::from_raw(self.targets.width, self.targets.height, bytes)
            .expect("read-back has w*h*4 bytes"))
    }
}

#[cfg(test)]
mod tests {
    use super::{PipelineConfig, RenderError, unsupported_samples};

    /// A format with 4 samples only refuses 2 and 8, naming the count, the
    /// format, the adapter and the counts it has.
    #[test]
    fn sample_counts_the_format_lacks_are_named() {
        let flags = wgpu::TextureFormatFeatureFlags::MULTISAMPLE_X4;
        let format = wgpu::TextureFormat::Rgba16Float;
        assert!(unsupported_samples(flags, 1, format, "gpu").is_ok());
        assert!(unsupported_samples(flags, 4, format, "gpu").is_ok());
        for n in [2, 8] {
            let e = unsupported_samples(flags, n, format, "gpu").unwrap_err();
            assert!(matches!(e, RenderError::SamplesUnsupported { samples, .. } if samples == n));
            assert_eq!(
                e.to_string(),
                format!(
                    "--msaa {n}: gpu cannot render Rgba16Float targets with {n} samples per pixel (it offers 1, 4)"
                )
            );
        }
    }

    #[test]
    fn every_pipeline_name_builds_its_config() {
        for name in PipelineConfig::NAMES {
            assert_eq!(PipelineConfig::from_name(name).map(|p| p.name()), Some(name));
        }
        assert!(PipelineConfig::from_name("Forward").is_none() && PipelineConfig::from_name("").is_none());
    }
}
