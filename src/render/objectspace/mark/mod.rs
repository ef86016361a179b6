//! Tile marking and queueing (`mark.wgsl`): per pixel of the visibility
//! buffer, the mip level and the tiles of its bilinear footprint are marked
//! visible; a tile whose cached shade is too old or stale is queued, and a
//! tile whose page has no physical page yet is requested. After paging,
//! the tiles requested on the pages it backed are marked and queued (the
//! queue is kept per physical tile). `cpu.rs` is the CPU twin that tests check this pass against.
//! [`Marking`] picks whether each pixel or each workgroup's first pixel of
//! a tile marks it globally, and whether a subgroup elects one claimant per
//! tile before the workgroup's table.

use super::Marking;
use super::resources::{BACKED_ARGS, Resources};
use crate::render::frame::{TimedComputePass, stage};
use crate::render::passes::{Binding, bind_group, bind_group_layout, compute_pipeline, compute_pipeline_with};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("mark.wgsl", include_str!("mark.wgsl"));
/// The marking of the pages backed this frame (`shadespace::objectspace_mark_backed`),
/// which the mark-backed pass or, unless [`super::PagingChain::Split`], the
/// triangle-map pass runs.
pub const MARK_BACKED_WGSL: ShaderSource = ShaderSource::new("mark_backed.wgsl", include_str!("mark_backed.wgsl"));
/// Defined for [`Marking::PerPixel`].
pub const PER_PIXEL: &str = "MARK_PER_PIXEL";
/// Defined for [`Marking::Subgroup`].
pub const SUBGROUP: &str = "MARK_SUBGROUP";
/// Defined to count the global tile marks and atomics.
pub const COUNT_ATOMICS: &str = "COUNT_MARK_ATOMICS";
/// Defined for [`super::GatherInput::Record`] (in `gather.wgsl` too): marking
/// writes each pixel's chart UV and levels for the gather.
pub const PIXEL_RECORD: &str = "PIXEL_RECORD";
/// The variants besides [`SHADER`], for the test that validates every shader.
pub const VARIANTS: [ShaderSource; 6] = [
    SHADER.with_defs(&[PER_PIXEL]),
    SHADER.with_defs(&[COUNT_ATOMICS]),
    SHADER.with_defs(&[SUBGROUP]),
    SHADER.with_defs(&[SUBGROUP, COUNT_ATOMICS]),
    SHADER.with_defs(&[PER_PIXEL, COUNT_ATOMICS]),
    SHADER.with_defs(&[PIXEL_RECORD]),
];

pub struct MarkPass {
    mark: wgpu::ComputePipeline,
    /// With [`super::GatherInput::Record`]: the pixel records (group 2).
    records: Option<wgpu::BindGroup>,
    mark_backed: wgpu::ComputePipeline,
    shade_args: wgpu::ComputePipeline,
}

impl MarkPass {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        marking: Marking,
        count_atomics: bool,
        records: Option<&wgpu::Buffer>,
    ) -> Result<Self, ShaderError> {
        let plain = [&scene.layout, &res.layout];
        let with_dispatch = [&scene.layout, &res.layout, &res.dispatch_layout];
        let records_layout = bind_group_layout(device, "pixel records", &[Binding::Storage { read_only: false }]);
        let records = records.map(|b| bind_group(device, "pixel records", &records_layout, &[b.as_entire_binding()]));
        let mark_groups: &[&wgpu::BindGroupLayout] =
            if records.is_some() { &[&scene.layout, &res.layout, &records_layout] } else { &plain };
        let mut defs = Vec::new();
        match marking {
            Marking::PerPixel => defs.push(PER_PIXEL),
            Marking::Subgroup => defs.push(SUBGROUP),
            Marking::Workgroup => {}
        }
        if count_atomics {
            defs.push(COUNT_ATOMICS);
        }
        if records.is_some() {
            defs.push(PIXEL_RECORD);
        }
        Ok(Self {
            mark: compute_pipeline_with(device, shaders, SHADER, &defs, "mark", mark_groups)?,
            records,
            mark_backed: compute_pipeline(device, shaders, SHADER, "mark_backed", &plain)?,
            shade_args: compute_pipeline(device, shaders, SHADER, "shade_args", &with_dispatch)?,
        })
    }
}

/// Pixels along a side of the square each invocation of the mark pass
/// marks (`QUAD` in `mark.wgsl`): a 2x2 quad at one sample per pixel (its
/// pixels mostly share a triangle, whose vertices it then loads and
/// transforms once), one pixel under MSAA (its samples are the loop).
pub fn quad_side(samples: u32) -> u32 {
    if samples > 1 { 1 } else { 2 }
}

/// Workgroups of the mark pass (and of the gather, which takes the same
/// quads) over the frame's pixels.
pub fn pixel_groups(targets: &Targets, res: &Resources) -> [u32; 2] {
    let side = 8 * quad_side(res.visibility.samples());
    [targets.width.div_ceil(side), targets.height.div_ceil(side)]
}

/// Reads: the visibility buffer, the atlas table, the page table, the tile
/// stamps. Writes: the tile stamps, page use, page requests, the shade
/// queue, the counters (and the pixel records, when the gather reads them).
/// `view`: which view's visibility buffer (0: the main view), whose scene
/// group is `scene`; `groups`: [`pixel_groups`].
pub fn mark_tiles(
    cp: &mut TimedComputePass,
    pass: &MarkPass,
    res: &Resources,
    scene: &wgpu::BindGroup,
    view: usize,
    groups: [u32; 2],
) {
    let mut cp = stage(cp, if view == 0 { "mark" } else { "mark: other views" });
    cp.set_pipeline(&pass.mark);
    res.bind_view(&mut cp, scene, view);
    if let Some(records) = &pass.records {
        cp.set_bind_group(2, records, &[]);
    }
    cp.dispatch_workgroups(groups[0], groups[1], 1);
}

/// Reads: the backed-page list, the page requests. Writes: the tile stamps
/// of the backed pages, the shade queue, the counters.
pub fn mark_backed_pages(cp: &mut TimedComputePass, pass: &MarkPass, res: &Resources, scene: &wgpu::BindGroup) {
    let mut cp = stage(cp, "mark backed");
    cp.set_pipeline(&pass.mark_backed);
    res.bind(&mut cp, scene);
    cp.dispatch_workgroups_indirect(&res.dispatch, BACKED_ARGS);
}

/// Reads: the shade list's count. Writes: the shade pass's dispatch
/// (`shade_args`), with [`super::PagingChain::Split`]: the fused chain's
/// paging writes it.
pub fn write_shade_args(cp: &mut TimedComputePass, pass: &MarkPass, res: &Resources, scene: &wgpu::BindGroup) {
    let mut cp = stage(cp, "queue");
    res.bind(&mut cp, scene);
    cp.set_pipeline(&pass.shade_args);
    cp.set_bind_group(2, &res.dispatch_group, &[]);
    cp.dispatch_workgroups(1, 1, 1);
}
