//! WGSL sources and their composition. WGSL has no `#include`, so shared
//! modules (the lighting model, the scene layout) are composed into each
//! pass's shader by `naga_oil`.

use std::borrow::Cow;

use naga_oil::compose::{
    ComposableModuleDescriptor, Composer, ComposerError, NagaModuleDescriptor, ShaderLanguage, ShaderType,
};

/// Modules that other shaders `#import`, in dependency order.
const SHARED: &[(&str, &str)] = &[
    ("lighting.wgsl", include_str!("lighting.wgsl")),
    ("scene.wgsl", include_str!("scene.wgsl")),
    ("scene_bindings.wgsl", include_str!("scene_bindings.wgsl")),
    ("surface.wgsl", include_str!("surface.wgsl")),
    ("objectspace.wgsl", include_str!("objectspace.wgsl")),
];

/// One pass's shader: its file name (for error messages) and source.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSource {
    pub file: &'static str,
    pub source: &'static str,
}

macro_rules! shader {
    ($name:ident, $file:literal) => {
        pub const $name: ShaderSource = ShaderSource { file: $file, source: include_str!($file) };
    };
}

shader!(FORWARD, "forward.wgsl");
shader!(TONEMAP, "tonemap.wgsl");
shader!(VISIBILITY, "visibility.wgsl");
shader!(MARK, "mark.wgsl");
shader!(SHADE, "shade.wgsl");
shader!(GATHER, "gather.wgsl");
shader!(TRIMAP, "trimap.wgsl");
shader!(DILATE, "dilate.wgsl");

/// Every pass shader, for the test that validates them all.
pub const ALL: &[ShaderSource] = &[FORWARD, TONEMAP, VISIBILITY, MARK, SHADE, GATHER, TRIMAP, DILATE];

/// Composes pass shaders with the shared modules.
pub struct ShaderLibrary {
    composer: Composer,
}

#[derive(Debug, thiserror::Error)]
#[error("shader {file}: {message}")]
pub struct ShaderError {
    pub file: String,
    pub message: String,
}

impl ShaderLibrary {
    pub fn new() -> Result<Self, ShaderError> {
        let mut composer = Composer::default().with_capabilities(wgpu::naga::valid::Capabilities::all());
        for (file, source) in SHARED {
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
        Ok(Self { composer })
    }

    /// The composed, validated naga module of a pass shader.
    pub fn compose(&mut self, shader: ShaderSource) -> Result<wgpu::naga::Module, ShaderError> {
        let module = self.composer.make_naga_module(NagaModuleDescriptor {
            source: shader.source,
            file_path: shader.file,
            shader_type: ShaderType::Wgsl,
            ..Default::default()
        });
        module.map_err(|e| error(&self.composer, shader.file, e))
    }

    /// A device shader module for a pass shader.
    pub fn module(&mut self, device: &wgpu::Device, shader: ShaderSource) -> Result<wgpu::ShaderModule, ShaderError> {
        let module = self.compose(shader)?;
        Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(shader.file),
            source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
        }))
    }
}

fn error(composer: &Composer, file: &str, e: ComposerError) -> ShaderError {
    ShaderError { file: file.to_string(), message: e.emit_to_string(composer) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pass shader composes and passes naga's validation, without a GPU.
    #[test]
    fn all_shaders_compose_and_validate() {
        let mut lib = ShaderLibrary::new().expect("shared modules compose");
        for shader in ALL {
            let module = lib.compose(*shader).unwrap_or_else(|e| panic!("{e}"));
            wgpu::naga::valid::Validator::new(
                wgpu::naga::valid::ValidationFlags::all(),
                wgpu::naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {e:?}", shader.file));
        }
    }
}
