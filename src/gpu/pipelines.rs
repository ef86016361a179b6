//! Pipelines a device has built, kept for the life of its
//! [`GpuContext`](super::GpuContext).
//!
//! A renderer builds a few dozen pipelines, and programs that build
//! many renderers on one device (an experiment, one per cell of its grid;
//! the viewer, one per switch of pipeline or option; the tests, several per
//! scene) would otherwise compile the same ones again each time: on a CPU
//! driver that was about half of building an object-space renderer. The key
//! is the composed shader (its library, source and definitions), the entry
//! points, the number of bind groups and, for raster pipelines, their fixed
//! state, given by the caller (`ShaderLibrary::pipeline`, from
//! `render::passes::compute_pipeline_with` and `raster_pipeline`). The bind-group layouts are not
//! in the key: an entry point's layouts follow from its WGSL declarations,
//! and wgpu pools layouts of equal entries, so a later renderer's layouts are
//! the cached pipeline's own (a pass that bound one entry point through
//! layouts of different entries would fail wgpu's validation in the tests).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The pipelines of one device, shared by the clones of its context.
#[derive(Clone, Default)]
pub struct PipelineCache {
    compute: Arc<Mutex<HashMap<u64, wgpu::ComputePipeline>>>,
    raster: Arc<Mutex<HashMap<u64, wgpu::RenderPipeline>>>,
}

/// A pipeline kind the cache keeps.
pub trait Cached: Clone {
    /// Its map in `cache`.
    fn map(cache: &PipelineCache) -> &Mutex<HashMap<u64, Self>>;
}

impl Cached for wgpu::ComputePipeline {
    fn map(cache: &PipelineCache) -> &Mutex<HashMap<u64, Self>> {
        &cache.compute
    }
}

impl Cached for wgpu::RenderPipeline {
    fn map(cache: &PipelineCache) -> &Mutex<HashMap<u64, Self>> {
        &cache.raster
    }
}

impl PipelineCache {
    /// The pipeline cached under `key`, or the one `build` makes (cached if
    /// it succeeds).
    pub fn get_or_build<P: Cached, E>(&self, key: u64, build: impl FnOnce() -> Result<P, E>) -> Result<P, E> {
        let map = || P::map(self).lock().unwrap_or_else(|e| e.into_inner());
        if let Some(pipeline) = map().get(&key) {
            return Ok(pipeline.clone());
        }
        // Built outside the lock: another thread building the same pipeline
        // meanwhile costs a compile, not a wait.
        let pipeline = build()?;
        map().entry(key).or_insert(pipeline.clone());
        Ok(pipeline)
    }

    /// How many pipelines are kept (compute and raster).
    pub fn len(&self) -> usize {
        let compute = self.compute.lock().unwrap_or_else(|e| e.into_inner()).len();
        compute + self.raster.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Whether no pipeline is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
