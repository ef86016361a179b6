//! Read-backs of object-space state for debugging and tests (they block on
//! the GPU, so they stay out of the frame loop).

use super::ObjectSpace;
use super::atlas::BLOCK_PAGES;
use super::resources::{ATLAS_FORMAT, TRIANGLE_MAP_FORMAT};
use crate::color::reinhard_srgb8;
use crate::gpu::{GpuContext, GpuError, readback};
use crate::render::RenderError;
use crate::render::passes::visibility::VisibilityBuffer;
use crate::render::scene_gpu::SceneGpu;
use crate::shaders::ShaderLibrary;

/// Per virtual page backed: its triangle map's and its shades' texel bytes
/// ([`ObjectSpace::read_backed_pages`]).
pub type BackedPages = std::collections::BTreeMap<u32, (Vec<u8>, Vec<u8>)>;

/// The object-space marking state after a frame, read back from the GPU,
/// with the tile state of the backed pages translated to virtual tiles.
#[derive(Clone, Debug)]
pub struct MarkState {
    /// The frame's stamp (frames rendered so far; 0 in the tile buffers means never).
    pub stamp: u32,
    /// Per scene object: shades stamped before this are stale.
    pub valid_since: Vec<u32>,
    /// Stamp of the first frame with this frame's view.
    pub view_since: u32,
    /// Per pixel, row-major, its [`Self::samples`] side by side: (object +
    /// 1, triangle); object 0 = background.
    pub visibility: Vec<[u32; 2]>,
    /// Samples per pixel of [`Self::visibility`].
    pub samples: u32,
    /// Per virtual tile: stamp of the last frame it was visible (0 for
    /// tiles on pages with no physical page).
    pub tile_visible: Vec<u32>,
    /// Per virtual tile: stamp of the last frame it was shaded.
    pub tile_shaded: Vec<u32>,
    /// This frame's shade queue: (virtual tile, object << 8 | level), in
    /// physical tile order.
    pub queue: Vec<[u32; 2]>,
    /// Indexed by [`super::TileCounter`].
    pub counters: [u32; super::TileCounter::SLOTS],
    /// Per physical page: the virtual page it backs, if any.
    pub page_owner: Vec<Option<u32>>,
}

/// Whether a pixel's samples see one surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coverage {
    /// Every sample sees the background.
    Background,
    /// Every sample sees one chart surface (the gather reads the pixel once).
    Interior,
    /// Samples see different surfaces (under MSAA: the gather reads each
    /// group of samples on one surface; with
    /// [`super::MsaaGather::Sample`], any pixel of more than one sample
    /// gathered, each sample its own group).
    Edge,
}

/// Where a pixel's shade comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadeSource {
    /// Filtered from the atlas.
    Atlas,
    /// Its object is not in the atlas: shaded per pixel in the gather.
    Forward,
    /// A tap's page had no physical page (the atlas was full): shaded per pixel.
    NotBacked,
}

/// Which of the taps of the gather's filter lie in the pixel's chart island.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IslandTaps {
    All,
    /// Some: the filter renormalizes over the others (near a chart border).
    Some,
    /// None: the filter keeps all of them (a sliver thinner than a texel).
    None,
}

/// What the gather read for one pixel in the last frame
/// ([`ObjectSpace::read_pixel_classes`]; for an edge pixel, for its first
/// sample on a surface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelClass {
    pub coverage: Coverage,
    /// `None` for background pixels.
    pub source: Option<ShadeSource>,
    /// The level read (of the two blended, the one of the larger weight).
    pub level: u32,
    /// Texels of that level per pixel along the footprint's longer axis
    /// (below 1: a texel is larger than the pixel, magnified).
    pub texels_per_pixel: f32,
    /// The same along the footprint's shorter axis (anisotropic footprints,
    /// seen at a grazing angle, have fewer: there a texel is longer than a
    /// pixel).
    pub texels_per_pixel_minor: f32,
    /// Atlas pixels only.
    pub taps: IslandTaps,
    /// Frames since the tile under the pixel was shaded (0: this frame), at most 255. Atlas pixels only.
    pub age: u32,
    /// Blended between two levels (`--level-blend`).
    pub blended: bool,
}

impl PixelClass {
    /// Decodes the `classify` pass's words (`gather.wgsl`, `CLASS_*`).
    pub fn from_words([x, y, z, _]: [u32; 4]) -> Self {
        let coverage = match x & 3 {
            0 => Coverage::Background,
            1 => Coverage::Interior,
            _ => Coverage::Edge,
        };
        let source = match (coverage, x >> 2 & 3) {
            (Coverage::Background, _) => None,
            (_, 0) => Some(ShadeSource::Atlas),
            (_, 1) => Some(ShadeSource::Forward),
            _ => Some(ShadeSource::NotBacked),
        };
        let taps = match x >> 8 & 3 {
            0 => IslandTaps::All,
            1 => IslandTaps::Some,
            _ => IslandTaps::None,
        };
        Self {
            coverage,
            source,
            level: x >> 4 & 15,
            texels_per_pixel: f32::from_bits(y),
            texels_per_pixel_minor: f32::from_bits(z),
            taps,
            age: x >> 10 & 255,
            blended: x >> 18 & 1 == 1,
        }
    }
}

/// The two-level page table after a frame, read back from the GPU.
#[derive(Clone, Debug)]
pub struct PageTableState {
    /// Per physical page: the virtual page it backs + 1 (0: free).
    pub owners: Vec<u32>,
    /// Per block of virtual pages: its chunk + 1 (0: none).
    pub directory: Vec<u32>,
    /// Per chunk, per page of its block: physical page + 1 (0: not backed).
    pub table: Vec<u32>,
    /// Per chunk: (backed pages it counts, its block + 1).
    pub chunks: Vec<[u32; 2]>,
}

impl PageTableState {
    /// Everything that disagrees between the levels of the table and the
    /// page owners (empty when consistent): every backed page is found
    /// through its block's chunk, every table word names a page that owns
    /// it back, every chunk counts its words and belongs to the block that
    /// points at it. (A chunk the frame's allocation left with no page
    /// keeps its block until the next frame's ranking frees it:
    /// [`Self::empty_chunks`].)
    pub fn inconsistencies(&self) -> Vec<String> {
        let block_pages = BLOCK_PAGES as usize;
        let mut out = Vec::new();
        let chunk_of = |block: usize| self.directory.get(block).and_then(|c| c.checked_sub(1)).map(|c| c as usize);
        for (physical, &owner) in self.owners.iter().enumerate() {
            let Some(page) = owner.checked_sub(1).map(|p| p as usize) else { continue };
            let word = chunk_of(page / block_pages).map(|c| self.table[c * block_pages + page % block_pages]);
            if word != Some(physical as u32 + 1) {
                out.push(format!("physical page {physical} backs virtual page {page}, the table says {word:?}"));
            }
        }
        for (c, &[pages, block]) in self.chunks.iter().enumerate() {
            let words = &self.table[c * block_pages..(c + 1) * block_pages];
            let backed = words.iter().filter(|&&w| w != 0).count() as u32;
            if backed != pages {
                out.push(format!("chunk {c} counts {pages} pages and holds {backed}"));
            }
            match block.checked_sub(1) {
                None if backed > 0 => out.push(format!("free chunk {c} holds {backed} pages")),
                None => {}
                Some(b) if chunk_of(b as usize) != Some(c) => {
                    out.push(format!("chunk {c} of block {b} is not its chunk"))
                }
                Some(_) if backed == 0 => {}
                Some(b) => {
                    for (i, &w) in words.iter().enumerate().filter(|(_, w)| **w != 0) {
                        let page = b * BLOCK_PAGES + i as u32;
                        if self.owners.get(w as usize - 1) != Some(&(page + 1)) {
                            out.push(format!(
                                "virtual page {page} maps to physical page {}, which backs another",
                                w - 1
                            ));
                        }
                    }
                }
            }
        }
        out
    }

    /// Chunks given to a block (holding pages, or left with none by the
    /// frame's allocation).
    pub fn chunks_in_use(&self) -> usize {
        self.chunks.iter().filter(|c| c[1] != 0).count()
    }

    /// The chunks given to a block that hold no page, as (chunk, block).
    pub fn empty_chunks(&self) -> Vec<(usize, u32)> {
        (self.chunks.iter().enumerate())
            .filter(|(_, [pages, block])| *block != 0 && *pages == 0)
            .map(|(c, [_, block])| (c, block - 1))
            .collect()
    }
}

impl ObjectSpace {
    /// The page table and page owners after the last frame.
    pub fn read_page_table(&self, ctx: &GpuContext) -> Result<PageTableState, GpuError> {
        let res = &self.res;
        Ok(PageTableState {
            owners: Self::words(ctx, &res.physical.page_owner)?,
            directory: Self::words(ctx, &res.page_directory)?,
            table: Self::words(ctx, &res.page_table)?,
            chunks: Self::words(ctx, &res.table_chunks)?.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
        })
    }

    fn words(ctx: &GpuContext, b: &wgpu::Buffer) -> Result<Vec<u32>, GpuError> {
        Ok(bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, b)?))
    }

    /// Calls `f(virtual tile, physical tile)` for every tile of every backed page.
    fn backed_tiles(&self, page_owner: &[Option<u32>], mut f: impl FnMut(usize, usize)) {
        let (page, tile) = (self.layout.page_size, self.layout.tile_size);
        let per_row = page / tile;
        for (physical, owner) in page_owner.iter().enumerate() {
            let Some((object, level, origin)) = owner.and_then(|v| self.layout.page_origin(v)) else { continue };
            let l = self.layout.objects[object].as_ref().expect("pages belong to atlas objects").levels[level];
            for t in 0..per_row * per_row {
                let (x, y) = (origin[0] + t % per_row * tile, origin[1] + t / per_row * tile);
                if x < l.size && y < l.size {
                    let virtual_tile = l.tile_base + y / tile * (l.size / tile) + x / tile;
                    f(virtual_tile as usize, (physical as u32 * per_row * per_row + t) as usize);
                }
            }
        }
    }

    /// The parameters the frame of `state` was marked with (its stamp and
    /// view, this pipeline's settings): what the CPU twin of marking takes.
    pub fn mark_params(&self, state: &MarkState) -> super::cpu::MarkParams {
        let o = self.config();
        super::cpu::MarkParams {
            stamp: state.stamp,
            reuse: o.reuse,
            view_since: state.view_since,
            tile_size: o.tile_size,
            mip_bias: o.mip_bias,
            variable_rate: o.variable_rate,
            level_blend: o.level_blend,
            gather_filter: o.gather_filter,
            aniso: o.aniso,
        }
    }

    /// Per pixel of the main view, row-major: what the last frame's gather
    /// read ([`PixelClass`]), from a debug pass run now over the state the
    /// frame left (its pipeline is built on the first call). Call it after
    /// a frame and before the next; it blocks on the GPU.
    pub fn read_pixel_classes(
        &mut self,
        ctx: &GpuContext,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
    ) -> Result<Vec<PixelClass>, RenderError> {
        let size = (self.res.visibility.texture.width(), self.res.visibility.texture.height());
        if self.classify.is_none() {
            let pixels = u64::from(size.0) * u64::from(size.1);
            let pass = self.gather.classify_pass(&ctx.device, shaders, scene, &self.res, &self.grid.grid, pixels)?;
            self.classify = Some(pass);
        }
        let pass = self.classify.as_ref().expect("built above");
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("classify") });
        let groups = (&self.res, scene.bind_group(), &self.grid.grid);
        super::gather::classify(&mut encoder, &ctx.device, pass, groups, size);
        ctx.queue.submit([encoder.finish()]);
        let words = Self::words(ctx, &pass.classes)?;
        ctx.check_errors()?;
        Ok(words.chunks_exact(4).map(|w| PixelClass::from_words([w[0], w[1], w[2], w[3]])).collect())
    }

    /// The main view's visibility buffer (for tests: its ids per sample
    /// through [`VisibilityBuffer::read_samples`]).
    pub fn visibility_buffer(&self) -> &VisibilityBuffer {
        &self.res.visibility
    }

    /// The marking state after the last frame, for tests that check tile
    /// marking against its CPU twin.
    pub fn read_mark_state(&self, ctx: &GpuContext) -> Result<MarkState, GpuError> {
        let res = &self.res;
        let page_owner: Vec<Option<u32>> =
            Self::words(ctx, &res.physical.page_owner)?.into_iter().map(|o| o.checked_sub(1)).collect();
        let (visible, shaded) =
            (Self::words(ctx, &res.physical.tile_visible)?, Self::words(ctx, &res.physical.tile_shaded)?);
        let tiles = self.layout.tile_count as usize;
        let (mut tile_visible, mut tile_shaded) = (vec![0; tiles], vec![0; tiles]);
        self.backed_tiles(&page_owner, |v, p| {
            tile_visible[v] = visible[p];
            tile_shaded[v] = shaded[p];
        });
        let counters = super::TileCounter::fold(&Self::words(ctx, &res.counters)?);
        // The queue holds an entry per physical tile; those shaded this
        // frame are this frame's.
        let queue = (Self::words(ctx, &res.physical.work_queue)?.chunks_exact(2).zip(&shaded))
            .filter(|&(_, &s)| s == self.frames)
            .map(|(c, _)| [c[0], c[1]])
            .collect();
        Ok(MarkState {
            stamp: self.frames,
            valid_since: res.entry_data.iter().map(|e| e.valid_since).collect(),
            view_since: self.view_since,
            visibility: res.visibility.read_samples(ctx)?,
            samples: res.visibility.samples(),
            tile_visible,
            tile_shaded,
            queue,
            counters,
            page_owner,
        })
    }

    /// Copies texel rows of the backed pages of `object`'s `level` (counted
    /// as in the atlas table: from the finest its slot holds) out of a
    /// physical texture read back whole (`bytes`, `texel` bytes a texel)
    /// into a level-sized image; texels of pages with no physical page keep
    /// `fill`.
    fn gather_level(
        &self,
        ctx: &GpuContext,
        bytes: &[u8],
        texel: usize,
        object: usize,
        level: usize,
        fill: &[u8],
    ) -> Result<(u32, Vec<u8>), GpuError> {
        // `level` counts from the finest level the object's slot holds (as
        // the atlas table the passes read does); the layout's levels from 0.
        let atlas = self.layout.objects.get(object).and_then(|o| o.as_ref());
        let Some((l, level)) = atlas.and_then(|o| o.levels.get(o.first + level).map(|l| (*l, o.first + level))) else {
            return Err(GpuError::Readback(format!("object {object} has no atlas level {level}")));
        };
        let pool = self.res.pool;
        let side = (pool.layer_pages * pool.page_size) as usize;
        let mut out: Vec<u8> = fill.iter().copied().cycle().take(l.size as usize * l.size as usize * texel).collect();
        let owners = Self::words(ctx, &self.res.physical.page_owner)?;
        for (physical, owner) in owners.iter().enumerate() {
            let Some((o, lv, origin)) = owner.checked_sub(1).and_then(|v| self.layout.page_origin(v)) else { continue };
            if (o, lv) != (object, level) {
                continue;
            }
            let (px, py, layer) = pool.origin(physical as u32);
            let rows = pool.page_size.min(l.size - origin[1]);
            let width = pool.page_size.min(l.size - origin[0]) as usize;
            for r in 0..rows {
                let src = ((layer as usize * side + (py + r) as usize) * side + px as usize) * texel;
                let dst = (((origin[1] + r) * l.size + origin[0]) as usize) * texel;
                out[dst..dst + width * texel].copy_from_slice(&bytes[src..src + width * texel]);
            }
        }
        Ok((l.size, out))
    }

    /// One mip level of one object's shades as an image (Reinhard tone
    /// mapped, sRGB), for the atlas debug view; texels of pages with no
    /// physical page are magenta.
    pub fn read_atlas(&self, ctx: &GpuContext, object: usize, level: usize) -> Result<image::RgbaImage, GpuError> {
        let texel = ATLAS_FORMAT.block_copy_size(None).expect("uncompressed format");
        let bytes = self.read_layers(ctx, &self.res.physical.atlas, texel)?;
        let magenta = [half::f16::from_f32(4.0), half::f16::ZERO, half::f16::from_f32(4.0), half::f16::ONE];
        let (size, level_bytes) =
            self.gather_level(ctx, &bytes, texel as usize, object, level, bytemuck::cast_slice(&magenta))?;
        let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&level_bytes);
        let pixels = halves.chunks_exact(4).flat_map(|p| {
            [reinhard_srgb8(p[0].to_f32()), reinhard_srgb8(p[1].to_f32()), reinhard_srgb8(p[2].to_f32()), 255]
        });
        Ok(image::RgbaImage::from_raw(size, size, pixels.collect()).expect("size matches"))
    }

    /// Levels of objects' virtual textures as the GPU holds them, raw: the
    /// shades (`Rgba16Float`, widened to `f32`) and triangle maps of the
    /// backed pages, for the CPU twins of shade and gather
    /// ([`super::cpu::LevelTexels`]). Reads the physical atlas once for all
    /// of `levels` (object, level).
    pub fn read_levels(
        &self,
        ctx: &GpuContext,
        levels: &[(usize, usize)],
    ) -> Result<Vec<super::cpu::LevelTexels>, GpuError> {
        let shade_texel = ATLAS_FORMAT.block_copy_size(None).expect("uncompressed format");
        let id_texel = TRIANGLE_MAP_FORMAT.block_copy_size(None).expect("uncompressed format");
        let shades = self.read_layers(ctx, &self.res.physical.atlas, shade_texel)?;
        let ids = self.read_layers(ctx, &self.res.physical.triangle_map, id_texel)?;
        let mut out = Vec::with_capacity(levels.len());
        for &(object, level) in levels {
            // Texels of pages with no physical page: triangle u32::MAX,
            // which no triangle map holds.
            let nan = [half::f16::NAN; 4];
            let (size, s) =
                self.gather_level(ctx, &shades, shade_texel as usize, object, level, bytemuck::cast_slice(&nan))?;
            let (_, t) = self.gather_level(ctx, &ids, id_texel as usize, object, level, &[0xff; 4])?;
            let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&s);
            let triangles: Vec<u32> = bytemuck::pod_collect_to_vec(&t);
            out.push(super::cpu::LevelTexels {
                size,
                shades: halves
                    .chunks_exact(4)
                    .zip(&triangles)
                    .map(|(h, &id)| (id != u32::MAX).then(|| std::array::from_fn(|i| h[i].to_f32())))
                    .collect(),
                triangles: triangles.into_iter().map(|id| (id != u32::MAX).then_some(id)).collect(),
            });
        }
        Ok(out)
    }

    /// Every backed page's triangle map and shades (raw texel bytes, rows of
    /// the page one after the other), keyed by the virtual page it backs:
    /// what the atlas holds, whichever physical page holds it.
    pub fn read_backed_pages(&self, ctx: &GpuContext) -> Result<BackedPages, GpuError> {
        let shade_texel = ATLAS_FORMAT.block_copy_size(None).expect("uncompressed format") as usize;
        let id_texel = TRIANGLE_MAP_FORMAT.block_copy_size(None).expect("uncompressed format") as usize;
        let shades = self.read_layers(ctx, &self.res.physical.atlas, shade_texel as u32)?;
        let ids = self.read_layers(ctx, &self.res.physical.triangle_map, id_texel as u32)?;
        let pool = self.res.pool;
        let (side, size) = ((pool.layer_pages * pool.page_size) as usize, pool.page_size as usize);
        let owners = Self::words(ctx, &self.res.physical.page_owner)?;
        let mut pages = BackedPages::new();
        for (physical, owner) in owners.iter().enumerate().take(pool.pages as usize) {
            let Some(page) = owner.checked_sub(1) else { continue };
            let (px, py, layer) = pool.origin(physical as u32);
            let rows = |bytes: &[u8], texel: usize| -> Vec<u8> {
                (0..size)
                    .flat_map(|r| {
                        let src = ((layer as usize * side + py as usize + r) * side + px as usize) * texel;
                        bytes[src..src + size * texel].iter().copied()
                    })
                    .collect()
            };
            pages.insert(page, (rows(&ids, id_texel), rows(&shades, shade_texel)));
        }
        Ok(pages)
    }

    /// One mip level of one object's triangle map, row-major: triangle + 1
    /// per texel (0 for none), `None` for texels of pages with no physical page.
    pub fn read_triangle_map(
        &self,
        ctx: &GpuContext,
        object: usize,
        level: usize,
    ) -> Result<(u32, Vec<Option<u32>>), GpuError> {
        let texel = TRIANGLE_MAP_FORMAT.block_copy_size(None).expect("uncompressed format");
        let bytes = self.read_layers(ctx, &self.res.physical.triangle_map, texel)?;
        // No page: a value no triangle map holds (triangle indices stay below it).
        let (size, level_bytes) = self.gather_level(ctx, &bytes, texel as usize, object, level, &[0xff; 4])?;
        let ids: Vec<u32> = bytemuck::pod_collect_to_vec(&level_bytes);
        Ok((size, ids.into_iter().map(|id| (id != u32::MAX).then_some(id)).collect()))
    }

    /// How many extra views share the atlas.
    pub fn extra_view_count(&self) -> usize {
        self.extra_view_images().count()
    }

    /// Extra view `k`'s image (1 is the first extra view), tone mapped as
    /// the renderer does at exposure 1 (Reinhard, sRGB).
    pub fn read_extra_view(&self, ctx: &GpuContext, k: usize) -> Result<image::RgbaImage, GpuError> {
        let Some(texture) = self.extra_view_images().nth(k.wrapping_sub(1)) else {
            return Err(GpuError::Readback(format!("no extra view {k}")));
        };
        let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&readback::read_texture(ctx, texture, 8)?);
        let pixels = halves.chunks_exact(4).flat_map(|p| {
            [reinhard_srgb8(p[0].to_f32()), reinhard_srgb8(p[1].to_f32()), reinhard_srgb8(p[2].to_f32()), 255]
        });
        Ok(image::RgbaImage::from_raw(texture.width(), texture.height(), pixels.collect()).expect("size matches"))
    }

    /// Every layer of a physical texture, one after the other.
    fn read_layers(&self, ctx: &GpuContext, texture: &wgpu::Texture, texel: u32) -> Result<Vec<u8>, GpuError> {
        let mut all = Vec::new();
        for layer in 0..texture.depth_or_array_layers() {
            let size = (texture.width(), texture.height());
            all.extend(readback::read_texture_region(ctx, texture, texel, (0, 0, layer), size)?);
        }
        Ok(all)
    }
}
