//! The finest mip level an object's pixels can pick from a camera, from the
//! CPU, before the frame: what its page-directory slot must hold
//! ([`super::slots`]). Conservative: no pixel picks a finer level.
//!
//! A pixel's level is `log2(rho)` (plus biases), `rho` the longer of its UV
//! footprint's axes times the texture side. A pixel at distance `d` covers
//! at least `1 / ppm` metres of surface along each axis, `ppm = h / (2 d
//! tan(fov / 2))` (facing the camera on the view axis; more at an angle or
//! off the axis), and a metre of the surface is at least `stretch` of chart
//! UV along any direction (the least singular value of the chart mapping
//! over the mesh's triangles, scaled by the object's transform). So `rho >=
//! size * stretch / ppm`, with `d` the distance to the object's bounds.

use glam::{Mat2, Mat4, Vec2, Vec3};

use crate::scene::{Aabb, Camera, Mesh};

/// The longest a local metre becomes in the world under `transform`.
pub fn max_scale(transform: &Mat4) -> f32 {
    [transform.x_axis, transform.y_axis, transform.z_axis]
        .iter()
        .map(|a| a.truncate().length())
        .fold(0.0, f32::max)
        .max(f32::MIN_POSITIVE)
}

/// The least chart-UV length per metre (of the mesh's own space) along
/// any direction over the triangles of `mesh` (0 where a triangle's charts
/// are degenerate: then every level may be picked). Placed by a transform,
/// divide by its [`max_scale`].
pub fn min_stretch(mesh: &Mesh) -> f32 {
    let uv = mesh.uv1.as_ref().unwrap_or(&mesh.uv0);
    let mut least = f32::MAX;
    for t in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| t[k] as usize);
        let (e1, e2) = (mesh.positions[b] - mesh.positions[a], mesh.positions[c] - mesh.positions[a]);
        let Some(x) = e1.try_normalize() else { continue };
        let Some(y) = (e2 - e2.dot(x) * x).try_normalize() else { continue };
        // Local 2D edges and UV edges: J maps the first to the second.
        let (p1, p2) = (Vec2::new(e1.dot(x), 0.0), Vec2::new(e2.dot(x), e2.dot(y)));
        let (u1, u2) = (uv[b] - uv[a], uv[c] - uv[a]);
        let det = p1.x * p2.y - p2.x * p1.y;
        if det.abs() < 1e-12 {
            continue;
        }
        // J = [u1 u2] * inverse([p1 p2]).
        let j = Mat2::from_cols(u1, u2) * Mat2::from_cols(p1, p2).inverse();
        least = least.min(least_singular_value(j));
    }
    if least == f32::MAX { 0.0 } else { least }
}

fn least_singular_value(m: Mat2) -> f32 {
    let (a, b, c, d) = (m.x_axis.x, m.y_axis.x, m.x_axis.y, m.y_axis.y);
    let t = a * a + b * b + c * c + d * d;
    let det = a * d - b * c;
    let root = (t * t - 4.0 * det * det).max(0.0).sqrt();
    ((t - root) * 0.5).max(0.0).sqrt()
}

/// The finest level (of a texture of `size` texels, `stretch` from
/// [`min_stretch`], a pixel bias of `bias` levels) that a pixel of `camera`
/// in an image `height` pixels tall can pick on an object within `bounds`,
/// less `margin` levels; 0 when that is level 0 or finer.
pub fn finest_level(
    size: u32,
    stretch: f32,
    bounds: &Aabb,
    camera: &Camera,
    height: u32,
    bias: f32,
    margin: u32,
) -> usize {
    if stretch <= 0.0 {
        return 0;
    }
    let d = (bounds.min - camera.position).max(camera.position - bounds.max).max(Vec3::ZERO).length();
    let pixels_per_metre = height as f32 / (2.0 * d.max(camera.near) * (0.5 * camera.fov_y).tan());
    let level = (size as f32 * stretch / pixels_per_metre).log2() + bias;
    (level.floor() - margin as f32).max(0.0) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 m square, charted onto the whole UV square (or its half).
    fn square(u: f32) -> Mesh {
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            uv0: vec![Vec2::ZERO, Vec2::new(u, 0.0), Vec2::new(u, 1.0), Vec2::Y],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Default::default()
        }
    }

    fn camera(position: Vec3) -> Camera {
        Camera { position, forward: -Vec3::Z, up: Vec3::Y, fov_y: 90f32.to_radians(), near: 0.1, far: 1000.0 }
    }

    #[test]
    fn the_stretch_is_the_least_uv_per_metre() {
        assert!((min_stretch(&square(1.0)) - 1.0).abs() < 1e-5);
        // Squeezed to half the width: half a unit of UV per metre across.
        assert!((min_stretch(&square(0.5)) - 0.5).abs() < 1e-5);
        // Scaled up twice (and turned): a UV unit over two metres.
        let t = Mat4::from_scale(Vec3::splat(2.0)) * Mat4::from_rotation_y(1.0);
        assert!((max_scale(&t) - 2.0).abs() < 1e-5);
    }

    #[test]
    fn a_far_object_needs_no_fine_levels() {
        let bounds = Aabb { min: Vec3::new(-0.5, -0.5, -100.0), max: Vec3::new(0.5, 0.5, -100.0) };
        let camera = camera(Vec3::ZERO);
        // 100 m away, 90 degrees over 200 pixels: a pixel a metre; 1024
        // texels a metre: 1024 texels a pixel, level 10, less a margin.
        assert_eq!(finest_level(1024, 1.0, &bounds, &camera, 200, 0.0, 1), 9);
        // A coarser bias picks coarser levels; near, every level.
        assert_eq!(finest_level(1024, 1.0, &bounds, &camera, 200, 2.0, 1), 11);
        let near = self::camera(Vec3::new(0.0, 0.0, -99.9));
        assert_eq!(finest_level(1024, 1.0, &bounds, &near, 200, 0.0, 1), 0);
        assert_eq!(finest_level(1024, 0.0, &bounds, &camera, 200, 0.0, 1), 0);
    }
}
