//! Tile marking and queueing (`mark.wgsl`): per pixel of the visibility
//! buffer, the mip level and the tiles of its bilinear footprint are marked
//! visible; a tile whose cached shade is too old or stale is queued. Then
//! one invocation turns the queue length into the shade pass's indirect
//! dispatch. `cpu.rs` is the CPU twin that tests check this pass against.

use super::resources::Resources;
use crate::render::frame::Frame;
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("mark.wgsl", include_str!("mark.wgsl"));

pub struct MarkPass {
    mark: wgpu::ComputePipeline,
    queue_args: wgpu::ComputePipeline,
    /// The dispatch arguments as storage: its own group, because the shade
    /// pass reads the same buffer as INDIRECT, which excludes storage use.
    dispatch_group: wgpu::BindGroup,
}

impl MarkPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
    ) -> Result<Self, ShaderError> {
        let dispatch_layout = bind_group_layout(device, "shade dispatch", &[Binding::Storage { read_only: false }]);
        let dispatch_group =
            bind_group(device, "shade dispatch", &dispatch_layout, &[res.shade_dispatch.as_entire_binding()]);
        let mark = compute_pipeline(device, shaders, SHADER, "mark", &[&scene.layout, &res.layout])?;
        let groups = [&scene.layout, &res.layout, &dispatch_layout];
        let queue_args = compute_pipeline(device, shaders, SHADER, "queue_args", &groups)?;
        Ok(Self { mark, queue_args, dispatch_group })
    }
}

/// Reads: the visibility buffer, the atlas table, the tile stamps.
/// Writes: the tile stamps, the shade queue, the counters, the shade dispatch.
pub fn mark_tiles(frame: &mut Frame, pass: &MarkPass, res: &Resources) {
    let (w, h) = (frame.targets.width.div_ceil(8), frame.targets.height.div_ceil(8));
    let scene = frame.scene.bind_group();
    {
        let mut cp = frame.compute_pass("mark");
        cp.set_pipeline(&pass.mark);
        res.bind(&mut cp, scene);
        cp.dispatch_workgroups(w, h, 1);
    }
    let mut cp = frame.compute_pass("queue");
    cp.set_pipeline(&pass.queue_args);
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &pass.dispatch_group, &[]);
    cp.dispatch_workgroups(1, 1, 1);
}
