// Evaluating the shared lighting model at a point of an object's triangle,
// given barycentrics: used by object-space shading (per texel) and by the
// object-space gather for objects shaded forward (per pixel).
#define_import_path shadespace::surface
#import shadespace::lighting::{Surface, light_radiance}
#import shadespace::scene::{Object, vertex_uv0}
#import shadespace::scene_bindings::{view, vertices, lights, light_indices, albedo, albedo_sampler, normal_maps}
#import shadespace::normal_map::{mapped_normal, sample_layer}

// The surface at barycentrics `b` of the triangle with vertices `tri`
// (world position and normal, albedo and normal map sampled at mip
// `texture_lod`).
fn surface_point(o: Object, tri: vec3u, b: vec3f, texture_lod: f32) -> Surface {
    let v0 = vertices[tri.x];
    let v1 = vertices[tri.y];
    let v2 = vertices[tri.z];
    let local = v0.position * b.x + v1.position * b.y + v2.position * b.z;
    let n = v0.normal * b.x + v1.normal * b.y + v2.normal * b.z;
    let t = v0.tangent * b.x + v1.tangent * b.y + v2.tangent * b.z;
    let uv0 = vertex_uv0(v0) * b.x + vertex_uv0(v1) * b.y + vertex_uv0(v2) * b.z;
    let world = (o.model * vec4f(local, 1.0)).xyz;
    let texel = textureSampleLevel(normal_maps, albedo_sampler, uv0, sample_layer(o.normal_layer), texture_lod).rgb;
    let world_t = vec4f((o.model * vec4f(t.xyz, 0.0)).xyz, v0.tangent.w);
    var s = object_surface(o);
    s.position = world;
    s.normal = mapped_normal((o.normal_model * vec4f(n, 0.0)).xyz, world_t, texel, o.normal_layer);
    s.albedo = textureSampleLevel(albedo, albedo_sampler, uv0, o.albedo_layer, texture_lod).rgb * o.base_color.rgb;
    return s;
}

// A surface with object `o`'s material and the view's lighting model (the
// caller fills in position, normal and albedo).
fn object_surface(o: Object) -> Surface {
    var s: Surface;
    s.specular = o.specular;
    s.shininess = o.shininess;
    s.metallic = o.metallic;
    s.roughness = o.roughness;
    s.model = view.shading;
    return s;
}

// Emission plus every light the object's list holds, seen from the camera.
fn light_surface(o: Object, s: Surface) -> vec3f {
    let to_eye = normalize(view.camera_position.xyz - s.position);
    var color = o.emissive;
    for (var i = 0u; i < o.light_count; i++) {
        color += light_radiance(lights[light_indices[o.light_offset + i]], s, to_eye);
    }
    return color;
}

// The ambient and directional lights: the first `view.global_light_count`
// lights, which reach every point (light grids list only the others).
fn light_globals(s: Surface, to_eye: vec3f) -> vec3f {
    var color = vec3f(0.0);
    for (var i = 0u; i < view.global_light_count; i++) {
        color += light_radiance(lights[i], s, to_eye);
    }
    return color;
}

// Albedo mip for a footprint whose UV0 derivatives are `d0` and `d1`.
fn albedo_lod(d0: vec2f, d1: vec2f) -> f32 {
    let size = vec2f(textureDimensions(albedo));
    let rho = max(length(d0 * size), length(d1 * size));
    return max(log2(max(rho, 1e-8)), 0.0);
}
