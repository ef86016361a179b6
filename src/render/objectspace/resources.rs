//! Everything the object-space passes share, in one place: the physical
//! shading atlas and triangle-index maps, the visibility buffer, the atlas
//! table, the page table and page state, the tile stamps, the shade queue
//! and its counters, and the bind group (group 1 of every object-space pass,
//! `objectspace.wgsl`) that exposes them.

use wgpu::util::DeviceExt;

use super::atlas::{AtlasLayout, GpuAtlasEntry, PagePool};
use super::{ObjectSpaceConfig, TileCounter};
use crate::render::passes::visibility::VisibilityBuffer;
use crate::render::passes::{Binding, bind_group, bind_group_layout, view_as};
use crate::render::targets::Targets;
use crate::shaders::gpu_struct;

pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const TRIANGLE_MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

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
        /// Capacity of the shade queue (the physical atlas's tile count).
        pub max_queue: u32,
        /// 1: due tiles wait for their phase frame (decoupled shading rate).
        pub spread: u32,
        pub page_size: u32,
        pub physical_pages: u32,
        pub layer_pages: u32,
        pub virtual_pages: u32,
        /// Word of the request bits where the tile bits start.
        pub request_tile_base: u32,
        /// Chunks of the page table ([`table_chunks`]).
        pub table_chunks: u32,
        pub pad_b: u32,
        pub pad_c: u32,
    }
}

gpu_struct! {
    /// Which view a pass records for (`ViewSlot` in `objectspace.wgsl`).
    pub struct GpuViewSlot as "ViewSlot" {
        pub index: u32,
        /// Views marking into the atlas this frame.
        pub count: u32,
        pub pad_a: u32,
        pub pad_b: u32,
    }
}

pub struct Resources {
    pub pool: PagePool,
    pub atlas: wgpu::Texture,
    /// The atlas as a 2D array (one layer per page).
    pub atlas_array: wgpu::TextureView,
    pub triangle_map: wgpu::Texture,
    /// The triangle maps as a 2D array.
    pub triangle_map_array: wgpu::TextureView,
    pub visibility: VisibilityBuffer,
    pub params: wgpu::Buffer,
    pub entries: wgpu::Buffer,
    /// CPU copy of the atlas table (its `valid_since` changes with the lights).
    pub entry_data: Vec<GpuAtlasEntry>,
    /// Per physical tile: stamp of the last frame it was visible.
    pub tile_visible: wgpu::Buffer,
    /// Per physical tile: stamp of the last frame it was shaded.
    pub tile_shaded: wgpu::Buffer,
    /// This frame's tiles to shade: (virtual tile, object << 8 | level).
    pub work_queue: wgpu::Buffer,
    /// Indexed by [`TileCounter`].
    pub counters: wgpu::Buffer,
    /// The page table's first level: per block of virtual pages, its chunk + 1.
    pub page_directory: wgpu::Buffer,
    /// The page table's chunks: per page of a block, physical page + 1 (0: not backed).
    pub page_table: wgpu::Buffer,
    /// Per chunk: its backed pages and block (GPU state only).
    pub table_chunks: wgpu::Buffer,
    pub free_chunks: wgpu::Buffer,
    /// Per physical page: stamp of its last use.
    pub page_used: wgpu::Buffer,
    /// Per physical page: the virtual page it backs + 1 (0: free).
    pub page_owner: wgpu::Buffer,
    /// Request bits: one per virtual page, then one per virtual tile.
    pub page_requests: wgpu::Buffer,
    pub request_list: wgpu::Buffer,
    pub candidates: wgpu::Buffer,
    /// Pages backed this frame.
    pub backed: wgpu::Buffer,
    /// Indirect dispatch arguments (`dispatch.wgsl`): shade, allocate, backed pages.
    pub dispatch: wgpu::Buffer,
    /// `dispatch` as storage, for the passes that write it (group 2).
    pub dispatch_layout: wgpu::BindGroupLayout,
    pub dispatch_group: wgpu::BindGroup,
    /// Per physical tile: the views that marked it this frame (one bit each),
    /// cleared every frame when there are several views.
    pub tile_views: wgpu::Buffer,
    /// The scene's chart islands per triangle (bound for the gather's filter).
    triangle_charts: wgpu::Buffer,
    pub layout: wgpu::BindGroupLayout,
    /// Group 1 per view (its visibility buffer and view slot; 0 is the main view).
    pub view_groups: Vec<wgpu::BindGroup>,
    view_count: u32,
    virtual_pages: u32,
    request_tile_base: u32,
    chunks: u32,
}

/// Chunks of the page table for a pool of `pages` physical pages: one per
/// page, so that a requested block always finds one (a chunk in use holds
/// at least one backed page). Sponza's pages share blocks (about 5 pages
/// a block of 16 at 1080p; at most 7,000 of 32,400 chunks in use along its
/// path), so most chunks stay free: 76 bytes a page, the price of never
/// failing a request for want of a chunk.
pub fn table_chunks(pages: u32) -> u32 {
    pages
}

/// Indirect dispatch offsets in [`Resources::dispatch`] (bytes).
pub const SHADE_ARGS: u64 = 0;
pub const ALLOCATE_ARGS: u64 = 16;
pub const BACKED_ARGS: u64 = 32;

impl Resources {
    pub fn new(
        device: &wgpu::Device,
        atlas_layout: &AtlasLayout,
        pool: PagePool,
        triangle_charts: &wgpu::Buffer,
        targets: &Targets,
        view_count: u32,
    ) -> Self {
        let atlas = pool.texture(
            device,
            "shading atlas",
            ATLAS_FORMAT,
            wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
        );
        // COPY_SRC: debug and test read-backs.
        let triangle_map = pool.texture(
            device,
            "triangle maps",
            TRIANGLE_MAP_FORMAT,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
        );
        let visibility = VisibilityBuffer::new(device, targets);
        // Zero-initialised: 0 = never visible, never shaded, not backed, free.
        // COPY_SRC: tests and debug views read them back.
        let storage = |label, size: u64, extra| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra,
                mapped_at_creation: false,
            })
        };
        let none = wgpu::BufferUsages::empty();
        let page_tiles = (pool.page_size / atlas_layout.tile_size).pow(2) as u64;
        let tiles = pool.pages as u64 * page_tiles;
        let virtual_pages = atlas_layout.page_count as u64;
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
        let tile_visible = storage("tile visible", tiles * 4, none);
        let tile_shaded = storage("tile shaded", tiles * 4, none);
        let work_queue = storage("shade queue", tiles * 8, none);
        let counters = storage("tile counters", TileCounter::SLOTS as u64 * 4, wgpu::BufferUsages::COPY_DST);
        let chunks = table_chunks(pool.pages);
        let block_pages = super::atlas::BLOCK_PAGES as u64;
        let page_directory = storage("page directory", virtual_pages / block_pages * 4, none);
        let page_table = storage("page table", chunks as u64 * block_pages * 4, none);
        let table_chunk_state = storage("page table chunks", chunks as u64 * 8, none);
        let free_chunks = storage("free page table chunks", chunks as u64 * 4, none);
        let request_tile_base = virtual_pages.div_ceil(32);
        let request_words = request_tile_base + (atlas_layout.tile_count as u64).div_ceil(32);
        let page_used = storage("page used", pool.pages as u64 * 4, none);
        let page_owner = storage("page owner", pool.pages as u64 * 4, none);
        let page_requests = storage("page requests", request_words * 4, none);
        let request_list = storage("page request list", pool.pages as u64 * 8, none);
        let candidates = storage("page candidates", pool.pages as u64 * 4, none);
        let backed = storage("backed pages", pool.pages as u64 * 16, none);
        let dispatch = storage("object-space dispatch", 48, wgpu::BufferUsages::INDIRECT);
        let tile_views = storage("tile views", tiles * 4, wgpu::BufferUsages::COPY_DST);
        let dispatch_layout =
            bind_group_layout(device, "object-space dispatch", &[Binding::Storage { read_only: false }]);
        let dispatch_group =
            bind_group(device, "object-space dispatch", &dispatch_layout, &[dispatch.as_entire_binding()]);

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
                Binding::Storage { read_only: true },
                rw,
                rw,
                rw,
                rw,
                rw,
                rw,
                rw,
                Binding::Storage { read_only: true },
                rw,
                rw,
                rw,
                rw,
            ],
        );
        let mut res = Self {
            view_groups: Vec::new(),
            view_count,
            tile_views,
            triangle_charts: triangle_charts.clone(),
            pool,
            atlas_array: view_as(&atlas, wgpu::TextureViewDimension::D2Array),
            atlas,
            triangle_map_array: view_as(&triangle_map, wgpu::TextureViewDimension::D2Array),
            triangle_map,
            visibility,
            params,
            entries,
            entry_data,
            tile_visible,
            tile_shaded,
            work_queue,
            counters,
            page_directory,
            page_table,
            table_chunks: table_chunk_state,
            free_chunks,
            page_used,
            page_owner,
            page_requests,
            request_list,
            candidates,
            backed,
            dispatch,
            dispatch_layout,
            dispatch_group,
            layout,
            virtual_pages: virtual_pages as u32,
            request_tile_base: request_tile_base as u32,
            chunks,
        };
        let main = res.visibility.view.clone();
        res.add_view(device, &main);
        res
    }

    /// Adds group 1 of the next view: these resources with the view's
    /// visibility buffer and its view slot.
    pub fn add_view(&mut self, device: &wgpu::Device, visibility: &wgpu::TextureView) {
        let index = self.view_groups.len() as u32;
        let slot = GpuViewSlot { index, count: self.view_count, pad_a: 0, pad_b: 0 };
        let slot = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view slot"),
            contents: bytemuck::bytes_of(&slot),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let group = bind_group(
            device,
            "object space",
            &self.layout,
            &[
                self.params.as_entire_binding(),
                self.entries.as_entire_binding(),
                self.tile_visible.as_entire_binding(),
                self.tile_shaded.as_entire_binding(),
                self.work_queue.as_entire_binding(),
                self.counters.as_entire_binding(),
                wgpu::BindingResource::TextureView(visibility),
                self.triangle_charts.as_entire_binding(),
                self.page_table.as_entire_binding(),
                self.page_used.as_entire_binding(),
                self.page_owner.as_entire_binding(),
                self.page_requests.as_entire_binding(),
                self.request_list.as_entire_binding(),
                self.candidates.as_entire_binding(),
                self.backed.as_entire_binding(),
                slot.as_entire_binding(),
                self.tile_views.as_entire_binding(),
                self.page_directory.as_entire_binding(),
                self.table_chunks.as_entire_binding(),
                self.free_chunks.as_entire_binding(),
            ],
        );
        self.view_groups.push(group);
    }

    /// Shade queue capacity: every tile of the physical atlas.
    pub fn max_queue(&self, tile_size: u32) -> u32 {
        (self.pool.pages as u64 * (self.pool.page_size / tile_size).pow(2) as u64).min(u32::MAX as u64) as u32
    }

    /// Bytes of the page table and page state: the directory (a word per
    /// block of virtual pages), the chunks (a word per page of a block, its
    /// state and free-list slot), the request bits, and per physical page
    /// its owner, last use, request, candidate and backed slots.
    pub fn page_table_bytes(&self) -> u64 {
        let block_pages = super::atlas::BLOCK_PAGES as u64;
        let directory = self.virtual_pages as u64 / block_pages * 4;
        let chunks = self.chunks as u64 * (block_pages * 4 + 8 + 4);
        let request_bits = self.page_requests.size();
        directory + chunks + request_bits + self.pool.pages as u64 * (4 + 4 + 8 + 4 + 16)
    }

    /// Sets each object's mip bias (the budget's share per object), uploading
    /// the atlas table when they changed.
    pub fn set_object_biases(&mut self, queue: &wgpu::Queue, biases: &[f32]) {
        let mut changed = false;
        for (e, &b) in self.entry_data.iter_mut().zip(biases) {
            changed |= e.mip_bias != b;
            e.mip_bias = b;
        }
        if changed {
            queue.write_buffer(&self.entries, 0, bytemuck::cast_slice(&self.entry_data));
        }
    }

    /// Uploads this frame's settings (and, when the shades went stale, the
    /// atlas table with its new `valid_since`) and clears the counters.
    /// The budget's bias is per object, in the table ([`Self::set_object_biases`]).
    pub fn begin_frame(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        stamp: u32,
        stale: bool,
        config: &ObjectSpaceConfig,
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
            mip_bias: config.mip_bias,
            variable_rate: config.variable_rate,
            max_queue: self.max_queue(config.tile_size),
            spread: config.spread_reshading as u32,
            page_size: self.pool.page_size,
            physical_pages: self.pool.pages,
            layer_pages: self.pool.layer_pages,
            virtual_pages: self.virtual_pages,
            request_tile_base: self.request_tile_base,
            table_chunks: self.chunks,
            pad_b: 0,
            pad_c: 0,
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(&self.counters, 0, None);
        if self.view_count > 1 {
            encoder.clear_buffer(&self.tile_views, 0, None);
        }
    }

    /// Binds the scene as view `view` sees it (group 0) and these resources
    /// for that view (group 1) on a compute pass.
    pub fn bind_view(&self, pass: &mut wgpu::ComputePass, scene: &wgpu::BindGroup, view: usize) {
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, &self.view_groups[view], &[]);
    }

    /// Binds the scene (group 0) and these resources (group 1) on a compute pass.
    pub fn bind(&self, pass: &mut wgpu::ComputePass, scene: &wgpu::BindGroup) {
        pass.set_bind_group(0, scene, &[]);
        pass.set_bind_group(1, &self.view_groups[0], &[]);
    }
}
