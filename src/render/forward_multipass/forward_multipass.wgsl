// Multi-pass forward: one draw per (object, light) pair, blended additively
// into the HDR target after a depth pre-pass (depth test `Equal`). The draw's
// instance index is its pair's index (its `first_instance`).
#import shadespace::contract::PAIR_EMISSION
#import shadespace::layers::{layered_radiance, layered_emission}
#import shadespace::raster_surface::{VertexOut, object_vertex, sample_albedo, sample_normal_map, sample_material,
    fragment_surface}
#import shadespace::scene_bindings::{view, objects, lights}
#import shadespace::alpha_mask::opacity
#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#endif

// Mirrors `render::forward_multipass::LightPair`.
struct LightPair {
    object: u32,
    // Index into `lights`, or PAIR_EMISSION: the object's emission.
    light: u32,
}

@group(1) @binding(0) var<storage, read> pairs: array<LightPair>;

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) pair: u32) -> VertexOut {
    return object_vertex(pairs[pair].object, vi, pair);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4f {
    let pair = pairs[in.tag];
#ifdef ALPHA_MASK
    if masked_out(pair.object, in.uv) {
        discard;
    }
#endif
    return vec4f(pair_radiance(pair, in), 1.0);
}

// An alpha-blended object's pair (`render::forward_multipass`): the pair's
// radiance times the object's opacity, and the opacity (premultiplied). The
// object's emission pair is composited "over" the frame, its light pairs
// added to it.
@fragment
fn fs_blend(in: VertexOut) -> @location(0) vec4f {
    let pair = pairs[in.tag];
    let a = opacity(pair.object, in.uv);
    return vec4f(a * pair_radiance(pair, in), a);
}

// What `pair` adds at the fragment: its light's radiance, or the object's
// emission (call it in uniform control flow: it samples textures).
fn pair_radiance(pair: LightPair, in: VertexOut) -> vec3f {
    let o = objects[pair.object];
    // Sampled before the branch: implicit derivatives need uniform control flow.
    let texel = sample_albedo(o, in);
    let normal_texel = sample_normal_map(o, in);
    let material = sample_material(o, in);
    let s = fragment_surface(o, in, texel, normal_texel, material);
    if pair.light == PAIR_EMISSION {
        return layered_emission(s);
    }
    let to_eye = normalize(view.camera_position.xyz - s.position);
    return layered_radiance(lights[pair.light], s, to_eye);
}
