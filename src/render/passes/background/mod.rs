//! The environment as the background (`--env`, docs/environment.md): after
//! a pipeline's opaque frame and before its blended surfaces, one
//! full-screen draw (`background.wgsl`) adds the environment's radiance
//! seen through each pixel (level 0 of the prefiltered map: the unfiltered
//! source), times the frame's environment lights' colour and intensity,
//! wherever no opaque surface covers the pixel. It goes into the HDR target,
//! before bloom, exposure and tone mapping, so the sky is exposed as the
//! surfaces it lights are, and blended surfaces composite over it.
//!
//! Which pixels are uncovered, by what the opaque frame leaves:
//! - its depth target (raster visibility) at the HDR target's samples: the
//!   draw tests `Equal` against the cleared far plane, per sample under
//!   MSAA (the forward pipelines that keep their samples for the blended
//!   pass), so its fragments run on background pixels only;
//! - a multisampled depth target under a one-sample HDR target (deferred,
//!   deferred-compute, object space, and the forward pipelines that
//!   resolved their samples): the draw reads every sample's depth and adds
//!   the radiance times the share of uncovered samples, which the resolve
//!   left black: the same mean as drawing into the samples;
//! - the visibility buffer's ids where the compute rasterizer left the
//!   depth target unwritten.
//!
//! A scene without an environment builds no pass, and a frame without an
//! environment light draws nothing (the environment then adds nothing
//! anywhere, as `--env none`).

use glam::{Mat4, Vec3};

use super::{Binding, bind_group, bind_group_layout_for};
use crate::render::frame::Frame;
use crate::render::passes::visibility::VisibilityBuffer;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::{self, Targets};
use crate::scene::{Camera, Light, LightKind};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("background.wgsl", include_str!("background.wgsl"));
/// Reading a multisampled depth target (for a one-sample HDR target).
pub const SHADER_SAMPLES: ShaderSource = SHADER.with_defs(&["COVERAGE_SAMPLES"]);
/// Reading the visibility buffer's ids.
pub const SHADER_IDS: ShaderSource = SHADER.with_defs(&["COVERAGE_IDS"]);
/// [`SHADER_IDS`] for the compute rasterizer's samples (a layer each).
pub const SHADER_ID_LAYERS: ShaderSource = SHADER.with_defs(&["COVERAGE_IDS", crate::shaders::MSAA]);

gpu_struct! {
    /// The background's per-frame parameters (`Background` in `background.wgsl`).
    pub struct GpuBackground as "Background" {
        /// Inverse of the view-projection with the eye at the origin:
        /// (NDC x, y, 1, 1) -> the direction through that point.
        pub direction_from_ndc: Mat4,
        /// Sum of the frame's environment lights' colour times intensity.
        pub radiance: Vec3,
        pub pad: u32,
    }
}

impl GpuBackground {
    /// The parameters for `camera` seen through `view_proj` (jitter
    /// included) under `lights`; `None` when no light is an environment.
    pub fn new(camera: &Camera, view_proj: Mat4, lights: &[Light]) -> Option<Self> {
        let radiance: Vec3 =
            lights.iter().filter(|l| l.kind == LightKind::Environment).map(|l| l.color * l.intensity).sum();
        if radiance == Vec3::ZERO {
            return None;
        }
        // In double precision, as `GpuUnproject` (the reversed-Z depth row
        // is small next to the others); the eye at the origin keeps far
        // cameras (the city's) precise.
        let at_eye = view_proj.as_dmat4() * glam::DMat4::from_translation(camera.position.as_dvec3());
        Some(Self { direction_from_ndc: at_eye.inverse().as_mat4(), radiance, pad: 0 })
    }
}

/// What tells a pipeline's background pixels.
#[derive(Clone, Copy)]
pub enum Coverage<'a> {
    /// The depth target, which the opaque frame wrote.
    Depth,
    /// The compute rasterizer's visibility buffer (under MSAA a layer per sample).
    Ids(&'a VisibilityBuffer),
}

/// The background pass of one pipeline.
pub struct Background {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    uniform: wgpu::Buffer,
    /// Tests depth against the cleared far plane (else reads coverage).
    depth_test: bool,
    /// Draws into the multisampled HDR colour, which the blended pass resolves.
    into_samples: bool,
}

impl Background {
    /// The pass for a pipeline whose opaque frame leaves its coverage in
    /// `coverage`; `samples_stored`: under MSAA, its opaque pass left the
    /// samples in `targets.hdr_msaa_view` for the blended pass to resolve.
    /// `None` for a scene without an environment.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        coverage: Coverage,
        samples_stored: bool,
    ) -> Result<Option<Self>, ShaderError> {
        if !scene.environment.is_set() {
            return Ok(None);
        }
        let into_samples = samples_stored && targets.samples > 1 && targets.hdr_msaa_view.is_some();
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("background"),
            size: size_of::<GpuBackground>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let (shader, coverage_binding, coverage_view) = match coverage {
            Coverage::Ids(ids) => {
                let layers = ids.texture.depth_or_array_layers() > 1;
                let texture = Binding::Texture {
                    sample: wgpu::TextureSampleType::Uint,
                    dimension: if layers {
                        wgpu::TextureViewDimension::D2Array
                    } else {
                        wgpu::TextureViewDimension::D2
                    },
                };
                (if layers { SHADER_ID_LAYERS } else { SHADER_IDS }, Some(texture), Some(&ids.view))
            }
            Coverage::Depth if targets.samples > 1 && !into_samples => {
                let texture = Binding::MultisampledTexture { sample: wgpu::TextureSampleType::Depth };
                (SHADER_SAMPLES, Some(texture), Some(&targets.depth_view))
            }
            Coverage::Depth => (SHADER, None, None),
        };
        let depth_test = coverage_binding.is_none();
        let bindings: Vec<Binding> = std::iter::once(Binding::Uniform).chain(coverage_binding).collect();
        let layout = bind_group_layout_for(device, "background", wgpu::ShaderStages::FRAGMENT, &bindings);
        let resources: Vec<wgpu::BindingResource> = std::iter::once(uniform.as_entire_binding())
            .chain(coverage_view.map(wgpu::BindingResource::TextureView))
            .collect();
        let group = bind_group(device, "background", &layout, &resources);
        let module = shaders.module(device, shader)?;
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("background"),
            bind_group_layouts: &[Some(&scene.layout), Some(&layout)],
            immediate_size: 0,
        });
        // Added: the uncovered samples hold the cleared black.
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("background"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_full"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_background"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets::HDR_FORMAT,
                    blend: Some(wgpu::BlendState { color: add, alpha: add }),
                    write_mask: wgpu::ColorWrites::COLOR,
                })],
            }),
            primitive: Default::default(),
            depth_stencil: depth_test.then_some(wgpu::DepthStencilState {
                format: targets::DEPTH_FORMAT,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Equal),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: if depth_test { targets.samples } else { 1 },
                ..Default::default()
            },
            multiview_mask: None,
            cache: None,
        });
        Ok(Some(Self { pipeline, group, uniform, depth_test, into_samples }))
    }
}

/// Reads: the opaque frame's coverage (depth or ids) and the environment.
/// Writes: the environment's radiance added into `targets.hdr` (or the
/// multisampled colour the blended pass resolves) where nothing covers it;
/// nothing when the frame has no environment light.
pub fn background(frame: &mut Frame, pass: &Background) {
    let Some(params) = GpuBackground::new(frame.camera, frame.view.view_proj, frame.lights) else {
        return;
    };
    frame.queue.write_buffer(&pass.uniform, 0, bytemuck::bytes_of(&params));
    let targets = frame.targets;
    let view = match &targets.hdr_msaa_view {
        Some(msaa) if pass.into_samples => msaa,
        _ => &targets.hdr_view,
    };
    let color = [Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
    })];
    let depth = pass.depth_test.then(|| super::depth_attachment_read_only(targets));
    let scene_group = frame.scene_group;
    let mut rp = frame.render_pass("background", &color, depth);
    rp.set_pipeline(&pass.pipeline);
    rp.set_bind_group(0, scene_group, &[]);
    rp.set_bind_group(1, &pass.group, &[]);
    rp.draw(0..3, 0..1);
}
