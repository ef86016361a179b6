// Compute rasterizer of the visibility pass: one thread per triangle writes,
// per covered pixel, one 64-bit `atomicMax(depth_bits << 32 | payload)`
// (reversed Z: nearer is greater, and positive floats order like their
// bits), after a load of the pixel where `params.depth_test` says, which
// skips the atomic where the pixel already holds a larger value (most of
// the covered pixels of a deep scene: the atomic is the costlier access). The payload is the complement of the triangle's index in the
// scene's numbering (objects' triangles back to back, in object order), so
// that at equal depth the triangle drawn first without culling wins, as with
// the raster path's `Greater` test, whichever triangles culling skipped; 0
// (background) is no triangle's. The resolve pass turns it back into
// (object, triangle) through `ranges`.
//
// Under MSAA (`MSAA` defined, `params.samples` per pixel) each pixel holds
// one such value per sample, at Vulkan's standard sample positions (as the
// hardware places them): coverage and depth are tested per sample, an
// alpha-masked triangle is tested once per pixel at its centre (as the
// hardware runs a fragment once per pixel and applies its discard to every
// covered sample).
//
// Two ways to find the triangles: `raster` runs one thread per triangle of
// the visible objects (`ranges`); `raster_clusters` one workgroup per entry of
// a list of clusters that `cull.wgsl` kept, one thread per triangle of it.
#import shadespace::scene_bindings::{view, object_clip_position, objects, triangle_vertices}
#ifdef MSAA
#import shadespace::pixel_surface::standard_sample_position
#endif
#ifdef ALPHA_MASK
#import shadespace::scene::{alpha_cut_by, vertex_uv0}
#import shadespace::scene_bindings::{vertices, albedo, albedo_sampler}
#endif

// Mirrors `visibility::compute::GpuRasterParams`.
struct RasterParams {
    // Entries of `ranges` (visible objects).
    range_count: u32,
    // Visible triangles: the threads of `raster`.
    triangle_count: u32,
    // Entries of `big_tiles`.
    big_capacity: u32,
    // Entries of `big_setups`.
    setup_capacity: u32,
    // Samples per pixel (1 without MSAA).
    samples: u32,
    // 1: read a pixel before its atomicMax and skip the atomic where the
    // pixel already holds a value at least as large (`keep_nearest`).
    depth_test: u32,
    // A thread rasterizes its triangle itself when the bounding box has at
    // most this many pixels; bigger ones go to `raster_big`.
    small_area: u32,
    pad_c: u32,
}

@group(1) @binding(0) var<uniform> params: RasterParams;
// Per visible object, ascending: (object, index of its first triangle in
// this frame's list of visible triangles, index of its first triangle in the
// scene's numbering, 0).
@group(1) @binding(1) var<storage, read> ranges: array<vec4u>;
// Per pixel (under MSAA per sample of a pixel, a pixel's samples side by
// side): depth bits << 32 | payload; 0 = background.
@group(1) @binding(2) var<storage, read_write> depth_ids: array<atomic<u64>>;
// Big triangles' work: (entry of `big_setups`, tile of the triangle's
// bounding box).
@group(1) @binding(3) var<storage, read_write> big_tiles: array<vec2u>;
// Entries appended to `big_tiles` and `big_setups` (either may exceed its
// capacity: see `raster`).
struct BigCounts {
    tiles: atomic<u32>,
    setups: atomic<u32>,
}
@group(1) @binding(4) var<storage, read_write> big_count: BigCounts;
// Big triangles, set up once by the thread that queues their tiles.
@group(1) @binding(5) var<storage, read_write> big_setups: array<Setup>;

// Mirrors `clusters::GpuCluster`.
struct Cluster {
    min: vec3f,
    // First entry of `cluster_triangles`.
    first: u32,
    max: vec3f,
    count: u32,
    center: vec3f,
    radius: f32,
    cone_axis: vec3f,
    cone_cutoff: f32,
}
// Which list of `cluster_lists` a `raster_clusters` dispatch reads.
struct ListParams {
    // Entry of `list_counts` holding its length.
    index: u32,
    // Its first entry in `cluster_lists`.
    base: u32,
}
@group(1) @binding(6) var<storage, read> clusters: array<Cluster>;
// Per cluster entry: a triangle of the cluster's mesh.
@group(1) @binding(7) var<storage, read> cluster_triangles: array<u32>;
// (entry of `ranges`, cluster), written by `cull.wgsl`.
@group(1) @binding(8) var<storage, read> cluster_lists: array<vec2u>;
@group(1) @binding(9) var<storage, read> list_counts: array<u32>;
@group(1) @binding(10) var<uniform> list: ListParams;

#ifdef COUNT
// The profiling variant's work counts (`compute::RasterCount`), each added
// once per thread.
@group(1) @binding(11) var<storage, read_write> counts: array<atomic<u32>, 10>;
#endif

// Adds n to work count `k` (nothing unless built with COUNT).
fn count(k: u32, n: u32) {
#ifdef COUNT
    if n > 0u {
        atomicAdd(&counts[k], n);
    }
#endif
}

// Adds an invocation's atomicMax writes (`back_facing` of them by triangles
// facing away) and the pixels `beaten` rejected since its last call.
fn count_writes(written: u32, back_facing: u32) {
    count(PIXELS_WRITTEN, written);
    count(BACK_FACING_WRITES, back_facing);
#ifdef COUNT
    count(DEPTH_REJECTS, rejects);
    rejects = 0u;
#endif
}

// Indices of `counts`, as `compute::RasterCount` numbers them.
const SMALL_TRIANGLES: u32 = 0u;
const SMALL_PIXELS_TESTED: u32 = 1u;
const BIG_TRIANGLES: u32 = 2u;
const BIG_TILES: u32 = 3u;
const BIG_SQUARES_PASSED: u32 = 4u;
const BIG_PIXELS_TESTED: u32 = 5u;
const PIXELS_WRITTEN: u32 = 6u;
const OVERFLOW_TRIANGLES: u32 = 7u;
const BACK_FACING_WRITES: u32 = 8u;
const DEPTH_REJECTS: u32 = 9u;

// Threads per workgroup of `raster` (`compute::RASTER_WORKGROUP`).
const RASTER_WORKGROUP: u32 = 64u;
// Big triangles (bounds over `params.small_area` pixels) go to `raster_big`
// in BIG_TILE squares, which it tests in SUB_TILE squares (SUB_TILES^2 of
// them) before their pixels.
const BIG_TILE: i32 = 32;
const SUB_TILE: i32 = 8;
const SUB_TILES: i32 = 4;
// Threads per workgroup of `raster_big` (`compute::BIG_WORKGROUP`); its
// workgroups (`SceneGpu::vis_big_workgroups`) loop over the big tiles.
const BIG_WORKGROUP: u32 = 64u;

// Sub-pixel steps of snapped vertices (8 bits), and the guard band in pixels
// beyond which a triangle is rasterized in homogeneous coordinates (keeps the
// fixed-point edge functions below 2^46).
const SUBPIXELS: f32 = 256.0;
const SUBPIXEL_BITS: u32 = 8u;
const GUARD_BAND: f32 = 8192.0;

// A triangle ready to rasterize (members ordered to fill the 32-byte
// alignment of the 64-bit vectors: `big_setups` holds many).
struct Setup {
    // 1: fixed-point edges (`fixed_*`), 0: homogeneous ones (`edge_*`).
    fixed: u32,
    // Bit i: edge i owns the pixels it passes through exactly (top-left rule);
    // bit MASKED: the triangle's object is alpha-masked.
    owns: u32,
    // What `keep_nearest` stores with the depth (see the file's top).
    payload: u32,
    // A big triangle's first entry in `big_tiles`, and the entries from
    // there that hold its tiles (`queue_big` writes them).
    first_tile: u32,
    // Sub-pixel position of the depth plane's origin (`depth`); sub-pixel
    // coordinates inside the guard band fit 32 bits.
    depth_origin: vec2i,
    // 1 when the triangle faces away (clockwise on screen): counted only,
    // as both facings are drawn.
    back_facing: u32,
    queued_tiles: u32,
    // Per edge of the near-clipped polygon, in sub-pixels: the value at pixel (0, 0)'s centre (less one
    // where the edge does not own its pixels, so inside is >= 0), and the
    // steps one pixel right and one pixel down.
    fixed_origin: vec4<i64>,
    fixed_dx: vec4<i64>,
    fixed_dy: vec4<i64>,
    // Edge functions over (ndc.x, ndc.y, 1), oriented so that inside is >= 0.
    edge_a: vec3f,
    edge_b: vec3f,
    edge_c: vec3f,
    // NDC depth (z / w), affine in screen space. Fixed: over sub-pixel
    // offsets from `depth_origin`, from the snapped vertices (as the hardware
    // interpolates it); homogeneous: over (ndc.x, ndc.y, 1).
    depth: vec3f,
    // Inclusive pixel bounds (min x, min y, max x, max y); empty when min > max.
    bounds: vec4i,
}

// `Setup.owns` bit of a triangle whose object is alpha-masked.
const MASKED: u32 = 8u;

// Index of the entry of `ranges` whose component `k` (1: the frame's list,
// 2: the scene's numbering) is the last at most `index`.
fn find_range(index: u32, k: u32) -> u32 {
    var lo = 0u;
    var hi = params.range_count - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if range_entry(mid)[k] <= index {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    return lo;
}

// `raster`'s workgroup copies `ranges` where it holds at most one entry per
// invocation (Sponza's 15): each thread's search for its triangle's object
// (and alpha testing's) then reads workgroup memory, not the buffer.
var<workgroup> cached_ranges: array<vec4u, RASTER_WORKGROUP>;
var<private> ranges_cached: bool;

// Entry `i` of `ranges`, from the workgroup's copy where there is one.
fn range_entry(i: u32) -> vec4u {
    if ranges_cached {
        return cached_ranges[i];
    }
    return ranges[i];
}

// Whether a comes before b in a fixed order of points (lexicographic).
fn before(a: vec3f, b: vec3f) -> bool {
    if a.x != b.x {
        return a.x < b.x;
    }
    if a.y != b.y {
        return a.y < b.y;
    }
    return a.z < b.z;
}

// The edge plane through the eye and clip points a and b, cross(a, b),
// computed from the two points in a fixed order: the triangle on the other
// side of the edge gets the exact negation, so no pixel centre on a shared
// edge is lost to rounding (and the top-left rule gives it to one of them).
fn edge_plane(a: vec3f, b: vec3f) -> vec3f {
    if before(a, b) {
        return cross(a, b);
    }
    return -cross(b, a);
}

// Top-left rule in NDC (y up): an edge owns its pixels when its inward normal
// points right (a left edge), or straight down on screen (a top edge).
fn owns_pixels(edge: vec3f) -> bool {
    return edge.x > 0.0 || (edge.x == 0.0 && edge.y < 0.0);
}

fn ndc_to_pixel(ndc: vec2f) -> vec2f {
    return vec2f(ndc.x + 1.0, 1.0 - ndc.y) * 0.5 * view.viewport.xy - 0.5;
}

// Pixel bounds of the part of the triangle in front of the near plane
// (z <= w), one pixel wider on each side (the edge functions decide).
fn near_clipped_bounds(h: array<vec4f, 3>) -> vec4i {
    var lo = vec2f(3.0e38);
    var hi = vec2f(-3.0e38);
    for (var i = 0u; i < 3u; i++) {
        let a = h[i];
        let b = h[(i + 1u) % 3u];
        let da = a.w - a.z;
        let db = b.w - b.z;
        if da >= 0.0 && a.w > 0.0 {
            let p = a.xy / a.w;
            lo = min(lo, p);
            hi = max(hi, p);
        }
        if (da < 0.0) != (db < 0.0) {
            let c = mix(a, b, da / (da - db));
            if c.w > 0.0 {
                let p = c.xy / c.w;
                lo = min(lo, p);
                hi = max(hi, p);
            }
        }
    }
    if lo.x > hi.x {
        return vec4i(0, 0, -1, -1);
    }
    // NDC y grows up, pixel rows down; clamp before converting to integers.
    let size = view.viewport.xy;
    let p_lo = clamp(ndc_to_pixel(vec2f(lo.x, hi.y)), vec2f(-2.0), size + 1.0);
    let p_hi = clamp(ndc_to_pixel(vec2f(hi.x, lo.y)), vec2f(-2.0), size + 1.0);
    let last = vec2i(size) - 1;
    let min_px = max(vec2i(ceil(p_lo)) - 1, vec2i(0));
    let max_px = min(vec2i(floor(p_hi)) + 1, last);
    return vec4i(min_px, max_px);
}

fn cross_i64(a: vec2<i64>, b: vec2<i64>) -> i64 {
    return a.x * b.y - a.y * b.x;
}

// Sets up `s`'s fixed-point edges: the triangle is clipped against the near
// plane (z <= w) into a convex polygon of up to four vertices, as the
// hardware clips it, then snapped. Coverage is the intersection of the
// polygon's edges, each with the top-left rule: the same pixels as the
// hardware's fan of triangles, whose inner edges cover each pixel once.
// Returns false (and leaves `s`) when a vertex lies beyond the guard band.
fn setup_fixed(h: array<vec4f, 3>, s: ptr<function, Setup>) -> bool {
    let half = 0.5 * view.viewport.xy;
    var v: array<vec2<i64>, 4>;
    var z: array<f32, 4>;
    var n = 0u;
    var lo = vec2f(3.0e38);
    var hi = vec2f(-3.0e38);
    for (var i = 0u; i < 3u; i++) {
        let a = h[i];
        let b = h[(i + 1u) % 3u];
        let da = a.w - a.z;
        let db = b.w - b.z;
        var points = array<vec4f, 2>(a, mix(a, b, da / (da - db)));
        let keep = vec2<bool>(da >= 0.0, (da < 0.0) != (db < 0.0));
        for (var k = 0u; k < 2u; k++) {
            if !keep[k] {
                continue;
            }
            let c = points[k];
            if !(c.w > 0.0) {
                return false;
            }
            // The viewport transform (y down), then the snap.
            let ndc = c.xy / c.w;
            let p = vec2f(ndc.x, -ndc.y) * half + half;
            if !all(abs(p - half) <= vec2f(GUARD_BAND)) {
                return false;
            }
            v[n] = vec2<i64>(round(p * SUBPIXELS));
            z[n] = c.z / c.w;
            lo = min(lo, p);
            hi = max(hi, p);
            n++;
        }
    }
    (*s).fixed = 1u;
    (*s).bounds = vec4i(0, 0, -1, -1);
    if n < 3u {
        return true;
    }
    // Twice the signed area (shoelace): 0 is degenerate after snapping, no
    // pixels, as in the hardware; clockwise polygons get their edges flipped
    // (both facings are drawn).
    var area = 0li;
    for (var i = 0u; i < n; i++) {
        let a = v[i];
        let b = v[(i + 1u) % n];
        area += a.x * b.y - a.y * b.x;
    }
    if area == 0li {
        return true;
    }
    let facing = select(1li, -1li, area > 0li);
    let unit = i64(SUBPIXELS);
    let centre = unit / 2li;
    // A missing fourth edge, or one of zero length, passes every pixel.
    var origin = vec4<i64>(0li);
    var step_x = vec4<i64>(0li);
    var step_y = vec4<i64>(0li);
    for (var i = 0u; i < n; i++) {
        let a = v[i];
        let d = (v[(i + 1u) % n] - a) * facing;
        if all(d == vec2<i64>(0li)) {
            continue;
        }
        // E(p) = d.y (p.x - a.x) - d.x (p.y - a.y): positive inside.
        step_x[i] = d.y * unit;
        step_y[i] = -d.x * unit;
        // Top-left rule (y down): an edge owns its pixels when the inside
        // lies to its right (a left edge) or straight below it (a top edge).
        let owns = step_x[i] > 0li || (step_x[i] == 0li && step_y[i] > 0li);
        origin[i] = d.y * (centre - a.x) - d.x * (centre - a.y) - select(1li, 0li, owns);
    }
    // The depth plane through vertex 0 and the larger of the fan's triangles.
    let a1 = cross_i64(v[1] - v[0], v[2] - v[0]);
    let a2 = cross_i64(v[2] - v[0], v[3] - v[0]);
    let k = select(1u, 2u, n == 4u && abs(a2) > abs(a1));
    let e1 = vec2f(v[k] - v[0]);
    let e2 = vec2f(v[k + 1u] - v[0]);
    let dz = vec2f(z[k] - z[0], z[k + 1u] - z[0]);
    let det = f32(select(a1, a2, k == 2u));
    (*s).depth = vec3f((dz.x * e2.y - dz.y * e1.y) / det, (e1.x * dz.y - e2.x * dz.x) / det, z[0]);
    (*s).depth_origin = vec2i(v[0]);
    (*s).fixed_origin = origin;
    (*s).fixed_dx = step_x;
    (*s).fixed_dy = step_y;
    // Pixels whose centres the polygon's box holds, one more on each side.
    let last = vec2i(view.viewport.xy) - 1;
    (*s).bounds = vec4i(max(vec2i(ceil(lo - 0.5)) - 1, vec2i(0)), min(vec2i(floor(hi - 0.5)) + 1, last));
    return true;
}

// Sets up triangle `triangle` of `object`, whose payload is `payload`.
fn setup_triangle(object: u32, triangle: u32, payload: u32) -> Setup {
    let tri = triangle_vertices(objects[object], triangle);
    let h = array<vec4f, 3>(
        object_clip_position(object, tri.x),
        object_clip_position(object, tri.y),
        object_clip_position(object, tri.z),
    );
    var s: Setup;
    s.payload = payload;
    s.bounds = vec4i(0, 0, -1, -1);
#ifdef ALPHA_MASK
    let masked = select(0u, MASKED, objects[object].alpha_cutoff > 0.0);
#else
    let masked = 0u;
#endif
    // Wholly behind the far plane (z < 0).
    if all(vec3f(h[0].z, h[1].z, h[2].z) < vec3f(0.0)) {
        return s;
    }
    let c = array<vec3f, 3>(h[0].xyw, h[1].xyw, h[2].xyw);
    let n = array<vec3f, 3>(edge_plane(c[1], c[2]), edge_plane(c[2], c[0]), edge_plane(c[0], c[1]));
    // det > 0: counter-clockwise on screen; 0: the triangle's plane holds the
    // eye (seen edge-on: no pixels, as in the hardware).
    let det = dot(c[0], n[0]);
    if det == 0.0 {
        return s;
    }
#ifdef CULL_BACK
    // Clockwise: a back face, culled where the object's material is
    // single-sided as the raster pipelines cull it (the sign of the
    // homogeneous determinant, as the hardware decides it).
    if det < 0.0 && objects[object].cull_back != 0u {
        return s;
    }
#endif
    // sum_i e_i(q) c_i = det (q, 1), so the depth is sum_i e_i(q) z_i / det.
    s.depth = (n[0] * h[0].z + n[1] * h[1].z + n[2] * h[2].z) / det;
    s.back_facing = select(0u, 1u, det < 0.0);
    if setup_fixed(h, &s) {
        s.owns = masked;
        return s;
    }
    // The facings left are drawn, as the raster path draws them.
    let inward = sign(det);
    s.edge_a = n[0] * inward;
    s.edge_b = n[1] * inward;
    s.edge_c = n[2] * inward;
    s.owns = select(0u, 1u, owns_pixels(s.edge_a)) | select(0u, 2u, owns_pixels(s.edge_b))
        | select(0u, 4u, owns_pixels(s.edge_c)) | masked;
    s.bounds = near_clipped_bounds(h);
    return s;
}

fn inside(e: f32, owns: bool) -> bool {
    return e > 0.0 || (e == 0.0 && owns);
}

fn fixed_depth(s: Setup, p: vec2i) -> f32 {
    return fixed_depth_at(s, p, vec2i(i32(SUBPIXELS / 2.0)));
}

// The depth at sub-pixel `sub` (from the pixel's top-left corner) of pixel p.
fn fixed_depth_at(s: Setup, p: vec2i, sub: vec2i) -> f32 {
    let offset = vec2f(p * i32(SUBPIXELS) + sub - s.depth_origin);
    return dot(s.depth, vec3f(offset, 1.0));
}

fn pixel_index(p: vec2i) -> u32 {
    return u32(p.y) * u32(view.viewport.x) + u32(p.x);
}

#ifdef ALPHA_MASK
// UV0 at pixel p of the triangle whose homogeneous edge planes are n0-n2 and
// vertex UVs uv0-uv2: the edge functions weigh the vertices perspective-
// correctly (they sum to the determinant, which the division removes).
fn uv_at(n0: vec3f, n1: vec3f, n2: vec3f, uv0: vec2f, uv1: vec2f, uv2: vec2f, p: vec2f) -> vec2f {
    let px = (p + 0.5) * view.viewport.zw;
    let q = vec3f(px.x * 2.0 - 1.0, 1.0 - px.y * 2.0, 1.0);
    let e = vec3f(dot(n0, q), dot(n1, q), dot(n2, q));
    return (e.x * uv0 + e.y * uv1 + e.z * uv2) / (e.x + e.y + e.z);
}

// What alpha testing needs of a masked triangle: its homogeneous edge
// planes and vertex UVs (`uv_at`), its object's texture layer, base alpha
// and cutoff. Fetched once per triangle (per tile of a big one: `load_mask`)
// into `mask`: fetched per covered pixel (the triangle found by binary
// search over the ranges, its indices, vertices and transform) it made
// Sponza's `vis: raster` 0.045 ms slower on the H200 at 1920x1080 than the
// same scene with no masks.
struct Mask {
    n0: vec3f,
    n1: vec3f,
    n2: vec3f,
    t0: vec2f,
    t1: vec2f,
    t2: vec2f,
    layer: u32,
    base_alpha: f32,
    cutoff: f32,
}
var<private> mask: Mask;

// Fetches scene triangle ~payload's `Mask` into `mask`.
fn load_mask(payload: u32) {
    let index = ~payload;
    let range = range_entry(find_range(index, 2u));
    let o = objects[range.x];
    let tri = triangle_vertices(o, index - range.z);
    let c0 = object_clip_position(range.x, tri.x).xyw;
    let c1 = object_clip_position(range.x, tri.y).xyw;
    let c2 = object_clip_position(range.x, tri.z).xyw;
    mask = Mask(cross(c1, c2), cross(c2, c0), cross(c0, c1), vertex_uv0(vertices[tri.x]),
        vertex_uv0(vertices[tri.y]), vertex_uv0(vertices[tri.z]), o.albedo_layer, o.base_color.a, o.alpha_cutoff);
}

// Whether the triangle of `mask` (`load_mask`), of an alpha-masked object,
// is cut away at pixel p: its base colour texel's alpha there, at the level
// its UV derivatives across the pixel's 2x2 quad give, as fragment shaders
// take them (coarse: from the quad's first pixel), against the object's
// cutoff. On lavapipe the ids of masked scenes then
// differ from the raster path's on 0.01-0.05 % of the pixels (0.3 % with
// derivatives one pixel ahead, 0.04-0.08 % with fine ones); on the H100
// masked borders differ more, with either (BENCHMARKS.md).
fn cut_away(p: vec2i) -> bool {
    let m = mask;
    let quad = vec2f(p & vec2i(-2));
    let uv = uv_at(m.n0, m.n1, m.n2, m.t0, m.t1, m.t2, vec2f(p));
    let corner = uv_at(m.n0, m.n1, m.n2, m.t0, m.t1, m.t2, quad);
    // Scaled by 2^bias: the view's texture_lod_bias, as the raster path's
    // `textureSampleBias` applies it.
    let scale = exp2(view.texture_lod_bias);
    let ddx = (uv_at(m.n0, m.n1, m.n2, m.t0, m.t1, m.t2, quad + vec2f(1.0, 0.0)) - corner) * scale;
    let ddy = (uv_at(m.n0, m.n1, m.n2, m.t0, m.t1, m.t2, quad + vec2f(0.0, 1.0)) - corner) * scale;
    let alpha = textureSampleGrad(albedo, albedo_sampler, uv, m.layer, ddx, ddy).a;
    return alpha_cut_by(m.base_alpha, m.cutoff, alpha);
}
#endif

#ifdef COUNT
// This invocation's pixels (samples) that `beaten` rejected, added to
// DEPTH_REJECTS with its other counts.
var<private> rejects: u32;
#endif

// Whether entry `index` of `depth_ids` already holds `value` or more, so
// that an atomicMax of `value` would change nothing (the entries only grow
// during the pass): a load instead of the read-modify-write, as the
// hardware's depth test rejects a fragment before it writes.
fn beaten(index: u32, value: u64) -> bool {
    if atomicLoad(&depth_ids[index]) >= value {
#ifdef COUNT
        rejects++;
#endif
        return true;
    }
    return false;
}

// Keeps the nearer of pixel p's surface and a triangle at `depth` (`owns`:
// its setup's flags; an alpha-masked triangle's cut-away pixels are not
// kept). With `params.depth_test` (and always for a masked triangle, whose
// texture is read only where it would be kept) the pixel is read first and
// the atomic skipped where it would not win. Returns 1 when it issued the
// atomicMax, else 0.
fn keep_nearest(payload: u32, owns: u32, p: vec2i, depth: f32) -> u32 {
    // Clip to the depth range, as the hardware does (the background is 0).
    if !(depth > 0.0 && depth <= 1.0) {
        return 0u;
    }
    let pixel = pixel_index(p);
    let value = (u64(bitcast<u32>(depth)) << 32u) | u64(payload);
    let masked = (owns & MASKED) != 0u;
    if (params.depth_test != 0u || masked) && beaten(pixel, value) {
        return 0u;
    }
#ifdef ALPHA_MASK
    if masked && cut_away(p) {
        return 0u;
    }
#endif
    atomicMax(&depth_ids[pixel], value);
    return 1u;
}

// (NDC x, y, 1) of the point `xy` pixels from the image's top-left corner.
fn ndc_point(xy: vec2f) -> vec3f {
    let uv = xy * view.viewport.zw;
    return vec3f(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 1.0);
}

// Whether a triangle with homogeneous edges covers NDC point q.
fn inside_homogeneous(s: Setup, q: vec3f) -> bool {
    return inside(dot(s.edge_a, q), (s.owns & 1u) != 0u) && inside(dot(s.edge_b, q), (s.owns & 2u) != 0u)
        && inside(dot(s.edge_c, q), (s.owns & 4u) != 0u);
}

// Tests pixel p against a triangle with homogeneous edges and keeps the
// nearest surface; returns the atomics it issued.
fn raster_pixel_homogeneous(s: Setup, p: vec2i) -> u32 {
    let q = ndc_point(vec2f(p) + 0.5);
    if inside_homogeneous(s, q) {
        return keep_nearest(s.payload, s.owns, p, dot(s.depth, q));
    }
    return 0u;
}

#ifdef MSAA
// Sample k's position (0..1 from the pixel's top-left corner), sub-pixel
// position, and what its fixed-point edge functions add to the pixel
// centre's (exact: the standard positions are sixteenths of a pixel).
// Computed where used rather than kept in per-triangle arrays: arrays
// indexed by the sample at run time made lavapipe's compile of this shader
// several times longer (the MSAA tests' largest cost from a cold driver
// cache) and live in local memory on GPUs.
struct SampleStep {
    at: vec2f,
    sub: vec2i,
    edge: vec4<i64>,
}

fn sample_step(s: Setup, k: u32) -> SampleStep {
    let at = standard_sample_position(params.samples, k);
    let sub = vec2i(round(at * SUBPIXELS));
    // A pixel's step is SUBPIXELS sub-pixels' (a multiple of it).
    let o = vec2<i64>(sub - i32(SUBPIXELS / 2.0));
    return SampleStep(at, sub, (s.fixed_dx * o.x + s.fixed_dy * o.y) >> vec4u(SUBPIXEL_BITS));
}

// Per edge, the most any sample adds: a pixel whose centre's edge functions
// plus this are not all >= 0 has no covered sample. Set up once a triangle.
fn sample_reach(s: Setup) -> vec4<i64> {
    var reach = vec4<i64>(-(1li << 62u));
    for (var k = 0u; k < params.samples; k++) {
        reach = max(reach, sample_step(s, k).edge);
    }
    return reach;
}

// Tests the samples of pixel p against a triangle (`e`: its fixed-point
// edge functions at the pixel centre; unused with homogeneous edges;
// `reach`: its `sample_reach`) and keeps, per covered sample, the nearer
// surface; returns the atomics it issued.
fn raster_samples(s: Setup, reach: vec4<i64>, p: vec2i, e: vec4<i64>) -> u32 {
    if s.fixed != 0u && any(e + reach < vec4<i64>(0li)) {
        return 0u;
    }
    let base = pixel_index(p) * params.samples;
    var written = 0u;
    var masked = (s.owns & MASKED) != 0u;
    for (var k = 0u; k < params.samples; k++) {
        var depth = 0.0;
        let step = sample_step(s, k);
        if s.fixed != 0u {
            if any(e + step.edge < vec4<i64>(0li)) {
                continue;
            }
            depth = fixed_depth_at(s, p, step.sub);
        } else {
            let q = ndc_point(vec2f(p) + step.at);
            if !inside_homogeneous(s, q) {
                continue;
            }
            depth = dot(s.depth, q);
        }
        // Clip to the depth range, as the hardware does (the background is 0).
        if !(depth > 0.0 && depth <= 1.0) {
            continue;
        }
        let value = (u64(bitcast<u32>(depth)) << 32u) | u64(s.payload);
        if (params.depth_test != 0u || masked) && beaten(base + k, value) {
            continue;
        }
#ifdef ALPHA_MASK
        // The texture is read once, where the triangle would first be kept
        // (`written` is still 0): its cut decides every sample of the pixel.
        if masked {
            if cut_away(p) {
                return 0u;
            }
            masked = false;
        }
#endif
        atomicMax(&depth_ids[base + k], value);
        written++;
    }
    return written;
}
#endif

// Rasterizes the pixels of [lo, hi]; fixed-point edges step by additions
// (64-bit multiplies are several instructions on GPUs). Returns the atomics
// it issued.
fn raster_rect(s: Setup, lo: vec2i, hi: vec2i) -> u32 {
    var written = 0u;
#ifdef ALPHA_MASK
    if (s.owns & MASKED) != 0u {
        load_mask(s.payload);
    }
#endif
#ifdef MSAA
    let reach = sample_reach(s);
#endif
    if s.fixed == 0u {
        for (var y = lo.y; y <= hi.y; y++) {
            for (var x = lo.x; x <= hi.x; x++) {
#ifdef MSAA
                written += raster_samples(s, reach, vec2i(x, y), vec4<i64>(0li));
#else
                written += raster_pixel_homogeneous(s, vec2i(x, y));
#endif
            }
        }
        return written;
    }
    var row = s.fixed_origin + s.fixed_dx * i64(lo.x) + s.fixed_dy * i64(lo.y);
    for (var y = lo.y; y <= hi.y; y++) {
        var e = row;
        for (var x = lo.x; x <= hi.x; x++) {
#ifdef MSAA
            written += raster_samples(s, reach, vec2i(x, y), e);
#else
            if all(e >= vec4<i64>(0li)) {
                written += keep_nearest(s.payload, s.owns, vec2i(x, y), fixed_depth(s, vec2i(x, y)));
            }
#endif
            e += s.fixed_dx;
        }
        row += s.fixed_dy;
    }
    return written;
}

// Pixel bounds of tile `t` of a big triangle's bounding box.
fn big_tile_rect(bounds: vec4i, t: u32) -> vec4i {
    let tiles_x = u32((bounds.z - bounds.x) / BIG_TILE + 1);
    let lo = bounds.xy + vec2i(vec2u(t % tiles_x, t / tiles_x)) * BIG_TILE;
    return vec4i(lo, min(lo + BIG_TILE - 1, bounds.zw));
}

@compute @workgroup_size(RASTER_WORKGROUP)
fn raster(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    ranges_cached = params.range_count <= RASTER_WORKGROUP;
    if ranges_cached && local < params.range_count {
        cached_ranges[local] = ranges[local];
    }
    workgroupBarrier();
    let index = (group.y * groups.x + group.x) * RASTER_WORKGROUP + local;
    if index >= params.triangle_count {
        return;
    }
    let range = range_entry(find_range(index, 1u));
    let triangle = index - range.y;
    raster_triangle(setup_triangle(range.x, triangle, ~(range.z + triangle)));
}

// One workgroup per entry of the list `list` names (dispatched indirectly,
// `cull.wgsl`'s `finish` sizes it): thread i rasterizes the cluster's
// triangle i.
@compute @workgroup_size(RASTER_WORKGROUP)
fn raster_clusters(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) local: u32,
) {
    let entry = group.y * groups.x + group.x;
    if entry >= list_counts[list.index] {
        return;
    }
    let item = cluster_lists[list.base + entry];
    let c = clusters[item.y];
    if local >= c.count {
        return;
    }
    let range = ranges[item.x];
    let triangle = cluster_triangles[c.first + local];
    raster_triangle(setup_triangle(range.x, triangle, ~(range.z + triangle)));
}

// Rasterizes a set-up triangle: small ones here, big ones queued for
// `raster_big` as tiles.
fn raster_triangle(s: Setup) {
    let extent = s.bounds.zw - s.bounds.xy + 1;
    if any(extent <= vec2i(0)) {
        return;
    }
    let area = u32(extent.x * extent.y);
    if area <= params.small_area {
        let written = raster_rect(s, s.bounds.xy, s.bounds.zw);
        count_writes(written, written * s.back_facing);
        count(SMALL_TRIANGLES, 1u);
        count(SMALL_PIXELS_TESTED, area);
        return;
    }
    // Big: set up once, its tiles queued for whole workgroups; past either
    // queue's capacity this thread rasterizes them itself (slow, but no pixel
    // is lost).
    let tiles = vec2u((extent + BIG_TILE - 1) / BIG_TILE);
    let tile_count = tiles.x * tiles.y;
    let slot = atomicAdd(&big_count.setups, 1u);
    if slot >= params.setup_capacity {
        let written = raster_rect(s, s.bounds.xy, s.bounds.zw);
        count_writes(written, written * s.back_facing);
        count(OVERFLOW_TRIANGLES, 1u);
        return;
    }
    let first = atomicAdd(&big_count.tiles, tile_count);
    var queued = s;
    queued.first_tile = first;
    queued.queued_tiles = min(tile_count, params.big_capacity - min(first, params.big_capacity));
    big_setups[slot] = queued;
    // `queue_big` lists the queued tiles; the rest are drawn here.
    var written = 0u;
    for (var t = queued.queued_tiles; t < tile_count; t++) {
        let r = big_tile_rect(s.bounds, t);
        written += raster_rect(s, r.xy, r.zw);
    }
    count_writes(written, written * s.back_facing);
    count(BIG_TRIANGLES, 1u);
    count(BIG_TILES, queued.queued_tiles);
    count(OVERFLOW_TRIANGLES, select(0u, 1u, first + tile_count > params.big_capacity));
}

// The largest value fixed-point edge function `i` of `s` takes over the
// pixels of [lo, hi] (at the corner its inside points to).
fn edge_max(s: Setup, i: u32, lo: vec2i, hi: vec2i) -> i64 {
    let x = select(lo.x, hi.x, s.fixed_dx[i] > 0li);
    let y = select(lo.y, hi.y, s.fixed_dy[i] > 0li);
    let at_centre = s.fixed_origin[i] + s.fixed_dx[i] * i64(x) + s.fixed_dy[i] * i64(y);
#ifdef MSAA
    // Samples lie up to half a pixel from the centre along each axis.
    return at_centre + ((abs(s.fixed_dx[i]) + abs(s.fixed_dy[i])) >> 1u);
#else
    return at_centre;
#endif
}

// Whether a triangle may cover a pixel of [lo, hi]: every edge has a pixel of
// the rectangle inside its half-plane (under MSAA a sample of one; conservative: near a triangle's
// corners a rectangle can pass and hold no covered pixel).
fn may_cover(s: Setup, lo: vec2i, hi: vec2i) -> bool {
    if any(lo > hi) {
        return false;
    }
    if s.fixed == 0u {
        return true;
    }
    return edge_max(s, 0u, lo, hi) >= 0li && edge_max(s, 1u, lo, hi) >= 0li && edge_max(s, 2u, lo, hi) >= 0li
        && edge_max(s, 3u, lo, hi) >= 0li;
}

// Lists each big triangle's queued tiles in `big_tiles`: a workgroup per
// triangle (looping over them), an invocation per tile. Listed by the
// triangle's own thread in `raster`, a screen-wide triangle's 2,000 serial
// writes (8,000 at 3840x2160) set the length of that whole pass.
@compute @workgroup_size(BIG_WORKGROUP)
fn queue_big(@builtin(workgroup_id) group: vec3u, @builtin(num_workgroups) groups: vec3u,
             @builtin(local_invocation_index) local: u32) {
    let setups = min(atomicLoad(&big_count.setups), params.setup_capacity);
    for (var slot = group.x; slot < setups; slot += groups.x) {
        let first = big_setups[slot].first_tile;
        let count = big_setups[slot].queued_tiles;
        for (var t = local; t < count; t += BIG_WORKGROUP) {
            big_tiles[first + t] = vec2u(slot, t);
        }
    }
}

var<workgroup> shared_count: u32;
// The squares of the current tile the triangle may cover, a bit each (two
// masks, by the tile's parity in the workgroup's loop: the one for the next
// tile is cleared while this one is read), and the edge functions at each
// square's first pixel.
var<workgroup> live_masks: array<atomic<u32>, 2>;
var<workgroup> square_edges: array<vec4<i64>, 16>;

// One workgroup per big-triangle tile (a fixed number of workgroups looping
// over the queue). The first SUB_TILES^2 threads test the tile's SUB_TILE squares
// against the triangle's edges (a thin triangle's box is mostly empty); then
// each thread tests its pixel of every square that passed, and only those.
@compute @workgroup_size(BIG_WORKGROUP)
fn raster_big(@builtin(workgroup_id) group: vec3u, @builtin(num_workgroups) groups: vec3u,
              @builtin(local_invocation_index) local: u32) {
    if local == 0u {
        shared_count = min(atomicLoad(&big_count.tiles), params.big_capacity);
    }
    let queued = workgroupUniformLoad(&shared_count);
    var passed = 0u;
    var tested = 0u;
    var written = 0u;
    var back_facing = 0u;
    let in_square = vec2i(i32(local) % SUB_TILE, i32(local) / SUB_TILE);
    var parity = 0u;
    for (var i = group.x; i < queued; i += groups.x) {
        let item = big_tiles[i];
        let s = big_setups[item.x];
        let r = big_tile_rect(s.bounds, item.y);
#ifdef ALPHA_MASK
        if (s.owns & MASKED) != 0u {
            load_mask(s.payload);
        }
#endif
#ifdef MSAA
        let reach = sample_reach(s);
#endif
        if local < u32(SUB_TILES * SUB_TILES) {
            let lo = r.xy + vec2i(i32(local) % SUB_TILES, i32(local) / SUB_TILES) * SUB_TILE;
            if may_cover(s, lo, min(lo + SUB_TILE - 1, r.zw)) {
                atomicOr(&live_masks[parity], 1u << local);
                square_edges[local] = s.fixed_origin + s.fixed_dx * i64(lo.x) + s.fixed_dy * i64(lo.y);
                passed++;
            }
        }
        if local == 0u {
            // Last read in the previous tile, before the barrier that ended it.
            atomicStore(&live_masks[parity ^ 1u], 0u);
        }
        workgroupBarrier();
        var live = atomicLoad(&live_masks[parity]);
        // This thread's pixel's offset from each square's first pixel.
        let offset = s.fixed_dx * i64(in_square.x) + s.fixed_dy * i64(in_square.y);
        while live != 0u {
            let k = firstTrailingBit(live);
            live &= live - 1u;
            let p = r.xy + vec2i(i32(k) % SUB_TILES, i32(k) / SUB_TILES) * SUB_TILE + in_square;
            if any(p > r.zw) {
                continue;
            }
            tested++;
            let at = square_edges[k] + offset;
#ifdef MSAA
            let w = raster_samples(s, reach, p, at);
            written += w;
            back_facing += w * s.back_facing;
#else
            if s.fixed == 0u {
                let w = raster_pixel_homogeneous(s, p);
                written += w;
                back_facing += w * s.back_facing;
                continue;
            }
            if all(at >= vec4<i64>(0li)) {
                let w = keep_nearest(s.payload, s.owns, p, fixed_depth(s, p));
                written += w;
                back_facing += w * s.back_facing;
            }
#endif
        }
        // The next tile's testers rewrite `square_edges` after this barrier.
        parity ^= 1u;
        workgroupBarrier();
    }
    count(BIG_SQUARES_PASSED, passed);
    count(BIG_PIXELS_TESTED, tested);
    count_writes(written, back_facing);
}
