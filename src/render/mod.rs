//! Pipelines and what they share: the scene on the GPU, render targets, tone
//! mapping, per-frame statistics, and the [`Renderer`] that runs a frame.

pub mod culling;
pub mod forward;
pub mod gpu_types;
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

/// The shading pipelines, for `--pipeline`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PipelineKind {
    /// Single-pass forward shading (the reference image).
    Forward,
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
}

/// A shading pipeline: records the passes that fill `targets.hdr` (and depth).
pub trait Pipeline {
    fn name(&self) -> &'static str;
    fn encode(&mut self, frame: &FrameContext, encoder: &mut wgpu::CommandEncoder, timer: &mut GpuTimer);
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
}

/// Renders frames of one scene at one size with one pipeline.
pub struct Renderer {
    pub scene: SceneGpu,
    pub targets: Targets,
    pipeline: Box<dyn Pipeline>,
    tonemap: Tonemap,
    timer: GpuTimer,
    pub exposure: f32,
}

/// Passes a frame may time (pipelines use a handful).
const MAX_TIMED_PASSES: u32 = 16;

impl Renderer {
    pub fn new(ctx: &GpuContext, scene: &Scene, kind: PipelineKind, width: u32, height: u32) -> Result<Self, RenderError> {
        let max = ctx.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadSize(width, height, max));
        }
        let mut shaders = ShaderLibrary::new()?;
        let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, scene);
        let targets = Targets::new(&ctx.device, width, height);
        let pipeline: Box<dyn Pipeline> = match kind {
            PipelineKind::Forward => Box::new(forward::Forward::new(
                &ctx.device,
                &mut shaders,
                &scene_gpu.layout,
                forward::ForwardOptions { depth_prepass: true },
            )?),
        };
        let tonemap = Tonemap::new(&ctx.device, &mut shaders, &targets)?;
        let timer = GpuTimer::new(&ctx.device, &ctx.queue, MAX_TIMED_PASSES);
        ctx.check_errors()?;
        Ok(Self { scene: scene_gpu, targets, pipeline, tonemap, timer, exposure: 1.0 })
    }

    pub fn pipeline_name(&self) -> &'static str {
        self.pipeline.name()
    }

    /// Culls, uploads and records one frame, and submits it. Does not wait
    /// for the GPU.
    pub fn render(&mut self, ctx: &GpuContext, camera: &Camera, lights: &[Light], frame: u64) -> Result<FrameStats, RenderError> {
        let start = Instant::now();
        let (w, h) = (self.targets.width, self.targets.height);
        let view = scene_gpu::gpu_view(camera, w, h, frame, self.exposure);
        let frustum = Frustum::from_view_projection(view.view_proj);
        let lists = culling::lights_per_object(lights, &self.scene.object_bounds, Some(&frustum));
        let visible: Vec<bool> = self.scene.object_bounds.iter().map(|b| frustum.intersects_aabb(b)).collect();
        self.scene.update_frame(&ctx.device, &ctx.queue, &view, lights, &lists);

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
        };
        self.pipeline.encode(&frame_ctx, &mut encoder, &mut self.timer);
        self.tonemap.encode(&ctx.queue, &mut encoder, self.exposure, &mut self.timer);
        self.timer.end_frame(&ctx.device, &mut encoder);
        ctx.queue.submit([encoder.finish()]);
        self.timer.after_submit();
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

    /// Whether the adapter can time passes.
    pub fn timing_enabled(&self) -> bool {
        self.timer.enabled()
    }

    /// Reads the last tone-mapped frame back (blocks).
    pub fn read_image(&self, ctx: &GpuContext) -> Result<image::RgbaImage, RenderError> {
        let bytes = readback::read_texture_rgba8(ctx, &self.targets.ldr)?;
        Ok(image::RgbaImage::from_raw(self.targets.width, self.targets.height, bytes).expect("read-back has w*h*4 bytes"))
    }
}
