// Binning into the world grid (Oxide's "light matrix"): uniform cubic cells
// over the scene's bounds, lights as world-space spheres (spots also tested
// against their cone). One group of LANES threads per point or spot light,
// or per slice of a light whose box holds many cells (`work` in build.wgsl),
// walks the cells of the light's bounding box; `count` counts the hits,
// `fill` lists them (see build.wgsl).
#import shadespace::scene_bindings::{view, lights}
#import shadespace::light_grid_build::{params, Work, work_of, binning_radius, light_touches_box, record}

// The cells of the light's box that `w` walks, each tested and recorded.
fn bin(w: Work, fill: bool) {
    let light = w.light;
    let l = lights[light];
    let r = binning_radius(l.radius);
    let last = vec3f(params.dims - 1u);
    // Cells the box may touch, widened by a thousandth of a cell against rounding.
    let lo = vec3u(clamp(floor((l.position - r - params.origin) / params.cell_size - 1e-3), vec3f(0.0), last));
    let hi = vec3u(clamp(floor((l.position + r - params.origin) / params.cell_size + 1e-3), vec3f(0.0), last));
    let size = hi - lo + 1u;
    let n = size.x * size.y * size.z;
    for (var i = w.first; i < n; i += w.step) {
        let c = lo + vec3u(i % size.x, (i / size.x) % size.y, i / (size.x * size.y));
        let cell_lo = params.origin + vec3f(c) * params.cell_size;
        let cell_hi = cell_lo + params.cell_size;
        if light_touches_box(l.kind, l.position, l.direction, r, l.cos_outer, cell_lo, cell_hi) {
            record((c.z * params.dims.y + c.y) * params.dims.x + c.x, light, fill);
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
