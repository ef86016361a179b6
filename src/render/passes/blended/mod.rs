//! Alpha-blended surfaces (glTF `BLEND`, [`crate::scene::Material::blend`]),
//! drawn after a pipeline's opaque frame: object by object, back to front,
//! each fragment returning its radiance times its opacity and its opacity
//! (premultiplied alpha), composited [`OVER`] what is behind it in linear
//! HDR, depth-tested against the opaque surfaces and writing no depth.
//!
//! The renderer leaves blended objects out of the frame's visible objects
//! (`Frame::visible`), so no opaque pass (depth pre-pass, G-buffer,
//! visibility, light passes) draws them; they still cast shadows as
//! opaque casters.
//!
//! Under MSAA: the forward pipelines blend per sample, into the
//! multisampled colour their opaque pass leaves stored, and resolve at the
//! end of the blended pass. The pipelines whose opaque frame has one sample
//! (deferred, deferred-compute, object space) resolve first: the blended
//! surfaces go into a multisampled layer cleared to transparent (per sample
//! "over", depth-tested per sample), which is resolved and composited over
//! the resolved frame (`composite.wgsl`). That is exact wherever the opaque
//! frame or the layer is uniform within the pixel, and averages the two
//! apart at pixels where both have an edge.

use glam::Mat4;

use super::depth_prepass::{DepthPrepass, depth_prepass};
use super::{Binding, DepthMode, SceneRaster, bind_group, bind_group_layout_for, depth_attachment_read_only};
use crate::render::culling::Frustum;
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{HDR_FORMAT, Targets};
use crate::scene::{Aabb, Camera};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const COMPOSITE_SHADER: ShaderSource = ShaderSource::new("composite.wgsl", include_str!("composite.wgsl"));

/// Premultiplied "over": `src + (1 - src.a) * dst`, colour and alpha.
pub const OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// The blended objects inside the view frustum of `view_proj`, back to
/// front: per object, by the view depth of its bounds' centre along the
/// camera's forward axis, the usual engine choice (it sorts separate
/// objects, not the triangles of one object nor objects that cross).
/// Equal depths keep object order.
pub fn back_to_front(scene: &SceneGpu, camera: &Camera, view_proj: Mat4) -> Vec<u32> {
    sort_boxes(camera, view_proj, &scene.object_bounds, &scene.blended)
}

/// [`back_to_front`] of the objects `i` with `blended[i]` and world bounds `bounds[i]`.
fn sort_boxes(camera: &Camera, view_proj: Mat4, bounds: &[Aabb], blended: &[bool]) -> Vec<u32> {
    let frustum = Frustum::from_view_projection(view_proj);
    let mut order: Vec<(f32, u32)> = (0..blended.len())
        .filter(|&o| blended[o] && frustum.intersects_aabb(&bounds[o]))
        .map(|o| ((bounds[o].center() - camera.position).dot(camera.forward), o as u32))
        .collect();
    order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    order.into_iter().map(|(_, o)| o).collect()
}

/// Under MSAA with a one-sample opaque frame: the multisampled layer the
/// blended surfaces are drawn into, its resolve, and the composite.
struct Layer {
    msaa: wgpu::TextureView,
    resolved: wgpu::TextureView,
    composite: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
}

/// A pipeline's pass over its blended objects.
pub struct BlendedPass {
    pipeline: wgpu::RenderPipeline,
    /// For opaque frames that leave the depth target unwritten (compute
    /// visibility): the depth pre-pass of the opaque objects.
    depth: Option<DepthPrepass>,
    layer: Option<Layer>,
    /// Draw through the index buffer (else vertex `k` of an object's draw
    /// is its `k`-th index, which the shader looks up itself).
    indexed: bool,
}

impl BlendedPass {
    /// The pass drawing the blended objects with `shader`'s `vs_main` and
    /// `fs_blend` (over bind groups 1, 2, ... `groups`), or `None` when the
    /// scene has none. `lay_depth`: the opaque frame does not write the
    /// depth target, so the pass lays it down first.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        shader: ShaderSource,
        groups: &[Option<&wgpu::BindGroupLayout>],
        lay_depth: bool,
    ) -> Result<Option<Self>, ShaderError> {
        if !scene.has_blended() {
            return Ok(None);
        }
        let pipeline = blended_pipeline(device, shaders, scene, targets, shader, groups, OVER)?;
        let depth = lay_depth.then(|| DepthPrepass::new(device, shaders, scene, targets.samples)).transpose()?;
        let mut pass = Self::with_pipeline(device, shaders, targets, pipeline, true)?;
        pass.depth = depth;
        Ok(Some(pass))
    }

    /// The pass drawing the blended objects with `pipeline` (its blend
    /// [`OVER`], its depth [`DepthMode::TestOnly`]), through the index
    /// buffer or not (`indexed`), over a depth target the opaque frame wrote.
    pub fn with_pipeline(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        targets: &Targets,
        pipeline: wgpu::RenderPipeline,
        indexed: bool,
    ) -> Result<Self, ShaderError> {
        let layer = (targets.samples > 1 && targets.hdr_msaa_view.is_none())
            .then(|| Layer::new(device, shaders, targets))
            .transpose()?;
        Ok(Self { pipeline, depth: None, layer, indexed })
    }
}

/// A raster pipeline over `shader`'s `vs_main` and `fs_blend` with `blend`,
/// testing the opaque depth and writing none, at the targets' samples.
pub fn blended_pipeline(
    device: &wgpu::Device,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    targets: &Targets,
    shader: ShaderSource,
    groups: &[Option<&wgpu::BindGroupLayout>],
    blend: wgpu::BlendState,
) -> Result<wgpu::RenderPipeline, ShaderError> {
    let raster = SceneRaster {
        shader,
        vertex_entry: "vs_main",
        fragment: Some(("fs_blend", &[HDR_FORMAT])),
        depth: DepthMode::TestOnly,
        groups,
        blend: Some(blend),
        samples: targets.samples,
    };
    super::raster_pipeline(device, shaders, scene, &raster, false)
}

impl Layer {
    fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, targets: &Targets) -> Result<Self, ShaderError> {
        use wgpu::TextureUsages as U;
        let texture = |label, samples, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: targets.width, height: targets.height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format: HDR_FORMAT,
                usage,
                view_formats: &[],
            })
        };
        let msaa =
            texture("blended layer msaa", targets.samples, U::RENDER_ATTACHMENT).create_view(&Default::default());
        let resolved =
            texture("blended layer", 1, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING).create_view(&Default::default());
        let sample = wgpu::TextureSampleType::Float { filterable: false };
        let dimension = wgpu::TextureViewDimension::D2;
        let layout = bind_group_layout_for(
            device,
            "blended layer",
            wgpu::ShaderStages::FRAGMENT,
            &[Binding::Texture { sample, dimension }],
        );
        let group = bind_group(device, "blended layer", &layout, &[wgpu::BindingResource::TextureView(&resolved)]);
        let module = shaders.module(device, COMPOSITE_SHADER)?;
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("blended composite"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let composite = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("blended composite"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_full"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_composite"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: Some(OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            multiview_mask: None,
            cache: None,
        });
        Ok(Self { msaa, resolved, composite, group })
    }
}

/// The colour attachment the blended surfaces are drawn into over the
/// opaque frame of a pipeline without a layer: the multisampled colour the
/// opaque pass stored (loaded, resolved into `targets.hdr` at the end), or
/// at one sample `targets.hdr` itself.
pub fn over_frame_attachment(targets: &Targets) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    let load = wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store };
    Some(match &targets.hdr_msaa_view {
        None => wgpu::RenderPassColorAttachment {
            view: &targets.hdr_view,
            depth_slice: None,
            resolve_target: None,
            ops: load,
        },
        Some(msaa) => wgpu::RenderPassColorAttachment {
            view: msaa,
            depth_slice: None,
            resolve_target: Some(&targets.hdr_view),
            ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Discard },
        },
    })
}

/// One draw per object of `order`, with the bound pipeline (the instance
/// index is the object, as [`super::draw_objects`] draws), through the
/// index buffer or, unless `indexed`, one vertex per index.
pub fn draw_in_order(pass: &mut wgpu::RenderPass, scene: &SceneGpu, order: &[u32], indexed: bool) {
    for &o in order {
        let d = scene.draws[o as usize];
        if indexed {
            pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, o..o + 1);
        } else {
            pass.draw(0..d.index_count, o..o + 1);
        }
    }
}

/// Reads: the opaque frame (`targets.hdr`, or the multisampled colour the
/// opaque pass stored), its depth (laid down first when the pass was built
/// to), the scene and `groups` (each bound at its index). Writes: the
/// visible blended objects composited over the frame, back to front
/// ([`back_to_front`]), into `targets.hdr`.
pub fn blended_pass(frame: &mut Frame, pass: &BlendedPass, groups: &[(u32, &wgpu::BindGroup)]) {
    let order = back_to_front(frame.scene, frame.camera, frame.view.view_proj);
    // The forward pipelines' multisampled colour is resolved here even
    // with nothing to blend.
    if order.is_empty() && frame.targets.hdr_msaa_view.is_none() {
        return;
    }
    if let Some(depth) = &pass.depth {
        depth_prepass(frame, depth);
    }
    let (scene, targets, scene_group) = (frame.scene, frame.targets, frame.scene_group);
    let color = [match &pass.layer {
        Some(layer) => Some(wgpu::RenderPassColorAttachment {
            view: &layer.msaa,
            depth_slice: None,
            resolve_target: Some(&layer.resolved),
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: wgpu::StoreOp::Discard,
            },
        }),
        None => over_frame_attachment(targets),
    }];
    {
        let mut rp = frame.render_pass("blended", &color, Some(depth_attachment_read_only(targets)));
        rp.set_pipeline(&pass.pipeline);
        rp.set_bind_group(0, scene_group, &[]);
        for &(index, group) in groups {
            rp.set_bind_group(index, group, &[]);
        }
        rp.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        draw_in_order(&mut rp, scene, &order, pass.indexed);
    }
    if let Some(layer) = &pass.layer {
        let load = wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store };
        let color = [Some(wgpu::RenderPassColorAttachment {
            view: &targets.hdr_view,
            depth_slice: None,
            resolve_target: None,
            ops: load,
        })];
        let mut rp = frame.render_pass("blended composite", &color, None);
        rp.set_pipeline(&layer.composite);
        rp.set_bind_group(0, &layer.group, &[]);
        rp.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Three boxes along the view axis, listed nearest first, come back
    /// farthest first; one behind the camera is left out.
    #[test]
    fn blended_objects_sort_back_to_front() {
        let camera = Camera {
            position: Vec3::new(0.0, 0.0, 4.0),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 20.0,
        };
        let boxes = [0.6, 0.2, -0.2, 6.0].map(|z| Aabb { min: Vec3::new(-0.5, -0.5, z), max: Vec3::new(0.5, 0.5, z) });
        let vp = camera.view_projection(1.0);
        assert_eq!(sort_boxes(&camera, vp, &boxes, &[true; 4]), [2, 1, 0]);
        assert_eq!(sort_boxes(&camera, vp, &boxes, &[true, false, true, false]), [2, 0]);
    }
}
