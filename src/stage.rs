//! A scene staged for rendering as `shadespace render` stages it when given
//! only the scene: loaded, with its cameras, its default light set and
//! exposure, and charted for object space when that pipeline is asked for.
//! The short way in for programs that embed the renderer
//! (`examples/render_frame.rs`); the modules behind it stay available for
//! everything it does not cover.

use crate::charts::{self, ChartCache, ChartError, ChartSettings};
use crate::gpu::GpuContext;
use crate::render::objectspace::MAX_DENSITY_SIZE;
use crate::render::{Exposure, PipelineConfig, RenderError, RenderOptions, Renderer};
use crate::scene::lights::LightSetError;
use crate::scene::path::{CameraFileError, SceneCameras};
use crate::scene::{self, Camera, Light, LightSpec, Scene, SceneError};

/// A scene, its cameras and the image size it is rendered at.
#[derive(Clone, Debug)]
pub struct Stage {
    pub scene: Scene,
    /// The camera path, fixed cameras and the file's own cameras
    /// ([`crate::scene::path::cameras_for_scene`]).
    pub cameras: SceneCameras,
    pub width: u32,
    pub height: u32,
    /// MSAA samples per pixel of [`Stage::renderer`]'s renderers (default 1).
    pub samples: u32,
}

/// Why a scene cannot be staged or rendered.
#[derive(Debug, thiserror::Error)]
pub enum StageError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Cameras(#[from] CameraFileError),
    #[error(transparent)]
    Lights(#[from] LightSetError),
    #[error(transparent)]
    Charts(#[from] ChartError),
    #[error(transparent)]
    Render(#[from] RenderError),
}

impl Stage {
    /// Loads `scene` as `--scene` names it (`atrium`, `voxels`, or a path to
    /// a `.gltf`/`.glb`/`.obj` file or a folder of `.obj` files) for images
    /// of `width` x `height`.
    pub fn load(scene: &str, width: u32, height: u32) -> Result<Self, StageError> {
        Self::new(scene, scene::load(scene)?, width, height)
    }

    /// Stages a scene built in code (or loaded and changed); `name` picks
    /// its cameras as [`Stage::load`]'s argument would (`atrium` and
    /// `voxels` orbit, a shared scene's folder reads its `cameras.json`, any
    /// other name is framed automatically).
    pub fn new(name: &str, scene: Scene, width: u32, height: u32) -> Result<Self, StageError> {
        let cameras = scene::path::cameras_for_scene(name, &scene, width as f32 / height.max(1) as f32)?;
        Ok(Self { scene, cameras, width, height, samples: 1 })
    }

    /// The camera of the scene's path (`--camera path`) at `frame`.
    pub fn camera(&self, frame: u32) -> Camera {
        self.cameras.path.camera_at(frame)
    }

    /// The light set `spec` asks for (`LightSpec::Auto`: the scene's
    /// default), placed for the path's first camera with `seed`, as
    /// `--lights` and `--seed` place it.
    pub fn lights(&self, spec: &LightSpec, seed: u64) -> Result<Vec<Light>, StageError> {
        let aspect = self.width as f32 / self.height.max(1) as f32;
        Ok(self.cameras.build_lights(spec, &self.scene.bounds(), &self.camera(0), aspect, seed)?.1)
    }

    /// `--exposure`'s default: automatic for a model seen from outside, 1
    /// for a scene the cameras move through.
    pub fn exposure(&self) -> Exposure {
        if self.cameras.source.seen_from_outside() { Exposure::Auto } else { Exposure::default() }
    }

    /// A renderer of the scene for `pipeline` at the stage's size, with the
    /// default exposure. For object space without texture sizes the scene is
    /// charted first (cached where `SHADESPACE_CACHE_DIR` or the user's cache
    /// folder says), each object's texture sized for the most pixels per
    /// metre it covers along the camera path at the stage's size, as `render
    /// --camera path` sizes it ([`charts::screen`]; a program that renders
    /// from elsewhere charts the scene itself with
    /// [`charts::screen_sizings`] for its cameras).
    pub fn renderer(&self, ctx: &GpuContext, pipeline: PipelineConfig) -> Result<Renderer, StageError> {
        let mut options = RenderOptions { width: self.width, height: self.height, pipeline, samples: self.samples };
        let mut renderer = match &mut options.pipeline {
            PipelineConfig::ObjectSpace(c) if c.texture_sizes.is_empty() => {
                let views = charts::path_cameras(&self.cameras.path);
                let sizings =
                    charts::screen_sizings(&self.scene, &views, self.width, self.height, 64, MAX_DENSITY_SIZE);
                let settings = ChartSettings::default();
                let charts = charts::chart_scene_sized(
                    &self.scene,
                    &sizings,
                    &charts::PACKING_SIZING,
                    &settings,
                    &ChartCache::from_env(),
                )?;
                c.texture_sizes = charts.texture_sizes();
                Renderer::new(ctx, &charts.apply(&self.scene), &options)?
            }
            _ => Renderer::new(ctx, &self.scene, &options)?,
        };
        renderer.exposure = self.exposure();
        Ok(renderer)
    }
}
