//! Supersampled reference images: the ground truth pipelines are judged
//! against. The forward pipeline renders the frame N x N times, each time
//! with the projection shifted by a sub-pixel offset of a regular grid
//! (`(i + 0.5) / N - 0.5` pixels on each axis) and its material textures
//! sampled log2(N) levels finer (`Renderer::texture_lod_bias` = -log2(N)),
//! and the HDR frames are averaged in linear light (a box filter over the
//! pixel) before tone mapping with the exposure the pipelines use.
//!
//! So each sample sees what the pixel centre of a frame N times larger sees:
//! the same point (the grid's points are the large frame's pixel centres),
//! and its textures filtered over that smaller pixel's footprint (the large
//! frame's UV derivatives are 1/N of these, log2(N) levels finer). The
//! result is that large frame box-filtered down N x N, which converges to
//! the pixel integral of geometry, shading, specular aliasing and texture
//! detail alike.
//!
//! Why jittered frames and not one frame at N times the size: the samples
//! are the same, but every frame is at the pipelines' own size, so no target
//! outgrows the adapter (16384 / 8 is 2048 pixels a side: an 8x8 reference
//! at 3840x2160 would need tiles) and what is sized from the screen (light
//! grids, clusters) is what the pipelines see. What remains different from a
//! true integral: each sample's texture value is the hardware's trilinear
//! filter of its footprint (a square box between two mip levels, not the
//! footprint's own shape: at grazing angles it blurs along the short axis as
//! the long one wants; no anisotropic filter), and implicit derivatives are
//! taken over 2x2 quads of the pipelines' pixels, N times the large frame's
//! quads (equal where UV is affine over them, close under perspective).
//! Shadow maps and the environment are sampled as in any frame: their
//! resolution does not follow the screen's.
//!
//! References are cached on disk ([`ReferenceCache`]) by a hash of all their
//! inputs, so experiments render each one once.

use std::ffi::OsString;
use std::path::PathBuf;

use glam::Vec2;
use image::RgbaImage;

use crate::color::reinhard_srgb8;
use crate::gpu::{GpuContext, readback};
use crate::hash::Fnv1a;
use crate::render::{Exposure, ForwardConfig, PipelineConfig, RenderError, RenderOptions, Renderer, ShadingModel};
use crate::scene::environment::Environment;
use crate::scene::{Camera, Light, Scene};

/// Bumped when the reference's method changes, so old cache files are not reused.
/// 2: material textures sampled at the samples' own footprints (a level bias
/// of -log2(N)); 1 sampled them at the whole pixel's.
const METHOD_VERSION: u32 = 2;
const MAGIC: &[u8; 8] = b"SSREF\0\0\x01";

/// Why a reference could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error("{0} samples per axis: a reference needs at least 1")]
    NoSamples(u32),
}

/// A supersampled frame: linear HDR, resolved, before tone mapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub width: u32,
    pub height: u32,
    /// Samples per axis (N x N per pixel).
    pub samples: u32,
    /// The exposure it is tone-mapped with (what `Exposure::Auto` found on the
    /// unjittered forward frame, or the fixed value).
    pub exposure: f32,
    /// Row-major linear RGB, `width * height * 3` values.
    pub hdr: Vec<f32>,
}

impl Reference {
    /// The tone-mapped image, as the renderer's tone map pass makes it
    /// (exposure, Reinhard per channel, sRGB).
    pub fn image(&self) -> RgbaImage {
        tone_map(self.width, self.height, &self.hdr, self.exposure)
    }
}

/// Exposure, Reinhard per channel, sRGB: the CPU twin of `tonemap.wgsl`.
pub fn tone_map(width: u32, height: u32, hdr: &[f32], exposure: f32) -> RgbaImage {
    RgbaImage::from_fn(width, height, |x, y| {
        let i = (y as usize * width as usize + x as usize) * 3;
        let c = |k: usize| reinhard_srgb8(hdr[i + k] * exposure);
        image::Rgba([c(0), c(1), c(2), 255])
    })
}

/// What a reference depends on besides the scene and the adapter.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceView<'a> {
    pub camera: &'a Camera,
    pub lights: &'a [Light],
    /// Samples per axis (N x N per pixel).
    pub samples: u32,
}

/// The renderer settings a reference shares with the pipelines it judges.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceSettings {
    pub width: u32,
    pub height: u32,
    pub shading: ShadingModel,
    pub sun_shadow: bool,
    pub exposure: Exposure,
}

/// Renders references of one scene at one size, reusing one forward renderer
/// and the scene's hash across frames; with a cache, each is rendered once.
pub struct References<'a> {
    ctx: &'a GpuContext,
    scene: &'a Scene,
    settings: ReferenceSettings,
    cache: ReferenceCache,
    scene_hash: u64,
    renderer: Option<Renderer>,
}

impl<'a> References<'a> {
    pub fn new(ctx: &'a GpuContext, scene: &'a Scene, settings: ReferenceSettings, cache: ReferenceCache) -> Self {
        Self { ctx, scene, settings, cache, scene_hash: scene_hash(scene), renderer: None }
    }

    /// The cache key of a view: every input of the image.
    pub fn key(&self, view: &ReferenceView) -> u64 {
        let s = &self.settings;
        let mut h = Fnv1a::default();
        h.write_u32(METHOD_VERSION);
        h.write(self.ctx.info.name.as_bytes());
        h.write(self.ctx.info.driver.as_bytes());
        h.write(&self.scene_hash.to_le_bytes());
        h.write(format!("{:?}|{:?}", view.camera, view.lights).as_bytes());
        h.write(format!("{}x{} {:?} {} {:?}", s.width, s.height, s.shading, s.sun_shadow, s.exposure).as_bytes());
        h.write_u32(view.samples);
        for shader in crate::shaders::SHARED
            .iter()
            .chain(crate::render::shader_set::SHARED)
            .chain([&crate::render::forward::SHADER, &crate::render::passes::depth_prepass::SHADER])
            .chain([&crate::render::passes::shadows::SHADER, &crate::render::passes::tonemap::SHADER])
            .chain([&crate::render::passes::exposure::SHADER])
        {
            h.write(shader.source.as_bytes());
        }
        h.finish()
    }

    /// The reference of a view: from the cache when it holds it (the flag
    /// says so), else rendered and stored.
    pub fn get(&mut self, view: &ReferenceView) -> Result<(Reference, bool), ReferenceError> {
        let key = self.key(view);
        if let Some(r) = self.cache.load(key) {
            return Ok((r, true));
        }
        let r = self.render(view)?;
        self.cache.store(key, &r);
        Ok((r, false))
    }

    /// Renders a view's reference (no cache).
    pub fn render(&mut self, view: &ReferenceView) -> Result<Reference, ReferenceError> {
        let n = view.samples;
        if n == 0 {
            return Err(ReferenceError::NoSamples(n));
        }
        let (ctx, s) = (self.ctx, self.settings);
        let renderer = match &mut self.renderer {
            Some(r) => r,
            None => {
                let forward = PipelineConfig::Forward(ForwardConfig::default());
                // One sample per pixel: the grid of shifted frames is the supersampling.
                let options = RenderOptions::new(s.width, s.height, forward);
                let mut r = Renderer::new(ctx, self.scene, &options)?;
                r.shading = s.shading;
                r.sun_shadow = s.sun_shadow;
                self.renderer.insert(r)
            }
        };
        // The exposure: fixed, or what auto exposure finds on the unjittered
        // frame, as `--pipeline forward --exposure auto` would show it.
        let exposure = match s.exposure {
            Exposure::Fixed(e) => e,
            Exposure::Auto => {
                renderer.exposure = Exposure::Auto;
                renderer.jitter = Vec2::ZERO;
                renderer.render(ctx, view.camera, view.lights, 0)?;
                renderer.read_exposure(ctx)?
            }
        };
        renderer.exposure = Exposure::Fixed(exposure);
        // Each sample's textures at its own footprint, a pixel of the frame
        // N times larger: log2(N) levels finer than this frame's pixel.
        renderer.texture_lod_bias = lod_bias(n);
        let pixels = (s.width * s.height) as usize;
        let mut sum = vec![0.0f64; pixels * 3];
        for j in 0..n {
            for i in 0..n {
                renderer.jitter = Vec2::new(offset(i, n), offset(j, n));
                renderer.render(ctx, view.camera, view.lights, 0)?;
                // Its timings are not wanted: drain them so that none pile up.
                renderer.collect_timings(ctx, false);
                let bytes = readback::read_texture(ctx, &renderer.targets.hdr, 8).map_err(RenderError::from)?;
                // Rgba16Float texels, 8 bytes each (the bytes need not be 2-aligned).
                for (p, t) in bytes.chunks_exact(8).enumerate() {
                    for k in 0..3 {
                        sum[p * 3 + k] += f64::from(half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32());
                    }
                }
            }
        }
        renderer.jitter = Vec2::ZERO;
        renderer.texture_lod_bias = 0.0;
        let scale = 1.0 / f64::from(n * n);
        let hdr = sum.iter().map(|v| (v * scale) as f32).collect();
        Ok(Reference { width: s.width, height: s.height, samples: n, exposure, hdr })
    }
}

/// Sample `i` of `n` per axis, in pixels from the pixel's centre: the
/// centres of an n x n grid over the pixel.
pub fn offset(i: u32, n: u32) -> f32 {
    (i as f32 + 0.5) / n as f32 - 0.5
}

/// The texture level bias of a reference with `n` samples per axis:
/// `-log2(n)`, the level shift from a pixel's footprint to an `n`-th of it.
pub fn lod_bias(n: u32) -> f32 {
    -(n as f32).log2()
}

/// A stable hash of everything in a scene that reaches the image: geometry,
/// materials (every field), textures (their texels), objects and their
/// transforms. So a material override (`--gloss`), detailed textures or
/// excluded objects give another key than the file alone.
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fnv1a::default();
    for m in &scene.meshes {
        h.write_pod(&m.positions);
        h.write_pod(&m.normals);
        h.write_pod(&m.tangents);
        h.write_pod(&m.uv0);
        h.write_pod(m.uv1.as_deref().unwrap_or(&[]));
        h.write_pod(&m.indices);
    }
    for t in &scene.textures {
        h.write_u32(t.width);
        h.write_u32(t.height);
        h.write_pod(&t.rgba8);
    }
    h.write(format!("{:?}|{:?}", scene.materials, scene.objects).as_bytes());
    match &scene.environment {
        None => h.write(b"no environment"),
        Some(Environment::Sky(sky)) => h.write(format!("{sky:?}").as_bytes()),
        Some(Environment::Image(img)) => {
            h.write_u32(img.width);
            h.write_u32(img.height);
            h.write_pod(&img.rgb);
        }
    }
    h.finish()
}

/// Where references are kept: `references/` in the cache folder of the
/// charts' convention (`$SHADESPACE_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/shadespace`, else `~/.cache/shadespace`), or nowhere.
#[derive(Clone, Debug)]
pub struct ReferenceCache {
    dir: Option<PathBuf>,
}

impl ReferenceCache {
    /// The cache in the environment's folder ([`cache_dir_from`]); none
    /// (with a warning) when no folder is set.
    pub fn from_env() -> Self {
        match cache_dir_from(|name| std::env::var_os(name)) {
            Some(dir) => Self::in_dir(dir),
            None => {
                tracing::warn!("no cache folder (set SHADESPACE_CACHE_DIR or HOME): references are not cached");
                Self::disabled()
            }
        }
    }

    /// The cache in `dir` (created when first stored to).
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        Self { dir: Some(dir.into()) }
    }

    /// A cache that keeps nothing.
    pub fn disabled() -> Self {
        Self { dir: None }
    }

    /// The file of a key, where the cache has a folder.
    pub fn path(&self, key: u64) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join(format!("{key:016x}.ref")))
    }

    fn load(&self, key: u64) -> Option<Reference> {
        let path = self.path(key)?;
        let bytes = std::fs::read(&path).ok()?;
        let r = decode(&bytes);
        if r.is_none() {
            tracing::warn!("{}: not a reference file; rendering it again", path.display());
        }
        r
    }

    /// Stores a reference; a cache that cannot write warns and goes on.
    fn store(&self, key: u64, r: &Reference) {
        let Some(path) = self.path(key) else { return };
        let write = || -> std::io::Result<()> {
            std::fs::create_dir_all(path.parent().expect("a file in a folder"))?;
            let tmp = path.with_extension(format!("tmp{}", std::process::id()));
            std::fs::write(&tmp, encode(r))?;
            std::fs::rename(&tmp, &path)
        };
        if let Err(e) = write() {
            tracing::warn!("reference cache {}: {e}; the reference is not cached", path.display());
        }
    }
}

/// The reference folder from the environment (`var` reads one variable).
/// Empty values count as unset and a relative `XDG_CACHE_HOME` is ignored,
/// as for the charts.
pub fn cache_dir_from(var: impl Fn(&str) -> Option<OsString>) -> Option<PathBuf> {
    crate::cache_dir::cache_root_from(var).map(|root| root.join("references"))
}

fn encode(r: &Reference) -> Vec<u8> {
    let mut out = Vec::with_capacity(24 + r.hdr.len() * 4);
    out.extend_from_slice(MAGIC);
    for v in [r.width, r.height, r.samples, r.exposure.to_bits()] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in &r.hdr {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

fn decode(bytes: &[u8]) -> Option<Reference> {
    let rest = bytes.strip_prefix(MAGIC)?;
    let word = |i: usize| Some(u32::from_le_bytes(rest.get(i * 4..i * 4 + 4)?.try_into().ok()?));
    let (width, height, samples, exposure) = (word(0)?, word(1)?, word(2)?, f32::from_bits(word(3)?));
    let data = &rest[16..];
    if data.len() != width as usize * height as usize * 12 {
        return None;
    }
    let hdr = data.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect();
    Some(Reference { width, height, samples, exposure, hdr })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_offsets_are_the_centres_of_a_grid_over_the_pixel() {
        assert_eq!(offset(0, 1), 0.0);
        let four: Vec<f32> = (0..4).map(|i| offset(i, 4)).collect();
        assert_eq!(four, [-0.375, -0.125, 0.125, 0.375]);
        // Symmetric about the centre: the resolved pixel is not shifted.
        assert_eq!((0..8).map(|i| offset(i, 8)).sum::<f32>(), 0.0);
    }

    #[test]
    fn the_lod_bias_is_minus_log2_of_the_samples_per_axis() {
        assert_eq!([1, 2, 4, 8].map(lod_bias), [0.0, -1.0, -2.0, -3.0]);
    }

    #[test]
    fn cache_files_round_trip_and_reject_others() {
        let r = Reference { width: 2, height: 1, samples: 4, exposure: 0.5, hdr: vec![0.0, 1.0, 2.5, 3.0, 1e-3, 7.0] };
        let bytes = encode(&r);
        assert_eq!(decode(&bytes), Some(r));
        assert_eq!(decode(&bytes[..bytes.len() - 1]), None);
        assert_eq!(decode(b"not a reference file at all"), None);
    }

    #[test]
    fn the_cache_folder_follows_the_charts_convention() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| pairs.iter().find(|(k, _)| *k == name).map(|(_, v)| OsString::from(v))
        };
        assert_eq!(
            cache_dir_from(env(&[("SHADESPACE_CACHE_DIR", "/c"), ("HOME", "/h")])),
            Some("/c/references".into())
        );
        assert_eq!(cache_dir_from(env(&[("XDG_CACHE_HOME", "/x")])), Some("/x/shadespace/references".into()));
        assert_eq!(cache_dir_from(env(&[("HOME", "/h")])), Some("/h/.cache/shadespace/references".into()));
        assert_eq!(cache_dir_from(env(&[])), None);
    }

    #[test]
    fn tone_mapping_matches_the_renderers() {
        let img = tone_map(2, 1, &[0.0, 1.0, 3.0, 100.0, 0.25, 0.5], 2.0);
        assert_eq!(img.get_pixel(0, 0).0, [0, reinhard_srgb8(2.0), reinhard_srgb8(6.0), 255]);
        assert_eq!(img.get_pixel(1, 0).0, [reinhard_srgb8(200.0), reinhard_srgb8(0.5), reinhard_srgb8(1.0), 255]);
    }
}
