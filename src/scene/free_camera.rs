//! Cameras placed by hand (the command line's `--eye`/`--target` and
//! `--orbit`), with clip planes from the scene's bounds so that the whole
//! scene stays between them whatever its size.

use glam::Vec3;

use super::Aabb;
use super::Camera;
use super::framing::{clip_planes, clip_planes_from};
use super::path::{Turntable, look_at};

/// Vertical field of view of hand-placed cameras unless given, degrees
/// (the reference study's).
pub const DEFAULT_FOV_DEG: f32 = 60.0;

/// Why a hand-placed camera cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FreeCameraError {
    /// A value is infinite or NaN.
    #[error("{what} is not finite")]
    NotFinite { what: &'static str },
    /// The field of view is not strictly between 0 and 180 degrees.
    #[error("field of view {0} degrees is not between 0 and 180")]
    BadFov(f32),
    /// The eye and the target coincide: no view direction.
    #[error("the eye and the target are the same point ({0}): there is no direction to look in")]
    EyeIsTarget(Vec3),
    /// The orbit's radius is not positive.
    #[error("orbit radius {0} is not positive")]
    BadRadius(f32),
    /// The orbit's period is zero frames.
    #[error("an orbit needs at least 1 frame per turn")]
    NoFrames,
    /// The scene has no finite, non-empty bounds to place clip planes by.
    #[error("the scene bounds are empty or not finite")]
    EmptyBounds,
}

/// A camera at `eye` looking at `target`, upright.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookAt {
    pub eye: Vec3,
    pub target: Vec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
}

impl LookAt {
    /// The camera, its near and far planes holding all of `bounds`.
    pub fn camera(&self, bounds: &Aabb) -> Result<Camera, FreeCameraError> {
        finite(self.eye, "the eye")?;
        finite(self.target, "the target")?;
        let fov_y = fov(self.fov_deg)?;
        check_bounds(bounds)?;
        if (self.target - self.eye).length_squared() <= f32::MIN_POSITIVE {
            return Err(FreeCameraError::EyeIsTarget(self.eye));
        }
        Ok(look_at(self.eye, self.target, clip_planes_from(self.eye, bounds, fov_y)))
    }
}

/// A turntable given by hand: the eye circles `target` (by default the
/// centre of the scene's bounds) at `radius` and `height` above it, one
/// turn in `frames` frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitSpec {
    pub radius: f32,
    pub height: f32,
    pub frames: u32,
    pub target: Option<Vec3>,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
}

impl OrbitSpec {
    /// The turntable, its near and far planes holding all of `bounds` from
    /// every point of the turn.
    pub fn turntable(&self, bounds: &Aabb) -> Result<Turntable, FreeCameraError> {
        check_bounds(bounds)?;
        let target = self.target.unwrap_or_else(|| bounds.center());
        finite(target, "the target")?;
        if !self.height.is_finite() {
            return Err(FreeCameraError::NotFinite { what: "the orbit height" });
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(FreeCameraError::BadRadius(self.radius));
        }
        if self.frames == 0 {
            return Err(FreeCameraError::NoFrames);
        }
        let fov_y = fov(self.fov_deg)?;
        // The eye stays on a circle of `radius` around (target + height y):
        // its distances to the scene's bounding sphere follow from the
        // circle's distances to the sphere's centre.
        let (centre, sphere) = (bounds.center(), 0.5 * bounds.extent().length());
        let offset = centre - (target + self.height * Vec3::Y);
        let across = Vec3::new(offset.x, 0.0, offset.z).length();
        let nearest = Vec3::new(self.radius - across, offset.y, 0.0).length() - sphere;
        let farthest = Vec3::new(self.radius + across, offset.y, 0.0).length() + sphere;
        Ok(Turntable {
            target,
            radius: self.radius,
            height: self.height,
            frames: self.frames,
            start: 0.0,
            projection: clip_planes(fov_y, nearest, farthest),
        })
    }
}

fn finite(v: Vec3, what: &'static str) -> Result<(), FreeCameraError> {
    if v.is_finite() { Ok(()) } else { Err(FreeCameraError::NotFinite { what }) }
}

/// The field of view in radians, when it is strictly between 0 and 180 degrees.
fn fov(degrees: f32) -> Result<f32, FreeCameraError> {
    if degrees.is_finite() && degrees > 0.0 && degrees < 180.0 {
        Ok(degrees.to_radians())
    } else {
        Err(FreeCameraError::BadFov(degrees))
    }
}

fn check_bounds(bounds: &Aabb) -> Result<(), FreeCameraError> {
    if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return Err(FreeCameraError::EmptyBounds);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::CameraPath;

    fn orbit() -> OrbitSpec {
        OrbitSpec { radius: 1.0, height: 0.0, frames: 600, target: None, fov_deg: DEFAULT_FOV_DEG }
    }

    fn scene() -> Aabb {
        Aabb { min: Vec3::new(-2.0, 0.0, -1.0), max: Vec3::new(2.0, 3.0, 1.0) }
    }

    /// Every corner of the box is between the clip planes.
    fn holds(camera: &Camera, bounds: &Aabb) -> bool {
        bounds.corners().iter().all(|c| {
            let depth = (*c - camera.position).dot(camera.forward);
            depth <= camera.far && (depth >= camera.near || depth <= 0.0)
        })
    }

    #[test]
    fn look_at_sees_the_target_in_the_middle() {
        let l = LookAt { eye: Vec3::new(5.0, 4.0, 6.0), target: Vec3::new(1.0, 1.0, 0.0), fov_deg: 40.0 };
        let c = l.camera(&scene()).unwrap();
        assert_eq!(c.position, l.eye);
        assert!((c.fov_y - 40f32.to_radians()).abs() < 1e-6);
        let clip = c.view_projection(1.5) * l.target.extend(1.0);
        assert!((clip.x / clip.w).abs() < 1e-5 && (clip.y / clip.w).abs() < 1e-5, "{clip}");
        assert!(holds(&c, &scene()) && c.up.y > 0.0);
        // Inside the scene: near is tiny but positive.
        let inside = LookAt { eye: Vec3::new(0.0, 1.0, 0.0), ..l }.camera(&scene()).unwrap();
        assert!(inside.near > 0.0 && inside.near < 1e-2 && holds(&inside, &scene()));
    }

    #[test]
    fn bad_free_cameras_say_why() {
        let l = LookAt { eye: Vec3::ONE, target: Vec3::ONE, fov_deg: 60.0 };
        assert_eq!(l.camera(&scene()), Err(FreeCameraError::EyeIsTarget(Vec3::ONE)));
        for fov in [0.0, 180.0, -5.0, f32::NAN] {
            let l = LookAt { target: Vec3::ZERO, fov_deg: fov, ..l };
            assert!(matches!(l.camera(&scene()), Err(FreeCameraError::BadFov(_))), "{fov}");
        }
        let l = LookAt { eye: Vec3::new(f32::INFINITY, 0.0, 0.0), target: Vec3::ZERO, fov_deg: 60.0 };
        assert_eq!(l.camera(&scene()).unwrap_err().to_string(), "the eye is not finite");
        let o = orbit();
        assert_eq!(OrbitSpec { radius: 0.0, ..o }.turntable(&scene()), Err(FreeCameraError::BadRadius(0.0)));
        assert_eq!(OrbitSpec { frames: 0, ..o }.turntable(&scene()), Err(FreeCameraError::NoFrames));
        assert_eq!(o.turntable(&Aabb::EMPTY), Err(FreeCameraError::EmptyBounds));
    }

    #[test]
    fn orbit_circles_its_target_and_holds_the_scene() {
        let o = OrbitSpec { radius: 8.0, height: 2.0, frames: 40, target: Some(Vec3::new(1.0, 1.0, 0.5)), ..orbit() };
        let path = CameraPath::Turntable(o.turntable(&scene()).unwrap());
        assert_eq!(path.frame_count(), 40);
        for f in 0..40 {
            let c = path.camera_at(f);
            let to_eye = c.position - o.target.unwrap();
            assert!((to_eye.y - 2.0).abs() < 1e-5 && (Vec3::new(to_eye.x, 0.0, to_eye.z).length() - 8.0).abs() < 1e-4);
            assert!(holds(&c, &scene()), "frame {f}: {c:?}");
        }
        // A quarter turn from +x is +z.
        let q = path.camera_at(10).position - o.target.unwrap();
        assert!((q - Vec3::new(0.0, 2.0, 8.0)).length() < 1e-4, "{q}");
        // By default it circles the scene's centre.
        let t = orbit().turntable(&scene()).unwrap();
        assert_eq!(t.target, scene().center());
    }
}
