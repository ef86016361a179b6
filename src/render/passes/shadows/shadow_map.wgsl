// Shadow-map faces: the depth of the casters seen from a light, into one layer
// of the shadow atlas (reversed Z, like the camera's depth). Depth only, no
// fragment stage. Not the scene bind group: that one samples the atlas, which
// this pass renders into.
#import shadespace::scene::{Vertex, Object}

@group(0) @binding(0) var<storage, read> objects: array<Object>;
@group(0) @binding(1) var<storage, read> vertices: array<Vertex>;
// The face's view-projection (bound at a dynamic offset per face).
@group(0) @binding(2) var<uniform> face_view_proj: mat4x4f;

@vertex
fn vs_shadow(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> @builtin(position) vec4f {
    return face_view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
}
