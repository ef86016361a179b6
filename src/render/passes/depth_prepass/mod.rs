//! Depth pre-pass: lays down the scene's depth, so that the pass after it
//! (forward shading, the visibility ids) tests `Equal` and runs one fragment
//! per pixel.

use super::{DepthMode, ScenePipeline, depth_attachment, draw_objects, scene_raster_pipeline};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("depth.wgsl", include_str!("depth.wgsl"));

pub struct DepthPrepass {
    pipeline: ScenePipeline,
}

impl DepthPrepass {
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, scene: &SceneGpu) -> Result<Self, ShaderError> {
        let pipeline = scene_raster_pipeline(device, shaders, SHADER, scene, "vs_depth", None, DepthMode::Write)?;
        Ok(Self { pipeline })
    }
}

/// Writes: the frame's depth target (cleared first), from the visible objects.
pub fn depth_prepass(frame: &mut Frame, pass: &DepthPrepass) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let mut rp = frame.render_pass("depth prepass", &[], Some(depth_attachment(targets, true)));
    draw_objects(&mut rp, scene, visible, &pass.pipeline);
}
