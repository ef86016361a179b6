// Reading the compute visibility pass's output the way lighting passes read
// the G-buffer (group 1; mirrors `ComputeVisibility::read_layout`): the same
// functions as `shadespace::gbuffer`, with each pixel's surface rebuilt from
// its ids, as object space rebuilds it, and its depth taken from the
// rasterizer's 64-bit buffer (the depth target is not written).
#define_import_path shadespace::visibility_read
#import shadespace::lighting::Surface
#import shadespace::scene_bindings::view
#import shadespace::pixel_surface::{sample_pixel, pixel_surface}

// (object + 1, triangle) per pixel; 0 = background.
@group(1) @binding(0) var visibility_ids: texture_2d<u32>;
// Per pixel: (payload, depth bits) of the compute rasterizer.
@group(1) @binding(1) var<storage, read> visibility_depth: array<vec2u>;

// A lit pixel (as `shadespace::gbuffer::GbufferTexel`).
struct GbufferTexel {
    surface: Surface,
    // Unit vector from the surface to the eye.
    to_eye: vec3f,
}

// Device depth of a pixel; 0 (the cleared far plane, reversed Z) is background.
fn gbuffer_depth_at(pixel: vec2u) -> f32 {
    return bitcast<f32>(visibility_depth[pixel.y * u32(view.viewport.x) + pixel.x].y);
}

// The surface at `pixel`, which is not background (`depth` is unused: the
// position comes from the triangle).
fn gbuffer_texel(pixel: vec2u, depth: f32) -> GbufferTexel {
    let p = sample_pixel(pixel, textureLoad(visibility_ids, pixel, 0).xy);
    var t: GbufferTexel;
    t.surface = pixel_surface(p);
    t.to_eye = normalize(view.camera_position.xyz - t.surface.position);
    return t;
}
