// Reading a light grid (clusters or the world grid): which cell a point is
// in, and the lighting of a surface point from the global lights plus its
// cell's list. Mirrors `passes::light_grid` (the Rust twin of the cell
// geometry is `clusters.rs` / `world.rs`).
//
// The grid is bind group 3 of the passes that read it, so that pipelines
// with their own groups 1 and 2 (object space) can bind it too.
#define_import_path shadespace::light_grid
#import shadespace::lighting::{Surface, light_radiance}
#import shadespace::scene::Object
#import shadespace::scene_bindings::{view, lights}
#import shadespace::surface::light_globals
#ifdef LAYERS
#import shadespace::layers::{layer_at, layer_mask, layer_surface}
#endif

// Mirrors `passes::light_grid::GpuLightGridParams`.
struct LightGridParams {
    // World to grid space: the view matrix (clusters) or identity (world grid).
    to_grid: mat4x4f,
    // Cells per axis: clusters (tiles x, tiles y, slices), world grid (x, y, z).
    dims: vec3u,
    cell_count: u32,
    // World grid: the min corner and the side of its cubic cells.
    origin: vec3f,
    cell_size: f32,
    // Clusters: view-space x and y per unit depth at the screen's edge
    // (aspect * tan(fov/2), tan(fov/2)), and the depth range of the slices.
    tan_half: vec2f,
    near: f32,
    far: f32,
    // Clusters: slices per unit of ln(depth) (slices / ln(far / near)).
    slices_per_log: f32,
    // Entries the index list holds; a cell whose range passes it was not
    // (fully) written, and its points loop over every light instead.
    capacity: u32,
    // Work items of the build's `count` and `fill` (`work` in build.wgsl).
    work_count: u32,
    pad_b: u32,
}

@group(3) @binding(0) var<uniform> grid: LightGridParams;
// Per cell: (first entry in `grid_lights`, entry count).
@group(3) @binding(1) var<storage, read> grid_cells: array<vec2u>;
// Light indices, cell after cell.
@group(3) @binding(2) var<storage, read> grid_lights: array<u32>;

// The logarithmic depth slice holding view depth `depth` (clamped to the slices).
fn cluster_slice(depth: f32) -> u32 {
    let k = floor(log(max(depth, 1e-30) / grid.near) * grid.slices_per_log);
    return u32(clamp(k, 0.0, f32(grid.dims.z - 1u)));
}

// The cluster of the fragment at framebuffer position `frag` (pixels) and
// world position `world`: cell (tile x, tile y from the top, slice).
fn cluster_of(frag: vec2f, world: vec3f) -> u32 {
    let depth = -(grid.to_grid * vec4f(world, 1.0)).z;
    let tile = min(vec2u(frag * view.viewport.zw * vec2f(grid.dims.xy)), grid.dims.xy - 1u);
    return (cluster_slice(depth) * grid.dims.y + tile.y) * grid.dims.x + tile.x;
}

// The world-grid cell holding `p` (clamped: the grid covers the scene with a margin).
fn world_cell_of(p: vec3f) -> u32 {
    let c = vec3u(clamp(floor((p - grid.origin) / grid.cell_size), vec3f(0.0), vec3f(grid.dims - 1u)));
    return (c.z * grid.dims.y + c.y) * grid.dims.x + c.x;
}

// Radiance from the point and spot lights of `cell`. A cell whose list did
// not fit in the index list (it is regrown a few frames later) loops over
// all of them instead: slower, never wrong.
fn cell_radiance(cell: u32, s: Surface, to_eye: vec3f) -> vec3f {
    let range = grid_cells[cell];
    var color = vec3f(0.0);
    if range.x <= grid.capacity && range.y <= grid.capacity - range.x {
        for (var i = 0u; i < range.y; i++) {
            color += light_radiance(lights[grid_lights[range.x + i]], s, to_eye);
        }
    } else {
        for (var i = view.global_light_count; i < view.light_count; i++) {
            color += light_radiance(lights[i], s, to_eye);
        }
    }
    return color;
}

// Emission, the global lights and the lights of `cell`, seen from the camera
// (what `surface::light_surface` computes from an object's CPU list); for
// a layered material, each layer's with its weight (`shadespace::layers`).
fn light_surface_in_cell(o: Object, s: Surface, cell: u32) -> vec3f {
#ifdef LAYERS
    var color = vec3f(0.0);
    var remaining = 1.0;
    for (var i = s.layer_count; i > 0u && remaining > 0.0; i--) {
        let l = layer_at(s, i);
        let w = layer_mask(l, s) * remaining;
        remaining -= w;
        if w > 0.0 {
            color += w * light_surface_in_cell_one(layer_surface(l, s), cell);
        }
    }
    if remaining > 0.0 {
        color += remaining * light_surface_in_cell_one(s, cell);
    }
    return color;
#else
    return light_surface_in_cell_one(s, cell);
#endif
}

// `light_surface_in_cell` of one surface (a material or one of its layers).
fn light_surface_in_cell_one(s: Surface, cell: u32) -> vec3f {
    let to_eye = normalize(view.camera_position.xyz - s.position);
    return s.emission + light_globals(s, to_eye) + cell_radiance(cell, s, to_eye);
}
