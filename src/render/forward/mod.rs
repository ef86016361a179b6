//! Single-pass forward shading: one draw per object; each fragment loops over
//! the lights that CPU culling assigned to its object. An optional depth
//! pre-pass removes overdraw from the shading pass.

use serde::Serialize;

use super::frame::Frame;
use super::passes::background::{Background, Coverage, background};
use super::passes::blended::{BlendedPass, blended_pass};
use super::passes::cluster_draws::ClusterCull;
use super::passes::depth_prepass::{DepthPrepass, culled_depth_prepass};
use super::passes::{
    DepthMode, ScenePipeline, SceneRaster, depth_attachment, draw_scene, hdr_attachment_then,
    scene_raster_pipeline_from,
};
use super::report::{Counters, PipelineReport};
use super::scene_gpu::SceneGpu;
use super::targets::{HDR_FORMAT, Targets};
use super::{Pipeline, RenderError};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("forward.wgsl", include_str!("forward.wgsl"));

/// Settings of the forward pipeline.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ForwardConfig {
    /// Lay down depth first, then shade with an `Equal` depth test, so every
    /// pixel is shaded once.
    pub depth_prepass: bool,
}

impl Default for ForwardConfig {
    fn default() -> Self {
        Self { depth_prepass: true }
    }
}

pub struct Forward {
    config: ForwardConfig,
    prepass: Option<DepthPrepass>,
    shade: ScenePipeline,
    /// For scenes with an environment: drawn where the opaque ones leave background.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: drawn after the opaque ones.
    blended: Option<BlendedPass>,
}

impl Forward {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: ForwardConfig,
    ) -> Result<Self, RenderError> {
        let samples = targets.samples;
        let prepass = config.depth_prepass.then(|| DepthPrepass::new(device, shaders, scene, samples)).transpose()?;
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_main",
            fragment: Some(("fs_main", &[HDR_FORMAT])),
            depth: DepthMode::after(config.depth_prepass),
            groups: &[],
            blend: None,
            samples,
        };
        let shade = scene_raster_pipeline_from(device, shaders, scene, &raster)?;
        let blended = BlendedPass::new(device, shaders, scene, targets, SHADER, &[], false)?;
        let background = Background::new(device, shaders, scene, targets, Coverage::Depth, blended.is_some())?;
        Ok(Self { config, prepass, shade, background, blended })
    }
}

impl Pipeline for Forward {
    fn encode(&mut self, frame: &mut Frame) {
        if let Some(prepass) = &mut self.prepass {
            culled_depth_prepass(frame, prepass);
        }
        let cull = self.prepass.as_ref().and_then(DepthPrepass::cull);
        forward_shade(frame, &self.shade, self.prepass.is_none(), self.blended.is_some(), cull);
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            blended_pass(frame, blended, &[]);
        }
    }

    /// With the depth pre-pass only (culling draws what it drew).
    /// Report: `cluster_culling` memory, and `cluster_draw_passes`, the
    /// passes that draw the cluster lists (the pre-pass and the shading).
    fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<(), ShaderError> {
        if let Some(prepass) = &mut self.prepass {
            prepass.enable_cluster_culling(device, shaders, scene, targets, &mut self.shade)?;
        }
        Ok(())
    }

    fn after_submit(&mut self) {
        if let Some(prepass) = &mut self.prepass {
            prepass.after_submit();
        }
    }

    /// The cull counts of the frames that culled clusters.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.prepass.as_mut().map(|p| p.collect_counts(device, wait)).unwrap_or_default()
    }

    fn report(&self) -> PipelineReport {
        let culling = self.prepass.as_ref().map_or(0, DepthPrepass::bytes);
        let culls = self.prepass.as_ref().is_some_and(DepthPrepass::culls);
        PipelineReport::new(super::PipelineConfig::Forward(self.config))
            .memory("cluster_culling", culling)
            .setup("cluster_draw_passes", u64::from(culls) + u64::from(culls && self.shade.draws_clusters()))
    }
}

/// Reads: the scene, its lights and per-object light lists, and the depth
/// target unless `clear_depth`. Writes: `targets.hdr` (cleared first;
/// under MSAA resolved from the samples, or with `blended_after` left in
/// them for the blended pass) and depth. Draws what `cull` kept where it culled.
fn forward_shade(
    frame: &mut Frame,
    pipeline: &ScenePipeline,
    clear_depth: bool,
    blended_after: bool,
    cull: Option<&ClusterCull>,
) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let color = [hdr_attachment_then(targets, blended_after)];
    let mut rp = frame.render_pass("forward shade", &color, Some(depth_attachment(targets, clear_depth)));
    draw_scene(&mut rp, scene, visible, pipeline, cull);
}
