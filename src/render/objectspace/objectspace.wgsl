// What the object-space passes share: the atlas table, the tile buffers, the
// visibility buffer, and the per-pixel mip selection that tile marking and
// gathering must compute identically.
#define_import_path shadespace::objectspace
#import shadespace::contract::{MAX_LEVELS, TILE_COUNTER_SLOTS}
#import shadespace::scene_bindings::vertices
#import shadespace::pixel_surface::{PixelSample, interpolate2}

struct AtlasLevel {
    page: u32,
    // x | y << 16
    origin: u32,
    size: u32,
    tile_base: u32,
}

// Mirrors `objectspace::atlas::GpuAtlasEntry` (and `AtlasLevel` its
// `GpuAtlasLevel`).
struct AtlasEntry {
    size: u32,
    level_count: u32,
    valid_since: u32,
    mip_bias: f32,
    levels: array<AtlasLevel, MAX_LEVELS>,
}

// Mirrors `objectspace::resources::GpuParams`.
struct Params {
    // frame + 1: 0 in the stamp buffers means "never".
    stamp: u32,
    // Re-shade a visible tile when its shade is this many frames old (N).
    reuse: u32,
    tile_size: u32,
    // 0 = shade, else a debug view (see gather.wgsl).
    view_mode: u32,
    mip_bias: f32,
    // Strength of the per-pixel variable-rate bias (0 = off).
    variable_rate: f32,
    max_queue: u32,
    pad: u32,
}

@group(1) @binding(0) var<uniform> params: Params;
@group(1) @binding(1) var<storage, read> atlas_entries: array<AtlasEntry>;
// Per tile: stamp of the last frame it was visible.
@group(1) @binding(2) var<storage, read_write> tile_visible: array<atomic<u32>>;
// Per tile: stamp of the last frame it was shaded (the cache age).
@group(1) @binding(3) var<storage, read_write> tile_shaded: array<u32>;
// Work list: (global tile, object << 8 | level).
@group(1) @binding(4) var<storage, read_write> queue: array<vec2u>;
// Indexed by the `COUNT_*` constants.
@group(1) @binding(5) var<storage, read_write> counters: array<atomic<u32>, TILE_COUNTER_SLOTS>;
// Visibility buffer: (object + 1, triangle); 0 = background.
@group(1) @binding(6) var visibility: texture_2d<u32>;
// Per atlas texel: triangle + 1 covering it; 0 = empty.
@group(1) @binding(7) var triangle_map: texture_2d_array<u32>;
// Per triangle of the scene's index buffer: its chart island (a number
// shared by the triangles of one island of its mesh's chart UVs).
@group(1) @binding(8) var<storage, read> triangle_charts: array<u32>;

// Chart UV of the pixel and its screen derivatives.
struct ChartFootprint {
    uv: vec2f,
    du_dx: vec2f,
    du_dy: vec2f,
}

fn chart_footprint(p: PixelSample) -> ChartFootprint {
    let a = vertices[p.tri.x].chart_uv;
    let c = vertices[p.tri.y].chart_uv;
    let d = vertices[p.tri.z].chart_uv;
    var f: ChartFootprint;
    f.uv = interpolate2(p.b, a, c, d);
    f.du_dx = interpolate2(p.b_dx, a, c, d) - f.uv;
    f.du_dy = interpolate2(p.b_dy, a, c, d) - f.uv;
    return f;
}

// Variable rate: a positive bias (coarser shading) where the triangle is flat,
// none where its vertex normals diverge.
fn variable_rate_bias(p: PixelSample) -> f32 {
    if params.variable_rate <= 0.0 {
        return 0.0;
    }
    let n0 = normalize(vertices[p.tri.x].normal);
    let n1 = normalize(vertices[p.tri.y].normal);
    let n2 = normalize(vertices[p.tri.z].normal);
    let min_dot = min(dot(n0, n1), min(dot(n1, n2), dot(n0, n2)));
    let curvature = clamp((1.0 - min_dot) * 8.0, 0.0, 1.0);
    return params.variable_rate * (1.0 - curvature);
}

// The mip level a pixel shades at and gathers from:
// round(log2(max(|dUV/dx|, |dUV/dy|) * size) + biases), clamped to the levels.
fn select_level(e: AtlasEntry, p: PixelSample, f: ChartFootprint) -> u32 {
    let size = f32(e.size);
    let rho = max(length(f.du_dx), length(f.du_dy)) * size;
    let lod = log2(max(rho, 1e-8)) + params.mip_bias + e.mip_bias + variable_rate_bias(p);
    return u32(clamp(round(lod), 0.0, f32(e.level_count - 1u)));
}

fn level_origin(l: AtlasLevel) -> vec2u {
    return vec2u(l.origin & 0xffffu, l.origin >> 16u);
}

// The bilinear footprint at a level: top-left texel (level-local, clamped so
// that both taps lie in the level) and the weight of the right/lower taps.
struct Bilinear {
    texel: vec2i,
    texel_hi: vec2i,
    weight: vec2f,
}

fn bilinear(l: AtlasLevel, uv: vec2f) -> Bilinear {
    let s = i32(l.size);
    let t = uv * f32(l.size) - 0.5;
    let base = floor(t);
    var out: Bilinear;
    out.weight = t - base;
    out.texel = clamp(vec2i(base), vec2i(0), vec2i(s - 1));
    out.texel_hi = clamp(vec2i(base) + 1, vec2i(0), vec2i(s - 1));
    return out;
}
