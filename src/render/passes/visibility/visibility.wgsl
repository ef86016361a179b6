// Visibility pass: rasterize the scene with depth and write, per pixel, the
// object (+1) and the triangle. No shading: later compute passes rebuild
// everything else from these ids. After a depth pre-pass it tests `Equal`.
enable primitive_index;
#import shadespace::scene_bindings::object_clip_position
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
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> VertexOut {
    var out: VertexOut;
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
    return vec2u(in.object + 1u, triangle);
}
