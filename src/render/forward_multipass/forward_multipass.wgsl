// Multi-pass forward: one draw per (object, light) pair, blended additively
// into the HDR target after a depth pre-pass (depth test `Equal`). The draw's
// instance index is its pair's index (its `first_instance`). Clip positions
// come from `object_clip_position`, as in the pre-pass, so depths match bit
// for bit.
#import shadespace::contract::PAIR_EMISSION
#import shadespace::lighting::{Surface, light_radiance}
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::{view, objects, vertices, lights, albedo, albedo_sampler, object_clip_position}

// Mirrors `render::forward_multipass::LightPair`.
struct LightPair {
    object: u32,
    // Index into `lights`, or PAIR_EMISSION: the object's emission.
    light: u32,
}

@group(1) @binding(0) var<storage, read> pairs: array<LightPair>;

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) uv0: vec2f,
    @location(3) @interpolate(flat) pair: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) pair: u32) -> VertexOut {
    let object = pairs[pair].object;
    let o = objects[object];
    let v = vertices[vi];
    var out: VertexOut;
    out.clip = object_clip_position(object, vi);
    out.world = (o.model * vec4f(v.position, 1.0)).xyz;
    out.normal = (o.normal_model * vec4f(v.normal, 0.0)).xyz;
    out.uv0 = vertex_uv0(v);
    out.pair = pair;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4f {
    let pair = pairs[in.pair];
    let o = objects[pair.object];
    // Sampled before the branch: implicit derivatives need uniform control flow.
    let texel = textureSample(albedo, albedo_sampler, in.uv0, o.albedo_layer).rgb;
    if pair.light == PAIR_EMISSION {
        return vec4f(o.emissive, 1.0);
    }
    var s: Surface;
    s.position = in.world;
    s.normal = normalize(in.normal);
    s.albedo = texel * o.base_color.rgb;
    s.specular = o.specular;
    s.shininess = o.shininess;
    let to_eye = normalize(view.camera_position.xyz - s.position);
    return vec4f(light_radiance(lights[pair.light], s, to_eye), 1.0);
}
