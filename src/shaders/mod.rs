//! WGSL sources and their composition. WGSL has no `#include`, so shared
//! modules (the lighting model, the scene layout, the constants shared with
//! Rust) are composed into each pass's shader by `naga_oil`.
//!
//! Pass shaders live beside the Rust of their pass or pipeline (for example
//! `render/objectspace/mark/mark.wgsl`); the modules every pipeline imports
//! live in `shaders/shared/`; the constants WGSL shares with Rust are
//! generated from the Rust definitions ([`contract`]), and every struct whose
//! bytes cross between the two is declared with `gpu_struct!` so that a
//! test can compare it member by member ([`layout`]).
//!
//! This module is the mechanism and the lowest shared WGSL; it imports
//! nothing from the layers above. What the pipelines add (their shared
//! modules, the constants they share, the list of pass shaders, and the
//! tests that validate them all) is `render::shader_set`.

pub mod contract;
pub mod layout;

use std::borrow::Cow;
use std::collections::{HashMap, HashSet};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::{LazyLock, Mutex};

use crate::gpu::pipelines::{Cached, PipelineCache};
use naga_oil::compose::{
    ComposableModuleDescriptor, Composer, ComposerError, NagaModuleDescriptor, ShaderDefValue, ShaderLanguage,
    ShaderType,
};

pub(crate) use layout::gpu_struct;

/// One WGSL file: its name (for error messages) and source, and the
/// naga_oil shader definitions (`#ifdef NAME`) it is composed with.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    pub file: &'static str,
    pub source: &'static str,
    pub defs: &'static [&'static str],
}

impl ShaderSource {
    pub const fn new(file: &'static str, source: &'static str) -> Self {
        Self { file, source, defs: &[] }
    }

    /// The same file composed with `defs` defined (one variant of it).
    pub const fn with_defs(self, defs: &'static [&'static str]) -> Self {
        Self { defs, ..self }
    }
}

/// The modules of `shaders/shared/` that pass shaders `#import`, in
/// dependency order (after the generated `shadespace::contract`); they
/// import nothing but each other and the contract. The render layer adds
/// its own shared modules after them ([`ShaderLibrary::new`]).
pub const SHARED: &[ShaderSource] = &[
    ShaderSource::new("shared/shadows.wgsl", include_str!("shared/shadows.wgsl")),
    ShaderSource::new("shared/environment.wgsl", include_str!("shared/environment.wgsl")),
    ShaderSource::new("shared/lighting.wgsl", include_str!("shared/lighting.wgsl")),
    ShaderSource::new("shared/scene.wgsl", include_str!("shared/scene.wgsl")),
    ShaderSource::new("shared/scene_bindings.wgsl", include_str!("shared/scene_bindings.wgsl")),
    ShaderSource::new("shared/alpha_mask.wgsl", include_str!("shared/alpha_mask.wgsl")),
    ShaderSource::new("shared/normal_map.wgsl", include_str!("shared/normal_map.wgsl")),
    ShaderSource::new("materials/layers.wgsl", include_str!("../materials/layers.wgsl")),
    ShaderSource::new("shared/surface.wgsl", include_str!("shared/surface.wgsl")),
    ShaderSource::new("shared/pixel_surface.wgsl", include_str!("shared/pixel_surface.wgsl")),
    ShaderSource::new("shared/raster_surface.wgsl", include_str!("shared/raster_surface.wgsl")),
    ShaderSource::new("shared/octahedral.wgsl", include_str!("shared/octahedral.wgsl")),
    ShaderSource::new("shared/light_bounds.wgsl", include_str!("shared/light_bounds.wgsl")),
];

/// Defined when some object of the scene has an emissive, metallic-roughness
/// or occlusion texture ([`ShaderLibrary::define`]): the shaders then sample
/// them and the raster G-buffer stores their texels. Without it that code is
/// not compiled at all, so scenes without such textures do not pay for it
/// (measured on the H100: 3-7 % in every pipeline, 20 % in the two that
/// write the raster G-buffer).
pub const MATERIAL_TEXTURES: &str = "MATERIAL_TEXTURES";

/// Defined when some material of the scene has layers
/// ([`crate::materials`]): every pipeline then evaluates each layer's surface
/// and blends the lit results by mask (`materials/layers.wgsl`), and the
/// raster G-buffer stores UV0 and its mip. Without it that code is not
/// compiled, so unlayered scenes render and cost as before.
pub const LAYERS: &str = "LAYERS";

/// Defined when the scene has an environment (`--env`,
/// [`crate::scene::Scene::environment`]): lights of kind `environment` then
/// read its prefiltered maps (`shared/environment.wgsl`). Without it that
/// code is not compiled, so scenes without one render and cost as before
/// (an environment light there adds nothing).
pub const ENVIRONMENT: &str = "ENVIRONMENT";

/// Defined when the renderer has MSAA (more than one sample per pixel,
/// [`ShaderLibrary::define`]): the G-buffer and object space's visibility
/// buffer are multisampled, and the passes reading them read every sample.
pub const MSAA: &str = "MSAA";

/// Defined with [`MSAA`] when the compute rasterizer fills the visibility
/// buffer: it is then a 2D array with a layer per sample (multisampled
/// textures cannot be written by compute passes), and the passes reading it
/// read the layers.
pub const VISIBILITY_LAYERS: &str = "VISIBILITY_LAYERS";

/// Defined in the variant of a scene raster pass that draws the alpha-masked
/// objects (`render::passes::ScenePipeline`): its fragment stage
/// discards their cut-away fragments (`shared/alpha_mask.wgsl`); a depth-only
/// pass gains the fragment entry point `fs_alpha_mask` for it.
pub const ALPHA_MASK: &str = "ALPHA_MASK";

/// Composes pass shaders with the shared modules.
///
/// Composed modules are kept for the life of the process, keyed by
/// everything that goes into them (the library's modules and constants, the
/// shader's source and its definitions): every renderer composes the same few
/// dozen shaders, and composing them (naga_oil's preprocessing, parsing and
/// validation) was a large share of building a renderer on a CPU driver,
/// where tests and the viewer build hundreds.
pub struct ShaderLibrary {
    /// Built on the first shader not composed before in this process.
    composer: Option<Composer>,
    /// The library's modules, kept to build the composer when needed.
    sources: Vec<(&'static str, Cow<'static, str>)>,
    /// Hash of `sources`: the part of a composed module's key the library gives.
    key: u64,
    /// Defined for every shader this library composes.
    defs: Vec<&'static str>,
    /// Where compute pipelines are kept ([`Self::keep_pipelines_in`]).
    pipelines: Option<PipelineCache>,
}

/// Composed modules by [`ShaderLibrary::module_key`].
static COMPOSED: LazyLock<Mutex<HashMap<u64, wgpu::naga::Module>>> = LazyLock::new(Default::default);

/// Libraries (by [`ShaderLibrary::key`]) whose modules composed without error.
static VALID_LIBRARIES: LazyLock<Mutex<HashSet<u64>>> = LazyLock::new(Default::default);

#[derive(Debug, thiserror::Error)]
#[error("shader {file}: {message}")]
pub struct ShaderError {
    pub file: String,
    pub message: String,
}

impl ShaderLibrary {
    /// A library of the generated `shadespace::contract` (from `constants`,
    /// the `u32` constants WGSL shares with Rust), the modules of [`SHARED`],
    /// then `modules` (shared modules of the layers above, in dependency
    /// order). `render::shader_set::library` is the one the renderer uses.
    pub fn new(constants: &[(&str, u32)], modules: &[ShaderSource]) -> Result<Self, ShaderError> {
        let contract = contract::wgsl(constants);
        let generated = [("shadespace::contract (generated)", Cow::Owned(contract))];
        let shared = SHARED.iter().chain(modules).map(|s| (s.file, Cow::Borrowed(s.source)));
        let sources: Vec<_> = generated.into_iter().chain(shared).collect();
        let mut hasher = DefaultHasher::new();
        sources.hash(&mut hasher);
        let key = hasher.finish();
        let mut library = Self { composer: None, sources, key, defs: Vec::new(), pipelines: None };
        if !VALID_LIBRARIES.lock().unwrap_or_else(|e| e.into_inner()).contains(&key) {
            library.composer()?;
        }
        Ok(library)
    }

    /// The composer of this library's modules, built on first use (its
    /// errors name the module that fails).
    fn composer(&mut self) -> Result<&mut Composer, ShaderError> {
        if self.composer.is_none() {
            let mut composer = Composer::default().with_capabilities(wgpu::naga::valid::Capabilities::all());
            for (file, source) in &self.sources {
                let added = composer.add_composable_module(ComposableModuleDescriptor {
                    source,
                    file_path: file,
                    language: ShaderLanguage::Wgsl,
                    ..Default::default()
                });
                if let Err(e) = added {
                    return Err(error(&composer, file, e));
                }
            }
            VALID_LIBRARIES.lock().unwrap_or_else(|e| e.into_inner()).insert(self.key);
            self.composer = Some(composer);
        }
        Ok(self.composer.as_mut().expect("built above"))
    }

    /// The key of `shader` composed with `defs` by this library.
    fn module_key(&self, shader: &ShaderSource, defs: &[&str]) -> u64 {
        let mut hasher = DefaultHasher::new();
        (self.key, shader.file, shader.source, defs).hash(&mut hasher);
        hasher.finish()
    }

    /// Keeps the pipelines built through [`Self::pipeline`] in `cache` (the
    /// device's), and takes them from it when built before.
    pub fn keep_pipelines_in(&mut self, cache: &PipelineCache) {
        self.pipelines = Some(cache.clone());
    }

    /// The pipeline of `shader` (with `extra` defined too) that `build`
    /// makes with this library, or as it was made before if pipelines are
    /// kept ([`Self::keep_pipelines_in`]); `state` is everything else that
    /// tells it apart (entry points, number of bind groups, fixed state).
    pub fn pipeline<P: Cached>(
        &mut self,
        shader: ShaderSource,
        extra: &[&str],
        state: impl Hash,
        build: impl FnOnce(&mut Self) -> Result<P, ShaderError>,
    ) -> Result<P, ShaderError> {
        let Some(cache) = self.pipelines.clone() else {
            return build(self);
        };
        let mut hasher = DefaultHasher::new();
        (self.module_key(&shader, &self.defs_with(&shader, extra)), state).hash(&mut hasher);
        cache.get_or_build(hasher.finish(), || build(self))
    }

    /// Every definition `shader` is composed with: its own, the library's
    /// and `extra`, sorted, once each.
    fn defs_with<'a>(&'a self, shader: &ShaderSource, extra: &[&'a str]) -> Vec<&'a str> {
        let mut defs: Vec<&str> = shader.defs.iter().chain(&self.defs).chain(extra).copied().collect();
        defs.sort_unstable();
        defs.dedup();
        defs
    }

    /// Defines `def` for every shader composed from now on (for example
    /// [`MATERIAL_TEXTURES`] for the scene a renderer draws).
    pub fn define(&mut self, def: &'static str) {
        if !self.defs.contains(&def) {
            self.defs.push(def);
        }
    }

    /// The composed, validated naga module of a pass shader.
    pub fn compose(&mut self, shader: ShaderSource) -> Result<wgpu::naga::Module, ShaderError> {
        self.compose_with(shader, &[])
    }

    /// [`Self::compose`] with `extra` defined too (a variant of a shader
    /// that may itself have definitions).
    pub fn compose_with(&mut self, shader: ShaderSource, extra: &[&str]) -> Result<wgpu::naga::Module, ShaderError> {
        let defs = self.defs_with(&shader, extra);
        let key = self.module_key(&shader, &defs);
        if let Some(module) = COMPOSED.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
            return Ok(module.clone());
        }
        let shader_defs = defs.iter().map(|d| (d.to_string(), ShaderDefValue::Bool(true))).collect();
        let composer = self.composer()?;
        let module = composer.make_naga_module(NagaModuleDescriptor {
            source: shader.source,
            file_path: shader.file,
            shader_type: ShaderType::Wgsl,
            shader_defs,
            ..Default::default()
        });
        let module = module.map_err(|e| error(composer, shader.file, e))?;
        COMPOSED.lock().unwrap_or_else(|e| e.into_inner()).insert(key, module.clone());
        Ok(module)
    }

    /// A device shader module for a pass shader.
    pub fn module(&mut self, device: &wgpu::Device, shader: ShaderSource) -> Result<wgpu::ShaderModule, ShaderError> {
        self.module_with(device, shader, &[])
    }

    /// [`Self::module`] with `extra` defined too.
    pub fn module_with(
        &mut self,
        device: &wgpu::Device,
        shader: ShaderSource,
        extra: &[&str],
    ) -> Result<wgpu::ShaderModule, ShaderError> {
        let module = self.compose_with(shader, extra)?;
        let desc = wgpu::ShaderModuleDescriptor {
            label: Some(shader.file),
            source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
        };
        // SAFETY: the one check left out, `force_loop_bounding`, makes a
        // loop that never ends stop after 2^64 turns instead of hanging the
        // GPU; every loop in the project's shaders ends by its own bound
        // (counts, lists and probes with a maximum). naga's counter in every
        // loop cost every pipeline 4-11 % of its frame along Sponza's path
        // on an H200 (`deferred-compute` 0.570 -> 0.506 ms with 30
        // shadowed lights; BENCHMARKS.md, "Loops without naga's bound").
        Ok(unsafe { device.create_shader_module_trusted(desc, SHADER_CHECKS) })
    }
}

/// The runtime checks compiled into every pass shader: wgpu's defaults
/// (bounds checks, integer division checks) less the loop counter naga
/// adds to every loop (see [`ShaderLibrary::module_with`]).
pub const SHADER_CHECKS: wgpu::ShaderRuntimeChecks = {
    let mut checks = wgpu::ShaderRuntimeChecks::checked();
    checks.force_loop_bounding = false;
    checks
};

/// Bytes of the WGSL struct `name` (declared in `module`'s own file, not an
/// imported one) as an array element: for buffers of structs that only the
/// GPU reads and writes, so that no Rust copy of their layout can drift.
pub fn struct_size(module: &wgpu::naga::Module, name: &str) -> Option<u64> {
    module.types.iter().find_map(|(_, ty)| match (&ty.name, &ty.inner) {
        (Some(n), wgpu::naga::TypeInner::Struct { span, .. }) if n == name => Some(*span as u64),
        _ => None,
    })
}

fn error(composer: &Composer, file: &str, e: ComposerError) -> ShaderError {
    ShaderError { file: file.to_string(), message: e.emit_to_string(composer) }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PASS: ShaderSource = ShaderSource::new(
        "cache_test.wgsl",
        "#ifdef WIDE\nconst SIDE: u32 = 16u;\n#else\nconst SIDE: u32 = 8u;\n#endif\n\
         @compute @workgroup_size(SIDE) fn main() {}",
    );

    fn side(module: &wgpu::naga::Module) -> [u32; 3] {
        module.entry_points[0].workgroup_size
    }

    /// A second library of the same modules composes from the cache, and the
    /// key tells definitions apart (a cached module must not stand for a
    /// variant with other definitions).
    #[test]
    fn composed_modules_are_kept_per_definitions() {
        let mut first = ShaderLibrary::new(&[], &[]).unwrap();
        assert_eq!(side(&first.compose(PASS).unwrap()), [8, 1, 1]);
        assert_eq!(side(&first.compose_with(PASS, &["WIDE"]).unwrap()), [16, 1, 1]);
        let mut second = ShaderLibrary::new(&[], &[]).unwrap();
        assert!(second.composer.is_none(), "a library composed before is not parsed again");
        assert_eq!(side(&second.compose(PASS).unwrap()), [8, 1, 1]);
        second.define("WIDE");
        assert_eq!(side(&second.compose(PASS).unwrap()), [16, 1, 1]);
        assert!(second.composer.is_none(), "both variants came from the cache");
    }

    /// A library with a module that cannot be added (no import path) fails
    /// when it is made, naming the module, however many good libraries were
    /// made before.
    #[test]
    fn a_bad_module_fails_the_library() {
        ShaderLibrary::new(&[], &[]).unwrap();
        let bad = ShaderSource::new("bad_module.wgsl", "fn f() {}");
        let e = ShaderLibrary::new(&[], &[bad]).err().expect("a module without an import path");
        assert_eq!(e.file, "bad_module.wgsl", "{e}");
    }
}
