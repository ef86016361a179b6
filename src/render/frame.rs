//! One frame being recorded: what the passes read (scene, targets, visible
//! objects) and where they record (the encoder, with a timing scope per pass).
//!
//! Why no frame graph (resource handles, declared reads and writes): wgpu
//! already tracks resource states and inserts the barriers, and every
//! pipeline here records a fixed, short sequence of passes, so a graph's
//! scheduling and aliasing would buy nothing yet. What a graph would make
//! explicit lives in the pass functions instead: each takes its inputs and
//! outputs as named arguments, and a pipeline's `encode` is the list of
//! passes in order. Timing labels are automatic: every pass opened through
//! [`Frame::compute_pass`] or [`Frame::render_pass`] is timed under its name.

use wgpu_profiler::{GpuProfiler, OwningScope, Scope};

use super::gpu_types::GpuView;
use super::scene_gpu::SceneGpu;
use super::targets::Targets;
use crate::scene::{Camera, Light};

/// A frame's inputs and its command encoder.
pub struct Frame<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    pub scene: &'a SceneGpu,
    /// The scene as group 0 of the passes: `scene.bind_group()`, or the
    /// scene seen from another view for passes recorded for that view.
    pub scene_group: &'a wgpu::BindGroup,
    pub targets: &'a Targets,
    pub camera: &'a Camera,
    /// The frame's lights in GPU order: the `view.global_light_count`
    /// ambient and directional lights first, then point and spot lights.
    pub lights: &'a [Light],
    /// This frame's view uniform as uploaded (camera, light counts).
    pub view: &'a GpuView,
    /// Per object: inside the view frustum.
    pub visible: &'a [bool],
    /// Frame number (tags counters and timings).
    pub number: u64,
    /// The lights differ from the previous frame's (cached shades are stale).
    pub lights_changed: bool,
    pub encoder: &'a mut wgpu::CommandEncoder,
    pub profiler: &'a GpuProfiler,
    /// Passes get timing scopes of their own ([`crate::gpu::timing::GpuTiming::Passes`]); with
    /// [`crate::gpu::timing::GpuTiming::Frame`] the renderer times the whole frame instead.
    pub time_passes: bool,
}

impl Frame<'_> {
    /// This frame as passes recorded for another view see it: the same
    /// encoder and inputs, with `scene_group` as group 0 (the scene with
    /// that view's uniform).
    pub fn with_scene_group<'b>(&'b mut self, scene_group: &'b wgpu::BindGroup) -> Frame<'b> {
        Frame {
            device: self.device,
            queue: self.queue,
            scene: self.scene,
            scene_group,
            targets: self.targets,
            camera: self.camera,
            lights: self.lights,
            view: self.view,
            visible: self.visible,
            number: self.number,
            lights_changed: self.lights_changed,
            encoder: &mut *self.encoder,
            profiler: self.profiler,
            time_passes: self.time_passes,
        }
    }

    /// A compute pass timed as `label` (when the frame times its passes).
    pub fn compute_pass(&mut self, label: &str) -> OwningScope<'_, wgpu::ComputePass<'_>> {
        let query = self.pass_query(label);
        let pass = self.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: query.as_ref().and_then(|q| q.compute_pass_timestamp_writes()),
        });
        OwningScope { profiler: self.profiler, recorder: pass, scope: query }
    }

    /// A timing scope `label` over several passes, each opened inside it
    /// with [`scoped_render_pass`] and timed as `label/name` (for example
    /// one pass per shadow-map face), when the frame times its passes.
    pub fn scope(&mut self, label: &str) -> Scope<'_, wgpu::CommandEncoder> {
        if !self.time_passes {
            return Scope { profiler: self.profiler, recorder: self.encoder, scope: None };
        }
        self.profiler.scope(label, self.encoder)
    }

    /// A render pass timed as `label` (when the frame times its passes),
    /// over `color` and `depth` attachments.
    pub fn render_pass(
        &mut self,
        label: &str,
        color: &[Option<wgpu::RenderPassColorAttachment<'_>>],
        depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    ) -> OwningScope<'_, wgpu::RenderPass<'_>> {
        let query = self.pass_query(label);
        let pass = self.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: color,
            depth_stencil_attachment: depth,
            timestamp_writes: query.as_ref().and_then(|q| q.render_pass_timestamp_writes()),
            ..Default::default()
        });
        OwningScope { profiler: self.profiler, recorder: pass, scope: query }
    }

    /// The timing query of a pass `label`, when the frame times its passes.
    fn pass_query(&mut self, label: &str) -> Option<wgpu_profiler::GpuProfilerQuery> {
        self.time_passes.then(|| self.profiler.begin_pass_query(label, self.encoder))
    }
}

/// A compute pass opened by [`Frame::compute_pass`], with its timing scope.
pub type TimedComputePass<'a, 'p> = OwningScope<'a, wgpu::ComputePass<'p>>;

/// Stage `label` of `pass`, a pass of several dispatches that depend on
/// each other (one pass rather than one each: fewer pass boundaries), timed
/// as `pass/label` when the pass is timed (with timestamps inside the pass,
/// where the adapter has them).
pub fn stage<'a, 'p>(pass: &'a mut TimedComputePass<'_, 'p>, label: &str) -> Scope<'a, wgpu::ComputePass<'p>> {
    if pass.scope.is_some() {
        pass.scope(label)
    } else {
        Scope { profiler: pass.profiler, recorder: &mut pass.recorder, scope: None }
    }
}

/// A render pass `label` inside `scope` (one of [`Frame::scope`]), timed as
/// `scope/label` when the frame times its passes.
pub fn scoped_render_pass<'a>(
    scope: &'a mut Scope<'_, wgpu::CommandEncoder>,
    label: String,
    descriptor: wgpu::RenderPassDescriptor<'_>,
) -> OwningScope<'a, wgpu::RenderPass<'a>> {
    if scope.scope.is_some() {
        return scope.scoped_render_pass(label, descriptor);
    }
    let descriptor = wgpu::RenderPassDescriptor { label: Some(&label), ..descriptor };
    let pass = scope.recorder.begin_render_pass(&descriptor);
    OwningScope { profiler: scope.profiler, recorder: pass, scope: None }
}
