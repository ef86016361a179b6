//! Per-resolution render targets: the HDR colour every pipeline writes, its
//! depth, and the tone-mapped 8-bit image.

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

pub struct Targets {
    pub width: u32,
    pub height: u32,
    pub hdr: wgpu::Texture,
    pub hdr_view: wgpu::TextureView,
    pub depth: wgpu::Texture,
    pub depth_view: wgpu::TextureView,
    /// Tone-mapped, sRGB-encoded image (stored as `Rgba8Unorm` because sRGB
    /// formats cannot be storage textures; the tone mapper encodes by hand).
    pub ldr: wgpu::Texture,
    pub ldr_view: wgpu::TextureView,
}

fn texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
    width: u32,
    height: u32,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

impl Targets {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Self {
        use wgpu::TextureUsages as U;
        let make = |label, format, usage| texture(device, label, format, usage, width, height);
        let hdr = Self::hdr_texture(device, width, height);
        let depth = make("depth", DEPTH_FORMAT, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let ldr = make("ldr", LDR_FORMAT, U::STORAGE_BINDING | U::COPY_SRC);
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        Self { width, height, hdr_view: view(&hdr), depth_view: view(&depth), ldr_view: view(&ldr), hdr, depth, ldr }
    }

    /// An HDR image like the targets' own (for a second view's gather).
    pub fn hdr_texture(device: &wgpu::Device, width: u32, height: u32) -> wgpu::Texture {
        use wgpu::TextureUsages as U;
        let usage = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::STORAGE_BINDING | U::COPY_SRC;
        texture(device, "hdr", HDR_FORMAT, usage, width, height)
    }
}
