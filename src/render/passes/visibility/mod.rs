//! Visibility pass: rasterizes the visible objects into a visibility buffer
//! of (object + 1, triangle) per pixel, from which compute passes rebuild
//! everything else a pixel needs. [`compute`] fills the same buffer with a
//! software rasterizer instead.

pub mod compute;

use std::str::FromStr;

use serde::Serialize;

use super::cluster_draws::ClusterCull;
use super::{
    DepthMode, ScenePipeline, SceneRaster, color_attachment, depth_attachment, draw_scene, scene_raster_pipeline_from,
};
use crate::gpu::{GpuContext, GpuError, readback};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("visibility.wgsl", include_str!("visibility.wgsl"));

/// How a pipeline fills its visibility buffer (`--visibility`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum VisibilityMethod {
    /// The hardware rasterizer ([`visibility`], after an optional depth pre-pass).
    #[default]
    Raster,
    /// The compute rasterizer ([`compute::compute_visibility`]); needs
    /// [`compute::FEATURES`].
    Compute,
}

impl VisibilityMethod {
    pub const ALL: [Self; 2] = [Self::Raster, Self::Compute];

    /// The faster method the device can run: compute where it has
    /// [`compute::FEATURES`] (measured on the H100: the compute rasterizer
    /// takes 0.7 ms at 1920x1080 where the hardware's depth pre-pass and id
    /// pass take 1.65 ms), else raster.
    pub fn preferred(features: wgpu::Features) -> Self {
        if features.contains(compute::FEATURES) { Self::Compute } else { Self::Raster }
    }

    /// [`VisibilityMethod::preferred`] at `samples` per pixel: the compute
    /// rasterizer takes the samples too, and on the H200 at 1920x1080 it made
    /// 4x MSAA frames 2.2x (`deferred-compute`) and 1.9x (object space)
    /// faster than the hardware path (`scripts/bench-msvis`).
    pub fn preferred_for(features: wgpu::Features, _samples: u32) -> Self {
        Self::preferred(features)
    }

    /// The name `--visibility` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Raster => "raster",
            Self::Compute => "compute",
        }
    }
}

impl FromStr for VisibilityMethod {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|v| v.name() == s).ok_or_else(|| format!("'{s}' is not raster or compute"))
    }
}

/// Per pixel: (object + 1, triangle); (0, 0) is background.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;

/// The visibility buffer, one texel per pixel of the targets. Under MSAA
/// one per sample: for the raster pass a multisampled texture (not copied),
/// for the compute rasterizer a 2D array with a layer per sample (its
/// resolve writes it; multisampled textures cannot be storage).
pub struct VisibilityBuffer {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl VisibilityBuffer {
    /// The buffer `method` writes.
    pub fn new(device: &wgpu::Device, targets: &Targets, method: VisibilityMethod) -> Self {
        let layers = targets.samples > 1 && method == VisibilityMethod::Compute;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("visibility"),
            size: wgpu::Extent3d {
                width: targets.width,
                height: targets.height,
                depth_or_array_layers: if layers { targets.samples } else { 1 },
            },
            mip_level_count: 1,
            sample_count: if layers { 1 } else { targets.samples },
            dimension: wgpu::TextureDimension::D2,
            format: FORMAT,
            // STORAGE_BINDING: the compute rasterizer's resolve writes it
            // (multisampled textures can be neither storage nor copied).
            usage: if layers {
                wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
            } else if targets.samples > 1 {
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING
            } else {
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
            },
            view_formats: &[],
        });
        let dimension = layers.then_some(wgpu::TextureViewDimension::D2Array);
        let view = texture.create_view(&wgpu::TextureViewDescriptor { dimension, ..Default::default() });
        Self { texture, view }
    }

    /// Samples per pixel (of either layout).
    pub fn samples(&self) -> u32 {
        self.texture.sample_count() * self.texture.depth_or_array_layers()
    }

    /// Reads the ids back, per pixel (row by row) its samples side by side,
    /// whichever pass wrote them (for tests: it waits for the GPU).
    pub fn read_samples(&self, ctx: &GpuContext) -> Result<Vec<[u32; 2]>, GpuError> {
        let (width, height, samples) = (self.texture.width(), self.texture.height(), self.samples());
        let pairs = |bytes: Vec<u8>| -> Vec<[u32; 2]> {
            bytemuck::pod_collect_to_vec::<u8, u32>(&bytes).chunks_exact(2).map(|c| [c[0], c[1]]).collect()
        };
        if self.texture.sample_count() == 1 {
            let layers = (0..samples)
                .map(|layer| readback::read_texture_level(ctx, &self.texture, 8, 0, layer, (width, height)).map(pairs))
                .collect::<Result<Vec<_>, _>>()?;
            let pixels = (width * height) as usize;
            return Ok((0..pixels * samples as usize)
                .map(|i| layers[i % samples as usize][i / samples as usize])
                .collect());
        }
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("visibility read-back"),
            source: wgpu::ShaderSource::Wgsl(include_str!("read_samples.wgsl").into()),
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("visibility read-back"),
            layout: None,
            module: &module,
            entry_point: Some("copy_samples"),
            compilation_options: Default::default(),
            cache: None,
        });
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility read-back"),
            size: u64::from(width * height * samples) * 8,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("visibility read-back"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&self.view) },
                wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut cp = encoder.begin_compute_pass(&Default::default());
            cp.set_pipeline(&pipeline);
            cp.set_bind_group(0, &group, &[]);
            cp.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        }
        ctx.queue.submit([encoder.finish()]);
        readback::read_whole_buffer(ctx, &out).map(pairs)
    }

    pub fn bytes(&self) -> u64 {
        let per_pixel = self.texture.sample_count() * self.texture.depth_or_array_layers();
        self.texture.width() as u64 * self.texture.height() as u64 * u64::from(per_pixel) * 8
    }
}

pub struct VisibilityPass {
    pipeline: ScenePipeline,
    after_prepass: bool,
}

impl VisibilityPass {
    /// `after_prepass`: the depth target already holds the scene's depth
    /// (test `Equal`, each pixel's ids written once); otherwise the pass
    /// clears and writes depth itself. `samples`: per pixel of the targets.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        after_prepass: bool,
        samples: u32,
    ) -> Result<Self, ShaderError> {
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_main",
            fragment: Some(("fs_main", &[FORMAT])),
            depth: DepthMode::after(after_prepass),
            groups: &[],
            blend: None,
            samples,
        };
        let pipeline = scene_raster_pipeline_from(device, shaders, scene, &raster)?;
        Ok(Self { pipeline, after_prepass })
    }

    /// Its pipeline, for a culling depth pre-pass to add the variants that
    /// draw cluster lists
    /// ([`super::depth_prepass::DepthPrepass::enable_cluster_culling`]).
    pub fn pipeline_mut(&mut self) -> &mut ScenePipeline {
        &mut self.pipeline
    }
}

/// Reads: the depth target when built `after_prepass`. Writes: `out`
/// (cleared to background) and the depth target. Draws what `cull` kept
/// where it culled.
pub fn visibility(frame: &mut Frame, pass: &VisibilityPass, out: &VisibilityBuffer, cull: Option<&ClusterCull>) {
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let color = [color_attachment(&out.view, wgpu::Color::TRANSPARENT)];
    let mut rp = frame.render_pass("visibility", &color, Some(depth_attachment(targets, !pass.after_prepass)));
    draw_scene(&mut rp, scene, visible, &pass.pipeline, cull);
}
