//! Tiled deferred shading, lit in compute: the shared G-buffer pass, then
//! one compute pass over 8x8 or 16x16 screen tiles (`tiled.wgsl`; the side
//! measured faster for the frame's lights, materials and samples,
//! [`TileSide::for_scenario`], or `--dc-tile 8|16`). Each workgroup reduces
//! its tile's depth range, builds the
//! tile's frustum, culls every point and spot light against it in chunks of
//! one light per invocation into a workgroup list
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
//! Under MSAA the G-buffer is multisampled (or, with compute visibility,
//! the compute rasterizer writes ids and depth per sample) and the lighting
//! pass shades a pixel once where all its samples see one surface (same
//! object, normals within 8 degrees, depths within 1 %), else each sample at
//! its own position, and writes their mean: the resolve, in linear HDR. It counts
//! the frame's lit and edge pixels (counters `msaa_lit_pixels`,
//! `msaa_edge_pixels`, `msaa_edge_share`).
//!
//! Alpha-blended objects are drawn last, by a forward pass over the lit HDR
//! target and the depth (`passes::blended`; with compute visibility it
//! first lays the opaque depth down), lit by the shared lighting code from
//! their CPU light lists.
//!
//! Simplified: lights are culled by bounding spheres (a spot light by its
//! sector's), not by exact cone tests; one depth range per tile (no 2.5D
//! depth masks or clusters), so tiles across depth discontinuities keep
//! lights of the gap.

use serde::Serialize;

use super::forward;
use super::frame::Frame;
use super::passes::background::{Background, Coverage, background};
use super::passes::blended::{BlendedPass, blended_pass};
use super::passes::gbuffer::{GbufferStage, geometry};
use super::passes::visibility::compute::{ComputeVisibility, compute_visibility};
use super::passes::visibility::{VisibilityBuffer, VisibilityMethod};
use super::passes::{Binding, bind_group, bind_group_layout, compute_pipeline_with, hdr_output};
use super::report::Counters;
use super::report::PipelineReport;
use super::scene_gpu::SceneGpu;
use super::targets::Targets;
use super::{Pipeline, PipelineConfig, RenderError};
use crate::gpu::readback::ReadbackRing;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("tiled.wgsl", include_str!("tiled.wgsl"));
/// `tiled.wgsl` reading the compute visibility pass instead of the G-buffer.
pub const SHADER_VISIBILITY: ShaderSource = SHADER.with_defs(&["VISIBILITY_BUFFER"]);
/// `tiled.wgsl` reading a multisampled G-buffer.
pub const SHADER_MSAA: ShaderSource = SHADER.with_defs(&[crate::shaders::MSAA]);
/// `tiled.wgsl` reading the compute visibility pass's samples.
pub const SHADER_VISIBILITY_MSAA: ShaderSource = SHADER.with_defs(&["VISIBILITY_BUFFER", crate::shaders::MSAA]);

/// `--dc-tile`: the side of the lighting pass's tiles, or `auto`, the one
/// measured faster for the scenario ([`TileSide::for_scenario`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum TileChoice {
    /// 8x8 with few lights on single-layer materials at one sample a pixel,
    /// else 16x16, chosen again whenever the frame's lights change.
    #[default]
    Auto,
    /// 8x8 pixels, 64 invocations a workgroup.
    #[value(name = "8")]
    #[serde(rename = "8")]
    Eight,
    /// 16x16 pixels, 256 invocations a workgroup.
    #[value(name = "16")]
    #[serde(rename = "16")]
    Sixteen,
}

impl TileChoice {
    /// The side for a frame with `point_lights` point and spot lights.
    pub fn side(self, point_lights: usize, layered: bool, samples: u32) -> TileSide {
        match self {
            Self::Auto => TileSide::for_scenario(point_lights, layered, samples),
            Self::Eight => TileSide::Eight,
            Self::Sixteen => TileSide::Sixteen,
        }
    }
}

/// Side in pixels of the lighting pass's tiles: one workgroup of side x side
/// invocations a tile, each culling one light a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileSide {
    /// 8x8 pixels, 64 invocations a workgroup.
    Eight,
    /// 16x16 pixels, 256 invocations a workgroup.
    Sixteen,
}

/// The most point and spot lights for which `--dc-tile auto` takes 8x8
/// tiles. Along Sponza's path on an H200 8x8 tiles were 2-13 % faster up to
/// 100 small lights (and with 64 shadowed or 32 big ones) and 1-26 % slower
/// from 150 to 500 (43-52 % at 1,000) at 1920x1080 and 3840x2160
/// (BENCHMARKS.md, "The lighting tiles' side, chosen per scenario").
pub const SMALL_TILES_MOST_LIGHTS: usize = 128;

impl TileSide {
    /// The side measured faster for a frame with `point_lights` point and
    /// spot lights, on layered materials or not, at `samples` per pixel:
    /// 8x8 where a pixel's work is short and the lights few (the pass holds
    /// 109 registers an invocation, so small workgroups wait at their
    /// barriers for fewer invocations), 16x16 where each tile's culling of
    /// many lights costs more than that (a quarter of the tiles cull them)
    /// or a pixel's work is long: layers walked for every light, MSAA's edge
    /// pixels shaded per sample. Measured with compute visibility, the
    /// default where the adapter has 64-bit atomics.
    pub fn for_scenario(point_lights: usize, layered: bool, samples: u32) -> Self {
        if layered || samples > 1 || point_lights > SMALL_TILES_MOST_LIGHTS { Self::Sixteen } else { Self::Eight }
    }

    /// The side in pixels.
    pub fn pixels(self) -> u32 {
        match self {
            Self::Eight => 8,
            Self::Sixteen => 16,
        }
    }

    /// The definitions `tiled.wgsl` takes for it.
    fn defs(self) -> &'static [&'static str] {
        match self {
            Self::Eight => &[SMALL_TILES],
            Self::Sixteen => &[],
        }
    }
}

/// Defined for `tiled.wgsl` with [`TileSide::Eight`].
pub const SMALL_TILES: &str = "SMALL_TILES";
/// Lights a tile's workgroup list holds; when fewer than a chunk's worth of
/// places are left, the tile shades the listed lights and starts again.
pub const TILE_LIGHT_CAPACITY: u32 = 512;

/// The constants `tiled.wgsl` shares with Rust (`shaders::contract`): the
/// list's capacity and the tile sides, which size the workgroups there and
/// the dispatch here.
pub fn wgsl_constants() -> [(&'static str, u32); 3] {
    [
        ("TILED_LIST_CAPACITY", TILE_LIGHT_CAPACITY),
        ("TILED_SMALL_SIDE", TileSide::Eight.pixels()),
        ("TILED_LARGE_SIDE", TileSide::Sixteen.pixels()),
    ]
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
    /// The lighting pass's tiles.
    pub tile: TileChoice,
}

impl Default for DeferredComputeConfig {
    fn default() -> Self {
        Self {
            depth_prepass: true,
            visibility: VisibilityMethod::Raster,
            count_visibility: false,
            tile: TileChoice::default(),
        }
    }
}

/// Where the lighting pass reads its pixels from.
enum Surfaces {
    Gbuffer(Box<GbufferStage>),
    Visibility { ids: VisibilityBuffer, pass: Box<ComputeVisibility> },
}

impl Surfaces {
    /// The layout of their group (the lighting pass's group 1).
    fn read_layout(&self) -> &wgpu::BindGroupLayout {
        match self {
            Self::Gbuffer(stage) => &stage.gbuffer.read_layout,
            Self::Visibility { pass, .. } => &pass.read_layout,
        }
    }
}

/// Under MSAA: the lighting pass's count of lit and edge pixels (two
/// `u32`s, cleared every frame) and its read-back.
struct EdgeCounts {
    buffer: wgpu::Buffer,
    readback: ReadbackRing<u64>,
}

/// Bytes of [`EdgeCounts::buffer`].
const EDGE_COUNTS_BYTES: u64 = 8;

/// The lighting pass's pipeline for one tile side, and what building it for
/// the other side takes (its shader variant and its group 2's layout).
struct TiledLighting {
    side: TileSide,
    pipeline: wgpu::ComputePipeline,
    shader: ShaderSource,
    output_layout: wgpu::BindGroupLayout,
}

impl TiledLighting {
    /// Builds the pass for `side`, over the scene's and the surfaces' groups.
    fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        groups: [&wgpu::BindGroupLayout; 2],
        shader: ShaderSource,
        output_layout: wgpu::BindGroupLayout,
        side: TileSide,
    ) -> Result<Self, ShaderError> {
        let pipeline = Self::build(device, shaders, groups, shader, &output_layout, side)?;
        Ok(Self { side, pipeline, shader, output_layout })
    }

    /// Builds it again for `side` where it was built for the other.
    fn set_side(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        groups: [&wgpu::BindGroupLayout; 2],
        side: TileSide,
    ) -> Result<(), ShaderError> {
        if side != self.side {
            self.pipeline = Self::build(device, shaders, groups, self.shader, &self.output_layout, side)?;
            self.side = side;
        }
        Ok(())
    }

    fn build(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        groups: [&wgpu::BindGroupLayout; 2],
        shader: ShaderSource,
        output_layout: &wgpu::BindGroupLayout,
        side: TileSide,
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let layouts = [groups[0], groups[1], output_layout];
        compute_pipeline_with(device, shaders, shader, side.defs(), "tiled_lighting", &layouts)
    }
}

/// The tiled deferred pipeline.
pub struct DeferredCompute {
    config: DeferredComputeConfig,
    surfaces: Surfaces,
    lighting: TiledLighting,
    /// Samples a pixel: with the lights and the scene's layers, what
    /// `--dc-tile auto` chooses by.
    samples: u32,
    /// The HDR target, written (and under MSAA the edge counts).
    output: wgpu::BindGroup,
    edge_counts: Option<EdgeCounts>,
    /// For scenes with an environment: drawn where no surface is.
    background: Option<Background>,
    /// For scenes with alpha-blended objects: lit forward after the tiles.
    blended: Option<BlendedPass>,
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
        let msaa = targets.samples > 1;
        let surfaces = match config.visibility {
            VisibilityMethod::Raster => {
                Surfaces::Gbuffer(Box::new(GbufferStage::new(device, shaders, scene, targets, config.depth_prepass)?))
            }
            VisibilityMethod::Compute => {
                let ids = VisibilityBuffer::new(device, targets, VisibilityMethod::Compute);
                let pass = ComputeVisibility::new(device, shaders, scene, targets, &ids, config.count_visibility)?;
                Surfaces::Visibility { ids, pass: Box::new(pass) }
            }
        };
        let (layout, output, edge_counts) = if msaa {
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("msaa edge counts"),
                size: EDGE_COUNTS_BYTES,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let dimension = wgpu::TextureViewDimension::D2;
            let layout = bind_group_layout(
                device,
                "tiled lighting output",
                &[
                    Binding::StorageTexture { format: super::targets::HDR_FORMAT, dimension },
                    Binding::Storage { read_only: false },
                ],
            );
            let resources = [wgpu::BindingResource::TextureView(&targets.hdr_view), buffer.as_entire_binding()];
            let output = bind_group(device, "tiled lighting output", &layout, &resources);
            let readback = ReadbackRing::new("msaa edge counts", EDGE_COUNTS_BYTES);
            (layout, output, Some(EdgeCounts { buffer, readback }))
        } else {
            let (layout, output) = hdr_output(device, targets, "tiled lighting output");
            (layout, output, None)
        };
        let shader = match (&surfaces, msaa) {
            (Surfaces::Gbuffer(_), true) => SHADER_MSAA,
            (Surfaces::Gbuffer(_), false) => SHADER,
            (Surfaces::Visibility { .. }, true) => SHADER_VISIBILITY_MSAA,
            (Surfaces::Visibility { .. }, false) => SHADER_VISIBILITY,
        };
        // `auto` builds the side for no point lights until the first
        // frame's lights ask for the other (`lights_changed`).
        let side = config.tile.side(0, scene.layers, targets.samples);
        let lighting =
            TiledLighting::new(device, shaders, [&scene.layout, surfaces.read_layout()], shader, layout, side)?;
        // The compute rasterizer leaves the depth target to the blended pass.
        let lay_depth = config.visibility == VisibilityMethod::Compute;
        let blended = BlendedPass::new(device, shaders, scene, targets, forward::SHADER, &[], lay_depth)?;
        let coverage = match &surfaces {
            Surfaces::Gbuffer(_) => Coverage::Depth,
            Surfaces::Visibility { ids, .. } => Coverage::Ids(ids),
        };
        let background = Background::new(device, shaders, scene, targets, coverage, false)?;
        Ok(Self { config, surfaces, lighting, samples: targets.samples, output, edge_counts, background, blended })
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
        if let Some(counts) = &self.edge_counts {
            frame.encoder.clear_buffer(&counts.buffer, 0, None);
        }
        tiled_lighting(frame, &self.lighting.pipeline, read, &self.output, self.lighting.side.pixels());
        if let Some(counts) = &mut self.edge_counts {
            counts.readback.copy(frame.device, frame.encoder, &counts.buffer, EDGE_COUNTS_BYTES, frame.number);
        }
        if let Some(pass) = &self.background {
            background(frame, pass);
        }
        if let Some(blended) = &self.blended {
            blended_pass(frame, blended, &[]);
        }
    }

    /// Lights come from the tiles' own lists, not the CPU's per-object ones.
    fn uses_object_light_lists(&self) -> bool {
        false
    }

    /// `--dc-tile auto`: the tile side for these lights, the pass built
    /// again when it changes.
    fn lights_changed(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        point_lights: usize,
    ) -> Result<(), ShaderError> {
        let side = self.config.tile.side(point_lights, scene.layers, self.samples);
        self.lighting.set_side(device, shaders, [&scene.layout, self.surfaces.read_layout()], side)
    }

    /// With the G-buffer and its depth pre-pass (the compute rasterizer culls on its own).
    fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<(), ShaderError> {
        match &mut self.surfaces {
            Surfaces::Gbuffer(stage) => stage.enable_cluster_culling(device, shaders, scene, targets),
            Surfaces::Visibility { .. } => Ok(()),
        }
    }

    fn after_submit(&mut self) {
        match &mut self.surfaces {
            Surfaces::Visibility { pass, .. } => pass.after_submit(),
            Surfaces::Gbuffer(stage) => {
                if let Some(p) = stage.prepass_mut() {
                    p.after_submit();
                }
            }
        }
        if let Some(counts) = &mut self.edge_counts {
            counts.readback.after_submit();
        }
    }

    /// With `count_visibility`, the compute rasterizer's counts; under MSAA
    /// the lit pixels, the edge pixels and their share of the lit ones.
    fn collect_counters(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(u64, Counters)> {
        if let Surfaces::Gbuffer(stage) = &mut self.surfaces
            && let Some(p) = stage.prepass_mut()
        {
            let culled = p.collect_counts(device, wait);
            if !culled.is_empty() {
                return culled;
            }
        }
        if let Some(counts) = &mut self.edge_counts {
            return counts
                .readback
                .collect(device, wait)
                .into_iter()
                .map(|(frame, bytes)| {
                    let [lit, edges]: [u32; 2] = bytemuck::pod_read_unaligned(&bytes);
                    let (lit, edges) = (f64::from(lit), f64::from(edges));
                    let share = if lit > 0.0 { edges / lit } else { 0.0 };
                    let counters: Counters = [
                        ("msaa_lit_pixels".to_string(), lit),
                        ("msaa_edge_pixels".to_string(), edges),
                        ("msaa_edge_share".to_string(), share),
                    ]
                    .into();
                    (frame, counters)
                })
                .collect();
        }
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
        report
            .setup("tile_size", self.lighting.side.pixels() as u64)
            .setup("tile_light_capacity", TILE_LIGHT_CAPACITY as u64)
    }
}

/// Reads: the surfaces (`read`: the G-buffer with depth, or the visibility
/// buffers) and the lights. Writes: every pixel of `targets.hdr` (through `output`).
fn tiled_lighting(
    frame: &mut Frame,
    pipeline: &wgpu::ComputePipeline,
    read: &wgpu::BindGroup,
    output: &wgpu::BindGroup,
    side: u32,
) {
    let (w, h) = (frame.targets.width.div_ceil(side), frame.targets.height.div_ceil(side));
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("tiled lighting");
    cp.set_pipeline(pipeline);
    cp.set_bind_group(0, scene, &[]);
    cp.set_bind_group(1, read, &[]);
    cp.set_bind_group(2, output, &[]);
    cp.dispatch_workgroups(w, h, 1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_takes_small_tiles_only_for_short_pixels_and_few_lights() {
        let most = SMALL_TILES_MOST_LIGHTS;
        assert_eq!(TileSide::for_scenario(0, false, 1), TileSide::Eight);
        assert_eq!(TileSide::for_scenario(most, false, 1), TileSide::Eight);
        assert_eq!(TileSide::for_scenario(most + 1, false, 1), TileSide::Sixteen);
        assert_eq!(TileSide::for_scenario(1, true, 1), TileSide::Sixteen);
        assert_eq!(TileSide::for_scenario(1, false, 4), TileSide::Sixteen);
        assert_eq!(TileChoice::Auto.side(most + 1, false, 1), TileSide::Sixteen);
        assert_eq!(TileChoice::Eight.side(10_000, true, 4), TileSide::Eight);
        assert_eq!(TileChoice::Sixteen.side(0, false, 1), TileSide::Sixteen);
    }
}
