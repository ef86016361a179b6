// The hardware raster passes' cluster draws (`passes::cluster_draws`): with
// cluster culling, a scene raster pass draws the clusters that `cull.wgsl`
// listed. With INDEXED_DRAWS, one indexed draw per cluster of its range of
// the cluster-ordered index buffer, its first instance the cluster's entry
// of the list; else one instanced draw per list: an instance per listed
// cluster, three vertices for each of its up to CLUSTER_TRIANGLES triangles.
// `scene_vertex` maps (vertex index, instance index) to the scene's vertex
// and object, in every pass the same way (so depths compare equal bit for
// bit); without CLUSTER_DRAW it is the plain draw's (the vertex index
// already holds the base vertex, the instance index is the object).
#define_import_path shadespace::cluster_draws
#ifdef CLUSTER_DRAW
#import shadespace::scene_bindings::{objects, indices}
#import shadespace::scene::Object
#endif

struct SceneVertex {
    // Index into the scene's vertices.
    vertex: u32,
    object: u32,
    // Cluster draws only (a plain draw's fragment takes `primitive_index`):
    // its triangle among its mesh's (the visibility ids), or with
    // INDEXED_DRAWS its cluster's first entry of `cluster_triangles`
    // (`drawn_triangle` turns it into the triangle).
    triangle: u32,
}

#ifdef CLUSTER_DRAW
// Mirrors `clusters::GpuCluster`.
struct Cluster {
    min: vec3f,
    first: u32,
    max: vec3f,
    count: u32,
    center: vec3f,
    radius: f32,
    cone_axis: vec3f,
    cone_cutoff: f32,
}

// Mirrors `cluster_draws::CLUSTER_DRAW_GROUP` and `CLUSTER_TRIANGLES`.
const TRIANGLES: u32 = 64u;

// First entry of the drawn list in `cluster_lists`.
@group(2) @binding(0) var<uniform> list_base: vec4u;
// Per visible object: (object, ...), as `cull.wgsl` reads them.
@group(2) @binding(1) var<storage, read> ranges: array<vec4u>;
// `cull.wgsl`'s lists of (entry of `ranges`, cluster).
@group(2) @binding(2) var<storage, read> cluster_lists: array<vec2u>;
@group(2) @binding(3) var<storage, read> clusters: array<Cluster>;
// The clusters' triangles (indices of their mesh's triangles).
@group(2) @binding(4) var<storage, read> cluster_triangles: array<u32>;

// Whether `o` is drawn by another pipeline's cull mode: in scenes with both
// single- and double-sided objects, every list is drawn with a pipeline of
// each (`passes::ScenePipeline`), defined SINGLE_SIDED_DRAW or
// DOUBLE_SIDED_DRAW, and each skips the other's objects.
fn other_sides(o: Object) -> bool {
#ifdef SINGLE_SIDED_DRAW
    return o.cull_back == 0u;
#else
#ifdef DOUBLE_SIDED_DRAW
    return o.cull_back != 0u;
#else
    return false;
#endif
#endif
}

#ifdef INDEXED_DRAWS
fn scene_vertex(vertex_index: u32, instance_index: u32) -> SceneVertex {
    // The draw's index range is a run of the object's clusters (the first
    // at `instance_index`); its base vertex the object's.
    let entry = cluster_lists[instance_index];
    let object = ranges[entry.x].x;
    // Another pipeline's object: every corner on its mesh's first vertex
    // (zero area, no fragment).
    if other_sides(objects[object]) {
        return SceneVertex(objects[object].base_vertex, object, clusters[entry.y].first);
    }
    return SceneVertex(vertex_index, object, clusters[entry.y].first);
}

// The mesh's triangle of a fragment: `triangle` from `scene_vertex`,
// `primitive` its `primitive_index` (counted from the draw's first index).
fn drawn_triangle(triangle: u32, primitive: u32) -> u32 {
    return cluster_triangles[triangle + primitive];
}
#else
fn scene_vertex(vertex_index: u32, instance_index: u32) -> SceneVertex {
    let entry = cluster_lists[list_base.x + instance_index];
    let object = ranges[entry.x].x;
    let c = clusters[entry.y];
    let o = objects[object];
    let t = vertex_index / 3u;
    // The passes draw opaque and alpha-masked objects (and single- and
    // double-sided ones) with pipelines of their own
    // (`passes::ScenePipeline`); the list holds all.
#ifdef ALPHA_MASK
    let drawn = o.alpha_cutoff > 0.0;
#else
    let drawn = !(o.alpha_cutoff > 0.0);
#endif
    // Past the cluster's triangles, or another pipeline's object: the first
    // corner of its first triangle, three times (zero area, no fragment).
    let kept = drawn && !other_sides(o) && t < c.count;
    let local = select(0u, t, kept);
    let corner = select(0u, vertex_index % 3u, kept);
    let triangle = cluster_triangles[c.first + local];
    let vertex = indices[o.first_index + 3u * triangle + corner] + o.base_vertex;
    return SceneVertex(vertex, object, triangle);
}

fn drawn_triangle(triangle: u32, primitive: u32) -> u32 {
    return triangle;
}
#endif
#else
fn scene_vertex(vertex_index: u32, instance_index: u32) -> SceneVertex {
    return SceneVertex(vertex_index, instance_index, 0u);
}
#endif
