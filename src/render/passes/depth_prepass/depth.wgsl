// Depth pre-pass: the scene's depth only, so that a later pass over the same
// objects (testing `Equal`) runs one fragment per pixel. Both passes take
// their positions from `object_clip_position` with `@invariant`, so equal
// depths compare equal bit for bit.
#import shadespace::scene_bindings::object_clip_position

@vertex
fn vs_depth(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> @builtin(position) @invariant vec4f {
    return object_clip_position(object, vi);
}
