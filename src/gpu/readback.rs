//! Reading textures back to the CPU (images, debug views, test comparisons).

use super::{GpuContext, GpuError};

/// Copies mip 0 of a 2D texture with 4 bytes per texel (for example
/// `Rgba8Unorm`) into a tightly packed `Vec<u8>`, waiting for the GPU.
/// Outside the frame loop only: it blocks.
pub fn read_texture_rgba8(ctx: &GpuContext, texture: &wgpu::Texture) -> Result<Vec<u8>, GpuError> {
    read_texture(ctx, texture, 4)
}

/// Like [`read_texture_rgba8`] for any format of `bytes_per_texel` bytes.
pub fn read_texture(ctx: &GpuContext, texture: &wgpu::Texture, bytes_per_texel: u32) -> Result<Vec<u8>, GpuError> {
    let (w, h) = (texture.width(), texture.height());
    let unpadded = w * bytes_per_texel;
    let padded = unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture read-back"),
        size: padded as u64 * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    ctx.queue.submit([encoder.finish()]);
    let bytes = read_buffer(ctx, &buffer)?;
    let mut out = Vec::with_capacity((unpadded * h) as usize);
    for row in bytes.chunks_exact(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    Ok(out)
}

/// Maps a `MAP_READ` buffer and returns its bytes, waiting for the GPU.
pub fn read_buffer(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait_idle()?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let bytes = buffer.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buffer.unmap();
    ctx.check_errors()?;
    Ok(bytes)
}
