//! Where every object's shading texture lives: each mip level of each object
//! is a square in one page of a shared physical atlas (a 2D array texture),
//! and its tiles are numbered in one flat index space for the tile buffers.
//!
//! Sizes are powers of two, so a buddy allocator packs the squares without
//! waste. The per-object table ([`GpuAtlasEntry`]) is what the GPU passes read;
//! a page table can replace its rectangles later without changing the passes.

use bytemuck::Zeroable;

use crate::shaders::gpu_struct;

/// Most mip levels an object can have (a 16384 texture down to 8x8 tiles is 12).
pub const MAX_LEVELS: usize = 14;

/// One mip level of one object in the atlas.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLevel {
    pub page: u32,
    pub x: u32,
    pub y: u32,
    pub size: u32,
    /// Global index of the level's first tile.
    pub tile_base: u32,
}

/// An object's shading texture: its size (mip 0) and levels.
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
    #[error("object {object}: texture size {size} is not a power of two")]
    NotPowerOfTwo { object: usize, size: u32 },
    #[error("the atlas needs {tiles} tiles, more than the 2^32 tile indices")]
    TooManyTiles { tiles: u64 },
}

/// The layout of all objects in the atlas pages.
#[derive(Clone, Debug)]
pub struct AtlasLayout {
    pub page_size: u32,
    pub pages: u32,
    pub tile_size: u32,
    /// Per scene object; `None` for objects shaded forward (not in the atlas).
    pub objects: Vec<Option<ObjectAtlas>>,
    pub tile_count: u32,
}

impl AtlasLayout {
    /// Lays out objects of the given shading-texture sizes (`None`: not in the
    /// atlas). Sizes above `max_page` are clamped to it; sizes below the tile
    /// size are raised to it. Levels go down to `coarsest` texels (or one
    /// tile, if larger): below the charts' gutter, neighbouring charts would
    /// share texels.
    pub fn new(sizes: &[Option<u32>], tile_size: u32, max_page: u32, coarsest: u32) -> Result<Self, AtlasError> {
        if ![8, 16, 32, 64].contains(&tile_size) {
            return Err(AtlasError::BadTileSize(tile_size));
        }
        let mut clamped = Vec::with_capacity(sizes.len());
        for (object, s) in sizes.iter().enumerate() {
            clamped.push(match *s {
                Some(size) if !size.is_power_of_two() => return Err(AtlasError::NotPowerOfTwo { object, size }),
                Some(size) => Some(size.clamp(tile_size, max_page)),
                None => None,
            });
        }
        let page_size = clamped.iter().flatten().copied().max().unwrap_or(tile_size);
        let coarsest = coarsest.max(tile_size);
        let level_count = |size: u32| ((size / coarsest.min(size)).ilog2() as usize + 1).min(MAX_LEVELS);
        // Requests (object, level, size), largest first: then buddy splitting never fragments.
        let mut requests: Vec<(usize, usize, u32)> = Vec::new();
        for (object, size) in clamped.iter().enumerate() {
            if let Some(size) = size {
                requests.extend((0..level_count(*size)).map(|l| (object, l, size >> l)));
            }
        }
        requests.sort_by(|a, b| b.2.cmp(&a.2).then(a.0.cmp(&b.0)).then(a.1.cmp(&b.1)));
        let mut buddy = Buddy::new(page_size);
        let mut placed: Vec<Vec<Option<AtlasLevel>>> =
            clamped.iter().map(|s| vec![None; s.map_or(0, level_count)]).collect();
        for &(object, level, size) in &requests {
            let (page, x, y) = buddy.alloc(size);
            placed[object][level] = Some(AtlasLevel { page, x, y, size, tile_base: 0 });
        }
        // Tile numbering in object, level order (stable, independent of packing).
        let mut next: u64 = 0;
        let mut objects = Vec::with_capacity(sizes.len());
        for (object, size) in clamped.iter().enumerate() {
            objects.push(size.map(|size| {
                let levels = placed[object]
                    .iter()
                    .map(|l| {
                        let mut l = l.expect("every requested level was placed");
                        l.tile_base = next as u32;
                        next += (l.size / tile_size) as u64 * (l.size / tile_size) as u64;
                        l
                    })
                    .collect();
                ObjectAtlas { size, levels }
            }));
        }
        if next > u32::MAX as u64 {
            return Err(AtlasError::TooManyTiles { tiles: next });
        }
        Ok(Self { page_size, pages: buddy.pages, tile_size, objects, tile_count: next as u32 })
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
                        *g = GpuAtlasLevel {
                            page: l.page,
                            origin: l.x | (l.y << 16),
                            size: l.size,
                            tile_base: l.tile_base,
                        };
                    }
                }
                e
            })
            .collect()
    }

    /// A 2D array texture with one layer per page: the shading atlas and the
    /// triangle-index maps share this layout, texel for texel. A layout with
    /// no page (every object shaded forward) still gets one layer, since a
    /// texture cannot be empty.
    pub fn page_array_texture(
        &self,
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: self.page_size,
                height: self.page_size,
                depth_or_array_layers: self.pages.max(1),
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    }

    pub fn atlas_texels(&self) -> u64 {
        self.pages as u64 * self.page_size as u64 * self.page_size as u64
    }
}

/// Oxide's stable shading budget: while the objects' texels (mip chains
/// included) exceed `budget_texels`, every object's side is halved (down to
/// `min_side`), so shading density drops uniformly and no scene overflows.
/// Returns the sizes and how many times they were halved.
pub fn fit_budget(sizes: &[Option<u32>], budget_texels: u64, min_side: u32) -> (Vec<Option<u32>>, u32) {
    let texels = |sizes: &[Option<u32>]| sizes.iter().flatten().map(|&s| s as u64 * s as u64 * 4 / 3).sum::<u64>();
    let mut sizes = sizes.to_vec();
    let mut halvings = 0;
    while texels(&sizes) > budget_texels && sizes.iter().flatten().any(|&s| s > min_side) {
        for s in sizes.iter_mut().flatten() {
            *s = (*s / 2).max(min_side);
        }
        halvings += 1;
    }
    (sizes, halvings)
}

/// A square's place: (page, x, y).
type Spot = (u32, u32, u32);

/// Buddy allocator over square pages of a power-of-two side.
struct Buddy {
    page_size: u32,
    pages: u32,
    /// Free squares by side: (side, [(page, x, y)]).
    free: Vec<(u32, Vec<Spot>)>,
}

impl Buddy {
    fn new(page_size: u32) -> Self {
        Self { page_size, pages: 0, free: Vec::new() }
    }

    fn free_list(&mut self, size: u32) -> &mut Vec<Spot> {
        let i = match self.free.iter().position(|(s, _)| *s == size) {
            Some(i) => i,
            None => {
                self.free.push((size, Vec::new()));
                self.free.len() - 1
            }
        };
        &mut self.free[i].1
    }

    fn alloc(&mut self, size: u32) -> Spot {
        if let Some(spot) = self.free_list(size).pop() {
            return spot;
        }
        if size >= self.page_size {
            self.pages += 1;
            return (self.pages - 1, 0, 0);
        }
        let (page, x, y) = self.alloc(size * 2);
        // Keep the first quadrant; the other three become free, pushed in
        // reverse so the next allocation takes the lowest address.
        let list = self.free_list(size);
        list.extend([(page, x + size, y + size), (page, x, y + size), (page, x + size, y)]);
        (page, x, y)
    }
}

gpu_struct! {
    pub struct GpuAtlasLevel as "AtlasLevel" {
        pub page: u32,
        /// x | y << 16, in texels of the page.
        pub origin: u32,
        pub size: u32,
        pub tile_base: u32,
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
        /// Per-object mip bias, added to every pixel's level.
        pub mip_bias: f32,
        pub levels: [GpuAtlasLevel; MAX_LEVELS],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn overlaps(a: &AtlasLevel, b: &AtlasLevel) -> bool {
        a.page == b.page && a.x < b.x + b.size && b.x < a.x + a.size && a.y < b.y + b.size && b.y < a.y + a.size
    }

    #[test]
    fn levels_are_disjoint_inside_pages_and_tiles_are_contiguous() {
        let sizes = [Some(1024), Some(256), None, Some(512), Some(64), Some(1024)];
        let a = AtlasLayout::new(&sizes, 8, 4096, 8).unwrap();
        assert_eq!(a.page_size, 1024);
        let all: Vec<AtlasLevel> = a.objects.iter().flatten().flat_map(|o| o.levels.clone()).collect();
        for (i, x) in all.iter().enumerate() {
            assert!(x.x + x.size <= a.page_size && x.y + x.size <= a.page_size && x.page < a.pages);
            for y in &all[i + 1..] {
                assert!(!overlaps(x, y), "{x:?} overlaps {y:?}");
            }
        }
        // Levels: 1024 -> 8 is 8 levels.
        assert_eq!(a.objects[0].as_ref().unwrap().levels.len(), 8);
        assert!(a.objects[2].is_none());
        // Tile bases are contiguous in object, level order.
        let mut expected = 0;
        for o in a.objects.iter().flatten() {
            for l in &o.levels {
                assert_eq!(l.tile_base, expected);
                expected += (l.size / 8) * (l.size / 8);
            }
        }
        assert_eq!(a.tile_count, expected);
        // Texels used fit the pages with little waste (buddy packing of sorted squares).
        let used: u64 = a.objects.iter().flatten().map(|o| o.texels()).sum();
        assert!(used <= a.atlas_texels() && used * 2 > a.atlas_texels(), "used {used} of {}", a.atlas_texels());
    }

    #[test]
    fn mip_chains_stop_at_the_coarsest_level() {
        let a = AtlasLayout::new(&[Some(1024), Some(64)], 8, 4096, 128).unwrap();
        let sizes: Vec<u32> = a.objects[0].as_ref().unwrap().levels.iter().map(|l| l.size).collect();
        assert_eq!(sizes, vec![1024, 512, 256, 128]);
        assert_eq!(a.objects[1].as_ref().unwrap().levels.len(), 1);
    }

    #[test]
    fn budget_halves_every_object_until_it_fits() {
        let (sizes, halvings) = fit_budget(&[Some(4096), Some(1024), None, Some(64)], 2 * 1024 * 1024, 64);
        assert_eq!(halvings, 2);
        assert_eq!(sizes, vec![Some(1024), Some(256), None, Some(64)]);
        let (same, none) = fit_budget(&[Some(256)], 1 << 20, 64);
        assert_eq!((same, none), (vec![Some(256)], 0));
    }

    #[test]
    fn sizes_are_clamped_and_checked() {
        let a = AtlasLayout::new(&[Some(4), Some(1 << 15)], 16, 2048, 16).unwrap();
        assert_eq!(a.objects[0].as_ref().unwrap().size, 16);
        assert_eq!(a.objects[0].as_ref().unwrap().levels.len(), 1);
        assert_eq!(a.objects[1].as_ref().unwrap().size, 2048);
        assert_eq!(
            AtlasLayout::new(&[Some(300)], 8, 2048, 8).unwrap_err(),
            AtlasError::NotPowerOfTwo { object: 0, size: 300 }
        );
        assert_eq!(AtlasLayout::new(&[Some(256)], 12, 2048, 8).unwrap_err(), AtlasError::BadTileSize(12));
    }
}
