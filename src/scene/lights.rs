//! Lights and the seeded light-set generators of the four classic scenarios
//! (small, big, big shadowed, mixed), the three-point [`studio`] set for
//! models seen from outside and the [`daylight`] set for open landscapes,
//! parsed from `--lights SPEC`.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::path::CameraSource;
use super::{Aabb, Camera};

/// The light types of the shared lighting model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    Ambient,
    Directional,
    Point,
    Spot,
    /// The scene's prefiltered environment map (`--env`,
    /// [`super::Scene::environment`]), scaled by `color` and `intensity`:
    /// diffuse and specular image-based light, everywhere, times the
    /// surface's occlusion. Black when the scene has no environment.
    Environment,
}

impl LightKind {
    /// Whether lights of this kind reach every point (ambient, directional,
    /// environment): pipelines apply them everywhere, light grids list only
    /// the others.
    pub fn is_global(self) -> bool {
        matches!(self, Self::Ambient | Self::Directional | Self::Environment)
    }
}

/// One light. Fields a kind does not use are ignored (an ambient light uses
/// only `color` and `intensity`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    pub intensity: f32,
    /// World position (point, spot).
    #[serde(default)]
    pub position: Vec3,
    /// Unit direction the light travels (directional, spot).
    #[serde(default = "default_direction")]
    pub direction: Vec3,
    /// Range: the attenuation `1/(1+d²)` is cut off at this distance (point, spot).
    #[serde(default = "default_radius")]
    pub radius: f32,
    /// Cosine of the spot's inner cone half-angle (full intensity inside).
    #[serde(default = "default_inner")]
    pub cos_inner: f32,
    /// Cosine of the spot's outer cone half-angle (zero outside).
    #[serde(default = "default_outer")]
    pub cos_outer: f32,
    /// Whether the light casts shadows (point and spot lights: shadow maps).
    #[serde(default)]
    pub casts_shadows: bool,
}

impl Light {
    /// A white point light of intensity 1 at `position` reaching `radius`
    /// (the other fields at their file defaults), for tests and examples.
    pub fn point(position: Vec3, radius: f32) -> Self {
        Light {
            kind: LightKind::Point,
            color: Vec3::ONE,
            intensity: 1.0,
            position,
            direction: default_direction(),
            radius,
            cos_inner: default_inner(),
            cos_outer: default_outer(),
            casts_shadows: false,
        }
    }
}

fn default_direction() -> Vec3 {
    Vec3::NEG_Y
}
fn default_radius() -> f32 {
    10.0
}
fn default_inner() -> f32 {
    0.95
}
fn default_outer() -> f32 {
    0.85
}

// ---------------------------------------------------------------------------
// Light-set specs and seeded generators
// ---------------------------------------------------------------------------

/// Most lights one spec may ask for in all (a typo like `small:10000000`
/// should fail at parse time, not exhaust memory).
pub const MAX_GENERATED_LIGHTS: u64 = 1_000_000;

/// Screen coverage range of one small light (fraction of the screen).
pub const SMALL_COVERAGE: (f32, f32) = (0.0025, 0.05);
/// Screen coverage range of one big light (fraction of the screen).
pub const BIG_COVERAGE: (f32, f32) = (0.20, 1.0);
/// Smallest generated light radius, metres, in scenes of at least
/// [`FULL_SIZE_DIAGONAL`] (see [`length_scale`]).
pub const MIN_LIGHT_RADIUS: f32 = 0.01;
/// Scenes whose bounds' diagonal is at least this long (metres) are placed
/// in with the generators' lengths as they are (lights floating at least
/// 0.5 m above the floor, radii from 0.01 m to at least 1 m); smaller scenes
/// scale those lengths down with their size ([`length_scale`]). The atrium,
/// the voxel world and Sponza are 30-360 m across, so their light sets stay
/// what the goldens and the published benchmarks were made with.
pub const FULL_SIZE_DIAGONAL: f32 = 10.0;

/// The factor the generators' fixed lengths (the floor gap, the smallest
/// and the largest radius) take in a scene of bounds `bounds`: its diagonal
/// over [`FULL_SIZE_DIAGONAL`], at most 1. Without it a 5 cm model had every
/// light 0.5 m above it, out of reach.
pub fn length_scale(bounds: &Aabb) -> f32 {
    (bounds.extent().length() / FULL_SIZE_DIAGONAL).min(1.0)
}

/// One `+`-separated part of a generated light spec.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightPart {
    /// `small:N`: N small point lights.
    Small(u32),
    /// `big:N`: N big lights without shadows.
    Big(u32),
    /// `shadowed:N`: N big lights with `casts_shadows = true`.
    Shadowed(u32),
    /// `mixed:N:R`: N big shadowed lights plus R small lights per big light.
    Mixed { big: u32, small_per_big: u32 },
}

impl LightPart {
    /// Number of lights this part generates.
    pub fn count(&self) -> u64 {
        match *self {
            LightPart::Small(n) | LightPart::Big(n) | LightPart::Shadowed(n) => n as u64,
            LightPart::Mixed { big, small_per_big } => big as u64 * (1 + small_per_big as u64),
        }
    }
}

impl fmt::Display for LightPart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LightPart::Small(n) => write!(f, "small:{n}"),
            LightPart::Big(n) => write!(f, "big:{n}"),
            LightPart::Shadowed(n) => write!(f, "shadowed:{n}"),
            LightPart::Mixed { big, small_per_big } => write!(f, "mixed:{big}:{small_per_big}"),
        }
    }
}

/// What `--lights SPEC` asks for.
///
/// Grammar: `auto` | `studio` | `daylight` | `none` | `PART(+PART)*` | a path to a JSON
/// light file, where PART is `small:N`, `big:N`, `shadowed:N` or
/// `mixed:N:R`. A spec that ends in `.json`, or names an existing file, is a
/// light file; anything else is parsed as parts. `Display` gives the
/// canonical form (`small:100+shadowed:2`), which parses back to the same spec.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LightSpec {
    /// The default for how the scene is seen, chosen by [`LightSpec::resolve`]:
    /// [`LightSpec::Studio`] for a model seen from outside,
    /// [`LightSpec::Daylight`] for a landscape flown over, `small:32` for a
    /// scene the cameras move through.
    Auto,
    /// Three-point studio lighting around the model ([`studio`]).
    Studio,
    /// Sun and sky for an open landscape ([`daylight`]).
    Daylight,
    /// Only the fixed ambient and directional lights.
    None,
    /// Fixed ambient + directional lights plus the generated parts, in order.
    Generated(Vec<LightPart>),
    /// A JSON light file: an array of [`Light`] or `{"lights": [...]}`. Its
    /// lights are the whole set, used as given (no ambient/directional added).
    File(PathBuf),
}

impl LightSpec {
    /// Number of generated lights (not counting the fixed ambient and
    /// directional ones); `None` for a light file, `studio`, `daylight` and `auto`.
    pub fn generated_count(&self) -> Option<u64> {
        match self {
            LightSpec::None => Some(0),
            LightSpec::Generated(parts) => Some(parts.iter().map(LightPart::count).sum()),
            LightSpec::File(_) | LightSpec::Studio | LightSpec::Daylight | LightSpec::Auto => None,
        }
    }

    /// The set a scene the cameras move through gets by default (the
    /// generated scenes, the shared ones): `small:32`, 32 coloured point lights.
    pub fn scene_default() -> LightSpec {
        LightSpec::Generated(vec![LightPart::Small(32)])
    }

    /// This spec with `auto` replaced by the default for how the scene is
    /// seen through `source`: `studio` for a model seen from outside (framed
    /// automatically, or through its file's own camera:
    /// [`CameraSource::seen_from_outside`]), `daylight` for the terrain's
    /// flight, [`LightSpec::scene_default`] otherwise. Other specs are
    /// returned as they are.
    pub fn resolve(&self, source: &CameraSource) -> LightSpec {
        match (self, source) {
            (LightSpec::Auto, s) if s.seen_from_outside() => LightSpec::Studio,
            (LightSpec::Auto, CameraSource::Flight) => LightSpec::Daylight,
            (LightSpec::Auto, _) => LightSpec::scene_default(),
            (other, _) => other.clone(),
        }
    }
}

impl fmt::Display for LightSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LightSpec::Auto => f.write_str("auto"),
            LightSpec::Studio => f.write_str("studio"),
            LightSpec::Daylight => f.write_str("daylight"),
            LightSpec::None => f.write_str("none"),
            LightSpec::Generated(parts) => {
                for (i, p) in parts.iter().enumerate() {
                    if i > 0 {
                        f.write_str("+")?;
                    }
                    write!(f, "{p}")?;
                }
                Ok(())
            }
            LightSpec::File(path) => write!(f, "{}", path.display()),
        }
    }
}

/// Why a `--lights` spec does not parse. Every message quotes the offending text.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LightSpecError {
    /// Nothing was given.
    #[error(
        "empty light spec (expected auto, studio, small:N, big:N, shadowed:N, mixed:N:R, none, or a .json light file)"
    )]
    Empty,
    #[error(
        "\"{part}\": unknown light kind '{kind}' (expected auto, studio, small:N, big:N, shadowed:N, mixed:N:R, none, or a .json light file)"
    )]
    /// A part names no known kind (and the spec is no `.json` file).
    UnknownKind { part: String, kind: String },
    #[error("\"{part}\": expected {expected}")]
    /// A part has the wrong number of `:` fields.
    Form { part: String, expected: &'static str },
    #[error("\"{part}\": {what} '{value}' is not a number")]
    /// A count is not a non-negative integer.
    NotANumber { part: String, what: &'static str, value: String },
    #[error("\"{part}\": {what} '{value}' is too large")]
    /// A count does not fit in 32 bits.
    TooLarge { part: String, what: &'static str, value: String },
    #[error("\"{spec}\": {count} lights in all is more than the limit of {MAX_GENERATED_LIGHTS}")]
    /// The parts add up to more than [`MAX_GENERATED_LIGHTS`].
    TooMany { spec: String, count: u64 },
    #[error("\"{spec}\": '{word}' cannot be combined with other parts")]
    /// `none`, `auto` or `studio` joined with other parts.
    Combined { spec: String, word: &'static str },
}

impl FromStr for LightSpec {
    type Err = LightSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let spec = s.trim();
        if spec.is_empty() {
            return Err(LightSpecError::Empty);
        }
        let words = [
            ("none", LightSpec::None),
            ("auto", LightSpec::Auto),
            ("studio", LightSpec::Studio),
            ("daylight", LightSpec::Daylight),
        ];
        for (word, whole) in words {
            if spec.eq_ignore_ascii_case(word) {
                return Ok(whole);
            }
        }
        // A file wins over parts: `x.json` is checked when the set is built,
        // so that a missing file is reported by name rather than as a bad kind.
        if spec.to_ascii_lowercase().ends_with(".json") || Path::new(spec).is_file() {
            return Ok(LightSpec::File(PathBuf::from(spec)));
        }
        let mut parts = Vec::new();
        for part in spec.split('+') {
            let part = part.trim();
            if let Some(word) =
                ["none", "auto", "studio", "daylight"].into_iter().find(|w| part.eq_ignore_ascii_case(w))
            {
                return Err(LightSpecError::Combined { spec: spec.into(), word });
            }
            parts.push(parse_part(part)?);
        }
        let count: u64 = parts.iter().map(LightPart::count).sum();
        if count > MAX_GENERATED_LIGHTS {
            return Err(LightSpecError::TooMany { spec: spec.into(), count });
        }
        Ok(LightSpec::Generated(parts))
    }
}

fn parse_part(part: &str) -> Result<LightPart, LightSpecError> {
    let fields: Vec<&str> = part.split(':').map(str::trim).collect();
    let kind = fields[0].to_ascii_lowercase();
    let number = |value: &str, what: &'static str| -> Result<u32, LightSpecError> {
        let not_a_number = || LightSpecError::NotANumber { part: part.into(), what, value: value.into() };
        if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
            return Err(not_a_number());
        }
        value.parse::<u32>().map_err(|_| LightSpecError::TooLarge { part: part.into(), what, value: value.into() })
    };
    let form = |expected| LightSpecError::Form { part: part.into(), expected };
    match kind.as_str() {
        "small" | "big" | "shadowed" => {
            let expected = match kind.as_str() {
                "small" => "small:N",
                "big" => "big:N",
                _ => "shadowed:N",
            };
            let [_, n] = fields[..] else { return Err(form(expected)) };
            let n = number(n, "light count")?;
            Ok(match kind.as_str() {
                "small" => LightPart::Small(n),
                "big" => LightPart::Big(n),
                _ => LightPart::Shadowed(n),
            })
        }
        "mixed" => {
            let [_, n, r] = fields[..] else {
                return Err(form("mixed:N:R (N big shadowed lights, R small lights per big light)"));
            };
            let big = number(n, "big light count")?;
            let small_per_big = number(r, "small lights per big light")?;
            Ok(LightPart::Mixed { big, small_per_big })
        }
        _ => Err(LightSpecError::UnknownKind { part: part.into(), kind: fields[0].into() }),
    }
}

/// Why a light set cannot be built. File errors name the file.
#[derive(Debug, thiserror::Error)]
pub enum LightSetError {
    /// The light file cannot be read.
    #[error("{path}: cannot read light file: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a light file (expected an array of lights or {{\"lights\": [...]}}): {message}")]
    /// The light file is not valid JSON of the expected shape.
    Json { path: PathBuf, message: String },
    /// A light in the file has an impossible value.
    #[error("{path}: light {index}: {problem}")]
    InvalidLight { path: PathBuf, index: usize, problem: String },
    /// Generated lights need a non-empty, finite box to be placed in.
    #[error("cannot place generated lights: the scene bounds are empty or not finite")]
    EmptyBounds,
    /// `auto` depends on how the scene is seen: [`LightSpec::resolve`] it
    /// first (as [`super::path::SceneCameras::build_lights`] does).
    #[error("light spec 'auto' depends on how the scene is seen: resolve it with the scene's cameras first")]
    Unresolved,
}

/// The light that adds the scene's environment map (`--env`) at its own
/// radiance.
pub fn environment_light() -> Light {
    Light { kind: LightKind::Environment, color: Vec3::ONE, intensity: 1.0, ..default_ambient() }
}

/// The fixed ambient light of every generated set: a dim, cool sky fill.
pub fn default_ambient() -> Light {
    Light {
        kind: LightKind::Ambient,
        color: Vec3::new(0.6, 0.7, 1.0),
        intensity: 0.05,
        position: Vec3::ZERO,
        direction: default_direction(),
        radius: default_radius(),
        cos_inner: default_inner(),
        cos_outer: default_outer(),
        casts_shadows: false,
    }
}

/// The fixed directional light of every generated set: a warm sun from above
/// at about 60 degrees elevation, at modest intensity (0.3) so that point
/// lights stay visible. It casts no shadows, so that the scenarios' shadow cost
/// is that of their own lights.
pub fn default_sun() -> Light {
    Light {
        kind: LightKind::Directional,
        color: Vec3::new(1.0, 0.9, 0.75),
        intensity: 0.3,
        direction: Vec3::new(0.35, -1.0, 0.25).normalize(),
        ..default_ambient()
    }
}

/// Sun and sky for an open landscape (the terrain's default, `--lights
/// daylight`): a white-warm sun at about 40 degrees elevation and a pale blue
/// sky ambient, scaled so that a sunlit field of albedo 0.5 sits near the
/// middle of the default exposure's range and shaded slopes stay readable.
/// Two lights of no position: the same on a 2 km terrain as on a 2 m model.
/// The sun's shadows are the renderers' `sun_shadow` option, as for every set.
pub fn daylight() -> [Light; 2] {
    let sky = Light { color: Vec3::new(0.55, 0.7, 1.0), intensity: 0.35, ..default_ambient() };
    let sun = Light {
        color: Vec3::new(1.0, 0.93, 0.82),
        intensity: 2.2,
        direction: Vec3::new(0.55, -0.65, 0.52).normalize(),
        ..default_sun()
    };
    [sky, sun]
}

/// The box to place the generated lights of an object seen from outside in
/// (a model framed automatically, not an enclosing scene like the atrium):
/// its bounds grown by a quarter of their extent sideways and upwards, not below
/// its bottom. Inside its own bounds many lights sit inside a solid model and
/// light nothing; around it they light it from every side (farther out, as
/// with half the extent, fewer reach it).
pub fn region_around(bounds: &Aabb) -> Aabb {
    let grow = 0.25 * bounds.extent();
    Aabb { min: bounds.min - grow.with_y(0.0), max: bounds.max + grow }
}

/// Share of the key light's intensity the fill light brings to the model's centre.
pub const STUDIO_FILL: f32 = 0.4;
/// Share of the key light's intensity the rim light brings to the model's centre.
pub const STUDIO_RIM: f32 = 0.7;
/// The studio set's ambient light, as a share of the key light at the
/// model's centre: enough that faces the key and fill miss are not black.
pub const STUDIO_AMBIENT: f32 = 0.08;
/// Distance of the studio lights from the model's centre, in radii of its
/// bounding sphere: far enough that the light falls evenly across the
/// model, near enough that the key's spot cone stays narrow (19 degrees)
/// and its shadow map sharp.
pub const STUDIO_DISTANCE: f32 = 3.0;

/// Three-point studio lighting for a model of bounds `model` seen from
/// `camera`: neutral white lights placed relative to the view, all aimed at
/// the centre of the bounds and scaled with them, so that a 5 cm model and a
/// 200 m one are lit alike.
///
/// Seen from above with the camera at the bottom, the model's bounding
/// sphere of radius R, each light [`STUDIO_DISTANCE`] R from its centre:
/// - the key: a spot light that casts shadows, 45 degrees to the camera's
///   left and 40 degrees up, its cone just holding the sphere (intensity 1
///   at the centre);
/// - the fill: a point light 60 degrees to the camera's right and 15 degrees
///   up, [`STUDIO_FILL`] of the key;
/// - the rim: a point light behind the model, 150 degrees to the camera's
///   left and 50 degrees up, [`STUDIO_RIM`] of the key, outlining the
///   silhouette against the black background;
/// - a white ambient light, [`STUDIO_AMBIENT`] of the key.
///
/// Intensities are set where the lights meet the model's centre: the shared
/// attenuation `1/(1+d²)` is in absolute units, so each light's intensity is
/// its share times `1 + d²`. There is no directional light (no sun). The
/// views are horizontal: a camera looking straight down takes its own up
/// vector as its facing. Fails when the bounds are empty, not finite or a point.
pub fn studio(model: &Aabb, camera: &Camera) -> Result<Vec<Light>, LightSetError> {
    if model.is_empty() || !model.min.is_finite() || !model.max.is_finite() {
        return Err(LightSetError::EmptyBounds);
    }
    let centre = model.center();
    let radius = 0.5 * model.extent().length();
    if radius <= 0.0 || !radius.is_finite() {
        return Err(LightSetError::EmptyBounds);
    }
    // The camera's facing on the ground plane (from the camera to the model).
    let towards = (centre - camera.position).with_y(0.0);
    let facing = towards
        .try_normalize()
        .or_else(|| camera.forward.with_y(0.0).try_normalize())
        .or_else(|| camera.up.with_y(0.0).try_normalize())
        .unwrap_or(Vec3::NEG_Z);
    let right = facing.cross(Vec3::Y);
    let distance = STUDIO_DISTANCE * radius;
    // A point `azimuth` degrees from the camera's side of the model (positive
    // to the camera's left) and `elevation` degrees up, `distance` from the centre.
    let place = |azimuth: f32, elevation: f32| {
        let (a, e) = (azimuth.to_radians(), elevation.to_radians());
        let horizontal = -facing * a.cos() - right * a.sin();
        centre + distance * (horizontal * e.cos() + Vec3::Y * e.sin())
    };
    // Light reaching the centre with `share` of the key's strength; its range
    // reaches past the far side of the sphere.
    let light = |kind: LightKind, position: Vec3, share: f32| Light {
        kind,
        color: Vec3::ONE,
        intensity: share * (1.0 + distance * distance),
        position,
        direction: (centre - position).normalize(),
        radius: 1.25 * (distance + radius),
        casts_shadows: false,
        ..default_ambient()
    };
    // The key's cone holds the bounding sphere inside its full-intensity
    // core; the fade to the outer edge falls beyond it.
    let core = (radius / distance).asin() * 1.05;
    let key = Light {
        cos_inner: core.cos(),
        cos_outer: (core + 8f32.to_radians()).cos(),
        casts_shadows: true,
        ..light(LightKind::Spot, place(45.0, 40.0), 1.0)
    };
    let ambient = Light { color: Vec3::ONE, intensity: STUDIO_AMBIENT, ..default_ambient() };
    Ok(vec![
        ambient,
        key,
        light(LightKind::Point, place(-60.0, 15.0), STUDIO_FILL),
        light(LightKind::Point, place(150.0, 50.0), STUDIO_RIM),
    ])
}

/// Radius that makes a sphere at distance `distance` from a camera with
/// vertical field of view `fov_y` cover the fraction `coverage` of a screen
/// of aspect `aspect` (width / height).
///
/// The sphere projects to a disc of NDC radius `ρ = r / (D·tan(fov/2))` in y
/// (the small-sphere approximation) and `ρ / aspect` in x, so its area is
/// `π ρ² / aspect` of the screen's 4 NDC units: `c = π (r / (D tan(fov/2)))² / (4 aspect)`,
/// hence `r = D tan(fov/2) sqrt(4 aspect c / π)`.
pub fn radius_for_coverage(coverage: f32, distance: f32, fov_y: f32, aspect: f32) -> f32 {
    distance * (0.5 * fov_y).tan() * (4.0 * aspect * coverage / std::f32::consts::PI).sqrt()
}

/// The inverse of [`radius_for_coverage`]: screen fraction covered by a sphere
/// of radius `radius` at distance `distance`.
pub fn coverage_of_sphere(radius: f32, distance: f32, fov_y: f32, aspect: f32) -> f32 {
    let rho = radius / (distance * (0.5 * fov_y).tan());
    std::f32::consts::PI * rho * rho / (4.0 * aspect)
}

/// Intensity of a generated light of radius `r`, before the per-part scale:
/// `0.5 + 0.25 r²`. With the shared attenuation `1/(1+d²)` this keeps the lit
/// value at least 0.5 at half the radius and about 0.25 at the cut-off, so that
/// every light visibly lights its whole sphere.
pub fn base_intensity(radius: f32) -> f32 {
    0.5 + 0.25 * radius * radius
}

/// Intensity scale of the lights of one part of `count` lights whose coverage
/// is drawn log-uniformly from `range`: `min(1, 2 / (count · mean coverage))`.
///
/// `count · mean coverage` is the expected number of that part's lights over
/// a pixel; the scale keeps their sum at about two full-strength lights, so
/// that 100 big lights (about 50 over each pixel) do not just saturate. For big
/// lights this is about `min(1, 4 / N)`, for small ones `min(1, 126 / N)`. The
/// scale depends only on the part itself, so adding `+` parts leaves earlier
/// parts unchanged.
pub fn part_intensity_scale(count: u32, range: (f32, f32)) -> f32 {
    let mean = log_uniform_mean(range);
    if count == 0 { 1.0 } else { (2.0 / (count as f32 * mean)).min(1.0) }
}

fn log_uniform_mean((lo, hi): (f32, f32)) -> f32 {
    (hi - lo) / (hi / lo).ln()
}

/// Builds the light set of `spec` for a scene with bounds `bounds`.
///
/// `studio` is [`studio`]`(bounds, reference)`; `auto` must be resolved
/// first ([`LightSpec::resolve`]). A generated set is `[ambient, directional, part 0's lights, part 1's lights, ...]`
/// ([`default_ambient`], [`default_sun`]); a light file's lights are returned
/// as given (after validation, with directions normalised).
///
/// Placement: each light's position is uniform in `bounds` shrunk by 5% of its
/// extent on every side, with the bottom raised by 10% of the height (at least
/// 0.5 m times [`length_scale`]) so that lights float above the floor. Part k draws from
/// `ChaCha8Rng::seed_from_u64(seed)` on its own stream (2k for a part's main
/// lights, 2k+1 for the small lights of `mixed`), and every light draws a fixed
/// sequence, so the same seed gives the same lights, adding `+` parts changes
/// no earlier part, and `small:10` is a prefix of `small:20`.
///
/// Size: a light's coverage c is drawn log-uniformly from [`SMALL_COVERAGE`]
/// (0.25-5% of the screen) or [`BIG_COVERAGE`] (20-100%), and its radius is the
/// one that covers c of the `reference` camera's screen at the light's distance
/// D from it ([`radius_for_coverage`] with the camera's `fov_y` and `aspect`;
/// D at least the near plane), clamped to at least [`MIN_LIGHT_RADIUS`] and at
/// most the scene's diagonal (at least 1 m), both lengths times [`length_scale`].
///
/// Kinds: small lights are point lights. In `big`, `shadowed` and the big
/// lights of `mixed`, light i is a spot when `i % 4 == 1` (a quarter of them,
/// and already one in `shadowed:2`) so that spot code paths are exercised:
/// pointing down, tilted up to about 30 degrees, outer half-angle 25-45 degrees,
/// inner 80% of it. `shadowed` and `mixed`'s big lights cast shadows.
///
/// Colour: a random hue at saturation 0.6-1, value 1. Intensity:
/// [`base_intensity`]`(r)` times [`part_intensity_scale`] of its part.
pub fn build_lights(
    spec: &LightSpec,
    bounds: &Aabb,
    reference: &Camera,
    aspect: f32,
    seed: u64,
) -> Result<Vec<Light>, LightSetError> {
    let parts = match spec {
        LightSpec::File(path) => return load_light_file(path),
        LightSpec::Studio => return studio(bounds, reference),
        LightSpec::Daylight => return Ok(daylight().to_vec()),
        LightSpec::Auto => return Err(LightSetError::Unresolved),
        LightSpec::None => &[][..],
        LightSpec::Generated(parts) => &parts[..],
    };
    let mut lights = vec![default_ambient(), default_sun()];
    if parts.iter().all(|p| p.count() == 0) {
        return Ok(lights);
    }
    if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return Err(LightSetError::EmptyBounds);
    }
    let placer = Placer::new(bounds, reference, aspect);
    for (k, part) in parts.iter().enumerate() {
        let stream = 2 * k as u64;
        match *part {
            LightPart::Small(n) => placer.generate(&mut lights, seed, stream, n, Size::Small, false),
            LightPart::Big(n) => placer.generate(&mut lights, seed, stream, n, Size::Big, false),
            LightPart::Shadowed(n) => placer.generate(&mut lights, seed, stream, n, Size::Big, true),
            LightPart::Mixed { big, small_per_big } => {
                placer.generate(&mut lights, seed, stream, big, Size::Big, true);
                placer.generate(&mut lights, seed, stream + 1, big * small_per_big, Size::Small, false);
            }
        }
    }
    Ok(lights)
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Size {
    Small,
    Big,
}

/// What every generated light of one build shares.
struct Placer {
    lo: Vec3,
    hi: Vec3,
    min_radius: f32,
    max_radius: f32,
    eye: Vec3,
    near: f32,
    fov_y: f32,
    aspect: f32,
}

impl Placer {
    fn new(bounds: &Aabb, reference: &Camera, aspect: f32) -> Self {
        let ext = bounds.extent();
        let scale = length_scale(bounds);
        let mut lo = bounds.min + 0.05 * ext;
        let mut hi = bounds.max - 0.05 * ext;
        lo.y = bounds.min.y + (0.1 * ext.y).max(0.5 * scale);
        hi.y = hi.y.max(lo.y);
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
        Self {
            lo,
            hi,
            min_radius: MIN_LIGHT_RADIUS * scale,
            max_radius: ext.length().max(scale),
            eye: reference.position,
            near: reference.near.max(1e-3 * scale),
            fov_y: reference.fov_y,
            aspect,
        }
    }

    fn generate(&self, out: &mut Vec<Light>, seed: u64, stream: u64, count: u32, size: Size, shadows: bool) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        let range = if size == Size::Small { SMALL_COVERAGE } else { BIG_COVERAGE };
        let scale = part_intensity_scale(count, range);
        out.reserve(count as usize);
        for i in 0..count {
            let t = Vec3::new(rng.random(), rng.random(), rng.random());
            let position = self.lo + t * (self.hi - self.lo);
            let u: f32 = rng.random();
            let coverage = range.0 * (range.1 / range.0).powf(u);
            let distance = position.distance(self.eye).max(self.near);
            let radius = radius_for_coverage(coverage, distance, self.fov_y, self.aspect)
                .clamp(self.min_radius, self.max_radius);
            let color = hsv_to_rgb(rng.random(), 0.6 + 0.4 * rng.random::<f32>(), 1.0);
            let mut light = Light {
                kind: LightKind::Point,
                color,
                intensity: base_intensity(radius) * scale,
                position,
                casts_shadows: shadows,
                radius,
                ..default_ambient()
            };
            if size == Size::Big && i % 4 == 1 {
                let tilt = 0.58; // tan(30°): the most a spot leans off straight down
                let (tx, tz): (f32, f32) = (rng.random(), rng.random());
                light.kind = LightKind::Spot;
                light.direction = Vec3::new(tilt * (2.0 * tx - 1.0), -1.0, tilt * (2.0 * tz - 1.0)).normalize();
                let outer = (25.0 + 20.0 * rng.random::<f32>()).to_radians();
                light.cos_outer = outer.cos();
                light.cos_inner = (0.8 * outer).cos();
            }
            out.push(light);
        }
    }
}

/// HSV (all in [0, 1]) to linear RGB.
fn hsv_to_rgb(h: f32, s: f32, v: f32) -> Vec3 {
    let h6 = (h.fract() * 6.0).min(5.999);
    let f = h6.fract();
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match h6 as u32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// Loads a JSON light file: an array of [`Light`] or `{"lights": [...]}`.
/// Lights are checked (finite values, non-negative intensity, positive radius
/// for point and spot lights, `cos_outer <= cos_inner`) and directions normalised.
pub fn load_light_file(path: &Path) -> Result<Vec<Light>, LightSetError> {
    #[derive(Deserialize)]
    struct LightFile {
        lights: Vec<Light>,
    }
    let text = std::fs::read_to_string(path).map_err(|source| LightSetError::Io { path: path.into(), source })?;
    let json_error = |e: serde_json::Error| LightSetError::Json { path: path.into(), message: e.to_string() };
    let mut lights: Vec<Light> = if text.trim_start().starts_with('[') {
        serde_json::from_str(&text).map_err(json_error)?
    } else {
        serde_json::from_str::<LightFile>(&text).map_err(json_error)?.lights
    };
    for (index, l) in lights.iter_mut().enumerate() {
        let invalid = |problem: String| LightSetError::InvalidLight { path: path.into(), index, problem };
        let finite = l.color.is_finite()
            && l.intensity.is_finite()
            && l.position.is_finite()
            && l.direction.is_finite()
            && l.radius.is_finite()
            && l.cos_inner.is_finite()
            && l.cos_outer.is_finite();
        if !finite {
            return Err(invalid("a value is not finite".into()));
        }
        if l.intensity < 0.0 || l.color.min_element() < 0.0 {
            return Err(invalid("negative colour or intensity".into()));
        }
        if matches!(l.kind, LightKind::Point | LightKind::Spot) && l.radius <= 0.0 {
            return Err(invalid(format!("radius {} is not positive", l.radius)));
        }
        if matches!(l.kind, LightKind::Directional | LightKind::Spot) {
            l.direction = l.direction.try_normalize().ok_or_else(|| invalid("direction is zero".into()))?;
        }
        if l.kind == LightKind::Spot && l.cos_outer > l.cos_inner {
            return Err(invalid(format!(
                "cos_outer {} is greater than cos_inner {} (the outer cone must be the wider one)",
                l.cos_outer, l.cos_inner
            )));
        }
    }
    Ok(lights)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bounds() -> Aabb {
        Aabb { min: Vec3::new(-15.0, 0.0, -9.0), max: Vec3::new(15.0, 13.0, 9.0) }
    }

    fn reference() -> Camera {
        Camera {
            position: Vec3::new(-12.0, 4.0, 0.0),
            forward: Vec3::X,
            up: Vec3::Y,
            fov_y: 60f32.to_radians(),
            near: 0.3,
            far: 1000.0,
        }
    }

    fn build(spec: &str, seed: u64) -> Vec<Light> {
        build_lights(&spec.parse().unwrap(), &bounds(), &reference(), 16.0 / 9.0, seed).unwrap()
    }

    fn parse_err(spec: &str) -> String {
        spec.parse::<LightSpec>().unwrap_err().to_string()
    }

    #[test]
    fn parses_every_form() {
        use LightPart::*;
        assert_eq!("none".parse(), Ok(LightSpec::None));
        assert_eq!("small:100".parse(), Ok(LightSpec::Generated(vec![Small(100)])));
        assert_eq!("big:7".parse(), Ok(LightSpec::Generated(vec![Big(7)])));
        assert_eq!("shadowed:2".parse(), Ok(LightSpec::Generated(vec![Shadowed(2)])));
        assert_eq!("mixed:2:5".parse(), Ok(LightSpec::Generated(vec![Mixed { big: 2, small_per_big: 5 }])));
        assert_eq!(" small:100 + shadowed:2 ".parse(), Ok(LightSpec::Generated(vec![Small(100), Shadowed(2)])));
        assert_eq!("lights/set.json".parse(), Ok(LightSpec::File("lights/set.json".into())));
        for canonical in ["none", "small:100+shadowed:2", "mixed:2:10", "big:0", "small:1+big:2+shadowed:3+mixed:4:5"] {
            let spec: LightSpec = canonical.parse().unwrap();
            assert_eq!(spec.to_string(), canonical);
            assert_eq!(spec.to_string().parse::<LightSpec>().unwrap(), spec);
        }
        assert_eq!("SMALL:3".parse::<LightSpec>().unwrap().to_string(), "small:3");
        assert_eq!("mixed:2:5+small:3".parse::<LightSpec>().unwrap().generated_count(), Some(15));
    }

    #[test]
    fn parse_errors_say_what_is_wrong() {
        assert_eq!(parse_err("small:x"), "\"small:x\": light count 'x' is not a number");
        assert_eq!(parse_err("small:-3"), "\"small:-3\": light count '-3' is not a number");
        assert_eq!(parse_err("small:"), "\"small:\": light count '' is not a number");
        assert_eq!(parse_err("small"), "\"small\": expected small:N");
        assert_eq!(parse_err("big:1:2"), "\"big:1:2\": expected big:N");
        assert!(parse_err("mixed:2").starts_with("\"mixed:2\": expected mixed:N:R"));
        assert_eq!(parse_err("mixed:2:y"), "\"mixed:2:y\": small lights per big light 'y' is not a number");
        assert!(parse_err("tiny:3").starts_with("\"tiny:3\": unknown light kind 'tiny'"));
        assert!(parse_err("small:3+").starts_with("\"\": unknown light kind ''"));
        assert!(parse_err("").starts_with("empty light spec"));
        assert_eq!(parse_err("none+small:3"), "\"none+small:3\": 'none' cannot be combined with other parts");
        assert_eq!(parse_err("small:99999999999"), "\"small:99999999999\": light count '99999999999' is too large");
        assert!(parse_err("mixed:1000:1000").contains("1001000 lights in all is more than the limit"));
    }

    #[test]
    fn counts_and_kinds() {
        let set = build("mixed:2:5", 1);
        assert_eq!(set.len(), 2 + 2 + 10);
        assert_eq!(set[0].kind, LightKind::Ambient);
        assert_eq!(set[1].kind, LightKind::Directional);
        assert_eq!(set.iter().filter(|l| l.kind == LightKind::Ambient).count(), 1);
        assert_eq!(set.iter().filter(|l| l.kind == LightKind::Directional).count(), 1);
        assert!(set[2..4].iter().all(|l| l.casts_shadows));
        assert_eq!(set[3].kind, LightKind::Spot, "light 1 of a big part is a spot");
        assert!(set[4..].iter().all(|l| !l.casts_shadows && l.kind == LightKind::Point));

        assert_eq!(build("none", 1).len(), 2);
        let big = build("big:100", 3);
        assert_eq!(big.iter().filter(|l| l.kind == LightKind::Spot).count(), 25);
        assert!(big.iter().all(|l| !l.casts_shadows));
        assert!(build("shadowed:2", 3)[2..].iter().all(|l| l.casts_shadows));
        assert_eq!(build("small:100+shadowed:2", 3).len(), 104);
    }

    #[test]
    fn generated_lights_are_sane() {
        let set = build("small:200+big:40", 9);
        let b = bounds();
        for l in &set[2..] {
            assert!(l.position.cmpge(b.min).all() && l.position.cmple(b.max).all(), "{l:?}");
            assert!(l.position.y >= b.min.y + 1.3 - 1e-4, "above the floor: {l:?}");
            assert!(l.radius >= MIN_LIGHT_RADIUS && l.radius <= b.extent().length());
            assert!(l.intensity > 0.0 && l.color.max_element() <= 1.0 + 1e-6 && l.color.min_element() >= 0.0);
            assert!((l.color.max_element() - 1.0).abs() < 1e-5, "value 1");
            if l.kind == LightKind::Spot {
                assert!(l.direction.is_normalized() && l.direction.y < -0.8, "downward-ish: {l:?}");
                assert!(l.cos_outer < l.cos_inner && l.cos_outer > 0.7);
            }
        }
    }

    #[test]
    fn same_seed_same_lights_other_seed_other_lights() {
        assert_eq!(build("mixed:3:4+small:50", 42), build("mixed:3:4+small:50", 42));
        assert_ne!(build("small:50", 42), build("small:50", 43));
    }

    #[test]
    fn adding_parts_keeps_earlier_parts() {
        let a = build("small:30", 5);
        let ab = build("small:30+shadowed:4", 5);
        let abc = build("small:30+shadowed:4+mixed:2:3", 5);
        assert_eq!(a[..], ab[..a.len()]);
        assert_eq!(ab[..], abc[..ab.len()]);
        // A longer part starts with the shorter one's lights (same positions and sizes).
        let short = build("big:4", 5);
        let long = build("big:40", 5);
        for (s, l) in short[2..].iter().zip(&long[2..]) {
            assert_eq!((s.position, s.radius, s.kind, s.color), (l.position, l.radius, l.kind, l.color));
        }
        // The same part at another place of the spec is a different set.
        let moved = build("shadowed:4+small:30", 5);
        assert_ne!(moved[2].position, ab[32].position);
    }

    #[test]
    fn coverage_is_within_range() {
        let cam = reference();
        let aspect = 16.0 / 9.0;
        for (spec, (lo, hi)) in [("small:300", SMALL_COVERAGE), ("big:300", BIG_COVERAGE)] {
            let set = build(spec, 11);
            let mut unclamped = 0;
            for l in &set[2..] {
                let d = l.position.distance(cam.position).max(cam.near);
                let c = coverage_of_sphere(l.radius, d, cam.fov_y, aspect);
                let clamped = l.radius == MIN_LIGHT_RADIUS || l.radius == bounds().extent().length();
                if !clamped {
                    unclamped += 1;
                    assert!(c >= lo * 0.999 && c <= hi * 1.001, "{spec}: coverage {c} out of [{lo}, {hi}]");
                }
            }
            assert!(unclamped > 250, "{spec}: only {unclamped} unclamped");
        }
        // The formula itself: a sphere of radius D tan(fov/2) covers π / (4 aspect).
        let r = 10.0 * (30f32.to_radians()).tan();
        let c = coverage_of_sphere(r, 10.0, 60f32.to_radians(), 1.0);
        assert!((c - std::f32::consts::FRAC_PI_4).abs() < 1e-5);
        assert!((radius_for_coverage(c, 10.0, 60f32.to_radians(), 1.0) - r).abs() < 1e-4);
    }

    #[test]
    fn big_part_intensity_scales_with_count() {
        assert_eq!(part_intensity_scale(1, BIG_COVERAGE), 1.0);
        assert_eq!(part_intensity_scale(4, BIG_COVERAGE), 1.0);
        let s100 = part_intensity_scale(100, BIG_COVERAGE);
        assert!((s100 - 0.0402).abs() < 1e-3, "{s100}");
        assert_eq!(part_intensity_scale(100, SMALL_COVERAGE), 1.0);
        assert!(part_intensity_scale(1000, SMALL_COVERAGE) < 0.13);
        let few = build("big:2", 1);
        let many = build("big:100", 1);
        assert_eq!(few[2].radius, many[2].radius);
        assert!((many[2].intensity - few[2].intensity * s100).abs() < 1e-4 * few[2].intensity);
    }

    #[test]
    fn json_light_files() {
        let dir = tempfile::tempdir().unwrap();
        let array = dir.path().join("array.json");
        std::fs::write(
            &array,
            r#"[{"kind": "ambient", "color": [1, 1, 1], "intensity": 0.1},
                {"kind": "spot", "color": [1, 0.5, 0], "intensity": 3, "position": [0, 5, 0],
                 "direction": [0, -2, 0], "radius": 8, "cos_inner": 0.9, "cos_outer": 0.8, "casts_shadows": true}]"#,
        )
        .unwrap();
        let spec: LightSpec = array.to_str().unwrap().parse().unwrap();
        assert_eq!(spec, LightSpec::File(array.clone()));
        let lights = build_lights(&spec, &Aabb::EMPTY, &reference(), 1.0, 0).unwrap();
        assert_eq!(lights.len(), 2, "a file is the whole set");
        assert_eq!(lights[1].direction, Vec3::NEG_Y, "normalised");
        assert_eq!(lights[0].radius, 10.0, "defaults fill missing fields");

        let object = dir.path().join("object.json");
        std::fs::write(
            &object,
            r#"{"about": "test", "lights": [{"kind": "point", "color": [1,1,1], "intensity": 1}]}"#,
        )
        .unwrap();
        assert_eq!(load_light_file(&object).unwrap().len(), 1);

        // An environment light scales `--env` and counts as global.
        let env = dir.path().join("env.json");
        std::fs::write(&env, r#"[{"kind": "environment", "color": [1, 0.9, 0.8], "intensity": 0.5}]"#).unwrap();
        let lights = load_light_file(&env).unwrap();
        assert_eq!(lights[0].kind, LightKind::Environment);
        assert!(lights[0].kind.is_global() && !LightKind::Point.is_global());

        // A round trip through serde keeps the lights.
        let set = build("mixed:1:2", 4);
        let round = dir.path().join("round.json");
        std::fs::write(&round, serde_json::to_string(&set).unwrap()).unwrap();
        assert_eq!(load_light_file(&round).unwrap(), set);

        let bad = dir.path().join("bad.json");
        std::fs::write(&bad, r#"[{"kind": "laser", "color": [1,1,1], "intensity": 1}]"#).unwrap();
        let err = build_lights(&LightSpec::File(bad.clone()), &bounds(), &reference(), 1.0, 0).unwrap_err().to_string();
        assert!(err.starts_with(&bad.display().to_string()) && err.contains("laser"), "{err}");

        std::fs::write(&bad, "{ not json").unwrap();
        let err = load_light_file(&bad).unwrap_err().to_string();
        assert!(err.starts_with(&format!("{}: not a light file", bad.display())), "{err}");

        std::fs::write(&bad, r#"[{"kind": "point", "color": [1,1,1], "intensity": 1, "radius": -1}]"#).unwrap();
        let err = load_light_file(&bad).unwrap_err().to_string();
        assert_eq!(err, format!("{}: light 0: radius -1 is not positive", bad.display()));

        let missing = dir.path().join("missing.json");
        let spec: LightSpec = missing.to_str().unwrap().parse().unwrap();
        let err = build_lights(&spec, &bounds(), &reference(), 1.0, 0).unwrap_err().to_string();
        assert!(err.starts_with(&format!("{}: cannot read light file", missing.display())), "{err}");
    }

    #[test]
    fn small_scenes_scale_the_fixed_lengths() {
        assert_eq!(length_scale(&bounds()), 1.0, "a 36 m scene keeps them");
        let model = |size: f32| Aabb { min: Vec3::new(0.1, 0.0, -0.2) * size, max: Vec3::new(0.3, 0.1, 0.0) * size };
        let camera =
            |size: f32| Camera { position: reference().position * 0.02 * size, near: 0.01 * size, ..reference() };
        let set =
            |size: f32| build_lights(&"small:40+big:8".parse().unwrap(), &model(size), &camera(size), 1.5, 3).unwrap();
        // A 30 cm model and a 9 m one (both under FULL_SIZE_DIAGONAL): the
        // lights of the one are those of the other, 30 times larger.
        let (small, large) = (set(1.0), set(30.0));
        assert!((length_scale(&model(1.0)) - 0.03).abs() < 1e-3 && length_scale(&model(100.0)) == 1.0);
        for (s, l) in small[2..].iter().zip(&large[2..]) {
            assert!((l.position - 30.0 * s.position).length() < 1e-4 * l.position.length().max(1.0), "{s:?} {l:?}");
            assert!((l.radius / s.radius - 30.0).abs() < 1e-3, "{} vs {}", s.radius, l.radius);
        }
        // Lights float above the small model's floor inside its box, not 0.5 m over it.
        let b = model(1.0);
        for l in &small[2..] {
            assert!(l.position.cmpge(b.min).all() && l.position.cmple(b.max).all(), "{l:?}");
        }
    }

    #[test]
    fn lights_around_an_object_surround_it_from_above() {
        let b = bounds();
        let around = region_around(&b);
        assert_eq!(around.min.y, b.min.y, "not below its bottom");
        assert_eq!(around.max - b.max, 0.25 * b.extent());
        assert_eq!((b.min - around.min).with_y(0.0), 0.25 * b.extent().with_y(0.0));
    }

    #[test]
    fn auto_and_studio_are_whole_specs() {
        assert_eq!("auto".parse(), Ok(LightSpec::Auto));
        assert_eq!("Studio".parse(), Ok(LightSpec::Studio));
        for canonical in ["auto", "studio"] {
            assert_eq!(canonical.parse::<LightSpec>().unwrap().to_string(), canonical);
        }
        assert_eq!(parse_err("studio+small:3"), "\"studio+small:3\": 'studio' cannot be combined with other parts");
        assert_eq!(parse_err("small:3+auto"), "\"small:3+auto\": 'auto' cannot be combined with other parts");
        assert_eq!(LightSpec::Auto.resolve(&CameraSource::Framed), LightSpec::Studio);
        assert_eq!(LightSpec::Auto.resolve(&CameraSource::Flight), LightSpec::Daylight);
        let inside = CameraSource::Orbit(super::super::path::OrbitStyle::Inside);
        assert_eq!(LightSpec::Auto.resolve(&inside).to_string(), "small:32");
        let given: LightSpec = "big:3".parse().unwrap();
        assert_eq!(given.resolve(&CameraSource::Framed), given, "a given spec overrides the default");
        assert_eq!(given.resolve(&CameraSource::Flight), given, "a given spec overrides the default");
        assert_eq!("Daylight".parse::<LightSpec>().unwrap().to_string(), "daylight");
        assert_eq!(
            parse_err("daylight+small:3"),
            "\"daylight+small:3\": 'daylight' cannot be combined with other parts"
        );
        assert!(matches!(
            build_lights(&LightSpec::Auto, &bounds(), &reference(), 1.0, 0),
            Err(LightSetError::Unresolved)
        ));
    }

    /// The studio set of a model of `bounds` seen by a camera at `eye`
    /// looking at the bounds' centre.
    fn studio_for(bounds: &Aabb, eye: Vec3) -> Vec<Light> {
        let camera = Camera { position: eye, forward: (bounds.center() - eye).normalize(), ..reference() };
        build_lights(&LightSpec::Studio, bounds, &camera, 1.5, 0).unwrap()
    }

    #[test]
    fn studio_lights_are_placed_from_the_view_and_the_bounds() {
        // A 2 m model seen from the +z side: the camera's left is -x.
        let model = Aabb { min: Vec3::new(-1.0, 0.0, -0.5), max: Vec3::new(1.0, 1.5, 0.5) };
        let (centre, radius) = (model.center(), 0.5 * model.extent().length());
        let set = studio_for(&model, Vec3::new(0.0, 2.0, 8.0));
        let kinds: Vec<LightKind> = set.iter().map(|l| l.kind).collect();
        assert_eq!(kinds, [LightKind::Ambient, LightKind::Spot, LightKind::Point, LightKind::Point]);
        assert!(set.iter().all(|l| l.color == Vec3::ONE), "neutral white");
        let [ambient, key, fill, rim] = [set[0], set[1], set[2], set[3]];
        assert_eq!(set.iter().filter(|l| l.casts_shadows).count(), 1);
        assert!(key.casts_shadows);
        // Key: camera side, to the left, above; fill: camera side, right, lower; rim: behind, above.
        let at = |l: &Light| l.position - centre;
        assert!(at(&key).z > 0.0 && at(&key).x < 0.0 && at(&key).y > 0.5 * radius, "{key:?}");
        assert!(at(&fill).z > 0.0 && at(&fill).x > 0.0 && at(&fill).y < at(&key).y, "{fill:?}");
        assert!(at(&rim).z < 0.0 && at(&rim).y > at(&key).y, "{rim:?}");
        // Each reaches the centre with its share of the key's strength.
        let at_centre = |l: &Light| l.intensity / (1.0 + l.position.distance_squared(centre));
        assert!((at_centre(&key) - 1.0).abs() < 1e-4);
        assert!((at_centre(&fill) - STUDIO_FILL).abs() < 1e-4);
        assert!((at_centre(&rim) - STUDIO_RIM).abs() < 1e-4);
        assert_eq!(ambient.intensity, STUDIO_AMBIENT);
        // The whole model is in every light's range and in the key's full-intensity cone.
        for corner in model.corners() {
            for l in &set[1..] {
                assert!(corner.distance(l.position) < 0.9 * l.radius, "{l:?} misses {corner}");
            }
            assert!((corner - key.position).normalize().dot(key.direction) > key.cos_inner, "{corner}");
        }
        assert!(key.cos_outer < key.cos_inner && key.cos_outer > 60f32.to_radians().cos(), "one shadow face");
    }

    #[test]
    fn studio_lights_scale_with_the_model() {
        let model = |size: f32| Aabb { min: Vec3::new(-0.3, 0.0, -0.2) * size, max: Vec3::new(0.3, 0.4, 0.2) * size };
        let eye = Vec3::new(0.5, 0.4, 1.0);
        // A 5 cm model and a 200 m one: the same lights, scaled (the ambient has no place).
        let (small, large) = (studio_for(&model(0.1), 0.1 * eye), studio_for(&model(400.0), 400.0 * eye));
        assert_eq!(small[0], large[0]);
        for (s, l) in small.iter().zip(&large).skip(1) {
            assert!((l.position - 4000.0 * s.position).length() <= 1e-3 * l.position.length(), "{s:?} {l:?}");
            assert!((l.radius / s.radius - 4000.0).abs() < 0.1);
            assert!(l.direction.distance(s.direction) < 1e-4 && l.cos_inner == s.cos_inner);
        }
        // Turning the camera around the model turns the lights with it.
        let behind = studio_for(&model(1.0), eye * Vec3::new(-1.0, 1.0, -1.0));
        let front = studio_for(&model(1.0), eye);
        let centre = model(1.0).center();
        for (f, b) in front.iter().zip(&behind).skip(1) {
            let turned = (f.position - centre) * Vec3::new(-1.0, 1.0, -1.0);
            assert!((turned - (b.position - centre)).length() < 1e-4, "{f:?} {b:?}");
        }
        assert!(matches!(studio(&Aabb::EMPTY, &reference()), Err(LightSetError::EmptyBounds)));
        let point = Aabb { min: Vec3::ONE, max: Vec3::ONE };
        assert!(matches!(studio(&point, &reference()), Err(LightSetError::EmptyBounds)));
    }

    #[test]
    fn empty_bounds_only_matter_when_placing() {
        let none = build_lights(&LightSpec::None, &Aabb::EMPTY, &reference(), 1.0, 0).unwrap();
        assert_eq!(none.len(), 2);
        let err = build_lights(&"small:3".parse().unwrap(), &Aabb::EMPTY, &reference(), 1.0, 0).unwrap_err();
        assert!(matches!(err, LightSetError::EmptyBounds));
    }
}
