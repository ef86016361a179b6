//! The reference study's cameras: its path stepping (a float32 parameter
//! advanced by 0.1/30 per frame, so 301 poses per segment, not the 300 of
//! [`KeyedPath::pose_at`]) and its projection for every camera.

use crate::scene::path::{CameraPath, KeyedPath, Projection, SceneCameras, UnityPose};
use crate::scene::{Camera, Scene};

/// Frames of the study's path (two segments; the last one is cut short).
pub const PATH_FRAMES: u32 = 600;

/// The study's per-frame advance of the segment parameter: speed 0.1 over a
/// key distance of 1 at 30 frames per second, in float32.
fn step() -> f32 {
    0.1f32 / 1.0 / 30.0
}

/// The parameter of each pose of a segment: accumulated in float32 from 0 while
/// below 1. The sum after 300 steps rounds to 0.99999917, so a segment has 301
/// poses, the last just short of the next key.
pub fn segment_parameters() -> Vec<f32> {
    let mut t = 0.0f32;
    let mut out = Vec::new();
    while t < 1.0 {
        out.push(t);
        t += step();
    }
    out
}

/// The study's path over a scene's keys: frame `f` is pose `f % 301` of
/// segment `f / 301`; past the last segment, the last key.
#[derive(Clone, Debug)]
pub struct StudyPath {
    keys: Vec<UnityPose>,
    parameters: Vec<f32>,
}

impl StudyPath {
    pub fn new(path: &KeyedPath) -> Self {
        Self { keys: path.keys.clone(), parameters: segment_parameters() }
    }

    /// The Unity pose of frame `frame`.
    pub fn pose_at(&self, frame: u32) -> UnityPose {
        let per_segment = self.parameters.len();
        let (segment, k) = (frame as usize / per_segment, frame as usize % per_segment);
        match (self.keys.get(segment), self.keys.get(segment + 1)) {
            (Some(a), Some(b)) => a.lerp(b, self.parameters[k]),
            _ => *self.keys.last().expect("a keyed path has a key"),
        }
    }
}

/// A scene's cameras as the experiments use them: the path (the study's
/// stepping for keyed paths from `cameras.json`; procedural scenes keep their
/// orbit) and the fixed cameras, all with the study's projection.
#[derive(Clone, Debug)]
pub struct StudyCameras {
    path: PathKind,
    /// The fixed cameras (five for the shared scenes and for orbits).
    pub fixed: Vec<Camera>,
    /// Where the cameras came from, for the report.
    pub source: String,
}

#[derive(Clone, Debug)]
enum PathKind {
    Study(StudyPath),
    Other(CameraPath),
}

impl StudyCameras {
    /// The cameras of `scene`, named `spec` (`cameras_for_scene`'s lookup;
    /// scenes without a camera path framed for images of aspect `aspect`),
    /// with the study's path stepping and projection.
    pub fn for_scene(spec: &str, scene: &Scene, aspect: f32) -> Result<Self, crate::scene::path::CameraFileError> {
        Ok(Self::from_cameras(crate::scene::path::cameras_for_scene(spec, scene, aspect)?))
    }

    pub fn from_cameras(cameras: SceneCameras) -> Self {
        let path = match cameras.path {
            CameraPath::Keyed(k) => PathKind::Study(StudyPath::new(&k)),
            other => PathKind::Other(other),
        };
        let fixed = cameras.fixed.iter().map(with_study_projection).collect();
        Self { path, fixed, source: cameras.source.to_string() }
    }

    /// The camera of path frame `frame`.
    pub fn path_camera(&self, frame: u32) -> Camera {
        match &self.path {
            PathKind::Study(p) => p.pose_at(frame).to_camera(Projection::REFERENCE),
            PathKind::Other(p) => with_study_projection(&p.camera_at(frame)),
        }
    }
}

fn with_study_projection(c: &Camera) -> Camera {
    let p = Projection::REFERENCE;
    Camera { fov_y: p.fov_y, near: p.near, far: p.far, ..*c }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    fn keyed() -> KeyedPath {
        let pose = |x: f32| UnityPose { position: Vec3::new(x, 0.0, 0.0), euler_deg: Vec3::ZERO };
        KeyedPath {
            keys: vec![pose(0.0), pose(1.0), pose(3.0)],
            frames_per_segment: 300,
            projection: Projection::REFERENCE,
        }
    }

    #[test]
    fn a_segment_has_301_poses_in_float32() {
        let t = segment_parameters();
        assert_eq!(t.len(), 301);
        assert_eq!(t[0], 0.0);
        assert!(t[300] < 1.0 && t[300] > 0.9999, "{}", t[300]);
    }

    #[test]
    fn frames_step_through_segments_of_301() {
        let p = StudyPath::new(&keyed());
        assert_eq!(p.pose_at(0).position.x, 0.0);
        // Frame 300 is the last pose of segment 0, just short of key 1;
        // frame 301 is key 1 exactly.
        assert!((p.pose_at(300).position.x - 1.0).abs() < 1e-5 && p.pose_at(300).position.x < 1.0);
        assert_eq!(p.pose_at(301).position.x, 1.0);
        // Frame 599: 298 steps into segment 1 (from 1 to 3).
        let t = segment_parameters()[298];
        assert!((p.pose_at(599).position.x - (1.0 + 2.0 * t)).abs() < 1e-5);
        assert_eq!(p.pose_at(10_000).position.x, 3.0);
    }
}
