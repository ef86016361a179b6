//! Triangle-index maps: per object and mip level, the triangle covering each
//! texel of its square in the atlas, built once on the GPU by rasterizing the
//! charts in UV space, then dilated so that bilinear taps just outside a chart
//! still find a triangle.
//!
//! Every texel a triangle touches is covered: by the hardware's conservative
//! rasterization where the adapter has it, else by emulating it (enlarged
//! triangles, `vs_conservative` in `trimap.wgsl`: lavapipe), so that thin
//! chart parts at coarse levels, narrower than a texel, still own their
//! texels on every adapter. One ring of dilation covers the taps beyond.

use wgpu::util::DeviceExt;

use super::atlas::AtlasLayout;
use crate::render::passes::{Binding, bind_group, bind_group_layout, bind_group_layout_for, compute_pipeline, view_as};
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("trimap.wgsl", include_str!("trimap.wgsl"));
pub const DILATE: ShaderSource = ShaderSource::new("dilate.wgsl", include_str!("dilate.wgsl"));

pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

gpu_struct! {
    /// One object's level for the emulated conservative raster
    /// (`TrimapDraw` in `trimap.wgsl`), drawn as one instance.
    pub struct GpuTrimapDraw as "TrimapDraw" {
        pub object: u32,
        pub size: u32,
        pub origin: [u32; 2],
    }
}

gpu_struct! {
    /// One level's square in the atlas (`Square` in `dilate.wgsl`).
    pub struct Square as "Square" {
        pub origin: [u32; 2],
        pub size: u32,
        pub page: u32,
    }
}

/// Builds the maps; returns the texture (one layer per atlas page).
pub fn build(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    shaders: &mut ShaderLibrary,
    scene: &SceneGpu,
    layout: &AtlasLayout,
) -> Result<wgpu::Texture, ShaderError> {
    let conservative = device.features().contains(wgpu::Features::CONSERVATIVE_RASTERIZATION);
    let make = |label| {
        layout.page_array_texture(
            device,
            label,
            FORMAT,
            // COPY_SRC: debug and test read-backs.
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        )
    };
    let (coverage, dilated) = (make("triangle map (coverage)"), make("triangle map"));

    // 1. Rasterize every object's levels into their squares.
    let module = shaders.module(device, SHADER)?;
    // The emulation's per-draw records (one per object level, in draw order).
    let draws: Vec<GpuTrimapDraw> = layout
        .objects
        .iter()
        .enumerate()
        .filter_map(|(object, atlas)| atlas.as_ref().map(|a| (object, a)))
        .flat_map(|(object, a)| {
            a.levels.iter().map(move |l| GpuTrimapDraw { object: object as u32, size: l.size, origin: [l.x, l.y] })
        })
        .collect();
    let draws_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("triangle map draws"),
        contents: bytemuck::cast_slice(if draws.is_empty() {
            &[GpuTrimapDraw { object: 0, size: 0, origin: [0; 2] }]
        } else {
            &draws[..]
        }),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let draws_layout = bind_group_layout_for(
        device,
        "triangle map draws",
        wgpu::ShaderStages::VERTEX,
        &[Binding::Storage { read_only: true }],
    );
    let draws_group = bind_group(device, "triangle map draws", &draws_layout, &[draws_buffer.as_entire_binding()]);
    let groups: &[Option<&wgpu::BindGroupLayout>] =
        if conservative { &[Some(&scene.layout)] } else { &[Some(&scene.layout), Some(&draws_layout)] };
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("triangle map"),
        bind_group_layouts: groups,
        immediate_size: 0,
    });
    let (vertex_entry, fragment_entry) =
        if conservative { ("vs_main", "fs_main") } else { ("vs_conservative", "fs_conservative") };
    let raster = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("triangle map"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some(vertex_entry),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some(fragment_entry),
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
        let view = coverage.create_view(&wgpu::TextureViewDescriptor {
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
        if !conservative {
            pass.set_bind_group(1, &draws_group, &[]);
        }
        pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
        let mut instance = 0u32;
        for (object, atlas) in layout.objects.iter().enumerate() {
            let Some(atlas) = atlas else { continue };
            let d = scene.draws[object];
            for l in &atlas.levels {
                let k = instance;
                instance += 1;
                if l.page != page {
                    continue;
                }
                pass.set_viewport(l.x as f32, l.y as f32, l.size as f32, l.size as f32, 0.0, 1.0);
                pass.set_scissor_rect(l.x, l.y, l.size, l.size);
                if conservative {
                    pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, 0..1);
                } else {
                    pass.draw(0..d.index_count, k..k + 1);
                }
            }
        }
    }

    // 2. Dilate inside each square by one ring, from the coverage into the map.
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
    let bgl = bind_group_layout(
        device,
        "dilate",
        &[
            Binding::DynamicUniform { size: 16 },
            Binding::Texture { sample: wgpu::TextureSampleType::Uint, dimension: wgpu::TextureViewDimension::D2Array },
            Binding::StorageTexture { format: FORMAT, dimension: wgpu::TextureViewDimension::D2Array },
        ],
    );
    let dilate = compute_pipeline(device, shaders, DILATE, "dilate", &[&bgl])?;
    let array_view = |t: &wgpu::Texture| view_as(t, wgpu::TextureViewDimension::D2Array);
    let square = wgpu::BufferBinding { buffer: &uniforms, offset: 0, size: wgpu::BufferSize::new(16) };
    let bind_group = bind_group(
        device,
        "dilate",
        &bgl,
        &[
            wgpu::BindingResource::Buffer(square),
            wgpu::BindingResource::TextureView(&array_view(&coverage)),
            wgpu::BindingResource::TextureView(&array_view(&dilated)),
        ],
    );
    {
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dilate"), timestamp_writes: None });
        pass.set_pipeline(&dilate);
        for (i, s) in squares.iter().enumerate() {
            pass.set_bind_group(0, &bind_group, &[(i * stride) as u32]);
            pass.dispatch_workgroups(s.size.div_ceil(8), s.size.div_ceil(8), 1);
        }
    }
    queue.submit([encoder.finish()]);
    Ok(dilated)
}
