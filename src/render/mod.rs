//! Pipelines and what they share: the scene on the GPU, render targets, tone
//! mapping, per-frame statistics, and the [`Renderer`] that runs a frame.

pub mod culling;
pub mod forward;
pub mod gpu_types;
pub mod objectspace;
pub mod scene_gpu;
pub mod targets;
pub mod tonemap;

use std::time::Instant;

use serde::Serialize;

use crate::gpu::timing::{FrameTimings, GpuTimer};
use crate::gpu::{GpuContext, GpuError, readback};
use crate::scene::{Camera, Light, Scene};
use crate::shaders::{ShaderError, ShaderLibrary};
use culling::Frustum;
use scene_gpu::SceneGpu;
use targets::Targets;
use tonemap::Tonemap;

/// Depth state of a scene raster pass (reversed Z: nearer is greater).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum DepthMode {
    /// Test `Greater` and write: the first (or only) pass.
    Write,
    /// Test `Equal`, no write: after a depth pre-pass, one fragment per pixel.
    EqualAfterPrepass,
}

/// A raster pipeline over the scene bind group: vertices pulled from storage
/// (no vertex buffers), no face culling, a reversed-Z depth test, and a
/// fragment stage writing `color` when given (none: depth only).
pub(crate) fn scene_raster_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    vertex_entry: &str,
    fragment: Option<(&str, wgpu::TextureFormat)>,
    depth: DepthMode,
) -> wgpu::RenderPipeline {
    let targets = fragment.map(|(_, format)| [Some(format.into())]);
    let (depth_write, compare) = match depth {
        DepthMode::Write => (true, wgpu::CompareFunction::Greater),
        DepthMode::EqualAfterPrepass => (false, wgpu::CompareFunction::Equal),
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vertex_entry),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: fragment.zip(targets.as_ref()).map(|((entry, _), targets)| wgpu::FragmentState {
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets,
        }),
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: targets::DEPTH_FORMAT,
            depth_write_enabled: Some(depth_write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    })
}

/// The shading pipelines, for `--pipeline`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PipelineKind {
    /// Single-pass forward shading (the reference image).
    Forward,
    /// Object-space (texel) shading: visible tiles shaded by compute into
    /// per-object atlas squares, reused across frames, gathered per pixel.
    #[value(name = "objectspace")]
    #[serde(rename = "objectspace")]
    ObjectSpace,
}

/// How to build a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub pipeline: PipelineKind,
    pub width: u32,
    pub height: u32,
    /// Forward: depth pre-pass before shading.
    pub depth_prepass: bool,
    /// Object space: tile size, reuse, mip bias, texture sizes, debug view.
    pub objectspace: Option<objectspace::ObjectSpaceOptions>,
}

/// What a pipeline needs to record one frame.
pub struct FrameContext<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub scene: &'a SceneGpu,
    pub targets: &'a Targets,
    pub camera: &'a Camera,
    /// Per object: inside the view frustum.
    pub visible: &'a [bool],
    pub frame: u64,
    /// The lights differ from the previous frame's (cached shades are stale).
    pub lights_changed: bool,
}

/// A shading pipeline: records the passes that fill `targets.hdr` (and depth).
pub trait Pipeline {
    fn name(&self) -> &'static str;
    fn encode(&mut self, frame: &FrameContext, encoder: &mut wgpu::CommandEncoder, timer: &mut GpuTimer);
    /// Called right after the frame's submit (to start read-backs).
    fn after_submit(&mut self) {}
    /// Shading counters of finished frames (object-space pipelines only).
    fn collect_counters(&mut self, _device: &wgpu::Device, _wait: bool) -> Vec<ShadingCounters> {
        Vec::new()
    }
    /// The object-space pipeline, when this is one (for its reports and debug read-backs).
    fn objectspace(&self) -> Option<&objectspace::ObjectSpace> {
        None
    }
}

/// What an object-space frame shaded, counted on the GPU.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ShadingCounters {
    pub frame: u64,
    /// Tiles some pixel needs this frame.
    pub visible_tiles: u64,
    /// Visible tiles shaded this frame (their cached shade was too old or stale).
    pub shaded_tiles: u64,
    /// Visible tiles whose cached shade was reused.
    pub reused_tiles: u64,
    /// Visible tiles that were not visible in the previous frame.
    pub new_tiles: u64,
    /// shaded tiles x tile area.
    pub shaded_texels: u64,
    /// visible tiles x tile area (what shading every visible tile costs).
    pub visible_texels: u64,
}

/// Statistics of one frame. GPU timings arrive a few frames later (they are
/// never waited for inside the frame loop); see [`Renderer::collect_timings`].
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameStats {
    pub frame: u64,
    /// CPU time to record and submit the frame (culling, uploads, encoding).
    pub cpu_ms: f64,
    pub visible_objects: u32,
    /// Sum over objects of the lights assigned to them.
    pub light_assignments: u64,
    pub screen_pixels: u64,
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
}

/// Renders frames of one scene at one size with one pipeline.
pub struct Renderer {
    pub scene: SceneGpu,
    pub targets: Targets,
    pipeline: Box<dyn Pipeline>,
    tonemap: Tonemap,
    timer: GpuTimer,
    pub exposure: f32,
    /// Hash of the previous frame's lights, to tell when they change.
    lights_hash: Option<u64>,
}

/// Passes a frame may time (pipelines use a handful).
const MAX_TIMED_PASSES: u32 = 16;

impl Renderer {
    pub fn new(ctx: &GpuContext, scene: &Scene, options: &RenderOptions) -> Result<Self, RenderError> {
        let (width, height) = (options.width, options.height);
        let max = ctx.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadSize(width, height, max));
        }
        let mut shaders = ShaderLibrary::new()?;
        let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, scene);
        let targets = Targets::new(&ctx.device, width, height);
        let pipeline: Box<dyn Pipeline> = match options.pipeline {
            PipelineKind::Forward => Box::new(forward::Forward::new(
                &ctx.device,
                &mut shaders,
                &scene_gpu.layout,
                forward::ForwardOptions { depth_prepass: options.depth_prepass },
            )?),
            PipelineKind::ObjectSpace => {
                let os = options.objectspace.clone().unwrap_or_else(|| objectspace::ObjectSpaceOptions {
                    texture_sizes: vec![Some(1024); scene.objects.len()],
                    ..Default::default()
                });
                Box::new(objectspace::ObjectSpace::new(
                    &ctx.device,
                    &ctx.queue,
                    &ctx.info.name,
                    &mut shaders,
                    &scene_gpu,
                    &targets,
                    os,
                )?)
            }
        };
        let tonemap = Tonemap::new(&ctx.device, &mut shaders, &targets)?;
        let timer = GpuTimer::new(&ctx.device, &ctx.queue, MAX_TIMED_PASSES);
        ctx.check_errors()?;
        Ok(Self { scene: scene_gpu, targets, pipeline, tonemap, timer, exposure: 1.0, lights_hash: None })
    }

    pub fn pipeline_name(&self) -> &'static str {
        self.pipeline.name()
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
        let start = Instant::now();
        let (w, h) = (self.targets.width, self.targets.height);
        let view = scene_gpu::gpu_view(camera, w, h, frame, self.exposure);
        let frustum = Frustum::from_view_projection(view.view_proj);
        let lists = culling::lights_per_object(lights, &self.scene.object_bounds, Some(&frustum));
        let visible: Vec<bool> = self.scene.object_bounds.iter().map(|b| frustum.intersects_aabb(b)).collect();
        let gpu_lights: Vec<gpu_types::GpuLight> = lights.iter().map(gpu_types::GpuLight::from).collect();
        let hash = hash_bytes(bytemuck::cast_slice(&gpu_lights));
        let lights_changed = self.lights_hash != Some(hash);
        self.lights_hash = Some(hash);
        let changed = lights_changed.then_some(gpu_lights.as_slice());
        self.scene.update_frame(&ctx.device, &ctx.queue, &view, changed, &lists);
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        self.timer.begin_frame(frame);
        let frame_ctx = FrameContext {
            device: &ctx.device,
            queue: &ctx.queue,
            scene: &self.scene,
            targets: &self.targets,
            camera,
            visible: &visible,
            frame,
            lights_changed,
        };
        self.pipeline.encode(&frame_ctx, &mut encoder, &mut self.timer);
        self.tonemap.encode(&ctx.queue, &mut encoder, self.exposure, &mut self.timer);
        self.timer.end_frame(&ctx.device, &mut encoder);
        ctx.queue.submit([encoder.finish()]);
        self.timer.after_submit();
        self.pipeline.after_submit();
        ctx.check_errors()?;
        Ok(FrameStats {
            frame,
            cpu_ms: start.elapsed().as_secs_f64() * 1e3,
            visible_objects: visible.iter().filter(|v| **v).count() as u32,
            light_assignments: lists.indices.len() as u64,
            screen_pixels: w as u64 * h as u64,
        })
    }

    /// GPU timings of finished frames; `wait` blocks until all are in.
    pub fn collect_timings(&mut self, ctx: &GpuContext, wait: bool) -> Vec<FrameTimings> {
        self.timer.collect(&ctx.device, wait)
    }

    /// Shading counters of finished frames (empty for forward); `wait`
    /// blocks until all are in.
    pub fn collect_counters(&mut self, ctx: &GpuContext, wait: bool) -> Vec<ShadingCounters> {
        self.pipeline.collect_counters(&ctx.device, wait)
    }

    /// Memory of the pipeline's own resources, when it reports any.
    pub fn memory(&self) -> Option<objectspace::MemoryReport> {
        self.pipeline.objectspace().map(|o| o.memory_report())
    }

    /// The object-space pipeline, when the renderer runs one.
    pub fn objectspace(&self) -> Option<&objectspace::ObjectSpace> {
        self.pipeline.objectspace()
    }

    /// Whether the adapter can time passes.
    pub fn timing_enabled(&self) -> bool {
        self.timer.enabled()
    }

    /// Reads the last tone-mapped frame back (blocks).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<image::RgbaImage, RenderError> {
        let bytes = readback::read_texture_rgba8(ctx, &self.targets.ldr)?;
        Ok(image::RgbaImage::from_raw(self.targets.width, self.targets.height, bytes)
            .expect("read-back has w*h*4 bytes"))
    }
}

/// FNV-1a: the lights' GPU form hashes differently when any light changes.
fn hash_bytes(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ *b as u64).wrapping_mul(0x100_0000_01b3))
}
