// Tile marking and queueing, in one pass over the visibility buffer: each
// pixel finds its mip level and the texels of its bilinear footprint, and
// marks their tiles visible for this frame. The first pixel to mark a tile
// this frame decides whether the tile's cached shade is still good (younger
// than N frames and not invalidated) or queues it for shading.
#import shadespace::contract::{COUNT_QUEUED, COUNT_VISIBLE, COUNT_NEW}
#import shadespace::pixel_surface::sample_pixel
#import shadespace::objectspace::{params, atlas_entries, tile_visible, tile_shaded, queue, counters, visibility,
    chart_footprint, select_level, bilinear, AtlasLevel}

fn mark_tile(object: u32, level_index: u32, l: AtlasLevel, valid_since: u32, texel: vec2i) {
    let tiles_per_row = l.size / params.tile_size;
    let t = vec2u(texel) / params.tile_size;
    let tile = l.tile_base + t.y * tiles_per_row + t.x;
    // Most pixels find their tile already marked: read before writing.
    if atomicLoad(&tile_visible[tile]) == params.stamp {
        return;
    }
    let previous = atomicExchange(&tile_visible[tile], params.stamp);
    if previous == params.stamp {
        return;
    }
    atomicAdd(&counters[COUNT_VISIBLE], 1u);
    if previous == 0u || previous + 1u != params.stamp {
        atomicAdd(&counters[COUNT_NEW], 1u);
    }
    // Only this invocation touches tile_shaded[tile] this frame.
    let shaded = tile_shaded[tile];
    if shaded == 0u || params.stamp - shaded >= params.reuse || shaded < valid_since {
        tile_shaded[tile] = params.stamp;
        let slot = atomicAdd(&counters[COUNT_QUEUED], 1u);
        if slot < params.max_queue {
            queue[slot] = vec2u(tile, (object << 8u) | level_index);
        }
    }
}

@compute @workgroup_size(8, 8)
fn mark(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(visibility);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let ids = textureLoad(visibility, id.xy, 0).xy;
    if ids.x == 0u {
        return;
    }
    let p = sample_pixel(id.xy, ids);
    let e = atlas_entries[p.object];
    if e.size == 0u {
        return; // shaded forward, in the gather
    }
    let f = chart_footprint(p);
    let level_index = select_level(e, p, f);
    let l = e.levels[level_index];
    let b = bilinear(l, f.uv);
    mark_tile(p.object, level_index, l, e.valid_since, b.texel);
    // The other taps only add a tile when they cross a tile edge.
    let lo = vec2u(b.texel) / params.tile_size;
    let hi = vec2u(b.texel_hi) / params.tile_size;
    if hi.x != lo.x {
        mark_tile(p.object, level_index, l, e.valid_since, vec2i(b.texel_hi.x, b.texel.y));
    }
    if hi.y != lo.y {
        mark_tile(p.object, level_index, l, e.valid_since, vec2i(b.texel.x, b.texel_hi.y));
    }
    if hi.x != lo.x && hi.y != lo.y {
        mark_tile(p.object, level_index, l, e.valid_since, b.texel_hi);
    }
}

@group(2) @binding(0) var<storage, read_write> shade_dispatch: array<u32, 4>;

// Indirect dispatch arguments for shading: one workgroup per queued tile,
// spread over x and y because one dimension holds at most 65535 groups.
@compute @workgroup_size(1)
fn queue_args() {
    let n = min(atomicLoad(&counters[COUNT_QUEUED]), params.max_queue);
    let x = min(n, 65535u);
    shade_dispatch[0] = x;
    shade_dispatch[1] = select(0u, (n + x - 1u) / max(x, 1u), n > 0u);
    shade_dispatch[2] = 1u;
}
