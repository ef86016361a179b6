// Triangle-index maps: rasterize an object's charts in UV space into its
// square of the atlas (the viewport), writing triangle + 1 per texel. With
// conservative rasterization every texel a triangle touches is written.
enable primitive_index;
#import shadespace::scene_bindings::vertices

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4f {
    let uv = vertices[vi].chart_uv;
    return vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.5, 1.0);
}

@fragment
fn fs_main(@builtin(primitive_index) triangle: u32) -> @location(0) u32 {
    return triangle + 1u;
}
