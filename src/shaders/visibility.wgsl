// Visibility pass: rasterize the scene with depth and write, per pixel, the
// object (+1) and the triangle. No shading: later compute passes rebuild
// everything else from these ids.
enable primitive_index;
#import shadespace::scene_bindings::{view, objects, vertices}

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) @interpolate(flat) object: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> VertexOut {
    var out: VertexOut;
    out.clip = view.view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
    out.object = object;
    return out;
}

// Depth-only pre-pass (optional): the id pass then runs one fragment per pixel.
@vertex
fn vs_depth(@builtin(vertex_index) vi: u32, @builtin(instance_index) object: u32) -> @builtin(position) @invariant vec4f {
    return view.view_proj * (objects[object].model * vec4f(vertices[vi].position, 1.0));
}

@fragment
fn fs_main(in: VertexOut, @builtin(primitive_index) triangle: u32) -> @location(0) vec2u {
    return vec2u(in.object + 1u, triangle);
}
