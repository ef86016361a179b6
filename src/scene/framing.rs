//! Auto framing: the default cameras of a scene that brings no camera path of
//! its own (a glTF model, an OBJ file), and the clip planes of any camera
//! placed from the command line.
//!
//! The framed path is a [`Turntable`] around the vertical through the centre
//! of the scene's bounds, looking down [`ELEVATION_DEG`], as close as it can
//! be while every vertex stays inside [`FILL`] of the frame (vertically: the
//! field of view; horizontally: the image's aspect) at every sampled angle of
//! the turn. The point it looks at is lifted or lowered on that vertical so
//! that the model sits in the middle of the frame (seen from above, its near
//! bottom looms larger than its far top), but not below a quarter of the
//! model's height, which would leave the eye level with its top. Frame 0
//! (the default camera) is the side where the model looks widest. Fitting the bounding sphere (or
//! box) instead leaves a box-like model covering about a fifth of a 16:9
//! frame and a round one a sixth; fitting the vertices keeps the model itself
//! at the margin. Clip planes come from the bounding sphere, so a 5 cm model
//! gets a near plane of millimetres and a 200 m city one of metres (a fixed
//! near plane of 0.1 m clipped small models away entirely).

use std::f32::consts::{FRAC_PI_3, TAU};

use glam::Vec3;

use super::path::{Projection, Turntable, look_at};
use super::{Aabb, Camera};

/// How far the framed views look down, degrees: the top and the front of a
/// model both show.
pub const ELEVATION_DEG: f32 = 25.0;
/// How far the fifth fixed camera, the overview, looks down, degrees.
pub const OVERVIEW_ELEVATION_DEG: f32 = 60.0;
/// The share of the frame's height and width the scene's box may fill, so
/// that it never touches the edges.
pub const FILL: f32 = 0.9;
/// Vertical field of view of the framed cameras (the reference study's).
pub const FOV_Y: f32 = FRAC_PI_3;
/// Turn angles sampled when fitting the turntable (every 5 degrees: between
/// samples a point moves by at most 4.4 % of its distance from the centre,
/// which the [`FILL`] margin absorbs).
const TURN_SAMPLES: u32 = 72;
/// Most vertices used while searching for the lift of the target (evenly
/// strided); the distance is then fitted with all of them.
const SEARCH_POINTS: usize = 4096;
/// Steps of the search for the lift (each keeps two thirds of the interval).
const SEARCH_STEPS: u32 = 40;
/// The nearest a near plane may be, as a fraction of the far plane (a camera
/// inside the scene's box): 32-bit reversed-Z depth resolves far more.
const MIN_NEAR_FRACTION: f32 = 1e-4;

/// The framed cameras of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Framed {
    /// The camera path: 600 frames per turn.
    pub turntable: Turntable,
    /// Five fixed cameras: the turntable at 45, 135, 225 and 315 degrees, and
    /// an overview looking down [`OVERVIEW_ELEVATION_DEG`] from the 45 degree side.
    pub fixed: Vec<Camera>,
}

/// Frames the scene made of the world-space vertices `points` for images of
/// aspect `aspect` (width / height; anything not positive and finite counts
/// as 1). `None` when their box is empty, not finite or a single point.
pub fn frame(points: &[Vec3], aspect: f32) -> Option<Framed> {
    let bounds = Aabb::from_points(points.iter().copied());
    let radius = bounding_radius(&bounds)?;
    let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
    let centre = bounds.center();
    let elevation = ELEVATION_DEG.to_radians();
    let turn: Vec<Vec3> =
        (0..TURN_SAMPLES).map(|k| -view_direction(TAU * k as f32 / TURN_SAMPLES as f32, elevation)).collect();
    let (lift, distance) = fit(points, centre, &turn, aspect);
    let target = centre + lift * Vec3::Y;
    let mut turntable = Turntable {
        target,
        radius: distance * elevation.cos(),
        height: distance * elevation.sin(),
        frames: super::path::Orbit::FRAMES,
        start: 0.0,
        projection: clip_planes_around(target - distance * turn[0], centre, radius),
    };
    turntable.start = widest_angle(&turntable, points, aspect);
    let mut fixed: Vec<Camera> =
        (0..4).map(|k| turntable.camera_at_angle((45.0 + 90.0 * k as f32).to_radians())).collect();
    let overview = -view_direction(45f32.to_radians(), OVERVIEW_ELEVATION_DEG.to_radians());
    let (lift, d) = fit(points, centre, &[overview], aspect);
    let target = centre + lift * Vec3::Y;
    let eye = target - d * overview;
    fixed.push(look_at(eye, target, clip_planes_around(eye, centre, radius)));
    Some(Framed { turntable, fixed })
}

/// The sampled turn angle at which the model's projected bounding rectangle
/// is largest, so that frame 0 (the default camera) shows its broad side: a
/// flat model seen edge-on, or a row of objects seen end-on, would fill
/// little of the frame.
fn widest_angle(turntable: &Turntable, points: &[Vec3], aspect: f32) -> f32 {
    let stride = points.len().div_ceil(SEARCH_POINTS).max(1);
    let area = |angle: f32| {
        let vp = turntable.camera_at_angle(angle).view_projection(aspect);
        let (lo, hi) = points.iter().step_by(stride).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
            let ndc = vp.project_point3(p);
            (lo.min(ndc), hi.max(ndc))
        });
        (hi.x - lo.x) * (hi.y - lo.y)
    };
    let angles = (0..TURN_SAMPLES).map(|k| TAU * k as f32 / TURN_SAMPLES as f32);
    // Ties (a sphere, a cube's symmetric views) go to the first angle.
    angles.fold((0.0, f32::NEG_INFINITY), |best, a| if area(a) > best.1 + 1e-4 { (a, area(a)) } else { best }).0
}

/// Clip planes for a camera at `eye` that should see the sphere of `radius`
/// around `centre`.
fn clip_planes_around(eye: Vec3, centre: Vec3, radius: f32) -> Projection {
    let d = eye.distance(centre);
    clip_planes(FOV_Y, d - radius, d + radius)
}

/// The lift of the target above `centre` and the distance back from it
/// along each of the view directions `forwards` at which every point is in
/// [`FILL`] of the frame, for the smallest such distance.
///
/// The distance a lift needs ([`fit_distance`]) is the largest of functions
/// linear in the lift, one per point and direction, hence convex: a
/// ternary search over lifts within the scene's height finds its minimum.
fn fit(points: &[Vec3], centre: Vec3, forwards: &[Vec3], aspect: f32) -> (f32, f32) {
    let stride = points.len().div_ceil(SEARCH_POINTS).max(1);
    let sample: Vec<Vec3> = points.iter().step_by(stride).copied().collect();
    let reaches =
        |points: &[Vec3]| -> Vec<Reach> { forwards.iter().map(|&f| Reach::new(points, centre, f, aspect)).collect() };
    let needed = |reaches: &[Reach], lift: f32| reaches.iter().map(|r| r.distance(lift)).fold(0.0, f32::max);
    let sampled = reaches(&sample);
    let half_height = points.iter().map(|p| (p.y - centre.y).abs()).fold(0.0, f32::max);
    // Lowering the target below a quarter of the height would bring the
    // closest fit with the eye level with the model's top: a box would show
    // no top face.
    let (mut lo, mut hi) = (-0.25 * half_height, half_height);
    for _ in 0..SEARCH_STEPS {
        let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if needed(&sampled, a) <= needed(&sampled, b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let lift = 0.5 * (lo + hi);
    (lift, needed(&reaches(points), lift))
}

/// Half the box's diagonal: the radius of the sphere around its centre that
/// holds it. `None` for a box that is empty, not finite or a point.
fn bounding_radius(bounds: &Aabb) -> Option<f32> {
    let finite = bounds.min.is_finite() && bounds.max.is_finite();
    let radius = 0.5 * bounds.extent().length();
    // A box smaller than float precision at its position is a point.
    let scale = bounds.min.abs().max(bounds.max.abs()).max_element().max(1.0);
    (finite && !bounds.is_empty() && radius > 1e-6 * scale).then_some(radius)
}

/// Unit vector from a target to an eye at turn angle `angle` (from +x
/// towards +z) and `elevation` above the horizon.
fn view_direction(angle: f32, elevation: f32) -> Vec3 {
    Vec3::new(elevation.cos() * angle.cos(), elevation.sin(), elevation.cos() * angle.sin())
}

/// For one view direction, the distance back from a target lifted `lift`
/// above `centre` at which a camera looking along the direction sees every
/// point inside [`FILL`] of the frame (vertically the field of view,
/// horizontally `aspect` times it).
///
/// A point at (x right, y up, z along the direction) from the target is at
/// depth `d + z` from a camera `d` behind it, and in the frame when
/// `|y| <= FILL (d + z) tan(fov/2)` and `|x| <= FILL (d + z) tan(fov/2) aspect`:
/// `d >= |y| / (FILL tan(fov/2)) - z`, and likewise for x. So the distance
/// is the largest of four functions linear
/// in the lift, one per frame edge (`|up . p| / tan_y - forward . p` and its
/// horizontal twin, for `p` a point less the target, split by sign). Their
/// largest values over the points do not depend on the lift, so they are
/// found once, and each lift tried costs four products, not one per point.
struct Reach {
    /// Per edge, the largest value over the points at lift 0.
    base: [f32; 4],
    /// Per edge, how the value grows with the lift.
    slope: [f32; 4],
}

impl Reach {
    fn new(points: &[Vec3], centre: Vec3, forward: Vec3, aspect: f32) -> Self {
        // The basis `look_at` gives the camera.
        let camera = look_at(Vec3::ZERO, forward, Projection { fov_y: FOV_Y, near: 1.0, far: 2.0 });
        let tan_y = FILL * (0.5 * FOV_Y).tan();
        let (f, up, right) = (camera.forward, camera.up / tan_y, camera.forward.cross(camera.up) / (tan_y * aspect));
        // A point q (relative to the centre) at lift L is q - L y: edge k
        // gives edges[k] . q + L slope[k].
        let edges = [up - f, -up - f, right - f, -right - f];
        let slope = [f.y - up.y, f.y + up.y, f.y - right.y, f.y + right.y];
        let mut base = [f32::NEG_INFINITY; 4];
        for &p in points {
            let q = p - centre;
            for (b, e) in base.iter_mut().zip(&edges) {
                *b = b.max(e.dot(q));
            }
        }
        Self { base, slope }
    }

    /// The distance at `lift` (0 for no point).
    fn distance(&self, lift: f32) -> f32 {
        self.base.iter().zip(&self.slope).map(|(b, s)| b + lift * s).fold(0.0, f32::max)
    }
}

/// Clip planes of vertical field of view `fov_y` for a camera whose scene
/// lies from `nearest` to `farthest` away: far 1 % beyond the farthest point,
/// near halfway to the nearest (for a camera inside the scene, a
/// `MIN_NEAR_FRACTION` of far).
pub fn clip_planes(fov_y: f32, nearest: f32, farthest: f32) -> Projection {
    let far = 1.01 * farthest.max(f32::MIN_POSITIVE);
    Projection { fov_y, near: (0.5 * nearest).max(MIN_NEAR_FRACTION * far), far }
}

/// Clip planes of vertical field of view `fov_y` for a camera at `eye` that
/// should see all of `bounds` (see [`clip_planes`]).
pub fn clip_planes_from(eye: Vec3, bounds: &Aabb, fov_y: f32) -> Projection {
    let nearest = eye.clamp(bounds.min, bounds.max).distance(eye);
    let farthest = bounds.corners().iter().map(|c| c.distance(eye)).fold(0.0, f32::max);
    clip_planes(fov_y, nearest, farthest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::CameraPath;
    use glam::Vec3Swizzles;

    /// The fraction of the frame, per axis, that the projected points reach
    /// from `camera` (1 = the edge), and whether all are between the clip planes.
    fn reach(camera: &Camera, points: &[Vec3], aspect: f32) -> (f32, f32, bool) {
        let vp = camera.view_projection(aspect);
        let mut most = (0.0f32, 0.0f32, true);
        for &c in points {
            let clip = vp * c.extend(1.0);
            most.2 &= clip.w > camera.near && clip.w < camera.far;
            most.0 = most.0.max((clip.x / clip.w).abs());
            most.1 = most.1.max((clip.y / clip.w).abs());
        }
        most
    }

    fn boxes() -> [Aabb; 4] {
        [
            // A 5 cm model off the origin.
            Aabb { min: Vec3::new(0.01, 0.0, -0.02), max: Vec3::new(0.06, 0.03, 0.02) },
            // A 200 m city, flat.
            Aabb { min: Vec3::new(-100.0, 0.0, -80.0), max: Vec3::new(100.0, 40.0, 120.0) },
            // A tall tower and a long rod.
            Aabb { min: Vec3::new(-1.0, 0.0, -1.0), max: Vec3::new(1.0, 30.0, 1.0) },
            Aabb { min: Vec3::new(-5.0, 1.0, -0.05), max: Vec3::new(5.0, 1.1, 0.05) },
        ]
    }

    /// Points on a sphere of `radius` around `centre`.
    fn sphere(centre: Vec3, radius: f32) -> Vec<Vec3> {
        let mut points = Vec::new();
        for i in 0..=16 {
            let polar = std::f32::consts::PI * i as f32 / 16.0;
            for j in 0..32 {
                let azimuth = TAU * j as f32 / 32.0;
                let dir = Vec3::new(polar.sin() * azimuth.cos(), polar.cos(), polar.sin() * azimuth.sin());
                points.push(centre + radius * dir);
            }
        }
        points
    }

    /// [`Reach`] gives, at any lift, the distance of the inequality in its
    /// doc evaluated point by point.
    #[test]
    fn reach_is_the_largest_distance_any_point_needs() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let points: Vec<Vec3> = (0..500).map(|_| Vec3::new(3.0 * next(), next(), 0.5 * next())).collect();
        let centre = Vec3::new(0.1, -0.05, 0.02);
        let tan_y = FILL * (0.5 * FOV_Y).tan();
        for k in 0..12 {
            let forward = -view_direction(TAU * k as f32 / 12.0, (10.0 + 5.0 * k as f32).to_radians());
            let camera = look_at(Vec3::ZERO, forward, Projection { fov_y: FOV_Y, near: 1.0, far: 2.0 });
            let right = camera.forward.cross(camera.up);
            let reach = Reach::new(&points, centre, forward, 1.6);
            for lift in [-0.2, 0.0, 0.13, 0.4] {
                let target = centre + lift * Vec3::Y;
                let direct = points
                    .iter()
                    .map(|&c| {
                        let p = c - target;
                        let z = p.dot(camera.forward);
                        (p.dot(camera.up).abs() / tan_y - z).max(p.dot(right).abs() / (tan_y * 1.6) - z)
                    })
                    .fold(0.0, f32::max);
                let d = reach.distance(lift);
                assert!(
                    (d - direct).abs() <= 1e-5 * direct.max(1.0),
                    "direction {k}, lift {lift}: {d} against {direct}"
                );
            }
        }
    }

    #[test]
    fn every_framed_view_holds_the_whole_scene_and_fills_the_frame() {
        let shapes: Vec<Vec<Vec3>> = boxes()
            .iter()
            .map(|b| b.corners().to_vec())
            .chain([sphere(Vec3::new(0.3, 0.02, -0.1), 0.025), sphere(Vec3::ZERO, 150.0)])
            .collect();
        for points in &shapes {
            let centre = Aabb::from_points(points.iter().copied()).center();
            for aspect in [16.0 / 9.0, 1.0, 0.5] {
                let framed = frame(points, aspect).unwrap();
                let t = framed.turntable;
                let sampled = (0..TURN_SAMPLES).map(|k| t.camera_at_angle(TAU * k as f32 / TURN_SAMPLES as f32));
                let frames = (0..600).map(|f| CameraPath::Turntable(t).camera_at(f));
                let mut tightest: f32 = 0.0;
                // The sampled angles and the fixed views keep the margin; the
                // frames between samples stay inside the image.
                let views = sampled.chain(framed.fixed.iter().copied()).map(|c| (c, FILL + 1e-3));
                for (k, (camera, fill)) in views.chain(frames.map(|c| (c, 1.0))).enumerate() {
                    let (x, y, in_depth) = reach(&camera, points, aspect);
                    assert!(in_depth, "{centre}: a point is clipped by near or far: {camera:?}");
                    assert!(x <= fill && y <= fill, "{centre} at {aspect}, view {k}: reaches {x}, {y}");
                    if k < TURN_SAMPLES as usize {
                        tightest = tightest.max(x.max(y));
                    }
                    // Looking at the vertical through the centre, upright.
                    let to_centre = (centre - camera.position).xz().normalize();
                    assert!(to_centre.dot(camera.forward.xz().normalize()) > 0.9999 && camera.up.y > 0.0);
                }
                // Some sampled view touches the margin: no closer turntable would do.
                assert!(tightest > FILL - 2e-3, "{centre} at {aspect}: at most {tightest}");
            }
        }
    }

    #[test]
    fn turntable_looks_down_the_elevation_and_scales_with_the_scene() {
        let small = Aabb { min: Vec3::splat(-0.025), max: Vec3::splat(0.025) }.corners();
        let big = Aabb { min: Vec3::splat(-100.0), max: Vec3::splat(100.0) }.corners();
        let (s, b) = (frame(&small, 1.5).unwrap(), frame(&big, 1.5).unwrap());
        let down = (-s.turntable.camera_at_angle(1.0).forward.y).asin().to_degrees();
        assert!((down - ELEVATION_DEG).abs() < 1e-3, "{down}");
        // The same view, 4000 times larger: distance and clip planes alike.
        let ratio = b.turntable.radius / s.turntable.radius;
        assert!((ratio - 4000.0).abs() < 0.5, "{ratio}");
        let (sp, bp) = (s.turntable.projection, b.turntable.projection);
        assert!((bp.near / sp.near - 4000.0).abs() < 0.5 && (bp.far / sp.far - 4000.0).abs() < 0.5);
        assert!(sp.near > 0.01 && sp.near < 0.1, "{sp:?}");
        assert_eq!(s.fixed.len(), 5);
        let overview = s.fixed[4];
        assert!(((-overview.forward.y).asin().to_degrees() - OVERVIEW_ELEVATION_DEG).abs() < 1e-3);
    }

    #[test]
    fn points_and_empty_boxes_cannot_be_framed() {
        assert!(frame(&[], 1.0).is_none());
        assert!(frame(&[Vec3::ONE, Vec3::ONE], 1.0).is_none());
        assert!(frame(&[Vec3::ZERO, Vec3::new(f32::INFINITY, 1.0, 1.0)], 1.0).is_none());
        // A flat quad is fine.
        let quad = Aabb { min: Vec3::ZERO, max: Vec3::new(1.0, 0.0, 1.0) }.corners();
        assert!(frame(&quad, f32::NAN).is_some());
    }

    #[test]
    fn clip_planes_hold_the_box_from_inside_and_outside() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::new(10.0, 2.0, 10.0) };
        let outside = clip_planes_from(Vec3::new(20.0, 1.0, 5.0), &b, FOV_Y);
        assert!((outside.near - 5.0).abs() < 1e-4, "{outside:?}");
        let farthest = Vec3::new(20.0, 1.0, 5.0).distance(Vec3::new(0.0, 0.0, 0.0));
        assert!((outside.far - 1.01 * farthest).abs() < 1e-3, "{outside:?}");
        let inside = clip_planes_from(Vec3::new(5.0, 1.0, 5.0), &b, FOV_Y);
        assert!(inside.near > 0.0 && inside.near == MIN_NEAR_FRACTION * inside.far, "{inside:?}");
    }
}
