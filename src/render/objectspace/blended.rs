//! Alpha-blended objects in object space: shaded into the atlas like the
//! opaque ones and blended at gather time. They are not in the visibility
//! buffer, so two raster passes over them, back to front, depth-tested
//! against the opaque depth and writing none, stand in for the compute
//! passes that read it: *blended mark*, after marking, whose fragments mark
//! the tiles of their footprints as marking marks a pixel's (so they are
//! paged and shaded with the others), and *blended*, after the gather, whose
//! fragments gather their shade from the atlas as the gather would and
//! composite it over the frame times their opacity ([`passes::blended`]:
//! under MSAA per sample into a layer, resolved and composited). Each
//! fragment rebuilds its surface from its triangle's ids, as a pixel of the
//! visibility buffer is rebuilt, so marking and gathering agree.
//!
//! With compute visibility (which writes no depth target) the opaque depth
//! is laid down first. Extra views (`--views`) do not show blended objects.

use super::gather::SHADER as GATHER_SHADER;
use super::mark::SHADER as MARK_SHADER;
use super::resources::Resources;
use crate::render::frame::Frame;
use crate::render::passes::blended::{BlendedPass, OVER, back_to_front, blended_pass};
use crate::render::passes::depth_prepass::{DepthPrepass, depth_prepass};
use crate::render::passes::light_grid::{LightGrid, READ_GROUP};
use crate::render::passes::{self, DepthMode, SceneRaster, depth_attachment_read_only};
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary};

/// Object space's passes over its blended objects.
pub struct BlendedObjects {
    mark: wgpu::RenderPipeline,
    gather: BlendedPass,
    /// The atlas and its triangle maps, as the gather reads them (group 2).
    io_layout: wgpu::BindGroupLayout,
    io: wgpu::BindGroup,
    /// With compute visibility: the opaque objects' depth, laid down first.
    depth: Option<DepthPrepass>,
}

impl BlendedObjects {
    /// The passes, or `None` when the scene has no blended objects.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        res: &Resources,
        targets: &Targets,
        grid: &LightGrid,
        lay_depth: bool,
    ) -> Result<Option<Self>, ShaderError> {
        if !scene.has_blended() {
            return Ok(None);
        }
        let texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2Array,
                multisampled: false,
            },
            count: None,
        };
        // The gather's group 2 without its storage output (binding 1): the
        // fragments return their shade.
        let io_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("blended gather io"),
            entries: &[
                texture(0, wgpu::TextureSampleType::Float { filterable: false }),
                texture(2, wgpu::TextureSampleType::Uint),
            ],
        });
        let io = io_group(device, &io_layout, res);
        let samples = targets.samples;
        let mark_groups = [Some(&res.layout)];
        let mark = SceneRaster {
            // Per pixel: a fragment stage has no workgroup to deduplicate in
            // (the workgroup table is not even declared in this variant).
            shader: MARK_SHADER.with_defs(&[super::mark::PER_PIXEL]),
            vertex_entry: "vs_blended",
            fragment: Some(("fs_mark_blended", &[])),
            depth: DepthMode::TestOnly,
            groups: &mark_groups,
            blend: None,
            samples,
        };
        let mark = passes::raster_pipeline(device, shaders, scene, &mark, false)?;
        let mut gather_groups = vec![Some(&res.layout), Some(&io_layout)];
        gather_groups.resize(READ_GROUP as usize - 1, None);
        gather_groups.push(Some(&grid.layout));
        let gather = SceneRaster {
            shader: GATHER_SHADER,
            vertex_entry: "vs_blended",
            fragment: Some(("fs_gather_blended", &[HDR_FORMAT])),
            depth: DepthMode::TestOnly,
            groups: &gather_groups,
            blend: Some(OVER),
            samples,
        };
        let gather = passes::raster_pipeline(device, shaders, scene, &gather, false)?;
        let gather = BlendedPass::with_pipeline(device, shaders, targets, gather, false)?;
        let depth = lay_depth.then(|| DepthPrepass::new(device, shaders, scene, targets.samples)).transpose()?;
        Ok(Some(Self { mark, gather, io_layout, io, depth }))
    }

    /// Binds the atlas again after a resize.
    pub fn rebind(&mut self, device: &wgpu::Device, res: &Resources) {
        self.io = io_group(device, &self.io_layout, res);
    }
}

fn io_group(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, res: &Resources) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("blended gather io"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&res.physical.atlas_array),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(&res.physical.triangle_map_array),
            },
        ],
    })
}

/// Reads: the opaque depth (laid down first with compute visibility), the
/// atlas table and page table. Writes: the tile stamps, queue, page
/// requests and counters of the tiles the visible blended objects'
/// fragments need, as marking writes those of pixels.
pub fn mark_blended(frame: &mut Frame, pass: &BlendedObjects, res: &Resources) {
    let order = back_to_front(frame.scene, frame.camera, frame.view.view_proj);
    if order.is_empty() {
        return;
    }
    if let Some(depth) = &pass.depth {
        depth_prepass(frame, depth);
    }
    let (scene, targets, scene_group) = (frame.scene, frame.targets, frame.scene_group);
    let mut rp = frame.render_pass("blended mark", &[], Some(depth_attachment_read_only(targets)));
    rp.set_pipeline(&pass.mark);
    rp.set_bind_group(0, scene_group, &[]);
    rp.set_bind_group(1, &res.view_groups[0], &[]);
    passes::blended::draw_in_order(&mut rp, scene, &order, false);
}

/// Reads: the atlas (shaded this frame), its tables, the world grid (for
/// pixels shaded forward) and the opaque depth. Writes: the visible blended
/// objects' shades composited over `targets.hdr`, back to front.
pub fn gather_blended(frame: &mut Frame, pass: &BlendedObjects, res: &Resources, grid: &LightGrid) {
    let groups = [(1, &res.view_groups[0]), (2, &pass.io), (READ_GROUP, grid.bind_group())];
    blended_pass(frame, &pass.gather, &groups);
}
