//! The viewer's cameras: the scene's camera path (played, paused, stepped),
//! a fly camera (WASD and mouse look) and an orbit camera. The free cameras
//! always end as a [`LookAt`] (eye, target, field of view), which is what
//! `render --eye --target --fov` takes: a view found by hand renders the
//! same from the command line, and bookmarks
//! ([`crate::scene::bookmarks`]) are stored in that form.

use glam::Vec3;

use crate::scene::free_camera::LookAt;
use crate::scene::{Aabb, Camera, CameraPath};

/// Steepest the free cameras look up or down, degrees (straight up or down
/// has no horizon to keep the camera upright by).
const MAX_PITCH_DEG: f32 = 89.0;

/// Which camera the viewer looks through.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraMode {
    /// The scene's camera path at a frame.
    Path { frame: u32, playing: bool },
    /// Free flight: WASD moves, the mouse turns.
    Fly(FlyCamera),
    /// Circling a target: the mouse turns around it, the wheel zooms.
    Orbit(OrbitCamera),
}

/// A free camera at `eye`, turned by `yaw` (about +y, 0 looks along -z) and
/// `pitch` (up positive), both in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    pub eye: Vec3,
    pub yaw_deg: f32,
    pub pitch_deg: f32,
    pub fov_deg: f32,
    /// Flight speed, scene units per second.
    pub speed: f32,
}

/// A camera `distance` from `target`, turned by `yaw`/`pitch` degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    pub distance: f32,
    pub yaw_deg: f32,
    pub pitch_deg: f32,
    pub fov_deg: f32,
}

/// Unit direction of a yaw and pitch in degrees.
fn direction(yaw_deg: f32, pitch_deg: f32) -> Vec3 {
    let (yaw, pitch) = (yaw_deg.to_radians(), pitch_deg.to_radians());
    Vec3::new(yaw.sin() * pitch.cos(), pitch.sin(), -yaw.cos() * pitch.cos())
}

/// Yaw and pitch in degrees of a direction.
fn angles(d: Vec3) -> (f32, f32) {
    let d = d.try_normalize().unwrap_or(Vec3::NEG_Z);
    (d.x.atan2(-d.z).to_degrees(), d.y.clamp(-1.0, 1.0).asin().to_degrees())
}

impl FlyCamera {
    /// The fly camera where `camera` is, looking where it looks.
    pub fn from_camera(camera: &Camera, speed: f32) -> Self {
        let (yaw_deg, pitch_deg) = angles(camera.forward);
        Self { eye: camera.position, yaw_deg, pitch_deg, fov_deg: camera.fov_y.to_degrees(), speed }
    }

    /// The fly camera at a look-at.
    pub fn from_look_at(l: &LookAt, speed: f32) -> Self {
        let (yaw_deg, pitch_deg) = angles(l.target - l.eye);
        Self { eye: l.eye, yaw_deg, pitch_deg, fov_deg: l.fov_deg, speed }
    }

    pub fn forward(&self) -> Vec3 {
        direction(self.yaw_deg, self.pitch_deg)
    }

    /// Moves `right`, `up` (world +y) and `forward` scene units.
    pub fn fly(&mut self, right: f32, up: f32, forward: f32) {
        let f = self.forward();
        let r = f.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
        self.eye += r * right + Vec3::Y * up + f * forward;
    }

    /// Turns by degrees (positive yaw turns right, positive pitch up).
    pub fn turn(&mut self, yaw_deg: f32, pitch_deg: f32) {
        self.yaw_deg = (self.yaw_deg + yaw_deg).rem_euclid(360.0);
        self.pitch_deg = (self.pitch_deg + pitch_deg).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    pub fn look_at(&self) -> LookAt {
        LookAt { eye: self.eye, target: self.eye + self.forward(), fov_deg: self.fov_deg }
    }
}

impl OrbitCamera {
    /// The orbit around the point `distance` ahead of `camera`.
    pub fn from_camera(camera: &Camera, distance: f32) -> Self {
        let (yaw_deg, pitch_deg) = angles(camera.forward);
        Self {
            target: camera.position + camera.forward * distance,
            distance,
            yaw_deg,
            pitch_deg,
            fov_deg: camera.fov_y.to_degrees(),
        }
    }

    /// Turns around the target by degrees.
    pub fn turn(&mut self, yaw_deg: f32, pitch_deg: f32) {
        self.yaw_deg = (self.yaw_deg + yaw_deg).rem_euclid(360.0);
        self.pitch_deg = (self.pitch_deg + pitch_deg).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    /// Moves the eye towards the target by the factor `scale` (< 1 nearer).
    pub fn zoom(&mut self, scale: f32) {
        self.distance = (self.distance * scale).max(1e-3);
    }

    pub fn look_at(&self) -> LookAt {
        let eye = self.target - direction(self.yaw_deg, self.pitch_deg) * self.distance;
        LookAt { eye, target: self.target, fov_deg: self.fov_deg }
    }
}

impl CameraMode {
    /// The camera to render, with clip planes holding the scene's `bounds`
    /// as `render --eye --target --fov` places them.
    pub fn camera(&self, path: &CameraPath, bounds: &Aabb) -> Camera {
        match self {
            Self::Path { frame, .. } => path.camera_at(*frame),
            Self::Fly(_) | Self::Orbit(_) => {
                let look = self.look_at(path);
                // Only the path's frames or non-finite input can fail; fall
                // back to the path's first frame rather than stop the viewer.
                look.camera(bounds).unwrap_or_else(|_| path.camera_at(0))
            }
        }
    }

    /// The free camera's look-at, or the path camera's eye and view direction.
    pub fn look_at(&self, path: &CameraPath) -> LookAt {
        match self {
            Self::Path { frame, .. } => {
                let c = path.camera_at(*frame);
                LookAt { eye: c.position, target: c.position + c.forward, fov_deg: c.fov_y.to_degrees() }
            }
            Self::Fly(f) => f.look_at(),
            Self::Orbit(o) => o.look_at(),
        }
    }
}

/// The `render` flags of a look-at: `--eye X,Y,Z --target X,Y,Z --fov DEG`
/// (numbers printed so that they parse back to the same floats).
pub fn look_at_args(l: &LookAt) -> Vec<String> {
    let xyz = |v: Vec3| format!("{},{},{}", v.x, v.y, v.z);
    ["--eye".into(), xyz(l.eye), "--target".into(), xyz(l.target), "--fov".into(), l.fov_deg.to_string()].into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_invert_direction() {
        for (yaw, pitch) in [(0.0, 0.0), (90.0, 10.0), (200.0, -45.0), (359.0, 80.0)] {
            let (y, p) = angles(direction(yaw, pitch));
            assert!((y.rem_euclid(360.0) - yaw).abs() < 1e-3, "{yaw} -> {y}");
            assert!((p - pitch).abs() < 1e-3, "{pitch} -> {p}");
        }
    }

    #[test]
    fn fly_camera_keeps_the_camera_it_starts_from() {
        let l = LookAt { eye: Vec3::new(1.0, 2.0, 3.0), target: Vec3::new(4.0, 1.0, -2.0), fov_deg: 50.0 };
        let fly = FlyCamera::from_look_at(&l, 1.0);
        let back = fly.look_at();
        let d = |l: &LookAt| (l.target - l.eye).normalize();
        assert!(d(&back).abs_diff_eq(d(&l), 1e-5));
        assert_eq!(back.eye, l.eye);
    }

    #[test]
    fn orbit_looks_at_its_target_from_its_distance() {
        let o = OrbitCamera { target: Vec3::ONE, distance: 5.0, yaw_deg: 30.0, pitch_deg: 20.0, fov_deg: 60.0 };
        let l = o.look_at();
        assert_eq!(l.target, Vec3::ONE);
        assert!(((l.eye - l.target).length() - 5.0).abs() < 1e-4);
    }

    #[test]
    fn look_at_args_parse_back_exactly() {
        let l = LookAt { eye: Vec3::new(0.1, -2.5, 1e-3), target: Vec3::new(1.0 / 3.0, 0.0, 7.25), fov_deg: 47.5 };
        let args = look_at_args(&l);
        let back: Vec<f32> = args[1].split(',').map(|v| v.parse().unwrap()).collect();
        assert_eq!(back, l.eye.to_array());
        assert_eq!(args[5].parse::<f32>().unwrap(), l.fov_deg);
    }
}
