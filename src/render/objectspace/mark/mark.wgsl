// Tile marking and queueing, in one pass over the visibility buffer: each
// pixel finds its mip level and the texels of its bilinear footprint, and
// marks their tiles visible for this frame. A tile on a backed page is
// marked in the page's tile stamps: the first pixel to mark it this frame
// decides whether its cached shade is still good (younger than N frames and
// not invalidated) or queues it for shading. A tile on a page with no
// physical page yet sets its request bit, and the first such pixel of the
// page sets the page's bit and lists the page; `mark_backed` marks those
// tiles once paging has backed the page.
// The 64 pixels of a workgroup mostly mark the same few tiles: the first
// invocation to mark a tile claims it in a small workgroup hash table and
// alone marks it in the global buffers, so the global atomics follow the
// distinct tiles, not the pixels (`MARK_PER_PIXEL`: every pixel marks its
// tiles globally, as before; the tiles marked are the same). The resolve of
// compute visibility is not fused in: it is a pass of its own that
// deferred-compute shares and the raster path lacks, and the gather reads its
// output anyway, so fusing would save one read of the visibility buffer and
// a pass boundary (the whole resolve is 0.026 ms at 1920x1080 on the H100).
// `MARK_SUBGROUP` (`--marking subgroup`) adds a step before the workgroup
// table: the invocations of a subgroup that mark one tile at one call site
// elect one of them to claim it, so the table's compare-exchanges (which
// serialise when a subgroup's lanes hit one slot, the common case: most
// neighbouring pixels need the same tile) follow the distinct tiles of each
// subgroup, not its pixels; the per-pixel counts are summed per subgroup.
// `COUNT_MARK_ATOMICS` counts the global tile marks and the global atomics
// they issue, and the claims reaching the workgroup table
// (`COUNT_MARK_TILES`, `COUNT_MARK_ATOMICS`, `COUNT_MARK_CLAIMS`).
#import shadespace::contract::{COUNT_QUEUED, COUNT_VISIBLE, COUNT_NEW, COUNT_PAGES_USED, COUNT_PAGES_REQUESTED, COUNT_PAGES_FAILED,
    COUNT_PAGES_BACKED, COUNT_VIEW_TILES, COUNT_BACKED_TILES, COUNT_ATLAS_PIXELS, COUNT_UNDER_SHADED_PIXELS}
#ifdef COUNT_MARK_ATOMICS
#import shadespace::contract::{COUNT_MARK_TILES, COUNT_MARK_ATOMICS, COUNT_MARK_CLAIMS}
#endif
#import shadespace::pixel_surface::{sample_pixel, sample_pixel_again, PixelSample}
#ifdef MSAA
#import shadespace::pixel_surface::sample_pixel_at
#import shadespace::contract::{COUNT_MSAA_EDGE_PIXELS, COUNT_MSAA_POINTS}
#endif
#import shadespace::objectspace_mark_backed::mark_backed_page
#import shadespace::objectspace_dispatch::{write_dispatch, SHADE_ARGS}
#import shadespace::objectspace::{params, atlas_entries, entry_level, tile_visible, tile_shaded, queue, counters, count,
    set_stripe, visibility, shade_list,
    chart_footprint, select_levels, footprint_level, bilinear, AtlasLevel, page_used, page_requests, request_list, backed,
    virtual_page, physical_page, virtual_tile, physical_tile, NOT_BACKED, view_slot, tile_views, page_origin,
    page_request_bit, tile_request_bit, page_tile_origin, forget_request, BlendedVertex, blended_vertex, filter_margin,
    aniso_taps, aniso_tap}
#import shadespace::objectspace::visibility_ids
#ifdef MSAA
#import shadespace::objectspace::{sample_group, visibility_samples}
#endif

#ifdef PIXEL_RECORD
// Per pixel of the view (`--os-gather record`): what the gather reads
// instead of rebuilding the pixel's surface: chart UV, the level pair's
// weight, its levels (lo | hi << 16). Written for pixels of objects in the
// atlas; `record_index` is the pixel `mark_surface` marks for.
@group(2) @binding(0) var<storage, read_write> pixel_records: array<vec4u>;
var<private> record_index: u32;
#endif

// A small integer hash (PCG's output permutation) for tile phases.
fn hash(x: u32) -> u32 {
    let state = x * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Whether a visible tile shaded at stamp `shaded` is shaded again this frame.
fn due(shaded: u32, valid_since: u32, tile: u32) -> bool {
    if shaded == 0u || shaded < valid_since {
        return true;
    }
    // Shaded with this view and these lights: shading again gives the same
    // shade, so a static camera shades nothing (reuse 1 shades every frame).
    if params.reuse > 1u && shaded >= params.view_since {
        return false;
    }
    let age = params.stamp - shaded;
    if params.spread == 0u {
        return age >= params.reuse;
    }
    // Decoupled shading rate: every tile has a phase frame in each window of
    // N frames and is shaded again on it, so a frame shades about 1/N of the
    // visible tiles (plus the new ones), not all of them every N frames.
    return age >= 1u && (params.stamp + hash(tile)) % params.reuse == 0u;
}

// Queues virtual tile `tile` (physical tile `slot`) when its shade is due;
// returns whether it did.
fn queue_if_due(slot: u32, tile: u32, object: u32, level_index: u32, valid_since: u32) -> bool {
    // Only this invocation touches tile_shaded[slot] this frame.
    if due(tile_shaded[slot], valid_since, tile) {
        tile_shaded[slot] = params.stamp;
        queue[slot] = vec2u(tile, (object << 8u) | level_index);
        enqueue(slot);
        return true;
    }
    return false;
}

#ifndef MARK_PER_PIXEL
// The tiles a workgroup queues, appended to `shade_list` at its end with
// one atomic on COUNT_QUEUED (a workgroup of 16x16 pixels queues a few; past
// the stash, a tile is appended on its own).
const QUEUE_STASH: u32 = 64u;
var<workgroup> stashed: atomic<u32>;
var<workgroup> stash: array<u32, QUEUE_STASH>;
var<workgroup> stash_base: u32;
#endif

// Lists physical tile `slot` in this frame's shade list.
fn enqueue(slot: u32) {
#ifndef MARK_PER_PIXEL
    let at = atomicAdd(&stashed, 1u);
    if at < QUEUE_STASH {
        stash[at] = slot;
        return;
    }
#endif
    shade_list[atomicAdd(&counters[COUNT_QUEUED], 1u)] = slot;
}

#ifdef COUNT_MARK_ATOMICS
var<workgroup> mark_tiles_counted: atomic<u32>;
var<workgroup> mark_atomics_counted: atomic<u32>;
var<workgroup> mark_claims_counted: atomic<u32>;
#endif

// Counts `n` global atomics of marking (with `COUNT_MARK_ATOMICS`).
fn count_atomics(n: u32) {
#ifdef COUNT_MARK_ATOMICS
    atomicAdd(&mark_atomics_counted, n);
#endif
}

// Asks for a physical page for virtual page `page`, remembering the tile of
// `texel` in its request bit: the first pixel of the page to set a tile
// bit and find the page's bit clear lists the page.
fn request_tile(page: u32, object: u32, level_index: u32, l: AtlasLevel, texel: vec2u) {
    let tile = tile_request_bit(virtual_tile(l, texel));
    count_atomics(1u);
    if (atomicLoad(&page_requests[tile.x]) & tile.y) != 0u {
        return;
    }
    count_atomics(1u);
    if (atomicOr(&page_requests[tile.x], tile.y) & tile.y) != 0u {
        return;
    }
    let p = page_request_bit(page);
    count_atomics(1u);
    if (atomicOr(&page_requests[p.x], p.y) & p.y) != 0u {
        return;
    }
    count_atomics(1u);
    let n = atomicAdd(&counters[COUNT_PAGES_REQUESTED], 1u);
    if n < params.request_capacity {
        request_list[n] = vec2u(page, (object << 8u) | level_index);
    } else {
        // More requests than the budget's pages: this one cannot be backed.
        // Its pixels are shaded forward; clear bits let the next frame ask
        // again (and let this frame's other pixels of the page ask and fail
        // again: past the budget, failures count pixels' requests, not pages).
        forget_request(l, page);
        atomicAdd(&counters[COUNT_PAGES_FAILED], 1u);
        // The page bit, one per tile of the page (at most), the counter.
        let per_row = params.page_size / params.tile_size;
        count_atomics(2u + per_row * per_row);
    }
}

fn mark_tile(object: u32, level_index: u32, l: AtlasLevel, valid_since: u32, texel: vec2i) {
    let t = vec2u(texel);
#ifdef COUNT_MARK_ATOMICS
    atomicAdd(&mark_tiles_counted, 1u);
#endif
    let page = virtual_page(l, t);
    // The page directory's word.
    count_atomics(1u);
    let physical = physical_page(page);
    if physical == NOT_BACKED {
        request_tile(page, object, level_index, l, t);
        return;
    }
    let slot = physical_tile(physical, t);
    if view_slot.count > 1u {
        // Count the tile once per view that needs it (tiles shaded for K
        // independent views), before the shared marking below.
        let bit = 1u << view_slot.index;
        count_atomics(1u);
        if (atomicLoad(&tile_views[slot]) & bit) != 0u {
            return;
        }
        count_atomics(1u);
        if (atomicOr(&tile_views[slot], bit) & bit) != 0u {
            return;
        }
        count_atomics(1u);
        count(COUNT_VIEW_TILES, 1u);
    }
    // Most pixels find their tile already marked: read before writing.
    count_atomics(1u);
    if atomicLoad(&tile_visible[slot]) == params.stamp {
        return;
    }
    count_atomics(1u);
    let previous = atomicExchange(&tile_visible[slot], params.stamp);
    if previous == params.stamp {
        return;
    }
    count_atomics(2u);
    if atomicExchange(&page_used[physical], params.stamp) != params.stamp {
        count_atomics(1u);
        count(COUNT_PAGES_USED, 1u);
    }
    count(COUNT_VISIBLE, 1u);
    if previous == 0u || previous + 1u != params.stamp {
        count_atomics(1u);
        count(COUNT_NEW, 1u);
    }
    if queue_if_due(slot, virtual_tile(l, t), object, level_index, valid_since) {
        count_atomics(1u);
    }
}

// The workgroup's table of tiles marked so far: global virtual tile
// numbers, EMPTY_SLOT where free; open addressing, linear probing.
const MARK_SLOTS: u32 = 128u;
const EMPTY_SLOT: u32 = 0xffffffffu;
// A crowded table (more distinct tiles than a workgroup's pixels usually
// mark) gives up after this many slots: the tile is marked globally, which
// is correct, only not deduplicated.
const MAX_PROBES: u32 = 8u;
#ifndef MARK_PER_PIXEL
var<workgroup> marked_tiles: array<atomic<u32>, MARK_SLOTS>;
#endif

// Whether this invocation is the workgroup's first to mark global virtual
// tile `tile` (and so marks it globally). Every tile a pixel marks gets
// marked, by that pixel or another of its workgroup, with the same object,
// level and tile: `mark_tile` reads nothing else of the texel.
fn first_in_workgroup(tile: u32) -> bool {
#ifdef MARK_PER_PIXEL
    return true;
#else
    // Fibonacci hashing: the top 7 bits of the product.
    var slot = (tile * 2654435769u) >> 25u;
    for (var probe = 0u; probe < MAX_PROBES; probe++) {
        let r = atomicCompareExchangeWeak(&marked_tiles[slot], EMPTY_SLOT, tile);
        if r.exchanged {
            return true;
        }
        if r.old_value == tile {
            return false;
        }
        // A weak exchange may fail spuriously on a free slot: try it again.
        if r.old_value != EMPTY_SLOT {
            slot = (slot + 1u) % MARK_SLOTS;
        }
    }
    return true;
#endif
}

#ifdef MARK_SUBGROUP
// Whether this invocation claims global virtual tile `tile` for the
// invocations of its subgroup that call this together: one per distinct
// tile among them (the first's tile, then the next's ...). Any split of the
// subgroup only elects more than one: the workgroup table still dedups.
fn first_in_subgroup(tile: u32) -> bool {
    var claims = false;
    // A round per distinct tile at most (each retires the first active
    // lane's), so at most one per lane. The bound is also what keeps this
    // loop's end from resting on other invocations alone: shaders are built
    // without naga's loop counter (`shaders::SHADER_CHECKS`), and a compiler
    // that takes loops without side effects to end (LLVM: lavapipe) then
    // made every lane leave in the first round, electing one tile a
    // subgroup (`mark_twin::subgroup_marking_matches_workgroup_marking_with_fewer_claims`).
    for (var round = 0u; round < MAX_SUBGROUP; round++) {
        if tile == subgroupBroadcastFirst(tile) {
            claims = elected();
            break;
        }
    }
    return claims;
}

// Lanes of the largest subgroup a GPU has (Vulkan allows up to 128).
const MAX_SUBGROUP: u32 = 128u;

// This invocation's index in its subgroup (`mark` sets it).
var<private> lane: u32;

// Whether this is the lowest of the invocations running this call together
// (naga has no `subgroupElect`).
fn elected() -> bool {
    return subgroupBroadcastFirst(lane) == lane;
}
#endif

// Marks the tile of texel `texel` unless the workgroup already did.
fn mark_tile_once(object: u32, level_index: u32, l: AtlasLevel, valid_since: u32, texel: vec2i) {
    let tile = virtual_tile(l, vec2u(texel));
#ifdef MARK_SUBGROUP
    if !first_in_subgroup(tile) {
        return;
    }
#endif
#ifdef COUNT_MARK_ATOMICS
    atomicAdd(&mark_claims_counted, 1u);
#endif
    if first_in_workgroup(tile) {
        mark_tile(object, level_index, l, valid_since, texel);
    }
}

// What a pixel is, for the under-shading counters.
const PIXEL_NOT_IN_ATLAS: u32 = 0u;
const PIXEL_SHADED: u32 = 1u;
// Its level holds fewer than one texel per gather tap (along the
// footprint's longer axis, or with `--os-aniso` the larger of its
// shorter axis and the longer over N): level > `footprint_level`.
const PIXEL_UNDER_SHADED: u32 = 2u;

var<workgroup> atlas_pixels: atomic<u32>;
var<workgroup> under_shaded_pixels: atomic<u32>;
#ifdef MSAA
// Under MSAA, of the atlas pixels: those marked (and gathered) at more than
// one point, and the points marked on surfaces in the atlas.
var<workgroup> edge_pixels: atomic<u32>;
var<workgroup> atlas_points: atomic<u32>;
// This invocation's pixel's: whether it is such an edge pixel, its points.
var<private> pixel_edge: bool;
var<private> pixel_points: u32;
#endif

// Pixels along a side of the square an invocation marks (`mark::quad_side`):
// without MSAA a 2x2 quad, whose pixels mostly lie on one triangle, loaded
// and transformed once for them (`sample_pixel_again`); under MSAA one pixel, its
// sample groups the loop.
#ifdef MSAA
const QUAD: u32 = 1u;
#else
const QUAD: u32 = 2u;
#endif

#ifdef MARK_SUBGROUP
// naga takes the subgroup builtins only with a one-dimensional workgroup:
// its 64 invocations cover its 8x8 squares row by row, as (8, 8) numbers them.
@compute @workgroup_size(64)
fn mark(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
        @builtin(local_invocation_index) local: u32, @builtin(subgroup_invocation_id) subgroup_lane: u32) {
    lane = subgroup_lane;
    set_stripe(wg, groups);
    let square = wg.xy * 8u + vec2u(local % 8u, local / 8u);
#else
@compute @workgroup_size(8, 8)
fn mark(@builtin(global_invocation_id) id: vec3u, @builtin(workgroup_id) wg: vec3u,
        @builtin(num_workgroups) groups: vec3u, @builtin(local_invocation_index) local: u32) {
    let square = id.xy;
    set_stripe(wg, groups);
#endif
#ifndef MARK_PER_PIXEL
    for (var i = local; i < MARK_SLOTS; i += 64u) {
        atomicStore(&marked_tiles[i], EMPTY_SLOT);
    }
    if local == 0u {
        atomicStore(&stashed, 0u);
    }
    workgroupBarrier();
#endif
    var atlas = 0u;
    var under = 0u;
#ifdef MSAA
    var edges = 0u;
    var points = 0u;
#endif
    for (var q = 0u; q < QUAD * QUAD; q++) {
        let kind = mark_pixel(square * QUAD + vec2u(q % QUAD, q / QUAD));
        atlas += u32(kind != PIXEL_NOT_IN_ATLAS);
        under += u32(kind == PIXEL_UNDER_SHADED);
#ifdef MSAA
        edges += u32(pixel_edge);
        points += pixel_points;
#endif
    }
    // Counted per workgroup first: one global atomic per workgroup.
#ifdef MARK_SUBGROUP
    // ... and per subgroup before that: one workgroup atomic per subgroup.
    atlas = subgroupAdd(atlas);
    under = subgroupAdd(under);
#ifdef MSAA
    edges = subgroupAdd(edges);
    points = subgroupAdd(points);
#endif
    if elected() {
#endif
        atomicAdd(&atlas_pixels, atlas);
        atomicAdd(&under_shaded_pixels, under);
#ifdef MSAA
        atomicAdd(&edge_pixels, edges);
        atomicAdd(&atlas_points, points);
#endif
#ifdef MARK_SUBGROUP
    }
#endif
    workgroupBarrier();
    if local == 0u {
        count(COUNT_ATLAS_PIXELS, atomicLoad(&atlas_pixels));
        count(COUNT_UNDER_SHADED_PIXELS, atomicLoad(&under_shaded_pixels));
#ifdef MSAA
        count(COUNT_MSAA_EDGE_PIXELS, atomicLoad(&edge_pixels));
        count(COUNT_MSAA_POINTS, atomicLoad(&atlas_points));
#endif
#ifdef COUNT_MARK_ATOMICS
        count(COUNT_MARK_TILES, atomicLoad(&mark_tiles_counted));
        count(COUNT_MARK_ATOMICS, atomicLoad(&mark_atomics_counted));
        count(COUNT_MARK_CLAIMS, atomicLoad(&mark_claims_counted));
#endif
#ifndef MARK_PER_PIXEL
        let queued = min(atomicLoad(&stashed), QUEUE_STASH);
        if queued > 0u {
            stash_base = atomicAdd(&counters[COUNT_QUEUED], queued);
        }
#endif
    }
#ifndef MARK_PER_PIXEL
    let base = workgroupUniformLoad(&stash_base);
    for (var i = local; i < min(atomicLoad(&stashed), QUEUE_STASH); i += 64u) {
        shade_list[base + i] = stash[i];
    }
#endif
}

// Marks the tiles of the gather's footprint of chart point `uv` in level
// `level_index` of `object`: the bilinear pair of texels along each axis,
// widened by the filter's margin (`filter_margin`: at most 4 texels,
// so at most two tiles along each axis).
fn mark_footprint(object: u32, level_index: u32, valid_since: u32, uv: vec2f) {
    let l = entry_level(object, level_index);
    let b = bilinear(l, uv);
    let m = i32(filter_margin());
    let last = i32(l.size) - 1;
    let first_texel = clamp(b.texel - m, vec2i(0), vec2i(last));
    let last_texel = clamp(b.texel_hi + m, vec2i(0), vec2i(last));
    // The first texel's tile, then each other corner's where the taps
    // cross a tile edge, through one call of `mark_tile_once`: a driver
    // inlines every call, and four made the shader four times as large (a
    // CPU driver took seconds to compile it).
    let lo = vec2u(first_texel) / params.tile_size;
    let hi = vec2u(last_texel) / params.tile_size;
    for (var corner = 0u; corner < 4u; corner++) {
        let right = (corner & 1u) != 0u;
        let down = (corner & 2u) != 0u;
        if (right && hi.x == lo.x) || (down && hi.y == lo.y) {
            continue;
        }
        let texel = vec2i(select(first_texel.x, last_texel.x, right), select(first_texel.y, last_texel.y, down));
        mark_tile_once(object, level_index, l, valid_since, texel);
    }
}

// Marks one pixel's tiles; returns what kind of pixel it is.
fn mark_pixel(pixel: vec2u) -> u32 {
    let size = textureDimensions(visibility);
    if pixel.x >= size.x || pixel.y >= size.y {
        return PIXEL_NOT_IN_ATLAS;
    }
#ifdef MSAA
    // Each group of samples on one chart surface (`sample_group`) marks
    // its footprint at its point, where the gather reads it.
    let n = visibility_samples();
    var left = (1u << n) - 1u;
    var kind = PIXEL_NOT_IN_ATLAS;
    var groups = 0u;
    pixel_points = 0u;
    loop {
        let g = sample_group(pixel, n, left);
        left = g.left;
        groups += 1u;
        if g.ids.x != 0u {
            let k = mark_surface(sample_pixel_at(pixel, g.at, g.ids));
            kind = max(kind, k);
            pixel_points += u32(k != PIXEL_NOT_IN_ATLAS);
        }
        if left == 0u {
            break;
        }
    }
    pixel_edge = kind != PIXEL_NOT_IN_ATLAS && groups > 1u;
    return kind;
#else
    let ids = visibility_ids(pixel, 0u);
    if ids.x == 0u {
        return PIXEL_NOT_IN_ATLAS;
    }
#ifdef PIXEL_RECORD
    record_index = pixel.y * size.x + pixel.x;
#endif
    return mark_surface(sample_pixel_again(pixel, ids));
#endif
}

// Marks the tiles of one surface point's footprint; returns what kind of
// pixel it makes.
fn mark_surface(p: PixelSample) -> u32 {
    let e = atlas_entries[p.object];
    if e.size == 0u {
        return PIXEL_NOT_IN_ATLAS; // shaded forward, in the gather
    }
    let f = chart_footprint(p);
    let levels = select_levels(e, p, f);
#ifdef PIXEL_RECORD
    pixel_records[record_index] = vec4u(bitcast<vec2u>(f.uv), bitcast<u32>(levels.t), levels.lo | (levels.hi << 16u));
#endif
    // The finer of the levels it reads decides whether it is under-shaded.
    let finest = select(levels.lo, levels.hi, levels.t >= 1.0);
    let kind = select(PIXEL_SHADED, PIXEL_UNDER_SHADED, f32(finest) > footprint_level(e, f));
    // Every tap the gather reads (`--os-aniso`: up to N along the longer axis).
    let taps = aniso_taps(e, f);
    for (var i = 0u; i < taps.count; i++) {
        let uv = aniso_tap(taps, i);
        // The fine level, then the coarse one, through one call.
        for (var k = 0u; k < 2u; k++) {
            if (k == 0u && levels.t < 1.0) || (k == 1u && levels.t > 0.0) {
                mark_footprint(p.object, select(levels.lo, levels.hi, k == 1u), e.valid_since, uv);
            }
        }
    }
    return kind;
}

// An alpha-blended object's vertex (`objectspace::blended`).
@vertex
fn vs_blended(@builtin(vertex_index) k: u32, @builtin(instance_index) object: u32) -> BlendedVertex {
    return blended_vertex(k, object);
}

// Marks the tiles an alpha-blended object's fragment needs (blended objects
// are not in the visibility buffer): its footprint's, as `mark_pixel` marks
// a pixel's. A fragment stage that writes storage may run before the depth
// test (wgpu cannot force it early), so fragments hidden behind opaque
// surfaces may mark tiles too: more shading, never a wrong image. Built with
// MARK_PER_PIXEL: a fragment stage has no workgroup memory.
@fragment
fn fs_mark_blended(in: BlendedVertex) {
    mark_surface(sample_pixel(vec2u(in.clip.xy), in.ids));
}

// Per page backed this frame (one workgroup each, one invocation per tile of
// the page, at most 16): `mark_backed_page`.
@compute @workgroup_size(16)
fn mark_backed(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
               @builtin(local_invocation_index) lid: u32) {
    set_stripe(wg, groups);
    let index = wg.y * groups.x + wg.x;
    if index >= min(atomicLoad(&counters[COUNT_PAGES_BACKED]), params.physical_pages) {
        return;
    }
    mark_backed_page(index, lid);
}


// The shade pass's indirect dispatch: a workgroup per listed tile (after
// the backed pages' marking, which lists theirs).
@compute @workgroup_size(1)
fn shade_args() {
    write_dispatch(SHADE_ARGS, min(atomicLoad(&counters[COUNT_QUEUED]), params.max_queue));
}
