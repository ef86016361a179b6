// The vertex stage of the pipelines that shade rasterized fragments (forward,
// multi-pass forward, clustered), and the surface a fragment rebuilds from
// its interpolated attributes.
#define_import_path shadespace::raster_surface
#import shadespace::lighting::Surface
#import shadespace::scene::{Object, vertex_uv0}
#import shadespace::scene_bindings::{objects, vertices, albedo, albedo_sampler, object_clip_position}

struct VertexOut {
    @builtin(position) @invariant clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) uv: vec2f,
    // The object (multi-pass forward: the draw's light pair).
    @location(3) @interpolate(flat) tag: u32,
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
    return out;
}

// The object's albedo texel at the fragment (implicit derivatives: call it
// in uniform control flow).
fn sample_albedo(o: Object, in: VertexOut) -> vec3f {
    return textureSample(albedo, albedo_sampler, in.uv, o.albedo_layer).rgb;
}

// The surface of object `o` at a fragment whose albedo texel is `texel`.
fn fragment_surface(o: Object, in: VertexOut, texel: vec3f) -> Surface {
    var s: Surface;
    s.position = in.world;
    s.normal = normalize(in.normal);
    s.albedo = texel * o.base_color.rgb;
    s.specular = o.specular;
    s.shininess = o.shininess;
    return s;
}
