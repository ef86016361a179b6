//! Compacting the atlas before it shrinks (`compact.wgsl`): the pages beyond
//! its new size that back a virtual page move below it, onto free or least
//! recently used pages, with their shades, triangle maps and tile stamps, so
//! that a shrink costs no re-shading of what the frames still see (until
//! this existed, those pages were evicted and their tiles shaded again).
//! Movers that find no page (more of them than pages below the new size, or
//! only younger pages there) are evicted as before.

use super::{PagingPass, rank_candidates};
use crate::render::frame::Frame;
use crate::render::objectspace::TileCounter;
use crate::render::objectspace::resources::{ATLAS_FORMAT, PhysicalPages, Resources, TRIANGLE_MAP_FORMAT};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("compact.wgsl", include_str!("compact.wgsl"));

pub struct CompactPass {
    count_movers: wgpu::ComputePipeline,
    mover_offsets: wgpu::ComputePipeline,
    list_movers: wgpu::ComputePipeline,
    move_pages: wgpu::ComputePipeline,
    evict_rest: wgpu::ComputePipeline,
    copy_pages: wgpu::ComputePipeline,
    moves_layout: wgpu::BindGroupLayout,
    textures_layout: wgpu::BindGroupLayout,
}

impl CompactPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
    ) -> Result<Self, ShaderError> {
        let moves_layout = bind_group_layout(device, "atlas moves", &[Binding::Storage { read_only: false }]);
        let array = wgpu::TextureViewDimension::D2Array;
        let textures_layout = bind_group_layout(
            device,
            "atlas compaction textures",
            &[
                Binding::Texture { sample: wgpu::TextureSampleType::Float { filterable: true }, dimension: array },
                Binding::Texture { sample: wgpu::TextureSampleType::Uint, dimension: array },
                Binding::StorageTexture { format: ATLAS_FORMAT, dimension: array },
                Binding::StorageTexture { format: TRIANGLE_MAP_FORMAT, dimension: array },
            ],
        );
        let moving = [&scene.layout, &res.layout, &moves_layout];
        let copying = [&scene.layout, &res.layout, &moves_layout, &textures_layout];
        Ok(Self {
            count_movers: compute_pipeline(device, shaders, SHADER, "count_movers", &moving)?,
            mover_offsets: compute_pipeline(device, shaders, SHADER, "mover_offsets", &moving)?,
            list_movers: compute_pipeline(device, shaders, SHADER, "list_movers", &moving)?,
            move_pages: compute_pipeline(device, shaders, SHADER, "move_pages", &moving)?,
            evict_rest: compute_pipeline(device, shaders, SHADER, "evict_rest", &moving)?,
            copy_pages: compute_pipeline(device, shaders, SHADER, "copy_pages", &copying)?,
            moves_layout,
            textures_layout,
        })
    }
}

/// The moves of one shrink, from [`compact_pages`] to [`copy_moved_pages`]
/// (a buffer of the frame that shrinks the atlas: shrinks are rare).
pub struct Moves {
    group: wgpu::BindGroup,
    /// Pages beyond the new size: the most there can be.
    capacity: u32,
}

/// Before the atlas shrinks to `pages` pages: moves the pages beyond them
/// that back a virtual page onto pages below, and evicts those that find
/// none. Reads the frame's params (which name the new size); writes the page
/// owners, use stamps, page table and tile stamps, and the counters (cleared
/// first; the frame clears them again). `res` is still the larger atlas.
pub fn compact_pages(frame: &mut Frame, pass: &CompactPass, paging: &PagingPass, res: &Resources, pages: u32) -> Moves {
    let capacity = res.pool.pages.saturating_sub(pages);
    // The count and the age buckets' counts (zeroed on creation), then a
    // pair per page beyond.
    let header = (4 + 4 * TileCounter::AGE_BUCKETS as u64).next_multiple_of(8);
    let buffer = frame.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("atlas moves"),
        size: header + 8 * capacity.max(1) as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let group = bind_group(frame.device, "atlas moves", &pass.moves_layout, &[buffer.as_entire_binding()]);
    frame.encoder.clear_buffer(&res.counters, 0, None);
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("atlas compaction");
    res.bind(&mut cp, scene);
    rank_candidates(&mut cp, paging, res);
    cp.set_bind_group(2, &group, &[]);
    cp.set_pipeline(&pass.count_movers);
    cp.dispatch_workgroups(capacity.div_ceil(64), 1, 1);
    cp.set_pipeline(&pass.mover_offsets);
    cp.dispatch_workgroups(1, 1, 1);
    for pipeline in [&pass.list_movers, &pass.move_pages, &pass.evict_rest] {
        cp.set_pipeline(pipeline);
        cp.dispatch_workgroups(capacity.div_ceil(64), 1, 1);
    }
    Moves { group, capacity }
}

/// Once the smaller atlas exists (`res`): copies the moved pages' shades and
/// triangle maps from the larger one's textures (`old`).
pub fn copy_moved_pages(frame: &mut Frame, pass: &CompactPass, res: &Resources, old: &PhysicalPages, moves: &Moves) {
    let textures = bind_group(
        frame.device,
        "atlas compaction textures",
        &pass.textures_layout,
        &[
            wgpu::BindingResource::TextureView(&old.atlas_array),
            wgpu::BindingResource::TextureView(&old.triangle_map_array),
            wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
        ],
    );
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("atlas page copy");
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &moves.group, &[]);
    cp.set_bind_group(3, &textures, &[]);
    cp.set_pipeline(&pass.copy_pages);
    // A workgroup per move, looping past the dimension's limit.
    cp.dispatch_workgroups(moves.capacity.clamp(1, 65_535), 1, 1);
}
