//! Rust mirrors of the scene structs every pipeline reads
//! (`shaders/shared/scene.wgsl`, `shaders/shared/lighting.wgsl`). Their
//! layouts are compared member by member with naga's (`render::shader_set`'s test, with `shaders::layout`).

use glam::{Mat4, Vec2, Vec3, Vec4};
use serde::Serialize;

use crate::scene::{Light, LightKind};
use crate::shaders::gpu_struct;

gpu_struct! {
    /// 64 bytes: pulled from a storage buffer by index, so raster and compute
    /// passes read the same data.
    pub struct GpuVertex as "Vertex" {
        pub position: Vec3,
        pub uv0_x: f32,
        pub normal: Vec3,
        pub uv0_y: f32,
        /// MikkTSpace tangent (xyz) and bitangent sign (w), for normal maps.
        pub tangent: Vec4,
        /// The object's unique chart (object-space shading).
        pub chart_uv: Vec2,
        pub pad_a: f32,
        pub pad_b: f32,
    }
}

gpu_struct! {
    pub struct GpuObject as "Object" {
        pub model: Mat4,
        /// Inverse transpose of `model` (upper 3x3 used).
        pub normal_model: Mat4,
        pub base_color: Vec4,
        pub emissive: Vec3,
        pub albedo_layer: u32,
        /// This frame's light list: `light_indices[light_offset..][..light_count]`.
        pub light_offset: u32,
        pub light_count: u32,
        pub first_index: u32,
        pub base_vertex: u32,
        /// Phong's specular strength and exponent.
        pub specular: f32,
        pub shininess: f32,
        /// GGX's metallic and perceptual roughness.
        pub metallic: f32,
        pub roughness: f32,
        /// Layer of the linear texture array holding the normal map, or [`NO_TEXTURE`].
        pub normal_layer: u32,
        /// Layer of the colour (sRGB) array holding the emissive texture
        /// (multiplying `emissive`), or [`NO_TEXTURE`].
        pub emissive_layer: u32,
        /// Layer of the linear array holding the metallic-roughness texture
        /// (blue, green multiplying `metallic`, `roughness`), or [`NO_TEXTURE`].
        pub metal_rough_layer: u32,
        /// Layer of the linear array holding the occlusion texture (red), or [`NO_TEXTURE`].
        pub occlusion_layer: u32,
        /// Occlusion is `1 + occlusion_strength * (red - 1)`, on ambient light only.
        pub occlusion_strength: f32,
        /// Fragments whose alpha (base colour factor times texture) is below
        /// this are cut away (alpha masking); 0 for opaque objects.
        pub alpha_cutoff: f32,
        /// The material's layers: entries `layer_first..layer_first +
        /// layer_count` of the layer table ([`crate::materials::GpuLayer`],
        /// binding 13); no layers for a plain material.
        pub layer_first: u32,
        pub layer_count: u32,
        /// 1 where the material is single-sided (not
        /// [`crate::scene::Material::double_sided`]): the compute
        /// rasterizer and the cluster cone test cull its back faces.
        pub cull_back: u32,
        pub pad_a: u32,
        pub pad_b: u32,
        pub pad_c: u32,
    }
}

/// A texture layer of an object without that texture (`Object.normal_layer`
/// and the other layers).
pub const NO_TEXTURE: u32 = u32::MAX;

gpu_struct! {
    pub struct GpuView as "View" {
        pub view_proj: Mat4,
        pub camera_position: Vec4,
        /// width, height, 1/width, 1/height
        pub viewport: Vec4,
        /// Lights in the light buffer.
        pub light_count: u32,
        /// The first `global_light_count` lights are ambient or directional:
        /// they reach everywhere, so light grids list only the others.
        pub global_light_count: u32,
        /// A [`ShadingModel`] (the lighting model every pass evaluates).
        pub shading: u32,
        /// Added to the mip level of every material texture sample taken
        /// from a footprint (0: none); see `Renderer::texture_lod_bias`.
        pub texture_lod_bias: f32,
    }
}

gpu_struct! {
    pub struct GpuLight as "Light" {
        pub position: Vec3,
        /// A [`GpuLightKind`].
        pub kind: u32,
        /// Direction the light travels (directional, spot).
        pub direction: Vec3,
        pub radius: f32,
        /// Colour times intensity.
        pub radiance: Vec3,
        pub cos_inner: f32,
        pub cos_outer: f32,
        /// Its first shadow face (`render::passes::shadows`).
        pub shadow_face: u32,
        /// Its number of shadow faces: 0 (casts no shadow), 1 (spot), 6
        /// (cube) or, for the sun, its cascades.
        pub shadow_faces: u32,
        pub pad_c: u32,
    }
}

/// The lighting model of `lighting.wgsl` (`--shading`), the same in every
/// pipeline; `View.shading` in WGSL (`SHADING_*` in `shaders::contract`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ShadingModel {
    /// Phong: diffuse plus a specular lobe `specular * max(R.V, 0)^shininess`
    /// (the studies' model).
    #[default]
    Phong = 0,
    /// GGX metallic-roughness (Cook-Torrance: GGX distribution, height-correlated
    /// Smith visibility, Schlick Fresnel), as glTF 2.0 materials define it.
    Pbr = 1,
}

impl ShadingModel {
    pub const ALL: [Self; 2] = [Self::Phong, Self::Pbr];

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Phong => "SHADING_PHONG",
            Self::Pbr => "SHADING_PBR",
        }
    }
}

/// `Light.kind` in WGSL (exported to it as `LIGHT_*` by `shaders::contract`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuLightKind {
    Ambient = 0,
    Directional = 1,
    Point = 2,
    Spot = 3,
    Environment = 4,
}

impl GpuLightKind {
    pub const ALL: [Self; 5] = [Self::Ambient, Self::Directional, Self::Point, Self::Spot, Self::Environment];

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Ambient => "LIGHT_AMBIENT",
            Self::Directional => "LIGHT_DIRECTIONAL",
            Self::Point => "LIGHT_POINT",
            Self::Spot => "LIGHT_SPOT",
            Self::Environment => "LIGHT_ENVIRONMENT",
        }
    }
}

impl From<LightKind> for GpuLightKind {
    fn from(kind: LightKind) -> Self {
        match kind {
            LightKind::Ambient => Self::Ambient,
            LightKind::Directional => Self::Directional,
            LightKind::Point => Self::Point,
            LightKind::Spot => Self::Spot,
            LightKind::Environment => Self::Environment,
        }
    }
}

impl From<&Light> for GpuLight {
    fn from(l: &Light) -> Self {
        GpuLight {
            position: l.position,
            kind: GpuLightKind::from(l.kind) as u32,
            direction: l.direction.normalize_or(Vec3::NEG_Y),
            radius: l.radius,
            radiance: l.color * l.intensity,
            cos_inner: l.cos_inner,
            cos_outer: l.cos_outer,
            ..Default::default()
        }
    }
}
