//! Everything the object-space passes share, in one place: the physical
//! shading atlas and triangle-index maps, the visibility buffer, the atlas
//! table, the page table and page state, the tile stamps, the shade queue
//! and its counters, and the bind group (group 1 of every object-space pass,
//! `objectspace.wgsl`) that exposes them.

use wgpu::util::DeviceExt;

use super::atlas::{AtlasLayout, GpuAtlasEntry, PagePool};
use super::{ObjectSpaceConfig, TileCounter};
use crate::render::passes::visibility::{VisibilityBuffer, VisibilityMethod};
use crate::render::passes::{Binding, bind_group, bind_group_layout, bind_group_layout_for, view_as};
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
        /// Slots of the page request list (the budget's pages).
        pub request_capacity: u32,
        /// Stamp of the first frame with this frame's view (camera): with
        /// reuse above 1, a tile shaded since then is not shaded again by
        /// age, since it would get the same shade.
        pub view_since: u32,
        /// [`ObjectSpaceConfig::level_blend`].
        pub level_blend: f32,
        /// [`ObjectSpaceConfig::gather_filter`] ([`super::GatherFilter::code`]).
        pub gather_filter: u32,
        /// Points per side of a texel that shading averages
        /// ([`ObjectSpaceConfig::texel_samples`]: 1 or 2).
        pub texel_sample_side: u32,
        /// [`ObjectSpaceConfig::aniso`].
        pub aniso: u32,
        /// [`ObjectSpaceConfig::msaa_gather`] ([`super::MsaaGather::code`]).
        pub msaa_gather: u32,
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
    /// What the atlas holds per physical page and tile (sized by `pool`).
    pub physical: PhysicalPages,
    pub visibility: VisibilityBuffer,
    pub params: wgpu::Buffer,
    pub entries: wgpu::Buffer,
    /// CPU copy of the atlas table (its `valid_since` changes with the lights).
    pub entry_data: Vec<GpuAtlasEntry>,
    /// Indexed by [`TileCounter`].
    pub counters: wgpu::Buffer,
    /// The page table's first level: per block of virtual pages, its chunk + 1.
    pub page_directory: wgpu::Buffer,
    /// The page table's chunks: per page of a block, physical page + 1 (0: not backed).
    pub page_table: wgpu::Buffer,
    /// Per chunk: its backed pages and block (GPU state only).
    pub table_chunks: wgpu::Buffer,
    pub free_chunks: wgpu::Buffer,
    /// Request bits: one per virtual page, then one per virtual tile.
    pub page_requests: wgpu::Buffer,
    /// This frame's requested pages (a slot per page of the budget).
    pub request_list: wgpu::Buffer,
    /// Indirect dispatch arguments (`dispatch.wgsl`): allocate, backed pages, shade.
    pub dispatch: wgpu::Buffer,
    /// `dispatch` as storage, for the passes that write it (group 2).
    pub dispatch_layout: wgpu::BindGroupLayout,
    pub dispatch_group: wgpu::BindGroup,
    /// The scene's chart islands per triangle (bound for the gather's filter).
    triangle_charts: wgpu::Buffer,
    pub layout: wgpu::BindGroupLayout,
    /// Group 1 per view (its visibility buffer and view slot; 0 is the main view).
    pub view_groups: Vec<wgpu::BindGroup>,
    /// Per view: its visibility buffer and view slot, to bind group 1 again
    /// when the atlas is resized.
    views: Vec<(wgpu::TextureView, wgpu::Buffer)>,
    view_count: u32,
    /// The atlas layout's tile side.
    pub tile_size: u32,
    virtual_pages: u32,
    request_tile_base: u32,
    /// Physical pages at the whole budget: the page table's chunks and the
    /// request list are sized for them, so a resize leaves them as they are.
    budget_pages: u32,
}

/// What the atlas holds per physical page and per physical tile: the shades
/// and triangle maps, page use and owners, tile stamps, and this frame's
/// lists. Resized with the atlas ([`Resources::resize`]).
pub struct PhysicalPages {
    pub atlas: wgpu::Texture,
    /// The atlas as a 2D array (one layer per page).
    pub atlas_array: wgpu::TextureView,
    pub triangle_map: wgpu::Texture,
    /// The triangle maps as a 2D array.
    pub triangle_map_array: wgpu::TextureView,
    /// Per physical tile: stamp of the last frame it was visible.
    pub tile_visible: wgpu::Buffer,
    /// Per physical tile: stamp of the last frame it was shaded.
    pub tile_shaded: wgpu::Buffer,
    /// Per physical tile: its shade-queue entry (virtual tile, object << 8
    /// | level), this frame's where `tile_shaded` holds the frame's stamp.
    pub work_queue: wgpu::Buffer,
    /// This frame's queued physical tiles, packed (`compact_queue`).
    pub shade_list: wgpu::Buffer,
    /// Per physical page: stamp of its last use.
    pub page_used: wgpu::Buffer,
    /// Per physical page: the virtual page it backs + 1 (0: free).
    pub page_owner: wgpu::Buffer,
    pub candidates: wgpu::Buffer,
    /// Pages backed this frame.
    pub backed: wgpu::Buffer,
    /// Per physical tile: the views that marked it this frame (one bit each),
    /// cleared every frame when there are several views.
    pub tile_views: wgpu::Buffer,
}

/// A zero-initialised storage buffer (0: never visible, never shaded, not
/// backed, free); COPY_SRC for tests, debug views and resizes.
fn storage(device: &wgpu::Device, label: &str, size: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size.max(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra,
        mapped_at_creation: false,
    })
}

impl PhysicalPages {
    fn new(device: &wgpu::Device, pool: &PagePool, tile_size: u32) -> Self {
        // COPY_SRC: debug and test read-backs, and resizes.
        let usage = wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST;
        let atlas = pool.texture(device, "shading atlas", ATLAS_FORMAT, usage);
        let triangle_map = pool.texture(device, "triangle maps", TRIANGLE_MAP_FORMAT, usage);
        let (none, copy) = (wgpu::BufferUsages::empty(), wgpu::BufferUsages::COPY_DST);
        let tiles = pool.pages as u64 * (pool.page_size / tile_size).pow(2) as u64;
        let pages = pool.pages as u64;
        Self {
            atlas_array: view_as(&atlas, wgpu::TextureViewDimension::D2Array),
            atlas,
            triangle_map_array: view_as(&triangle_map, wgpu::TextureViewDimension::D2Array),
            triangle_map,
            tile_visible: storage(device, "tile visible", tiles * 4, copy),
            tile_shaded: storage(device, "tile shaded", tiles * 4, copy),
            work_queue: storage(device, "shade queue", tiles * 8, none),
            shade_list: storage(device, "shade list", tiles * 4, none),
            page_used: storage(device, "page used", pages * 4, copy),
            page_owner: storage(device, "page owner", pages * 4, copy),
            // Paging lists each age bucket's pages apart (`rank_pages`).
            candidates: storage(device, "page candidates", pages * 4 * TileCounter::AGE_BUCKETS as u64, none),
            backed: storage(device, "backed pages", pages * 16, none),
            tile_views: storage(device, "tile views", tiles * 4, copy),
        }
    }

    /// Copies what `self` holds of the pages both have into `to`: page use
    /// and owners, tile stamps (this frame's lists are rebuilt every frame;
    /// the shades and triangle maps are copied by `paging::resize`).
    fn copy_into(&self, to: &Self, encoder: &mut wgpu::CommandEncoder) {
        for (from, into) in [
            (&self.tile_visible, &to.tile_visible),
            (&self.tile_shaded, &to.tile_shaded),
            (&self.page_used, &to.page_used),
            (&self.page_owner, &to.page_owner),
        ] {
            encoder.copy_buffer_to_buffer(from, 0, into, 0, from.size().min(into.size()));
        }
    }
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

/// The page directory (a word per block of the layout's virtual pages) and
/// the request bits (a bit per virtual page, then from the returned word a
/// bit per virtual tile).
fn directory_buffers(device: &wgpu::Device, layout: &AtlasLayout) -> (wgpu::Buffer, wgpu::Buffer, u32) {
    let copy = wgpu::BufferUsages::COPY_DST;
    let virtual_pages = layout.page_count as u64;
    let directory = storage(device, "page directory", virtual_pages / super::atlas::BLOCK_PAGES as u64 * 4, copy);
    let tile_base = virtual_pages.div_ceil(32);
    let words = tile_base + (layout.tile_count as u64).div_ceil(32);
    (directory, storage(device, "page requests", words * 4, copy), tile_base as u32)
}

/// Indirect dispatch offsets in [`Resources::dispatch`] (bytes).
pub const ALLOCATE_ARGS: u64 = 0;
pub const BACKED_ARGS: u64 = 16;
pub const SHADE_ARGS: u64 = 32;

impl Resources {
    pub fn new(
        device: &wgpu::Device,
        atlas_layout: &AtlasLayout,
        pool: PagePool,
        triangle_charts: &wgpu::Buffer,
        targets: &Targets,
        view_count: u32,
        method: VisibilityMethod,
    ) -> Self {
        let visibility = VisibilityBuffer::new(device, targets, method);
        let none = wgpu::BufferUsages::empty();
        let storage = |label, size, extra| storage(device, label, size, extra);
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
        let counters = storage("tile counters", TileCounter::WORDS as u64 * 4, wgpu::BufferUsages::COPY_DST);
        // Chunks for the whole budget: a resize leaves the table as it is.
        let chunks = table_chunks(pool.pages);
        let block_pages = super::atlas::BLOCK_PAGES as u64;
        let (page_directory, page_requests, request_tile_base) = directory_buffers(device, atlas_layout);
        let page_table = storage("page table", chunks as u64 * block_pages * 4, none);
        let table_chunk_state = storage("page table chunks", chunks as u64 * 8, none);
        let free_chunks = storage("free page table chunks", chunks as u64 * 4, none);
        let request_list = storage("page request list", pool.pages as u64 * 8, none);
        let dispatch = storage("object-space dispatch", 48, wgpu::BufferUsages::INDIRECT);
        let dispatch_layout =
            bind_group_layout(device, "object-space dispatch", &[Binding::Storage { read_only: false }]);
        let dispatch_group =
            bind_group(device, "object-space dispatch", &dispatch_layout, &[dispatch.as_entire_binding()]);

        let rw = Binding::Storage { read_only: false };
        let uint = wgpu::TextureSampleType::Uint;
        // Fragments of object space's passes over blended objects mark and
        // gather as its compute passes do.
        let stages = wgpu::ShaderStages::COMPUTE | wgpu::ShaderStages::FRAGMENT;
        let layout = bind_group_layout_for(
            device,
            "object space",
            stages,
            &[
                Binding::Uniform,
                Binding::Storage { read_only: true },
                rw,
                rw,
                rw,
                rw,
                // Under MSAA one id pair per sample (`MSAA` in the shaders):
                // the compute rasterizer's in a layer each (`VISIBILITY_LAYERS`).
                if targets.samples > 1 && method == VisibilityMethod::Compute {
                    Binding::Texture { sample: uint, dimension: wgpu::TextureViewDimension::D2Array }
                } else if targets.samples > 1 {
                    Binding::MultisampledTexture { sample: uint }
                } else {
                    Binding::Texture { sample: uint, dimension: wgpu::TextureViewDimension::D2 }
                },
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
                rw,
            ],
        );
        let mut res = Self {
            view_groups: Vec::new(),
            views: Vec::new(),
            view_count,
            tile_size: atlas_layout.tile_size,
            triangle_charts: triangle_charts.clone(),
            physical: PhysicalPages::new(device, &pool, atlas_layout.tile_size),
            pool,
            visibility,
            params,
            entries,
            entry_data,
            counters,
            page_directory,
            page_table,
            table_chunks: table_chunk_state,
            free_chunks,
            page_requests,
            request_list,
            dispatch,
            dispatch_layout,
            dispatch_group,
            layout,
            virtual_pages: virtual_pages as u32,
            request_tile_base,
            budget_pages: pool.pages,
        };
        let main = res.visibility.view.clone();
        res.add_view(device, &main);
        res
    }

    /// Resizes the atlas to `pool` (the same layers, more or fewer of them):
    /// the pages both sizes have keep their shades, maps and state, and
    /// group 1 of every view is bound again. When shrinking, the pages
    /// beyond `pool` must have been moved below it or evicted first. Returns
    /// the old atlas's pages, whose shades and triangle maps
    /// `paging::resize::copy_pages` then copies.
    pub fn resize(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        pool: PagePool,
    ) -> PhysicalPages {
        let physical = PhysicalPages::new(device, &pool, self.tile_size);
        self.physical.copy_into(&physical, encoder);
        self.pool = pool;
        let old = std::mem::replace(&mut self.physical, physical);
        self.view_groups =
            self.views.iter().map(|(visibility, slot)| self.view_group(device, visibility, slot)).collect();
        old
    }

    /// Follows the layout's larger virtual page space (`slots`): a new page
    /// directory and request bits, holding the old ones' words (the slots
    /// given out keep their numbers), and group 1 of every view bound again.
    pub fn grow_directory(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, layout: &AtlasLayout) {
        let (directory, requests, tile_base) = directory_buffers(device, layout);
        encoder.copy_buffer_to_buffer(&self.page_directory, 0, &directory, 0, self.page_directory.size());
        let (old_base, new_base) = (self.request_tile_base as u64 * 4, tile_base as u64 * 4);
        encoder.copy_buffer_to_buffer(&self.page_requests, 0, &requests, 0, old_base);
        let tile_bytes = self.page_requests.size() - old_base;
        encoder.copy_buffer_to_buffer(&self.page_requests, old_base, &requests, new_base, tile_bytes);
        (self.page_directory, self.page_requests) = (directory, requests);
        (self.virtual_pages, self.request_tile_base) = (layout.page_count, tile_base);
        self.view_groups =
            self.views.iter().map(|(visibility, slot)| self.view_group(device, visibility, slot)).collect();
    }

    /// Uploads the atlas-table rows of `objects` from `layout` (their slots
    /// changed; their stamps and biases stay).
    pub fn set_entries(&mut self, queue: &wgpu::Queue, layout: &AtlasLayout, objects: &[usize]) {
        for &o in objects {
            let e = &mut self.entry_data[o];
            *e = GpuAtlasEntry { valid_since: e.valid_since, mip_bias: e.mip_bias, ..layout.gpu_entry(o) };
        }
        // Row by row when few changed (an object coming into view), else at once.
        if objects.len() > 64 {
            queue.write_buffer(&self.entries, 0, bytemuck::cast_slice(&self.entry_data));
        } else {
            let row = size_of::<GpuAtlasEntry>() as u64;
            for &o in objects {
                queue.write_buffer(&self.entries, o as u64 * row, bytemuck::bytes_of(&self.entry_data[o]));
            }
        }
    }

    /// Adds group 1 of the next view: these resources with the view's
    /// visibility buffer and its view slot.
    pub fn add_view(&mut self, device: &wgpu::Device, visibility: &wgpu::TextureView) {
        let index = self.views.len() as u32;
        let slot = GpuViewSlot { index, count: self.view_count, pad_a: 0, pad_b: 0 };
        let slot = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view slot"),
            contents: bytemuck::bytes_of(&slot),
            usage: wgpu::BufferUsages::STORAGE,
        });
        self.view_groups.push(self.view_group(device, visibility, &slot));
        self.views.push((visibility.clone(), slot));
    }

    fn view_group(
        &self,
        device: &wgpu::Device,
        visibility: &wgpu::TextureView,
        slot: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let p = &self.physical;
        bind_group(
            device,
            "object space",
            &self.layout,
            &[
                self.params.as_entire_binding(),
                self.entries.as_entire_binding(),
                p.tile_visible.as_entire_binding(),
                p.tile_shaded.as_entire_binding(),
                p.work_queue.as_entire_binding(),
                self.counters.as_entire_binding(),
                wgpu::BindingResource::TextureView(visibility),
                self.triangle_charts.as_entire_binding(),
                self.page_table.as_entire_binding(),
                p.page_used.as_entire_binding(),
                p.page_owner.as_entire_binding(),
                self.page_requests.as_entire_binding(),
                self.request_list.as_entire_binding(),
                p.candidates.as_entire_binding(),
                p.backed.as_entire_binding(),
                slot.as_entire_binding(),
                p.tile_views.as_entire_binding(),
                self.page_directory.as_entire_binding(),
                self.table_chunks.as_entire_binding(),
                self.free_chunks.as_entire_binding(),
                p.shade_list.as_entire_binding(),
            ],
        )
    }

    /// Chunks of the page table (for the budget's pages, whatever the
    /// atlas's size now).
    pub fn chunk_count(&self) -> u32 {
        table_chunks(self.budget_pages)
    }

    /// Shade queue capacity: every tile of the physical atlas.
    pub fn max_queue(&self, tile_size: u32) -> u32 {
        (self.pool.pages as u64 * (self.pool.page_size / tile_size).pow(2) as u64).min(u32::MAX as u64) as u32
    }

    /// Bytes of the page table and page state: the directory (a word per
    /// block of the virtual pages the slots cover), the chunks (a word per page of a block, its
    /// state and free-list slot), the request bits, and per physical page
    /// its owner, last use, request, candidate and backed slots.
    pub fn page_table_bytes(&self) -> u64 {
        let block_pages = super::atlas::BLOCK_PAGES as u64;
        let directory = self.virtual_pages as u64 / block_pages * 4;
        let chunks = self.chunk_count() as u64 * (block_pages * 4 + 8 + 4);
        let request_bits = self.page_requests.size();
        let request_list = self.budget_pages as u64 * 8;
        directory + chunks + request_bits + request_list + self.pool.pages as u64 * (4 + 4 + 4 + 16)
    }

    /// Sets each object's mip bias (the budget's share per object), uploading
    /// the atlas table when they changed; returns whether they did.
    pub fn set_object_biases(&mut self, queue: &wgpu::Queue, biases: &[f32]) -> bool {
        let mut changed = false;
        for (e, &b) in self.entry_data.iter_mut().zip(biases) {
            changed |= e.mip_bias != b;
            e.mip_bias = b;
        }
        if changed {
            queue.write_buffer(&self.entries, 0, bytemuck::cast_slice(&self.entry_data));
        }
        changed
    }

    /// Uploads this frame's settings (and, when the shades went stale, the
    /// atlas table with its new `valid_since`; `view_since`: the stamp since
    /// which the view is unchanged) and clears the counters.
    /// The budget's bias is per object, in the table ([`Self::set_object_biases`]).
    pub fn begin_frame(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        stamp: u32,
        stale: bool,
        view_since: u32,
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
            table_chunks: self.chunk_count(),
            request_capacity: self.budget_pages,
            view_since,
            level_blend: config.level_blend,
            gather_filter: config.gather_filter.code(),
            texel_sample_side: config.texel_sample_side(),
            aniso: config.aniso,
            msaa_gather: config.msaa_gather.code(),
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(&self.counters, 0, None);
        if self.view_count > 1 {
            encoder.clear_buffer(&self.physical.tile_views, 0, None);
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
