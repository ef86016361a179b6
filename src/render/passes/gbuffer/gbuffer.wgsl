// G-buffer pass: rasterize the scene and store, per pixel, what lighting
// needs besides depth: the octahedral-encoded unit normal (normal-mapped),
// the albedo, the object (its specular, shininess, metallic, roughness,
// emission and occlusion strength are per object, so the index carries them
// exactly) and the texels of its emissive, metallic-roughness and occlusion
// textures (which `object_surface` combines with the object's factors, as
// every pipeline does). Positions come back from depth. Its clip position is
// `object_clip_position`, so after a depth pre-pass the `Equal` test passes.
#import shadespace::octahedral::oct_encode
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::{view, objects, vertices, albedo, albedo_sampler, linear_maps, object_clip_position}
#import shadespace::normal_map::{mapped_normal, sample_layer}
#import shadespace::cluster_draws::scene_vertex
#import shadespace::surface::{material_texels_grad, albedo_lod}
#ifdef ALPHA_MASK
#import shadespace::alpha_mask::masked_out
#endif

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) normal: vec3f,
    @location(1) uv0: vec2f,
    @location(2) @interpolate(flat) object: u32,
    // World tangent and bitangent sign.
    @location(3) tangent: vec4f,
}

struct GbufferOut {
    @location(0) normal: vec2f,
    @location(1) albedo_color: vec4f,
    @location(2) object: u32,
#ifdef MATERIAL_TEXTURES
    // The emissive texel (sRGB target) and the occlusion texel (alpha, linear).
    @location(3) emission_occlusion: vec4f,
    // The metallic and roughness texels.
    @location(4) metal_rough: vec2f,
#endif
#ifdef LAYERS
    // UV0 and the albedo mip there, for the layers' texture masks (the
    // target after the others).
#ifdef MATERIAL_TEXTURES
    @location(5) uv_lod: vec4f,
#else
    @location(3) uv_lod: vec4f,
#endif
#endif
}

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let d = scene_vertex(vertex_index, instance_index);
    let vi = d.vertex;
    let object = d.object;
    let v = vertices[vi];
    var out: VertexOut;
    out.clip = object_clip_position(object, vi);
    out.normal = (objects[object].normal_model * vec4f(v.normal, 0.0)).xyz;
    out.uv0 = vertex_uv0(v);
    out.object = object;
    out.tangent = vec4f((objects[object].model * vec4f(v.tangent.xyz, 0.0)).xyz, v.tangent.w);
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> GbufferOut {
#ifdef ALPHA_MASK
    if masked_out(in.object, in.uv0) {
        discard;
    }
#endif
    let o = objects[in.object];
    var out: GbufferOut;
    // Implicit derivatives biased by the view's texture_lod_bias, as forward's.
    let bias = view.texture_lod_bias;
    let normal_texel = textureSampleBias(linear_maps, albedo_sampler, in.uv0, sample_layer(o.normal_layer), bias).rgb;
    out.normal = oct_encode(mapped_normal(in.normal, in.tangent, normal_texel, o.normal_layer));
    out.albedo_color = vec4f(textureSampleBias(albedo, albedo_sampler, in.uv0, o.albedo_layer, bias).rgb * o.base_color.rgb, 1.0);
    out.object = in.object;
#ifdef MATERIAL_TEXTURES
    let material = material_texels_grad(o, in.uv0, dpdx(in.uv0), dpdy(in.uv0));
    out.emission_occlusion = vec4f(material.emissive, material.occlusion);
    out.metal_rough = material.metal_rough;
#endif
#ifdef LAYERS
    out.uv_lod = vec4f(in.uv0, albedo_lod(dpdx(in.uv0), dpdy(in.uv0)), 0.0);
#endif
    return out;
}
