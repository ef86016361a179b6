//! Rust twin of `shaders/shared/octahedral.wgsl`: the octahedral encoding of
//! unit normals that the G-buffer stores, operation for operation, so tests
//! can bound its round-trip error through the stored format.

use glam::{Vec2, Vec3};

/// +1 or -1 per component (+1 for zero).
fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::select(v.cmpge(Vec2::ZERO), Vec2::ONE, Vec2::NEG_ONE)
}

/// Unit vector -> [-1, 1]^2 (WGSL `oct_encode`).
pub fn oct_encode(n: Vec3) -> Vec2 {
    let p = Vec2::new(n.x, n.y) / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.z < 0.0 { (Vec2::ONE - Vec2::new(p.y, p.x).abs()) * sign_not_zero(p) } else { p }
}

/// [-1, 1]^2 -> unit vector (WGSL `oct_decode`).
pub fn oct_decode(e: Vec2) -> Vec3 {
    let z = 1.0 - e.x.abs() - e.y.abs();
    let t = (-z).max(0.0);
    let xy = e - t * sign_not_zero(e);
    Vec3::new(xy.x, xy.y, z).normalize()
}

/// What the G-buffer's `Rg16Float` target keeps of an encoded normal.
pub fn quantize_f16(e: Vec2) -> Vec2 {
    let q = |x: f32| half::f16::from_f32(x).to_f32();
    Vec2::new(q(e.x), q(e.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` directions spread evenly over the sphere (a Fibonacci
    /// lattice), plus the axes and the octahedron's edges, where the fold is.
    fn directions(count: u32) -> Vec<Vec3> {
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let mut dirs: Vec<Vec3> = (0..count)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f32;
                Vec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        for s in [-1.0, 1.0] {
            dirs.extend([Vec3::X * s, Vec3::Y * s, Vec3::Z * s]);
            dirs.extend([Vec3::new(s, 1.0, 0.0), Vec3::new(s, -1.0, 0.0), Vec3::new(s, 0.0, 1.0)]);
            dirs.extend([Vec3::new(s, 0.0, -1.0), Vec3::new(0.0, s, 1.0), Vec3::new(0.0, s, -1.0)]);
            dirs.push(Vec3::new(s, 1e-7, -1e-7));
        }
        dirs.into_iter().map(Vec3::normalize).collect()
    }

    /// Angle between unit vectors (atan2 stays precise near zero, where
    /// `acos` of an f32 dot product does not).
    fn angle(a: Vec3, b: Vec3) -> f32 {
        a.cross(b).length().atan2(a.dot(b))
    }

    #[test]
    fn encoding_stays_in_the_unit_square() {
        for n in directions(4096) {
            let e = oct_encode(n);
            assert!(e.abs().max_element() <= 1.0 + 1e-6, "{n} -> {e}");
        }
    }

    /// Unquantized, decode inverts encode to float precision.
    #[test]
    fn round_trip_is_exact_before_quantization() {
        let worst = directions(20_000).into_iter().map(|n| angle(n, oct_decode(oct_encode(n)))).fold(0.0, f32::max);
        assert!(worst < 1e-3_f32.to_radians(), "worst round-trip error {} degrees", worst.to_degrees());
    }

    /// Through the G-buffer's `Rg16Float` target the error stays below 0.08
    /// degrees (half floats keep 11 significant bits, a step of 2^-11 to
    /// 2^-10 near the square's edge, which the octahedral map stretches by up
    /// to about 2x), far below what Phong highlights of the scenes'
    /// shininess (8-64) can show.
    #[test]
    fn round_trip_through_half_floats_is_within_bound() {
        let errors: Vec<f32> =
            directions(20_000).into_iter().map(|n| angle(n, oct_decode(quantize_f16(oct_encode(n))))).collect();
        let worst = errors.iter().copied().fold(0.0, f32::max);
        let mean = errors.iter().sum::<f32>() / errors.len() as f32;
        assert!(worst < 0.08_f32.to_radians(), "worst error {} degrees", worst.to_degrees());
        eprintln!("Rg16Float round trip: worst {:.4} degrees, mean {:.4}", worst.to_degrees(), mean.to_degrees());
        assert!(mean < 0.02_f32.to_radians(), "mean error {} degrees", mean.to_degrees());
    }

    /// Lower-hemisphere directions come back in their own octant (the fold
    /// is undone, not mirrored).
    #[test]
    fn lower_hemisphere_is_not_mirrored() {
        let n = Vec3::new(0.3, -0.5, -0.8).normalize();
        let d = oct_decode(oct_encode(n));
        assert!(d.z < 0.0 && d.x > 0.0 && d.y < 0.0, "{n} -> {d}");
    }
}
