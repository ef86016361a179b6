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
    read_texture_region(ctx, texture, bytes_per_texel, (0, 0, 0), (texture.width(), texture.height()))
}

/// Reads the `size` texels at `origin` (x, y, array layer) of mip 0.
pub fn read_texture_region(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
    origin: (u32, u32, u32),
    size: (u32, u32),
) -> Result<Vec<u8>, GpuError> {
    read_texture_region_at(ctx, texture, bytes_per_texel, 0, origin, size)
}

/// Reads the `size` texels from the corner of array layer `layer` of mip `level`.
pub fn read_texture_level(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
    level: u32,
    layer: u32,
    size: (u32, u32),
) -> Result<Vec<u8>, GpuError> {
    read_texture_region_at(ctx, texture, bytes_per_texel, level, (0, 0, layer), size)
}

fn read_texture_region_at(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
    level: u32,
    origin: (u32, u32, u32),
    size: (u32, u32),
) -> Result<Vec<u8>, GpuError> {
    let (w, h) = size;
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
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: level,
            origin: wgpu::Origin3d { x: origin.0, y: origin.1, z: origin.2 },
            aspect: wgpu::TextureAspect::All,
        },
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

/// Copies a whole `COPY_SRC` buffer back, waiting for the GPU.
pub fn read_whole_buffer(ctx: &GpuContext, source: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("buffer read-back"),
        size: source.size(),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(source, 0, &staging, 0, source.size());
    ctx.queue.submit([encoder.finish()]);
    read_buffer(ctx, &staging)
}

/// Maps a `MAP_READ` buffer and returns its bytes, waiting for the GPU.
pub fn read_buffer(ctx: &GpuContext, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait_idle()?;
    rx.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
    let bytes = buffer.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
    buffer.unmap();
    ctx.check_errors()?;
    Ok(bytes)
}

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// Copied into its buffer; mapping not yet asked for.
const RECORDED: u8 = 0;
const MAPPING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

struct InFlight<T> {
    tag: T,
    size: u64,
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
}

/// Asynchronous read-back of small per-frame results (timestamps, counters):
/// a frame copies into a buffer from a pool, the buffer is mapped after the
/// submit, and [`ReadbackRing::collect`] hands back the results that have
/// arrived. The frame loop never waits on the GPU.
pub struct ReadbackRing<T> {
    label: &'static str,
    capacity: u64,
    free: Vec<wgpu::Buffer>,
    in_flight: VecDeque<InFlight<T>>,
}

impl<T> ReadbackRing<T> {
    /// Each read-back holds at most `capacity` bytes.
    pub fn new(label: &'static str, capacity: u64) -> Self {
        Self { label, capacity, free: Vec::new(), in_flight: VecDeque::new() }
    }

    /// Records a copy of `size` bytes of `source` for this frame, tagged `tag`.
    pub fn copy(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        size: u64,
        tag: T,
    ) {
        assert!(size <= self.capacity, "read-back of {size} bytes exceeds {}", self.capacity);
        let buffer = self.free.pop().unwrap_or_else(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: self.capacity,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        });
        encoder.copy_buffer_to_buffer(source, 0, &buffer, 0, size);
        self.in_flight.push_back(InFlight { tag, size, buffer, state: Arc::new(AtomicU8::new(RECORDED)) });
    }

    /// Starts mapping what was recorded since the last call. Call right after
    /// `queue.submit`.
    pub fn after_submit(&mut self) {
        for f in self.in_flight.iter().filter(|f| f.state.load(Ordering::Acquire) == RECORDED) {
            f.state.store(MAPPING, Ordering::Release);
            let state = f.state.clone();
            f.buffer.map_async(wgpu::MapMode::Read, ..f.size, move |r| {
                state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
            });
        }
    }

    /// The results that have arrived, oldest first (a failed mapping is
    /// dropped with a warning). With `wait`, first waits for all of them.
    pub fn collect(&mut self, device: &wgpu::Device, wait: bool) -> Vec<(T, Vec<u8>)> {
        let poll = if wait { wgpu::PollType::wait_indefinitely() } else { wgpu::PollType::Poll };
        if let Err(e) = device.poll(poll) {
            tracing::warn!("{}: poll failed: {e}", self.label);
        }
        let mut out = Vec::new();
        while let Some(f) = self.in_flight.front() {
            let mut state = f.state.load(Ordering::Acquire);
            if wait && state == MAPPING {
                state = settled(device, &f.state);
            }
            if state == RECORDED || state == MAPPING {
                break;
            }
            let f = self.in_flight.pop_front().expect("front exists");
            if state == MAPPED {
                match f.buffer.get_mapped_range(..f.size) {
                    Ok(view) => out.push((f.tag, view.to_vec())),
                    Err(e) => tracing::warn!("{}: cannot read: {e}", self.label),
                }
                f.buffer.unmap();
            } else {
                tracing::warn!("{}: mapping failed", self.label);
            }
            self.free.push(f.buffer);
        }
        out
    }
}

/// The state of a mapping once its callback has run. Another thread polling
/// the same device (tests share one; so may an embedding program) can be
/// running the callback when this thread's wait returns: the callbacks are
/// taken off the queue before they run. Gives up after ten seconds.
fn settled(device: &wgpu::Device, state: &AtomicU8) -> u8 {
    let start = std::time::Instant::now();
    loop {
        let s = state.load(Ordering::Acquire);
        if s != MAPPING || start.elapsed() > std::time::Duration::from_secs(10) {
            return s;
        }
        std::thread::yield_now();
        let _ = device.poll(wgpu::PollType::Poll);
    }
}
