//! What a pipeline reports, in one shape for every pipeline: its settings,
//! the GPU memory it holds, facts about its setup, and per-frame counters.
//! `render --stats` and `bench` both write it inside a
//! [`crate::bench::RunReport`].

use std::collections::BTreeMap;

use serde::Serialize;

use super::PipelineConfig;

/// Named per-frame counters (for object space: tiles visible, shaded, new,
/// texels per pixel), as the pipeline counted them on the GPU.
pub type Counters = BTreeMap<String, f64>;

/// A pipeline's settings and what it holds.
#[derive(Clone, Debug, Serialize)]
pub struct PipelineReport {
    /// The pipeline (`name`) and its settings.
    pub config: PipelineConfig,
    /// GPU memory the pipeline holds besides the scene and the render
    /// targets, in bytes per resource.
    pub memory: BTreeMap<String, u64>,
    /// Sum of `memory`.
    pub memory_total: u64,
    /// Facts about how the pipeline set itself up (for object space: atlas
    /// pages, page size, tiles, budget halvings).
    pub setup: BTreeMap<String, u64>,
    /// Per object, for pipelines that hold per-object resources (the
    /// object-space atlas); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub objects: Vec<ObjectMemory>,
}

impl PipelineReport {
    /// A report holding nothing yet.
    pub fn new(config: PipelineConfig) -> Self {
        Self { config, memory: BTreeMap::new(), memory_total: 0, setup: BTreeMap::new(), objects: Vec::new() }
    }

    /// Adds a resource of `bytes` to the memory table.
    pub fn memory(mut self, name: &str, bytes: u64) -> Self {
        self.memory.insert(name.to_string(), bytes);
        self.memory_total = self.memory.values().sum();
        self
    }

    /// Adds a setup fact.
    pub fn setup(mut self, name: &str, value: u64) -> Self {
        self.setup.insert(name.to_string(), value);
        self
    }
}

/// One object's share of a pipeline's per-object resources.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectMemory {
    pub object: usize,
    /// Mip-0 side of its virtual shading texture, in texels.
    pub texture_size: u32,
    pub levels: u32,
    /// Virtual texels, tiles and pages (mip chain included).
    pub texels: u64,
    pub tiles: u64,
    pub pages: u64,
}
