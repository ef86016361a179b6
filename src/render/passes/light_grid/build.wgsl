// What the passes that build a light grid share: their bindings (group 1;
// group 0 is the scene, whose light buffer they read), the conservative
// light-versus-cell test, and how a (light, cell) hit is counted or listed.
//
// A build: `count` (one 32-lane group of threads per work item: a light, or
// a slice of a light with many cells, over the cells its bounds cover:
// counts[cell] += 1) -> `scan_blocks`, `scan_sums`, `scan_add`
// (exclusive prefix sum of the counts: each cell's first entry) -> `fill`
// (the same loop: list[first + --counts[cell]] = light) -> `finish` (the
// cell's range is the entries fill wrote; counts back to zero for the next
// frame).
#define_import_path shadespace::light_grid_build
#import shadespace::contract::LIGHT_SPOT
#import shadespace::light_grid::LightGridParams

@group(1) @binding(0) var<uniform> params: LightGridParams;
// Per cell: lights counted (zero between builds).
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;
// Per cell: (first entry, entry count).
@group(1) @binding(2) var<storage, read_write> cells: array<vec2u>;
@group(1) @binding(3) var<storage, read_write> list: array<u32>;
// Per block of SCAN_BLOCK cells: its total, then its first entry.
@group(1) @binding(4) var<storage, read_write> block_sums: array<u32>;
// [0]: entries of all cells (saturated), read back to grow the list.
@group(1) @binding(5) var<storage, read_write> status: array<u32>;
// Per work item: (light among the grid's lights, slice | slices << 16). A
// light's cells are dealt to its slices LANES at a time, so that one light
// covering the whole grid is walked by many groups, not one.
@group(1) @binding(6) var<storage, read> work: array<vec2u>;

// Threads per work item in `count` and `fill`: they share its cells.
const LANES: u32 = 32u;
// Work items per 64-thread workgroup.
const ITEMS_PER_GROUP: u32 = 2u;

// What an invocation walks: the light (an index into `lights`) and its
// first cell and step in the light's cell order.
struct Work {
    light: u32,
    first: u32,
    step: u32,
}

// The work of this invocation; `None` (a light past `view.light_count`)
// when the dispatch has more threads than items. Workgroups may be laid out
// in 2D when there are more than 65535.
fn work_of(wg: vec3u, groups: vec3u, lid: u32, first_light: u32) -> Work {
    let item = (wg.y * groups.x + wg.x) * ITEMS_PER_GROUP + lid / LANES;
    let lane = lid % LANES;
    if item >= params.work_count {
        return Work(0xffffffffu, 0u, 0u);
    }
    let w = work[item];
    let slice = w.y & 0xffffu;
    let slices = w.y >> 16u;
    return Work(first_light + w.x, slice * LANES + lane, slices * LANES);
}

// The radius a light is binned with: a 1/1024 margin (and 0.1 mm) so that
// rounding in transforms and cell bounds never drops a light at its edge,
// where it adds nothing anyway.
fn binning_radius(radius: f32) -> f32 {
    return radius * (1.0 + 1.0 / 1024.0) + 1e-4;
}

// Whether the sphere (c, r) touches the box [lo, hi] (exact).
fn sphere_touches_box(c: vec3f, r: f32, lo: vec3f, hi: vec3f) -> bool {
    let d = c - clamp(c, lo, hi);
    return dot(d, d) <= r * r;
}

// Whether a light at `c` (grid space) with binning radius `r` may light any
// point of the box [lo, hi]: its sphere touches the box, and for a spot, the
// box's bounding sphere is not wholly outside the cone (behind the apex, or
// farther than its radius from the cone's surface: Wronski's cone-sphere
// test, never nearer than the true distance, so conservative). Mirrors
// `culling::cone_intersects_aabb`.
fn light_touches_box(kind: u32, c: vec3f, dir: vec3f, r: f32, cos_outer: f32, lo: vec3f, hi: vec3f) -> bool {
    if !sphere_touches_box(c, r, lo, hi) {
        return false;
    }
    let cos_a = min(cos_outer, 1.0);
    if kind != LIGHT_SPOT || cos_a <= 0.0 || dot(dir, dir) == 0.0 {
        return true;
    }
    let axis = normalize(dir);
    let sin_a = sqrt(max(1.0 - cos_a * cos_a, 0.0));
    let center = 0.5 * (lo + hi);
    let radius = 0.5 * length(hi - lo);
    let v = center - c;
    let along = dot(v, axis);
    let across = sqrt(max(dot(v, v) - along * along, 0.0));
    let to_surface = cos_a * across - along * sin_a;
    return !(to_surface > radius || along > r + radius || along < -radius);
}

// Counts (fill = false) or lists (fill = true) `light` in `cell`. Fill takes
// the cell's slots from the top down; slots past the list's capacity are not
// written (the cell's range then fails the readers' capacity check).
fn record(cell: u32, light: u32, fill: bool) {
    if !fill {
        atomicAdd(&counts[cell], 1u);
        return;
    }
    let first = cells[cell].x;
    let k = atomicSub(&counts[cell], 1u) - 1u;
    // k wraps to a huge value if fill ever found more hits than count did.
    if first < params.capacity && k < params.capacity - first && k < cells[cell].y {
        list[first + k] = light;
    }
}
