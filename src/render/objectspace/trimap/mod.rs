//! Triangle-index maps: per physical page, the triangle covering each texel
//! of the virtual page it backs, built on the GPU when paging backs the page
//! (`trimap.wgsl`, one workgroup per backed page), so that maps exist only
//! for the pages visible tiles use. The rule is the same on every adapter
//! (no conservative rasterization needed): of the triangles touching a
//! texel, the nearest to its centre; else one ring of dilation. `cpu.rs` is
//! its CPU twin, `grid.rs` the per-mesh chart grids it searches.

pub mod cpu;
pub mod grid;

use wgpu::util::DeviceExt;

use super::resources::{BACKED_ARGS, Resources, TRIANGLE_MAP_FORMAT};
use super::{ObjectSpaceConfig, PagingChain, TrimapSearch};
use crate::render::frame::Frame;
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline_with};
use crate::render::scene_gpu::SceneGpu;
use crate::scene::Scene;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};
use grid::ChartGrid;

pub const SHADER: ShaderSource = ShaderSource::new("trimap.wgsl", include_str!("trimap.wgsl"));
/// Defined with [`PagingChain::Fused`]: each page's workgroup also marks its
/// requested tiles (`mark_backed.wgsl`).
pub const MARK_BACKED: &str = "MARK_BACKED";
/// Defined for more than one invocation per texel, with `TRIMAP_LANES_4` or
/// `TRIMAP_LANES_8` for 4 or 8 (else 2).
pub const LANES: &str = "TRIMAP_LANES";
/// Defined with [`TrimapSearch::Neighbourhood`].
pub const NEIGHBOURHOOD: &str = "TRIMAP_NEIGHBOURHOOD";
/// The variants besides [`SHADER`], for the test that validates every shader.
pub const VARIANTS: [ShaderSource; 5] = [
    SHADER.with_defs(&[MARK_BACKED]),
    SHADER.with_defs(&[NEIGHBOURHOOD]),
    SHADER.with_defs(&[LANES]),
    SHADER.with_defs(&[LANES, "TRIMAP_LANES_4", MARK_BACKED, NEIGHBOURHOOD]),
    SHADER.with_defs(&[LANES, "TRIMAP_LANES_8", MARK_BACKED]),
];

/// The definitions composing the pass for `lanes` invocations per texel
/// (one of [`super::TRIMAP_LANES`]), the paging `chain` and the `search`.
fn defs(lanes: u32, chain: PagingChain, search: TrimapSearch) -> Vec<&'static str> {
    let mut defs = match lanes {
        1 => vec![],
        2 => vec![LANES],
        4 => vec![LANES, "TRIMAP_LANES_4"],
        _ => vec![LANES, "TRIMAP_LANES_8"],
    };
    if chain == PagingChain::Fused {
        defs.push(MARK_BACKED);
    }
    if search == TrimapSearch::Neighbourhood {
        defs.push(NEIGHBOURHOOD);
    }
    defs
}

gpu_struct! {
    /// One object's chart grid (`ChartGrid` in `trimap.wgsl`).
    pub struct GpuChartGrid as "ChartGrid" {
        pub cell_base: u32,
        pub side: u32,
    }
}

pub struct TrimapPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    /// The chart grids, their cells' first triangles and the triangles.
    grids: [wgpu::Buffer; 3],
    group: wgpu::BindGroup,
    /// Bytes of the chart grids.
    pub grid_bytes: u64,
    /// Invocations weighing each texel's triangles.
    pub lanes: u32,
}

impl TrimapPass {
    /// Builds the chart grids of `scene`'s meshes (chart UVs: `uv1`, else
    /// `uv0`; `config.trimap_grid` times the default cells per side); the
    /// pass weighs each texel's triangles with `lanes`
    /// invocations, searching as `config.trimap_search` says, and with
    /// [`PagingChain::Fused`] also marks the pages.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        res: &Resources,
        config: &ObjectSpaceConfig,
        lanes: u32,
    ) -> Result<Self, ShaderError> {
        let (mut cell_start, mut triangles, mut mesh_grids) = (Vec::new(), Vec::new(), Vec::new());
        for mesh in &scene.meshes {
            let g = ChartGrid::scaled(mesh.uv1.as_deref().unwrap_or(&mesh.uv0), &mesh.indices, config.trimap_grid);
            mesh_grids.push(GpuChartGrid { cell_base: cell_start.len() as u32, side: g.side });
            let offset = triangles.len() as u32;
            cell_start.extend(g.cell_start.iter().map(|s| s + offset));
            triangles.extend(g.triangles);
        }
        let grids: Vec<GpuChartGrid> = scene.objects.iter().map(|o| mesh_grids[o.mesh]).collect();
        let buffer = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                // Empty buffers cannot be bound.
                contents: if contents.is_empty() { &[0; 16] } else { contents },
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let grid_buffer = buffer("chart grids", bytemuck::cast_slice(&grids));
        let start_buffer = buffer("chart grid cells", bytemuck::cast_slice(&cell_start));
        let triangle_buffer = buffer("chart grid triangles", bytemuck::cast_slice(&triangles));
        let read = Binding::Storage { read_only: true };
        let dimension = wgpu::TextureViewDimension::D2Array;
        let layout = bind_group_layout(
            device,
            "triangle map build",
            &[Binding::StorageTexture { format: TRIANGLE_MAP_FORMAT, dimension }, read, read, read],
        );
        let groups = [&scene_gpu.layout, &res.layout, &layout];
        let defs = defs(lanes, config.paging_chain, config.trimap_search);
        let pipeline = compute_pipeline_with(device, shaders, SHADER, &defs, "build", &groups)?;
        let grid_bytes = (grids.len() * 8 + cell_start.len() * 4 + triangles.len() * 4) as u64;
        let grids = [grid_buffer, start_buffer, triangle_buffer];
        let group = Self::group(device, &layout, &grids, res);
        Ok(Self { pipeline, layout, grids, group, grid_bytes, lanes })
    }

    /// Binds the triangle maps again after the atlas was resized.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.group = Self::group(device, &self.layout, &self.grids, res);
    }

    fn group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        grids: &[wgpu::Buffer; 3],
        res: &Resources,
    ) -> wgpu::BindGroup {
        bind_group(
            device,
            "triangle map build",
            layout,
            &[
                wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
                grids[0].as_entire_binding(),
                grids[1].as_entire_binding(),
                grids[2].as_entire_binding(),
            ],
        )
    }
}

/// Reads: the backed-page list, the chart grids, the scene's chart UVs.
/// Writes: the triangle maps of the pages backed this frame (with
/// [`PagingChain::Fused`], what `mark::mark_backed_pages` writes too).
pub fn build_triangle_maps(frame: &mut Frame, pass: &TrimapPass, res: &Resources) {
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("triangle maps");
    cp.set_pipeline(&pass.pipeline);
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &pass.group, &[]);
    cp.dispatch_workgroups_indirect(&res.dispatch, BACKED_ARGS);
}
