//! Environment lighting's source (`--env`): a procedural sky or an
//! equirectangular Radiance HDR image. The renderer prefilters it on the GPU
//! (`render::passes::environment`) and every pipeline lights every material
//! with it through a light of kind [`super::LightKind::Environment`].

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::Vec3;

/// What `--env` names: no environment (the default), the procedural sky, or
/// an equirectangular Radiance `.hdr` file.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum EnvSpec {
    #[default]
    None,
    Sky,
    File(PathBuf),
}

impl FromStr for EnvSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "none" => Self::None,
            "sky" => Self::Sky,
            "" => return Err("expected none, sky or a Radiance .hdr file".into()),
            path => Self::File(PathBuf::from(path)),
        })
    }
}

impl fmt::Display for EnvSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::None => f.write_str("none"),
            Self::Sky => f.write_str("sky"),
            Self::File(p) => write!(f, "{}", p.display()),
        }
    }
}

impl EnvSpec {
    /// The environment it names (`None` for `none`); a file is read and
    /// checked here.
    pub fn load(&self) -> Result<Option<Environment>, EnvError> {
        Ok(match self {
            Self::None => None,
            Self::Sky => Some(Environment::Sky(Sky::default())),
            Self::File(path) => Some(Environment::Image(EquirectImage::load(path)?)),
        })
    }
}

/// Why an environment file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error("--env {path}: {problem}")]
    Unreadable { path: PathBuf, problem: String },
    #[error("--env {path}: not a Radiance HDR image ({problem})")]
    NotHdr { path: PathBuf, problem: String },
    #[error(
        "--env {path}: {width}x{height} is not an equirectangular image (expected twice as wide as high, at least 8x4)"
    )]
    NotEquirectangular { path: PathBuf, width: u32, height: u32 },
}

/// An environment to light the scene with.
#[derive(Clone, Debug)]
pub enum Environment {
    Sky(Sky),
    Image(EquirectImage),
}

/// The procedural sky: a gradient from the ground colour below the horizon
/// through the horizon colour to the zenith colour, and a soft sun. Radiance
/// in the lights' units (a white Lambert surface under a uniform sky of
/// radiance L shows L).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    /// Unit direction towards the sun.
    pub sun_direction: Vec3,
    /// The sun's radiance at its centre.
    pub sun_color: Vec3,
    /// The sun's falloff `exp(sharpness (cos θ - 1))` from its centre (2000:
    /// about 1.3 degrees to 1/e, a disc a 128x128 cube face resolves).
    pub sun_sharpness: f32,
    pub zenith: Vec3,
    pub horizon: Vec3,
    pub ground: Vec3,
}

impl Default for Sky {
    /// A clear day: the sun where the generated light sets put theirs (60
    /// degrees up), a blue zenith, a pale horizon and a dark brown ground.
    fn default() -> Self {
        Self {
            sun_direction: -super::lights::default_sun().direction,
            sun_color: Vec3::new(1.0, 0.9, 0.75) * 100.0,
            sun_sharpness: 2000.0,
            zenith: Vec3::new(0.10, 0.20, 0.45),
            horizon: Vec3::new(0.45, 0.50, 0.55),
            ground: Vec3::new(0.12, 0.10, 0.08),
        }
    }
}

impl Sky {
    /// A sky of one radiance in every direction (no sun): for tests whose
    /// answer is known in closed form.
    pub fn uniform(radiance: Vec3) -> Self {
        Self { sun_color: Vec3::ZERO, zenith: radiance, horizon: radiance, ground: radiance, ..Self::default() }
    }

    /// Radiance arriving from unit direction `d` (the CPU twin of `sky` in
    /// `environment.wgsl`).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let t = d.y.abs().sqrt();
        let base = if d.y >= 0.0 { self.horizon.lerp(self.zenith, t) } else { self.horizon.lerp(self.ground, t) };
        base + self.sun_color * (self.sun_sharpness * (d.dot(self.sun_direction) - 1.0)).exp()
    }
}

/// An equirectangular (latitude-longitude) image: row 0 looks straight up
/// (+y), the last row straight down; column u looks towards azimuth
/// 2π u - π from -z turning towards +x ([`equirect_uv`]).
#[derive(Clone)]
pub struct EquirectImage {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance, row-major, 3 values per texel.
    pub rgb: Vec<f32>,
}

impl fmt::Debug for EquirectImage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "EquirectImage({}x{})", self.width, self.height)
    }
}

impl EquirectImage {
    /// Reads a Radiance `.hdr` file; errors name the file and the problem.
    pub fn load(path: &Path) -> Result<Self, EnvError> {
        let bytes = std::fs::read(path)
            .map_err(|e| EnvError::Unreadable { path: path.to_path_buf(), problem: e.to_string() })?;
        let not_hdr = |problem: String| EnvError::NotHdr { path: path.to_path_buf(), problem };
        let format = image::guess_format(&bytes).map_err(|e| not_hdr(e.to_string()))?;
        if format != image::ImageFormat::Hdr {
            return Err(not_hdr(format!("it is {format:?}")));
        }
        let decoded = image::load_from_memory_with_format(&bytes, format).map_err(|e| not_hdr(e.to_string()))?;
        let rgb = decoded.into_rgb32f();
        let (width, height) = rgb.dimensions();
        if width != 2 * height || height < 4 {
            return Err(EnvError::NotEquirectangular { path: path.to_path_buf(), width, height });
        }
        Ok(Self { width, height, rgb: rgb.into_raw() })
    }
}

/// Where unit direction `d` falls in an equirectangular image, in [0, 1]²
/// (the CPU twin of `equirect_uv` in `environment.wgsl`).
pub fn equirect_uv(d: Vec3) -> (f32, f32) {
    let u = 0.5 + d.x.atan2(-d.z) / std::f32::consts::TAU;
    let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_parses_words_and_paths() {
        assert_eq!("none".parse::<EnvSpec>(), Ok(EnvSpec::None));
        assert_eq!("sky".parse::<EnvSpec>(), Ok(EnvSpec::Sky));
        assert_eq!("a/b.hdr".parse::<EnvSpec>(), Ok(EnvSpec::File("a/b.hdr".into())));
        assert!("".parse::<EnvSpec>().is_err());
        assert!(EnvSpec::default().load().unwrap().is_none());
    }

    /// Bad files are named with their problem.
    #[test]
    fn bad_files_name_the_file_and_the_problem() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.hdr");
        let e = EnvSpec::File(missing.clone()).load().unwrap_err().to_string();
        assert!(e.starts_with(&format!("--env {}: ", missing.display())), "{e}");
        let png = dir.path().join("sky.hdr");
        image::RgbImage::new(8, 4).save_with_format(&png, image::ImageFormat::Png).unwrap();
        let e = EnvSpec::File(png.clone()).load().unwrap_err().to_string();
        assert_eq!(e, format!("--env {}: not a Radiance HDR image (it is Png)", png.display()));
        let square = dir.path().join("square.hdr");
        write_hdr(&square, 8, 8, |_, _| [1.0; 3]);
        let e = EnvSpec::File(square.clone()).load().unwrap_err().to_string();
        assert!(e.contains("8x8 is not an equirectangular image"), "{e}");
    }

    /// A Radiance file comes back with its radiance (to the format's 8-bit
    /// mantissa) and orientation.
    #[test]
    fn hdr_files_load_with_their_radiance() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("env.hdr");
        write_hdr(&path, 16, 8, |x, y| [x as f32, y as f32 * 0.5, 2.0]);
        let Some(Environment::Image(img)) = EnvSpec::File(path).load().unwrap() else { panic!("an image") };
        assert_eq!((img.width, img.height), (16, 8));
        let at = |x: usize, y: usize| &img.rgb[(y * 16 + x) * 3..][..3];
        for (x, y) in [(0, 0), (15, 7), (3, 5)] {
            let want = [x as f32, y as f32 * 0.5, 2.0];
            for (g, w) in at(x, y).iter().zip(want) {
                assert!((g - w).abs() <= w * 0.01 + 1e-6, "({x}, {y}): {g} against {w}");
            }
        }
    }

    /// Writes a Radiance HDR file of `f(x, y)`.
    pub fn write_hdr(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) {
        let img = image::Rgb32FImage::from_fn(w, h, |x, y| image::Rgb(f(x, y)));
        image::DynamicImage::ImageRgb32F(img).save_with_format(path, image::ImageFormat::Hdr).unwrap();
    }

    #[test]
    fn equirect_orientation() {
        let close = |a: (f32, f32), b: (f32, f32)| (a.0 - b.0).abs() < 1e-5 && (a.1 - b.1).abs() < 1e-5;
        assert!(close(equirect_uv(Vec3::NEG_Z), (0.5, 0.5)));
        assert!(close(equirect_uv(Vec3::X), (0.75, 0.5)));
        assert!(equirect_uv(Vec3::Y).1 < 1e-5 && (equirect_uv(Vec3::NEG_Y).1 - 1.0).abs() < 1e-5);
    }

    #[test]
    fn uniform_sky_is_uniform_and_the_default_sun_is_bright() {
        let s = Sky::uniform(Vec3::splat(0.5));
        for d in [Vec3::Y, Vec3::NEG_Y, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            assert_eq!(s.radiance(d), Vec3::splat(0.5));
        }
        let sky = Sky::default();
        assert!(sky.radiance(sky.sun_direction).x > 50.0 && sky.radiance(Vec3::Y).x < 1.0);
    }
}
