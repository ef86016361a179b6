//! Where every object's shading texture lives. Each object's texture (its
//! whole mip pyramid, up to 16384 texels a side) is *virtual*: its levels
//! are cut into square pages, numbered within the object's *slot* (a range
//! of the virtual page space, [`ObjectAtlas::span`] numbers long, that the
//! renderer gives an object while it is in view: `super::slots`), and only
//! the pages that visible tiles need are backed by a page of the shared
//! physical atlas ([`PagePool`]), through a two-level page table the GPU
//! keeps (`paging/`). Pages are numbered in blocks of [`BLOCK_SIDE`] x
//! [`BLOCK_SIDE`] (a level's blocks row-major, the pages of a block
//! row-major): the page directory has one word per block, and only the
//! blocks holding backed pages have a table chunk of one word per page, so
//! the table grows with the pages in use, and the directory with the slots
//! given out, not with every object's virtual space. Tiles keep a virtual
//! numbering too (the shade queue and the CPU twin speak of virtual tiles):
//! a level's tiles start at its first page number times the tiles a page
//! holds, so a slot numbers its tiles as well; their state lives with the
//! physical page that backs them.

use bytemuck::Zeroable;

use crate::shaders::gpu_struct;

/// Most mip levels an object can have (a 16384 texture down to 8x8 tiles is 12).
pub const MAX_LEVELS: usize = 14;
/// Largest virtual texture side.
pub const MAX_TEXTURE_SIZE: u32 = 16384;
/// Pages per side of a page-table block (one directory word, one table
/// chunk). Small, so that one chunk per physical page (which never runs
/// out: every chunk in use holds a backed page) costs little: 76 bytes.
pub const BLOCK_SIDE: u32 = 4;
/// Pages per block.
pub const BLOCK_PAGES: u32 = BLOCK_SIDE * BLOCK_SIDE;
/// Slots start and end on multiples of this many page numbers: whole words
/// of page request bits (and of tile bits, and whole directory words).
pub const SLOT_ALIGN: u32 = 32;

/// One mip level of one object's virtual texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLevel {
    pub size: u32,
    /// Virtual index of the level's first page (a multiple of
    /// [`BLOCK_PAGES`]: the level's pages are numbered block by block).
    pub page_base: u32,
    /// Global index of the level's first tile (tiles row-major): the
    /// level's first page number times the tiles a page holds.
    pub tile_base: u32,
    /// The level's first page number within its object's slot.
    pub offset: u32,
}

impl AtlasLevel {
    /// Pages per row (the last row and column may be partly outside the level).
    pub fn pages_per_row(&self, page_size: u32) -> u32 {
        self.size.div_ceil(page_size)
    }

    /// Blocks per row of pages.
    pub fn blocks_per_row(&self, page_size: u32) -> u32 {
        self.pages_per_row(page_size).div_ceil(BLOCK_SIDE)
    }

    /// Virtual page numbers the level takes: whole blocks, so a level
    /// narrower than a block leaves numbers unused (no memory: the table
    /// holds chunks only for blocks with backed pages).
    pub fn page_numbers(&self, page_size: u32) -> u64 {
        (self.blocks_per_row(page_size) as u64).pow(2) * BLOCK_PAGES as u64
    }

    /// The level-local page (column, row) of virtual page `local` (counted
    /// from `page_base`).
    pub fn page_position(&self, page_size: u32, local: u32) -> [u32; 2] {
        let (block, i) = (local / BLOCK_PAGES, local % BLOCK_PAGES);
        let per_row = self.blocks_per_row(page_size);
        [block % per_row * BLOCK_SIDE + i % BLOCK_SIDE, block / per_row * BLOCK_SIDE + i / BLOCK_SIDE]
    }

    /// The virtual page of level-local page (column, row).
    pub fn page_number(&self, page_size: u32, page: [u32; 2]) -> u32 {
        let block = page[1] / BLOCK_SIDE * self.blocks_per_row(page_size) + page[0] / BLOCK_SIDE;
        self.page_base + block * BLOCK_PAGES + page[1] % BLOCK_SIDE * BLOCK_SIDE + page[0] % BLOCK_SIDE
    }
}

/// An object's virtual shading texture: its size (mip 0) and levels, and
/// where its slot lies in the virtual page space.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjectAtlas {
    pub size: u32,
    pub levels: Vec<AtlasLevel>,
    /// Page numbers its slot takes: those of its levels from `first` on (a
    /// multiple of [`SLOT_ALIGN`]).
    pub span: u32,
    /// Its slot's first page number; `None` while it has no slot (out of
    /// view: the passes see it as not in the atlas, `size` 0).
    pub slot: Option<u32>,
    /// The finest level its slot holds: the passes see a texture of
    /// `size >> first` with the levels from `first` on, so no pixel picks a
    /// finer one (the renderer holds back levels that no pixel can pick
    /// from where the views are: `super::slots`).
    pub first: usize,
    /// Page numbers of all its levels (before rounding to [`SLOT_ALIGN`]).
    end: u32,
}

impl ObjectAtlas {
    /// The span of a slot holding the levels from `first` on.
    pub fn span_from(&self, first: usize) -> u32 {
        (self.end - self.levels[first].offset).next_multiple_of(SLOT_ALIGN)
    }

    /// Moves the object into the slot at page `base` holding its levels
    /// from `first` on (`None`: takes its slot away), renumbering their
    /// pages and tiles.
    pub fn place(&mut self, base: Option<u32>, first: usize, tiles_per_page: u32) {
        let first = first.min(self.levels.len() - 1);
        (self.slot, self.first, self.span) = (base, first, self.span_from(first));
        let skipped = self.levels[first].offset;
        for l in &mut self.levels {
            l.page_base = (base.unwrap_or(0) + l.offset).saturating_sub(skipped);
            l.tile_base = l.page_base * tiles_per_page;
        }
    }

    pub fn texels(&self) -> u64 {
        self.levels.iter().map(|l| l.size as u64 * l.size as u64).sum()
    }

    pub fn tiles(&self, tile_size: u32) -> u64 {
        self.levels.iter().map(|l| (l.size / tile_size) as u64 * (l.size / tile_size) as u64).sum()
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum AtlasError {
    #[error("tile size {0} is not one of 8, 16, 32, 64")]
    BadTileSize(u32),
    #[error("page size {page} is not a power of two from the tile size {tile} to four times it")]
    BadPageSize { page: u32, tile: u32 },
    #[error("object {object}: texture size {size} is not a power of two")]
    NotPowerOfTwo { object: usize, size: u32 },
    #[error("the atlas needs {tiles} tiles, more than the 2^32 tile indices")]
    TooManyTiles { tiles: u64 },
    #[error("the atlas needs {pages} virtual pages, more than the 2^32 page numbers")]
    TooManyPages { pages: u64 },
}

/// The virtual layout of all objects' shading textures.
#[derive(Clone, Debug)]
pub struct AtlasLayout {
    pub page_size: u32,
    pub tile_size: u32,
    /// Per scene object; `None` for objects shaded forward (not in the atlas).
    pub objects: Vec<Option<ObjectAtlas>>,
    /// Virtual tile numbers ([`Self::tiles_per_page`] per page number).
    pub tile_count: u32,
    /// Virtual page numbers: the space the slots lie in and the page
    /// directory covers (a multiple of [`SLOT_ALIGN`]).
    pub page_count: u32,
}

impl AtlasLayout {
    /// Lays out objects of the given shading-texture sizes (`None`: not in the
    /// atlas), each in a slot of its own, one after the other. Sizes above `max_size` are clamped to it; sizes below the tile
    /// size are raised to it. Levels go down to `coarsest` texels (or one
    /// tile, if larger): below the charts' gutter, neighbouring charts would
    /// share texels.
    pub fn new(
        sizes: &[Option<u32>],
        tile_size: u32,
        page_size: u32,
        max_size: u32,
        coarsest: u32,
    ) -> Result<Self, AtlasError> {
        Self::with_coarsest(sizes, tile_size, page_size, max_size, &vec![coarsest; sizes.len()])
    }

    /// [`AtlasLayout::new`] with the coarsest level's side per object
    /// (`coarsest[i]` for object i; objects past its end take its last).
    pub fn with_coarsest(
        sizes: &[Option<u32>],
        tile_size: u32,
        page_size: u32,
        max_size: u32,
        coarsest: &[u32],
    ) -> Result<Self, AtlasError> {
        let mut layout = Self::unplaced(sizes, tile_size, page_size, max_size, coarsest)?;
        let pages: u64 = layout.objects.iter().flatten().map(|o| o.span as u64).sum();
        let tiles = pages * layout.tiles_per_page() as u64;
        if tiles > u32::MAX as u64 {
            return Err(AtlasError::TooManyTiles { tiles });
        }
        if pages > u32::MAX as u64 {
            return Err(AtlasError::TooManyPages { pages });
        }
        let mut base = 0;
        for o in 0..layout.objects.len() {
            // Every object in a slot of its own, one after the other.
            let Some(span) = layout.objects[o].as_ref().map(|a| a.span) else { continue };
            layout.place(o, Some(base), 0);
            base += span;
        }
        layout.set_page_count(pages as u32);
        Ok(layout)
    }

    /// The objects' textures with no slot and no page numbers (the
    /// renderer gives slots to the objects in view: `super::slots`).
    pub fn unplaced(
        sizes: &[Option<u32>],
        tile_size: u32,
        page_size: u32,
        max_size: u32,
        coarsest: &[u32],
    ) -> Result<Self, AtlasError> {
        if ![8, 16, 32, 64].contains(&tile_size) {
            return Err(AtlasError::BadTileSize(tile_size));
        }
        if !page_size.is_power_of_two() || page_size < tile_size || page_size > 4 * tile_size {
            return Err(AtlasError::BadPageSize { page: page_size, tile: tile_size });
        }
        let mut objects = Vec::with_capacity(sizes.len());
        for (object, s) in sizes.iter().enumerate() {
            let size = match *s {
                Some(size) if !size.is_power_of_two() => return Err(AtlasError::NotPowerOfTwo { object, size }),
                Some(size) => size.clamp(tile_size, max_size),
                None => {
                    objects.push(None);
                    continue;
                }
            };
            let coarsest = coarsest.get(object).or(coarsest.last()).copied().unwrap_or(tile_size).max(tile_size);
            let count = ((size / coarsest.min(size)).ilog2() as usize + 1).min(MAX_LEVELS);
            let mut span = 0u64;
            let levels = (0..count)
                .map(|l| {
                    let level = AtlasLevel { size: size >> l, page_base: 0, tile_base: 0, offset: span as u32 };
                    span += level.page_numbers(page_size);
                    level
                })
                .collect();
            let end = span as u32;
            let span = span.next_multiple_of(SLOT_ALIGN as u64) as u32;
            objects.push(Some(ObjectAtlas { size, levels, span, slot: None, first: 0, end }));
        }
        Ok(Self { page_size, tile_size, objects, tile_count: 0, page_count: 0 })
    }

    /// Virtual tile numbers per page number.
    pub fn tiles_per_page(&self) -> u32 {
        (self.page_size / self.tile_size).pow(2)
    }

    /// Sets the virtual page numbers the page directory covers (the slots
    /// lie below it), and the tile numbers with them.
    pub fn set_page_count(&mut self, pages: u32) {
        self.page_count = pages;
        self.tile_count = pages.saturating_mul(self.tiles_per_page());
    }

    /// Moves object `object` (in the atlas) into the slot at page `base`
    /// holding its levels from `first` on, or takes its slot away (`None`).
    pub fn place(&mut self, object: usize, base: Option<u32>, first: usize) {
        let tiles_per_page = self.tiles_per_page();
        if let Some(o) = &mut self.objects[object] {
            o.place(base, first, tiles_per_page);
        }
    }

    /// Object `object`'s row of the table the GPU passes read: an object
    /// with no slot is not in the atlas (size 0).
    pub fn gpu_entry(&self, object: usize) -> GpuAtlasEntry {
        let mut e = GpuAtlasEntry::zeroed();
        if let Some(o) = self.objects[object].as_ref().filter(|o| o.slot.is_some()) {
            e.size = o.size >> o.first;
            e.level_count = (o.levels.len() - o.first) as u32;
            for (g, l) in e.levels.iter_mut().zip(&o.levels[o.first..]) {
                *g = GpuAtlasLevel { size: l.size, page_base: l.page_base, tile_base: l.tile_base, pad: 0 };
            }
        }
        e
    }

    /// The table the GPU passes read, one entry per scene object.
    pub fn gpu_entries(&self) -> Vec<GpuAtlasEntry> {
        (0..self.objects.len()).map(|o| self.gpu_entry(o)).collect()
    }

    /// Virtual texels of all objects (mip chains included).
    pub fn virtual_texels(&self) -> u64 {
        self.objects.iter().flatten().map(|o| o.texels()).sum()
    }

    /// Where virtual page `page` lies: (object, level (an index into the
    /// object's `levels`), its first texel in the level). `None` past the last page, or for a number of a block's
    /// part outside its level.
    pub fn page_origin(&self, page: u32) -> Option<(usize, usize, [u32; 2])> {
        for (object, o) in self.objects.iter().enumerate() {
            let Some(o) = o.as_ref().filter(|o| o.slot.is_some()) else { continue };
            for (level, l) in o.levels.iter().enumerate().skip(o.first) {
                if (l.page_base as u64..l.page_base as u64 + l.page_numbers(self.page_size)).contains(&(page as u64)) {
                    let [x, y] = l.page_position(self.page_size, page - l.page_base).map(|p| p * self.page_size);
                    return (x < l.size && y < l.size).then_some((object, level, [x, y]));
                }
            }
        }
        None
    }
}

/// The physical atlas: `pages` pages of `page_size` texels a side, in
/// `layers` layers of `layer_pages` x `layer_pages` pages of a 2D array
/// texture. The atlas grows and shrinks by whole layers
/// ([`super::residency`]), so a page keeps its place when layers are added
/// or the last ones taken away.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PagePool {
    pub page_size: u32,
    pub pages: u32,
    pub layer_pages: u32,
    pub layers: u32,
}

/// Layers a pool of the full budget is cut into: the steps in which the
/// atlas grows and shrinks (3 % of the budget each).
pub const BUDGET_LAYERS: u64 = 32;

impl PagePool {
    /// A pool of at least `texels` texels (at least one page), in about
    /// [`BUDGET_LAYERS`] square layers no wider than `max_side`.
    pub fn new(page_size: u32, texels: u64, max_side: u32) -> Self {
        let wanted = texels.div_ceil(page_size as u64 * page_size as u64).max(1);
        let layer_pages =
            ((wanted as f64 / BUDGET_LAYERS as f64).sqrt().ceil() as u32).clamp(1, (max_side / page_size).max(1));
        let per_layer = layer_pages as u64 * layer_pages as u64;
        Self { page_size, pages: 0, layer_pages, layers: 0 }.with_layers(wanted.div_ceil(per_layer) as u32)
    }

    /// The same pool cut to `layers` layers (its pages keep their places).
    pub fn with_layers(self, layers: u32) -> Self {
        let pages = (self.layer_page_count() as u64 * layers as u64).min(u32::MAX as u64) as u32;
        Self { pages, layers, ..self }
    }

    /// Pages per layer.
    pub fn layer_page_count(&self) -> u32 {
        self.layer_pages * self.layer_pages
    }

    pub fn texels(&self) -> u64 {
        self.pages as u64 * self.page_size as u64 * self.page_size as u64
    }

    /// Physical page `page`'s first texel: (x, y, layer).
    pub fn origin(&self, page: u32) -> (u32, u32, u32) {
        let per_layer = self.layer_pages * self.layer_pages;
        let (layer, i) = (page / per_layer, page % per_layer);
        (i % self.layer_pages * self.page_size, i / self.layer_pages * self.page_size, layer)
    }

    /// A 2D array texture holding the pool: the shading atlas and the
    /// triangle-index maps share this layout, texel for texel.
    pub fn texture(
        &self,
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        let side = self.layer_pages * self.page_size;
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: side, height: side, depth_or_array_layers: self.layers },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }
}

gpu_struct! {
    pub struct GpuAtlasLevel as "AtlasLevel" {
        pub size: u32,
        pub page_base: u32,
        pub tile_base: u32,
        pub pad: u32,
    }
}

gpu_struct! {
    /// One object's row of the atlas table (`AtlasEntry` in `objectspace.wgsl`).
    pub struct GpuAtlasEntry as "AtlasEntry" {
        /// Mip-0 side in texels; 0 for objects not in the atlas.
        pub size: u32,
        pub level_count: u32,
        /// Shades older than this frame stamp are stale (lights or object changed).
        pub valid_since: u32,
        /// The budget's bias for this object (by its screen importance), added
        /// to its pixels' levels.
        pub mip_bias: f32,
        pub levels: [GpuAtlasLevel; MAX_LEVELS],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_number_pages_and_tiles_contiguously() {
        let sizes = [Some(1024), Some(256), None, Some(512), Some(64)];
        let a = AtlasLayout::new(&sizes, 16, 64, 16384, 64).unwrap();
        // Levels: 1024 -> 64 is 5 levels.
        assert_eq!(a.objects[0].as_ref().unwrap().levels.len(), 5);
        assert!(a.objects[2].is_none());
        // Pages of 64 texels hold 16 tiles of 16.
        assert_eq!(a.tiles_per_page(), 16);
        let pages = {
            let mut pages = 0;
            for o in a.objects.iter().flatten() {
                assert_eq!(o.slot, Some(pages));
                let mut span = 0;
                for l in &o.levels {
                    assert_eq!((l.page_base, l.tile_base), (pages + span, (pages + span) * 16));
                    // Whole blocks of 4x4 pages of 64 texels.
                    span += (l.size / 64).div_ceil(4).pow(2) * 16;
                }
                assert_eq!(o.span, span.next_multiple_of(SLOT_ALIGN));
                pages += o.span;
            }
            pages
        };
        let tiles = pages * 16;
        assert_eq!((a.tile_count, a.page_count), (tiles, pages));
        // Object 1's level 2 (64 texels) is one page; its origin is found
        // back, and the rest of its block is outside the level.
        let l = a.objects[1].as_ref().unwrap().levels[2];
        assert_eq!(a.page_origin(l.page_base), Some((1, 2, [0, 0])));
        assert_eq!(a.page_origin(l.page_base + 1), None);
        // Object 0's level 0: 16x16 pages, 4x4 blocks. Page 11 of block 2
        // is page (8 + 3, 2).
        let l0 = a.objects[0].as_ref().unwrap().levels[0];
        assert_eq!(a.page_origin(l0.page_base + 2 * 16 + 11), Some((0, 0, [11 * 64, 2 * 64])));
        assert_eq!(l0.page_number(64, [11, 2]), l0.page_base + 2 * 16 + 11);
        assert_eq!(a.page_origin(a.page_count), None);
    }

    #[test]
    fn page_numbers_and_positions_are_inverse() {
        let l = AtlasLevel { size: 1000, page_base: 128, tile_base: 0, offset: 0 };
        let per_row = l.pages_per_row(16);
        for y in 0..per_row {
            for x in 0..per_row {
                let n = l.page_number(16, [x, y]);
                assert!((l.page_base as u64..l.page_base as u64 + l.page_numbers(16)).contains(&(n as u64)));
                assert_eq!(l.page_position(16, n - l.page_base), [x, y]);
            }
        }
    }

    #[test]
    fn a_level_smaller_than_a_block_takes_one_block() {
        let a = AtlasLayout::new(&[Some(256)], 32, 128, 16384, 32).unwrap();
        let sizes: Vec<u32> = a.objects[0].as_ref().unwrap().levels.iter().map(|l| l.size).collect();
        assert_eq!(sizes, vec![256, 128, 64, 32]);
        assert_eq!(a.page_count, 4 * BLOCK_PAGES);
    }

    #[test]
    fn sizes_are_clamped_and_checked() {
        let a = AtlasLayout::new(&[Some(4), Some(1 << 15)], 16, 64, 2048, 16).unwrap();
        assert_eq!(a.objects[0].as_ref().unwrap().size, 16);
        assert_eq!(a.objects[0].as_ref().unwrap().levels.len(), 1);
        assert_eq!(a.objects[1].as_ref().unwrap().size, 2048);
        assert_eq!(
            AtlasLayout::new(&[Some(300)], 8, 16, 2048, 8).unwrap_err(),
            AtlasError::NotPowerOfTwo { object: 0, size: 300 }
        );
        assert_eq!(AtlasLayout::new(&[Some(256)], 12, 64, 2048, 8).unwrap_err(), AtlasError::BadTileSize(12));
        assert_eq!(
            AtlasLayout::new(&[Some(256)], 32, 16, 2048, 8).unwrap_err(),
            AtlasError::BadPageSize { page: 16, tile: 32 }
        );
        // A page holds at most 16 tiles (one mask word of requests).
        assert_eq!(
            AtlasLayout::new(&[Some(256)], 8, 64, 2048, 8).unwrap_err(),
            AtlasError::BadPageSize { page: 64, tile: 8 }
        );
    }

    #[test]
    fn coarsest_levels_are_per_object_and_at_least_a_tile() {
        // 256 down to 128: two levels; down to one texel, raised to the tile: 256 .. 8, six.
        let a = AtlasLayout::with_coarsest(&[Some(256), Some(256), None], 8, 16, 4096, &[128, 1]).unwrap();
        let levels: Vec<usize> = a.objects.iter().map(|o| o.as_ref().map_or(0, |o| o.levels.len())).collect();
        assert_eq!(levels, [2, 6, 0]);
        assert_eq!(a.objects[1].as_ref().unwrap().levels[5].size, 8);
    }

    #[test]
    fn objects_move_between_slots_and_leave_the_table_without_one() {
        let mut a = AtlasLayout::new(&[Some(256), None, Some(64)], 8, 16, 4096, 8).unwrap();
        let before = a.gpu_entries();
        let span = a.objects[2].as_ref().unwrap().span;
        a.place(2, Some(1024), 0);
        let o = a.objects[2].as_ref().unwrap();
        assert_eq!(o.levels[0].page_base, 1024);
        assert_eq!(o.levels[1].page_base, 1024 + o.levels[1].offset);
        assert_eq!(o.levels[1].tile_base, o.levels[1].page_base * 4);
        assert_eq!(a.page_origin(1024), Some((2, 0, [0, 0])));
        assert!(o.levels.iter().all(|l| l.page_base < 1024 + span));
        // Out of its slot: the passes see no texture, and no page is its.
        a.place(2, None, 0);
        assert_eq!(a.gpu_entry(2).size, 0);
        assert_eq!(a.page_origin(1024), None);
        let bytes = bytemuck::bytes_of::<GpuAtlasEntry>;
        assert_eq!(bytes(&a.gpu_entry(0)), bytes(&before[0]));
        // Back where it was: the same row as at first.
        a.place(2, before[2].levels[0].page_base.into(), 0);
        assert_eq!(bytes(&a.gpu_entry(2)), bytes(&before[2]));
    }

    #[test]
    fn pools_are_cut_into_layers_that_keep_their_pages() {
        // 10 pages in about 32 layers: layers of one page.
        let p = PagePool::new(64, 10 * 64 * 64, 8192);
        assert_eq!((p.layer_pages, p.layers, p.pages), (1, 10, 10));
        assert_eq!(p.origin(5), (0, 0, 5));
        // 3200 pages: 32 layers of 10x10.
        let p = PagePool::new(8, 3200 * 64, 8192);
        assert_eq!((p.layer_pages, p.layers, p.pages), (10, 32, 3200));
        assert_eq!(p.origin(123), (3 * 8, 2 * 8, 1));
        // Grown or shrunk by whole layers, a page stays where it was.
        for layers in [1, 5, 40] {
            let q = p.with_layers(layers);
            assert_eq!((q.layer_pages, q.pages), (10, layers * 100));
            assert_eq!(q.origin(57), p.origin(57));
        }
        // A pool wider than the largest texture takes more layers.
        let p = PagePool::new(64, 5000 * 64 * 64, 256);
        assert_eq!((p.layer_pages, p.layers, p.pages), (4, 313, 313 * 16));
        assert_eq!(p.origin(17), (64, 0, 1));
        assert_eq!(PagePool::new(64, 0, 8192).pages, 1);
    }
}
