//! Resizing the atlas (`resize.wgsl`): the pages both sizes have are copied
//! into the new atlas in compute, and before a shrink the pages beyond its
//! new size that back a virtual page move below it, onto free or least
//! recently used pages, with their shades, triangle maps and tile stamps, so
//! that a shrink costs no re-shading of what the frames still see (until
//! this existed, those pages were evicted and their tiles shaded again).
//! Movers that find no page (more of them than pages below the new size, or
//! only younger pages there) are evicted.

use super::{PagingPass, rank_candidates};
use crate::render::frame::Frame;
use crate::render::objectspace::TileCounter;
use crate::render::objectspace::resources::{ATLAS_FORMAT, PhysicalPages, Resources, TRIANGLE_MAP_FORMAT};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("resize.wgsl", include_str!("resize.wgsl"));

pub struct ResizePass {
    count_movers: wgpu::ComputePipeline,
    mover_offsets: wgpu::ComputePipeline,
    list_movers: wgpu::ComputePipeline,
    move_pages: wgpu::ComputePipeline,
    evict_rest: wgpu::ComputePipeline,
    copy_kept: wgpu::ComputePipeline,
    copy_moved: wgpu::ComputePipeline,
    moves_layout: wgpu::BindGroupLayout,
    textures_layout: wgpu::BindGroupLayout,
}

impl ResizePass {
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
            "atlas resize textures",
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
            copy_kept: compute_pipeline(device, shaders, SHADER, "copy_kept", &copying)?,
            copy_moved: compute_pipeline(device, shaders, SHADER, "copy_moved", &copying)?,
            moves_layout,
            textures_layout,
        })
    }
}

/// The moves of one resize, from [`compact_pages`] to [`copy_pages`] (a
/// buffer of the frame that resizes the atlas: resizes are rare).
pub struct Moves {
    group: wgpu::BindGroup,
    /// Pages beyond the new size: the most there can be.
    capacity: u32,
}

impl Moves {
    /// Room for `capacity` moves, none listed yet.
    fn new(device: &wgpu::Device, pass: &ResizePass, capacity: u32) -> Self {
        // The count and the age buckets' counts (zeroed on creation), then a
        // pair per page beyond.
        let header = (4 + 4 * TileCounter::AGE_BUCKETS as u64).next_multiple_of(8);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("atlas moves"),
            size: header + 8 * capacity.max(1) as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let group = bind_group(device, "atlas moves", &pass.moves_layout, &[buffer.as_entire_binding()]);
        Self { group, capacity }
    }
}

/// Before the atlas shrinks to `pages` pages: moves the pages beyond them
/// that back a virtual page onto pages below, and evicts those that find
/// none. Reads the frame's params (which name the new size); writes the page
/// owners, use stamps, page table and tile stamps, and the counters (cleared
/// first; the frame clears them again). `res` is still the larger atlas.
pub fn compact_pages(frame: &mut Frame, pass: &ResizePass, paging: &PagingPass, res: &Resources, pages: u32) -> Moves {
    let capacity = res.pool.pages.saturating_sub(pages);
    let moves = Moves::new(frame.device, pass, capacity);
    frame.encoder.clear_buffer(&res.counters, 0, None);
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("atlas compaction");
    res.bind(&mut cp, scene);
    rank_candidates(&mut cp, paging, res);
    cp.set_bind_group(2, &moves.group, &[]);
    cp.set_pipeline(&pass.count_movers);
    cp.dispatch_workgroups(capacity.div_ceil(64), 1, 1);
    cp.set_pipeline(&pass.mover_offsets);
    cp.dispatch_workgroups(1, 1, 1);
    for pipeline in [&pass.list_movers, &pass.move_pages, &pass.evict_rest] {
        cp.set_pipeline(pipeline);
        cp.dispatch_workgroups(capacity.div_ceil(64), 1, 1);
    }
    drop(cp);
    moves
}

/// Once the new atlas exists (`res`): copies the pages both sizes have (the
/// old atlas had `old_pages`), and the pages `moves` moved (after a
/// shrink), from the old atlas's textures (`old`) into the new ones.
pub fn copy_pages(
    frame: &mut Frame,
    pass: &ResizePass,
    res: &Resources,
    old: &PhysicalPages,
    old_pages: u32,
    moves: Option<&Moves>,
) {
    let textures = bind_group(
        frame.device,
        "atlas resize textures",
        &pass.textures_layout,
        &[
            wgpu::BindingResource::TextureView(&old.atlas_array),
            wgpu::BindingResource::TextureView(&old.triangle_map_array),
            wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
        ],
    );
    let none;
    let moves = match moves {
        Some(moves) => moves,
        None => {
            none = Moves::new(frame.device, pass, 0);
            &none
        }
    };
    let kept = res.pool.pages.min(old_pages);
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("atlas page copy");
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &moves.group, &[]);
    cp.set_bind_group(3, &textures, &[]);
    // A workgroup per page, looping past the dimension's limit.
    cp.set_pipeline(&pass.copy_kept);
    cp.dispatch_workgroups(kept.clamp(1, 65_535), 1, 1);
    if moves.capacity > 0 {
        cp.set_pipeline(&pass.copy_moved);
        cp.dispatch_workgroups(moves.capacity.min(65_535), 1, 1);
    }
}
