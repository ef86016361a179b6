//! Tone mapping: HDR target -> 8-bit sRGB image (exposure, Reinhard), in compute.

use super::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::frame::Frame;
use crate::render::targets::{HDR_FORMAT, LDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("tonemap.wgsl", include_str!("tonemap.wgsl"));

pub struct Tonemap {
    pipeline: wgpu::ComputePipeline,
    exposure: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

impl Tonemap {
    /// A tone mapper reading `targets.hdr` and writing `targets.ldr`.
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, targets: &Targets) -> Result<Self, ShaderError> {
        let d2 = wgpu::TextureViewDimension::D2;
        let layout = bind_group_layout(
            device,
            "tonemap",
            &[
                Binding::Texture { sample: wgpu::TextureSampleType::Float { filterable: false }, dimension: d2 },
                Binding::StorageTexture { format: LDR_FORMAT, dimension: d2 },
                Binding::Uniform,
            ],
        );
        debug_assert_eq!(targets.hdr.format(), HDR_FORMAT);
        let pipeline = compute_pipeline(device, shaders, SHADER, "tonemap", &[&layout])?;
        let exposure = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("exposure"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = bind_group(
            device,
            "tonemap",
            &layout,
            &[
                wgpu::BindingResource::TextureView(&targets.hdr_view),
                wgpu::BindingResource::TextureView(&targets.ldr_view),
                exposure.as_entire_binding(),
            ],
        );
        Ok(Self { pipeline, exposure, bind_group })
    }
}

/// Reads: `targets.hdr`. Writes: `targets.ldr`.
pub fn tonemap(frame: &mut Frame, pass: &Tonemap, exposure: f32) {
    frame.queue.write_buffer(&pass.exposure, 0, bytemuck::cast_slice(&[exposure, 0.0, 0.0, 0.0]));
    let (w, h) = (frame.targets.width, frame.targets.height);
    let mut cp = frame.compute_pass("tonemap");
    cp.set_pipeline(&pass.pipeline);
    cp.set_bind_group(0, &pass.bind_group, &[]);
    cp.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
}
