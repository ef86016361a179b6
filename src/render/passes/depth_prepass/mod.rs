//! Depth pre-pass: lays down the scene's depth, so that the pass after it
//! (forward shading, the visibility ids) tests `Equal` and runs one fragment
//! per pixel.

use super::{DepthMode, ScenePipeline, SceneRaster, depth_attachment, draw_objects, scene_raster_pipeline_from};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("depth.wgsl", include_str!("depth.wgsl"));

pub struct DepthPrepass {
    pipeline: ScenePipeline,
}

impl DepthPrepass {
    /// The pre-pass into a depth target of `samples` samples per pixel.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        samples: u32,
    ) -> Result<Self, ShaderError> {
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_depth",
            fragment: None,
            depth: DepthMode::Write,
            groups: &[],
            blend: None,
            samples,
        };
        Ok(Self { pipeline: scene_raster_pipeline_from(device, shaders, scene, &raster)? })
    }
}

/// Writes: the frame's depth target (cleared first), from the visible objects.
pub fn depth_prepass(frame: &mut Frame, pass: &DepthPrepass) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let mut rp = frame.render_pass("depth prepass", &[], Some(depth_attachment(targets, true)));
    draw_objects(&mut rp, scene, visible, &pass.pipeline);
}
