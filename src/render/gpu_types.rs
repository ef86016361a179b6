//! Rust mirrors of the WGSL structs in `shaders/scene.wgsl` and
//! `shaders/lighting.wgsl`. Sizes are checked by tests against naga's layout.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::scene::{Light, LightKind};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuVertex {
    pub position: Vec3,
    pub uv0_x: f32,
    pub normal: Vec3,
    pub uv0_y: f32,
    pub tangent: Vec4,
    pub chart_uv: Vec2,
    pub pad: Vec2,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuObject {
    pub model: Mat4,
    pub normal_model: Mat4,
    pub base_color: Vec4,
    pub emissive: Vec3,
    pub albedo_layer: u32,
    pub light_offset: u32,
    pub light_count: u32,
    pub first_index: u32,
    pub base_vertex: u32,
    pub specular: f32,
    pub shininess: f32,
    pub atlas_entry: u32,
    pub flags: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuView {
    pub view_proj: Mat4,
    pub inv_view_proj: Mat4,
    pub camera_position: Vec4,
    pub viewport: Vec4,
    pub frame: u32,
    pub exposure: f32,
    pub pad: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuLight {
    pub position: Vec3,
    pub kind: u32,
    pub direction: Vec3,
    pub radius: f32,
    pub radiance: Vec3,
    pub cos_inner: f32,
    pub cos_outer: f32,
    pub shadow: i32,
    pub pad: [u32; 2],
}

impl From<&Light> for GpuLight {
    fn from(l: &Light) -> Self {
        let kind = match l.kind {
            LightKind::Ambient => 0,
            LightKind::Directional => 1,
            LightKind::Point => 2,
            LightKind::Spot => 3,
        };
        GpuLight {
            position: l.position,
            kind,
            direction: l.direction.normalize_or(Vec3::NEG_Y),
            radius: l.radius,
            radiance: l.color * l.intensity,
            cos_inner: l.cos_inner,
            cos_outer: l.cos_outer,
            shadow: -1,
            pad: [0; 2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shaders::{ShaderLibrary, ShaderSource};

    /// The Rust structs must have exactly the sizes naga computes for the WGSL ones.
    #[test]
    fn sizes_match_wgsl() {
        const PROBE: ShaderSource = ShaderSource {
            file: "probe.wgsl",
            source: "#import shadespace::scene::{Vertex, Object, View}\n#import shadespace::lighting::Light\n#import shadespace::objectspace::AtlasEntry\n\
                     @group(0) @binding(0) var<storage> a: array<Vertex>;\n@group(0) @binding(1) var<storage> b: array<Object>;\n\
                     @group(0) @binding(2) var<storage> c: array<View>;\n@group(0) @binding(3) var<storage> d: array<Light>;\n\
                     @group(0) @binding(4) var<storage> e: array<AtlasEntry>;\n\
                     @compute @workgroup_size(1) fn main() { _ = a[0]; _ = b[0]; _ = c[0]; _ = d[0]; _ = e[0]; }",
        };
        let module = ShaderLibrary::new().unwrap().compose(PROBE).unwrap();
        let mut layouter = wgpu::naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let size_of = |name: &str| {
            let (handle, _) = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref().is_some_and(|n| n.starts_with(name)))
                .unwrap_or_else(|| panic!("no type {name}"));
            layouter[handle].size as usize
        };
        assert_eq!(size_of("Vertex"), size_of_val(&GpuVertex::default()));
        assert_eq!(size_of("Object"), size_of_val(&GpuObject::default()));
        assert_eq!(size_of("View"), size_of_val(&GpuView::default()));
        assert_eq!(size_of("Light"), size_of_val(&GpuLight::default()));
        assert_eq!(size_of("AtlasEntry"), std::mem::size_of::<crate::render::objectspace::atlas::GpuAtlasEntry>());
    }
}
