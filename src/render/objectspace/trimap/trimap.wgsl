// Triangle-index maps, built per page when paging backs it (one workgroup
// per backed page): each texel gets the triangle that covers it, found
// through the object's chart grid (the triangles overlapping each cell of
// its chart UV square). A texel takes, of the triangles touching its square
// (conservative coverage, so that chart parts thinner than a texel at coarse
// levels still own their texels), the one nearest its centre; a texel no
// triangle touches takes the nearest triangle touching its 3x3 neighbourhood
// (one ring of dilation, so that bilinear taps just outside a chart find a
// triangle to extrapolate); else 0. `cpu.rs` has the same rule in Rust.
// With `TRIMAP_SHARE` a page copies the map of a page holding the same
// (mesh, level, page) where the table of keys finds one (`mod.rs`). A page
// of a level no wider than its mesh's stored maps copies its map from them
// (`stored_maps`, built once by `build_stored` with the same search): those
// middle levels hold the slowest pages, and the pass lasts as its slowest.
#import shadespace::contract::{COUNT_PAGES_BACKED, COUNT_TRIMAP_PAGES, COUNT_TRIMAP_WEIGHED, COUNT_TRIMAP_SHARED}
#import shadespace::scene_bindings::{vertices, objects, triangle_vertices}
#import shadespace::scene::Object
#import shadespace::objectspace::{params, entry_level, counters, backed, atlas_texel, page_origin, set_stripe}
#ifdef MARK_BACKED
#import shadespace::objectspace_mark_backed::mark_backed_page
#endif

// Mirrors `trimap::GpuChartGrid`.
struct ChartGrid {
    // Index of the object's first cell in `cell_start`.
    cell_base: u32,
    // Cells per side.
    side: u32,
    // The object's mesh's first map number (NO_SHARE: its pages share none).
    key_base: u32,
    // Where its mesh's stored maps start in `stored_maps`, and the widest
    // level stored (0: none): every level up to it, smallest first.
    store_base: u32,
    store_size: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// Read and written: `copy_shared` reads the maps it copies.
@group(2) @binding(0) var map: texture_storage_2d_array<r32uint, read_write>;
@group(2) @binding(1) var<storage, read> grids: array<ChartGrid>;
// Per cell: its first entry in `cell_triangles` (one more entry closes the last cell).
@group(2) @binding(2) var<storage, read> cell_start: array<u32>;
// Object-local triangle indices, cell after cell.
@group(2) @binding(3) var<storage, read> cell_triangles: array<u32>;
// The shared maps' table (a power of two of slots): physical page + 1 of a
// page holding a map, found from its key's home slot (0: empty).
@group(2) @binding(4) var<storage, read_write> share_table: array<atomic<u32>>;
// Per physical page: the key of the map it holds (0: none known).
@group(2) @binding(5) var<storage, read_write> map_keys: array<atomic<u32>>;
// The stored maps, after the blocks of 8x8 texels `build_stored` fills
// (one buffer: a stage holds at most 32): their count, then per block an
// object of the mesh, level size, x | y << 16 of its first texel, 0; then
// per mesh each level size up to its `store_size`, row by row (triangle +
// 1, 0 for none).
@group(2) @binding(6) var<storage, read_write> stored_maps: array<u32>;

const NO_SHARE: u32 = 0xffffffffu;
// Slots a key's search looks at from its home slot: past them a page builds.
const SHARE_PROBES: u32 = 8u;

// Map numbers below level size `size`: a page per `page_size` texels each
// way, every size from 1 texel up (`keys_below` in `mod.rs`).
fn level_keys(size: u32) -> u32 {
    var n = 0u;
    for (var s = 1u; s < size; s *= 2u) {
        let per_row = (s + params.page_size - 1u) / params.page_size;
        n += per_row * per_row;
    }
    return n;
}

// The key of backed page `b`'s map: the first map number of its object's
// mesh, of its level's size and of its page, + 1 (0: the mesh shares none).
// It is the same for every instance of the mesh, and the map too.
fn map_key(b: vec4u) -> u32 {
    let object = b.y >> 8u;
    let base = grids[object].key_base;
    if base == NO_SHARE {
        return 0u;
    }
    let l = entry_level(object, b.y & 0xffu);
    let page = page_origin(l, b.x) / params.page_size;
    let per_row = (l.size + params.page_size - 1u) / params.page_size;
    return base + level_keys(l.size) + page.y * per_row + page.x + 1u;
}

fn hash(key: u32) -> u32 {
    var x = key;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// The physical page + 1 whose map backed page `b` copies, or 0: it builds
// its own, entered in the table. A slot's page is a source when its key is
// `b`'s (its map was built before this frame, or by a page building it this
// frame: keys of the pages backed this frame are forgotten first, and a
// page copying sets its key only once copied). A slot whose page holds no
// known map, or one whose search starts too far off to reach the slot, is
// taken. Races (two pages taking one slot, a key not yet seen) make a page
// build what it could have copied, never copy what it should not.
fn find_source(b: vec4u) -> u32 {
    let key = map_key(b);
    let page = b.z;
    let pages = min(params.physical_pages, arrayLength(&map_keys));
    if key == 0u || page >= pages {
        return 0u;
    }
    let mask = arrayLength(&share_table) - 1u;
    let home = hash(key) & mask;
    for (var i = 0u; i < SHARE_PROBES; i++) {
        let s = (home + i) & mask;
        let v = atomicLoad(&share_table[s]);
        if v != 0u && v - 1u < pages {
            let k = atomicLoad(&map_keys[v - 1u]);
            if k == key {
                return v;
            }
            if k != 0u && ((s - (hash(k) & mask)) & mask) < SHARE_PROBES {
                continue;
            }
        }
        atomicStore(&map_keys[page], key);
        atomicCompareExchangeWeak(&share_table[s], v, page + 1u);
        return 0u;
    }
    atomicStore(&map_keys[page], key);
    return 0u;
}

var<workgroup> page_source: u32;

// Backed page `index`'s source (`find_source`, decided by invocation 0 and
// written to the page's entry for `copy_shared`), the same in every invocation.
fn share_source(index: u32, b: vec4u, li: u32) -> u32 {
    if li == 0u {
        let source = find_source(b);
        page_source = source;
        backed[index].w = source;
        if source != 0u {
            atomicAdd(&counters[COUNT_TRIMAP_SHARED], 1u);
        }
    }
    return workgroupUniformLoad(&page_source);
}

// Whether workgroup `index` has a page backed this frame.
fn backed_this_frame(index: u32) -> bool {
    return index < min(atomicLoad(&counters[COUNT_PAGES_BACKED]), params.physical_pages);
}

// Per page backed this frame: which map it holds is not known until it is
// built or copied.
@compute @workgroup_size(1)
fn forget_keys(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let index = wg.y * groups.x + wg.x;
    if backed_this_frame(index) && backed[index].z < arrayLength(&map_keys) {
        atomicStore(&map_keys[backed[index].z], 0u);
    }
}

// Per page backed this frame that found a source: its map copied from the
// source's (whole pages: texels past the level's edge are 0 in both), then
// its key set, so that later frames may copy from it.
@compute @workgroup_size(8, 8)
fn copy_shared(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
               @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    let index = wg.y * groups.x + wg.x;
    if !backed_this_frame(index) || backed[index].w == 0u {
        return;
    }
    let b = backed[index];
    let source = b.w - 1u;
    let blocks = params.page_size / 8u;
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = vec2u(bx, by) * 8u + lid.xy;
            let read = atlas_texel(source, texel);
            let write = atlas_texel(b.z, texel);
            textureStore(map, write.xy, write.layer, textureLoad(map, read.xy, read.layer));
        }
    }
    if li == 0u {
        atomicStore(&map_keys[b.z], map_key(b));
    }
}

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

// A texel's search so far: the nearest triangles found, where this
// invocation's share of the next cell starts (see `weigh_cell`), and the
// grid entries it weighed (`COUNT_TRIMAP_WEIGHED`).
struct Search {
    n: Nearest,
    skip: u32,
    weighed: u32,
}

fn new_search(skip: u32) -> Search {
    return Search(Nearest(3.0e38, 0u, 3.0e38, 0u), skip, 0u);
}

// Weighs entries skip, skip + step, ... of cell `cell`'s list, the share
// of one of `step` invocations that take the cells' lists one after the
// other.
fn weigh_cell(search: ptr<function, Search>, o: Object, g: ChartGrid, s: f32, lo: vec2f, cell: vec2u, step: u32) {
    let c = g.cell_base + cell.y * g.side + cell.x;
    let end = cell_start[c + 1u];
    var k = cell_start[c] + (*search).skip;
    for (; k < end; k += step) {
        (*search).n = weigh((*search).n, o, s, lo, cell_triangles[k]);
        (*search).weighed += 1u;
    }
    (*search).skip = k - end;
}

// Rings of cells round `centre` within [c0, c1]: the last one's number.
fn ring_count(centre: vec2u, c0: vec2u, c1: vec2u) -> u32 {
    let m = max(centre - c0, c1 - centre);
    return max(m.x, m.y);
}

// Weighs the cells of [c0, c1] `ring` cells from `centre` (Chebyshev
// distance), row by row.
fn weigh_ring(search: ptr<function, Search>, o: Object, g: ChartGrid, s: f32, lo: vec2f, centre: vec2u, c0: vec2u,
              c1: vec2u, ring: u32, step: u32) {
    let first = max(centre, c0 + ring) - ring;
    let last = min(centre + ring, c1);
    for (var y = first.y; y <= last.y; y++) {
        if y + ring == centre.y || y == centre.y + ring {
            for (var x = first.x; x <= last.x; x++) {
                weigh_cell(search, o, g, s, lo, vec2u(x, y), step);
            }
        } else {
            if centre.x >= c0.x + ring {
                weigh_cell(search, o, g, s, lo, vec2u(centre.x - ring, y), step);
            }
            if centre.x + ring <= c1.x {
                weigh_cell(search, o, g, s, lo, vec2u(centre.x + ring, y), step);
            }
        }
    }
}

// Whether the search may stop after ring `ring` of cells `width` texels
// wide, with the nearest triangles `n` found. A triangle's point nearest
// the texel's centre lies in its bounding box, so in a cell that lists it:
// a triangle not yet weighed is at least `ring` cells from the centre (less
// a 64th of a cell for rounding). A triangle holding the centre (distance
// 0) is listed in the centre's cell (ring 0), so coarse levels, whose 3x3
// rings span many cells, mostly stop there. Triangles touching the texel
// are within 0.71 texels of its centre: past 0.75 with none found there is
// none, and the nearest of the others decides. `cpu.rs`: `search_done`.
fn search_done(n: Nearest, ring: u32, width: f32) -> bool {
    let beyond = (f32(ring) - 1.0 / 64.0) * width;
    if n.touching_id != 0u {
        return n.touching == 0.0 || n.touching < beyond;
    }
    return beyond > 0.75 && n.near_id != 0u && n.near < beyond;
}

// Weighs the texel's cells past the centre's: ring by ring until
// `search_done`, or (`TRIMAP_NEIGHBOURHOOD`, the search before the rings)
// every cell of [c0, c1], the centre's again included, row by row.
fn weigh_rest(search: ptr<function, Search>, o: Object, g: ChartGrid, s: f32, lo: vec2f, centre: vec2u, c0: vec2u,
              c1: vec2u, step: u32) {
#ifdef TRIMAP_NEIGHBOURHOOD
    for (var y = c0.y; y <= c1.y; y++) {
        for (var x = c0.x; x <= c1.x; x++) {
            weigh_cell(search, o, g, s, lo, vec2u(x, y), step);
        }
    }
#else
    let width = s / f32(g.side);
    let rings = ring_count(centre, c0, c1);
    for (var ring = 1u; ring <= rings; ring++) {
        weigh_ring(search, o, g, s, lo, centre, c0, c1, ring, step);
        if search_done((*search).n, ring, width) {
            break;
        }
    }
#endif
}

// The chart grid cell holding point `p` of a level `s` texels wide.
fn cell_of(g: ChartGrid, s: f32, p: vec2f) -> vec2u {
    let side = f32(g.side);
    return vec2u(clamp(floor(p / s * side), vec2f(0.0), vec2f(side - 1.0)));
}

// The triangle + 1 a search found (0 for none).
fn found(n: Nearest) -> u32 {
    return select(n.near_id, n.touching_id, n.touching_id != 0u);
}

// Where the stored map of a level `size` texels wide starts in
// `stored_maps` (the sizes below it before it), or NO_STORE.
fn stored_level(g: ChartGrid, size: u32) -> u32 {
    if size > g.store_size {
        return NO_STORE;
    }
    return g.store_base + (size * size - 1u) / 3u;
}

const NO_STORE: u32 = 0xffffffffu;

// The stored level of backed page `b`'s map (NO_STORE: built), the same
// in every invocation.
var<workgroup> page_stored: u32;
fn page_store(b: vec4u, li: u32) -> u32 {
    if li == 0u {
        let object = b.y >> 8u;
        page_stored = stored_level(grids[object], entry_level(object, b.y & 0xffu).size);
    }
    return workgroupUniformLoad(&page_stored);
}

// Texel `texel` of backed page `b`'s map from the stored level at `stored`
// (a level `size` texels wide).
fn copy_stored(b: vec4u, stored: u32, size: u32, texel: vec2u) {
    var id = 0u;
    if all(texel < vec2u(size)) {
        id = stored_maps[stored + texel.y * size + texel.x];
    }
    let at = atlas_texel(b.z, texel);
    textureStore(map, at.xy, at.layer, vec4u(id, 0u, 0u, 0u));
}

// Block `index` of the stored maps: its object, level size, first texel and
// where its level starts (NO_STORE past the last block).
struct StoreBlock {
    object: u32,
    size: u32,
    origin: vec2u,
    stored: u32,
}

fn store_block(index: u32) -> StoreBlock {
    if index >= stored_maps[0] {
        return StoreBlock(0u, 0u, vec2u(0u), NO_STORE);
    }
    let at = 1u + 4u * index;
    let object = stored_maps[at];
    let size = stored_maps[at + 1u];
    let origin = stored_maps[at + 2u];
    return StoreBlock(object, size, vec2u(origin & 0xffffu, origin >> 16u), stored_level(grids[object], size));
}

// Entries weighed by the workgroup's invocations, counted once per page.
var<workgroup> page_weighed: atomic<u32>;

// Adds the workgroup's weighed entries to `COUNT_TRIMAP_WEIGHED`.
fn count_weighed(weighed: u32, li: u32) {
    atomicAdd(&page_weighed, weighed);
    workgroupBarrier();
    if li == 0u {
        atomicAdd(&counters[COUNT_TRIMAP_WEIGHED], atomicLoad(&page_weighed));
    }
}

/// Whether workgroup `index` has a page backed this frame whose map it
/// builds: if so (with the fused paging chain) its requested tiles are
/// marked, and (with `TRIMAP_SHARE`) it has no source to copy from; a page
/// building its map is counted. Both `build` variants start so.
fn claim_page(index: u32, li: u32) -> bool {
    if !backed_this_frame(index) {
        return false;
    }
#ifdef MARK_BACKED
    mark_backed_page(index, li);
#endif
#ifdef TRIMAP_SHARE
    if share_source(index, backed[index], li) != 0u {
        return false;
    }
#endif
    if li == 0u {
        atomicAdd(&counters[COUNT_TRIMAP_PAGES], 1u);
    }
    return true;
}

#ifndef TRIMAP_LANES
// Triangle + 1 for texel `texel` of a level `size` texels wide (0 for
// none): the centre's cell, which settles most texels (`search_done`),
// then the others (`weigh_rest`).
fn covering_triangle(search: ptr<function, Search>, o: Object, g: ChartGrid, size: u32, texel: vec2u) -> u32 {
    let s = f32(size);
    let lo = vec2f(texel);
    let centre = cell_of(g, s, lo + 0.5);
    let c0 = cell_of(g, s, lo - 1.0);
    let c1 = cell_of(g, s, lo + 2.0);
    (*search).n = Nearest(3.0e38, 0u, 3.0e38, 0u);
    weigh_ring(search, o, g, s, lo, centre, c0, c1, 0u, 1u);
    if !search_done((*search).n, 0u, s / f32(g.side)) {
        weigh_rest(search, o, g, s, lo, centre, c0, c1, 1u);
    }
    return found((*search).n);
}

@compute @workgroup_size(8, 8)
fn build(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    set_stripe(wg, groups);
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
    let stored = page_store(b, li);
    if stored != NO_STORE {
        for (var by = 0u; by < blocks; by++) {
            for (var bx = 0u; bx < blocks; bx++) {
                copy_stored(b, stored, l.size, origin + vec2u(bx, by) * 8u + lid.xy);
            }
        }
        return;
    }
    var search = new_search(0u);
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = origin + vec2u(bx, by) * 8u + lid.xy;
            var id = 0u;
            if all(texel < vec2u(l.size)) {
                id = covering_triangle(&search, o, g, l.size, texel);
            }
            let at = atlas_texel(b.z, texel);
            textureStore(map, at.xy, at.layer, vec4u(id, 0u, 0u, 0u));
        }
    }
    count_weighed(search.weighed, li);
}

// A block of 8x8 texels of the stored maps, once.
@compute @workgroup_size(8, 8)
fn build_stored(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
                @builtin(local_invocation_id) lid: vec3u) {
    let k = store_block(wg.y * groups.x + wg.x);
    let texel = k.origin + lid.xy;
    if k.stored == NO_STORE || any(texel >= vec2u(k.size)) {
        return;
    }
    var search = new_search(0u);
    let id = covering_triangle(&search, objects[k.object], grids[k.object], k.size, texel);
    stored_maps[k.stored + texel.y * k.size + texel.x] = id;
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

// Per invocation: the nearest triangles of its share of the centre's
// cell, then of the texel's search.
var<workgroup> centre_part: array<Nearest, 64u * LANES>;
var<workgroup> ring_part: array<Nearest, 64u * LANES>;

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

// The triangle + 1 of texel `texel` of a level `size` texels wide (0 for
// none), found by the texel's lanes together (`lane` of them; every
// invocation of the workgroup calls this, for its texel). Adds the entries
// this lane weighed to `weighed`.
fn lanes_texel(o: Object, g: ChartGrid, size: u32, texel: vec2u, lane: u32, li: u32, weighed: ptr<function, u32>) -> u32 {
    let s = f32(size);
    let width = s / f32(g.side);
    let first = li - lane;
    let inside = all(texel < vec2u(size));
    let lo = vec2f(texel);
    let centre = cell_of(g, s, lo + 0.5);
    let c0 = cell_of(g, s, lo - 1.0);
    let c1 = cell_of(g, s, lo + 2.0);
    var search = new_search(lane);
    if inside {
        weigh_ring(&search, o, g, s, lo, centre, c0, c1, 0u, LANES);
    }
    centre_part[li] = search.n;
    workgroupBarrier();
    var merged = search.n;
    for (var j = 0u; j < LANES; j++) {
        merged = nearer(merged, centre_part[first + j]);
    }
    // The texel's lanes merged the same pairs: they go on together.
    if inside && !search_done(merged, 0u, width) {
        search.n = merged;
        weigh_rest(&search, o, g, s, lo, centre, c0, c1, LANES);
    }
    *weighed += search.weighed;
    ring_part[li] = search.n;
    workgroupBarrier();
    for (var j = 0u; j < LANES; j++) {
        merged = nearer(merged, ring_part[first + j]);
    }
    return select(0u, found(merged), inside);
}

// The centre's cell first, its entries shared by the lanes, which merge
// their least pairs: most texels stop there (`search_done`). The others
// go on (`weigh_rest`), each lane its share of the entries from the merged
// pairs; with the rings a lane stops when no entry of its share left can be
// nearer than what it holds: what a lane skips cannot change the least
// pair, so the lanes need not wait for each other until the final merge.
@compute @workgroup_size(LANES, 8, 8)
fn build(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    set_stripe(wg, groups);
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
    let lane = lid.x;
    let blocks = params.page_size / 8u;
    let stored = page_store(b, li);
    if stored != NO_STORE {
        for (var by = 0u; by < blocks; by++) {
            for (var bx = 0u; bx < blocks; bx++) {
                if lane == 0u {
                    copy_stored(b, stored, l.size, origin + vec2u(bx, by) * 8u + lid.yz);
                }
            }
        }
        return;
    }
    var weighed = 0u;
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = origin + vec2u(bx, by) * 8u + lid.yz;
            let id = lanes_texel(o, g, l.size, texel, lane, li, &weighed);
            if lane == 0u {
                let at = atlas_texel(b.z, texel);
                textureStore(map, at.xy, at.layer, vec4u(id, 0u, 0u, 0u));
            }
        }
    }
    count_weighed(weighed, li);
}

var<workgroup> block: StoreBlock;

// A block of 8x8 texels of the stored maps, once.
@compute @workgroup_size(LANES, 8, 8)
fn build_stored(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
                @builtin(local_invocation_id) lid: vec3u, @builtin(local_invocation_index) li: u32) {
    // Read by one invocation for all: the buffer is written here too, so
    // its loads are not uniform to the compiler.
    if li == 0u {
        block = store_block(wg.y * groups.x + wg.x);
    }
    let k = workgroupUniformLoad(&block);
    if k.stored == NO_STORE {
        return;
    }
    let texel = k.origin + lid.yz;
    var weighed = 0u;
    let id = lanes_texel(objects[k.object], grids[k.object], k.size, texel, lid.x, li, &weighed);
    if lid.x == 0u && all(texel < vec2u(k.size)) {
        stored_maps[k.stored + texel.y * k.size + texel.x] = id;
    }
}
#endif
