//! Tone mapping: HDR target -> 8-bit sRGB image (exposure, Reinhard), in compute.

use super::{Binding, bind_group, bind_group_layout, compute_pipeline};
use crate::render::frame::Frame;
use crate::render::targets::{HDR_FORMAT, LDR_FORMAT, Targets};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("tonemap.wgsl", include_str!("tonemap.wgsl"));

pub struct Tonemap {
    pipeline: wgpu::ComputePipeline,
    /// The exposure multiplier (x of a vec4): written by the CPU for a fixed
    /// exposure, by the auto-exposure pass otherwise.
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
            usage: wgpu::BufferUsages::UNIFORM
                | wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
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

    /// The buffer holding the exposure (a vec4 whose x is the multiplier),
    /// for the auto-exposure pass to write and for read-back.
    pub fn exposure_buffer(&self) -> &wgpu::Buffer {
        &self.exposure
    }
}

/// Reads: `targets.hdr` and the exposure buffer, after writing `fixed` into
/// it (`None`: the auto-exposure pass wrote this frame's). Writes: `targets.ldr`.
pub fn tonemap(frame: &mut Frame, pass: &Tonemap, fixed: Option<f32>) {
    if let Some(exposure) = fixed {
        frame.queue.write_buffer(&pass.exposure, 0, bytemuck::cast_slice(&[exposure, 0.0, 0.0, 0.0]));
    }
    let (w, h) = (frame.targets.width, frame.targets.height);
    let mut cp = frame.compute_pass("tonemap");
    cp.set_pipeline(&pass.pipeline);
    cp.set_bind_group(0, &pass.bind_group, &[]);
    cp.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
}
