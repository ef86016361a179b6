//! Single-pass forward shading: one draw per object; each fragment loops over
//! the lights that CPU culling assigned to its object. An optional depth
//! pre-pass removes overdraw from the shading pass.

use super::targets::HDR_FORMAT;
use super::{DepthMode, FrameContext, Pipeline, scene_raster_pipeline};
use crate::gpu::timing::GpuTimer;
use crate::shaders::{self, ShaderError, ShaderLibrary};

#[derive(Clone, Copy, Debug, Default)]
pub struct ForwardOptions {
    /// Lay down depth first, then shade with an `Equal` depth test, so every
    /// pixel is shaded once.
    pub depth_prepass: bool,
}

pub struct Forward {
    prepass: Option<wgpu::RenderPipeline>,
    shade: wgpu::RenderPipeline,
}

impl Forward {
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene_layout: &wgpu::BindGroupLayout,
        options: ForwardOptions,
    ) -> Result<Self, ShaderError> {
        let module = shaders.module(device, shaders::FORWARD)?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("forward"),
            bind_group_layouts: &[Some(scene_layout)],
            immediate_size: 0,
        });
        let pipeline = |label, vs, fs: Option<&str>, depth| {
            scene_raster_pipeline(device, label, &module, &layout, vs, fs.map(|fs| (fs, HDR_FORMAT)), depth)
        };
        let (prepass, shade) = if options.depth_prepass {
            (
                Some(pipeline("forward depth", "vs_depth", None, DepthMode::Write)),
                pipeline("forward shade", "vs_main", Some("fs_main"), DepthMode::EqualAfterPrepass),
            )
        } else {
            (None, pipeline("forward shade", "vs_main", Some("fs_main"), DepthMode::Write))
        };
        Ok(Self { prepass, shade })
    }
}

impl Pipeline for Forward {
    fn name(&self) -> &'static str {
        "forward"
    }

    fn encode(&mut self, frame: &FrameContext, encoder: &mut wgpu::CommandEncoder, timer: &mut GpuTimer) {
        let scene = frame.scene;
        let draw_all = |pass: &mut wgpu::RenderPass, pipeline| {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, scene.bind_group(), &[]);
            pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
            for (i, d) in scene.draws.iter().enumerate() {
                if frame.visible[i] {
                    let i = i as u32;
                    pass.draw_indexed(d.first_index..d.first_index + d.index_count, d.base_vertex as i32, i..i + 1);
                }
            }
        };
        let depth_load = if let Some(prepass) = &self.prepass {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth prepass"),
                depth_stencil_attachment: Some(depth_attachment(frame, wgpu::LoadOp::Clear(0.0))),
                timestamp_writes: timer.render_pass("depth prepass"),
                ..Default::default()
            });
            draw_all(&mut pass, prepass);
            wgpu::LoadOp::Load
        } else {
            wgpu::LoadOp::Clear(0.0)
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("forward shade"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &frame.targets.hdr_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(depth_attachment(frame, depth_load)),
            timestamp_writes: timer.render_pass("forward shade"),
            ..Default::default()
        });
        draw_all(&mut pass, &self.shade);
    }
}

fn depth_attachment<'a>(
    frame: &FrameContext<'a>,
    load: wgpu::LoadOp<f32>,
) -> wgpu::RenderPassDepthStencilAttachment<'a> {
    wgpu::RenderPassDepthStencilAttachment {
        view: &frame.targets.depth_view,
        depth_ops: Some(wgpu::Operations { load, store: wgpu::StoreOp::Store }),
        stencil_ops: None,
    }
}
