// Visibility pass: rasterize the scene with depth and write, per pixel, the
// object (+1) and the triangle. No shading: later compute passes rebuild
// everything else from these ids. After a depth pre-pass it tests `Equal`.
enable primitive_index;
#import shadespace::scene_bindings::object_clip_position
#import shadespace::cluster_draws::scene_vertex
#ifdef CLUSTER_DRAW
#import shadespace::cluster_draws::drawn_triangle
#endif
#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::vertices
#endif

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) @interpolate(flat) object: u32,
#ifdef ALPHA_MASK
    @location(1) uv0: vec2f,
#endif
#ifdef CLUSTER_DRAW
    // `SceneVertex::triangle` (a cluster draw's `primitive_index` counts
    // the list's triangle slots or the cluster's triangles).
    @location(2) @interpolate(flat) triangle: u32,
#endif
}

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let d = scene_vertex(vertex_index, instance_index);
    let vi = d.vertex;
    let object = d.object;
    var out: VertexOut;
#ifdef CLUSTER_DRAW
    out.triangle = d.triangle;
#endif
    out.clip = object_clip_position(object, vi);
    out.object = object;
#ifdef ALPHA_MASK
    out.uv0 = vertex_uv0(vertices[vi]);
#endif
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(primitive_index) triangle: u32) -> @location(0) vec2u {
#ifdef ALPHA_MASK
    if masked_out(in.object, in.uv0) {
        discard;
    }
#endif
#ifdef CLUSTER_DRAW
    return vec2u(in.object + 1u, drawn_triangle(in.triangle, triangle));
#else
    return vec2u(in.object + 1u, triangle);
#endif
}
