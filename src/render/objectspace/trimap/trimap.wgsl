// Triangle-index maps, built per page when paging backs it (one workgroup
// per backed page): each texel gets the triangle that covers it, found
// through the object's chart grid (the triangles overlapping each cell of
// its chart UV square). A texel takes, of the triangles touching its square
// (conservative coverage, so that chart parts thinner than a texel at coarse
// levels still own their texels), the one nearest its centre; a texel no
// triangle touches takes the nearest triangle touching its 3x3 neighbourhood
// (one ring of dilation, so that bilinear taps just outside a chart find a
// triangle to extrapolate); else 0. `cpu.rs` has the same rule in Rust.
#import shadespace::contract::{COUNT_PAGES_BACKED, COUNT_TRIMAP_PAGES}
#import shadespace::scene_bindings::{vertices, objects, triangle_vertices}
#import shadespace::scene::Object
#import shadespace::objectspace::{params, entry_level, counters, backed, atlas_texel, page_origin}
#ifdef MARK_BACKED
#import shadespace::objectspace_mark_backed::mark_backed_page
#endif

// Mirrors `trimap::GpuChartGrid`.
struct ChartGrid {
    // Index of the object's first cell in `cell_start`.
    cell_base: u32,
    // Cells per side.
    side: u32,
}

@group(2) @binding(0) var map: texture_storage_2d_array<r32uint, write>;
@group(2) @binding(1) var<storage, read> grids: array<ChartGrid>;
// Per cell: its first entry in `cell_triangles` (one more entry closes the last cell).
@group(2) @binding(2) var<storage, read> cell_start: array<u32>;
// Object-local triangle indices, cell after cell.
@group(2) @binding(3) var<storage, read> cell_triangles: array<u32>;

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// Whether edge a -> b of a triangle of signed area `area` has the square
// [lo, hi] wholly outside it.
fn edge_separates(a: vec2f, b: vec2f, area: f32, lo: vec2f, hi: vec2f) -> bool {
    let e = b - a;
    // Outward normal of the edge.
    let n = vec2f(e.y, -e.x) * sign(area);
    // The square's corner farthest inside.
    let corner = select(hi, lo, n > vec2f(0.0));
    return dot(n, corner - a) > 0.0;
}

// Whether triangle p and the square [lo, hi] overlap (separating axes: the
// square's and the triangle's edge normals; a degenerate triangle keeps
// only its bounding box test). Edges by constant index: a loop indexing `p`
// by its counter would make naga copy the array to function memory.
fn overlaps(p: array<vec2f, 3>, lo: vec2f, hi: vec2f) -> bool {
    if any(max(max(p[0], p[1]), p[2]) < lo) || any(min(min(p[0], p[1]), p[2]) > hi) {
        return false;
    }
    let area = cross2(p[1] - p[0], p[2] - p[0]);
    return !(edge_separates(p[0], p[1], area, lo, hi) || edge_separates(p[1], p[2], area, lo, hi)
        || edge_separates(p[2], p[0], area, lo, hi));
}

fn segment_distance(q: vec2f, a: vec2f, b: vec2f) -> f32 {
    let e = b - a;
    let t = clamp(dot(q - a, e) / max(dot(e, e), 1e-30), 0.0, 1.0);
    return length(q - (a + e * t));
}

// Distance from q to triangle p (0 inside).
fn triangle_distance(p: array<vec2f, 3>, q: vec2f) -> f32 {
    let area = cross2(p[1] - p[0], p[2] - p[0]);
    let w0 = cross2(p[1] - q, p[2] - q) * sign(area);
    let w1 = cross2(p[2] - q, p[0] - q) * sign(area);
    let w2 = cross2(p[0] - q, p[1] - q) * sign(area);
    if area != 0.0 && w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
        return 0.0;
    }
    return min(segment_distance(q, p[0], p[1]), min(segment_distance(q, p[1], p[2]), segment_distance(q, p[2], p[0])));
}

// The nearest triangles to a texel among those listed in cells c0..=c1:
// touching its square, and touching only its 3x3 neighbourhood.
struct Nearest {
    touching: f32,
    touching_id: u32,
    near: f32,
    near_id: u32,
}

// `n` with triangle `triangle` weighed in (when it touches the texel's 3x3
// neighbourhood): the lexicographic least (distance, triangle) of each
// kind, so the order in which triangles are weighed does not matter.
fn weigh(n: Nearest, o: Object, s: f32, lo: vec2f, triangle: u32) -> Nearest {
    var m = n;
    let tri = triangle_vertices(o, triangle);
    let p = array<vec2f, 3>(vertices[tri.x].chart_uv * s, vertices[tri.y].chart_uv * s,
        vertices[tri.z].chart_uv * s);
    if !overlaps(p, lo - 1.0, lo + 2.0) {
        return m;
    }
    let d = triangle_distance(p, lo + 0.5);
    // Ties go to the lower index (a triangle can sit in several cells).
    if overlaps(p, lo, lo + 1.0) {
        if d < m.touching || (d == m.touching && triangle + 1u < m.touching_id) {
            m.touching = d;
            m.touching_id = triangle + 1u;
        }
    } else if d < m.near || (d == m.near && triangle + 1u < m.near_id) {
        m.near = d;
        m.near_id = triangle + 1u;
    }
    return m;
}

fn search_cells(o: Object, g: ChartGrid, s: f32, lo: vec2f, c0: vec2u, c1: vec2u) -> Nearest {
    var n = Nearest(3.0e38, 0u, 3.0e38, 0u);
    for (var cy = c0.y; cy <= c1.y; cy++) {
        for (var cx = c0.x; cx <= c1.x; cx++) {
            let cell = g.cell_base + cy * g.side + cx;
            for (var k = cell_start[cell]; k < cell_start[cell + 1u]; k++) {
                n = weigh(n, o, s, lo, cell_triangles[k]);
            }
        }
    }
    return n;
}

// The chart grid cell holding point `p` of a level `s` texels wide.
fn cell_of(g: ChartGrid, s: f32, p: vec2f) -> vec2u {
    let side = f32(g.side);
    return vec2u(clamp(floor(p / s * side), vec2f(0.0), vec2f(side - 1.0)));
}

// Triangle + 1 for texel `texel` of a level `size` texels wide, 0 for none.
fn covering_triangle(o: Object, g: ChartGrid, size: u32, texel: vec2u) -> u32 {
    let s = f32(size);
    let lo = vec2f(texel);
    // A triangle holding the texel's centre (distance 0, the least) is
    // listed in the centre's cell: when that cell has one, no other cell can
    // change the answer. Coarse levels, whose 3x3 rings span many cells,
    // mostly stop here.
    let centre_cell = cell_of(g, s, lo + 0.5);
    let own = search_cells(o, g, s, lo, centre_cell, centre_cell);
    if own.touching_id != 0u && own.touching == 0.0 {
        return own.touching_id;
    }
    let n = search_cells(o, g, s, lo, cell_of(g, s, lo - 1.0), cell_of(g, s, lo + 2.0));
    return select(n.near_id, n.touching_id, n.touching_id != 0u);
}

/// Whether workgroup `index` has a page backed this frame to map: if so it
/// is counted and (with the fused paging chain) its requested tiles marked.
/// Both `build` variants start so.
fn claim_page(index: u32, li: u32) -> bool {
    if index >= min(atomicLoad(&counters[COUNT_PAGES_BACKED]), params.physical_pages) {
        return false;
    }
    if li == 0u {
        atomicAdd(&counters[COUNT_TRIMAP_PAGES], 1u);
    }
#ifdef MARK_BACKED
    mark_backed_page(index, li);
#endif
    return true;
}

#ifndef TRIMAP_LANES
@compute @workgroup_size(8, 8)
fn build(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    let index = wg.y * groups.x + wg.x;
    if !claim_page(index, li) {
        return;
    }
    let b = backed[index];
    let object = b.y >> 8u;
    let l = entry_level(object, b.y & 0xffu);
    let o = objects[object];
    let g = grids[object];
    let origin = page_origin(l, b.x);
    let blocks = params.page_size / 8u;
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = origin + vec2u(bx, by) * 8u + lid.xy;
            var id = 0u;
            if all(texel < vec2u(l.size)) {
                id = covering_triangle(o, g, l.size, texel);
            }
            let at = atlas_texel(b.z, texel);
            textureStore(map, at.xy, at.layer, vec4u(id, 0u, 0u, 0u));
        }
    }
}
#else
// Several invocations per texel (`LANES`, adjacent in the workgroup): each
// weighs every LANES-th triangle listed in the cells searched, and the
// lanes' least (distance, triangle) pairs are merged in workgroup memory.
// A page lasts as long as its texel with the most triangles to weigh, and
// the pass as its slowest page: this divides that chain by the lanes. The
// maps are the same: the least pair does not depend on the order.
#ifdef TRIMAP_LANES_8
const LANES: u32 = 8u;
#else
#ifdef TRIMAP_LANES_4
const LANES: u32 = 4u;
#else
const LANES: u32 = 2u;
#endif
#endif

// Per invocation: the least triangle + 1 holding its texel's centre among
// its share of the centre's cell (NONE: none), then its share's nearest
// triangles over the texel's ring of cells.
const NONE: u32 = 0xffffffffu;
var<workgroup> own_part: array<u32, 64u * LANES>;
var<workgroup> ring_part: array<Nearest, 64u * LANES>;

// As `search_cells`, over entries lane, lane + LANES, ... of the cells'
// lists taken one after the other.
fn search_cells_lane(o: Object, g: ChartGrid, s: f32, lo: vec2f, c0: vec2u, c1: vec2u, lane: u32) -> Nearest {
    var n = Nearest(3.0e38, 0u, 3.0e38, 0u);
    var skip = lane;
    for (var cy = c0.y; cy <= c1.y; cy++) {
        for (var cx = c0.x; cx <= c1.x; cx++) {
            let cell = g.cell_base + cy * g.side + cx;
            let end = cell_start[cell + 1u];
            var k = cell_start[cell] + skip;
            for (; k < end; k += LANES) {
                n = weigh(n, o, s, lo, cell_triangles[k]);
            }
            skip = k - end;
        }
    }
    return n;
}

// The least pairs of `a` and `b`, kind by kind.
fn nearer(a: Nearest, b: Nearest) -> Nearest {
    var n = a;
    if b.touching < n.touching || (b.touching == n.touching && b.touching_id < n.touching_id) {
        n.touching = b.touching;
        n.touching_id = b.touching_id;
    }
    if b.near < n.near || (b.near == n.near && b.near_id < n.near_id) {
        n.near = b.near;
        n.near_id = b.near_id;
    }
    return n;
}

@compute @workgroup_size(LANES, 8, 8)
fn build(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    let index = wg.y * groups.x + wg.x;
    if !claim_page(index, li) {
        return;
    }
    let b = backed[index];
    let object = b.y >> 8u;
    let l = entry_level(object, b.y & 0xffu);
    let o = objects[object];
    let g = grids[object];
    let origin = page_origin(l, b.x);
    let s = f32(l.size);
    let lane = lid.x;
    let first = li - lane;
    let blocks = params.page_size / 8u;
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = origin + vec2u(bx, by) * 8u + lid.yz;
            let inside = all(texel < vec2u(l.size));
            let lo = vec2f(texel);
            // The centre's cell first (see `covering_triangle`).
            var own = NONE;
            if inside {
                let c = cell_of(g, s, lo + 0.5);
                let n = search_cells_lane(o, g, s, lo, c, c, lane);
                own = select(NONE, n.touching_id, n.touching_id != 0u && n.touching == 0.0);
            }
            own_part[li] = own;
            workgroupBarrier();
            for (var j = 0u; j < LANES; j++) {
                own = min(own, own_part[first + j]);
            }
            var ring = Nearest(3.0e38, 0u, 3.0e38, 0u);
            if inside && own == NONE {
                ring = search_cells_lane(o, g, s, lo, cell_of(g, s, lo - 1.0), cell_of(g, s, lo + 2.0), lane);
            }
            ring_part[li] = ring;
            workgroupBarrier();
            for (var j = 0u; j < LANES; j++) {
                ring = nearer(ring, ring_part[first + j]);
            }
            if lane == 0u {
                var id = 0u;
                if inside {
                    id = select(select(ring.near_id, ring.touching_id, ring.touching_id != 0u), own, own != NONE);
                }
                let at = atlas_texel(b.z, texel);
                textureStore(map, at.xy, at.layer, vec4u(id, 0u, 0u, 0u));
            }
        }
    }
}
#endif
