//! Shading density that follows the screen: each object's texture is sized
//! from the largest projected size it has in the views it will be seen
//! from (Oxide: "the estimated projected area of the object is calculated,
//! thus an object requests a certain amount of shading"), not from a fixed
//! density in texels per metre, so that a 5 cm model filling the frame gets
//! as many texels as a 5 m one, and a distant patch of a large terrain no
//! more than it can show.
//!
//! An object seen at distance `d` by a camera of vertical field of view `f`
//! in an image `h` pixels tall covers `h / (2 d tan(f / 2))` pixels per
//! metre where it faces the camera; that is the density its finest level
//! needs, at the nearest point of its bounds that any view sees (surfaces
//! seen at an angle need less along one axis, and marking picks levels by
//! the longer one). [`TextureSizing::Density`] then rounds the side up to a
//! power of two and clamps it.

use glam::{Mat4, Vec3, Vec4};

use super::density::TextureSizing;
use crate::scene::{Aabb, Camera, CameraPath, Mesh, Scene};

/// Most cameras sampled along a path: longer paths are sampled evenly.
pub const MAX_PATH_SAMPLES: u32 = 2048;

/// How generated charts are packed when textures follow the screen: as for
/// the former default of 256 texels per metre, whatever the image size and
/// cameras, so that the charts and their cache entries stay the same.
pub const PACKING_SIZING: TextureSizing = TextureSizing::Density { texels_per_metre: 256.0, min: 64, max: 8192 };

/// The cameras of `path` to size textures for: every frame of one run of the
/// path, or [`MAX_PATH_SAMPLES`] evenly spaced ones for longer paths.
pub fn path_cameras(path: &CameraPath) -> Vec<Camera> {
    let frames = path.frame_count().max(1);
    let samples = frames.min(MAX_PATH_SAMPLES);
    (0..samples).map(|k| path.camera_at((k as u64 * frames as u64 / samples as u64) as u32)).collect()
}

/// Per object of `scene`, the most screen pixels per metre of surface any of
/// `cameras` can show it at in a `width` x `height` image: `height / (2 d
/// tan(fov / 2))` at the distance `d` from the eye to the object (at least
/// the camera's near plane), over the cameras whose frustum its bounds
/// touch; 0 for an object no camera sees.
///
/// `d` is the distance to the object's bounding box, or where the eye is
/// within a triangle edge of the box (inside a heightfield patch's box, low
/// over it; inside a room), the larger of that and the distance to the
/// nearest vertex less the longest edge: no point of a triangle is farther
/// than its longest edge from one of its vertices, so `d` never exceeds the
/// distance to the surface.
pub fn projected_densities(scene: &Scene, cameras: &[Camera], width: u32, height: u32) -> Vec<f32> {
    let aspect = width.max(1) as f32 / height.max(1) as f32;
    let views: Vec<_> = cameras.iter().map(|c| (c, c.view_projection(aspect))).collect();
    let all_bounds = scene.all_object_bounds();
    (0..scene.objects.len())
        .map(|i| {
            let bounds = all_bounds[i];
            if bounds.is_empty() {
                return 0.0;
            }
            let object = &scene.objects[i];
            let mesh = &scene.meshes[object.mesh];
            // World vertices and longest edge, only if some eye comes that close.
            let mut near: Option<(Vec<Vec3>, f32)> = None;
            views
                .iter()
                .filter(|(_, vp)| touches_frustum(&bounds, vp))
                .map(|(c, _)| {
                    let mut d = distance(&bounds, c.position);
                    let (vertices, edge) = near.get_or_insert_with(|| world_vertices(mesh, &object.transform));
                    if d <= *edge {
                        let nearest = vertices.iter().map(|v| v.distance_squared(c.position)).fold(f32::MAX, f32::min);
                        d = d.max(nearest.sqrt() - *edge);
                    }
                    let d = d.max(c.near).max(f32::MIN_POSITIVE);
                    height as f32 / (2.0 * d * (0.5 * c.fov_y).tan())
                })
                .fold(0.0, f32::max)
        })
        .collect()
}

/// The mesh's vertices placed by `transform`, and its longest triangle edge.
fn world_vertices(mesh: &Mesh, transform: &Mat4) -> (Vec<Vec3>, f32) {
    let world: Vec<Vec3> = mesh.positions.iter().map(|&p| transform.transform_point3(p)).collect();
    let edge = mesh
        .indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| world[t[k] as usize]);
            a.distance(b).max(b.distance(c)).max(c.distance(a))
        })
        .fold(0.0, f32::max);
    (world, edge)
}

/// One [`TextureSizing::Density`] per object from [`projected_densities`],
/// sides clamped to `[min, max]`.
pub fn screen_sizings(
    scene: &Scene,
    cameras: &[Camera],
    width: u32,
    height: u32,
    min: u32,
    max: u32,
) -> Vec<TextureSizing> {
    projected_densities(scene, cameras, width, height)
        .into_iter()
        .map(|texels_per_metre| TextureSizing::Density { texels_per_metre, min, max })
        .collect()
}

/// Distance from `p` to the box (0 inside it).
fn distance(b: &Aabb, p: Vec3) -> f32 {
    (b.min - p).max(p - b.max).max(Vec3::ZERO).length()
}

/// Whether the box may be in the view of clip matrix `vp` (reversed depth:
/// `0 <= z <= w`): false only when all eight corners lie outside one plane.
fn touches_frustum(b: &Aabb, vp: &glam::Mat4) -> bool {
    let corners: Vec<Vec4> = (0..8)
        .map(|k| {
            let p = Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            );
            *vp * p.extend(1.0)
        })
        .collect();
    let planes: [fn(&Vec4) -> f32; 6] =
        [|c| c.w + c.x, |c| c.w - c.x, |c| c.w + c.y, |c| c.w - c.y, |c| c.z, |c| c.w - c.z];
    planes.iter().all(|plane| corners.iter().any(|c| plane(c) >= 0.0))
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::scene::{Material, Object};

    /// A scene of `n` unit quads facing +z, quad k at z = -k * 10.
    fn quads(n: usize) -> Scene {
        let mut scene = Scene::default();
        scene.materials.push(Material::default());
        scene.meshes.push(Mesh {
            name: "quad".into(),
            positions: vec![
                Vec3::new(-0.5, -0.5, 0.0),
                Vec3::new(0.5, -0.5, 0.0),
                Vec3::new(0.5, 0.5, 0.0),
                Vec3::new(-0.5, 0.5, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            tangents: vec![Vec4::X; 4],
            uv0: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            uv1: None,
            indices: vec![0, 1, 2, 0, 2, 3],
        });
        for k in 0..n {
            scene.objects.push(Object {
                name: format!("quad{k}"),
                mesh: 0,
                material: 0,
                transform: Mat4::from_translation(Vec3::new(0.0, 0.0, -10.0 * k as f32)),
                forward_only: false,
            });
        }
        scene
    }

    fn camera(position: Vec3, forward: Vec3) -> Camera {
        Camera { position, forward, up: Vec3::Y, fov_y: 90f32.to_radians(), near: 0.01, far: 1000.0 }
    }

    #[test]
    fn density_is_the_nearest_projection_and_unseen_objects_get_none() {
        let scene = quads(3);
        // 2 m in front of quad 0 looking at it (-z): at 90 degrees and 200
        // pixels, 200 / (2 * 2 * 1) = 50 px/m; quad 1 at 12 m: 200 / 24.
        let looking = camera(Vec3::new(0.0, 0.0, 2.0), Vec3::NEG_Z);
        let d = projected_densities(&scene, &[looking], 200, 200);
        assert!((d[0] - 50.0).abs() < 1e-3 && (d[1] - 200.0 / 24.0).abs() < 1e-3, "{d:?}");
        // Turned away: nothing is seen.
        let away = camera(Vec3::new(0.0, 0.0, 2.0), Vec3::Z);
        assert_eq!(projected_densities(&scene, &[away], 200, 200), vec![0.0; 3]);
        // Over several cameras, the nearest view wins; the width only sets the aspect.
        let near = camera(Vec3::new(0.0, 0.0, -9.0), Vec3::NEG_Z);
        let d = projected_densities(&scene, &[looking, near], 400, 200);
        assert!((d[1] - 100.0).abs() < 1e-3, "{d:?}");
    }

    #[test]
    fn an_eye_inside_the_box_is_as_far_as_the_surface_allows() {
        // A 10 x 10 m ramp of 1 m cells rising 0.3 m a metre along x: its box
        // is 3 m tall, its longest edge 1.44 m. An eye 2.2 m over it at x = 1
        // is inside the box; its nearest vertex is 2.15 m away, so it is taken
        // as 0.7 m from the surface (the ramp's plane is 2.1 m away), not as
        // at the near plane (0.01 m: 10,000 px/m).
        let mut scene = quads(1);
        let n = 10;
        let positions: Vec<Vec3> =
            (0..=n).flat_map(|z| (0..=n).map(move |x| Vec3::new(x as f32, 0.3 * x as f32, z as f32))).collect();
        let mut indices = Vec::new();
        for z in 0..n {
            for x in 0..n {
                let a = z * (n + 1) + x;
                indices.extend([a, a + n + 1, a + 1, a + 1, a + n + 1, a + n + 2]);
            }
        }
        let count = positions.len();
        scene.meshes[0] = Mesh {
            positions,
            normals: vec![Vec3::Y; count],
            tangents: vec![Vec4::X; count],
            uv0: vec![Vec2::ZERO; count],
            indices,
            ..scene.meshes[0].clone()
        };
        let eye = camera(Vec3::new(1.0, 2.5, 1.0), Vec3::new(1.0, -1.0, 0.0).normalize());
        let d = projected_densities(&scene, &[eye], 200, 200)[0];
        // 200 px at 90 degrees: 100 / d px/m.
        assert!((100.0 / 2.2..=100.0 / 0.6).contains(&d), "{d} px/m");
    }

    #[test]
    fn sides_follow_the_screen_and_the_path_is_sampled() {
        let scene = quads(2);
        let eye = camera(Vec3::new(0.0, 0.0, 0.5), Vec3::NEG_Z);
        // 1024 px tall at 0.5 m: 1024 px/m on a 1 m quad -> 1024 texels.
        let s = screen_sizings(&scene, &[eye], 1024, 1024, 64, 8192);
        assert_eq!(s[0].size(1.0, 1.0).side, 1024);
        // Quad 1 at 10.5 m: 48.8 px/m -> 64, the minimum.
        assert_eq!(s[1].size(1.0, 1.0).side, 64);
        let path = CameraPath::Fixed(eye);
        assert_eq!(path_cameras(&path), vec![eye]);
    }
}
