//! Mesh clusters for GPU culling: each mesh's triangles grouped into
//! clusters of at most [`CLUSTER_TRIANGLES`], each with an object-space box,
//! a bounding sphere and a normal cone, built once per mesh when the scene is
//! put on the GPU. The compute rasterizer culls them per frame
//! (`passes/visibility/cull.wgsl`); the CPU twins of its frustum and cone
//! tests live here.
//!
//! Why a clusterizer of our own rather than `meshopt` (meshoptimizer's
//! bindings): a meshlet there is a new local vertex list and re-indexed
//! triangles, so the triangle ids the visibility buffer holds (and object
//! space's triangle-index maps and charts are keyed by) would change or need
//! a reverse lookup; and its C++ build adds about 7.5 s (debug, on this
//! project's 2-core CI) to a suite with 20 s of margin. Here a cluster is a
//! list of the mesh's own triangle indices (`MeshClusters::triangles`), so
//! culling changes which triangles are drawn, never their ids. Grouping:
//! triangles sorted by the dominant axis and sign of their normal (six
//! classes, so cones stay under about 55 degrees), then by the Morton code of
//! their centroid, cut into runs of [`CLUSTER_TRIANGLES`] that never straddle
//! two classes.

use std::str::FromStr;

use glam::{Mat4, Vec3, Vec4};
use serde::Serialize;

use crate::shaders::gpu_struct;

/// How the compute rasterizer culls the scene's clusters (`--culling`).
/// Objects outside the view frustum are skipped on the CPU in every mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Culling {
    /// Every triangle of every object in view is rasterized.
    #[default]
    None,
    /// Clusters outside the frustum, and under back-face culling those whose
    /// normal cone faces away, are skipped (GPU).
    Frustum,
    /// [`Culling::Frustum`], then two-pass occlusion: the clusters visible
    /// last frame are drawn, a depth pyramid is built from them, the rest
    /// are tested against it and the newly visible drawn.
    Occlusion,
}

/// Objects from which a scene is culled by occlusion by default
/// ([`Culling::for_scene`]).
pub const OCCLUSION_OBJECTS: usize = 64;

impl Culling {
    pub const ALL: [Self; 3] = [Self::None, Self::Frustum, Self::Occlusion];

    /// The default for a scene of `objects` objects (instances): two-pass
    /// occlusion where there are many to hide one another, none where there
    /// are few. On the H200 at 1920x1080 (BENCHMARKS.md, "Cluster culling"),
    /// occlusion took the city's street-path visibility from 1.98 to 0.57
    /// ms, but Sponza's (15 objects, seen from inside, few clusters hidden)
    /// from 0.67 to 0.76 ms; frustum culling alone cost 0.01-0.1 ms more
    /// than none on every path.
    pub fn for_scene(objects: usize) -> Self {
        if objects >= OCCLUSION_OBJECTS { Self::Occlusion } else { Self::None }
    }

    /// The name `--culling` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Frustum => "frustum",
            Self::Occlusion => "occlusion",
        }
    }
}

impl FromStr for Culling {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| format!("'{s}' is not none, frustum or occlusion"))
    }
}

/// The default of `--cull-plain-above`: the hardware raster passes draw the
/// plain way (every object in view, one instanced draw per run of a mesh's
/// instances) in a frame after one whose culling kept more than this share
/// of the clusters it tested. On the H200 at 1920x1080 (BENCHMARKS.md,
/// "Indexed cluster draws") the culled draws cost 1.38 times the plain
/// ones per cluster drawn on the city's fly-over (89 % kept: 64.8 against
/// 52.8 ms of raster passes), so they pay below 72 % kept; Sponza, whose
/// passes are bound by its pixels, not its triangles, kept 68 % and was
/// 4-10 % slower culled. 0.6 stays under both.
pub const CULL_PLAIN_ABOVE: f32 = 0.6;

/// How the hardware raster passes draw the clusters that culling keeps
/// (`--cluster-draws`; `passes::cluster_draws`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ClusterDraws {
    /// One indexed indirect draw per surviving cluster, of its range of the
    /// scene's cluster-ordered index buffer (vertices shared within the
    /// cluster), counted on the GPU (`multi_draw_indexed_indirect_count`).
    /// Needs `INDIRECT_FIRST_INSTANCE` and `MULTI_DRAW_INDIRECT_COUNT`;
    /// without them the renderer draws [`ClusterDraws::List`].
    #[default]
    Indexed,
    /// One instanced, non-indexed draw per list: an instance per cluster of
    /// 64 triangle slots, three vertex invocations per triangle, unused
    /// slots zero-area (the draws before indexed ones; kept to compare).
    List,
}

impl ClusterDraws {
    pub const ALL: [Self; 2] = [Self::Indexed, Self::List];

    /// The name `--cluster-draws` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Indexed => "indexed",
            Self::List => "list",
        }
    }
}

impl FromStr for ClusterDraws {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|c| c.name() == s).ok_or_else(|| format!("'{s}' is not indexed or list"))
    }
}

gpu_struct! {
    /// A [`Cluster`] as `cull.wgsl` and `raster.wgsl` read it (`Cluster`).
    pub struct GpuCluster as "Cluster" {
        pub min: Vec3,
        /// First entry of the scene's cluster triangle list.
        pub first: u32,
        pub max: Vec3,
        pub count: u32,
        pub center: Vec3,
        pub radius: f32,
        pub cone_axis: Vec3,
        pub cone_cutoff: f32,
    }
}

impl GpuCluster {
    /// `c` with its triangles starting at `first` of the scene's list.
    pub fn new(c: &Cluster, first: u32) -> Self {
        Self {
            min: c.min,
            first,
            max: c.max,
            count: c.count,
            center: c.center,
            radius: c.radius,
            cone_axis: c.cone_axis,
            cone_cutoff: c.cone_cutoff,
        }
    }
}

/// Most triangles of a cluster: one workgroup of the compute rasterizer
/// (`RASTER_WORKGROUP`) rasterizes one cluster, a triangle per thread.
pub const CLUSTER_TRIANGLES: usize = 64;

/// Added to a cluster's cone cutoff in the back-face test: the rasterizer
/// decides facing from rounded clip-space positions, so a triangle seen
/// nearly edge-on may come out front-facing; only cones back-facing by a
/// margin of about half a degree are culled.
pub const CONE_MARGIN: f32 = 0.01;

/// A cluster of one mesh (object space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    pub min: Vec3,
    pub max: Vec3,
    /// Bounding sphere: the box's centre and the farthest vertex from it.
    pub center: Vec3,
    pub radius: f32,
    /// Mean direction of the triangles' unit normals.
    pub cone_axis: Vec3,
    /// Sine of the largest angle between a triangle's normal and the axis;
    /// above 1 (no cone) when a normal is 90 degrees or more off the axis or
    /// a triangle is degenerate.
    pub cone_cutoff: f32,
    /// Its triangles: `MeshClusters::triangles[first .. first + count]`.
    pub first: u32,
    pub count: u32,
}

/// Cutoff of a cluster with no usable normal cone (never culled by it).
pub const NO_CONE: f32 = 2.0;

/// A mesh's clusters and their triangles (indices of the mesh's triangles,
/// cluster by cluster).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshClusters {
    pub clusters: Vec<Cluster>,
    pub triangles: Vec<u32>,
}

/// Clusters of the triangle list `indices` over `positions` (every triangle
/// in exactly one cluster).
pub fn build(positions: &[Vec3], indices: &[u32]) -> MeshClusters {
    let triangles = indices.len() / 3;
    let corners = |t: usize| [0, 1, 2].map(|k| positions[indices[3 * t + k] as usize]);
    let (lo, hi) =
        positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let scale = (hi - lo).max(Vec3::splat(1e-30));
    let mut keyed: Vec<(u64, u32)> = (0..triangles)
        .map(|t| {
            let [a, b, c] = corners(t);
            let n = (b - a).cross(c - a);
            let cell = ((a + b + c) / 3.0 - lo) / scale * 1023.0;
            let q = cell.clamp(Vec3::ZERO, Vec3::splat(1023.0)).as_uvec3();
            ((u64::from(normal_class(n)) << 32) | u64::from(morton3(q.x, q.y, q.z)), t as u32)
        })
        .collect();
    keyed.sort_unstable();
    let mut out = MeshClusters { clusters: Vec::new(), triangles: Vec::with_capacity(triangles) };
    let mut start = 0;
    while start < keyed.len() {
        let class = keyed[start].0 >> 32;
        let mut end = start + 1;
        while end < keyed.len() && end - start < CLUSTER_TRIANGLES && keyed[end].0 >> 32 == class {
            end += 1;
        }
        let members: Vec<u32> = keyed[start..end].iter().map(|&(_, t)| t).collect();
        out.clusters.push(cluster_of(&members, out.triangles.len() as u32, &corners));
        out.triangles.extend_from_slice(&members);
        start = end;
    }
    out
}

/// 0-5: the dominant axis of `n` and its sign; 6: degenerate.
fn normal_class(n: Vec3) -> u32 {
    let a = n.abs();
    // NaN (a non-finite vertex) counts as degenerate too.
    if a.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return 6;
    }
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + u32::from(n[axis as usize] < 0.0)
}

/// Interleaves the low 10 bits of x, y and z.
fn morton3(x: u32, y: u32, z: u32) -> u32 {
    let spread = |v: u32| {
        let mut v = v & 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    };
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

fn cluster_of(members: &[u32], first: u32, corners: &impl Fn(usize) -> [Vec3; 3]) -> Cluster {
    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    let mut normals = Vec::with_capacity(members.len());
    let mut degenerate = false;
    for &t in members {
        let [a, b, c] = corners(t as usize);
        min = min.min(a).min(b).min(c);
        max = max.max(a).max(b).max(c);
        let n = (b - a).cross(c - a);
        let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
        // A sliver's normal is mostly rounding: its facing is not known. The
        // corners' rounding, relative to their distance from the origin,
        // moves the normal by about that times the longest edge.
        let rounding = 8.0 * f32::EPSILON * a.abs().max(b.abs()).max(c.abs()).max_element() * longest.sqrt();
        if n.length().partial_cmp(&(1e-6 * longest + rounding)) != Some(std::cmp::Ordering::Greater) {
            degenerate = true;
        }
        normals.push(n.normalize_or_zero());
    }
    let center = 0.5 * (min + max);
    let radius = members.iter().flat_map(|&t| corners(t as usize)).map(|p| p.distance(center)).fold(0.0f32, f32::max);
    let axis = normals.iter().sum::<Vec3>().normalize_or_zero();
    let min_dot = normals.iter().map(|n| n.dot(axis)).fold(1.0f32, f32::min);
    let cone_cutoff = if degenerate || axis == Vec3::ZERO || min_dot <= 0.0 {
        NO_CONE
    } else {
        (1.0 - min_dot * min_dot).max(0.0).sqrt()
    };
    Cluster { min, max, center, radius, cone_axis: axis, cone_cutoff, first, count: members.len() as u32 }
}

impl Cluster {
    /// Whether every triangle faces away from a camera at `eye` (object
    /// space of a transform with positive determinant): the eye sees every
    /// point of the bounding sphere from behind every normal of the cone
    /// (meshoptimizer's sphere-cone test), with [`CONE_MARGIN`]. The GPU's
    /// `backfacing` in `cull.wgsl` is its twin.
    pub fn backfacing(&self, eye: Vec3) -> bool {
        let d = self.center - eye;
        d.dot(self.cone_axis) > (self.cone_cutoff + CONE_MARGIN) * d.length() + self.radius
    }

    /// Whether the box lies wholly outside one clip plane of
    /// `view_proj * model` (wgpu clip space, `0 <= z <= w`). The GPU's
    /// `outside_frustum` in `cull.wgsl` is its twin.
    pub fn outside_frustum(&self, model_view_proj: Mat4) -> bool {
        let clip: Vec<Vec4> = (0..8)
            .map(|i| {
                let p = Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), self.max, self.min);
                model_view_proj * p.extend(1.0)
            })
            .collect();
        let all = |f: &dyn Fn(Vec4) -> bool| clip.iter().all(|c| f(*c));
        all(&|c| c.x < -c.w)
            || all(&|c| c.x > c.w)
            || all(&|c| c.y < -c.w)
            || all(&|c| c.y > c.w)
            || all(&|c| c.z < 0.0)
            || all(&|c| c.z > c.w)
    }
}

/// Whether the triangle `a, b, c` (counter-clockwise seen from its front)
/// faces away from `eye`: what back-face culling removes.
pub fn triangle_backfacing(a: Vec3, b: Vec3, c: Vec3, eye: Vec3) -> bool {
    (b - a).cross(c - a).dot(a - eye) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere-ish mesh: a UV sphere of radius 1 with `n` rings.
    fn sphere(n: u32) -> (Vec<Vec3>, Vec<u32>) {
        let mut positions = Vec::new();
        for i in 0..=n {
            let theta = std::f32::consts::PI * i as f32 / n as f32;
            for j in 0..=2 * n {
                let phi = std::f32::consts::PI * j as f32 / n as f32;
                positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
            }
        }
        let row = 2 * n + 1;
        let mut indices = Vec::new();
        for i in 0..n {
            for j in 0..2 * n {
                let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j, (i + 1) * row + j + 1);
                // Counter-clockwise seen from outside.
                indices.extend([a, b, c, b, d, c]);
            }
        }
        (positions, indices)
    }

    #[test]
    fn every_triangle_is_in_one_cluster_of_at_most_the_limit() {
        let (positions, indices) = sphere(24);
        let mc = build(&positions, &indices);
        let mut seen = mc.triangles.clone();
        seen.sort();
        assert_eq!(seen, (0..indices.len() as u32 / 3).collect::<Vec<_>>());
        let mut next = 0;
        for c in &mc.clusters {
            assert_eq!(c.first, next);
            assert!(c.count >= 1 && c.count as usize <= CLUSTER_TRIANGLES);
            next += c.count;
            for &t in &mc.triangles[c.first as usize..(c.first + c.count) as usize] {
                for k in 0..3 {
                    let p = positions[indices[3 * t as usize + k] as usize];
                    assert!(p.cmpge(c.min).all() && p.cmple(c.max).all());
                    assert!(p.distance(c.center) <= c.radius * 1.0001);
                }
            }
        }
    }

    /// The CPU twin of the cone test never culls a cluster holding a
    /// triangle that faces the eye, and does cull some from eyes inside and
    /// around the sphere (its far side).
    #[test]
    fn cone_test_culls_only_clusters_wholly_facing_away() {
        let (positions, indices) = sphere(24);
        let mc = build(&positions, &indices);
        let mut culled = 0;
        let eyes = [Vec3::ZERO, Vec3::new(0.0, 0.0, 3.0), Vec3::new(2.0, 1.5, -1.0), Vec3::new(0.0, -5.0, 0.2)];
        for eye in eyes {
            for c in &mc.clusters {
                if !c.backfacing(eye) {
                    continue;
                }
                culled += 1;
                for &t in &mc.triangles[c.first as usize..(c.first + c.count) as usize] {
                    let [a, b, cc] = [0, 1, 2].map(|k| positions[indices[3 * t as usize + k] as usize]);
                    assert!(triangle_backfacing(a, b, cc, eye), "cluster culled with a front face toward {eye}");
                }
            }
        }
        assert!(culled > 0, "no cluster culled");
    }

    /// Clusters of mixed facing: a crumpled sheet of triangles with normals
    /// scattered over every direction (so each cluster's cone is as wide as
    /// its normal class allows), back-to-back twins (a leaf seen from both
    /// sides) and slivers. From eyes all around and inside it, no culled
    /// cluster holds a triangle that faces the eye, and a cluster holding a
    /// sliver has no cone.
    #[test]
    fn cone_test_never_culls_a_front_face_of_a_mixed_cluster() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        let mut slivers = Vec::new();
        for t in 0..2000u32 {
            let centre =
                Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let mut corner = || centre + 0.1 * Vec3::new(rng.random(), rng.random(), rng.random()) - Vec3::splat(0.05);
            let [a, b, c] = if t % 50 == 0 {
                // A sliver: its third corner on the first edge.
                let (a, b) = (corner(), corner());
                [a, b, a.lerp(b, 0.5)]
            } else {
                [corner(), corner(), corner()]
            };
            if t % 50 == 0 {
                slivers.push(indices.len() as u32 / 3);
            }
            let first = positions.len() as u32;
            positions.extend([a, b, c]);
            indices.extend([first, first + 1, first + 2]);
            if t % 7 == 0 {
                // Its back-to-back twin, at the same place.
                indices.extend([first, first + 2, first + 1]);
            }
        }
        let mc = build(&positions, &indices);
        let members = |c: &Cluster| &mc.triangles[c.first as usize..(c.first + c.count) as usize];
        let with_sliver: Vec<&Cluster> =
            mc.clusters.iter().filter(|c| members(c).iter().any(|t| slivers.contains(t))).collect();
        assert!(!with_sliver.is_empty());
        for c in with_sliver {
            assert_eq!(c.cone_cutoff, NO_CONE, "a cluster with a sliver has a cone");
        }
        let corners = |t: u32| [0, 1, 2].map(|k| positions[indices[3 * t as usize + k] as usize]);
        let mut culled = 0;
        for e in 0..64 {
            let eye = if e == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0))
            };
            for c in mc.clusters.iter().filter(|c| c.backfacing(eye)) {
                culled += 1;
                for &t in members(c) {
                    let [a, b, cc] = corners(t);
                    assert!(triangle_backfacing(a, b, cc, eye), "mixed cluster culled with a front face toward {eye}");
                }
            }
        }
        assert!(culled > 0, "no cluster culled: the test would not see a wrong cull");
    }

    /// The CPU twin of the frustum test keeps every cluster a vertex of
    /// which is inside the view volume and culls those behind the camera.
    #[test]
    fn frustum_test_keeps_clusters_with_a_visible_vertex() {
        let (positions, indices) = sphere(16);
        let mc = build(&positions, &indices);
        let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
        let model = Mat4::from_translation(Vec3::new(0.8, 0.0, -2.0));
        let mvp = proj * model;
        let (mut kept, mut culled) = (0, 0);
        for c in &mc.clusters {
            let tris = &mc.triangles[c.first as usize..(c.first + c.count) as usize];
            let indices = &indices;
            let visible_vertex = tris.iter().flat_map(|&t| (0..3).map(move |k| indices[3 * t as usize + k])).any(|v| {
                let q = mvp * positions[v as usize].extend(1.0);
                q.x.abs() <= q.w && q.y.abs() <= q.w && q.z >= 0.0 && q.z <= q.w
            });
            if c.outside_frustum(mvp) {
                culled += 1;
                assert!(!visible_vertex, "a cluster with a vertex in view was culled");
            } else {
                kept += 1;
            }
        }
        assert!(kept > 0 && culled > 0, "kept {kept}, culled {culled}");
    }
}
