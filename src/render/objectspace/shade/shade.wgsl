// Shade evaluation: one workgroup per queued tile (`shade_list`, packed by
// `compact_queue`), one invocation per texel
// (tiles larger than 8x8 loop over 8x8 blocks). Each texel finds its triangle
// in the triangle-index map, interpolates the vertex attributes at the texel
// centre in chart space, applies the object's current transform, and runs the
// shared lighting model with the global lights and its world-grid cell's lights.
// With `params.texel_sample_side` n > 1 (`--os-texel-samples`), a texel's
// shade is the mean of n x n points spread over it (each on the texel's
// triangle, extrapolated past its edges as the centre is): the shade
// filtered over the texel's footprint instead of sampled at its centre.

#import shadespace::contract::COUNT_QUEUED
#import shadespace::scene::vertex_uv0
#import shadespace::scene_bindings::{objects, vertices, triangle_vertices}
#import shadespace::surface::{surface_point, albedo_lod}
#import shadespace::light_grid::{world_cell_of, light_surface_in_cell}
#import shadespace::objectspace::{params, entry_level, queue, counters, shade_list, virtual_page, physical_page,
    atlas_texel}

@group(2) @binding(0) var atlas: texture_storage_2d_array<rgba16float, write>;
// Per atlas texel: triangle + 1 covering it; 0 = empty.
@group(2) @binding(1) var triangle_map: texture_2d_array<u32>;

// Barycentrics of `uv` in the chart triangle (a, c, d); extrapolated outside
// it, which is what dilated texels at chart borders want.
fn chart_barycentrics(a: vec2f, c: vec2f, d: vec2f, uv: vec2f) -> vec3f {
    let e0 = c - a;
    let e1 = d - a;
    let det = e0.x * e1.y - e0.y * e1.x;
    if abs(det) < 1e-20 {
        return vec3f(1.0, 0.0, 0.0);
    }
    let r = uv - a;
    let v = (r.x * e1.y - r.y * e1.x) / det;
    let w = (e0.x * r.y - e0.y * r.x) / det;
    return vec3f(1.0 - v - w, v, w);
}


@compute @workgroup_size(8, 8)
fn shade(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u, @builtin(local_invocation_id) lid: vec3u) {
    let index = wg.y * groups.x + wg.x;
    if index >= min(atomicLoad(&counters[COUNT_QUEUED]), params.max_queue) {
        return;
    }
    let item = queue[shade_list[index]];
    let object = item.y >> 8u;
    let level_index = item.y & 0xffu;
    let o = objects[object];
    let l = entry_level(object, level_index);
    let tiles_per_row = l.size / params.tile_size;
    let local_tile = item.x - l.tile_base;
    let tile_origin = vec2u(local_tile % tiles_per_row, local_tile / tiles_per_row) * params.tile_size;
    // Marking queued the tile this frame, so its page is backed.
    let page = physical_page(virtual_page(l, tile_origin));
    let blocks = params.tile_size / 8u;
    for (var by = 0u; by < blocks; by++) {
        for (var bx = 0u; bx < blocks; bx++) {
            let texel = tile_origin + vec2u(bx, by) * 8u + lid.xy;
            let at = atlas_texel(page, texel);
            let id = textureLoad(triangle_map, at.xy, at.layer, 0).x;
            var color = vec3f(0.0);
            if id != 0u {
                let tri = triangle_vertices(o, id - 1u);
                let a = vertices[tri.x].chart_uv;
                let c = vertices[tri.y].chart_uv;
                let d = vertices[tri.z].chart_uv;
                let t0 = vertex_uv0(vertices[tri.x]);
                let t1 = vertex_uv0(vertices[tri.y]);
                let t2 = vertex_uv0(vertices[tri.z]);
                let side = params.texel_sample_side;
                // Chart UV step between the texel's points (one texel with one point).
                let step = 1.0 / f32(l.size * side);
                for (var sy = 0u; sy < side; sy++) {
                    for (var sx = 0u; sx < side; sx++) {
                        let uv = (vec2f(texel * side + vec2u(sx, sy)) + 0.5) * step;
                        let b = chart_barycentrics(a, c, d, uv);
                        // UV0 change across one point's share of the texel, for the albedo mip.
                        let bx1 = chart_barycentrics(a, c, d, uv + vec2f(step, 0.0));
                        let by1 = chart_barycentrics(a, c, d, uv + vec2f(0.0, step));
                        let u = t0 * b.x + t1 * b.y + t2 * b.z;
                        let du = t0 * bx1.x + t1 * bx1.y + t2 * bx1.z - u;
                        let dv = t0 * by1.x + t1 * by1.y + t2 * by1.z - u;
                        let s = surface_point(o, tri, b, albedo_lod(du, dv));
                        color += light_surface_in_cell(o, s, world_cell_of(s.position));
                    }
                }
                color /= f32(side * side);
            }
            textureStore(atlas, at.xy, at.layer, vec4f(color, 1.0));
        }
    }
}
