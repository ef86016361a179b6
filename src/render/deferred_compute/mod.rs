//! Tiled deferred shading, lit in compute: the shared G-buffer pass, then
//! one compute pass over 16x16 screen tiles (`tiled.wgsl`). Each workgroup
//! reduces its tile's depth range, builds the tile's frustum, culls every
//! point and spot light against it in chunks of 256 into a workgroup list
//! (in light order, so the image is deterministic), shades its pixels with
//! the ambient and directional lights and the listed ones, and writes
//! `targets.hdr`. A tile reached by more lights than the list holds shades in
//! batches (no light is dropped). This is the conventional pipeline the H100
//! favours (lighting on every SM, fragment work only in the G-buffer pass).
//!
//! With `visibility: compute` the G-buffer pass is replaced by the compute
//! visibility pass, and each pixel's surface is rebuilt from its triangle
//! ids (`shadespace::visibility_read`), as object space rebuilds it.
//!
//! Simplified: lights are culled by bounding spheres (a spot light by its
//! sector's), not by exact cone tests; one depth range per tile (no 2.5D
//! depth masks or clusters), so tiles across depth discontinuities keep
//! lights of the gap; no shadows (the lighting model has none yet).

use serde::Serialize;

use super::frame::Frame;
use super::passes::gbuffer::{GbufferStage, geometry};
use super::passes::visibility::compute::{ComputeVisibility, compute_visibility};
use super::passes::visibility::{VisibilityBuffer, VisibilityMethod};
use super::passes::{compute_pipeline, hdr_output};
use super::report::Counters;
use super::report::PipelineReport;
use super::scene_gpu::SceneGpu;
use super::targets::Targets;
use super::{Pipeline, PipelineConfig, RenderError};
use crate::shaders::{ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("tiled.wgsl", include_str!("tiled.wgsl"));
/// `tiled.wgsl` reading the compute visibility pass instead of the G-buffer.
pub const SHADER_VISIBILITY: ShaderSource = SHADER.with_defs(&["VISIBILITY_BUFFER"]);

/// Tile side in pixels (one workgroup of `TILE_SIZE`² threads per tile).
pub const TILE_SIZE: u32 = 16;
/// Lights culled per step, one per thread of a tile.
pub const LIGHT_CHUNK: u32 = TILE_SIZE * TILE_SIZE;
/// Lights a tile's workgroup list holds; when fewer than a chunk's worth of
/// places are left, the tile shades the listed lights and starts again.
pub const TILE_LIGHT_CAPACITY: u32 = 512;

/// The constants `tiled.wgsl` shares with Rust (`shaders::contract`).
pub fn wgsl_constants() -> [(&'static str, u32); 3] {
    [("TILED_TILE_SIZE", TILE_SIZE), ("TILED_CHUNK", LIGHT_CHUNK), ("TILED_LIST_CAPACITY", TILE_LIGHT_CAPACITY)]
}

/// Settings of the tiled deferred pipeline.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DeferredComputeConfig {
    /// Lay down depth first, so that the G-buffer pass runs one fragment per
    /// pixel (`Equal` test): on by default because fragment work is what the
    /// H100 is slow at, and the same pre-pass measured faster there before the
    /// (lighter) visibility pass. Raster visibility only.
    pub depth_prepass: bool,
    /// Raster: the G-buffer pass. Compute: the compute visibility pass, the
    /// surfaces rebuilt from ids (no G-buffer). Raster here (it runs on every
    /// adapter); the CLI's `--visibility auto` takes [`VisibilityMethod::preferred`].
    pub visibility: VisibilityMethod,
    /// Compute visibility: count the rasterizer's work every frame into the
    /// counters (adds atomics: for profiling, not timing).
    pub count_visibility: bool,
}

impl Default for DeferredComputeConfig {
    fn default() -> Self {
        Self { depth_prepass: true, visibility: VisibilityMethod::Raster, count_visibility: false }
    }
}

/// Where the lighting pass reads its pixels from.
enum Surfaces {
    Gbuffer(Box<GbufferStage>),
    Visibility { ids: VisibilityBuffer, pass: Box<ComputeVisibility> },
}

/// The tiled deferred pipeline.
pub struct DeferredCompute {
    config: DeferredComputeConfig,
    surfaces: Surfaces,
    lighting: wgpu::ComputePipeline,
    /// The HDR target, written.
    output: wgpu::BindGroup,
}

impl DeferredCompute {
    /// Builds its passes for `scene` and `targets`.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        config: DeferredComputeConfig,
    ) -> Result<Self, RenderError> {
        let surfaces = match config.visibility {
            VisibilityMethod::Raster => {
                Surfaces::Gbuffer(Box::new(GbufferStage::new(device, shaders, scene, targets, config.depth_prepass)?))
            }
            VisibilityMethod::Compute => {
                let ids = VisibilityBuffer::new(device, targets);
                let pass = ComputeVisibility::new(device, shaders, scene, targets, &ids, config.count_visibility)?;
                Surfaces::Visibility { ids, pass: Box::new(pass) }
            }
        };
        let (layout, output) = hdr_output(device, targets, "tiled lighting output");
        let (shader, read_layout) = match &surfaces {
            Surfaces::Gbuffer(stage) => (SHADER, &stage.gbuffer.read_layout),
            Surfaces::Visibility { pass, .. } => (SHADER_VISIBILITY, &pass.read_layout),
        };
        let groups = [&scene.layout, read_layout, &layout];
        let lighting = compute_pipeline(device, shaders, shader, "tiled_lighting", &groups)?;
        Ok(Self { config, surfaces, lighting, output })
    }
}

impl Pipeline for DeferredCompute {
    fn encode(&mut self, frame: &mut Frame) {
        let read = match &mut self.surfaces {
            Surfaces::Gbuffer(stage) => {
                geometry(frame, stage);
                &stage.gbuffer.read_group
            }
            Surfaces::Visibility { pass, .. } => {
                compute_visibility(frame, pass);
                &pass.read_group
            }
        };
        tiled_lighting(frame, &self.lighting, read, &self.output);
    }

    /// Lights come from the tiles' own lists, not the CPU's per-object ones.
    fn uses_object_light_lists(&self) -> bool {
        false
    }

    fn after_submit(&mut self) {
        if let Surfaces::Visibility { pass, .. } = &mut self.surfaces {
            pass.after_submit();
        }
    }

    /// With `count_visibility`, the compute rasterizer's counts.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        match &mut self.surfaces {
            Surfaces::Visibility { pass, .. } => pass.collect_counts(device, wait),
            Surfaces::Gbuffer(_) => Vec::new(),
        }
    }

    /// Memory: the G-buffer (or the visibility buffers); setup: its bytes
    /// per pixel (with depth), the tile size and the tile list's capacity.
    fn report(&self) -> PipelineReport {
        let report = PipelineReport::new(PipelineConfig::DeferredCompute(self.config));
        let report = match &self.surfaces {
            Surfaces::Gbuffer(stage) => report
                .memory("gbuffer", stage.gbuffer.bytes())
                .setup("gbuffer_bytes_per_pixel", stage.gbuffer.bytes_per_pixel_with_depth()),
            Surfaces::Visibility { ids, pass } => {
                report.memory("visibility", ids.bytes()).memory("visibility_raster", pass.bytes())
            }
        };
        report.setup("tile_size", TILE_SIZE as u64).setup("tile_light_capacity", TILE_LIGHT_CAPACITY as u64)
    }
}

/// Reads: the surfaces (`read`: the G-buffer with depth, or the visibility
/// buffers) and the lights. Writes: every pixel of `targets.hdr` (through `output`).
fn tiled_lighting(
    frame: &mut Frame,
    pipeline: &wgpu::ComputePipeline,
    read: &wgpu::BindGroup,
    output: &wgpu::BindGroup,
) {
    let (w, h) = (frame.targets.width.div_ceil(TILE_SIZE), frame.targets.height.div_ceil(TILE_SIZE));
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("tiled lighting");
    cp.set_pipeline(pipeline);
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, read, &[]);
    cp.set_bind_group(2, output, &[]);
    cp.dispatch_workgroups(w, h, 1);
}
