//! Texel density: how large each object's shading texture is.
//!
//! An object whose surface has world area `A` (m²) and whose charts cover a
//! share `a` of the UV square gets `a * side²` texels for `A` m², so a density
//! of `d` texels per metre needs `side = d * sqrt(A / a)`.

use glam::{Mat4, Vec2};

use crate::scene::Mesh;

/// How an object's shading-texture size is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TextureSizing {
    /// A target texel density: `side = texels_per_metre * sqrt(A / a)`,
    /// rounded up to a power of two (within 0.01%) and clamped to `[min, max]` (themselves
    /// rounded to powers of two: `min` up, `max` down).
    Density { texels_per_metre: f32, min: u32, max: u32 },
    /// The same side for every object. `Fixed(4096)` reproduces the
    /// reference study, where every object had a 4096 x 4096 texture.
    Fixed(u32),
}

impl TextureSizing {
    /// The reference study's sizing: 4096 x 4096 for every object.
    pub const REFERENCE: TextureSizing = TextureSizing::Fixed(4096);

    /// The texture of an object with world surface area `world_area` (m²)
    /// whose charts cover `uv_area` of the UV square (`0..=1`).
    pub fn size(&self, world_area: f32, uv_area: f32) -> TextureSize {
        let side = match *self {
            TextureSizing::Fixed(side) => side.max(1),
            TextureSizing::Density { texels_per_metre, min, max } => {
                let (min, max) = pow2_bounds(min, max);
                let ideal = texels_per_metre as f64 * (world_area as f64 / uv_area as f64).sqrt();
                if ideal.is_finite() && ideal > 0.0 {
                    // Up to a power of two, forgiving 0.01% of rounding error in
                    // the areas (a 2 m quad rotated by 90 degrees is still 512).
                    let exponent = (ideal.log2() - 1.5e-4).ceil().clamp(0.0, 31.0) as u32;
                    (1u32 << exponent).clamp(min, max)
                } else {
                    min
                }
            }
        };
        let density = side as f64 * (uv_area as f64 / world_area as f64).sqrt();
        TextureSize {
            side,
            mip_count: mip_count(side),
            texels_per_metre: if density.is_finite() { density as f32 } else { 0.0 },
        }
    }

    /// The smallest side this sizing can give an object of `world_area` m²
    /// (the side for charts covering the whole UV square). Charts generated at
    /// this resolution keep gutters of at least their padding in texels in
    /// the final texture, which is never smaller.
    pub fn min_side(&self, world_area: f32) -> u32 {
        self.size(world_area, 1.0).side
    }
}

/// An object's shading texture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureSize {
    /// Width and height in texels.
    pub side: u32,
    /// Levels of the full mip chain down to 1 x 1: `floor(log2(side)) + 1`.
    pub mip_count: u32,
    /// Texels per metre actually achieved at mip 0: `side * sqrt(a / A)`
    /// (0 for an object without area).
    pub texels_per_metre: f32,
}

/// Levels of a full mip chain for a square texture of `side` texels.
pub fn mip_count(side: u32) -> u32 {
    32 - side.max(1).leading_zeros()
}

/// `min` rounded up and `max` rounded down to powers of two, `max >= min`.
fn pow2_bounds(min: u32, max: u32) -> (u32, u32) {
    let min = min.max(1).checked_next_power_of_two().unwrap_or(1 << 31);
    let max = if max == 0 { 1 } else { 1u32 << (31 - max.leading_zeros()) };
    (min, max.max(min))
}

/// World surface area (m²) of `mesh` placed by `transform`: the triangles are
/// transformed first, so non-uniform scale and shear count correctly.
pub fn world_area(mesh: &Mesh, transform: &Mat4) -> f32 {
    let world: Vec<_> = mesh.positions.iter().map(|&p| transform.transform_point3(p).as_dvec3()).collect();
    let area: f64 = mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| world[t[k] as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    area as f32
}

/// Share of the UV square covered by the triangles `indices` of `uvs`: the sum
/// of their unsigned UV areas, at most 1 (a unique layout never sums above 1).
pub fn uv_area(uvs: &[Vec2], indices: &[u32]) -> f32 {
    let area: f64 = indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| uvs[t[k] as usize].as_dvec2());
            0.5 * (b - a).perp_dot(c - a).abs()
        })
        .sum();
    area.min(1.0) as f32
}

#[cfg(test)]
mod tests {
    use glam::{Quat, Vec3, Vec4};

    use super::*;

    /// A `size` x `size` m quad in the XZ plane whose UVs fill [0, u] x [0, 1].
    fn quad(size: f32, u: f32) -> Mesh {
        Mesh {
            name: "quad".into(),
            positions: vec![
                Vec3::ZERO,
                Vec3::new(size, 0.0, 0.0),
                Vec3::new(size, 0.0, size),
                Vec3::new(0.0, 0.0, size),
            ],
            normals: vec![Vec3::Y; 4],
            tangents: vec![Vec4::X; 4],
            uv0: vec![Vec2::new(0.0, 0.0), Vec2::new(u, 0.0), Vec2::new(u, 1.0), Vec2::new(0.0, 1.0)],
            uv1: None,
            indices: vec![0, 1, 2, 0, 2, 3],
        }
    }

    const DENSITY: TextureSizing = TextureSizing::Density { texels_per_metre: 256.0, min: 16, max: 4096 };

    #[test]
    fn two_metre_quad_filling_the_square_at_256_gets_512() {
        let q = quad(2.0, 1.0);
        let (area, uv) = (world_area(&q, &Mat4::IDENTITY), uv_area(&q.uv0, &q.indices));
        assert!((area - 4.0).abs() < 1e-5 && (uv - 1.0).abs() < 1e-6);
        let s = DENSITY.size(area, uv);
        assert_eq!(s, TextureSize { side: 512, mip_count: 10, texels_per_metre: 256.0 });
    }

    #[test]
    fn half_coverage_rounds_up_and_reports_the_achieved_density() {
        let q = quad(2.0, 0.5);
        let uv = uv_area(&q.uv0, &q.indices);
        assert!((uv - 0.5).abs() < 1e-6);
        // 256 * sqrt(4 / 0.5) = 724 -> 1024, which gives 1024 * sqrt(0.5 / 4) = 362 texels/m.
        let s = DENSITY.size(world_area(&q, &Mat4::IDENTITY), uv);
        assert_eq!((s.side, s.mip_count), (1024, 11));
        assert!((s.texels_per_metre - 362.04).abs() < 0.1, "{}", s.texels_per_metre);
    }

    #[test]
    fn world_area_follows_the_transform() {
        let q = quad(1.0, 1.0);
        let m = Mat4::from_scale_rotation_translation(Vec3::splat(2.0), Quat::from_rotation_y(0.7), Vec3::ONE);
        assert!((world_area(&q, &m) - 4.0).abs() < 1e-5);
        assert_eq!(DENSITY.size(world_area(&q, &m), 1.0).side, 512);
        // Non-uniform scale: 3 x 1 in the quad's plane, 5 along its normal (no effect).
        let m = Mat4::from_scale(Vec3::new(3.0, 5.0, 1.0));
        assert!((world_area(&q, &m) - 3.0).abs() < 1e-5);
    }

    #[test]
    fn sizes_are_clamped_and_fixed_sizes_are_kept() {
        let tiny = TextureSizing::Density { texels_per_metre: 256.0, min: 64, max: 1024 };
        assert_eq!(tiny.size(0.0001, 1.0).side, 64);
        assert_eq!(tiny.size(1000.0, 1.0).side, 1024);
        assert_eq!(tiny.size(0.0, 0.0).side, 64, "no area: the minimum");
        assert_eq!(tiny.size(0.0, 0.0).texels_per_metre, 0.0);
        // Bounds that are not powers of two are rounded inwards.
        let odd = TextureSizing::Density { texels_per_metre: 256.0, min: 100, max: 1000 };
        assert_eq!(odd.size(0.0001, 1.0).side, 128);
        assert_eq!(odd.size(1000.0, 1.0).side, 512);
        let r = TextureSizing::REFERENCE.size(4.0, 0.25);
        assert_eq!((r.side, r.mip_count, r.texels_per_metre), (4096, 13, 1024.0));
        assert_eq!(DENSITY.min_side(4.0), 512);
    }

    #[test]
    fn mip_chains() {
        assert_eq!([1, 2, 3, 512, 4096, 5000].map(mip_count), [1, 2, 2, 10, 13, 13]);
    }
}
