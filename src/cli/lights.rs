//! Which lights a scene gets: the one place the command line picks the light
//! set (from `--lights` and `--seed`, with `--env`'s environment light), for
//! `render`, `bench` and `view`.

use shadespace::scene::environment::EnvSpec;
use shadespace::scene::path::SceneCameras;
use shadespace::scene::{Aabb, Camera, CameraPath, Light, LightKind, LightSpec};

use super::options::SceneArgs;
use super::{Failure, input};

/// The `--lights` set of a scene of `bounds` seen through `cameras`, placed
/// for the path's first camera, and its spec as text (`auto` resolved).
pub fn light_set(
    a: &SceneArgs,
    cameras: &SceneCameras,
    bounds: &Aabb,
    path: &CameraPath,
) -> Result<(Vec<Light>, String), Failure> {
    let spec: LightSpec = input(a.lights.parse())?;
    let reference: Camera = path.camera_at(0);
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let (spec, mut lights) = input(cameras.build_lights(&spec, bounds, &reference, aspect, a.seed))?;
    // `--env` lights through a light of its own, unless a light file
    // already holds one (with its own scale).
    if a.env != EnvSpec::None && !lights.iter().any(|l| l.kind == LightKind::Environment) {
        lights.push(shadespace::scene::lights::environment_light());
    }
    Ok((lights, spec.to_string()))
}
