//! Tone mapping pass: HDR target -> 8-bit sRGB image (Reinhard), in compute.

use super::targets::Targets;
use crate::gpu::timing::GpuTimer;
use crate::shaders::{self, ShaderError, ShaderLibrary};

pub struct Tonemap {
    pipeline: wgpu::ComputePipeline,
    exposure: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    size: (u32, u32),
}

impl Tonemap {
    /// A tone mapper reading and writing `targets`.
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, targets: &Targets) -> Result<Self, ShaderError> {
        let module = shaders.module(device, shaders::TONEMAP)?;
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("tonemap"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let exposure = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("exposure"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("tonemap"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&targets.hdr_view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&targets.ldr_view) },
                wgpu::BindGroupEntry { binding: 2, resource: exposure.as_entire_binding() },
            ],
        });
        Ok(Self { pipeline, exposure, bind_group, size: (targets.width, targets.height) })
    }

    pub fn encode(
        &mut self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        exposure: f32,
        timer: &mut GpuTimer,
    ) {
        queue.write_buffer(&self.exposure, 0, bytemuck::cast_slice(&[exposure, 0.0, 0.0, 0.0]));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("tonemap"),
            timestamp_writes: timer.compute_pass("tonemap"),
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
    }
}
