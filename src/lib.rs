//! shadespace: a real-time renderer that shades surfaces in object space, and
//! the testbed that compares it with forward, deferred and clustered shading.
//!
//! Data flows one way: [`scene`] (load or generate) -> [`render`] (upload, then
//! per frame: views + lights -> a pipeline's passes -> HDR target -> tone map)
//! -> image + [`render::FrameStats`].

pub mod bench;
pub mod charts;
pub mod gpu;
pub mod metrics;
pub mod render;
pub mod scene;
pub mod shaders;
