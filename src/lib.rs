//! shadespace: a real-time renderer that shades surfaces in object space, and
//! the testbed that measures when that beats conventional shading (forward
//! today; deferred and clustered baselines are planned).
//!
//! Data flows one way: [`scene`] (load or generate) -> [`render`] (upload, then
//! per frame: views + lights -> a pipeline's passes -> HDR target -> tone map)
//! -> image + [`bench::RunReport`].

pub mod bench;
pub mod charts;
pub mod color;
pub mod experiments;
pub mod gpu;
pub mod hash;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod scene;
pub mod shaders;
#[cfg(feature = "viewer")]
pub mod viewer;
