//! CPU twin of shade evaluation (`shade/shade.wgsl`): for a texel of a
//! level, its triangle (from the triangle map the GPU built, itself checked
//! by `trimap::cpu`), its barycentrics in the chart triangle, the surface
//! point there, and its shade by the shared lighting model
//! (`shaders/shared/lighting.wgsl`) evaluated in Rust, in `f32` and in the
//! WGSL's order.
//!
//! Evaluated rather than read back from a reference pass because no other
//! pass shades at texel centres, and a pixel of forward shading would test
//! rasterization and filtering as well. The twin covers what every scene
//! uses: Phong, point, spot, ambient and directional lights, vertex
//! normals, base colours and emission; not textures (whose sampling would
//! twin the sampler, not this code), GGX or shadows: [`unsupported`] says
//! when a scene needs more.

use glam::{UVec2, Vec2, Vec3, Vec4Swizzles};

use super::chart_uvs;
use crate::render::gpu_types::{GpuLight, GpuLightKind};
use crate::scene::{Light, Scene};

/// Bound on a shaded channel, in units in the last place of `Rgba16Float`
/// at the twin's value ([`super::f16_ulp`]): the atlas stores 11
/// significant bits (lavapipe rounds towards zero: up to one unit), and
/// the GPU's `f32` arithmetic (its `pow`, `normalize`, summation order) may
/// carry a value across a rounding step. On lavapipe the largest difference
/// in `tests/it/stage_twins.rs` is 1.0 unit (atrium and floor).
pub const SHADE_ULPS: f32 = 2.0;

/// What the twin does not model in `scene` lit by `lights`, if anything.
pub fn unsupported(scene: &Scene, lights: &[Light]) -> Option<String> {
    if let Some(m) = scene.materials.iter().find(|m| m.textures().iter().any(Option::is_some)) {
        return Some(format!("material '{}' has textures", m.name));
    }
    if lights.iter().any(|l| l.casts_shadows) {
        return Some("a light casts shadows".into());
    }
    None
}

/// Mirrors `chart_barycentrics`: barycentrics of `uv` in the chart
/// triangle (a, c, d), extrapolated outside it.
pub fn chart_barycentrics(a: Vec2, c: Vec2, d: Vec2, uv: Vec2) -> Vec3 {
    let e0 = c - a;
    let e1 = d - a;
    let det = e0.x * e1.y - e0.y * e1.x;
    if det.abs() < 1e-20 {
        return Vec3::X;
    }
    let r = uv - a;
    let v = (r.x * e1.y - r.y * e1.x) / det;
    let w = (e0.x * r.y - e0.y * r.x) / det;
    Vec3::new(1.0 - v - w, v, w)
}

/// The surface at a texel centre: what `surface_point` hands the lighting
/// (Phong, no textures).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelSurface {
    /// The triangle of the object's mesh (triangle map's id - 1).
    pub triangle: usize,
    /// Barycentrics of the texel centre in the triangle's chart.
    pub b: Vec3,
    pub position: Vec3,
    /// Unit world normal.
    pub normal: Vec3,
    pub albedo: Vec3,
    pub specular: f32,
    pub shininess: f32,
    pub emission: Vec3,
}

/// The surface of `object` at the centre of texel `texel` of a level
/// `size` texels wide, whose triangle map names `triangle` (id - 1).
pub fn texel_surface(scene: &Scene, object: usize, size: u32, texel: UVec2, triangle: usize) -> TexelSurface {
    surface_at(scene, object, (texel.as_vec2() + 0.5) / size as f32, triangle)
}

/// Mirrors `shade` in `shade.wgsl`: the shade of texel `texel` (of a level
/// `size` texels wide, covered by `triangle`), the mean over `side` x
/// `side` points spread over it (its centre alone for 1).
pub fn texel_shade(
    scene: &Scene,
    object: usize,
    (size, side): (u32, u32),
    texel: UVec2,
    triangle: usize,
    lights: &[GpuLight],
    camera: Vec3,
) -> Vec3 {
    let step = 1.0 / (size * side) as f32;
    let mut color = Vec3::ZERO;
    for sy in 0..side {
        for sx in 0..side {
            let uv = ((texel * side + UVec2::new(sx, sy)).as_vec2() + 0.5) * step;
            color += shade(&surface_at(scene, object, uv, triangle), lights, camera);
        }
    }
    color / (side * side) as f32
}

/// The surface of `object` at chart point `uv` of `triangle`'s plane.
fn surface_at(scene: &Scene, object: usize, uv: Vec2, triangle: usize) -> TexelSurface {
    let o = &scene.objects[object];
    let mesh = &scene.meshes[o.mesh];
    let material = &scene.materials[o.material];
    let tri = [0, 1, 2].map(|k| mesh.indices[3 * triangle + k] as usize);
    let charts = chart_uvs(mesh);
    let b = chart_barycentrics(charts[tri[0]], charts[tri[1]], charts[tri[2]], uv);
    let local = mesh.positions[tri[0]] * b.x + mesh.positions[tri[1]] * b.y + mesh.positions[tri[2]] * b.z;
    let n = mesh.normals[tri[0]] * b.x + mesh.normals[tri[1]] * b.y + mesh.normals[tri[2]] * b.z;
    let normal_model = o.transform.inverse().transpose();
    TexelSurface {
        triangle,
        b,
        position: (o.transform * local.extend(1.0)).xyz(),
        normal: (normal_model * n.extend(0.0)).xyz().normalize(),
        albedo: material.base_color.xyz(),
        specular: material.specular,
        shininess: material.shininess,
        emission: material.emissive,
    }
}

/// WGSL's `reflect`.
fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - 2.0 * n.dot(i) * n
}

/// Mirrors `attenuation`.
pub fn attenuation(d: f32, radius: f32) -> f32 {
    let fade = ((radius - d) / (0.1 * radius)).clamp(0.0, 1.0);
    fade / (1.0 + d * d)
}

/// Mirrors `light_radiance` for the Phong model, with no shadow and no
/// environment light (the twin has no environment maps).
pub fn light_radiance(light: &GpuLight, s: &TexelSurface, to_eye: Vec3) -> Vec3 {
    let kind = light.kind;
    if kind == GpuLightKind::Ambient as u32 {
        return light.radiance * s.albedo;
    }
    let (to_light, mut falloff) = if kind == GpuLightKind::Directional as u32 {
        (-light.direction, 1.0)
    } else {
        let d = light.position - s.position;
        let dist = d.length();
        if dist >= light.radius {
            return Vec3::ZERO;
        }
        let to_light = d / dist.max(1e-6);
        (to_light, attenuation(dist, light.radius))
    };
    if kind == GpuLightKind::Spot as u32 {
        let cos_theta = (-to_light).dot(light.direction);
        falloff *= ((cos_theta - light.cos_outer) / (light.cos_inner - light.cos_outer).max(1e-4)).clamp(0.0, 1.0);
    }
    let n_dot_l = s.normal.dot(to_light);
    if n_dot_l <= 0.0 || falloff <= 0.0 {
        return Vec3::ZERO;
    }
    let r = reflect(-to_light, s.normal);
    let spec = s.specular * r.dot(to_eye).max(0.0).powf(s.shininess);
    light.radiance * falloff * (s.albedo * n_dot_l + Vec3::splat(spec))
}

/// The shade of surface `s` seen from `camera`: emission plus every light
/// (`light_surface_in_cell` sums the global lights and those of the
/// point's world-grid cell; a light the grid leaves out of the cell must
/// reach no point of it, so summing all of them is the contract).
pub fn shade(s: &TexelSurface, lights: &[GpuLight], camera: Vec3) -> Vec3 {
    let to_eye = (camera - s.position).normalize();
    lights.iter().fold(s.emission, |c, l| c + light_radiance(l, s, to_eye))
}

/// The difference of the GPU's shade `gpu` from the twin's `cpu`: its
/// largest channel, in units in the last place of `Rgba16Float` at `cpu`.
pub fn shade_ulps(gpu: Vec3, cpu: Vec3) -> f32 {
    (0..3).map(|i| (gpu[i] - cpu[i]).abs() / super::f16_ulp(cpu[i])).fold(0.0, f32::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chart_barycentrics_extrapolate_outside_the_triangle() {
        let (a, c, d) = (Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0));
        assert_eq!(chart_barycentrics(a, c, d, Vec2::new(0.25, 0.5)), Vec3::new(0.25, 0.25, 0.5));
        assert_eq!(chart_barycentrics(a, c, d, Vec2::new(-1.0, 0.0)), Vec3::new(2.0, -1.0, 0.0));
        // Degenerate: the first vertex.
        assert_eq!(chart_barycentrics(a, c, c, Vec2::new(0.5, 0.5)), Vec3::X);
    }

    fn surface() -> TexelSurface {
        TexelSurface {
            triangle: 0,
            b: Vec3::X,
            position: Vec3::ZERO,
            normal: Vec3::Y,
            albedo: Vec3::new(1.0, 0.5, 0.25),
            specular: 0.5,
            shininess: 2.0,
            emission: Vec3::ZERO,
        }
    }

    fn point(position: Vec3, radius: f32) -> GpuLight {
        GpuLight { position, kind: GpuLightKind::Point as u32, radius, radiance: Vec3::ONE, ..Default::default() }
    }

    #[test]
    fn point_lights_fade_with_distance_and_cut_off_at_their_radius() {
        let s = surface();
        // One metre above: attenuation 1/2, N.L 1; the eye straight up sees
        // the reflection: specular 0.5 * 1^2.
        let up = point(Vec3::Y, 10.0);
        let c = light_radiance(&up, &s, Vec3::Y);
        assert!((c - (s.albedo + Vec3::splat(0.5)) * 0.5).abs().max_element() < 1e-6, "{c}");
        // Past the radius, nothing; within its last tenth, a linear fade.
        assert_eq!(light_radiance(&point(Vec3::Y, 1.0), &s, Vec3::Y), Vec3::ZERO);
        let fading = light_radiance(&point(Vec3::Y, 1.05), &s, Vec3::Y);
        assert!((fading.x - (0.05 / 0.105) * 1.5 * 0.5).abs() < 1e-5, "{fading}");
        // Below the surface, nothing.
        assert_eq!(light_radiance(&point(-Vec3::Y, 10.0), &s, Vec3::Y), Vec3::ZERO);
    }

    #[test]
    fn ambient_directional_and_spot_lights() {
        let s = surface();
        let ambient = GpuLight { kind: GpuLightKind::Ambient as u32, radiance: Vec3::splat(0.1), ..Default::default() };
        assert_eq!(light_radiance(&ambient, &s, Vec3::Y), s.albedo * 0.1);
        // Directional at 60 degrees from the normal: N.L = 0.5; the eye off the reflection sees no highlight.
        let dir = Vec3::new(-(3.0f32.sqrt()) / 2.0, -0.5, 0.0);
        let sun = GpuLight {
            kind: GpuLightKind::Directional as u32,
            direction: dir,
            radiance: Vec3::ONE,
            ..Default::default()
        };
        let c = light_radiance(&sun, &s, Vec3::new(1.0, 0.0, 0.0));
        assert!((c - s.albedo * 0.5).abs().max_element() < 1e-6, "{c}");
        // A spot pointing down, the point on its axis or outside its cone.
        let spot = |position: Vec3| GpuLight {
            kind: GpuLightKind::Spot as u32,
            direction: Vec3::NEG_Y,
            cos_inner: 0.9,
            cos_outer: 0.8,
            ..point(position, 10.0)
        };
        assert!(light_radiance(&spot(Vec3::Y), &s, Vec3::Y).x > 0.0);
        assert_eq!(light_radiance(&spot(Vec3::new(2.0, 1.0, 0.0)), &s, Vec3::Y), Vec3::ZERO);
        // Emission and lights add up.
        let lit = TexelSurface { emission: Vec3::splat(2.0), ..s };
        assert_eq!(shade(&lit, &[ambient], Vec3::Y), Vec3::splat(2.0) + s.albedo * 0.1);
    }
}
