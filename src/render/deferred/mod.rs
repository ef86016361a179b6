//! Deferred shading with light volumes, as in the forward-versus-deferred
//! study: the shared G-buffer pass, then the lights, added into the HDR
//! target one light at a time where its volume covers the screen:
//!
//! 1. *lights ambient+directional*: every pixel, emission plus the ambient
//!    and directional lights (the study's full-screen pass; in compute here,
//!    since it writes every pixel anyway, which also clears the target);
//! 2. *light volumes*: one workgroup sorts the point and spot lights that
//!    may be in view into four instance lists (sphere or cone, eye outside
//!    or inside the volume) and sets the instance counts of four indirect
//!    draws, so 10,000+ lights take four draw calls ([`volumes`]);
//! 3. *lights point*, *lights spot*: a low-poly sphere enclosing each point
//!    light's range, a cone enclosing each spot light's cone, instanced, each
//!    fragment lighting the G-buffer surface behind it with its light,
//!    blended additively. From outside a volume, front faces tested against
//!    the scene's depth; from inside, back faces, untested.
//!
//! Under MSAA the G-buffer is multisampled; the full-screen pass shades a
//! pixel once where its samples see one surface, else per sample, and the
//! volumes are drawn without a depth attachment (the HDR target has one
//! sample, the depth N), each fragment testing its samples' depths against
//! the face itself (`volumes.wgsl`), so volumes cost their fragments even
//! behind walls there.
//!
//! Alpha-blended objects are drawn last, by a forward pass over the lit HDR
//! target and the G-buffer's depth (`passes::blended`), lit by the shared
//! lighting code from their CPU light lists.
//!
//! Simplified: no stencil marking of the pixels inside a volume (the
//! lighting model's range cut-off leaves pixels in front of or behind the
//! lit region unlit, at the cost of shading them); no shadows (the lighting
//! model has none yet); spot lights wider than about 63 degrees use the
//! sphere.

pub mod volumes;

use serde::Serialize;

use super::forward;
use super::frame::Frame;
use super::passes::background::{Background, Coverage, background};
use super::passes::blended::{BlendedPass, blended_pass};
use super::passes::gbuffer::{GBuffer, GbufferStage, geometry};
use super::passes::{compute_pipeline, hdr_output};
use super::report::{Counters, PipelineReport};
use super::scene_gpu::SceneGpu;
use super::targets::Targets;
use super::{Pipeline, PipelineConfig, RenderError};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};
use volumes::{LightVolumes, VolumeList, classify_volumes, draw_volumes};

/// The module the light-volume shaders import (`shadespace::deferred`).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("deferred.wgsl", include_str!("deferred.wgsl"));
pub const GLOBALS_SHADER: ShaderSource = ShaderSource::new("globals.wgsl", include_str!("globals.wgsl"));
/// The pass shaders, for the test that validates every shader.
pub const PASS_SHADERS: &[ShaderSource] = &[GLOBALS_SHADER, volumes::CLASSIFY_SHADER, volumes::VOLUMES_SHADER];

/// Settings of the deferred (light volume) pipeline.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DeferredConfig {
    /// Lay down depth first, so that the G-buffer pass runs one fragment per
    /// pixel (`Equal` test): on by default because fragment work is what the
    /// H100 is slow at, and the same pre-pass measured faster there before the
    /// (lighter) visibility pass.
    pub depth_prepass: bool,
}

impl Default for DeferredConfig {
    fn default() -> Self {
        Self { depth_prepass: true }
    }
}

/// The deferred (light volume) pipeline.
pub struct Deferred {
    config: DeferredConfig,
    geometry: GbufferStage,
    globals: wgpu::ComputePipeline,
    /// The HDR target, written by the full-screen pass.
    output: wgpu::BindGroup,
    volumes: LightVolumes,
    /// For scenes with an environment: drawn where the G-buffer is background.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: lit forward after the lights.
    blended: Option<BlendedPass>,
}

impl Deferred {
    /// Builds its passes for `scene` and `targets`.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: DeferredConfig,
    ) -> Result<Self, RenderError> {
        let geometry = GbufferStage::new(device, shaders, scene, targets, config.depth_prepass)?;
        let (layout, output) = hdr_output(device, targets, "deferred output");
        let groups = [&scene.layout, &geometry.gbuffer.read_layout, &layout];
        let globals = compute_pipeline(device, shaders, GLOBALS_SHADER, "lights_globals", &groups)?;
        let volumes = LightVolumes::new(device, shaders, scene, &geometry.gbuffer)?;
        let blended = BlendedPass::new(device, shaders, scene, targets, forward::SHADER, &[], false)?;
        let background = Background::new(device, shaders, scene, targets, Coverage::Depth, false)?;
        Ok(Self { config, geometry, globals, output, volumes, background, blended })
    }
}

impl Deferred {
    /// The light volumes (for their debug read-backs).
    pub fn volumes(&self) -> &LightVolumes {
        &self.volumes
    }
}

impl Pipeline for Deferred {
    fn encode(&mut self, frame: &mut Frame) {
        geometry(frame, &mut self.geometry);
        let gbuffer = &self.geometry.gbuffer;
        lights_globals(frame, &self.globals, gbuffer, &self.output);
        classify_volumes(frame, &mut self.volumes);
        let (point, spot) =
            ([VolumeList::PointOutside, VolumeList::PointInside], [VolumeList::SpotOutside, VolumeList::SpotInside]);
        draw_volumes(frame, &self.volumes, gbuffer, point, "lights point");
        draw_volumes(frame, &self.volumes, gbuffer, spot, "lights spot");
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            blended_pass(frame, blended, &[]);
        }
    }

    /// Lights come from the volume lists, not the CPU's per-object ones.
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
        self.geometry.enable_cluster_culling(device, shaders, scene, targets)
    }

    fn after_submit(&mut self) {
        if let Some(p) = self.geometry.prepass_mut() {
            p.after_submit();
        }
    }

    /// The cull counts of the frames that culled clusters.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        self.geometry.prepass_mut().map(|p| p.collect_counts(device, wait)).unwrap_or_default()
    }

    /// Memory: the G-buffer and the light volumes (meshes, lists, draws);
    /// setup: the G-buffer's bytes per pixel (with depth) and the meshes'
    /// triangles.
    fn report(&self) -> PipelineReport {
        let (sphere, cone) = LightVolumes::triangles();
        PipelineReport::new(PipelineConfig::Deferred(self.config))
            .memory("gbuffer", self.geometry.gbuffer.bytes())
            .memory("light_volumes", self.volumes.bytes())
            .memory("cluster_culling", self.geometry.prepass().map_or(0, |p| p.bytes()))
            .setup("cluster_draw_passes", self.geometry.cluster_draw_passes())
            .setup("gbuffer_bytes_per_pixel", self.geometry.gbuffer.bytes_per_pixel_with_depth())
            .setup("sphere_triangles", sphere)
            .setup("cone_triangles", cone)
    }
}

/// Reads: the G-buffer (with depth) and the ambient and directional lights.
/// Writes: every pixel of `targets.hdr` (through `output`).
fn lights_globals(frame: &mut Frame, pipeline: &wgpu::ComputePipeline, gbuffer: &GBuffer, output: &wgpu::BindGroup) {
    let (w, h) = (frame.targets.width.div_ceil(8), frame.targets.height.div_ceil(8));
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("lights ambient+directional");
    cp.set_pipeline(pipeline);
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, &gbuffer.read_group, &[]);
    cp.set_bind_group(2, output, &[]);
    cp.dispatch_workgroups(w, h, 1);
}
