//! Which lights a scene gets: the one place the command line picks the light
//! set (from `--lights` and `--seed`) and the environment (`--env`, with its
//! environment light), for `render`, `bench` and `view`.

use shadespace::scene::environment::{EnvSpec, Environment, Sky};
use shadespace::scene::path::{CameraSource, SceneCameras};
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
    if env_spec(a, &cameras.source) != EnvSpec::None && !lights.iter().any(|l| l.kind == LightKind::Environment) {
        lights.push(shadespace::scene::lights::environment_light());
    }
    Ok((lights, spec.to_string()))
}

/// The environment `--env` names, or without it the default for the scene
/// seen through `source` ([`default_env`]).
pub fn env_spec(a: &SceneArgs, source: &CameraSource) -> EnvSpec {
    a.env.clone().unwrap_or_else(|| default_env(&a.lights, source))
}

/// The environment a scene gets without `--env`, under `--lights` `lights`:
/// the procedural sky for the outdoor scenes (the terrain's flight, the
/// city's streets) under `auto`, which would otherwise stand under a black
/// sky; none for every other scene and for an explicit light set (the
/// studies' and benchmarks' setups stay as they were).
pub fn default_env(lights: &str, source: &CameraSource) -> EnvSpec {
    let outdoors = matches!(source, CameraSource::Flight | CameraSource::Streets);
    if outdoors && lights.parse::<LightSpec>() == Ok(LightSpec::Auto) { EnvSpec::Sky } else { EnvSpec::None }
}

/// `env` lit by `lights`: the procedural sky with its sun where the set's
/// first directional light comes from (the generated sets' sun is already
/// where the sky's is; the terrain's daylight sun is lower), so that the sun
/// drawn in the background, its reflections and the shadows agree.
pub fn under_lights(env: Option<Environment>, lights: &[Light]) -> Option<Environment> {
    match (env, lights.iter().find(|l| l.kind == LightKind::Directional)) {
        (Some(Environment::Sky(sky)), Some(sun)) if sun.direction.length_squared() > 0.0 => {
            Some(Environment::Sky(Sky { sun_direction: -sun.direction.normalize(), ..sky }))
        }
        (env, _) => env,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use shadespace::scene::path::OrbitStyle;

    /// The city and the terrain get the sky under `auto` lights only; other
    /// scenes none.
    #[test]
    fn outdoor_scenes_get_the_sky_under_auto_lights() {
        for source in [CameraSource::Flight, CameraSource::Streets] {
            assert_eq!(default_env("auto", &source), EnvSpec::Sky, "{source}");
            assert_eq!(default_env("shadowed:30", &source), EnvSpec::None, "{source}");
        }
        for source in [CameraSource::Framed, CameraSource::Orbit(OrbitStyle::Inside)] {
            assert_eq!(default_env("auto", &source), EnvSpec::None, "{source}");
        }
    }

    /// The sky's sun goes where the set's directional light comes from; an
    /// image or no directional light leaves the environment as it was.
    #[test]
    fn the_sky_sun_follows_the_light_sets_sun() {
        let sky = Some(Environment::Sky(Sky::default()));
        let daylight = shadespace::scene::lights::daylight();
        let Some(Environment::Sky(moved)) = under_lights(sky.clone(), &daylight) else { panic!("a sky") };
        assert!(moved.sun_direction.dot(-daylight[1].direction) > 0.9999, "{}", moved.sun_direction);
        let ambient = [shadespace::scene::lights::default_ambient()];
        let Some(Environment::Sky(kept)) = under_lights(sky, &ambient) else { panic!("a sky") };
        assert_eq!(kept, Sky::default());
        assert!(Vec3::Y.dot(moved.sun_direction) < Vec3::Y.dot(kept.sun_direction), "daylight's sun is lower");
    }
}
