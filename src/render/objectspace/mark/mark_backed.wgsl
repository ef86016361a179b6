// Marking the tiles of the pages paging backed this frame: the `mark_backed`
// pass (`mark.wgsl`) runs it, or, with the fused paging chain, the triangle
// map pass in the same workgroup as the page's map (`trimap.wgsl`).
#define_import_path shadespace::objectspace_mark_backed
#import shadespace::contract::{COUNT_VISIBLE, COUNT_NEW, COUNT_BACKED_TILES, COUNT_QUEUED}
#import shadespace::objectspace::{params, entry_level, tile_visible, tile_shaded, queue, count, page_requests, counters,
    shade_list,
    backed, virtual_tile, page_origin, page_request_bit, tile_request_bit, page_tile_origin}

// Backed page `index` of this frame's list, by invocation `lid` of its
// workgroup (at least 16 invocations: one per tile of the page): the page's
// tiles start over (never visible, never shaded), and those whose request
// bits are set are marked visible and queued (a tile never shaded is due)
// and listed for shading;
// the bits are cleared for a later request.
fn mark_backed_page(index: u32, lid: u32) {
    let b = backed[index];
    let object = b.y >> 8u;
    let level_index = b.y & 0xffu;
    let l = entry_level(object, level_index);
    let per_row = params.page_size / params.tile_size;
    let t = lid;
    if t < per_row * per_row {
        let slot = b.z * per_row * per_row + t;
        let texel = page_tile_origin(page_origin(l, b.x), t);
        var requested = false;
        if all(texel < vec2u(l.size)) {
            let bit = tile_request_bit(virtual_tile(l, texel));
            requested = (atomicAnd(&page_requests[bit.x], ~bit.y) & bit.y) != 0u;
        }
        atomicStore(&tile_visible[slot], select(0u, params.stamp, requested));
        tile_shaded[slot] = 0u;
        if requested {
            count(COUNT_VISIBLE, 1u);
            count(COUNT_BACKED_TILES, 1u);
            count(COUNT_NEW, 1u);
            tile_shaded[slot] = params.stamp;
            queue[slot] = vec2u(virtual_tile(l, texel), (object << 8u) | level_index);
            shade_list[atomicAdd(&counters[COUNT_QUEUED], 1u)] = slot;
        }
    }
    if lid == 0u {
        let p = page_request_bit(b.x);
        atomicAnd(&page_requests[p.x], ~p.y);
    }
}
