//! Visibility buffers for the tile studies: the renderer's own visibility
//! pass (hardware raster or the compute rasterizer, as `--visibility auto`
//! picks), with nothing else of a pipeline, rendered for a camera and read
//! back so that the CPU can mark tiles in every variant from one render.

use wgpu_profiler::{GpuProfiler, GpuProfilerSettings};

use crate::gpu::{GpuContext, readback};
use crate::render::RenderError;
use crate::render::culling::{Frustum, LightLists};
use crate::render::frame::Frame;
use crate::render::gpu_types::GpuView;
use crate::render::passes::visibility::compute::{ComputeVisibility, compute_visibility};
use crate::render::passes::visibility::{VisibilityBuffer, VisibilityMethod, VisibilityPass, visibility};
use crate::render::scene_gpu::{SceneGpu, gpu_view};
use crate::render::targets::Targets;
use crate::scene::{Camera, Scene};

/// One resolution's targets and visibility pass.
struct Target {
    targets: Targets,
    buffer: VisibilityBuffer,
    pass: Pass,
}

enum Pass {
    Raster(VisibilityPass),
    // Boxed: it holds its buffers and pipelines inline, the raster pass one pipeline.
    Compute(Box<ComputeVisibility>),
}

/// A read-back visibility buffer and the view it was rendered with.
pub struct IdImage {
    pub view: GpuView,
    pub width: u32,
    pub height: u32,
    /// Row-major `(object + 1, triangle)` per pixel, `(0, 0)` for background.
    pub ids: Vec<[u32; 2]>,
}

/// Renders visibility buffers of one scene at several resolutions.
pub struct VisibilityRenderer {
    scene: SceneGpu,
    targets: Vec<Target>,
    /// Timestamps off: the studies count tiles, they do not time passes.
    profiler: GpuProfiler,
    pub method: VisibilityMethod,
    frames: u64,
}

impl VisibilityRenderer {
    /// Uploads `scene` and builds a visibility pass per resolution.
    pub fn new(ctx: &GpuContext, scene: &Scene, resolutions: &[(u32, u32)]) -> Result<Self, RenderError> {
        let device = &ctx.device;
        let max = ctx.limits.max_texture_dimension_2d;
        if let Some(&(w, h)) = resolutions.iter().find(|(w, h)| *w == 0 || *h == 0 || *w > max || *h > max) {
            return Err(RenderError::BadSize(w, h, max));
        }
        let mut shaders = crate::render::shader_set::library()?;
        let scene_gpu = SceneGpu::new(device, &ctx.queue, scene);
        let method = VisibilityMethod::preferred(device.features());
        let targets = resolutions
            .iter()
            .map(|&(w, h)| -> Result<Target, RenderError> {
                let targets = Targets::new(device, w, h, 1, false);
                let buffer = VisibilityBuffer::new(device, &targets, method);
                let pass = match method {
                    VisibilityMethod::Raster => {
                        Pass::Raster(VisibilityPass::new(device, &mut shaders, &scene_gpu, false, 1)?)
                    }
                    VisibilityMethod::Compute => {
                        let pass = ComputeVisibility::new(device, &mut shaders, &scene_gpu, &targets, &buffer, false)?;
                        Pass::Compute(Box::new(pass))
                    }
                };
                Ok(Target { targets, buffer, pass })
            })
            .collect::<Result<_, _>>()?;
        let settings = GpuProfilerSettings { enable_timer_queries: false, ..Default::default() };
        let profiler = GpuProfiler::new(device, settings).expect("profiler settings are valid");
        ctx.check_errors()?;
        Ok(Self { scene: scene_gpu, targets, profiler, method, frames: 0 })
    }

    /// Renders `camera` at resolution `index` (of those given to `new`) and
    /// reads the ids back (blocks).
    pub fn render(&mut self, ctx: &GpuContext, camera: &Camera, index: usize) -> Result<IdImage, RenderError> {
        let Target { targets, buffer, pass } = &mut self.targets[index];
        let t = &*targets;
        let (width, height) = (t.width, t.height);
        let view = gpu_view(camera, width, height);
        let frustum = Frustum::from_view_projection(view.view_proj);
        let visible: Vec<bool> = self.scene.object_bounds.iter().map(|b| frustum.intersects_aabb(b)).collect();
        let no_lights = LightLists::empty(self.scene.object_bounds.len());
        self.scene.update_frame(&ctx.device, &ctx.queue, &view, None, &no_lights);
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("study ids") });
        {
            let lights: &[crate::scene::Light] = &[];
            let mut frame = Frame {
                device: &ctx.device,
                queue: &ctx.queue,
                scene: &self.scene,
                scene_group: self.scene.bind_group(),
                targets: t,
                camera,
                lights,
                view: &view,
                visible: &visible,
                number: self.frames,
                lights_changed: false,
                encoder: &mut encoder,
                profiler: &self.profiler,
                time_passes: true,
            };
            match pass {
                Pass::Raster(pass) => visibility(&mut frame, pass, buffer, None),
                Pass::Compute(pass) => compute_visibility(&mut frame, pass),
            }
        }
        self.profiler.resolve_queries(&mut encoder);
        ctx.queue.submit([encoder.finish()]);
        // Nothing is timed; ending the frame keeps the profiler's bookkeeping empty.
        let _ = self.profiler.end_frame();
        self.frames += 1;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_texture(ctx, &buffer.texture, 8)?);
        ctx.check_errors()?;
        Ok(IdImage { view, width, height, ids: words.chunks_exact(2).map(|c| [c[0], c[1]]).collect() })
    }
}
