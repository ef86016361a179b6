// Depth pre-pass: the scene's depth only, so that a later pass over the same
// objects (testing `Equal`) runs one fragment per pixel. Both passes take
// their positions from `object_clip_position` with `@invariant`, so equal
// depths compare equal bit for bit.
#import shadespace::scene_bindings::object_clip_position
#import shadespace::cluster_draws::scene_vertex

#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::vertices

// The alpha-masked objects' variant: a fragment stage cuts their depth.
struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) uv0: vec2f,
    @location(1) @interpolate(flat) object: u32,
}

@vertex
fn vs_depth(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let d = scene_vertex(vertex_index, instance_index);
    return VertexOut(object_clip_position(d.object, d.vertex), vertex_uv0(vertices[d.vertex]), d.object);
}

@fragment
fn fs_alpha_mask(in: VertexOut) {
    if masked_out(in.object, in.uv0) {
        discard;
    }
}
#else
@vertex
fn vs_depth(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> @builtin(position) @invariant vec4f {
    let d = scene_vertex(vertex_index, instance_index);
    return object_clip_position(d.object, d.vertex);
}
#endif
