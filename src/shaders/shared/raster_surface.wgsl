// The vertex stage of the pipelines that shade rasterized fragments (forward,
// multi-pass forward, clustered), and the surface a fragment rebuilds from
// its interpolated attributes.
#define_import_path shadespace::raster_surface
#import shadespace::lighting::Surface
#import shadespace::scene::{Object, vertex_uv0}
#import shadespace::scene_bindings::{view, objects, vertices, albedo, albedo_sampler, linear_maps, object_clip_position}
#import shadespace::surface::{MaterialTexels, object_surface, material_texels_grad, albedo_lod}
#import shadespace::normal_map::{mapped_normal, sample_layer}

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) uv: vec2f,
    // The object (multi-pass forward: the draw's light pair).
    @location(3) @interpolate(flat) tag: u32,
    // World tangent and bitangent sign.
    @location(4) tangent: vec4f,
}

// Vertex `vi` of `object`, tagged `tag`. The clip position is
// `object_clip_position`'s, as in the depth pre-pass, so depths match bit for
// bit under an `Equal` test.
fn object_vertex(object: u32, vi: u32, tag: u32) -> VertexOut {
    let o = objects[object];
    let v = vertices[vi];
    var out: VertexOut;
    out.clip = object_clip_position(object, vi);
    out.world = (o.model * vec4f(v.position, 1.0)).xyz;
    out.normal = (o.normal_model * vec4f(v.normal, 0.0)).xyz;
    out.uv = vertex_uv0(v);
    out.tag = tag;
    out.tangent = vec4f((o.model * vec4f(v.tangent.xyz, 0.0)).xyz, v.tangent.w);
    return out;
}

// The object's albedo texel at the fragment (implicit derivatives, biased by
// the view's texture_lod_bias: call it in uniform control flow).
fn sample_albedo(o: Object, in: VertexOut) -> vec3f {
    return textureSampleBias(albedo, albedo_sampler, in.uv, o.albedo_layer, view.texture_lod_bias).rgb;
}

// The object's normal-map texel at the fragment (uniform control flow, as
// `sample_albedo`; meaningless for objects without a map).
fn sample_normal_map(o: Object, in: VertexOut) -> vec3f {
    return textureSampleBias(linear_maps, albedo_sampler, in.uv, sample_layer(o.normal_layer), view.texture_lod_bias).rgb;
}

// The object's emissive, metallic-roughness and occlusion texels at the
// fragment (call it in uniform control flow: it takes UV derivatives; only
// the textures the object has are sampled).
fn sample_material(o: Object, in: VertexOut) -> MaterialTexels {
    return material_texels_grad(o, in.uv, dpdx(in.uv), dpdy(in.uv));
}

// The surface of object `o` at a fragment whose albedo texel is `texel`,
// normal-map texel `normal_texel` and material texels `material` (call it
// in uniform control flow: a layered material takes UV derivatives).
fn fragment_surface(o: Object, in: VertexOut, texel: vec3f, normal_texel: vec3f, material: MaterialTexels) -> Surface {
    var s = object_surface(o, material);
    s.position = in.world;
    s.normal = mapped_normal(in.normal, in.tangent, normal_texel, o.normal_layer);
    s.albedo = texel * o.base_color.rgb;
#ifdef LAYERS
    s.uv = in.uv;
    s.uv_lod = albedo_lod(dpdx(in.uv), dpdy(in.uv));
#endif
    return s;
}
