//! Paging (`paging.wgsl`): after marking, the virtual pages this frame's
//! tiles need that have no physical page get one, on the GPU, least
//! recently used first (free pages, then by age bucket), with no CPU round
//! trip, and the two-level page table follows (a chunk of table words for
//! each block of pages with backed pages, freed with its last page). The pages backed this frame are then built (`trimap`) and their
//! requested tiles marked (`mark::mark_backed`). When the atlas is resized,
//! [`resize`] copies its pages, and before it shrinks moves the pages beyond
//! its new size below it.

pub mod resize;

use wgpu::util::DeviceExt;

use super::PagingChain;
use super::resources::{ALLOCATE_ARGS, Resources};
use crate::render::frame::{Frame, TimedComputePass, stage};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline, compute_pipeline_with};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("paging.wgsl", include_str!("paging.wgsl"));
/// Frees the pages of slots given back (`slots`).
pub const RELEASE_SHADER: ShaderSource = ShaderSource::new("release.wgsl", include_str!("release.wgsl"));
/// Defined for [`PagingChain::Fused`]: the paging arguments (`rank_pages`
/// writes them) include the backed pages' and the shade pass's dispatch
/// (bounds).
pub const FUSED: &str = "FUSED_PAGING";
/// Defined for every paging pipeline: they write the page directory, with
/// atomics; the other passes read it with plain loads (`objectspace.wgsl`).
pub const DIRECTORY_ATOMIC: &str = "DIRECTORY_ATOMIC";
/// The variants besides [`SHADER`], for the test that validates every shader.
pub const VARIANTS: [ShaderSource; 2] =
    [SHADER.with_defs(&[FUSED, DIRECTORY_ATOMIC]), SHADER.with_defs(&[DIRECTORY_ATOMIC])];

pub struct PagingPass {
    age_pages: wgpu::ComputePipeline,
    page_offsets: wgpu::ComputePipeline,
    list_candidates: wgpu::ComputePipeline,
    rank_pages: wgpu::ComputePipeline,
    allocate: wgpu::ComputePipeline,
    bind_pages: wgpu::ComputePipeline,
    backed_args: wgpu::ComputePipeline,
    release_slots: wgpu::ComputePipeline,
    /// Group 2 of `release_slots`: the released ranges.
    release_layout: wgpu::BindGroupLayout,
    chain: PagingChain,
}

impl PagingPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        chain: PagingChain,
    ) -> Result<Self, ShaderError> {
        let plain = [&scene.layout, &res.layout];
        let with_dispatch = [&scene.layout, &res.layout, &res.dispatch_layout];
        let release_layout = bind_group_layout(device, "released slots", &[Binding::Storage { read_only: true }]);
        let with_ranges = [&scene.layout, &res.layout, &release_layout];
        let rank_defs: &[&str] =
            if chain == PagingChain::Fused { &[FUSED, DIRECTORY_ATOMIC] } else { &[DIRECTORY_ATOMIC] };
        let atomic = &[DIRECTORY_ATOMIC][..];
        Ok(Self {
            chain,
            release_slots: compute_pipeline(device, shaders, RELEASE_SHADER, "release_slots", &with_ranges)?,
            release_layout,
            age_pages: compute_pipeline_with(device, shaders, SHADER, atomic, "age_pages", &plain)?,
            page_offsets: compute_pipeline_with(device, shaders, SHADER, atomic, "page_offsets", &plain)?,
            list_candidates: compute_pipeline_with(device, shaders, SHADER, atomic, "list_candidates", &plain)?,
            rank_pages: compute_pipeline_with(device, shaders, SHADER, rank_defs, "rank_pages", &with_dispatch)?,
            allocate: compute_pipeline_with(device, shaders, SHADER, atomic, "allocate", &plain)?,
            bind_pages: compute_pipeline_with(device, shaders, SHADER, atomic, "bind_pages", &plain)?,
            backed_args: compute_pipeline_with(device, shaders, SHADER, atomic, "backed_args", &with_dispatch)?,
        })
    }
}

/// Reads: the page requests, page use and owners. Writes: the page
/// directory and table chunks, page owners and use, the backed-page list,
/// the counters, the dispatches of allocation and of the backed pages' passes
/// (with [`PagingChain::Fused`], a bound, and a bound on the shade pass's).
pub fn back_pages(cp: &mut TimedComputePass, pass: &PagingPass, res: &Resources, scene: &wgpu::BindGroup) {
    let mut cp = stage(cp, "paging");
    res.bind(&mut cp, scene);
    // One dispatch ranks the pages when a page was requested (a list per
    // age bucket), releases the chunks left with no page (a workgroup per
    // 64 of each) and writes the allocation's dispatch.
    cp.set_bind_group(2, &res.dispatch_group, &[]);
    cp.set_pipeline(&pass.rank_pages);
    cp.dispatch_workgroups(res.pool.pages.max(res.chunk_count()).div_ceil(64), 1, 1);
    // Group 2 (the dispatch arguments as storage) stays bound, but the
    // allocation's pipelines do not use it: a dispatch that reads the
    // arguments as INDIRECT may follow in the same pass.
    cp.set_pipeline(&pass.allocate);
    cp.dispatch_workgroups_indirect(&res.dispatch, ALLOCATE_ARGS);
    cp.set_pipeline(&pass.bind_pages);
    cp.dispatch_workgroups_indirect(&res.dispatch, ALLOCATE_ARGS);
    if pass.chain == PagingChain::Split {
        cp.set_bind_group(2, &res.dispatch_group, &[]);
        cp.set_pipeline(&pass.backed_args);
        cp.dispatch_workgroups(1, 1, 1);
    }
    // (With the fused chain `rank_pages` wrote a bound on the backed pages' dispatch.)
}

/// Frees the physical pages backing the virtual pages of `ranges` (first,
/// end), the slots given back this frame: their table words are cleared and
/// their chunks freed by this frame's [`back_pages`].
pub fn release_slots(frame: &mut Frame, pass: &PagingPass, res: &Resources, ranges: &[[u32; 2]]) {
    let buffer = frame.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("released slots"),
        contents: bytemuck::cast_slice(ranges),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let group = bind_group(frame.device, "released slots", &pass.release_layout, &[buffer.as_entire_binding()]);
    let scene = frame.scene_group;
    let mut cp = frame.compute_pass("release slots");
    res.bind(&mut cp, scene);
    cp.set_bind_group(2, &group, &[]);
    cp.set_pipeline(&pass.release_slots);
    cp.dispatch_workgroups(res.pool.pages.div_ceil(64), 1, 1);
}

/// For a resize's moves: lists the physical pages below
/// `params.physical_pages` not used this frame as `candidates`, in one list,
/// free first, then least recently used (offsets in the counters' age
/// buckets, their count in `COUNT_CANDIDATES`), on a compute pass with `res`
/// bound as group 1.
pub(super) fn rank_candidates(cp: &mut wgpu::ComputePass, pass: &PagingPass, res: &Resources) {
    let pages = res.pool.pages.div_ceil(64);
    cp.set_pipeline(&pass.age_pages);
    cp.dispatch_workgroups(pages, 1, 1);
    cp.set_pipeline(&pass.page_offsets);
    cp.dispatch_workgroups(1, 1, 1);
    cp.set_pipeline(&pass.list_candidates);
    cp.dispatch_workgroups(pages, 1, 1);
}
