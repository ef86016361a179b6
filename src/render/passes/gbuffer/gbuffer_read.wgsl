// Reading the G-buffer (group 1 of every deferred lighting pass; mirrors
// `render::passes::gbuffer::GBuffer::read_layout`): the surface at a pixel,
// its position rebuilt from depth with the inverse view-projection.
#define_import_path shadespace::gbuffer
#import shadespace::lighting::Surface
#import shadespace::octahedral::oct_decode
#import shadespace::scene_bindings::{view, objects}
#import shadespace::contract::NO_TEXTURE
#import shadespace::surface::{MaterialTexels, object_surface, no_material_texels}

// Mirrors `render::passes::gbuffer::GpuUnproject`.
struct Unproject {
    inv_view_proj: mat4x4f,
}

@group(1) @binding(0) var gbuffer_depth: texture_depth_2d;
@group(1) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(1) @binding(2) var gbuffer_albedo: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_object: texture_2d<u32>;
@group(1) @binding(4) var<uniform> unproject: Unproject;
// Material texels: emissive RGB and occlusion (alpha); metallic, roughness.
@group(1) @binding(5) var gbuffer_emission_occlusion: texture_2d<f32>;
@group(1) @binding(6) var gbuffer_metal_rough: texture_2d<f32>;
// Layered materials: UV0 and the albedo mip there.
@group(1) @binding(7) var gbuffer_uv_lod: texture_2d<f32>;

// A lit pixel of the G-buffer.
struct GbufferTexel {
    surface: Surface,
    // Unit vector from the surface to the eye.
    to_eye: vec3f,
}

// Device depth of a pixel; 0 (the cleared far plane, reversed Z) is background.
fn gbuffer_depth_at(pixel: vec2u) -> f32 {
    return textureLoad(gbuffer_depth, pixel, 0);
}

// World position of the centre of `pixel` at device depth `depth`.
fn world_position(pixel: vec2u, depth: f32) -> vec3f {
    let uv = (vec2f(pixel) + 0.5) * view.viewport.zw;
    let ndc = vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let p = unproject.inv_view_proj * ndc;
    return p.xyz / p.w;
}

// The surface at `pixel`, whose depth `depth` is not background.
fn gbuffer_texel(pixel: vec2u, depth: f32) -> GbufferTexel {
    let object = textureLoad(gbuffer_object, pixel, 0).x;
    let o = objects[object];
    var t: GbufferTexel;
    var material = no_material_texels();
#ifdef MATERIAL_TEXTURES
    if o.emissive_layer != NO_TEXTURE || o.metal_rough_layer != NO_TEXTURE || o.occlusion_layer != NO_TEXTURE {
        // Objects without material textures skip the loads.
        let e = textureLoad(gbuffer_emission_occlusion, pixel, 0);
        material = MaterialTexels(e.rgb, textureLoad(gbuffer_metal_rough, pixel, 0).xy, e.a);
    }
#endif
    t.surface = object_surface(o, material);
    t.surface.position = world_position(pixel, depth);
    t.surface.normal = oct_decode(textureLoad(gbuffer_normal, pixel, 0).xy);
    t.surface.albedo = textureLoad(gbuffer_albedo, pixel, 0).rgb;
#ifdef LAYERS
    if o.layer_count != 0u {
        let uv_lod = textureLoad(gbuffer_uv_lod, pixel, 0);
        t.surface.uv = uv_lod.xy;
        t.surface.uv_lod = uv_lod.z;
    }
#endif
    t.to_eye = normalize(view.camera_position.xyz - t.surface.position);
    return t;
}
