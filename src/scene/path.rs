//! Camera paths, sampled by frame index (never by wall clock, so that every
//! run renders the same frames): the keyed paths of `cameras.json` (Unity's
//! conventions, converted), fixed cameras, the procedural scenes' orbits and
//! turntables (the framed default of other scenes, and `--orbit`). Also the
//! `--camera` choice and its resolver.

use std::collections::BTreeMap;
use std::f32::consts::TAU;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::{EulerRot, Quat, Vec3};
use serde::Deserialize;

use super::lights::{LightSetError, LightSpec};
use super::{Aabb, Camera, Light, Scene, framing};

/// Vertical field of view and clip planes of a path's cameras.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Vertical field of view in radians.
    pub fov_y: f32,
    /// Near clip distance (depth 1 in the reversed-Z projection).
    pub near: f32,
    /// Far clip distance (depth 0).
    pub far: f32,
}

impl Projection {
    /// The reference study's projection (`cameras.json`): 60 degrees, 0.3 to 1000.
    pub const REFERENCE: Projection = Projection { fov_y: std::f32::consts::FRAC_PI_3, near: 0.3, far: 1000.0 };
}

/// One camera pose in Unity's conventions, as `cameras.json` stores it:
/// left-handed, y up, looking along local +z; euler angles in degrees
/// (x = pitch, positive looks down; y = yaw; z = roll), applied z, x, then y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnityPose {
    /// Unity world position.
    pub position: Vec3,
    /// (pitch, yaw, roll) in degrees.
    pub euler_deg: Vec3,
}

impl UnityPose {
    /// Converts to our right-handed frame, as the file's `about` says:
    /// position (x, y, z) -> (-x, y, z); forward and up are Unity's local +z
    /// and +y turned by the rotation `Ry(yaw) Rx(pitch) Rz(roll)`, then x mirrored.
    /// For roll 0 that is forward = (-sin(yaw) cos(pitch), -sin(pitch), cos(yaw) cos(pitch))
    /// and up = (-sin(yaw) sin(pitch), cos(pitch), cos(yaw) sin(pitch)).
    pub fn to_camera(&self, projection: Projection) -> Camera {
        let [pitch, yaw, roll] = self.euler_deg.to_array().map(f32::to_radians);
        // Same matrices in either handedness: only the final mirror changes frames.
        let q = Quat::from_euler(EulerRot::YXZ, yaw, pitch, roll);
        let mirror = Vec3::new(-1.0, 1.0, 1.0);
        Camera {
            position: self.position * mirror,
            forward: (q * Vec3::Z * mirror).normalize(),
            up: (q * Vec3::Y * mirror).normalize(),
            fov_y: projection.fov_y,
            near: projection.near,
            far: projection.far,
        }
    }

    /// Componentwise linear interpolation of position and euler angles (the
    /// file's `path_rule`: angles are not wrapped to the shorter way).
    pub fn lerp(&self, other: &UnityPose, t: f32) -> UnityPose {
        UnityPose {
            position: self.position.lerp(other.position, t),
            euler_deg: self.euler_deg.lerp(other.euler_deg, t),
        }
    }
}

/// How a procedural scene's orbit looks at it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrbitStyle {
    /// Inside an enclosed scene (the atrium's courtyard), looking across it.
    Inside,
    /// Above an open scene (the voxel terrain), looking down at 30 degrees.
    Above,
}

/// The camera path of a procedural scene: one full turn around the vertical
/// axis through the centre of `bounds`, over `frames` frames.
///
/// - `Inside`: the eye moves on an ellipse at 35% of the box's half-extents
///   around the centre, at 35% of the height above the floor, and looks at the
///   mirrored point at 70% of the half-extents on the other side, at 20% of
///   the height: across the courtyard, slightly down.
/// - `Above`: the eye moves on a circle of radius = the larger horizontal
///   half-extent, looking at the centre of the box's mid-height at 30 degrees
///   down (eye height = target height + radius·tan 30°).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The scene box orbited.
    pub bounds: Aabb,
    /// Inside looking across, or above looking down.
    pub style: OrbitStyle,
    /// Frames per full turn; later frames wrap around.
    pub frames: u32,
    /// Projection of every orbit camera.
    pub projection: Projection,
}

impl Orbit {
    /// Default frames per turn.
    pub const FRAMES: u32 = 600;

    /// The orbit of `bounds` in `style`: 600 frames, 60 degrees fov, near 0.1
    /// and far `max(1000, 4 × diagonal)`.
    pub fn with_style(bounds: &Aabb, style: OrbitStyle) -> Orbit {
        let diagonal = bounds.extent().length();
        let far = if diagonal.is_finite() { (4.0 * diagonal).max(1000.0) } else { 1000.0 };
        Orbit {
            bounds: *bounds,
            style,
            frames: Self::FRAMES,
            projection: Projection { fov_y: std::f32::consts::FRAC_PI_3, near: 0.1, far },
        }
    }

    /// The camera at turn angle `angle` (radians; 0 is on the +x side).
    pub fn camera_at_angle(&self, angle: f32) -> Camera {
        let (min, ext) = (self.bounds.min, self.bounds.extent());
        let half = 0.5 * ext;
        let c = self.bounds.center();
        let dir = Vec3::new(angle.cos(), 0.0, angle.sin());
        let (eye, target) = match self.style {
            OrbitStyle::Inside => {
                let eye = c + 0.35 * half * dir;
                let target = c - 0.7 * half * dir;
                (eye.with_y(min.y + 0.35 * ext.y), target.with_y(min.y + 0.2 * ext.y))
            }
            OrbitStyle::Above => {
                let radius = half.x.max(half.z).max(1e-3);
                let target = c;
                let eye = target + radius * dir + Vec3::Y * radius * 30f32.to_radians().tan();
                (eye, target)
            }
        };
        look_at(eye, target, self.projection)
    }

    fn camera_at(&self, frame: u32) -> Camera {
        let frames = self.frames.max(1);
        self.camera_at_angle(TAU * (frame % frames) as f32 / frames as f32)
    }

    /// Five fixed cameras: the orbit at 45, 135, 225 and 315 degrees, and an
    /// overview from above the (+x, +z) top corner looking at the centre.
    pub fn fixed_cameras(&self) -> Vec<Camera> {
        let mut cams: Vec<Camera> =
            (0..4).map(|k| self.camera_at_angle((45.0 + 90.0 * k as f32).to_radians())).collect();
        let b = &self.bounds;
        let eye = Vec3::new(b.max.x, b.max.y + 0.25 * b.extent().y.max(1.0), b.max.z);
        cams.push(look_at(eye, b.center(), self.projection));
        cams
    }
}

/// A camera at `eye` looking at `target`, upright (its up in the vertical
/// plane through its view direction; looking straight down, up is -z).
pub fn look_at(eye: Vec3, target: Vec3, p: Projection) -> Camera {
    let forward = (target - eye).try_normalize().unwrap_or(Vec3::NEG_Z);
    // Up orthogonal to forward, in the vertical plane through it.
    let right = forward.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
    Camera { position: eye, forward, up: right.cross(forward), fov_y: p.fov_y, near: p.near, far: p.far }
}

/// A camera circling `target` on a horizontal circle of `radius` at `height`
/// above it, always looking at it: the framed default of scenes without a
/// camera path ([`framing`]) and `--orbit`. Frame k is at angle `start +
/// 2π k / frames` from the +x side, turning towards +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turntable {
    /// The point circled and looked at.
    pub target: Vec3,
    /// Horizontal distance of the eye from `target`.
    pub radius: f32,
    /// Height of the eye above `target` (negative: below).
    pub height: f32,
    /// Frames per full turn; later frames wrap around.
    pub frames: u32,
    /// Turn angle of frame 0 (radians; 0 is on the +x side).
    pub start: f32,
    /// Projection of every camera of the turn.
    pub projection: Projection,
}

impl Turntable {
    /// The camera at turn angle `angle` (radians; 0 is on the +x side).
    pub fn camera_at_angle(&self, angle: f32) -> Camera {
        let eye = self.target + Vec3::new(self.radius * angle.cos(), self.height, self.radius * angle.sin());
        look_at(eye, self.target, self.projection)
    }

    fn camera_at(&self, frame: u32) -> Camera {
        let frames = self.frames.max(1);
        self.camera_at_angle(self.start + TAU * (frame % frames) as f32 / frames as f32)
    }
}

/// A camera path of `cameras.json`: keys interpolated linearly.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyedPath {
    /// At least one key, in path order.
    pub keys: Vec<UnityPose>,
    /// Frames from one key to the next (300 in the reference study).
    pub frames_per_segment: u32,
    /// Projection of every camera of the path (from the file).
    pub projection: Projection,
}

impl KeyedPath {
    /// Pose at `frame`: segment `frame / frames_per_segment`, interpolated by
    /// `(frame % frames_per_segment) / frames_per_segment`; frame `k ×
    /// frames_per_segment` is exactly key k, and frames past the end are the last key.
    pub fn pose_at(&self, frame: u32) -> UnityPose {
        let fps = self.frames_per_segment.max(1);
        let last = self.keys.len() - 1;
        let segment = (frame / fps) as usize;
        if segment >= last {
            return self.keys[last];
        }
        let t = (frame % fps) as f32 / fps as f32;
        self.keys[segment].lerp(&self.keys[segment + 1], t)
    }
}

/// A camera over frames. Sampled by frame index only.
#[derive(Clone, Debug, PartialEq)]
pub enum CameraPath {
    /// Keyed path from `cameras.json`.
    Keyed(KeyedPath),
    /// One camera for every frame.
    Fixed(Camera),
    /// A procedural scene's orbit of its bounds.
    Orbit(Orbit),
    /// A camera circling a point.
    Turntable(Turntable),
}

impl CameraPath {
    /// The camera of frame `frame` (0-based).
    pub fn camera_at(&self, frame: u32) -> Camera {
        match self {
            CameraPath::Keyed(p) => p.pose_at(frame).to_camera(p.projection),
            CameraPath::Fixed(c) => *c,
            CameraPath::Orbit(o) => o.camera_at(frame),
            CameraPath::Turntable(t) => t.camera_at(frame),
        }
    }

    /// Frames in one run of the path: `(keys - 1) × frames_per_segment` for a
    /// keyed path (600 for 3 keys; 1 for a single key), 1 for a fixed camera,
    /// the frames of one turn for an orbit or a turntable.
    pub fn frame_count(&self) -> u32 {
        match self {
            CameraPath::Keyed(p) => ((p.keys.len() as u32).saturating_sub(1) * p.frames_per_segment).max(1),
            CameraPath::Fixed(_) => 1,
            CameraPath::Orbit(o) => o.frames.max(1),
            CameraPath::Turntable(t) => t.frames.max(1),
        }
    }
}

/// Where a scene's cameras came from (for reports).
#[derive(Clone, Debug, PartialEq)]
pub enum CameraSource {
    /// The scene's entry in a `cameras.json` file.
    File { path: PathBuf, scene: String },
    /// A procedural scene's orbit of its bounds.
    Orbit(OrbitStyle),
    /// The turntable framing the scene's bounds ([`framing`]).
    Framed,
    /// The procedural terrain's flight, low and high
    /// ([`super::generate::terrain::TerrainSpec::path`]).
    Flight,
    /// The city's walk at street level; `--camera flyover` flies over it
    /// ([`super::generate::city::CitySpec::street_path`]).
    Streets,
    /// Camera `index` of the scene file (glTF).
    Own { scene: String, index: usize },
}

impl CameraSource {
    /// Whether the scene is an object framed from outside (a model without
    /// a camera path), not a scene the cameras move through: its generated
    /// lights go around it ([`super::lights::region_around`]).
    pub fn seen_from_outside(&self) -> bool {
        matches!(self, CameraSource::Framed | CameraSource::Own { .. })
    }
}

impl fmt::Display for CameraSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CameraSource::File { path, scene } => write!(f, "{} [{}]", path.display(), scene),
            CameraSource::Orbit(OrbitStyle::Inside) => f.write_str("orbit inside the scene bounds"),
            CameraSource::Orbit(OrbitStyle::Above) => f.write_str("orbit above the scene bounds"),
            CameraSource::Framed => f.write_str("turntable framing the scene bounds"),
            CameraSource::Flight => f.write_str("flight over the terrain, low and high"),
            CameraSource::Streets => f.write_str("walk through the city at street level"),
            CameraSource::Own { scene, index } => write!(f, "{scene} [camera {index}]"),
        }
    }
}

/// A scene's camera path and fixed cameras.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCameras {
    /// The scene as `--scene` names it (for messages).
    pub scene: String,
    /// The camera path of `--camera path`.
    pub path: CameraPath,
    /// The fixed cameras (five for the reference scenes, orbits and framed scenes).
    pub fixed: Vec<Camera>,
    /// The scene file's own cameras (glTF), for `--camera gltf:K`.
    pub own: Vec<Camera>,
    /// A second path flying over the scene, for `--camera flyover` (the
    /// city's; `None` for other scenes).
    pub flyover: Option<CameraPath>,
    /// Where the path came from.
    pub source: CameraSource,
}

impl SceneCameras {
    /// Where generated lights go in a scene of `bounds` seen through these
    /// cameras: inside the scene when the cameras move through it, around
    /// it when they look at it from outside ([`CameraSource::seen_from_outside`]).
    pub fn light_region(&self, bounds: &Aabb) -> Aabb {
        if self.source.seen_from_outside() { super::lights::region_around(bounds) } else { *bounds }
    }

    /// The light set `spec` asks for in a scene of `bounds` seen through
    /// these cameras, placed for the `reference` camera at image aspect
    /// `aspect`, and the spec it built (`auto` resolved for how the scene is
    /// seen: [`LightSpec::resolve`]). `studio` is placed around `bounds`,
    /// generated lights in [`SceneCameras::light_region`].
    pub fn build_lights(
        &self,
        spec: &LightSpec,
        bounds: &Aabb,
        reference: &Camera,
        aspect: f32,
        seed: u64,
    ) -> Result<(LightSpec, Vec<Light>), LightSetError> {
        let spec = spec.resolve(&self.source);
        let region = if spec == LightSpec::Studio { *bounds } else { self.light_region(bounds) };
        let lights = super::lights::build_lights(&spec, &region, reference, aspect, seed)?;
        Ok((spec, lights))
    }

    /// The path `choice` selects: the scene path, or one fixed or file camera
    /// as a [`CameraPath::Fixed`]. Fails when the index is out of range.
    pub fn select(&self, choice: CameraChoice) -> Result<CameraPath, CameraChoiceError> {
        match choice {
            CameraChoice::Path => Ok(self.path.clone()),
            CameraChoice::Flyover => {
                self.flyover.clone().ok_or_else(|| CameraChoiceError::NoFlyover { scene: self.scene.clone() })
            }
            CameraChoice::Fixed(k) => self
                .fixed
                .get(k)
                .map(|c| CameraPath::Fixed(*c))
                .ok_or(CameraChoiceError::OutOfRange { index: k, count: self.fixed.len() }),
            CameraChoice::Gltf(k) => self.own.get(k).map(|c| CameraPath::Fixed(*c)).ok_or_else(|| {
                CameraChoiceError::NoSuchFileCamera { scene: self.scene.clone(), index: k, count: self.own.len() }
            }),
        }
    }
}

/// The CLI's `--camera`: `path`, `fixed:K` or `gltf:K` (K from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CameraChoice {
    /// The scene's camera path.
    #[default]
    Path,
    /// The scene's fly-over path (the city's).
    Flyover,
    /// Fixed camera K (from 0).
    Fixed(usize),
    /// Camera K (from 0) of the scene's glTF file.
    Gltf(usize),
}

impl fmt::Display for CameraChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CameraChoice::Path => f.write_str("path"),
            CameraChoice::Flyover => f.write_str("flyover"),
            CameraChoice::Fixed(k) => write!(f, "fixed:{k}"),
            CameraChoice::Gltf(k) => write!(f, "gltf:{k}"),
        }
    }
}

/// Why a `--camera` value is not usable.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraChoiceError {
    /// Not `path`, `fixed:K` or `gltf:K` (nor `bookmark:FILE:NAME`, which
    /// the command line resolves with [`super::bookmarks::BookmarkRef`]).
    #[error("\"{0}\": expected 'path', 'flyover', 'fixed:K' or 'gltf:K' (K = 0, 1, ...), or 'bookmark:FILE:NAME'")]
    Syntax(String),
    /// The scene has fewer fixed cameras.
    #[error("camera fixed:{index} does not exist: the scene has {count} fixed cameras (fixed:0 to fixed:{})", count.saturating_sub(1))]
    OutOfRange { index: usize, count: usize },
    /// The scene has no fly-over path.
    #[error("camera flyover: {scene} has no fly-over path (the city has one)")]
    NoFlyover { scene: String },
    /// The scene file has fewer cameras of its own.
    #[error("camera gltf:{index} does not exist: {scene} {}", file_camera_count(*count))]
    NoSuchFileCamera { scene: String, index: usize, count: usize },
}

fn file_camera_count(count: usize) -> String {
    match count {
        0 => "has no cameras of its own".into(),
        1 => "has 1 camera (gltf:0)".into(),
        n => format!("has {n} cameras (gltf:0 to gltf:{})", n - 1),
    }
}

impl FromStr for CameraChoice {
    type Err = CameraChoiceError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let s = s.trim();
        if s.eq_ignore_ascii_case("path") {
            return Ok(CameraChoice::Path);
        }
        if s.eq_ignore_ascii_case("flyover") {
            return Ok(CameraChoice::Flyover);
        }
        let index = |prefix: &str| s.strip_prefix(prefix).and_then(|k| k.parse::<usize>().ok());
        index("fixed:")
            .map(CameraChoice::Fixed)
            .or_else(|| index("gltf:").map(CameraChoice::Gltf))
            .ok_or_else(|| CameraChoiceError::Syntax(s.into()))
    }
}

/// Why a camera file cannot be used. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum CameraFileError {
    /// The file cannot be read.
    #[error("{path}: cannot read camera file: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not JSON of the `cameras.json` shape.
    #[error("{path}: not a camera file: {message}")]
    Json { path: PathBuf, message: String },
    /// The file parses but holds impossible values.
    #[error("{path}: {problem}")]
    Invalid { path: PathBuf, problem: String },
    /// The file has no entry for the scene.
    #[error("{path}: no cameras for scene '{scene}' (the file has: {})", known.join(", "))]
    UnknownScene { path: PathBuf, scene: String, known: Vec<String> },
    /// An orbit or framing needs a finite box that is more than a point.
    #[error("cannot place cameras: the scene bounds are empty, a single point, or not finite")]
    EmptyBounds,
}

#[derive(Deserialize)]
struct CamerasFile {
    projection: ProjectionJson,
    frames_per_segment: u32,
    scenes: BTreeMap<String, SceneJson>,
}

#[derive(Deserialize)]
struct ProjectionJson {
    vertical_fov_deg: f32,
    near: f32,
    far: f32,
}

#[derive(Deserialize)]
struct SceneJson {
    path: PosesJson,
    fixed_cameras: PosesJson,
}

#[derive(Deserialize)]
struct PosesJson {
    positions: Vec<[f32; 3]>,
    euler_deg: Vec<[f32; 3]>,
}

fn read_cameras_file(path: &Path) -> Result<CamerasFile, CameraFileError> {
    let text = std::fs::read_to_string(path).map_err(|source| CameraFileError::Io { path: path.into(), source })?;
    serde_json::from_str(&text).map_err(|e| CameraFileError::Json { path: path.into(), message: e.to_string() })
}

impl CamerasFile {
    fn projection(&self, path: &Path) -> Result<Projection, CameraFileError> {
        let p = &self.projection;
        let ok = p.vertical_fov_deg > 0.0 && p.vertical_fov_deg < 180.0 && p.near > 0.0 && p.far > p.near;
        if !ok || self.frames_per_segment == 0 {
            return Err(CameraFileError::Invalid {
                path: path.into(),
                problem: format!(
                    "bad projection or frames_per_segment (fov {} deg, near {}, far {}, {} frames per segment)",
                    p.vertical_fov_deg, p.near, p.far, self.frames_per_segment
                ),
            });
        }
        Ok(Projection { fov_y: p.vertical_fov_deg.to_radians(), near: p.near, far: p.far })
    }

    /// The entry `scene` as [`SceneCameras`] (with no cameras of the scene
    /// file's own, which [`cameras_for_scene`] adds).
    fn scene_cameras(&self, path: &Path, scene: &str) -> Result<SceneCameras, CameraFileError> {
        let projection = self.projection(path)?;
        let entry = self.scenes.get(scene).ok_or_else(|| CameraFileError::UnknownScene {
            path: path.into(),
            scene: scene.into(),
            known: self.scenes.keys().cloned().collect(),
        })?;
        let poses = |p: &PosesJson, what: &str| -> Result<Vec<UnityPose>, CameraFileError> {
            let invalid = |problem: String| CameraFileError::Invalid { path: path.into(), problem };
            if p.positions.len() != p.euler_deg.len() {
                return Err(invalid(format!(
                    "scene '{scene}': {what} has {} positions but {} euler angles",
                    p.positions.len(),
                    p.euler_deg.len()
                )));
            }
            let poses: Vec<UnityPose> = p
                .positions
                .iter()
                .zip(&p.euler_deg)
                .map(|(&pos, &e)| UnityPose { position: Vec3::from(pos), euler_deg: Vec3::from(e) })
                .collect();
            if poses.iter().any(|k| !k.position.is_finite() || !k.euler_deg.is_finite()) {
                return Err(invalid(format!("scene '{scene}': {what} has a non-finite value")));
            }
            Ok(poses)
        };
        let keys = poses(&entry.path, "path")?;
        if keys.is_empty() {
            return Err(CameraFileError::Invalid {
                path: path.into(),
                problem: format!("scene '{scene}': path has no keys"),
            });
        }
        let fixed = poses(&entry.fixed_cameras, "fixed_cameras")?.iter().map(|p| p.to_camera(projection)).collect();
        Ok(SceneCameras {
            scene: scene.into(),
            path: CameraPath::Keyed(KeyedPath { keys, frames_per_segment: self.frames_per_segment, projection }),
            fixed,
            own: Vec::new(),
            flyover: None,
            source: CameraSource::File { path: path.into(), scene: scene.into() },
        })
    }
}

/// Loads the path and fixed cameras of scene `scene_name` from a
/// `cameras.json` file (format: `/work/shared/scenes/cameras.json`).
pub fn load_cameras_json(path: &Path, scene_name: &str) -> Result<SceneCameras, CameraFileError> {
    read_cameras_file(path)?.scene_cameras(path, scene_name)
}

/// The cameras of `scene`, named `scene_spec` by `--scene`, for images of
/// aspect `aspect` (width / height).
///
/// A folder or file whose parent folder holds a `cameras.json` with an entry
/// named after it (the folder name, or the file stem) uses that entry:
/// `../shared/scenes/sponza-thesis` -> `../shared/scenes/cameras.json`,
/// scene `sponza-thesis`. A `cameras.json` that exists but cannot be read or
/// parsed is an error. The procedural `atrium` and `voxels` get the
/// deterministic [`Orbit`] of their bounds (inside and above) and its five
/// fixed cameras; the terrain its flight; the city its street-level walk,
/// its fly-over (`--camera flyover`) and five fixed cameras from their keys. Every other scene is framed from outside ([`framing`]):
/// its path is the framing turntable, or, when the file brings cameras
/// (glTF), its first camera held still; its fixed cameras are the framed
/// views. The file's own cameras are `gltf:K` in every case.
pub fn cameras_for_scene(scene_spec: &str, scene: &Scene, aspect: f32) -> Result<SceneCameras, CameraFileError> {
    cameras_for(scene_spec, &scene.bounds(), &scene.cameras, || framing::frame(&scene.world_positions(), aspect))
}

/// [`cameras_for_scene`] for a scene of `bounds` with cameras `own`, framed
/// by `frame` when it comes to that.
fn cameras_for(
    spec: &str,
    bounds: &Aabb,
    own: &[Camera],
    frame: impl FnOnce() -> Option<framing::Framed>,
) -> Result<SceneCameras, CameraFileError> {
    if let Some(mut cameras) = cameras_json_entry(spec)? {
        cameras.scene = spec.into();
        cameras.own = own.to_vec();
        return Ok(cameras);
    }
    if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return Err(CameraFileError::EmptyBounds);
    }
    if let Some(Ok(city)) = super::generate::city::CitySpec::parse(spec) {
        let (street, flyover) = (city.street_path(), city.flyover_path());
        // Fixed cameras: the walk's first two keys, the fly-over's first three.
        let keys =
            |p: &KeyedPath, n: usize| p.keys.iter().take(n).map(|k| k.to_camera(p.projection)).collect::<Vec<_>>();
        let fixed = [keys(&street, 2), keys(&flyover, 3)].concat();
        return Ok(SceneCameras {
            scene: spec.into(),
            path: CameraPath::Keyed(street),
            fixed,
            own: own.to_vec(),
            flyover: Some(CameraPath::Keyed(flyover)),
            source: CameraSource::Streets,
        });
    }
    let (path, fixed, source) = match spec {
        "atrium" | "voxels" => {
            let style = if spec == "atrium" { OrbitStyle::Inside } else { OrbitStyle::Above };
            let orbit = Orbit::with_style(bounds, style);
            (CameraPath::Orbit(orbit), orbit.fixed_cameras(), CameraSource::Orbit(style))
        }
        "terrain" | "terrain-small" => {
            use super::generate::terrain::TerrainSpec;
            let terrain = if spec == "terrain" { TerrainSpec::DEFAULT } else { TerrainSpec::SMALL };
            let flight = terrain.path();
            // The fixed cameras: the flight's first five keys (low, low, high, high, low).
            let fixed = flight.keys.iter().take(5).map(|k| k.to_camera(flight.projection)).collect();
            (CameraPath::Keyed(flight), fixed, CameraSource::Flight)
        }
        _ => {
            let framed = frame().ok_or(CameraFileError::EmptyBounds)?;
            match own.first() {
                Some(first) => {
                    (CameraPath::Fixed(*first), framed.fixed, CameraSource::Own { scene: spec.into(), index: 0 })
                }
                None => (CameraPath::Turntable(framed.turntable), framed.fixed, CameraSource::Framed),
            }
        }
    };
    Ok(SceneCameras { scene: spec.into(), path, fixed, own: own.to_vec(), flyover: None, source })
}

/// The entry of `cameras.json` beside the scene `spec` names, if there is one.
fn cameras_json_entry(spec: &str) -> Result<Option<SceneCameras>, CameraFileError> {
    let spec = Path::new(spec);
    if !spec.exists() {
        return Ok(None);
    }
    let key = if spec.is_dir() { spec.file_name() } else { spec.file_stem() };
    let Some(key) = key.and_then(|k| k.to_str()) else { return Ok(None) };
    let parent = spec.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let file = parent.join("cameras.json");
    if !file.is_file() {
        return Ok(None);
    }
    let cameras = read_cameras_file(&file)?;
    if !cameras.scenes.contains_key(key) {
        return Ok(None);
    }
    cameras.scene_cameras(&file, key).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHARED_CAMERAS: &str = "../shared/scenes/cameras.json";

    fn shared_cameras(scene: &str) -> Option<SceneCameras> {
        if !Path::new(SHARED_CAMERAS).is_file() {
            eprintln!("skipped: {SHARED_CAMERAS} is absent (the shared scenes are not beside the project)");
            return None;
        }
        Some(load_cameras_json(Path::new(SHARED_CAMERAS), scene).expect("shared cameras.json loads"))
    }

    fn close(a: Vec3, b: Vec3, eps: f32) -> bool {
        (a - b).abs().max_element() <= eps
    }

    fn temp_json(text: &str) -> tempfile::NamedTempFile {
        let f = tempfile::Builder::new().suffix(".json").tempfile().unwrap();
        std::fs::write(f.path(), text).unwrap();
        f
    }

    #[test]
    fn sponza_frame0_matches_the_files_own_check() {
        let Some(cams) = shared_cameras("sponza-thesis") else { return };
        assert_eq!(cams.path.frame_count(), 600);
        let c = cams.path.camera_at(0);
        assert!(close(c.position, Vec3::new(-6.0, 4.0, -0.5), 1e-5), "{:?}", c.position);
        assert!(close(c.forward, Vec3::new(0.975, -0.139, 0.172), 2e-3), "{:?}", c.forward);
        assert_eq!((c.fov_y, c.near, c.far), (60f32.to_radians(), 0.3, 1000.0));
    }

    #[test]
    fn sponza_frame300_is_key1_and_150_is_halfway() {
        let Some(cams) = shared_cameras("sponza-thesis") else { return };
        let CameraPath::Keyed(p) = &cams.path else { panic!("keyed path expected") };
        let proj = p.projection;
        assert_eq!(cams.path.camera_at(300), p.keys[1].to_camera(proj));
        let half = p.keys[0].lerp(&p.keys[1], 0.5);
        assert_eq!(cams.path.camera_at(150), half.to_camera(proj));
        // Halfway of (6,4,-0.5)..(4,4,-2.5), mirrored; euler (8,-52,0).
        let c = cams.path.camera_at(150);
        assert!(close(c.position, Vec3::new(-5.0, 4.0, -1.5), 1e-5));
        assert!(close(half.euler_deg, Vec3::new(8.0, -52.0, 0.0), 1e-4));
        // The end clamps to the last key.
        let last = p.keys[2].to_camera(proj);
        assert_eq!(cams.path.camera_at(600), last);
        assert_eq!(cams.path.camera_at(10_000), last);
        assert_ne!(cams.path.camera_at(599), last);
    }

    #[test]
    fn up_is_orthogonal_to_forward_and_points_up() {
        let mut cams: Vec<Camera> = Vec::new();
        for scene in ["sponza-thesis", "lost-empire-partial"] {
            if let Some(c) = shared_cameras(scene) {
                cams.extend((0..=600).step_by(25).map(|f| c.path.camera_at(f)));
                cams.extend(c.fixed);
            }
        }
        for pitch in [-80.0, -7.0, 0.0, 8.0, 80.0] {
            for yaw in [-280.0, -90.0, -24.0, 0.0, 45.0, 200.0] {
                let pose = UnityPose { position: Vec3::ZERO, euler_deg: Vec3::new(pitch, yaw, 0.0) };
                cams.push(pose.to_camera(Projection::REFERENCE));
            }
        }
        for c in cams {
            assert!(c.up.dot(c.forward).abs() < 1e-5, "{c:?}");
            assert!(c.up.y > 0.0, "{c:?}");
            assert!((c.forward.length() - 1.0).abs() < 1e-5 && (c.up.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn unity_conversion_closed_form() {
        let (p, y) = (20f32.to_radians(), 130f32.to_radians());
        let pose = UnityPose { position: Vec3::new(1.0, 2.0, 3.0), euler_deg: Vec3::new(20.0, 130.0, 0.0) };
        let c = pose.to_camera(Projection::REFERENCE);
        assert_eq!(c.position, Vec3::new(-1.0, 2.0, 3.0));
        assert!(close(c.forward, Vec3::new(-y.sin() * p.cos(), -p.sin(), y.cos() * p.cos()), 1e-6));
        assert!(close(c.up, Vec3::new(-y.sin() * p.sin(), p.cos(), y.cos() * p.sin()), 1e-6));
        // Positive pitch looks down.
        assert!(c.forward.y < 0.0);
    }

    #[test]
    fn fixed_cameras_of_the_shared_file() {
        let Some(cams) = shared_cameras("sponza-thesis") else { return };
        assert_eq!(cams.fixed.len(), 5);
        // Fixed camera 1 is the path's first key.
        assert_eq!(cams.fixed[1], cams.path.camera_at(0));
        assert_eq!(cams.fixed[2].position, Vec3::new(6.0, 4.0, -0.5));
        let p = cams.select(CameraChoice::Fixed(4)).unwrap();
        assert_eq!(p.camera_at(123), cams.fixed[4]);
        assert_eq!(p.frame_count(), 1);
        let err = cams.select(CameraChoice::Fixed(5)).unwrap_err();
        assert_eq!(
            err.to_string(),
            "camera fixed:5 does not exist: the scene has 5 fixed cameras (fixed:0 to fixed:4)"
        );
        let Some(lost) = shared_cameras("lost-empire-partial") else { return };
        // "starts high above the map looking down".
        let c = lost.path.camera_at(0);
        assert!(c.position.y == 60.0 && c.forward.y < -0.95);
    }

    #[test]
    fn unknown_scene_lists_the_known_ones() {
        if !Path::new(SHARED_CAMERAS).is_file() {
            eprintln!("skipped: {SHARED_CAMERAS} is absent");
            return;
        }
        let err = load_cameras_json(Path::new(SHARED_CAMERAS), "nope").unwrap_err().to_string();
        assert!(err.contains("cameras.json") && err.contains("'nope'"), "{err}");
        assert!(err.contains("lost-empire-partial, sponza-thesis"), "{err}");
    }

    #[test]
    fn camera_file_errors_name_the_file() {
        let missing = Path::new("/nonexistent/cameras.json");
        let err = load_cameras_json(missing, "x").unwrap_err().to_string();
        assert!(err.starts_with("/nonexistent/cameras.json: cannot read"), "{err}");

        let bad = temp_json("{ \"projection\": ");
        let err = load_cameras_json(bad.path(), "x").unwrap_err().to_string();
        assert!(err.starts_with(&bad.path().display().to_string()) && err.contains("not a camera file"), "{err}");

        let mismatched = temp_json(
            r#"{"projection": {"vertical_fov_deg": 60, "near": 0.3, "far": 1000}, "frames_per_segment": 10,
                "scenes": {"a": {"path": {"positions": [[0,0,0],[1,0,0]], "euler_deg": [[0,0,0]]},
                                 "fixed_cameras": {"positions": [], "euler_deg": []}}}}"#,
        );
        let err = load_cameras_json(mismatched.path(), "a").unwrap_err().to_string();
        assert!(err.contains("2 positions but 1 euler angles"), "{err}");

        let bad_proj = temp_json(
            r#"{"projection": {"vertical_fov_deg": 60, "near": 10, "far": 1}, "frames_per_segment": 10, "scenes": {}}"#,
        );
        let err = load_cameras_json(bad_proj.path(), "a").unwrap_err().to_string();
        assert!(err.contains("bad projection"), "{err}");
    }

    #[test]
    fn small_keyed_file_frames() {
        let f = temp_json(
            r#"{"projection": {"vertical_fov_deg": 90, "near": 0.1, "far": 50}, "frames_per_segment": 10,
                "scenes": {"a": {"path": {"positions": [[0,0,0],[10,0,0],[10,0,10],[0,0,10]],
                                          "euler_deg": [[0,0,0],[0,90,0],[0,180,0],[0,270,0]]},
                                 "fixed_cameras": {"positions": [[1,2,3]], "euler_deg": [[0,0,0]]}}}}"#,
        );
        let cams = load_cameras_json(f.path(), "a").unwrap();
        assert_eq!(cams.path.frame_count(), 30);
        assert!(close(cams.path.camera_at(5).position, Vec3::new(-5.0, 0.0, 0.0), 1e-6));
        assert!(close(cams.path.camera_at(25).position, Vec3::new(-5.0, 0.0, 10.0), 1e-6));
        // Yaw 45 at frame 5: forward (sin 45, 0, cos 45) mirrored.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!(close(cams.path.camera_at(5).forward, Vec3::new(-h, 0.0, h), 1e-6));
        assert_eq!(cams.path.camera_at(30).position, Vec3::new(0.0, 0.0, 10.0));
        assert_eq!(cams.fixed.len(), 1);
        assert_eq!(cams.path.camera_at(0).fov_y, 90f32.to_radians());
    }

    #[test]
    fn camera_choice_parsing() {
        assert_eq!("path".parse::<CameraChoice>(), Ok(CameraChoice::Path));
        assert_eq!("fixed:0".parse::<CameraChoice>(), Ok(CameraChoice::Fixed(0)));
        assert_eq!("fixed:3".parse::<CameraChoice>().unwrap().to_string(), "fixed:3");
        assert_eq!("gltf:2".parse::<CameraChoice>(), Ok(CameraChoice::Gltf(2)));
        assert_eq!(CameraChoice::Gltf(1).to_string(), "gltf:1");
        assert_eq!("flyover".parse::<CameraChoice>(), Ok(CameraChoice::Flyover));
        assert_eq!(CameraChoice::Flyover.to_string(), "flyover");
        for bad in ["", "fixed", "fixed:", "fixed:-1", "fixed:x", "orbit", "gltf:", "gltf:a", "fly"] {
            let err = bad.parse::<CameraChoice>().unwrap_err().to_string();
            assert!(err.contains("expected 'path', 'flyover', 'fixed:K' or 'gltf:K'"), "{bad}: {err}");
        }
    }

    /// Frames the corners of `bounds`.
    fn framer(bounds: &Aabb, aspect: f32) -> impl FnOnce() -> Option<framing::Framed> {
        let corners = bounds.corners();
        move || framing::frame(&corners, aspect)
    }

    fn courtyard() -> Aabb {
        Aabb { min: Vec3::new(-15.0, 0.0, -9.0), max: Vec3::new(15.0, 13.0, 9.0) }
    }

    fn terrain() -> Aabb {
        Aabb { min: Vec3::new(-100.0, 0.0, -80.0), max: Vec3::new(100.0, 20.0, 80.0) }
    }

    #[test]
    fn orbit_styles_and_views() {
        let inside = CameraPath::Orbit(Orbit::with_style(&courtyard(), OrbitStyle::Inside));
        assert_eq!(inside.frame_count(), 600);
        for f in (0..600).step_by(37) {
            let c = inside.camera_at(f);
            let b = courtyard();
            assert!(c.position.cmpgt(b.min).all() && c.position.cmplt(b.max).all(), "inside: {c:?}");
            assert!(c.forward.y < 0.0 && c.forward.y > -0.5, "looks across, slightly down: {c:?}");
            assert!(c.up.dot(c.forward).abs() < 1e-5 && c.up.y > 0.0);
        }
        assert_eq!(inside.camera_at(0), inside.camera_at(600), "one full turn");
        let c0 = inside.camera_at(0);
        let c300 = inside.camera_at(300);
        assert!(c0.position.x > 0.0 && c300.position.x < 0.0, "half a turn later on the other side");

        let above = CameraPath::Orbit(Orbit::with_style(&terrain(), OrbitStyle::Above));
        for f in (0..600).step_by(41) {
            let c = above.camera_at(f);
            assert!(c.position.y > terrain().max.y);
            let down = (-c.forward.y).asin().to_degrees();
            assert!((down - 30.0).abs() < 1e-3, "{down}");
            assert!(c.up.dot(c.forward).abs() < 1e-5 && c.up.y > 0.0);
        }
    }

    #[test]
    fn procedural_scenes_get_a_deterministic_orbit() {
        let a = cameras_for("atrium", &terrain(), &[], framer(&terrain(), 1.5)).unwrap();
        assert_eq!(a.source, CameraSource::Orbit(OrbitStyle::Inside), "atrium orbits inside whatever its shape");
        let v = cameras_for("voxels", &terrain(), &[], framer(&terrain(), 1.5)).unwrap();
        assert_eq!(v.source, CameraSource::Orbit(OrbitStyle::Above));
        assert_eq!(v, cameras_for("voxels", &terrain(), &[], framer(&terrain(), 1.5)).unwrap());
        assert_eq!(
            v,
            cameras_for("voxels", &terrain(), &[], framer(&terrain(), 0.5)).unwrap(),
            "the orbit ignores the aspect"
        );
        assert_eq!(v.fixed.len(), 5);
        for c in &v.fixed {
            assert!(c.forward.is_normalized() && c.up.dot(c.forward).abs() < 1e-5);
        }
        assert!(matches!(
            cameras_for("atrium", &Aabb::EMPTY, &[], framer(&Aabb::EMPTY, 1.0)),
            Err(CameraFileError::EmptyBounds)
        ));
    }

    #[test]
    fn other_scenes_are_framed_or_use_their_own_cameras() {
        let framed = cameras_for("model.glb", &courtyard(), &[], framer(&courtyard(), 1.5)).unwrap();
        assert_eq!(framed.source, CameraSource::Framed);
        let CameraPath::Turntable(t) = framed.path else { panic!("turntable expected: {:?}", framed.path) };
        let c = courtyard().center();
        assert_eq!((t.target.x, t.target.z), (c.x, c.z), "on the vertical through the centre");
        assert_eq!(framed.fixed.len(), 5);
        assert_eq!(framed.path.frame_count(), 600);
        let err = framed.select(CameraChoice::Gltf(0)).unwrap_err().to_string();
        assert_eq!(err, "camera gltf:0 does not exist: model.glb has no cameras of its own");

        let own = [Camera { position: Vec3::new(1.0, 2.0, 3.0), ..framed.fixed[0] }, framed.fixed[1]];
        let with_own = cameras_for("model.glb", &courtyard(), &own, framer(&courtyard(), 1.5)).unwrap();
        assert_eq!(with_own.source, CameraSource::Own { scene: "model.glb".into(), index: 0 });
        assert_eq!(with_own.path, CameraPath::Fixed(own[0]), "the file's first camera is the default");
        assert_eq!(with_own.fixed, framed.fixed, "fixed cameras stay the framed views");
        assert_eq!(with_own.select(CameraChoice::Gltf(1)).unwrap(), CameraPath::Fixed(own[1]));
        let err = with_own.select(CameraChoice::Gltf(2)).unwrap_err().to_string();
        assert_eq!(err, "camera gltf:2 does not exist: model.glb has 2 cameras (gltf:0 to gltf:1)");
        let one = cameras_for("a.gltf", &courtyard(), &own[..1], framer(&courtyard(), 1.5)).unwrap();
        let err = one.select(CameraChoice::Gltf(1)).unwrap_err().to_string();
        assert_eq!(err, "camera gltf:1 does not exist: a.gltf has 1 camera (gltf:0)");

        let point = Aabb { min: Vec3::ONE, max: Vec3::ONE };
        assert!(matches!(
            cameras_for("model.glb", &point, &[], framer(&point, 1.0)),
            Err(CameraFileError::EmptyBounds)
        ));
    }

    #[test]
    fn shared_scene_folders_use_cameras_json() {
        if !Path::new(SHARED_CAMERAS).is_file() {
            eprintln!("skipped: {SHARED_CAMERAS} is absent");
            return;
        }
        for spec in ["../shared/scenes/sponza-thesis", "../shared/scenes/sponza-thesis/"] {
            if !Path::new(spec).is_dir() {
                eprintln!("skipped: {spec} is absent");
                return;
            }
            let cams = cameras_for(spec, &courtyard(), &[], framer(&courtyard(), 1.0)).unwrap();
            assert_eq!(cams.source.to_string(), "../shared/scenes/cameras.json [sponza-thesis]");
            assert_eq!(cams.path.camera_at(0).position, Vec3::new(-6.0, 4.0, -0.5));
        }
    }

    #[test]
    fn files_beside_a_cameras_json() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("cameras.json"),
            r#"{"projection": {"vertical_fov_deg": 60, "near": 0.3, "far": 1000}, "frames_per_segment": 300,
                "scenes": {"box": {"path": {"positions": [[1,2,3]], "euler_deg": [[0,0,0]]},
                                   "fixed_cameras": {"positions": [], "euler_deg": []}}}}"#,
        )
        .unwrap();
        let boxed = dir.path().join("box.obj");
        let other = dir.path().join("other.obj");
        std::fs::write(&boxed, "").unwrap();
        std::fs::write(&other, "").unwrap();
        let cams = cameras_for(boxed.to_str().unwrap(), &courtyard(), &[], framer(&courtyard(), 1.0)).unwrap();
        assert!(matches!(cams.source, CameraSource::File { ref scene, .. } if scene == "box"));
        assert_eq!(cams.path.frame_count(), 1);
        assert_eq!(cams.path.camera_at(7).position, Vec3::new(-1.0, 2.0, 3.0));
        // A scene the file does not list is framed.
        let cams = cameras_for(other.to_str().unwrap(), &courtyard(), &[], framer(&courtyard(), 1.0)).unwrap();
        assert_eq!(cams.source, CameraSource::Framed);
        // A broken cameras.json beside the scene is an error naming it.
        std::fs::write(dir.path().join("cameras.json"), "[").unwrap();
        let err =
            cameras_for(other.to_str().unwrap(), &courtyard(), &[], framer(&courtyard(), 1.0)).unwrap_err().to_string();
        assert!(err.contains("cameras.json: not a camera file"), "{err}");
    }
}
