//! Where every object's shading texture lives. Each object's texture (its
//! whole mip pyramid, up to 16384 texels a side) is *virtual*: its levels
//! are cut into square pages, numbered in one flat virtual page space, and
//! only the pages that visible tiles need are backed by a page of the shared
//! physical atlas ([`PagePool`]), through a two-level page table the GPU
//! keeps (`paging/`). Pages are numbered in blocks of [`BLOCK_SIDE`] x
//! [`BLOCK_SIDE`] (a level's blocks row-major, the pages of a block
//! row-major): the page directory has one word per block, and only the
//! blocks holding backed pages have a table chunk of one word per page, so
//! the table grows with the pages in use, not with the virtual space. Tiles keep a flat virtual numbering too (the shade queue and
//! the CPU twin speak of virtual tiles); their state lives with the physical
//! page that backs them.

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

/// One mip level of one object's virtual texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLevel {
    pub size: u32,
    /// Virtual index of the level's first page (a multiple of
    /// [`BLOCK_PAGES`]: the level's pages are numbered block by block).
    pub page_base: u32,
    /// Global index of the level's first tile (tiles row-major).
    pub tile_base: u32,
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

/// An object's virtual shading texture: its size (mip 0) and levels.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjectAtlas {
    pub size: u32,
    pub levels: Vec<AtlasLevel>,
}

impl ObjectAtlas {
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
    /// Virtual tiles, all objects and levels.
    pub tile_count: u32,
    /// Virtual page numbers, all objects and levels (a multiple of
    /// [`BLOCK_PAGES`]).
    pub page_count: u32,
}

impl AtlasLayout {
    /// Lays out objects of the given shading-texture sizes (`None`: not in the
    /// atlas). Sizes above `max_size` are clamped to it; sizes below the tile
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
        if ![8, 16, 32, 64].contains(&tile_size) {
            return Err(AtlasError::BadTileSize(tile_size));
        }
        if !page_size.is_power_of_two() || page_size < tile_size || page_size > 4 * tile_size {
            return Err(AtlasError::BadPageSize { page: page_size, tile: tile_size });
        }
        let (mut tiles, mut pages) = (0u64, 0u64);
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
            let levels = (0..count)
                .map(|l| {
                    let level = AtlasLevel {
                        size: size >> l,
                        page_base: pages as u32,
                        tile_base: tiles.min(u32::MAX as u64) as u32,
                    };
                    tiles += ((size >> l) / tile_size) as u64 * ((size >> l) / tile_size) as u64;
                    pages += level.page_numbers(page_size);
                    level
                })
                .collect();
            objects.push(Some(ObjectAtlas { size, levels }));
        }
        if tiles > u32::MAX as u64 {
            return Err(AtlasError::TooManyTiles { tiles });
        }
        if pages > u32::MAX as u64 {
            return Err(AtlasError::TooManyPages { pages });
        }
        Ok(Self { page_size, tile_size, objects, tile_count: tiles as u32, page_count: pages as u32 })
    }

    /// [`AtlasLayout::new`], with every object's side halved (down to 64)
    /// until the layout has at most `max_pages` virtual pages: virtual pages
    /// are numbered in 32 bits, and the page directory and request bits grow
    /// with them. Returns the layout and the halvings.
    pub fn fitting(
        sizes: &[Option<u32>],
        tile_size: u32,
        page_size: u32,
        max_size: u32,
        coarsest: &[u32],
        max_pages: u64,
    ) -> Result<(Self, u32), AtlasError> {
        let mut sizes: Vec<Option<u32>> = sizes.iter().map(|s| s.map(|s| s.min(max_size))).collect();
        let mut halvings = 0;
        loop {
            let can_halve = sizes.iter().flatten().any(|&s| s > 64);
            match Self::with_coarsest(&sizes, tile_size, page_size, max_size, coarsest) {
                Ok(layout) if layout.page_count as u64 <= max_pages || !can_halve => return Ok((layout, halvings)),
                Err(AtlasError::TooManyPages { .. } | AtlasError::TooManyTiles { .. }) if can_halve => {}
                Ok(_) => {}
                Err(e) => return Err(e),
            }
            for s in sizes.iter_mut().flatten() {
                *s = (*s / 2).max(64);
            }
            halvings += 1;
        }
    }

    /// The table the GPU passes read, one entry per scene object.
    pub fn gpu_entries(&self) -> Vec<GpuAtlasEntry> {
        self.objects
            .iter()
            .map(|o| {
                let mut e = GpuAtlasEntry::zeroed();
                if let Some(o) = o {
                    e.size = o.size;
                    e.level_count = o.levels.len() as u32;
                    for (g, l) in e.levels.iter_mut().zip(&o.levels) {
                        *g = GpuAtlasLevel { size: l.size, page_base: l.page_base, tile_base: l.tile_base, pad: 0 };
                    }
                }
                e
            })
            .collect()
    }

    /// Virtual texels of all objects (mip chains included).
    pub fn virtual_texels(&self) -> u64 {
        self.objects.iter().flatten().map(|o| o.texels()).sum()
    }

    /// Where virtual page `page` lies: (object, level, its first texel in
    /// the level). `None` past the last page, or for a number of a block's
    /// part outside its level.
    pub fn page_origin(&self, page: u32) -> Option<(usize, usize, [u32; 2])> {
        for (object, o) in self.objects.iter().enumerate() {
            let Some(o) = o else { continue };
            for (level, l) in o.levels.iter().enumerate() {
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
        let t = 16;
        assert!(a.objects[2].is_none());
        let (mut tiles, mut pages) = (0, 0);
        for o in a.objects.iter().flatten() {
            for l in &o.levels {
                assert_eq!((l.tile_base, l.page_base), (tiles, pages));
                tiles += (l.size / t) * (l.size / t);
                // Whole blocks of 4x4 pages of 64 texels.
                pages += (l.size / 64).div_ceil(4).pow(2) * 16;
            }
        }
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
        let l = AtlasLevel { size: 1000, page_base: 128, tile_base: 0 };
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
    fn large_virtual_spaces_are_halved_until_the_page_table_fits() {
        let sizes = [Some(8192), Some(4096), None];
        let (full, none) = AtlasLayout::fitting(&sizes, 8, 16, 16384, &[128], 1 << 30).unwrap();
        assert_eq!(none, 0);
        let (fit, halvings) = AtlasLayout::fitting(&sizes, 8, 16, 16384, &[128], full.page_count as u64 / 3).unwrap();
        assert_eq!(halvings, 1);
        assert!(fit.page_count as u64 <= full.page_count as u64 / 3);
        assert_eq!(fit.objects[0].as_ref().unwrap().size, 4096);
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
