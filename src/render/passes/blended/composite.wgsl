// Composites the resolved layer of blended surfaces (premultiplied colour and
// coverage, `passes::blended`) over the opaque frame, under MSAA in the
// pipelines whose opaque frame has one sample: a full-screen triangle whose
// fragments return the layer's texel, blended "over" by the pipeline state.
@group(0) @binding(0) var layer: texture_2d<f32>;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {
    let corner = vec2f(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4f(corner * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_composite(@builtin(position) p: vec4f) -> @location(0) vec4f {
    return textureLoad(layer, vec2i(p.xy), 0);
}
