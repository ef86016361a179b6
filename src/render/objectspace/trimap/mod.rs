//! Triangle-index maps: per physical page, the triangle covering each texel
//! of the virtual page it backs, built on the GPU when paging backs the page
//! (`trimap.wgsl`, one workgroup per backed page), so that maps exist only
//! for the pages visible tiles use. The rule is the same on every adapter
//! (no conservative rasterization needed): of the triangles touching a
//! texel, the nearest to its centre; else one ring of dilation. `cpu.rs` is
//! its CPU twin, `grid.rs` the per-mesh chart grids it searches.
//!
//! A page's map depends only on its mesh, level size and page, never on the
//! instance: with [`ObjectSpaceConfig::trimap_share`] a page backed this
//! frame copies the map of a page that already holds it (another
//! instance's, built this frame or before) instead of building it again.
//! The maps stay one per physical page, so shading and gathering read them
//! as before. Each physical page's *key* says which map it holds (its
//! mesh's first map number, the level's, the page's, + 1; 0: none known),
//! and a hash table from keys to physical pages finds one; a page whose key
//! no longer matches the entry (freed and backed again elsewhere) is no
//! source, and a page finding none builds its map: a missed share costs a
//! build, never a wrong texel. Per frame, one pass forgets the keys of the
//! pages backed this frame, the build pass claims each page (a source, or
//! it builds and enters itself in the table) and a last pass copies the
//! maps of the pages that found a source, after every build.
//!
//! The slowest pages to build are at the middle levels (on Sponza's path at
//! 1920x1080, levels of 128 to 1,024 texels: the pass took 0.025 ms without
//! their search, 0.049 with it, on the H200), and the pass lasts as long as
//! its slowest page. With [`ObjectSpaceConfig::trimap_store`] each mesh's
//! maps of every level up to that size are built once, the first frame
//! (`build_stored`, the same search), and a page of those levels copies its
//! texels from them: 350,000 texels a mesh up to 512 (the default on a GPU).

pub mod cpu;
pub mod grid;

use wgpu::util::DeviceExt;

use super::atlas::AtlasLayout;
use super::resources::{BACKED_ARGS, Resources, TRIANGLE_MAP_FORMAT};
use super::{ObjectSpaceConfig, PagingChain, TrimapSearch, trimap_lanes, trimap_store};
use crate::gpu::GpuContext;
use crate::render::frame::{TimedComputePass, stage};
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
/// Defined with [`ObjectSpaceConfig::trimap_share`]: a page copies the map
/// of a page holding the same one where it finds it.
pub const SHARE: &str = "TRIMAP_SHARE";
/// The variants besides [`SHADER`], for the test that validates every shader.
pub const VARIANTS: [ShaderSource; 6] = [
    SHADER.with_defs(&[MARK_BACKED]),
    SHADER.with_defs(&[NEIGHBOURHOOD]),
    SHADER.with_defs(&[LANES]),
    SHADER.with_defs(&[LANES, "TRIMAP_LANES_4", MARK_BACKED, NEIGHBOURHOOD, SHARE]),
    SHADER.with_defs(&[LANES, "TRIMAP_LANES_8", MARK_BACKED]),
    SHADER.with_defs(&[SHARE]),
];

/// A mesh whose pages share no maps (one instance, or past the 32-bit keys).
const NO_SHARE: u32 = u32::MAX;

/// The definitions composing the pass for `lanes` invocations per texel
/// (one of [`super::TRIMAP_LANES`]), the paging `chain`, the `search` and
/// whether pages `share` maps.
fn defs(lanes: u32, chain: PagingChain, search: TrimapSearch, share: bool) -> Vec<&'static str> {
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
    if share {
        defs.push(SHARE);
    }
    defs
}

/// Map numbers below level size `size` (a power of two) of pages of
/// `page_size` texels: a page per `page_size` texels each way, every size
/// from 1 texel up (`level_keys` in `trimap.wgsl`).
fn keys_below(size: u32, page_size: u32) -> u64 {
    (0..size.ilog2()).map(|k| ((1u64 << k).div_ceil(page_size as u64)).pow(2)).sum()
}

/// Per mesh, its first map number ([`NO_SHARE`] for a mesh with fewer than
/// two instances in the atlas, or once the numbers pass 32 bits): each mesh
/// numbers the pages of every level size up to its largest instance's.
fn mesh_key_bases(scene: &Scene, layout: &AtlasLayout) -> Vec<u32> {
    let mut largest = vec![(0u32, 0u32); scene.meshes.len()];
    for (object, atlas) in scene.objects.iter().zip(&layout.objects) {
        if let Some(a) = atlas {
            let (count, size) = &mut largest[object.mesh];
            *count += 1;
            *size = (*size).max(a.size);
        }
    }
    let mut next = 0u64;
    largest
        .iter()
        .map(|&(count, size)| {
            let span = keys_below(size.max(1) * 2, layout.page_size);
            // Keys are numbers + 1, 0 meaning none.
            if count < 2 || next + span >= u32::MAX as u64 {
                return NO_SHARE;
            }
            next += span;
            (next - span) as u32
        })
        .collect()
}

gpu_struct! {
    /// One object's chart grid (`ChartGrid` in `trimap.wgsl`) and its
    /// mesh's first map number for shared maps.
    pub struct GpuChartGrid as "ChartGrid" {
        pub cell_base: u32,
        pub side: u32,
        pub key_base: u32,
        /// Where the mesh's stored maps start (`StoredMaps`), and the
        /// widest level stored (0: none).
        pub store_base: u32,
        pub store_size: u32,
        pub pad0: u32,
        pub pad1: u32,
        pub pad2: u32,
    }
}

/// The stored maps: per mesh, every level size up to the store's (or the
/// mesh's largest instance's, if smaller), built once by `build_stored`.
struct StoredMaps {
    pipeline: wgpu::ComputePipeline,
    /// Blocks of 8x8 texels to fill (a workgroup each).
    blocks: u32,
    built: bool,
}

/// Per mesh, where its stored maps start and the widest level stored (0:
/// none), for levels up to `store` texels wide (0: none); and the blocks
/// of 8x8 texels they take, (an object of the mesh, level size, first texel
/// x | y << 16, 0).
fn store_layout(scene: &Scene, layout: &AtlasLayout, store: u32) -> (Vec<(u32, u32)>, Vec<[u32; 4]>, u64) {
    let mut largest = vec![(0u32, 0usize); scene.meshes.len()];
    for (o, (object, atlas)) in scene.objects.iter().zip(&layout.objects).enumerate() {
        if let Some(a) = atlas
            && a.size > largest[object.mesh].0
        {
            largest[object.mesh] = (a.size, o);
        }
    }
    let (mut next, mut blocks) = (0u64, Vec::new());
    let bases = largest
        .iter()
        .map(|&(size, object)| {
            let top = store.min(size);
            if top == 0 {
                return (0, 0);
            }
            let base = next;
            // Every power of two up to `top`: (4 top^2 - 1) / 3 texels.
            next += (4 * u64::from(top) * u64::from(top) - 1) / 3;
            let mut s = 1;
            while s <= top {
                for y in (0..s).step_by(8) {
                    for x in (0..s).step_by(8) {
                        blocks.push([object as u32, s, x | (y << 16), 0]);
                    }
                }
                s *= 2;
            }
            (base as u32, top)
        })
        .collect();
    (bases, blocks, next)
}

/// With shared maps: the passes forgetting the keys of the pages backed
/// this frame and copying the maps found, the keys' table and the pages' keys.
struct Sharing {
    forget: wgpu::ComputePipeline,
    copy: wgpu::ComputePipeline,
    keys: wgpu::Buffer,
}

pub struct TrimapPass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    /// The chart grids, their cells' first triangles, the triangles, the
    /// shared maps' table (physical page + 1 per slot) and keys (per
    /// physical page: the key of the map it holds + 1, 0 for none known),
    /// the stored maps after their blocks.
    buffers: [wgpu::Buffer; 6],
    sharing: Option<Sharing>,
    group: wgpu::BindGroup,
    /// Bytes of the chart grids.
    pub grid_bytes: u64,
    /// Bytes of the shared maps' table and keys (0 without sharing).
    pub share_bytes: u64,
    /// The stored maps, until built and after ([`ObjectSpaceConfig::trimap_store`]).
    stored: Option<StoredMaps>,
    /// Bytes of the stored maps (0 without).
    pub store_bytes: u64,
    /// Invocations weighing each texel's triangles.
    pub lanes: u32,
}

impl TrimapPass {
    /// Builds the chart grids of `scene`'s meshes (chart UVs: `uv1`, else
    /// `uv0`; `config.trimap_grid` times the default cells per side); the
    /// pass weighs each texel's triangles with the lanes `config` asks for
    /// on `ctx`'s adapter ([`trimap_lanes`]), searching as
    /// `config.trimap_search` says, and with [`PagingChain::Fused`] also
    /// marks the pages; with `config.trimap_share` the instances of a mesh
    /// in `layout` share maps.
    pub fn new(
        ctx: &GpuContext,
        shaders: &mut ShaderLibrary,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        res: &Resources,
        layout: &AtlasLayout,
        config: &ObjectSpaceConfig,
    ) -> Result<Self, ShaderError> {
        let (device, lanes) = (&ctx.device, trimap_lanes(config, &ctx.info));
        let (mut cell_start, mut triangles, mut mesh_grids) = (Vec::new(), Vec::new(), Vec::new());
        let key_bases =
            if config.trimap_share { mesh_key_bases(scene, layout) } else { vec![NO_SHARE; scene.meshes.len()] };
        let (store_bases, store_blocks, store_texels) = store_layout(scene, layout, trimap_store(config, &ctx.info));
        // The maps follow the blocks' count and the blocks in their buffer.
        let maps_start = 1 + 4 * store_blocks.len() as u32;
        for ((mesh, &key_base), &(store_base, store_size)) in scene.meshes.iter().zip(&key_bases).zip(&store_bases) {
            let g = ChartGrid::scaled(mesh.uv1.as_deref().unwrap_or(&mesh.uv0), &mesh.indices, config.trimap_grid);
            let cell_base = cell_start.len() as u32;
            let store_base = store_base + maps_start;
            mesh_grids.push(GpuChartGrid {
                cell_base,
                side: g.side,
                key_base,
                store_base,
                store_size,
                pad0: 0,
                pad1: 0,
                pad2: 0,
            });
            let offset = triangles.len() as u32;
            cell_start.extend(g.cell_start.iter().map(|s| s + offset));
            triangles.extend(g.triangles);
        }
        let grids: Vec<GpuChartGrid> = scene.objects.iter().map(|o| mesh_grids[o.mesh]).collect();
        let buffer = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                // Empty buffers cannot be bound.
                contents: if contents.is_empty() { &[0; 16] } else { contents },
                usage: wgpu::BufferUsages::STORAGE | usage,
            })
        };
        let none = wgpu::BufferUsages::empty();
        let grid_buffer = buffer("chart grids", bytemuck::cast_slice(&grids), none);
        let start_buffer = buffer("chart grid cells", bytemuck::cast_slice(&cell_start), none);
        let triangle_buffer = buffer("chart grid triangles", bytemuck::cast_slice(&triangles), none);
        let share = config.trimap_share && key_bases.iter().any(|&b| b != NO_SHARE);
        // At most half full: each physical page enters the table once per backing.
        let (table_slots, key_count) =
            if share { ((res.pool.pages * 2).next_power_of_two().max(64), res.pool.pages) } else { (4, 4) };
        let table = buffer("shared triangle maps", &vec![0; table_slots as usize * 4], none);
        let keys = buffer("triangle map keys", &vec![0; key_count as usize * 4], wgpu::BufferUsages::COPY_DST);
        // The blocks' count and the blocks, then the maps (one binding).
        let mut store_words = vec![store_blocks.len() as u32];
        store_words.extend(store_blocks.iter().flatten());
        store_words.resize(store_words.len() + store_texels as usize, 0);
        let store = buffer("stored triangle maps", bytemuck::cast_slice(&store_words), none);
        let store_bytes = store_words.len() as u64 * 4;
        let read = Binding::Storage { read_only: true };
        let write = Binding::Storage { read_only: false };
        let dimension = wgpu::TextureViewDimension::D2Array;
        // Read and written: the copy pass reads the maps it copies.
        let map = Binding::StorageTextureReadWrite { format: TRIANGLE_MAP_FORMAT, dimension };
        let layout = bind_group_layout(device, "triangle map build", &[map, read, read, read, write, write, write]);
        let groups = [&scene_gpu.layout, &res.layout, &layout];
        let defs = defs(lanes, config.paging_chain, config.trimap_search, share);
        let pipeline = compute_pipeline_with(device, shaders, SHADER, &defs, "build", &groups)?;
        let sharing = if share {
            let defs = [SHARE];
            Some(Sharing {
                forget: compute_pipeline_with(device, shaders, SHADER, &defs, "forget_keys", &groups)?,
                copy: compute_pipeline_with(device, shaders, SHADER, &defs, "copy_shared", &groups)?,
                keys: keys.clone(),
            })
        } else {
            None
        };
        let grid_bytes = (grids.len() * size_of::<GpuChartGrid>() + cell_start.len() * 4 + triangles.len() * 4) as u64;
        let share_bytes = if share { (table_slots as u64 + key_count as u64) * 4 } else { 0 };
        let stored = if store_blocks.is_empty() {
            None
        } else {
            let pipeline = compute_pipeline_with(device, shaders, SHADER, &defs, "build_stored", &groups)?;
            Some(StoredMaps { pipeline, blocks: store_blocks.len() as u32, built: false })
        };
        let buffers = [grid_buffer, start_buffer, triangle_buffer, table, keys, store];
        let group = Self::group(device, &layout, &buffers, res);
        Ok(Self { pipeline, layout, buffers, sharing, group, grid_bytes, share_bytes, stored, store_bytes, lanes })
    }

    /// Binds the triangle maps again after the atlas was resized.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.group = Self::group(device, &self.layout, &self.buffers, res);
    }

    /// Forgets which map every physical page holds (after pages moved onto
    /// others): their maps are built again, or copied, when next backed.
    pub fn forget_maps(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(sharing) = &self.sharing {
            encoder.clear_buffer(&sharing.keys, 0, None);
        }
    }

    fn group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        buffers: &[wgpu::Buffer; 6],
        res: &Resources,
    ) -> wgpu::BindGroup {
        let mut resources = vec![wgpu::BindingResource::TextureView(&res.physical.triangle_map_array)];
        resources.extend(buffers.iter().map(|b| b.as_entire_binding()));
        bind_group(device, "triangle map build", layout, &resources)
    }
}

/// Reads: the backed-page list, the chart grids, the scene's chart UVs.
/// Writes: the triangle maps of the pages backed this frame (with
/// [`PagingChain::Fused`], what `mark::mark_backed_pages` writes too).
/// With shared maps, first forgets the keys of those pages, and after the
/// build copies the maps of the pages that found a source (reads and
/// writes the table and the keys; writes the backed pages' sources).
pub fn build_triangle_maps(cp: &mut TimedComputePass, pass: &mut TrimapPass, res: &Resources, scene: &wgpu::BindGroup) {
    if let Some(stored) = pass.stored.as_mut().filter(|s| !s.built) {
        // The stored maps, once, before the first page copies from them.
        let mut cp = stage(cp, "stored triangle maps");
        cp.set_pipeline(&stored.pipeline);
        res.bind(&mut cp, scene);
        cp.set_bind_group(2, &pass.group, &[]);
        let x = stored.blocks.clamp(1, 65535);
        cp.dispatch_workgroups(x, stored.blocks.div_ceil(x), 1);
        stored.built = true;
    }
    let mut record = |name, pipeline| {
        let mut cp = stage(cp, name);
        cp.set_pipeline(pipeline);
        res.bind(&mut cp, scene);
        cp.set_bind_group(2, &pass.group, &[]);
        cp.dispatch_workgroups_indirect(&res.dispatch, BACKED_ARGS);
    };
    if let Some(sharing) = &pass.sharing {
        record("triangle map keys", &sharing.forget);
    }
    record("triangle maps", &pass.pipeline);
    if let Some(sharing) = &pass.sharing {
        record("triangle map copies", &sharing.copy);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, Object};
    use glam::Mat4;

    /// Mesh 0 has two instances in the atlas (textures of 64 and 32), mesh
    /// 1 one (and one not in the atlas), mesh 2 two of 16: meshes 0 and 2
    /// share, numbering every page of each size up to their largest, one
    /// mesh after the other.
    #[test]
    fn meshes_with_two_instances_number_their_maps_one_after_the_other() {
        // Pages of 8: sizes 1 to 8 a page each, 16 four, 32 sixteen, 64 sixty-four.
        assert_eq!([1, 8, 16, 32, 64, 128].map(|s| keys_below(s, 8)), [0, 3, 4, 8, 24, 88]);
        let object =
            |mesh| Object { name: String::new(), mesh, material: 0, transform: Mat4::IDENTITY, forward_only: false };
        let scene = Scene {
            meshes: vec![Mesh::default(), Mesh::default(), Mesh::default()],
            objects: [0, 1, 0, 1, 2, 2].map(object).to_vec(),
            ..Default::default()
        };
        let sizes = [Some(64), Some(32), Some(32), None, Some(16), Some(16)];
        let layout = AtlasLayout::unplaced(&sizes, 8, 8, 1024, &[8]).unwrap();
        assert_eq!(mesh_key_bases(&scene, &layout), [0, NO_SHARE, 88]);
    }
}
