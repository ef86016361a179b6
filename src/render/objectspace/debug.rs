//! Read-backs of object-space state for debugging and tests (they block on
//! the GPU, so they stay out of the frame loop).

use super::ObjectSpace;
use super::resources::ATLAS_FORMAT;
use crate::color::reinhard_srgb8;
use crate::gpu::{GpuContext, GpuError, readback};

/// The object-space marking state after a frame, read back from the GPU.
#[derive(Clone, Debug)]
pub struct MarkState {
    /// The frame's stamp (frames rendered so far; 0 in the tile buffers means never).
    pub stamp: u32,
    /// Per scene object: shades stamped before this are stale.
    pub valid_since: Vec<u32>,
    /// Per pixel, row-major: (object + 1, triangle); object 0 = background.
    pub visibility: Vec<[u32; 2]>,
    /// Per tile: stamp of the last frame it was visible.
    pub tile_visible: Vec<u32>,
    /// Per tile: stamp of the last frame it was shaded.
    pub tile_shaded: Vec<u32>,
    /// This frame's shade queue: (global tile, object << 8 | level), in GPU order.
    pub queue: Vec<[u32; 2]>,
    /// Indexed by [`super::TileCounter`].
    pub counters: [u32; super::TileCounter::SLOTS],
}

impl ObjectSpace {
    /// The marking state after the last frame, for tests that check tile
    /// marking against its CPU twin.
    pub fn read_mark_state(&self, ctx: &GpuContext) -> Result<MarkState, GpuError> {
        let res = &self.res;
        let words = |b: &wgpu::Buffer| -> Result<Vec<u32>, GpuError> {
            Ok(bytemuck::pod_collect_to_vec(&readback::read_whole_buffer(ctx, b)?))
        };
        let tiles = self.layout.tile_count as usize;
        let mut tile_visible = words(&res.tile_visible)?;
        let mut tile_shaded = words(&res.tile_shaded)?;
        tile_visible.truncate(tiles);
        tile_shaded.truncate(tiles);
        let c = words(&res.counters)?;
        let queued = (c[super::TileCounter::Queued as usize] as usize).min(tiles);
        let queue = words(&res.work_queue)?.chunks_exact(2).take(queued).map(|c| [c[0], c[1]]).collect();
        let ids: Vec<u32> = bytemuck::pod_collect_to_vec(&readback::read_texture(ctx, &res.visibility.texture, 8)?);
        Ok(MarkState {
            stamp: self.frames,
            valid_since: res.entry_data.iter().map(|e| e.valid_since).collect(),
            visibility: ids.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
            tile_visible,
            tile_shaded,
            queue,
            counters: std::array::from_fn(|i| c[i]),
        })
    }

    /// One mip level of one object's shades as an image (Reinhard tone
    /// mapped, sRGB), for the atlas debug view.
    pub fn read_atlas(&self, ctx: &GpuContext, object: usize, level: usize) -> Result<image::RgbaImage, GpuError> {
        let Some(l) = self.layout.objects.get(object).and_then(|o| o.as_ref()).and_then(|o| o.levels.get(level)) else {
            return Err(GpuError::Readback(format!("object {object} has no atlas level {level}")));
        };
        let texel_bytes = ATLAS_FORMAT.block_copy_size(None).expect("uncompressed format");
        let bytes =
            readback::read_texture_region(ctx, &self.res.atlas, texel_bytes, (l.x, l.y, l.page), (l.size, l.size))?;
        let halves: Vec<half::f16> = bytemuck::pod_collect_to_vec(&bytes);
        let pixels = halves.chunks_exact(4).flat_map(|p| {
            [reinhard_srgb8(p[0].to_f32()), reinhard_srgb8(p[1].to_f32()), reinhard_srgb8(p[2].to_f32()), 255]
        });
        Ok(image::RgbaImage::from_raw(l.size, l.size, pixels.collect()).expect("size matches"))
    }
}
