//! Per-resolution render targets: the HDR colour every pipeline writes, its
//! depth, and the tone-mapped 8-bit image; under MSAA also the
//! multisampled colour that raster pipelines draw into and resolve.

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The sample counts `--msaa` takes (the counts Vulkan's standard sample
/// positions are defined for, so every pipeline samples the same points).
pub const SAMPLE_COUNTS: [u32; 4] = [1, 2, 4, 8];

pub struct Targets {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the scene's raster passes ([`SAMPLE_COUNTS`]; 1: no MSAA).
    pub samples: u32,
    /// The resolved HDR image (one sample per pixel) that bloom, exposure and
    /// tone mapping read.
    pub hdr: wgpu::Texture,
    pub hdr_view: wgpu::TextureView,
    /// Under MSAA (`samples > 1`): the multisampled HDR colour raster
    /// pipelines draw into and resolve into `hdr` (see
    /// [`super::passes::hdr_attachment`]); `None` at one sample and for
    /// pipelines that resolve in compute.
    pub hdr_msaa_view: Option<wgpu::TextureView>,
    /// Depth with `samples` samples per pixel.
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
    (width, height, samples): (u32, u32, u32),
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

impl Targets {
    /// Targets of `width` x `height` with `samples` samples per pixel (one of
    /// [`SAMPLE_COUNTS`], which the adapter must support for [`HDR_FORMAT`]
    /// and [`DEPTH_FORMAT`]: [`super::check_samples`]); the multisampled
    /// colour only with `msaa_colour` (for pipelines that resolve it).
    pub fn new(device: &wgpu::Device, width: u32, height: u32, samples: u32, msaa_colour: bool) -> Self {
        use wgpu::TextureUsages as U;
        let hdr = Self::hdr_texture(device, width, height);
        let depth =
            texture(device, "depth", DEPTH_FORMAT, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING, (width, height, samples));
        let ldr = texture(device, "ldr", LDR_FORMAT, U::STORAGE_BINDING | U::COPY_SRC, (width, height, 1));
        let hdr_msaa = (samples > 1 && msaa_colour)
            .then(|| texture(device, "hdr msaa", HDR_FORMAT, U::RENDER_ATTACHMENT, (width, height, samples)));
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        Self {
            width,
            height,
            samples,
            hdr_view: view(&hdr),
            hdr_msaa_view: hdr_msaa.as_ref().map(view),
            depth_view: view(&depth),
            ldr_view: view(&ldr),
            hdr,
            depth,
            ldr,
        }
    }

    /// An HDR image like the targets' own (for a second view's gather).
    pub fn hdr_texture(device: &wgpu::Device, width: u32, height: u32) -> wgpu::Texture {
        use wgpu::TextureUsages as U;
        let usage = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::STORAGE_BINDING | U::COPY_SRC;
        texture(device, "hdr", HDR_FORMAT, usage, (width, height, 1))
    }

    /// Bytes of the multisampled colour and depth (0 at one sample), for
    /// the run report.
    pub fn msaa_bytes(&self) -> u64 {
        if self.samples == 1 {
            return 0;
        }
        // Rgba16Float (8 bytes) and Depth32Float (4) per sample.
        let colour = if self.hdr_msaa_view.is_some() { 8 } else { 0 };
        u64::from(self.width) * u64::from(self.height) * u64::from(self.samples) * (colour + 4)
    }
}
