//! Everything the object-space passes share, in one place: the shading atlas,
//! the triangle-index maps, the visibility buffer, the atlas table, the tile
//! stamps, the shade queue and its counters, and the bind group (group 1 of
//! every object-space pass, `objectspace.wgsl`) that exposes them.

use wgpu::util::DeviceExt;

use super::atlas::{AtlasLayout, GpuAtlasEntry};
use super::{ObjectSpaceConfig, TileCounter};
use crate::render::passes::visibility::VisibilityBuffer;
use crate::render::passes::{Binding, bind_group, bind_group_layout, view_as};
use crate::render::targets::Targets;
use crate::shaders::gpu_struct;

pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

gpu_struct! {
    /// Per-frame settings of the object-space passes (`Params` in `objectspace.wgsl`).
    pub struct GpuParams as "Params" {
        /// Frame + 1: 0 in the stamp buffers means "never".
        pub stamp: u32,
        pub reuse: u32,
        pub tile_size: u32,
        /// A [`super::DebugView`].
        pub view_mode: u32,
        pub mip_bias: f32,
        pub variable_rate: f32,
        /// Capacity of the shade queue (the atlas's tile count).
        pub max_queue: u32,
        pub pad: u32,
    }
}

pub struct Resources {
    pub atlas: wgpu::Texture,
    /// The atlas as a 2D array (one layer per page).
    pub atlas_array: wgpu::TextureView,
    pub visibility: VisibilityBuffer,
    pub params: wgpu::Buffer,
    pub entries: wgpu::Buffer,
    /// CPU copy of the atlas table (its `valid_since` changes with the lights).
    pub entry_data: Vec<GpuAtlasEntry>,
    /// Per tile: stamp of the last frame it was visible.
    pub tile_visible: wgpu::Buffer,
    /// Per tile: stamp of the last frame it was shaded.
    pub tile_shaded: wgpu::Buffer,
    /// This frame's tiles to shade: (tile, object << 8 | level).
    pub work_queue: wgpu::Buffer,
    /// Indexed by [`TileCounter`].
    pub counters: wgpu::Buffer,
    /// Indirect dispatch arguments of the shade pass.
    pub shade_dispatch: wgpu::Buffer,
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
}

impl Resources {
    pub fn new(
        device: &wgpu::Device,
        atlas_layout: &AtlasLayout,
        triangle_map: &wgpu::Texture,
        triangle_charts: &wgpu::Buffer,
        targets: &Targets,
    ) -> Self {
        let atlas = atlas_layout.page_array_texture(
            device,
            "shading atlas",
            ATLAS_FORMAT,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
        );
        let visibility = VisibilityBuffer::new(device, targets);
        let storage = |label, size: u64, extra| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | extra,
                mapped_at_creation: false,
            })
        };
        let tiles = atlas_layout.tile_count as u64;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("object-space params"),
            size: size_of::<GpuParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let entry_data = atlas_layout.gpu_entries();
        let entries = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("atlas entries"),
            contents: bytemuck::cast_slice(&entry_data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        // Zero-initialised: 0 = never visible / never shaded. COPY_SRC: tests read them back.
        let tile_visible = storage("tile visible", tiles * 4, wgpu::BufferUsages::COPY_SRC);
        let tile_shaded = storage("tile shaded", tiles * 4, wgpu::BufferUsages::COPY_SRC);
        let work_queue = storage("shade queue", tiles * 8, wgpu::BufferUsages::COPY_SRC);
        let counter_bytes = TileCounter::SLOTS as u64 * 4;
        let counters =
            storage("tile counters", counter_bytes, wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST);
        let shade_dispatch = storage("shade dispatch", 16, wgpu::BufferUsages::INDIRECT);

        let rw = Binding::Storage { read_only: false };
        let uint = wgpu::TextureSampleType::Uint;
        let layout = bind_group_layout(
            device,
            "object space",
            &[
                Binding::Uniform,
                Binding::Storage { read_only: true },
                rw,
                rw,
                rw,
                rw,
                Binding::Texture { sample: uint, dimension: wgpu::TextureViewDimension::D2 },
                Binding::Texture { sample: uint, dimension: wgpu::TextureViewDimension::D2Array },
                Binding::Storage { read_only: true },
            ],
        );
        let bind_group = bind_group(
            device,
            "object space",
            &layout,
            &[
                params.as_entire_binding(),
                entries.as_entire_binding(),
                tile_visible.as_entire_binding(),
                tile_shaded.as_entire_binding(),
                work_queue.as_entire_binding(),
                counters.as_entire_binding(),
                wgpu::BindingResource::TextureView(&visibility.view),
                wgpu::BindingResource::TextureView(&view_as(triangle_map, wgpu::TextureViewDimension::D2Array)),
                triangle_charts.as_entire_binding(),
            ],
        );
        Self {
            atlas_array: view_as(&atlas, wgpu::TextureViewDimension::D2Array),
            atlas,
            visibility,
            params,
            entries,
            entry_data,
            tile_visible,
            tile_shaded,
            work_queue,
            counters,
            shade_dispatch,
            layout,
            bind_group,
        }
    }

    /// Uploads this frame's settings (and, when the shades went stale, the
    /// atlas table with its new `valid_since`) and clears the counters.
    /// `mip_bias`: the configured bias plus what the shading budget adds.
    #[allow(clippy::too_many_arguments)]
    pub fn begin_frame(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        stamp: u32,
        stale: bool,
        config: &ObjectSpaceConfig,
        mip_bias: f32,
        max_queue: u32,
    ) {
        if stale {
            for e in &mut self.entry_data {
                e.valid_since = stamp;
            }
            queue.write_buffer(&self.entries, 0, bytemuck::cast_slice(&self.entry_data));
        }
        let params = GpuParams {
            stamp,
            reuse: config.reuse,
            tile_size: config.tile_size,
            view_mode: config.view as u32,
            mip_bias,
            variable_rate: config.variable_rate,
            max_queue,
            pad: 0,
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(&self.counters, 0, None);
    }

    /// Binds the scene (group 0) and these resources (group 1) on a compute pass.
    pub fn bind(&self, pass: &mut wgpu::ComputePass, scene: &wgpu::BindGroup) {
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, &self.bind_group, &[]);
    }
}
