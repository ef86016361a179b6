//! Rust mirrors of the scene structs every pipeline reads
//! (`shaders/shared/scene.wgsl`, `shaders/shared/lighting.wgsl`). Their
//! layouts are compared member by member with naga's (`shaders::layout`).

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::scene::{Light, LightKind};
use crate::shaders::gpu_struct;

gpu_struct! {
    /// 48 bytes: pulled from a storage buffer by index, so raster and compute
    /// passes read the same data.
    pub struct GpuVertex as "Vertex" {
        pub position: Vec3,
        pub uv0_x: f32,
        pub normal: Vec3,
        pub uv0_y: f32,
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
        pub specular: f32,
        pub shininess: f32,
        pub pad_a: u32,
        pub pad_b: u32,
    }
}

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
        pub pad_a: u32,
        pub pad_b: u32,
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

/// `Light.kind` in WGSL (exported to it as `LIGHT_*` by `shaders::contract`).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuLightKind {
    Ambient = 0,
    Directional = 1,
    Point = 2,
    Spot = 3,
}

impl GpuLightKind {
    pub const ALL: [Self; 4] = [Self::Ambient, Self::Directional, Self::Point, Self::Spot];

    pub fn wgsl_name(self) -> &'static str {
        match self {
            Self::Ambient => "LIGHT_AMBIENT",
            Self::Directional => "LIGHT_DIRECTIONAL",
            Self::Point => "LIGHT_POINT",
            Self::Spot => "LIGHT_SPOT",
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
