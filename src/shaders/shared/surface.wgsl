// Evaluating the shared lighting model at a point of an object's triangle,
// given barycentrics: used by object-space shading (per texel) and by the
// object-space gather for objects shaded forward (per pixel). Also the one
// place where an object's material becomes a Surface (`object_surface`), for
// every pipeline.
#define_import_path shadespace::surface
#import shadespace::contract::NO_TEXTURE
#import shadespace::lighting::{Surface, light_radiance, shininess_from_roughness}
#ifdef LAYERS
#import shadespace::layers::{layer_at, layer_mask, layer_surface}
#endif
#import shadespace::scene::{Object, vertex_uv0}
#import shadespace::scene_bindings::{view, vertices, lights, light_indices, albedo, albedo_sampler, linear_maps, texel_sampler}
#import shadespace::normal_map::{mapped_normal, sample_layer}

// The texels of an object's emissive, metallic-roughness and occlusion
// textures at a point; each is ignored when the object has no such texture
// (`object_surface` keeps the factor alone, exactly).
struct MaterialTexels {
    // The emissive texture's RGB (decoded from sRGB).
    emissive: vec3f,
    // The metallic-roughness texture's blue (metallic) and green (roughness).
    metal_rough: vec2f,
    // The occlusion texture's red.
    occlusion: f32,
}

// Texels for an object without material textures.
fn no_material_texels() -> MaterialTexels {
    return MaterialTexels(vec3f(1.0), vec2f(1.0), 1.0);
}

// The material texels at `uv` (UV0), sampled at mip `lod` (no derivatives:
// valid in compute and in non-uniform control flow). Objects without a
// texture skip its sample; without MATERIAL_TEXTURES (no object of the scene
// has any) none is sampled or even compiled.
fn material_texels_level(o: Object, uv: vec2f, lod: f32) -> MaterialTexels {
    var t = no_material_texels();
#ifdef MATERIAL_TEXTURES
    if o.emissive_layer != NO_TEXTURE {
        t.emissive = textureSampleLevel(albedo, texel_sampler, uv, o.emissive_layer, lod).rgb;
    }
    if o.metal_rough_layer != NO_TEXTURE {
        t.metal_rough = textureSampleLevel(linear_maps, texel_sampler, uv, o.metal_rough_layer, lod).bg;
    }
    if o.occlusion_layer != NO_TEXTURE {
        t.occlusion = textureSampleLevel(linear_maps, texel_sampler, uv, o.occlusion_layer, lod).r;
    }
#endif
    return t;
}

// As `material_texels_level`, with UV0's screen derivatives `pixel_ddx`,
// `pixel_ddy` (for fragments: `dpdx(uv)` and `dpdy(uv)` taken in uniform
// control flow, so that these samples, like implicit ones, filter the
// pixel's footprint). The view's texture_lod_bias scales them by 2^bias:
// the same level shift as `textureSampleBias`.
fn material_texels_grad(o: Object, uv: vec2f, pixel_ddx: vec2f, pixel_ddy: vec2f) -> MaterialTexels {
    var t = no_material_texels();
#ifdef MATERIAL_TEXTURES
    let ddx = pixel_ddx * exp2(view.texture_lod_bias);
    let ddy = pixel_ddy * exp2(view.texture_lod_bias);
    if o.emissive_layer != NO_TEXTURE {
        t.emissive = textureSampleGrad(albedo, albedo_sampler, uv, o.emissive_layer, ddx, ddy).rgb;
    }
    if o.metal_rough_layer != NO_TEXTURE {
        t.metal_rough = textureSampleGrad(linear_maps, albedo_sampler, uv, o.metal_rough_layer, ddx, ddy).bg;
    }
    if o.occlusion_layer != NO_TEXTURE {
        t.occlusion = textureSampleGrad(linear_maps, albedo_sampler, uv, o.occlusion_layer, ddx, ddy).r;
    }
#endif
    return t;
}

// A surface with object `o`'s material, its textures' texels `t` and the
// view's lighting model (the caller fills in position, normal and albedo).
// glTF 2.0's rules: emission = emissive factor x emissive texel; metallic and
// roughness = factors x the texture's blue and green (Phong's exponent then
// follows the textured roughness); occlusion = 1 + strength x (red - 1).
// Without a texture each is its factor alone, as before textures.
fn object_surface(o: Object, t: MaterialTexels) -> Surface {
    var s: Surface;
    s.specular = o.specular;
    s.shininess = o.shininess;
    s.metallic = o.metallic;
    s.roughness = o.roughness;
    s.model = view.shading;
    s.emission = o.emissive;
    s.occlusion = 1.0;
#ifdef LAYERS
    s.layer_first = o.layer_first;
    s.layer_count = o.layer_count;
#endif
#ifdef MATERIAL_TEXTURES
    if o.emissive_layer != NO_TEXTURE {
        s.emission = o.emissive * t.emissive;
    }
    if o.metal_rough_layer != NO_TEXTURE {
        s.metallic = o.metallic * t.metal_rough.x;
        s.roughness = o.roughness * t.metal_rough.y;
        s.shininess = shininess_from_roughness(s.roughness);
    }
    if o.occlusion_layer != NO_TEXTURE {
        s.occlusion = 1.0 + o.occlusion_strength * (t.occlusion - 1.0);
    }
#endif
    return s;
}

// A point at barycentrics `b` of the triangle with vertices `tri`: world
// position, normal, tangent (xyz world, w the bitangent sign) and UV0 (`uv`).
struct TrianglePoint {
    world: vec3f,
    normal: vec3f,
    tangent: vec4f,
    uv: vec2f,
}

fn triangle_point(o: Object, tri: vec3u, b: vec3f) -> TrianglePoint {
    let v0 = vertices[tri.x];
    let v1 = vertices[tri.y];
    let v2 = vertices[tri.z];
    let local = v0.position * b.x + v1.position * b.y + v2.position * b.z;
    let n = v0.normal * b.x + v1.normal * b.y + v2.normal * b.z;
    let t = v0.tangent * b.x + v1.tangent * b.y + v2.tangent * b.z;
    var p: TrianglePoint;
    p.world = (o.model * vec4f(local, 1.0)).xyz;
    p.normal = (o.normal_model * vec4f(n, 0.0)).xyz;
    p.tangent = vec4f((o.model * vec4f(t.xyz, 0.0)).xyz, v0.tangent.w);
    p.uv = vertex_uv0(v0) * b.x + vertex_uv0(v1) * b.y + vertex_uv0(v2) * b.z;
    return p;
}

// The surface of object `o` at point `p`, given its normal-map, albedo and
// material texels and its texture mip `uv_lod` (for layer masks).
fn point_surface(o: Object, p: TrianglePoint, normal_texel: vec3f, albedo_texel: vec3f, t: MaterialTexels, uv_lod: f32) -> Surface {
    var s = object_surface(o, t);
    s.position = p.world;
    s.normal = mapped_normal(p.normal, p.tangent, normal_texel, o.normal_layer);
    s.albedo = albedo_texel * o.base_color.rgb;
#ifdef LAYERS
    s.uv = p.uv;
    s.uv_lod = uv_lod;
#endif
    return s;
}

// The surface at barycentrics `b` of the triangle with vertices `tri`
// (world position and normal; albedo, normal map and material textures
// sampled at mip `texture_lod` with the isotropic `texel_sampler`: object
// space's texels, whatever `--aniso`).
fn surface_point(o: Object, tri: vec3u, b: vec3f, texture_lod: f32) -> Surface {
    let p = triangle_point(o, tri, b);
    let normal_texel = textureSampleLevel(linear_maps, texel_sampler, p.uv, sample_layer(o.normal_layer), texture_lod).rgb;
    let albedo_texel = textureSampleLevel(albedo, texel_sampler, p.uv, o.albedo_layer, texture_lod).rgb;
    return point_surface(o, p, normal_texel, albedo_texel, material_texels_level(o, p.uv, texture_lod), texture_lod);
}

// As `surface_point` for a pixel (or sample) whose UV0 changes by
// `pixel_ddx`, `pixel_ddy` one pixel right and down: every texture is
// sampled with those gradients, scaled by the view's texture_lod_bias as
// `material_texels_grad` does, so the sampler's anisotropy (`--aniso`)
// filters the footprint as it does a fragment's. Layer masks keep one
// level (`albedo_lod`), as every pipeline's do.
fn surface_point_grad(o: Object, tri: vec3u, b: vec3f, pixel_ddx: vec2f, pixel_ddy: vec2f) -> Surface {
    let p = triangle_point(o, tri, b);
    let ddx = pixel_ddx * exp2(view.texture_lod_bias);
    let ddy = pixel_ddy * exp2(view.texture_lod_bias);
    let normal_texel = textureSampleGrad(linear_maps, albedo_sampler, p.uv, sample_layer(o.normal_layer), ddx, ddy).rgb;
    let albedo_texel = textureSampleGrad(albedo, albedo_sampler, p.uv, o.albedo_layer, ddx, ddy).rgb;
    let t = material_texels_grad(o, p.uv, pixel_ddx, pixel_ddy);
    return point_surface(o, p, normal_texel, albedo_texel, t, albedo_lod(pixel_ddx, pixel_ddy));
}

// Emission plus every light the object's list holds, seen from the camera;
// for a layered material, each layer's with its weight
// (`shadespace::layers`).
fn light_surface(o: Object, s: Surface) -> vec3f {
#ifdef LAYERS
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * light_surface_one(o, layer_surface(l, s));
        }
    }
    if remaining > 0.0 {
        color += remaining * light_surface_one(o, s);
    }
    return color;
#else
    return light_surface_one(o, s);
#endif
}

// `light_surface` of one surface (a material or one of its layers).
fn light_surface_one(o: Object, s: Surface) -> vec3f {
    let to_eye = normalize(view.camera_position.xyz - s.position);
    var color = s.emission;
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

// Emission plus the ambient and directional lights (the full-screen part of
// deferred shading), each layer's with its weight for a layered material.
fn emission_and_globals(s: Surface, to_eye: vec3f) -> vec3f {
#ifdef LAYERS
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * emission_and_globals_one(layer_surface(l, s), to_eye);
        }
    }
    if remaining > 0.0 {
        color += remaining * emission_and_globals_one(s, to_eye);
    }
    return color;
#else
    return emission_and_globals_one(s, to_eye);
#endif
}

fn emission_and_globals_one(s: Surface, to_eye: vec3f) -> vec3f {
    return s.emission + light_globals(s, to_eye);
}

// Albedo mip for a footprint whose UV0 derivatives are `d0` and `d1`, with
// the view's texture_lod_bias added before the clamp, as the hardware adds
// `textureSampleBias`'s (every computed material level, layer masks' too,
// comes from here).
fn albedo_lod(d0: vec2f, d1: vec2f) -> f32 {
    let size = vec2f(textureDimensions(albedo));
    let rho = max(length(d0 * size), length(d1 * size));
    return max(log2(max(rho, 1e-8)) + view.texture_lod_bias, 0.0);
}
