//! Putting frames on the window: the renderer's tone-mapped image is copied
//! into a texture egui samples, egui paints it under its panels onto the
//! window's surface, and the same painting can go to an offscreen texture
//! for a screenshot with the panels. A headless viewer paints every frame
//! into an offscreen texture of the window's size instead of a surface:
//! the same GPU work between frames, with nothing presented.

use anyhow::Context;

use crate::gpu::{GpuContext, readback};
use crate::render::targets::LDR_FORMAT;

/// The window's surface (or the headless viewer's offscreen target), egui's
/// painter and the image they show.
pub struct Presenter {
    output: Output,
    /// The painted texture's format and size (physical pixels).
    format: wgpu::TextureFormat,
    size: (u32, u32),
    egui: egui_wgpu::Renderer,
    /// A copy of the renderer's `ldr` image that egui can sample.
    image: wgpu::Texture,
    image_id: egui::TextureId,
    /// egui textures to free once the frame that dropped them is painted.
    to_free: Vec<egui::TextureId>,
}

/// Where painted frames go.
enum Output {
    Surface {
        surface: wgpu::Surface<'static>,
        config: wgpu::SurfaceConfiguration,
    },
    /// Headless: a texture standing in for the window.
    Offscreen(wgpu::Texture),
}

/// The headless viewer's window format: non-sRGB, as the surface's is chosen.
const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// One frame of egui's output, tessellated (its texture changes already
/// handed to [`Presenter::update_textures`]).
pub struct EguiFrame {
    pub primitives: Vec<egui::ClippedPrimitive>,
    pub pixels_per_point: f32,
}

/// The present modes to try, best first: `--vsync on` waits for the display,
/// `off` presents at once where the surface allows it.
fn present_modes(vsync: bool) -> &'static [wgpu::PresentMode] {
    use wgpu::PresentMode as P;
    if vsync { &[P::Fifo] } else { &[P::Immediate, P::Mailbox, P::Fifo] }
}

impl Presenter {
    /// Configures `surface` at `size` (physical pixels) for images of `image_size`.
    pub fn new(
        ctx: &GpuContext,
        surface: wgpu::Surface<'static>,
        size: (u32, u32),
        vsync: bool,
        image_size: (u32, u32),
    ) -> anyhow::Result<Self> {
        let caps = surface.get_capabilities(&ctx.adapter);
        // A non-sRGB format: egui then encodes its colours itself, and the
        // renderer's already sRGB-encoded image round-trips exactly.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| matches!(f, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm))
            .or_else(|| caps.formats.first().copied())
            .context("the window's surface offers no format")?;
        let present_mode = present_modes(vsync)
            .iter()
            .copied()
            .find(|m| caps.present_modes.contains(m))
            .unwrap_or(wgpu::PresentMode::Fifo);
        let mut config =
            surface.get_default_config(&ctx.adapter, size.0.max(1), size.1.max(1)).context("surface unsupported")?;
        config.format = format;
        config.present_mode = present_mode;
        surface.configure(&ctx.device, &config);
        let size = (config.width, config.height);
        Ok(Self::with_output(ctx, Output::Surface { surface, config }, format, size, image_size))
    }

    /// A headless presenter: frames are painted into a texture of `size`.
    pub fn offscreen(ctx: &GpuContext, size: (u32, u32), image_size: (u32, u32)) -> Self {
        let size = (size.0.max(1), size.1.max(1));
        let target = offscreen_texture(ctx, size, OFFSCREEN_FORMAT, "viewer offscreen window");
        Self::with_output(ctx, Output::Offscreen(target), OFFSCREEN_FORMAT, size, image_size)
    }

    fn with_output(
        ctx: &GpuContext,
        output: Output,
        format: wgpu::TextureFormat,
        size: (u32, u32),
        image_size: (u32, u32),
    ) -> Self {
        let mut egui = egui_wgpu::Renderer::new(&ctx.device, format, egui_wgpu::RendererOptions::default());
        let image = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("viewer image"),
            size: wgpu::Extent3d { width: image_size.0, height: image_size.1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: LDR_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        // Sampled as stored: egui (0.37) takes texels as sRGB-encoded, as its
        // own textures are, and writes them to the non-sRGB target unchanged.
        // (Through an sRGB view it got them decoded, and the window showed
        // the frame about four times too dark in its mid-tones.)
        let view = image.create_view(&Default::default());
        let image_id = egui.register_native_texture(&ctx.device, &view, wgpu::FilterMode::Nearest);
        Self { output, format, size, egui, image, image_id, to_free: Vec::new() }
    }

    /// The rendered image's size in pixels.
    pub fn image_size(&self) -> (u32, u32) {
        (self.image.width(), self.image.height())
    }

    /// The texture id under which egui shows the rendered image.
    pub fn image_id(&self) -> egui::TextureId {
        self.image_id
    }

    /// The surface's present mode; `None` when headless.
    pub fn present_mode(&self) -> Option<wgpu::PresentMode> {
        match &self.output {
            Output::Surface { config, .. } => Some(config.present_mode),
            Output::Offscreen(_) => None,
        }
    }

    /// The window's size in physical pixels.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Follows a window resize.
    pub fn resize(&mut self, ctx: &GpuContext, width: u32, height: u32) {
        let Output::Surface { surface, config } = &mut self.output else { return };
        if width > 0 && height > 0 && (width, height) != self.size {
            config.width = width;
            config.height = height;
            surface.configure(&ctx.device, config);
            self.size = (width, height);
        }
    }

    /// Copies the renderer's newest image (`ldr`) into the shown texture.
    pub fn copy_image(&self, ctx: &GpuContext, ldr: &wgpu::Texture) {
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("viewer copy") });
        encoder.copy_texture_to_texture(ldr.as_image_copy(), self.image.as_image_copy(), ldr.size());
        ctx.queue.submit([encoder.finish()]);
    }

    /// Paints `frame` onto the window (headless: into its offscreen
    /// texture). A surface that is out of date is configured again and the
    /// frame skipped.
    pub fn present(&mut self, ctx: &GpuContext, frame: &EguiFrame) {
        let size = self.size;
        match &self.output {
            Output::Surface { surface, config } => {
                let texture = match surface.get_current_texture() {
                    wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
                    wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                        surface.configure(&ctx.device, config);
                        self.free();
                        return;
                    }
                    other => {
                        tracing::debug!("viewer: frame skipped: {other:?}");
                        self.free();
                        return;
                    }
                };
                let view = texture.texture.create_view(&Default::default());
                self.paint(ctx, frame, &view, size);
                ctx.queue.present(texture);
            }
            Output::Offscreen(target) => {
                let view = target.create_view(&Default::default());
                self.paint(ctx, frame, &view, size);
            }
        }
        self.free();
    }

    /// Paints `frame` into an offscreen texture of the window's size and
    /// reads it back (blocks): the window as the user sees it.
    pub fn capture(&mut self, ctx: &GpuContext, frame: &EguiFrame) -> anyhow::Result<image::RgbaImage> {
        let (width, height) = self.size;
        let target = offscreen_texture(ctx, self.size, self.format, "viewer capture");
        self.paint(ctx, frame, &target.create_view(&Default::default()), (width, height));
        let mut bytes = readback::read_texture_rgba8(ctx, &target)?;
        if self.format == wgpu::TextureFormat::Bgra8Unorm {
            bytes.chunks_exact_mut(4).for_each(|p| p.swap(0, 2));
        }
        image::RgbaImage::from_raw(width, height, bytes).context("capture has the window's size")
    }

    /// Applies egui's texture changes of a frame: new and changed textures
    /// now, the ones it dropped after the frame is presented.
    pub fn update_textures(&mut self, ctx: &GpuContext, mut delta: egui::TexturesDelta) {
        for (id, changes) in &delta.set {
            for change in changes {
                self.egui.update_texture(&ctx.device, &ctx.queue, *id, change);
            }
        }
        self.to_free.extend(delta.free.iter().copied());
        delta.clear();
    }

    fn free(&mut self) {
        for id in std::mem::take(&mut self.to_free) {
            self.egui.free_texture(&id);
        }
    }

    fn paint(&mut self, ctx: &GpuContext, frame: &EguiFrame, view: &wgpu::TextureView, size: (u32, u32)) {
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: frame.pixels_per_point };
        let mut encoder = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("egui") });
        let extra = self.egui.update_buffers(&ctx.device, &ctx.queue, &mut encoder, &frame.primitives, &screen);
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            self.egui.render(&mut pass.forget_lifetime(), &frame.primitives, &screen);
        }
        ctx.queue.submit(extra.into_iter().chain([encoder.finish()]));
    }
}

/// A texture egui can paint into and a read-back can copy from.
fn offscreen_texture(ctx: &GpuContext, size: (u32, u32), format: wgpu::TextureFormat, label: &str) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}
