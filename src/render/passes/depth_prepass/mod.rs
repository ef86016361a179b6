//! Depth pre-pass: lays down the scene's depth, so that the pass after it
//! (forward shading, the visibility ids) tests `Equal` and runs one fragment
//! per pixel. With cluster culling ([`DepthPrepass::enable_cluster_culling`]) it
//! also culls: it draws only the clusters that survive, and the passes
//! after it draw the same lists ([`DepthPrepass::cull`], [`culled_depth_prepass`]).

use super::cluster_draws::ClusterCull;
use super::{DepthMode, ScenePipeline, SceneRaster, depth_attachment, draw_objects, scene_raster_pipeline_from};
use crate::render::clusters::Culling;
use crate::render::frame::Frame;
use crate::render::report::Counters;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("depth.wgsl", include_str!("depth.wgsl"));

pub struct DepthPrepass {
    pipeline: ScenePipeline,
    /// Boxed: pass structs are held inline, culling is rarely built.
    cull: Option<Box<ClusterCull>>,
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
        Ok(Self { pipeline: scene_raster_pipeline_from(device, shaders, scene, &raster)?, cull: None })
    }

    /// Culls clusters from now on, as `scene.culling` says each frame
    /// (single-sampled `targets` only: the depth pyramid reads one sample
    /// per pixel; under MSAA it stays off), run by [`culled_depth_prepass`],
    /// and gives `after`, the pipeline of the pass that draws after it, its
    /// variants that draw the cluster lists. That pass must draw with
    /// [`super::draw_scene`] and [`Self::cull`].
    pub fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        after: &mut ScenePipeline,
    ) -> Result<(), ShaderError> {
        if self.cull.is_some() || targets.samples > 1 {
            return Ok(());
        }
        let cull = ClusterCull::new(device, shaders, scene, targets)?;
        self.pipeline.add_cluster_draws(device, shaders, scene)?;
        after.add_cluster_draws(device, shaders, scene)?;
        self.cull = Some(Box::new(cull));
        Ok(())
    }

    /// The culling the passes after it draw with (active only in frames
    /// that culled).
    pub fn cull(&self) -> Option<&ClusterCull> {
        self.cull.as_deref()
    }

    /// Starts the read-back of the frame's cull counts.
    pub fn after_submit(&mut self) {
        if let Some(c) = &mut self.cull {
            c.after_submit();
        }
    }

    /// The cull counts of finished frames ([`ClusterCull::collect_counts`]).
    pub fn collect_counts(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.cull.as_mut().map(|c| c.collect_counts(device, wait)).unwrap_or_default()
    }

    /// Whether it culls (built by [`Self::enable_cluster_culling`]).
    pub fn culls(&self) -> bool {
        self.cull.is_some()
    }

    /// GPU memory of culling's buffers (0 without culling).
    pub fn bytes(&self) -> u64 {
        self.cull.as_ref().map_or(0, |c| c.bytes())
    }
}

/// Writes: the frame's depth target (cleared first), from the visible
/// objects (no culling: for passes that draw every object after it).
pub fn depth_prepass(frame: &mut Frame, pass: &DepthPrepass) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let mut rp = frame.render_pass("depth prepass", &[], Some(depth_attachment(targets, true)));
    draw_objects(&mut rp, scene, visible, &pass.pipeline);
}

/// [`depth_prepass`], or where culling is enabled and `frame.scene.culling`
/// is not none, culls ([`ClusterCull::cull`]) and draws the surviving
/// clusters (or, in frames that draw the plain way, every visible object);
/// the passes after it then draw the same ([`DepthPrepass::cull`]).
pub fn culled_depth_prepass(frame: &mut Frame, pass: &mut DepthPrepass) {
    let pipeline = &pass.pipeline;
    if let Some(cull) = &mut pass.cull {
        cull.cull(frame, |frame, cull, list, clear| {
            let label = if list == Some(1) { "depth prepass late" } else { "depth prepass" };
            let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
            let mut rp = frame.render_pass(label, &[], Some(depth_attachment(targets, clear)));
            let Some(list) = list else {
                draw_objects(&mut rp, scene, visible, pipeline);
                return;
            };
            rp.set_bind_group(0, scene.bind_group(), &[]);
            for (p, masked) in pipeline.clustered_pipelines() {
                rp.set_pipeline(p);
                cull.draw_list(&mut rp, list, masked);
            }
        });
        if frame.scene.culling != Culling::None {
            return;
        }
    }
    depth_prepass(frame, pass);
}
