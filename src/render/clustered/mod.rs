//! Clustered forward shading: a depth pre-pass, the view-space cluster grid
//! built on the GPU from the light buffer, then one raster pass whose
//! fragments find their cluster (screen tile and depth slice) and loop over
//! the global lights and that cluster's lights. No CPU light culling.

use serde::Serialize;

use super::frame::Frame;
use super::passes::background::{Background, Coverage, background};
use super::passes::blended::{BlendedPass, blended_pass};
use super::passes::cluster_draws::ClusterCull;
use super::passes::depth_prepass::{DepthPrepass, culled_depth_prepass};
use super::passes::light_grid::clusters::{ClusterDims, Clusters, build_clusters};
use super::passes::light_grid::{LightGrid, READ_GROUP};
use super::passes::{
    DepthMode, ScenePipeline, SceneRaster, depth_attachment, draw_scene, hdr_attachment_then,
    scene_raster_pipeline_from,
};
use super::report::{Counters, PipelineReport};
use super::scene_gpu::SceneGpu;
use super::targets::{HDR_FORMAT, Targets};
use super::{Pipeline, PipelineConfig, RenderError};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("clustered.wgsl", include_str!("clustered.wgsl"));

/// Settings of the clustered pipeline.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ClusteredConfig {
    pub clusters: ClusterDims,
}

pub struct Clustered {
    config: ClusteredConfig,
    prepass: DepthPrepass,
    clusters: Clusters,
    shade: ScenePipeline,
    /// For scenes with an environment: drawn where the opaque ones leave background.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: lit from their clusters too.
    blended: Option<BlendedPass>,
}

impl Clustered {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: ClusteredConfig,
    ) -> Result<Self, RenderError> {
        let samples = targets.samples;
        let prepass = DepthPrepass::new(device, shaders, scene, samples)?;
        let clusters = Clusters::new(device, shaders, scene, config.clusters)?;
        let mut groups = vec![None; READ_GROUP as usize];
        groups[READ_GROUP as usize - 1] = Some(&clusters.grid.layout);
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_main",
            fragment: Some(("fs_main", &[HDR_FORMAT])),
            depth: DepthMode::EqualAfterPrepass,
            groups: &groups,
            blend: None,
            samples,
        };
        let shade = scene_raster_pipeline_from(device, shaders, scene, &raster)?;
        let blended = BlendedPass::new(device, shaders, scene, targets, SHADER, &groups, false)?;
        let background = Background::new(device, shaders, scene, targets, Coverage::Depth, blended.is_some())?;
        Ok(Self { config, prepass, clusters, shade, background, blended })
    }

    /// The cluster grid (its last build can be read back).
    pub fn light_grid(&self) -> &LightGrid {
        &self.clusters.grid
    }
}

impl Pipeline for Clustered {
    fn encode(&mut self, frame: &mut Frame) {
        culled_depth_prepass(frame, &mut self.prepass);
        build_clusters(frame, &mut self.clusters);
        clustered_shade(frame, &self.shade, &self.clusters.grid, self.blended.is_some(), self.prepass.cull());
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            blended_pass(frame, blended, &[(READ_GROUP, self.clusters.grid.bind_group())]);
        }
    }

    fn uses_object_light_lists(&self) -> bool {
        false
    }

    fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<(), ShaderError> {
        self.prepass.enable_cluster_culling(device, shaders, scene, targets, &mut self.shade)
    }

    fn after_submit(&mut self) {
        self.clusters.grid.after_submit();
        self.prepass.after_submit();
    }

    /// The cull counts of the frames that culled clusters.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.prepass.collect_counts(device, wait)
    }

    fn report(&self) -> PipelineReport {
        let grid = &self.clusters.grid;
        PipelineReport::new(PipelineConfig::Clustered(self.config))
            .memory("clusters", grid.bytes())
            .memory("cluster_culling", self.prepass.bytes())
            .setup(
                "cluster_draw_passes",
                u64::from(self.prepass.culls()) + u64::from(self.prepass.culls() && self.shade.draws_clusters()),
            )
            .setup("cluster_count", self.config.clusters.cell_count() as u64)
            .setup("cluster_list_capacity", grid.capacity())
            .setup("cluster_list_peak", grid.peak_entries())
    }
}

/// Reads: the scene, its lights, the clusters and the depth target. Writes:
/// `targets.hdr` (cleared first; under MSAA resolved from the samples, or
/// with `blended_after` left in them for the blended pass). Draws what
/// `cull` kept where it culled.
fn clustered_shade(
    frame: &mut Frame,
    pipeline: &ScenePipeline,
    grid: &LightGrid,
    blended_after: bool,
    cull: Option<&ClusterCull>,
) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let color = [hdr_attachment_then(targets, blended_after)];
    let mut rp = frame.render_pass("clustered shade", &color, Some(depth_attachment(targets, false)));
    rp.set_bind_group(READ_GROUP, grid.bind_group(), &[]);
    draw_scene(&mut rp, scene, visible, pipeline, cull);
}
