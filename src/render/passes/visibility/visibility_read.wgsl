// Reading the compute visibility pass's output the way lighting passes read
// the G-buffer (group 1; mirrors `ComputeVisibility::read_layout`): the same
// functions as `shadespace::gbuffer`, with each pixel's surface rebuilt from
// its ids, as object space rebuilds it, and its depth taken from the
// rasterizer's 64-bit buffer (the depth target is not written). With MSAA
// defined the ids have a layer per sample and the 64-bit buffer an entry
// per sample (a pixel's side by side): `gbuffer_pixel` compares a pixel's
// samples as the G-buffer's version does, `gbuffer_sample_texel` rebuilds a
// sample's surface at its own position.
#define_import_path shadespace::visibility_read
#import shadespace::lighting::Surface
#import shadespace::scene_bindings::view
#import shadespace::pixel_surface::{sample_pixel, pixel_surface, PixelSample}
#ifdef MSAA
#import shadespace::pixel_surface::{sample_pixel_at, standard_sample_position}
#endif

// (object + 1, triangle) per pixel (under MSAA per sample); 0 = background.
#ifdef MSAA
@group(1) @binding(0) var visibility_ids: texture_2d_array<u32>;
#else
@group(1) @binding(0) var visibility_ids: texture_2d<u32>;
#endif
// Per pixel (sample): (payload, depth bits) of the compute rasterizer.
@group(1) @binding(1) var<storage, read> visibility_depth: array<vec2u>;

// A lit pixel (as `shadespace::gbuffer::GbufferTexel`).
struct GbufferTexel {
    surface: Surface,
    // Unit vector from the surface to the eye.
    to_eye: vec3f,
}

// The texel of the surface a visibility-buffer point sees.
fn texel_of(p: PixelSample) -> GbufferTexel {
    var t: GbufferTexel;
    t.surface = pixel_surface(p);
    t.to_eye = normalize(view.camera_position.xyz - t.surface.position);
    return t;
}

#ifndef MSAA
// Device depth of a pixel; 0 (the cleared far plane, reversed Z) is background.
fn gbuffer_depth_at(pixel: vec2u) -> f32 {
    return bitcast<f32>(visibility_depth[pixel.y * u32(view.viewport.x) + pixel.x].y);
}

// The surface at `pixel`, which is not background (`depth` is unused: the
// position comes from the triangle).
fn gbuffer_texel(pixel: vec2u, depth: f32) -> GbufferTexel {
    return texel_of(sample_pixel(pixel, textureLoad(visibility_ids, pixel, 0).xy));
}
#endif

#ifdef MSAA
// Samples per pixel.
fn gbuffer_samples() -> u32 {
    return textureNumLayers(visibility_ids);
}

fn sample_ids(pixel: vec2u, s: u32) -> vec2u {
    return textureLoad(visibility_ids, pixel, s, 0).xy;
}

// Device depth of sample `s` of a pixel; 0 is background.
fn gbuffer_depth_sample(pixel: vec2u, s: u32) -> f32 {
    let first = (pixel.y * u32(view.viewport.x) + pixel.x) * gbuffer_samples();
    return bitcast<f32>(visibility_depth[first + s].y);
}

// The surface sample `s` of `pixel` (not background) sees, at its own
// position (`depth` is unused: the position comes from the triangle).
fn gbuffer_sample_texel(pixel: vec2u, s: u32, depth: f32) -> GbufferTexel {
    let at = standard_sample_position(gbuffer_samples(), s);
    return texel_of(sample_pixel_at(pixel, at, sample_ids(pixel, s)));
}

// The surface of a pixel whose samples see one: sample 0's triangle at the
// pixel centre.
fn gbuffer_centre_texel(pixel: vec2u, samples: PixelSamples) -> GbufferTexel {
    return texel_of(sample_pixel(pixel, sample_ids(pixel, 0u)));
}

// Samples of one pixel, compared (as `shadespace::gbuffer::PixelSamples`).
struct PixelSamples {
    edge: bool,
    // Some sample sees a surface.
    lit: bool,
    // Smallest and largest device depth of the samples that see one.
    depth_min: f32,
    depth_max: f32,
    // Mean device depth of the samples.
    depth_mean: f32,
}

// The shading normal sample `s` (ids `ids`) of `pixel` sees.
fn sample_normal(pixel: vec2u, s: u32, ids: vec2u) -> vec3f {
    let at = standard_sample_position(gbuffer_samples(), s);
    return pixel_surface(sample_pixel_at(pixel, at, ids)).normal;
}

// As the G-buffer's `gbuffer_pixel`: an edge pixel's samples see different
// surfaces (some background and some not, another object, a depth more
// than 1 % apart, or another triangle whose normal there is more than 8
// degrees apart; the normals are rebuilt only for that last test).
fn gbuffer_pixel(pixel: vec2u) -> PixelSamples {
    let n = gbuffer_samples();
    let d0 = gbuffer_depth_sample(pixel, 0u);
    let ids0 = sample_ids(pixel, 0u);
    var p = PixelSamples(false, d0 > 0.0, d0, d0, d0);
    if d0 <= 0.0 {
        p.depth_min = 1.0;
    }
    var n0 = vec3f(0.0);
    for (var s = 1u; s < n; s++) {
        let d = gbuffer_depth_sample(pixel, s);
        p.depth_mean += d;
        if d > 0.0 {
            p.lit = true;
            p.depth_min = min(p.depth_min, d);
            p.depth_max = max(p.depth_max, d);
        }
        if (d > 0.0) != (d0 > 0.0) {
            p.edge = true;
        } else if d > 0.0 && !p.edge {
            let ids = sample_ids(pixel, s);
            if ids.x != ids0.x || abs(d - d0) > 0.01 * max(d, d0) {
                p.edge = true;
            } else if ids.y != ids0.y {
                if all(n0 == vec3f(0.0)) {
                    n0 = sample_normal(pixel, 0u, ids0);
                }
                p.edge = dot(sample_normal(pixel, s, ids), n0) < 0.99;
            }
        }
    }
    p.depth_mean /= f32(n);
    return p;
}
#endif
