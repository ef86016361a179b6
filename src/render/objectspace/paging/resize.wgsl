// Resizing the atlas (at the start of a frame, before marking). On every
// resize `copy_kept` copies the pages both sizes have into the new atlas.
// Before it shrinks to `params.physical_pages` pages (the frame's params
// already name the new size, the bound buffers are still the larger
// atlas's), the pages beyond move below it. Paging's
// `age_pages`, `page_offsets` and `list_candidates` first rank the pages
// below the new size, free first, then least recently used. The pages
// beyond that back a virtual page (the movers) are ranked the other way,
// most recently used first (`count_movers`, `mover_offsets`,
// `list_movers`), and `move_pages` gives the i-th mover the i-th candidate
// while the candidate is free or less recently used: the table word,
// owner, use stamp and tile stamps follow the page, and `copy_moved`
// copies its shades and triangle map into the new atlas once it exists.
// `evict_rest` evicts the movers that found no page (their tiles are shaded
// again the next time they are seen).
#import shadespace::contract::{COUNT_CANDIDATES, AGE_BUCKETS}
#import shadespace::objectspace::{params, counters, page_table, page_used, page_owner, candidates, tile_visible,
    tile_shaded, table_word, unbind_page, age_bucket}

// A mover that found no page.
const NO_PAGE: u32 = 0xffffffffu;

struct Moves {
    count: atomic<u32>,
    // Movers per age bucket, then where each bucket's list starts.
    buckets: array<atomic<u32>, AGE_BUCKETS>,
    // (source, destination): the page beyond the new size, and the one it
    // moved to or NO_PAGE; most recently used first.
    pairs: array<vec2u>,
}

@group(2) @binding(0) var<storage, read_write> moves: Moves;

// Page `id.x` beyond the new size, when it backs a virtual page.
fn mover(id: vec3u) -> u32 {
    let page = params.physical_pages + id.x;
    if page < arrayLength(&page_owner) && page_owner[page] != 0u {
        return page;
    }
    return NO_PAGE;
}

@compute @workgroup_size(64)
fn count_movers(@builtin(global_invocation_id) id: vec3u) {
    let page = mover(id);
    if page != NO_PAGE {
        atomicAdd(&moves.buckets[age_bucket(page)], 1u);
    }
}

@compute @workgroup_size(1)
fn mover_offsets() {
    var offset = 0u;
    for (var b = AGE_BUCKETS; b > 0u; b--) {
        let n = atomicLoad(&moves.buckets[b - 1u]);
        atomicStore(&moves.buckets[b - 1u], offset);
        offset += n;
    }
    atomicStore(&moves.count, offset);
}

@compute @workgroup_size(64)
fn list_movers(@builtin(global_invocation_id) id: vec3u) {
    let page = mover(id);
    if page != NO_PAGE {
        moves.pairs[atomicAdd(&moves.buckets[age_bucket(page)], 1u)] = vec2u(page, NO_PAGE);
    }
}

@compute @workgroup_size(64)
fn move_pages(@builtin(global_invocation_id) id: vec3u) {
    let i = id.x;
    if i >= atomicLoad(&moves.count) || i >= atomicLoad(&counters[COUNT_CANDIDATES]) {
        return;
    }
    let source = moves.pairs[i].x;
    let dest = candidates[i];
    let used = atomicLoad(&page_used[source]);
    if page_owner[dest] != 0u && atomicLoad(&page_used[dest]) >= used {
        return;
    }
    unbind_page(dest);
    let owner = page_owner[source];
    page_table[table_word(owner - 1u)] = dest + 1u;
    page_owner[dest] = owner;
    atomicStore(&page_used[dest], used);
    // No table word names `source` now: `evict_rest` leaves it be.
    page_owner[source] = 0u;
    let tiles = (params.page_size / params.tile_size) * (params.page_size / params.tile_size);
    for (var t = 0u; t < tiles; t++) {
        atomicStore(&tile_visible[dest * tiles + t], atomicLoad(&tile_visible[source * tiles + t]));
        tile_shaded[dest * tiles + t] = tile_shaded[source * tiles + t];
    }
    moves.pairs[i].y = dest;
}

@compute @workgroup_size(64)
fn evict_rest(@builtin(global_invocation_id) id: vec3u) {
    let page = params.physical_pages + id.x;
    if page < arrayLength(&page_owner) {
        unbind_page(page);
    }
}

// The old atlas's shades and triangle maps, and the new atlas's.
@group(3) @binding(0) var old_atlas: texture_2d_array<f32>;
@group(3) @binding(1) var old_triangle_maps: texture_2d_array<u32>;
@group(3) @binding(2) var new_atlas: texture_storage_2d_array<rgba16float, write>;
@group(3) @binding(3) var new_triangle_maps: texture_storage_2d_array<r32uint, write>;

// Texel (x, y) of physical page `page` (both atlases place pages alike:
// they differ only in their number of layers).
fn page_texel(page: u32, x: u32, y: u32) -> vec3u {
    let per_layer = params.layer_pages * params.layer_pages;
    let i = page % per_layer;
    return vec3u(vec2u(i % params.layer_pages, i / params.layer_pages) * params.page_size + vec2u(x, y), page / per_layer);
}

// Copies page `source` of the old atlas into page `dest` of the new one, a
// thread per texel of an 8x8 square of the page.
fn copy_page(source: u32, dest: u32, lid: vec3u) {
    for (var y = lid.y; y < params.page_size; y += 8u) {
        for (var x = lid.x; x < params.page_size; x += 8u) {
            let from_texel = page_texel(source, x, y);
            let to_texel = page_texel(dest, x, y);
            textureStore(new_atlas, to_texel.xy, to_texel.z, textureLoad(old_atlas, from_texel.xy, from_texel.z, 0));
            let triangles = textureLoad(old_triangle_maps, from_texel.xy, from_texel.z, 0);
            textureStore(new_triangle_maps, to_texel.xy, to_texel.z, triangles);
        }
    }
}

// Every resize: the pages both atlases have keep their place. A workgroup
// per page, looping when there are more pages than workgroups. In compute
// because copy_texture_to_texture of the same pages took 0.52 ms on the H100
// at 1920x1080 (26,624 pages), this pass 0.033 ms (BENCHMARKS.md).
@compute @workgroup_size(8, 8)
fn copy_kept(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
             @builtin(local_invocation_id) lid: vec3u) {
    let layers = min(textureNumLayers(old_atlas), textureNumLayers(new_atlas));
    let kept = layers * params.layer_pages * params.layer_pages;
    for (var page = wg.x; page < kept; page += groups.x) {
        copy_page(page, page, lid);
    }
}

// After a shrink: the moved pages. A workgroup per move, looping as `copy_kept`.
@compute @workgroup_size(8, 8)
fn copy_moved(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
              @builtin(local_invocation_id) lid: vec3u) {
    for (var m = wg.x; m < atomicLoad(&moves.count); m += groups.x) {
        let pair = moves.pairs[m];
        if pair.y != NO_PAGE {
            copy_page(pair.x, pair.y, lid);
        }
    }
}
