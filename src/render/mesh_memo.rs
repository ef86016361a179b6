//! What the renderer derives from a mesh's triangles (chart islands,
//! clusters), remembered by the mesh's content for the rest of the process.
//!
//! Every renderer uploads its scene ([`super::scene_gpu::SceneGpu::new`]),
//! and programs that build many renderers of one scene (the viewer, one per
//! switch of pipeline or option; experiments, one per cell; the tests)
//! derived the same islands and clusters each time: a sixth of a viewer
//! switch on a CPU driver. The key hashes the data the derivation reads, so
//! a changed mesh is derived again.

use std::collections::HashMap;
use std::sync::{Arc, LazyLock, Mutex};

use glam::{Vec2, Vec3};

use super::clusters::{self, MeshClusters};
use crate::charts::islands::triangle_islands;
use crate::hash::Fnv1a;

/// Meshes remembered at most per kind: a process that loads scene after
/// scene forgets them all past it rather than grow without bound.
const CAPACITY: usize = 1024;

type Memo<T> = LazyLock<Mutex<HashMap<u64, Arc<T>>>>;

static ISLANDS: Memo<Vec<u32>> = LazyLock::new(Default::default);
static CLUSTERS: Memo<MeshClusters> = LazyLock::new(Default::default);

fn remembered<T>(memo: &Memo<T>, key: u64, derive: impl FnOnce() -> T) -> Arc<T> {
    let lock = || memo.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(value) = lock().get(&key) {
        return value.clone();
    }
    let value = Arc::new(derive());
    let mut map = lock();
    if map.len() >= CAPACITY {
        map.clear();
    }
    map.insert(key, value.clone());
    value
}

/// The chart island of every triangle of `indices` over `uv`
/// ([`triangle_islands`]).
pub fn islands(indices: &[u32], uv: &[Vec2]) -> Arc<Vec<u32>> {
    let mut h = Fnv1a::default();
    h.write_pod(indices);
    h.write_pod(uv);
    remembered(&ISLANDS, h.finish(), || triangle_islands(indices, uv))
}

/// The clusters of `indices` over `positions` ([`clusters::build`]).
pub fn clusters(positions: &[Vec3], indices: &[u32]) -> Arc<MeshClusters> {
    let mut h = Fnv1a::default();
    h.write_pod(indices);
    h.write_pod(positions);
    remembered(&CLUSTERS, h.finish(), || clusters::build(positions, indices))
}
