// Reading the G-buffer (group 1 of every deferred lighting pass; mirrors
// `render::passes::gbuffer::GBuffer::read_layout`): the surface at a pixel,
// its position rebuilt from depth with the inverse view-projection. With MSAA
// defined the targets are multisampled: `gbuffer_texel` reads sample 0 at the
// pixel centre, and `gbuffer_pixel` / `gbuffer_sample_texel` read the samples.
#define_import_path shadespace::gbuffer
#import shadespace::lighting::Surface
#import shadespace::octahedral::oct_decode
#import shadespace::scene_bindings::{view, objects}
#import shadespace::contract::NO_TEXTURE
#import shadespace::surface::{MaterialTexels, object_surface, no_material_texels}
#import shadespace::pixel_surface::standard_sample_position

// Mirrors `render::passes::gbuffer::GpuUnproject`.
struct Unproject {
    inv_view_proj: mat4x4f,
}

#ifdef MSAA
@group(1) @binding(0) var gbuffer_depth: texture_depth_multisampled_2d;
@group(1) @binding(1) var gbuffer_normal: texture_multisampled_2d<f32>;
@group(1) @binding(2) var gbuffer_albedo: texture_multisampled_2d<f32>;
@group(1) @binding(3) var gbuffer_object: texture_multisampled_2d<u32>;
#else
@group(1) @binding(0) var gbuffer_depth: texture_depth_2d;
@group(1) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(1) @binding(2) var gbuffer_albedo: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_object: texture_2d<u32>;
#endif
@group(1) @binding(4) var<uniform> unproject: Unproject;
// Material texels: emissive RGB and occlusion (alpha); metallic, roughness.
#ifdef MSAA
@group(1) @binding(5) var gbuffer_emission_occlusion: texture_multisampled_2d<f32>;
@group(1) @binding(6) var gbuffer_metal_rough: texture_multisampled_2d<f32>;
#ifdef LAYERS
// Layered materials: UV0 and the albedo mip there.
@group(1) @binding(7) var gbuffer_uv_lod: texture_multisampled_2d<f32>;
#endif
#else
@group(1) @binding(5) var gbuffer_emission_occlusion: texture_2d<f32>;
@group(1) @binding(6) var gbuffer_metal_rough: texture_2d<f32>;
#ifdef LAYERS
@group(1) @binding(7) var gbuffer_uv_lod: texture_2d<f32>;
#endif
#endif

// A lit pixel of the G-buffer.
struct GbufferTexel {
    surface: Surface,
    // Unit vector from the surface to the eye.
    to_eye: vec3f,
}

// Device depth of sample `s` of a pixel (without MSAA: of the pixel); 0
// (the cleared far plane, reversed Z) is background.
fn gbuffer_depth_sample(pixel: vec2u, s: u32) -> f32 {
#ifdef MSAA
    return textureLoad(gbuffer_depth, pixel, s);
#else
    return textureLoad(gbuffer_depth, pixel, 0);
#endif
}

// Device depth of a pixel (under MSAA: of its sample 0).
fn gbuffer_depth_at(pixel: vec2u) -> f32 {
    return gbuffer_depth_sample(pixel, 0u);
}

// World position of the point `xy` (pixels from the image's top-left
// corner) at device depth `depth`.
fn world_position_at(xy: vec2f, depth: f32) -> vec3f {
    let uv = xy * view.viewport.zw;
    let ndc = vec4f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let p = unproject.inv_view_proj * ndc;
    return p.xyz / p.w;
}

// World position of the centre of `pixel` at device depth `depth`.
fn world_position(pixel: vec2u, depth: f32) -> vec3f {
    return world_position_at(vec2f(pixel) + 0.5, depth);
}

// The surface of sample `s` of `pixel` (without MSAA: of the pixel) at
// world position `position`.
fn gbuffer_texel_at(pixel: vec2u, s: u32, position: vec3f) -> GbufferTexel {
#ifdef MSAA
    let i = s;
#else
    let i = 0u;
#endif
    let object = textureLoad(gbuffer_object, pixel, i).x;
    let o = objects[object];
    var t: GbufferTexel;
    var material = no_material_texels();
#ifdef MATERIAL_TEXTURES
    if o.emissive_layer != NO_TEXTURE || o.metal_rough_layer != NO_TEXTURE || o.occlusion_layer != NO_TEXTURE {
        // Objects without material textures skip the loads.
        let e = textureLoad(gbuffer_emission_occlusion, pixel, i);
        material = MaterialTexels(e.rgb, textureLoad(gbuffer_metal_rough, pixel, i).xy, e.a);
    }
#endif
    t.surface = object_surface(o, material);
    t.surface.position = position;
    t.surface.normal = oct_decode(textureLoad(gbuffer_normal, pixel, i).xy);
    t.surface.albedo = textureLoad(gbuffer_albedo, pixel, i).rgb;
#ifdef LAYERS
    if o.layer_count != 0u {
        let uv_lod = textureLoad(gbuffer_uv_lod, pixel, i);
        t.surface.uv = uv_lod.xy;
        t.surface.uv_lod = uv_lod.z;
    }
#endif
    t.to_eye = normalize(view.camera_position.xyz - t.surface.position);
    return t;
}

#ifdef MSAA
// The surface of a pixel whose samples see one (`samples`): sample 0's at
// the pixel centre, at the samples' mean depth.
fn gbuffer_centre_texel(pixel: vec2u, samples: PixelSamples) -> GbufferTexel {
    return gbuffer_texel_at(pixel, 0u, world_position(pixel, samples.depth_mean));
}
#endif

// The surface at `pixel`, whose depth `depth` is not background.
fn gbuffer_texel(pixel: vec2u, depth: f32) -> GbufferTexel {
    return gbuffer_texel_at(pixel, 0u, world_position(pixel, depth));
}

#ifdef MSAA
// Samples per pixel of the G-buffer.
fn gbuffer_samples() -> u32 {
    return textureNumSamples(gbuffer_depth);
}

// The surface of sample `s` of `pixel` at its own position and depth `depth`.
fn gbuffer_sample_texel(pixel: vec2u, s: u32, depth: f32) -> GbufferTexel {
    let at = standard_sample_position(gbuffer_samples(), s);
    return gbuffer_texel_at(pixel, s, world_position_at(vec2f(pixel) + at, depth));
}

// Samples of one pixel, compared: an edge pixel's samples see different
// surfaces (some background and some not, or another object, a normal
// more than 8 degrees apart, or a depth more than 1 % apart), and are
// shaded one by one; the others are shaded once for the pixel.
struct PixelSamples {
    edge: bool,
    // Some sample sees a surface.
    lit: bool,
    // Smallest and largest device depth of the samples that see one.
    depth_min: f32,
    depth_max: f32,
    // Mean device depth: at the pixel centre for a plane through the
    // samples (device depth is affine in screen space and the standard
    // positions average to the centre).
    depth_mean: f32,
}

fn gbuffer_pixel(pixel: vec2u) -> PixelSamples {
    let n = gbuffer_samples();
    let d0 = textureLoad(gbuffer_depth, pixel, 0);
    let o0 = textureLoad(gbuffer_object, pixel, 0).x;
    let n0 = oct_decode(textureLoad(gbuffer_normal, pixel, 0).xy);
    var p = PixelSamples(false, d0 > 0.0, d0, d0, d0);
    if d0 <= 0.0 {
        p.depth_min = 1.0;
    }
    for (var s = 1u; s < n; s++) {
        let d = textureLoad(gbuffer_depth, pixel, s);
        p.depth_mean += d;
        if d > 0.0 {
            p.lit = true;
            p.depth_min = min(p.depth_min, d);
            p.depth_max = max(p.depth_max, d);
        }
        if (d > 0.0) != (d0 > 0.0) {
            p.edge = true;
        } else if d > 0.0 && !p.edge {
            let normal = oct_decode(textureLoad(gbuffer_normal, pixel, s).xy);
            p.edge = textureLoad(gbuffer_object, pixel, s).x != o0 || dot(normal, n0) < 0.99
                || abs(d - d0) > 0.01 * max(d, d0);
        }
    }
    p.depth_mean /= f32(n);
    return p;
}
#endif
