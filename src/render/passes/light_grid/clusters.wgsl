// Binning into view-space clusters: screen tiles times logarithmic depth
// slices, each cell bounded by the view-space box of its frustum piece. One
// group of LANES threads per point or spot light (moved to view space) walks,
// slice by slice, the tiles whose boxes its sphere's box overlaps; `count`
// counts the hits, `fill` lists them (see build.wgsl).
#import shadespace::scene_bindings::{view, lights}
#import shadespace::light_grid_build::{params, Work, work_of, binning_radius, light_touches_box, record}

// View depth of slice boundary k (0: near, dims.z: far).
fn slice_depth(k: u32) -> f32 {
    if k == 0u {
        return params.near;
    }
    if k >= params.dims.z {
        return params.far;
    }
    return params.near * exp(f32(k) / params.slices_per_log);
}

// Slice of view depth `d`, as a float (not clamped).
fn slice_at(d: f32) -> f32 {
    return log(max(d, 1e-30) / params.near) * params.slices_per_log;
}

struct Box {
    lo: vec3f,
    hi: vec3f,
}

// View-space box of cluster (tile t, slice between depths d0 and d1): the
// box of its frustum piece's 8 corners. Mirrors `ClusterGeometry::cell_bounds`.
fn cluster_box(t: vec2u, d0: f32, d1: f32) -> Box {
    let tiles = vec2f(params.dims.xy);
    // NDC of the tile's edges; tile rows count from the top of the screen.
    let x0 = -1.0 + 2.0 * f32(t.x) / tiles.x;
    let x1 = -1.0 + 2.0 * f32(t.x + 1u) / tiles.x;
    let y1 = 1.0 - 2.0 * f32(t.y) / tiles.y;
    let y0 = 1.0 - 2.0 * f32(t.y + 1u) / tiles.y;
    let th = params.tan_half;
    var b: Box;
    b.lo = vec3f(min(x0 * d0, x0 * d1) * th.x, min(y0 * d0, y0 * d1) * th.y, -d1);
    b.hi = vec3f(max(x1 * d0, x1 * d1) * th.x, max(y1 * d0, y1 * d1) * th.y, -d0);
    return b;
}

// NDC range along one axis where cluster boxes of a slice between depths d0
// and d1 can overlap [lo, hi] (view units at tangent `th`): a box's edge
// e * d * th reaches farthest at d1 when e >= 0 and at d0 otherwise.
fn ndc_range(lo: f32, hi: f32, th: f32, d0: f32, d1: f32) -> vec2f {
    let lowest = lo / (th * select(d0, d1, lo >= 0.0));
    let highest = hi / (th * select(d1, d0, hi >= 0.0));
    return vec2f(lowest, highest);
}

fn bin(w: Work, fill: bool) {
    let light = w.light;
    let l = lights[light];
    let r = binning_radius(l.radius);
    let c = (params.to_grid * vec4f(l.position, 1.0)).xyz;
    let dir = (params.to_grid * vec4f(l.direction, 0.0)).xyz;
    let depth = -c.z;
    if depth + r < params.near || depth - r > params.far {
        return;
    }
    // Slices the sphere's depth range meets, widened by a thousandth of a slice.
    let k_last = f32(params.dims.z - 1u);
    let k0 = u32(clamp(floor(slice_at(depth - r) - 1e-3), 0.0, k_last));
    let k1 = u32(clamp(floor(slice_at(depth + r) + 1e-3), 0.0, k_last));
    let tiles = vec2f(params.dims.xy);
    for (var k = k0; k <= k1; k++) {
        let d0 = slice_depth(k);
        let d1 = slice_depth(k + 1u);
        let nx = ndc_range(c.x - r, c.x + r, params.tan_half.x, d0, d1);
        let ny = ndc_range(c.y - r, c.y + r, params.tan_half.y, d0, d1);
        // Tiles from NDC (rows from the top), widened by a thousandth of a tile.
        let tx = clamp(floor((nx + 1.0) * 0.5 * tiles.x + vec2f(-1e-3, 1e-3)), vec2f(-1.0), vec2f(tiles.x));
        let ty = clamp(floor((1.0 - ny.yx) * 0.5 * tiles.y + vec2f(-1e-3, 1e-3)), vec2f(-1.0), vec2f(tiles.y));
        let lo = vec2i(i32(tx.x), i32(ty.x));
        let hi = vec2i(i32(tx.y), i32(ty.y));
        let first = vec2u(max(lo, vec2i(0)));
        let last = vec2u(min(hi, vec2i(params.dims.xy) - 1));
        if any(hi < vec2i(0)) || any(lo >= vec2i(params.dims.xy)) || any(first > last) {
            continue;
        }
        let size = last - first + 1u;
        let n = size.x * size.y;
        for (var i = w.first; i < n; i += w.step) {
            let t = first + vec2u(i % size.x, i / size.x);
            let b = cluster_box(t, d0, d1);
            if light_touches_box(l.kind, c, dir, r, l.cos_outer, b.lo, b.hi) {
                record((k * params.dims.y + t.y) * params.dims.x + t.x, light, fill);
            }
        }
    }
}

@compute @workgroup_size(64)
fn count(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
         @builtin(local_invocation_index) lid: u32) {
    let w = work_of(wg, groups, lid, view.global_light_count);
    if w.light < view.light_count {
        bin(w, false);
    }
}

@compute @workgroup_size(64)
fn fill(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u,
        @builtin(local_invocation_index) lid: u32) {
    let w = work_of(wg, groups, lid, view.global_light_count);
    if w.light < view.light_count {
        bin(w, true);
    }
}
