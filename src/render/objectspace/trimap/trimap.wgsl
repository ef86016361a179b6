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

fn search_cells(o: Object, g: ChartGrid, s: f32, lo: vec2f, c0: vec2u, c1: vec2u) -> Nearest {
    let ring_lo = lo - 1.0;
    let ring_hi = lo + 2.0;
    let centre = lo + 0.5;
    var n = Nearest(3.0e38, 0u, 3.0e38, 0u);
    for (var cy = c0.y; cy <= c1.y; cy++) {
        for (var cx = c0.x; cx <= c1.x; cx++) {
            let cell = g.cell_base + cy * g.side + cx;
            for (var k = cell_start[cell]; k < cell_start[cell + 1u]; k++) {
                let triangle = cell_triangles[k];
                let tri = triangle_vertices(o, triangle);
                let p = array<vec2f, 3>(vertices[tri.x].chart_uv * s, vertices[tri.y].chart_uv * s,
                    vertices[tri.z].chart_uv * s);
                if !overlaps(p, ring_lo, ring_hi) {
                    continue;
                }
                let d = triangle_distance(p, centre);
                // Ties go to the lower index (a triangle can sit in several cells).
                if overlaps(p, lo, lo + 1.0) {
                    if d < n.touching || (d == n.touching && triangle + 1u < n.touching_id) {
                        n.touching = d;
                        n.touching_id = triangle + 1u;
                    }
                } else if d < n.near || (d == n.near && triangle + 1u < n.near_id) {
                    n.near = d;
                    n.near_id = triangle + 1u;
                }
            }
        }
    }
    return n;
}

// Triangle + 1 for texel `texel` of a level `size` texels wide, 0 for none.
fn covering_triangle(o: Object, g: ChartGrid, size: u32, texel: vec2u) -> u32 {
    let s = f32(size);
    let side = f32(g.side);
    let lo = vec2f(texel);
    // A triangle holding the texel's centre (distance 0, the least) is
    // listed in the centre's cell: when that cell has one, no other cell can
    // change the answer. Coarse levels, whose 3x3 rings span many cells,
    // mostly stop here.
    let centre_cell = vec2u(clamp(floor((lo + 0.5) / s * side), vec2f(0.0), vec2f(side - 1.0)));
    let own = search_cells(o, g, s, lo, centre_cell, centre_cell);
    if own.touching_id != 0u && own.touching == 0.0 {
        return own.touching_id;
    }
    let c0 = vec2u(clamp(floor((lo - 1.0) / s * side), vec2f(0.0), vec2f(side - 1.0)));
    let c1 = vec2u(clamp(floor((lo + 2.0) / s * side), vec2f(0.0), vec2f(side - 1.0)));
    let n = search_cells(o, g, s, lo, c0, c1);
    return select(n.near_id, n.touching_id, n.touching_id != 0u);
}

@compute @workgroup_size(8, 8)
fn build(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_id) lid: vec3u) {
    let index = wg.y * groups.x + wg.x;
    if index >= min(atomicLoad(&counters[COUNT_PAGES_BACKED]), params.physical_pages) {
        return;
    }
    if all(lid.xy == vec2u(0u)) {
        atomicAdd(&counters[COUNT_TRIMAP_PAGES], 1u);
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
