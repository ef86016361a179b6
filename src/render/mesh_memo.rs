//! What the renderer derives from a mesh's triangles (chart islands,
//! clusters), remembered by the mesh's content ([`crate::memo`]): every
//! renderer uploads its scene ([`super::scene_gpu::SceneGpu::new`]).

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::clusters::{self, MeshClusters};
use crate::charts::islands::triangle_islands;
use crate::hash::Fnv1a;
use crate::memo::Memo;

/// Meshes remembered at most per kind.
const CAPACITY: usize = 1024;

static ISLANDS: Memo<Vec<u32>> = Memo::new(CAPACITY, |_| 1);
static CLUSTERS: Memo<MeshClusters> = Memo::new(CAPACITY, |_| 1);

/// The chart island of every triangle of `indices` over `uv`
/// ([`triangle_islands`]).
pub fn islands(indices: &[u32], uv: &[Vec2]) -> Arc<Vec<u32>> {
    let mut h = Fnv1a::default();
    h.write_pod(indices);
    h.write_pod(uv);
    ISLANDS.get(h.finish(), || triangle_islands(indices, uv))
}

/// The clusters of `indices` over `positions` ([`clusters::build`]).
pub fn clusters(positions: &[Vec3], indices: &[u32]) -> Arc<MeshClusters> {
    let mut h = Fnv1a::default();
    h.write_pod(indices);
    h.write_pod(positions);
    CLUSTERS.get(h.finish(), || clusters::build(positions, indices))
}
