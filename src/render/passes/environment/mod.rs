//! Environment lighting's maps (`--env`, docs/environment.md), prefiltered
//! once at load in compute (`prefilter.wgsl`): the source (procedural sky
//! or equirectangular image) into a cube map with a box mip chain, then the
//! split sum's GGX-prefiltered cube map (one roughness per mip, importance
//! sampled), a 16x16 irradiance cube map and the split sum's 32x32 BRDF
//! lookup table (importance sampled; Karis's analytic fit for mobile was
//! measured up to 0.19 off the integral, `cpu::split_sum`). Lights of kind
//! `LightKind::Environment` read them through `shared/environment.wgsl`
//! (scene bindings 14-17).

pub mod cpu;

use glam::Vec3;

use super::Binding;
use crate::gpu::{GpuContext, GpuError, readback};
use crate::scene::environment::{Environment, Sky};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource, gpu_struct};

pub const SHADER: ShaderSource = ShaderSource::new("environment/prefilter.wgsl", include_str!("prefilter.wgsl"));

/// Format of every environment map (half floats: HDR radiance, filterable
/// and writable from compute on every adapter).
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Mips of the prefiltered map: level k holds GGX roughness k / 5 (0, 0.2,
/// ..., 1), so the smallest face is 1/32 of the first.
pub const SPECULAR_LEVELS: u32 = 6;

/// Side of the irradiance map's faces (irradiance varies slowly).
pub const IRRADIANCE_SIZE: u32 = 16;

/// Side of the source level the irradiance is summed over (6 x 32 x 32
/// texels per irradiance texel).
pub const IRRADIANCE_SOURCE_SIZE: u32 = 32;

/// Face side of the sky's maps: its sun (about 1.3 degrees) spans a few
/// texels of a 128x128 face (0.7 degrees each).
pub const SKY_FACE_SIZE: u32 = 128;

/// Largest face side for an image: a quarter of its width, up to 256 (mirror
/// reflections at 0.35 degrees a texel; larger faces cost prefiltering time
/// for detail only mirror-like surfaces show).
pub const MAX_FACE_SIZE: u32 = 256;

/// GGX samples per prefiltered texel.
pub const SAMPLES: u32 = 256;

/// Side of the BRDF lookup table (N.V across, roughness down; it is smooth).
pub const BRDF_LUT_SIZE: u32 = 32;

/// GGX samples per lookup-table texel.
pub const BRDF_LUT_SAMPLES: u32 = 1024;

gpu_struct! {
    /// The prefilter's parameters (`EnvParams` in `prefilter.wgsl`).
    pub struct GpuEnvParams as "EnvParams" {
        pub sun_direction: Vec3,
        pub sun_sharpness: f32,
        pub sun_color: Vec3,
        pub size: u32,
        pub zenith: Vec3,
        pub roughness: f32,
        pub horizon: Vec3,
        pub samples: u32,
        pub ground: Vec3,
        pub source_size: u32,
        pub equirect_width: u32,
        pub equirect_height: u32,
        pub taps: u32,
        pub pad: u32,
    }
}

/// The maps the lighting reads: the prefiltered specular cube (its mips are
/// roughness levels), the irradiance cube (irradiance / pi) and the BRDF
/// lookup table (scale and bias of F0 by N.V and roughness).
pub struct EnvironmentMaps {
    pub specular: wgpu::Texture,
    pub irradiance: wgpu::Texture,
    pub brdf_lut: wgpu::Texture,
    specular_view: wgpu::TextureView,
    irradiance_view: wgpu::TextureView,
    brdf_lut_view: wgpu::TextureView,
}

impl EnvironmentMaps {
    /// Black 1x1 maps: the bindings of a scene without an environment.
    pub fn black(device: &wgpu::Device) -> Self {
        // New textures are zero-initialized by wgpu.
        let none = "environment (none)";
        Self::from_textures(cube(device, none, 1, 1), cube(device, none, 1, 1), texture(device, none, 1, 1, 1))
    }

    fn from_textures(specular: wgpu::Texture, irradiance: wgpu::Texture, brdf_lut: wgpu::Texture) -> Self {
        let specular_view = super::view_as(&specular, wgpu::TextureViewDimension::Cube);
        let irradiance_view = super::view_as(&irradiance, wgpu::TextureViewDimension::Cube);
        let brdf_lut_view = super::view_as(&brdf_lut, wgpu::TextureViewDimension::D2);
        Self { specular, irradiance, brdf_lut, specular_view, irradiance_view, brdf_lut_view }
    }

    pub fn specular_view(&self) -> &wgpu::TextureView {
        &self.specular_view
    }

    pub fn irradiance_view(&self) -> &wgpu::TextureView {
        &self.irradiance_view
    }

    pub fn brdf_lut_view(&self) -> &wgpu::TextureView {
        &self.brdf_lut_view
    }

    /// Whether these are a scene's maps, not the black placeholders.
    pub fn is_set(&self) -> bool {
        self.specular.width() > 1
    }

    /// Bytes of the three maps, mips included.
    pub fn bytes(&self) -> u64 {
        [&self.specular, &self.irradiance, &self.brdf_lut]
            .iter()
            .map(|t| {
                let texel_bytes = 8 * u64::from(t.depth_or_array_layers());
                (0..t.mip_level_count()).map(|k| texel_bytes * u64::from((t.width() >> k).max(1)).pow(2)).sum::<u64>()
            })
            .sum()
    }

    /// Level `level` of `texture` (one of these maps) read back (blocks):
    /// per layer (cube faces +x, -x, +y, -y, +z, -z), row-major linear RGB.
    pub fn read_level(ctx: &GpuContext, texture: &wgpu::Texture, level: u32) -> Result<Vec<Vec<Vec3>>, GpuError> {
        let size = (texture.width() >> level).max(1);
        (0..texture.depth_or_array_layers())
            .map(|face| {
                let bytes = readback::read_texture_level(ctx, texture, 8, level, face, (size, size))?;
                let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
                Ok(halves.chunks_exact(4).map(|t| Vec3::new(t[0].to_f32(), t[1].to_f32(), t[2].to_f32())).collect())
            })
            .collect()
    }
}

/// Face side of the maps of `env`.
pub fn face_size(env: &Environment) -> u32 {
    match env {
        Environment::Sky(_) => SKY_FACE_SIZE,
        Environment::Image(img) => (img.width / 4).next_power_of_two().clamp(IRRADIANCE_SOURCE_SIZE, MAX_FACE_SIZE),
    }
}

fn cube(device: &wgpu::Device, label: &str, size: u32, levels: u32) -> wgpu::Texture {
    texture(device, label, size, levels, 6)
}

fn texture(device: &wgpu::Device, label: &str, size: u32, levels: u32, layers: u32) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// One mip of a cube texture as the six layers of a 2D array.
fn level_view(texture: &wgpu::Texture, level: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        base_mip_level: level,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

/// Prefilters `env` into its maps on the GPU (waits for nothing: the frames
/// after it are queued behind it).
pub fn prefilter(
    ctx: &GpuContext,
    shaders: &mut ShaderLibrary,
    env: &Environment,
) -> Result<EnvironmentMaps, ShaderError> {
    let device = &ctx.device;
    let size = face_size(env);
    let source_levels = size.ilog2() + 1;
    let source = cube(device, "environment source", size, source_levels);
    let specular = cube(device, "environment specular", size, SPECULAR_LEVELS);
    let irradiance = cube(device, "environment irradiance", IRRADIANCE_SIZE, 1);
    let brdf_lut = texture(device, "environment BRDF", BRDF_LUT_SIZE, 1, 1);

    let module = shaders.module(device, SHADER)?;
    let pipeline = |entry: &str| {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    };
    let sky = match env {
        Environment::Sky(s) => *s,
        Environment::Image(_) => Sky::uniform(Vec3::ZERO),
    };
    let base = GpuEnvParams {
        sun_direction: sky.sun_direction.normalize_or(Vec3::Y),
        sun_sharpness: sky.sun_sharpness,
        sun_color: sky.sun_color,
        zenith: sky.zenith,
        horizon: sky.horizon,
        ground: sky.ground,
        source_size: size,
        samples: SAMPLES,
        taps: 1,
        ..Default::default()
    };
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("environment"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("environment") });
    // One dispatch: `entry` writes level `out_level` of `out` (side
    // `out_size`) with `inputs` bound besides the parameters and the target.
    let dispatch = |encoder: &mut wgpu::CommandEncoder,
                    entry: &str,
                    params: GpuEnvParams,
                    out: &wgpu::Texture,
                    out_level: u32,
                    inputs: &[(u32, wgpu::BindingResource)]| {
        let pipeline = pipeline(entry);
        let uniform = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("environment params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            },
        );
        let target = level_view(out, out_level);
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&target) },
        ];
        entries
            .extend(inputs.iter().map(|(binding, r)| wgpu::BindGroupEntry { binding: *binding, resource: r.clone() }));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(entry),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(entry), ..Default::default() });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(params.size.div_ceil(8), params.size.div_ceil(8), out.depth_or_array_layers());
    };

    // The source's level 0, then its box mip chain.
    match env {
        Environment::Sky(_) => dispatch(&mut encoder, "source_sky", GpuEnvParams { size, ..base }, &source, 0, &[]),
        Environment::Image(img) => {
            let texels: Vec<[f32; 4]> = img.rgb.chunks_exact(3).map(|c| [c[0], c[1], c[2], 0.0]).collect();
            let buffer = wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("environment image"),
                    contents: bytemuck::cast_slice(&texels),
                    usage: wgpu::BufferUsages::STORAGE,
                },
            );
            let params = GpuEnvParams {
                size,
                equirect_width: img.width,
                equirect_height: img.height,
                taps: (img.width / (4 * size)).clamp(1, 4),
                ..base
            };
            dispatch(&mut encoder, "source_equirect", params, &source, 0, &[(2, buffer.as_entire_binding())]);
        }
    }
    for level in 1..source_levels {
        let above = level_view(&source, level - 1);
        let params = GpuEnvParams { size: size >> level, ..base };
        dispatch(
            &mut encoder,
            "downsample",
            params,
            &source,
            level,
            &[(3, wgpu::BindingResource::TextureView(&above))],
        );
    }
    // Roughness 0 is the source itself; each further level prefilters it.
    let layers = wgpu::Extent3d { width: size, height: size, depth_or_array_layers: 6 };
    encoder.copy_texture_to_texture(source.as_image_copy(), specular.as_image_copy(), layers);
    let source_cube = super::view_as(&source, wgpu::TextureViewDimension::Cube);
    for level in 1..SPECULAR_LEVELS {
        let roughness = level as f32 / (SPECULAR_LEVELS - 1) as f32;
        let params = GpuEnvParams { size: size >> level, roughness, ..base };
        let inputs =
            [(4, wgpu::BindingResource::TextureView(&source_cube)), (5, wgpu::BindingResource::Sampler(&sampler))];
        dispatch(&mut encoder, "prefilter", params, &specular, level, &inputs);
    }
    let irradiance_source = level_view(&source, (size / IRRADIANCE_SOURCE_SIZE).ilog2());
    let params = GpuEnvParams { size: IRRADIANCE_SIZE, ..base };
    dispatch(
        &mut encoder,
        "irradiance",
        params,
        &irradiance,
        0,
        &[(3, wgpu::BindingResource::TextureView(&irradiance_source))],
    );
    let params = GpuEnvParams { size: BRDF_LUT_SIZE, samples: BRDF_LUT_SAMPLES, ..base };
    dispatch(&mut encoder, "brdf_lut", params, &brdf_lut, 0, &[]);
    ctx.queue.submit([encoder.finish()]);
    Ok(EnvironmentMaps::from_textures(specular, irradiance, brdf_lut))
}

/// The scene group's environment bindings (14-17) in `scene_gpu`'s layout.
pub fn scene_bindings() -> [Binding; 4] {
    let sample = wgpu::TextureSampleType::Float { filterable: true };
    let cube = Binding::Texture { sample, dimension: wgpu::TextureViewDimension::Cube };
    let lut = Binding::Texture { sample, dimension: wgpu::TextureViewDimension::D2 };
    [cube, cube, Binding::Sampler, lut]
}
