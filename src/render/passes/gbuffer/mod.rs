//! G-buffer pass, shared by the deferred pipelines: rasterizes the visible
//! objects (after an optional depth pre-pass, testing `Equal`) into a slim
//! G-buffer, 16 bytes per pixel with the frame's depth, 22 in scenes with
//! material textures (the last two targets):
//!
//! | target | format | holds |
//! | --- | --- | --- |
//! | `targets.depth` | `Depth32Float` | reversed-Z depth (positions are rebuilt from it) |
//! | normal | `Rg16Float` | the unit normal, octahedral-encoded ([`octahedral`]) |
//! | albedo | `Rgb10a2Unorm` | albedo (texture times base colour), linear; alpha unused |
//! | object | `R32Uint` | the object, whose table entry holds specular, shininess, the metallic, roughness, emission and occlusion factors |
//! | emission, occlusion | `Rgba8UnormSrgb` | the emissive texture's texel (sRGB, as stored) and the occlusion texture's (alpha, linear) |
//! | metallic, roughness | `Rg8Unorm` | the metallic-roughness texture's blue and green |
//! | UV0, mip | `Rgba32Float` | in scenes with layered materials ([`crate::materials`]): UV0 and the albedo mip there, so that the lighting passes rebuild every layer's mask and surface and light each layer (16 bytes more) |
//!
//! Why these: 10-bit linear albedo costs the 4 bytes of `Rgba8Unorm` and is
//! finer than 8-bit sRGB above a linear albedo of about 0.02 (up to 9x at
//! white) and than 8-bit linear everywhere. Against forward at 320x180 (mean
//! FLIP, atrium / voxels; `tests/it/agreement.rs`): 8-bit sRGB 0.0072 / 0.0013,
//! 8-bit linear 0.0043 / 0.0095, 10-bit linear 0.0022 / 0.0033, half floats
//! (8 bytes) 0.0017 / 0.0009. Specular, shininess and the material
//! factors are per object in this renderer, so one object index carries them
//! exactly (emission in HDR) in 4 bytes, where storing them would take 8 or
//! more and quantize shininess. The material textures vary per pixel, so
//! their texels are stored (6 bytes, at the textures' own 8 bits; the
//! emissive texel in sRGB, as its texture), and the lighting passes combine
//! them with the object's factors in `object_surface`, as every pipeline
//! does. Only scenes with such textures have these targets
//! ([`crate::shaders::MATERIAL_TEXTURES`]): there every pixel writes them,
//! and objects without those textures light exactly as before (the lighting
//! passes do not load their texels). Half
//! floats keep the encoded normal within 0.06 degrees (tested); `Rg16Snorm`
//! would be finer but needs an optional feature. The lighting passes read
//! it through `gbuffer_read.wgsl` (`shadespace::gbuffer`, bind group 1).
//!
//! Under MSAA every target has the frame's samples per pixel: the G-buffer
//! pass writes each fragment's values to the samples it covers, and the
//! lighting pass (`gbuffer_read.wgsl` with `MSAA`) compares a pixel's
//! samples to shade it once or sample by sample.

pub mod octahedral;

use glam::{DVec4, Mat4};

use super::cluster_draws::ClusterCull;
use super::depth_prepass::{DepthPrepass, culled_depth_prepass};
use super::{
    Binding, DepthMode, ScenePipeline, SceneRaster, bind_group, bind_group_layout_for, color_attachment,
    depth_attachment, draw_scene, scene_raster_pipeline_from,
};
use crate::render::frame::Frame;
use crate::render::gpu_types::GpuView;
use crate::render::scene_gpu::SceneGpu;
use crate::render::targets::Targets;
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("gbuffer.wgsl", include_str!("gbuffer.wgsl"));
/// The module lighting passes import to read the G-buffer (`shadespace::gbuffer`).
pub const SHARED_WGSL: ShaderSource = ShaderSource::new("gbuffer_read.wgsl", include_str!("gbuffer_read.wgsl"));

/// Octahedral-encoded unit normal.
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
/// Linear albedo, 10 bits per channel.
pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgb10a2Unorm;
/// The object index (its material is in the object table).
pub const OBJECT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// The emissive texel (sRGB) and the occlusion texel (alpha).
pub const EMISSION_OCCLUSION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The metallic and roughness texels.
pub const METAL_ROUGH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg8Unorm;
/// UV0 (full precision: it repeats far past 1) and the albedo mip, for
/// layered materials.
pub const UV_LOD_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// The targets every G-buffer has (the material ones as 1x1 placeholders in
/// scenes without material textures), all with the frame's samples per
/// pixel; with layered materials [`UV_LOD_FORMAT`] follows.
pub const BASE_FORMATS: [wgpu::TextureFormat; 5] =
    [NORMAL_FORMAT, ALBEDO_FORMAT, OBJECT_FORMAT, EMISSION_OCCLUSION_FORMAT, METAL_ROUGH_FORMAT];
/// The G-buffer's own targets, in [`GBuffer::views`] order.
const FORMATS: [wgpu::TextureFormat; 6] =
    [BASE_FORMATS[0], BASE_FORMATS[1], BASE_FORMATS[2], BASE_FORMATS[3], BASE_FORMATS[4], UV_LOD_FORMAT];
/// Bytes per pixel of the G-buffer's own targets: normal, albedo, object,
/// and with material textures ([`crate::shaders::MATERIAL_TEXTURES`])
/// emission and occlusion, metallic and roughness.
pub const fn bytes_per_pixel(material_textures: bool) -> u64 {
    if material_textures { 18 } else { 12 }
}
/// Bytes per pixel including the frame's depth target, which it shares.
pub const fn bytes_per_pixel_with_depth(material_textures: bool) -> u64 {
    bytes_per_pixel(material_textures) + 4
}
/// Bytes per pixel the UV0 and mip target adds for layered materials.
pub const LAYERS_BYTES_PER_PIXEL: u64 = 16;

/// The targets the G-buffer pass writes, as indices into [`FORMATS`]: the
/// material ones only for scenes with material textures, the UV0 one only
/// for scenes with layered materials.
fn written(material_textures: bool, layers: bool) -> Vec<usize> {
    let mut w = vec![0, 1, 2];
    if material_textures {
        w.extend([3, 4]);
    }
    if layers {
        w.push(5);
    }
    w
}

gpu_struct! {
    /// What the lighting passes need to rebuild positions from depth
    /// (`Unproject` in `gbuffer_read.wgsl`).
    pub struct GpuUnproject as "Unproject" {
        /// Inverse of the view's `view_proj`: (NDC x, y, device depth, 1) -> world.
        pub inv_view_proj: Mat4,
    }
}

impl GpuUnproject {
    /// The inverse of `view.view_proj`, computed in double precision (the
    /// reversed-Z projection's depth row is small next to the others).
    pub fn new(view: &GpuView) -> Self {
        Self { inv_view_proj: view.view_proj.as_dmat4().inverse().as_mat4() }
    }

    /// World position of NDC point (`x`, `y`) at device depth `depth`.
    pub fn world(&self, x: f32, y: f32, depth: f32) -> glam::Vec3 {
        let p = self.inv_view_proj.as_dmat4() * DVec4::new(x as f64, y as f64, depth as f64, 1.0);
        (p.truncate() / p.w).as_vec3()
    }
}

/// The G-buffer's targets, its unproject uniform, and the bind group that
/// lighting passes read it through.
pub struct GBuffer {
    /// [`NORMAL_FORMAT`], one texel per pixel (as are the others).
    pub normal: wgpu::Texture,
    /// [`ALBEDO_FORMAT`].
    pub albedo: wgpu::Texture,
    /// [`OBJECT_FORMAT`].
    pub object: wgpu::Texture,
    /// [`EMISSION_OCCLUSION_FORMAT`].
    pub emission_occlusion: wgpu::Texture,
    /// [`METAL_ROUGH_FORMAT`].
    pub metal_rough: wgpu::Texture,
    /// [`UV_LOD_FORMAT`].
    pub uv_lod: wgpu::Texture,
    /// Views of the six targets, in [`FORMATS`] order.
    views: [wgpu::TextureView; 6],
    unproject: wgpu::Buffer,
    /// Group 1 of the lighting passes (`gbuffer_read.wgsl`): depth, normal,
    /// albedo, object, unproject, emission and occlusion, metallic and
    /// roughness; visible to fragment and compute stages.
    pub read_layout: wgpu::BindGroupLayout,
    pub read_group: wgpu::BindGroup,
    /// The material targets are written (the scene has material textures).
    pub material_textures: bool,
    /// The UV0 target is written (the scene has layered materials).
    pub layers: bool,
}

impl GBuffer {
    /// Targets of the size and samples per pixel of `targets`, read
    /// together with its depth. The material targets are 1x1 placeholders
    /// (bound, never read) for scenes without material textures; without
    /// layers the UV0 target is a 1x1 single-sample placeholder that is not
    /// bound at all (binding 7 exists only with `LAYERS`), so that scenes
    /// without layers never ask the adapter to multisample its format.
    pub fn new(device: &wgpu::Device, targets: &Targets, material_textures: bool, layers: bool) -> Self {
        let make_with = |label, format, (width, height), samples| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
        };
        let samples = targets.samples;
        let make_sized = |label, format, size| make_with(label, format, size, samples);
        let make = |label, format| make_sized(label, format, (targets.width, targets.height));
        let material_size = if material_textures { (targets.width, targets.height) } else { (1, 1) };
        let (normal, albedo, object) = (
            make("gbuffer normal", NORMAL_FORMAT),
            make("gbuffer albedo", ALBEDO_FORMAT),
            make("gbuffer object", OBJECT_FORMAT),
        );
        let emission_occlusion = make_sized("gbuffer emission occlusion", EMISSION_OCCLUSION_FORMAT, material_size);
        let metal_rough = make_sized("gbuffer metal rough", METAL_ROUGH_FORMAT, material_size);
        let uv_lod = if layers {
            make("gbuffer uv lod", UV_LOD_FORMAT)
        } else {
            make_with("gbuffer uv lod", UV_LOD_FORMAT, (1, 1), 1)
        };
        let views = [&normal, &albedo, &object, &emission_occlusion, &metal_rough, &uv_lod]
            .map(|t: &wgpu::Texture| t.create_view(&Default::default()));
        let unproject = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("gbuffer unproject"),
            size: size_of::<GpuUnproject>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let d2 = wgpu::TextureViewDimension::D2;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let texture = |sample| {
            if samples > 1 {
                Binding::MultisampledTexture { sample }
            } else {
                Binding::Texture { sample, dimension: d2 }
            }
        };
        let mut entries = vec![
            texture(wgpu::TextureSampleType::Depth),
            texture(float),
            texture(float),
            texture(wgpu::TextureSampleType::Uint),
            Binding::Uniform,
            texture(float),
            texture(float),
        ];
        let mut resources = vec![
            wgpu::BindingResource::TextureView(&targets.depth_view),
            wgpu::BindingResource::TextureView(&views[0]),
            wgpu::BindingResource::TextureView(&views[1]),
            wgpu::BindingResource::TextureView(&views[2]),
            unproject.as_entire_binding(),
            wgpu::BindingResource::TextureView(&views[3]),
            wgpu::BindingResource::TextureView(&views[4]),
        ];
        if layers {
            entries.push(texture(float));
            resources.push(wgpu::BindingResource::TextureView(&views[5]));
        }
        let read_layout = bind_group_layout_for(
            device,
            "gbuffer read",
            wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            &entries,
        );
        let read_group = bind_group(device, "gbuffer read", &read_layout, &resources);
        Self {
            normal,
            albedo,
            object,
            emission_occlusion,
            metal_rough,
            uv_lod,
            views,
            unproject,
            read_layout,
            read_group,
            material_textures,
            layers,
        }
    }

    /// Bytes per pixel of the targets written, with the frame's depth (per
    /// sample under MSAA).
    pub fn bytes_per_pixel_with_depth(&self) -> u64 {
        let layers = if self.layers { LAYERS_BYTES_PER_PIXEL } else { 0 };
        bytes_per_pixel_with_depth(self.material_textures) + layers
    }

    /// GPU memory of the G-buffer's own targets, every sample (depth belongs
    /// to the frame).
    pub fn bytes(&self) -> u64 {
        let samples = u64::from(self.normal.sample_count());
        self.normal.width() as u64 * self.normal.height() as u64 * samples * (self.bytes_per_pixel_with_depth() - 4)
    }
}

/// The G-buffer raster pipeline.
pub struct GbufferPass {
    pipeline: ScenePipeline,
    after_prepass: bool,
}

impl GbufferPass {
    /// `after_prepass`: the depth target already holds the scene's depth
    /// (test `Equal`: each pixel's fragment runs once); otherwise the pass
    /// clears and writes depth itself. `samples`: per pixel of the targets.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        after_prepass: bool,
        samples: u32,
    ) -> Result<Self, ShaderError> {
        let depth = DepthMode::after(after_prepass);
        let formats: Vec<_> = written(scene.material_textures, scene.layers).into_iter().map(|i| FORMATS[i]).collect();
        let raster = SceneRaster {
            shader: SHADER,
            vertex_entry: "vs_main",
            fragment: Some(("fs_main", &formats)),
            depth,
            groups: &[],
            blend: None,
            samples,
        };
        let pipeline = scene_raster_pipeline_from(device, shaders, scene, &raster)?;
        Ok(Self { pipeline, after_prepass })
    }
}

/// Reads: the visible objects, and the depth target when built after a
/// pre-pass. Writes: `out`'s targets (cleared first) and unproject uniform
/// (this frame's view), and the depth target.
/// Draws what `cull` kept where it culled.
pub fn gbuffer(frame: &mut Frame, pass: &GbufferPass, out: &GBuffer, cull: Option<&ClusterCull>) {
    frame.queue.write_buffer(&out.unproject, 0, bytemuck::bytes_of(&GpuUnproject::new(frame.view)));
    let (scene, targets, visible) = (frame.scene, frame.targets, frame.visible);
    let color: Vec<_> = written(out.material_textures, out.layers)
        .into_iter()
        .map(|i| color_attachment(&out.views[i], wgpu::Color::TRANSPARENT))
        .collect();
    let mut rp = frame.render_pass("gbuffer", &color, Some(depth_attachment(targets, !pass.after_prepass)));
    draw_scene(&mut rp, scene, visible, &pass.pipeline, cull);
}

/// The geometry stage both deferred pipelines share: an optional depth
/// pre-pass, the G-buffer pass, and the G-buffer it fills.
pub struct GbufferStage {
    prepass: Option<DepthPrepass>,
    pass: GbufferPass,
    pub gbuffer: GBuffer,
}

impl GbufferStage {
    /// Cluster culling in the depth pre-pass, if the stage has one
    /// ([`DepthPrepass::enable_cluster_culling`]).
    pub fn enable_cluster_culling(
        &mut self,
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
    ) -> Result<(), ShaderError> {
        if let Some(prepass) = &mut self.prepass {
            prepass.enable_cluster_culling(device, shaders, scene, targets, &mut self.pass.pipeline)?;
        }
        Ok(())
    }

    /// The passes that draw cluster lists: the pre-pass and the G-buffer
    /// pass once culling is enabled, else none.
    pub fn cluster_draw_passes(&self) -> u64 {
        let culls = self.prepass.as_ref().is_some_and(DepthPrepass::culls);
        u64::from(culls) + u64::from(culls && self.pass.pipeline.draws_clusters())
    }

    /// The depth pre-pass (with its culling), if the stage has one.
    pub fn prepass(&self) -> Option<&DepthPrepass> {
        self.prepass.as_ref()
    }

    /// [`Self::prepass`], to record with.
    pub fn prepass_mut(&mut self) -> Option<&mut DepthPrepass> {
        self.prepass.as_mut()
    }

    /// With `depth_prepass`, depth is laid down first and the G-buffer pass
    /// runs one fragment per pixel. As many samples per pixel as `targets`.
    pub fn new(
        device: &wgpu::Device,
        shaders: &mut ShaderLibrary,
        scene: &SceneGpu,
        targets: &Targets,
        depth_prepass: bool,
    ) -> Result<Self, ShaderError> {
        let samples = targets.samples;
        let prepass = depth_prepass.then(|| DepthPrepass::new(device, shaders, scene, samples)).transpose()?;
        let pass = GbufferPass::new(device, shaders, scene, depth_prepass, samples)?;
        Ok(Self { prepass, pass, gbuffer: GBuffer::new(device, targets, scene.material_textures, scene.layers) })
    }
}

/// Reads: the visible objects. Writes: the depth target and the G-buffer
/// (the depth pre-pass, when the stage has one, then the G-buffer pass).
pub fn geometry(frame: &mut Frame, stage: &mut GbufferStage) {
    if let Some(prepass) = &mut stage.prepass {
        culled_depth_prepass(frame, prepass);
    }
    let cull = stage.prepass.as_ref().and_then(DepthPrepass::cull);
    gbuffer(frame, &stage.pass, &stage.gbuffer, cull);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::scene_gpu::gpu_view;
    use crate::scene::Camera;
    use glam::Vec3;

    fn camera() -> Camera {
        Camera {
            position: Vec3::new(1.0, 2.0, 3.0),
            forward: Vec3::new(0.3, -0.2, -1.0).normalize(),
            up: Vec3::Y,
            fov_y: 1.0,
            near: 0.1,
            far: 1000.0,
        }
    }

    /// Unprojecting a projected point gives it back, near and far.
    #[test]
    fn unproject_inverts_the_view_projection() {
        let view = gpu_view(&camera(), 320, 180);
        let u = GpuUnproject::new(&view);
        for p in [Vec3::new(1.2, 1.9, 2.0), Vec3::new(5.0, -3.0, -40.0), Vec3::new(80.0, -50.0, -600.0)] {
            let clip = view.view_proj * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let back = u.world(ndc.x, ndc.y, ndc.z);
            let error = back.distance(p) / p.distance(camera().position);
            assert!(error < 1e-4, "{p} -> {back} (relative error {error})");
        }
    }
}
