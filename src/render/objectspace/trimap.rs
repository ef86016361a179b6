//! Triangle-index maps: per object and mip level, the triangle covering each
//! texel of its square in the atlas, built once on the GPU by rasterizing the
//! charts in UV space, then dilated so that bilinear taps just outside a chart
//! still find a triangle.
//!
//! With conservative rasterization (where the adapter has it) every texel a
//! triangle touches is covered, and one ring of dilation covers the taps
//! beyond. Without it (lavapipe), texels are covered by their centres and two
//! rings of dilation stand in for the conservative coverage.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::atlas::AtlasLayout;
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{self, ShaderError, ShaderLibrary};

pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Square {
    origin: [u32; 2],
    size: u32,
    page: u32,
}

/// Builds the maps; returns the texture (one layer per atlas page) and the
/// number of dilation rings applied.
pub fn build(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    layout: &AtlasLayout,
) -> Result<(wgpu::Texture, u32), ShaderError> {
    let conservative = device.features().contains(wgpu::Features::CONSERVATIVE_RASTERIZATION);
    let rings = if conservative { 1 } else { 2 };
    let make = |label| {
        layout.page_array_texture(
            device,
            label,
            FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING,
        )
    };
    let maps = [make("triangle map"), make("triangle map (dilation)")];

    // 1. Rasterize every object's levels into their squares.
    let module = shaders.module(device, shaders::TRIMAP)?;
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("triangle map"),
        bind_group_layouts: &[Some(&scene.layout)],
        immediate_size: 0,
    });
    let raster = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("triangle map"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(FORMAT.into())],
        }),
        primitive: wgpu::PrimitiveState { cull_mode: None, conservative, ..Default::default() },
        depth_stencil: None,
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("triangle maps") });
    for page in 0..layout.pages {
        let view = maps[0].create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            base_array_layer: page,
            array_layer_count: Some(1),
            ..Default::default()
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("triangle map"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        pass.set_pipeline(&raster);
        pass.set_bind_group(0, scene.bind_group(), &[]);
        pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        for (object, atlas) in layout.objects.iter().enumerate() {
            let Some(atlas) = atlas else { continue };
            let d = scene.draws[object];
            for l in atlas.levels.iter().filter(|l| l.page == page) {
                pass.set_viewport(l.x as f32, l.y as f32, l.size as f32, l.size as f32, 0.0, 1.0);
                pass.set_scissor_rect(l.x, l.y, l.size, l.size);
                pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, 0..1);
            }
        }
    }

    // 2. Dilate inside each square, ping-ponging between the two textures.
    let squares: Vec<Square> = layout
        .objects
        .iter()
        .flatten()
        .flat_map(|o| o.levels.iter().map(|l| Square { origin: [l.x, l.y], size: l.size, page: l.page }))
        .collect();
    let stride = device.limits().min_uniform_buffer_offset_alignment.max(16) as usize;
    let mut bytes = vec![0u8; squares.len().max(1) * stride];
    for (i, s) in squares.iter().enumerate() {
        bytes[i * stride..i * stride + 16].copy_from_slice(bytemuck::bytes_of(s));
    }
    let uniforms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("dilation squares"),
        contents: &bytes,
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let dilate_module = shaders.module(device, shaders::DILATE)?;
    let bgl = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("dilate"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(16),
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Uint,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                },
                count: None,
            },
        ],
    });
    let dilate = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("dilate"),
        layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dilate"),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        })),
        module: &dilate_module,
        entry_point: Some("dilate"),
        compilation_options: Default::default(),
        cache: None,
    });
    let array_view = |t: &wgpu::Texture| {
        t.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    };
    for ring in 0..rings {
        let (source, target) = (&maps[(ring % 2) as usize], &maps[((ring + 1) % 2) as usize]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("dilate"),
            layout: &bgl,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &uniforms,
                        offset: 0,
                        size: wgpu::BufferSize::new(16),
                    }),
                },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&array_view(source)) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&array_view(target)) },
            ],
        });
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dilate"), timestamp_writes: None });
        pass.set_pipeline(&dilate);
        for (i, s) in squares.iter().enumerate() {
            pass.set_bind_group(0, &bind_group, &[(i * stride) as u32]);
            pass.dispatch_workgroups(s.size.div_ceil(8), s.size.div_ceil(8), 1);
        }
    }
    queue.submit([encoder.finish()]);
    let [a, b] = maps;
    Ok((if rings % 2 == 0 { a } else { b }, rings))
}
