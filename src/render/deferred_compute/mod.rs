//! Tiled deferred shading, lit in compute: the shared G-buffer pass, then
//! one compute pass over 16x16 screen tiles (8x8 with `--dc-tile 8`;
//! `tiled.wgsl`). Each workgroup reduces its tile's depth range, builds the
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
//! lights of the gap; no shadows (the lighting model has none yet).

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

/// Side in pixels of the lighting pass's tiles (`--dc-tile`): one workgroup
/// of side x side invocations a tile, each culling one light a step.
/// Which is faster depends on the scene: along Sponza's path on an H200,
/// 8x8 tiles took 0.388 ms a frame instead of 0.422 at 1920x1080 with one
/// light, 0.460 instead of 0.507 with 30 shadowed lights (1.157 and 1.393
/// instead of 1.294 and 1.572 at 3840x2160), where the pass holds 109
/// registers an invocation and a workgroup of 64 waits at its barriers for
/// fewer; with 8 layers a material and 30 shadowed lights, 2.697 ms instead
/// of 2.074 (9.933 instead of 7.675): the layers' walk per light makes the
/// culling steps rarer and each pixel's work longer (BENCHMARKS.md, "Tiles
/// of 8x8").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
pub enum TileSide {
    /// 8x8 pixels, 64 invocations a workgroup.
    #[value(name = "8")]
    #[serde(rename = "8")]
    Eight,
    /// 16x16 pixels, 256 invocations a workgroup.
    #[default]
    #[value(name = "16")]
    #[serde(rename = "16")]
    Sixteen,
}

impl TileSide {
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
    pub tile: TileSide,
}

impl Default for DeferredComputeConfig {
    fn default() -> Self {
        Self {
            depth_prepass: true,
            visibility: VisibilityMethod::Raster,
            count_visibility: false,
            tile: TileSide::default(),
        }
    }
}

/// Where the lighting pass reads its pixels from.
enum Surfaces {
    Gbuffer(Box<GbufferStage>),
    Visibility { ids: VisibilityBuffer, pass: Box<ComputeVisibility> },
}

/// Under MSAA: the lighting pass's count of lit and edge pixels (two
/// `u32`s, cleared every frame) and its read-back.
struct EdgeCounts {
    buffer: wgpu::Buffer,
    readback: ReadbackRing<u64>,
}

/// Bytes of [`EdgeCounts::buffer`].
const EDGE_COUNTS_BYTES: u64 = 8;

/// The tiled deferred pipeline.
pub struct DeferredCompute {
    config: DeferredComputeConfig,
    surfaces: Surfaces,
    lighting: wgpu::ComputePipeline,
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
        let (shader, read_layout) = match &surfaces {
            Surfaces::Gbuffer(stage) if msaa => (SHADER_MSAA, &stage.gbuffer.read_layout),
            Surfaces::Gbuffer(stage) => (SHADER, &stage.gbuffer.read_layout),
            Surfaces::Visibility { pass, .. } if msaa => (SHADER_VISIBILITY_MSAA, &pass.read_layout),
            Surfaces::Visibility { pass, .. } => (SHADER_VISIBILITY, &pass.read_layout),
        };
        let groups = [&scene.layout, read_layout, &layout];
        let lighting = compute_pipeline_with(device, shaders, shader, config.tile.defs(), "tiled_lighting", &groups)?;
        // The compute rasterizer leaves the depth target to the blended pass.
        let lay_depth = config.visibility == VisibilityMethod::Compute;
        let blended = BlendedPass::new(device, shaders, scene, targets, forward::SHADER, &[], lay_depth)?;
        let coverage = match &surfaces {
            Surfaces::Gbuffer(_) => Coverage::Depth,
            Surfaces::Visibility { ids, .. } => Coverage::Ids(ids),
        };
        let background = Background::new(device, shaders, scene, targets, coverage, false)?;
        Ok(Self { config, surfaces, lighting, output, edge_counts, background, blended })
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
        tiled_lighting(frame, &self.lighting, read, &self.output, self.config.tile.pixels());
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
            .setup("tile_size", self.config.tile.pixels() as u64)
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
