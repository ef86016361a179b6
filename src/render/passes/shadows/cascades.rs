//! Cascaded shadow maps of the directional light (the sun): the view
//! frustum, up to the farthest scene point, is split into [`CASCADES`]
//! depth slices; each gets an orthographic face around its bounding sphere,
//! looking along the light, deep enough to hold every caster in the scene.

use glam::{Mat4, Vec3};

use crate::scene::{Aabb, Camera};

/// Cascades of the sun.
pub const CASCADES: usize = 4;
/// Side of a cascade's map, in texels.
pub const CASCADE_SIZE: u32 = 2048;
/// Blend of logarithmic (1) and uniform (0) split distances (the "practical
/// split scheme", Zhang et al. 2006): near cascades stay sharp without the
/// far ones covering too little.
const SPLIT_LAMBDA: f32 = 0.75;

/// The view-projections (reversed Z) of the sun's cascades, finest first,
/// for light travelling along `direction`, seen by `camera` with `aspect`
/// over a scene bounded by `scene`. Each cascade's square is the bounding
/// sphere of its slice, so its size does not change as the camera turns,
/// and its centre is snapped to whole texels, so that a static scene's
/// shadow edges do not shimmer as the camera moves.
pub fn cascade_view_projections(direction: Vec3, camera: &Camera, aspect: f32, scene: &Aabb) -> [Mat4; CASCADES] {
    let dir = direction.normalize_or(Vec3::NEG_Y);
    let near = camera.near.max(1e-3);
    let corners = scene_corners(scene);
    let reach = corners.iter().map(|c| c.distance(camera.position)).fold(0.0, f32::max);
    let far = camera.far.min(reach).max(near * 2.0);
    let split = |i: usize| {
        let t = i as f32 / CASCADES as f32;
        SPLIT_LAMBDA * near * (far / near).powf(t) + (1.0 - SPLIT_LAMBDA) * (near + (far - near) * t)
    };
    let up = if dir.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
    std::array::from_fn(|i| {
        let (center, radius) = slice_sphere(camera, aspect, split(i), split(i + 1));
        // Snap the centre to the texel grid of the light's view.
        let texel = 2.0 * radius / CASCADE_SIZE as f32;
        let basis = Mat4::look_to_rh(Vec3::ZERO, dir, up);
        let local = basis.transform_point3(center);
        let snapped = Vec3::new((local.x / texel).floor() * texel, (local.y / texel).floor() * texel, local.z);
        let center = basis.inverse().transform_point3(snapped);
        // Depth: every scene point along the light through the square.
        let along = corners.iter().map(|c| (*c - center).dot(dir));
        let (lo, hi) = along.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
        let pad = 0.01 * (hi - lo).max(1e-3);
        let view = Mat4::look_to_rh(center, dir, up);
        // Swapping near and far gives reversed Z (near -> 1, far -> 0).
        Mat4::orthographic_rh(-radius, radius, -radius, radius, hi + pad, lo - pad) * view
    })
}

fn scene_corners(b: &Aabb) -> [Vec3; 8] {
    std::array::from_fn(|i| Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), b.max, b.min))
}

/// The bounding sphere (centre, radius) of the camera frustum's slice
/// between view distances `d0` and `d1`. The radius is rounded up to a
/// 1/64 step of itself, so that it is stable under camera rotation's
/// float noise.
fn slice_sphere(camera: &Camera, aspect: f32, d0: f32, d1: f32) -> (Vec3, f32) {
    let forward = camera.forward.normalize();
    let right = forward.cross(camera.up).normalize();
    let up = right.cross(forward);
    let ty = (camera.fov_y * 0.5).tan();
    let tx = ty * aspect;
    let corners: Vec<Vec3> = [d0, d1]
        .iter()
        .flat_map(|&d| {
            [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
                .map(|(sx, sy)| camera.position + forward * d + right * (sx * tx * d) + up * (sy * ty * d))
        })
        .collect();
    let center = corners.iter().copied().sum::<Vec3>() / corners.len() as f32;
    let radius = corners.iter().map(|c| c.distance(center)).fold(0.0, f32::max);
    let step = 2f32.powi(radius.log2().ceil() as i32 - 6);
    (center, (radius / step).ceil() * step)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera {
            position: Vec3::new(0.0, 4.0, 6.0),
            forward: Vec3::new(0.0, -4.0, -6.0).normalize(),
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 100.0,
        }
    }

    /// Every point of the visible scene lies in some cascade, finest first
    /// near the camera, and every scene point projects inside the depth
    /// range of the cascade whose square holds it.
    #[test]
    fn cascades_cover_the_view_and_the_scene_depth() {
        let scene = Aabb { min: Vec3::new(-4.0, 0.0, -4.0), max: Vec3::new(4.0, 2.0, 4.0) };
        let sun = Vec3::new(0.3, -1.0, 0.2);
        let m = cascade_view_projections(sun, &camera(), 16.0 / 9.0, &scene);
        let inside = |m: &Mat4, p: Vec3| {
            let q = m.project_point3(p);
            q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && (0.0..=1.0).contains(&q.z)
        };
        // Near the camera: the first cascade.
        assert!(inside(&m[0], camera().position + camera().forward * 0.5));
        for x in -4..=4 {
            for z in -4..=4 {
                let p = Vec3::new(x as f32, 0.0, z as f32);
                assert!(m.iter().any(|c| inside(c, p)), "{p} in no cascade");
            }
        }
        // Wider cascades farther out.
        let width = |m: &Mat4| 2.0 / m.row(0).truncate().length();
        assert!(width(&m[0]) < width(&m[1]) && width(&m[1]) < width(&m[2]) && width(&m[2]) < width(&m[3]));
    }

    /// Moving the camera by less than a texel sideways keeps the cascades'
    /// texel grid: their matrices move by whole texels only.
    #[test]
    fn cascade_centres_snap_to_texels() {
        let scene = Aabb { min: Vec3::splat(-4.0), max: Vec3::splat(4.0) };
        let a = cascade_view_projections(Vec3::NEG_Y, &camera(), 1.0, &scene);
        let mut moved = camera();
        moved.position.x += 1e-4;
        let b = cascade_view_projections(Vec3::NEG_Y, &moved, 1.0, &scene);
        for (a, b) in a.iter().zip(&b) {
            let texel = 2.0 / CASCADE_SIZE as f32;
            let shift = a.project_point3(Vec3::ZERO) - b.project_point3(Vec3::ZERO);
            let whole = |v: f32| ((v / texel).round() * texel - v).abs() < 1e-4;
            assert!(whole(shift.x) && whole(shift.y), "{shift}");
        }
    }
}
