//! The CPU twin of the prefilter (`prefilter.wgsl`): the cube faces'
//! orientation, and the integrals the GPU maps approximate, evaluated by
//! brute force over a fine grid of directions, for tests to compare the
//! read-back maps with.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// The direction through point `uv` ([-1, 1]²) of cube face `face` (+x, -x,
/// +y, -y, +z, -z), not normalized: mirrors `face_point`.
pub fn face_point(face: u32, uv: Vec2) -> Vec3 {
    match face {
        0 => Vec3::new(1.0, -uv.y, -uv.x),
        1 => Vec3::new(-1.0, -uv.y, uv.x),
        2 => Vec3::new(uv.x, 1.0, uv.y),
        3 => Vec3::new(uv.x, -1.0, -uv.y),
        4 => Vec3::new(uv.x, -uv.y, 1.0),
        _ => Vec3::new(-uv.x, -uv.y, -1.0),
    }
}

/// The unit direction through the centre of texel (`x`, `y`) of a face of
/// side `size`.
pub fn texel_direction(face: u32, x: u32, y: u32, size: u32) -> Vec3 {
    let uv = (Vec2::new(x as f32, y as f32) + 0.5) / size as f32 * 2.0 - 1.0;
    face_point(face, uv).normalize()
}

/// The face and texel of a face of side `size` that direction `d` (not
/// zero) passes through: the inverse of [`texel_direction`], as cube
/// sampling picks them.
pub fn direction_texel(d: Vec3, size: u32) -> (u32, u32, u32) {
    let a = d.abs();
    // (face, s, t) with s, t in [-1, 1], from Vulkan's cube face selection.
    let (face, s, t) = if a.x >= a.y && a.x >= a.z {
        if d.x > 0.0 { (0, -d.z / a.x, -d.y / a.x) } else { (1, d.z / a.x, -d.y / a.x) }
    } else if a.y >= a.z {
        if d.y > 0.0 { (2, d.x / a.y, d.z / a.y) } else { (3, d.x / a.y, -d.z / a.y) }
    } else if d.z > 0.0 {
        (4, d.x / a.z, -d.y / a.z)
    } else {
        (5, -d.x / a.z, -d.y / a.z)
    };
    let texel = |c: f32| (((c + 1.0) * 0.5 * size as f32) as u32).min(size - 1);
    (face, texel(s), texel(t))
}

/// Every texel centre of a cube of side `grid` with its solid angle.
fn sphere_grid(grid: u32) -> impl Iterator<Item = (Vec3, f32)> {
    (0..6).flat_map(move |face| {
        (0..grid * grid).map(move |i| {
            let uv = (Vec2::new((i % grid) as f32, (i / grid) as f32) + 0.5) / grid as f32 * 2.0 - 1.0;
            let p = face_point(face, uv);
            let len2 = p.length_squared();
            let texel = 2.0 / grid as f32;
            (p / len2.sqrt(), texel * texel / (len2 * len2.sqrt()))
        })
    })
}

/// What the prefiltered map holds at `n` for perceptual `roughness` (above
/// 0): the mean of `radiance` over light directions l weighted by
/// GGX's D(h) N.L with n = v (the split sum's first factor, the integral the
/// GPU's importance sampling estimates), over a cube grid of side `grid`.
pub fn prefiltered(radiance: impl Fn(Vec3) -> Vec3, n: Vec3, roughness: f32, grid: u32) -> Vec3 {
    let a2 = (roughness * roughness).powi(2);
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
    for (l, solid_angle) in sphere_grid(grid) {
        let n_dot_l = n.dot(l);
        if n_dot_l <= 0.0 {
            continue;
        }
        let n_dot_h = n.dot((n + l).normalize());
        let denom = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
        let w = a2 / (PI * denom * denom) * n_dot_l * solid_angle;
        sum += radiance(l) * w;
        weight += w;
    }
    sum / weight
}

/// Irradiance / pi at a surface of normal `n` under `radiance`, over a cube
/// grid of side `grid`: what the irradiance map holds.
pub fn irradiance(radiance: impl Fn(Vec3) -> Vec3, n: Vec3, grid: u32) -> Vec3 {
    let sum: Vec3 = sphere_grid(grid).map(|(l, solid_angle)| radiance(l) * n.dot(l).max(0.0) * solid_angle).sum();
    sum / PI
}

/// The split sum's second factor at `n_dot_v` and perceptual `roughness`:
/// the scale and bias of F0 (GGX with the height-correlated Smith
/// visibility of `lighting.wgsl`, Schlick Fresnel), integrated by brute
/// force over light directions on a cube grid of side `grid` (n = +z):
/// what the GPU's lookup table holds.
pub fn split_sum(roughness: f32, n_dot_v: f32, grid: u32) -> (f32, f32) {
    let a = (roughness * roughness).max(2e-3);
    let a2 = a * a;
    let v = Vec3::new((1.0 - n_dot_v * n_dot_v).sqrt(), 0.0, n_dot_v);
    let (mut scale, mut bias) = (0.0, 0.0);
    for (l, solid_angle) in sphere_grid(grid) {
        if l.z <= 0.0 {
            continue;
        }
        let h = (l + v).normalize();
        let denom = h.z * h.z * (a2 - 1.0) + 1.0;
        let d = a2 / (PI * denom * denom);
        let vis_l = n_dot_v * (l.z * l.z * (1.0 - a2) + a2).sqrt();
        let vis_v = l.z * (n_dot_v * n_dot_v * (1.0 - a2) + a2).sqrt();
        let brdf = d * 0.5 / (vis_l + vis_v) * l.z * solid_angle;
        let fc = (1.0 - v.dot(h).max(0.0)).powi(5);
        scale += brdf * (1.0 - fc);
        bias += brdf * fc;
    }
    (scale, bias)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every texel's direction finds its texel again, and the grid's solid
    /// angles cover the sphere.
    #[test]
    fn faces_invert_and_cover_the_sphere() {
        let size = 8;
        for face in 0..6 {
            for y in 0..size {
                for x in 0..size {
                    assert_eq!(direction_texel(texel_direction(face, x, y, size), size), (face, x, y));
                }
            }
        }
        let total: f32 = sphere_grid(64).map(|(_, w)| w).sum();
        assert!((total - 4.0 * PI).abs() < 1e-3 * 4.0 * PI, "{total}");
    }

    /// A uniform environment L gives irradiance / pi = L and prefilters to
    /// L; a sky brighter above gives an upward normal more than a downward one.
    #[test]
    fn uniform_radiance_integrates_to_itself() {
        let l = Vec3::new(0.2, 0.5, 1.0);
        for n in [Vec3::Y, Vec3::new(0.3, -0.4, 0.8).normalize()] {
            assert!((irradiance(|_| l, n, 32) - l).abs().max_element() < 2e-3);
            assert!((prefiltered(|_| l, n, 0.5, 32) - l).abs().max_element() < 1e-5);
        }
        let up = |d: Vec3| Vec3::splat(d.y.max(0.0));
        assert!(irradiance(up, Vec3::Y, 32).x > irradiance(up, Vec3::NEG_Y, 32).x + 0.5);
        // Cosine-weighted mean of max(y, 0) over the upper hemisphere: 2/3.
        assert!((irradiance(up, Vec3::Y, 64).x - 2.0 / 3.0).abs() < 2e-3);
    }
}
