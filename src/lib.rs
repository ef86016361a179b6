//! shadespace: a real-time renderer that shades surfaces in object space, and
//! the testbed that measures when that beats conventional shading (forward,
//! multi-pass forward, deferred, tiled deferred in compute, clustered).
//!
//! Data flows one way: [`scene`] (load or generate) -> [`render`] (upload, then
//! per frame: camera + lights -> a pipeline's passes -> HDR target -> tone map)
//! -> image + [`FrameStats`] and per-pass GPU times.
//!
//! # The API
//!
//! The types a program that embeds the renderer needs are re-exported here:
//!
//! - scenes: [`Scene`] (meshes, materials, textures, objects), loaded with
//!   [`scene::load`] (glTF, OBJ, the procedural `atrium` and `voxels`) or built
//!   in code; [`Stage`] loads one with its cameras, default lights and
//!   exposure, and charts it for object space, as `shadespace render` does;
//! - rendering: [`GpuContext`] (adapter and device, [`GpuOptions`]),
//!   [`Renderer`] (one scene, one size, one pipeline) built from
//!   [`RenderOptions`] and a [`PipelineConfig`] (each pipeline's settings;
//!   [`PipelineConfig::from_name`] gives the defaults), [`Exposure`],
//!   [`ShadingModel`]; [`Renderer::render`] returns [`FrameStats`],
//!   [`Renderer::collect_timings`] the GPU time of every pass
//!   ([`FrameTimings`]), [`Renderer::read_image`] the pixels;
//! - lights: [`Light`] and [`LightKind`] (ambient, directional, point, spot),
//!   [`LightSpec`] (`--lights`: `auto`, `studio`, the seeded generated sets,
//!   JSON light files) built by [`scene::lights::build_lights`];
//! - cameras: [`Camera`], [`CameraPath`] (keyed paths, orbits, turntables,
//!   fixed cameras; [`CameraPath::camera_at`] a frame), [`SceneCameras`]
//!   (a scene's path and fixed cameras, [`scene::path::cameras_for_scene`]);
//! - metrics: [`metrics::compare`] (FLIP, PSNR, SSIM between two images).
//!
//! The other modules ([`charts`], [`experiments`], [`bench`](mod@bench), the pipelines
//! under [`render`]) are public for the command line, the tests and the
//! studies; they change more often.
//!
//! # Example
//!
//! One frame of a model, lit and exposed as `shadespace render` would, with
//! each pass's GPU time (`examples/render_frame.rs` is the same as a program):
//!
//! ```no_run
//! use shadespace::{GpuContext, GpuOptions, LightSpec, PipelineConfig, Stage};
//!
//! # fn main() -> anyhow::Result<()> {
//! let stage = Stage::load("tests/data/corpus/duck.glb", 640, 360)?;
//! let lights = stage.lights(&LightSpec::Auto, 1)?; // studio lighting for a model
//! let ctx = GpuContext::new(&GpuOptions::default())?;
//! let mut renderer = stage.renderer(&ctx, PipelineConfig::from_name("objectspace").unwrap())?;
//! renderer.render(&ctx, &stage.camera(0), &lights, 0)?;
//! renderer.read_image(&ctx)?.save("duck.png")?;
//! for frame in renderer.collect_timings(&ctx, true) {
//!     for (pass, ms) in &frame.passes {
//!         println!("{pass}: {ms:.3} ms");
//!     }
//! }
//! # Ok(())
//! # }
//! ```

pub mod bench;
pub mod cache_dir;
pub mod charts;
pub mod color;
pub mod experiments;
pub mod gpu;
pub mod hash;
pub mod materials;
pub mod memo;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod scene;
pub mod shaders;
pub mod stage;
#[cfg(feature = "viewer")]
pub mod viewer;

pub use gpu::timing::FrameTimings;
pub use gpu::{GpuContext, GpuOptions};
pub use render::{Exposure, FrameStats, PipelineConfig, RenderOptions, Renderer, ShadingModel};
pub use scene::path::SceneCameras;
pub use scene::{Aabb, Camera, CameraPath, Light, LightKind, LightSpec, Scene};
pub use stage::{Stage, StageError};
