// A pixel of a visibility buffer, rebuilt from its (object + 1, triangle)
// ids: perspective-correct barycentrics and their screen derivatives, and the
// surface there. Object space's passes and the visibility-buffer variant of
// tiled deferred read pixels through it.
#define_import_path shadespace::pixel_surface
#import shadespace::lighting::Surface
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::{view, objects, vertices, triangle_vertices}
#import shadespace::surface::surface_point_grad

// What a pixel of the visibility buffer sees, rebuilt from the triangle.
struct PixelSample {
    object: u32,
    triangle: u32,
    tri: vec3u,
    // Perspective-correct barycentrics at the pixel centre, and at the
    // centres one pixel right and one pixel down (for derivatives).
    b: vec3f,
    b_dx: vec3f,
    b_dy: vec3f,
}

// Homogeneous barycentrics: for clip-space vertices (x, y, w) and the ray
// through NDC point q, the weights cross(v_j, v_k) . (q, 1) are perspective
// correct and stay valid when a vertex lies behind the eye.
fn barycentrics(c0: vec3f, c1: vec3f, c2: vec3f, q: vec2f) -> vec3f {
    let r = vec3f(q, 1.0);
    let e = vec3f(dot(cross(c1, c2), r), dot(cross(c2, c0), r), dot(cross(c0, c1), r));
    return e / (e.x + e.y + e.z);
}

// NDC of the point `xy` pixels from the image's top-left corner.
fn point_ndc(xy: vec2f) -> vec2f {
    let uv = xy * view.viewport.zw;
    return vec2f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
}

// Vulkan's standard sample positions (0..1 from the pixel's top-left
// corner) of 2, 4 and 8 samples per pixel, where the hardware rasterizer
// covers them; the pixel centre for any other count.
const SAMPLES_2 = array<vec2f, 2>(vec2f(0.75, 0.75), vec2f(0.25, 0.25));
const SAMPLES_4 = array<vec2f, 4>(vec2f(0.375, 0.125), vec2f(0.875, 0.375), vec2f(0.125, 0.625), vec2f(0.625, 0.875));
const SAMPLES_8 = array<vec2f, 8>(
    vec2f(0.5625, 0.3125), vec2f(0.4375, 0.6875), vec2f(0.8125, 0.5625), vec2f(0.3125, 0.1875),
    vec2f(0.1875, 0.8125), vec2f(0.0625, 0.4375), vec2f(0.6875, 0.9375), vec2f(0.9375, 0.0625),
);

fn standard_sample_position(count: u32, s: u32) -> vec2f {
    // Copied into variables: arrays are indexed at run time through memory.
    switch count {
        case 2u: {
            var positions = SAMPLES_2;
            return positions[s];
        }
        case 4u: {
            var positions = SAMPLES_4;
            return positions[s];
        }
        case 8u: {
            var positions = SAMPLES_8;
            return positions[s];
        }
        default: {
            return vec2f(0.5);
        }
    }
}

// What rebuilding a pixel needs of its triangle, whatever the pixel: its
// ids and clip-space vertices (x, y, w). A pass that rebuilds several
// pixels of one triangle loads and transforms it once.
struct TriangleSetup {
    // (object + 1, triangle); non-zero.
    ids: vec2u,
    tri: vec3u,
    clip_a: vec3f,
    clip_b: vec3f,
    clip_c: vec3f,
}

// The setup of the triangle `ids` = (object + 1, triangle), non-zero.
fn triangle_setup(ids: vec2u) -> TriangleSetup {
    var t: TriangleSetup;
    t.ids = ids;
    let o = objects[ids.x - 1u];
    t.tri = triangle_vertices(o, ids.y);
    let mvp = view.view_proj * o.model;
    t.clip_a = (mvp * vec4f(vertices[t.tri.x].position, 1.0)).xyw;
    t.clip_b = (mvp * vec4f(vertices[t.tri.y].position, 1.0)).xyw;
    t.clip_c = (mvp * vec4f(vertices[t.tri.z].position, 1.0)).xyw;
    return t;
}

// Rebuilds a visibility-buffer pixel; `ids` = (object + 1, triangle), non-zero.
fn sample_pixel(pixel: vec2u, ids: vec2u) -> PixelSample {
    return sample_pixel_at(pixel, vec2f(0.5), ids);
}

// `sample_pixel` at the point `at` of the pixel (0..1 from its top-left
// corner; an MSAA sample's position), derivatives one pixel apart.
fn sample_pixel_at(pixel: vec2u, at: vec2f, ids: vec2u) -> PixelSample {
    return sample_setup_at(triangle_setup(ids), pixel, at);
}

// The triangle `sample_pixel_again` last set up (ids 0: none yet).
var<private> last_setup: TriangleSetup;

// `sample_pixel` for an invocation that rebuilds several pixels (a quad),
// which mostly lie on one triangle: loaded and transformed again only when
// `ids` is not the last pixel's triangle. The same values.
fn sample_pixel_again(pixel: vec2u, ids: vec2u) -> PixelSample {
    if any(ids != last_setup.ids) {
        last_setup = triangle_setup(ids);
    }
    return sample_setup_at(last_setup, pixel, vec2f(0.5));
}

// `sample_pixel_at` of a pixel of triangle `t`: the same values.
fn sample_setup_at(t: TriangleSetup, pixel: vec2u, at: vec2f) -> PixelSample {
    var p: PixelSample;
    p.object = t.ids.x - 1u;
    p.triangle = t.ids.y;
    p.tri = t.tri;
    let q = point_ndc(vec2f(pixel) + at);
    let step = 2.0 * view.viewport.zw;
    p.b = barycentrics(t.clip_a, t.clip_b, t.clip_c, q);
    p.b_dx = barycentrics(t.clip_a, t.clip_b, t.clip_c, q + vec2f(step.x, 0.0));
    p.b_dy = barycentrics(t.clip_a, t.clip_b, t.clip_c, q - vec2f(0.0, step.y));
    return p;
}

fn interpolate2(b: vec3f, a: vec2f, c: vec2f, d: vec2f) -> vec2f {
    return a * b.x + c * b.y + d * b.z;
}

// The surface a pixel sees, its textures filtered by its UV0 footprint:
// sampled with the footprint's gradients (not a level picked here), so that
// the material sampler's anisotropy (`--aniso`) applies as in the raster
// pipelines.
fn pixel_surface(p: PixelSample) -> Surface {
    let t0 = vertex_uv0(vertices[p.tri.x]);
    let t1 = vertex_uv0(vertices[p.tri.y]);
    let t2 = vertex_uv0(vertices[p.tri.z]);
    let u = interpolate2(p.b, t0, t1, t2);
    let ddx = interpolate2(p.b_dx, t0, t1, t2) - u;
    let ddy = interpolate2(p.b_dy, t0, t1, t2) - u;
    return surface_point_grad(objects[p.object], p.tri, p.b, ddx, ddy);
}
