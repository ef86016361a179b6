//! Compute pipelines a device has built, kept for the life of its
//! [`GpuContext`](super::GpuContext).
//!
//! A renderer builds a few dozen compute pipelines, and programs that build
//! many renderers on one device (an experiment, one per cell of its grid;
//! the viewer, one per switch of pipeline or option; the tests, several per
//! scene) would otherwise compile the same ones again each time: on a CPU
//! driver that was about half of building an object-space renderer. The key
//! is the composed shader (its library, source and definitions), the entry
//! point and the number of bind groups, given by the caller
//! (`render::passes::compute_pipeline_with`). The bind-group layouts are not
//! in the key: an entry point's layouts follow from its WGSL declarations,
//! and wgpu pools layouts of equal entries, so a later renderer's layouts are
//! the cached pipeline's own (a pass that bound one entry point through
//! layouts of different entries would fail wgpu's validation in the tests).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The compute pipelines of one device, shared by the clones of its context.
#[derive(Clone, Default)]
pub struct PipelineCache {
    pipelines: Arc<Mutex<HashMap<u64, wgpu::ComputePipeline>>>,
}

impl PipelineCache {
    /// The pipeline cached under `key`, or the one `build` makes (cached if
    /// it succeeds).
    pub fn compute<E>(
        &self,
        key: u64,
        build: impl FnOnce() -> Result<wgpu::ComputePipeline, E>,
    ) -> Result<wgpu::ComputePipeline, E> {
        if let Some(pipeline) = self.lock().get(&key) {
            return Ok(pipeline.clone());
        }
        // Built outside the lock: another thread building the same pipeline
        // meanwhile costs a compile, not a wait.
        let pipeline = build()?;
        self.lock().entry(key).or_insert(pipeline.clone());
        Ok(pipeline)
    }

    /// How many pipelines are kept.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Whether no pipeline is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<u64, wgpu::ComputePipeline>> {
        self.pipelines.lock().unwrap_or_else(|e| e.into_inner())
    }
}
