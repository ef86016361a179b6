//! The world grid (Oxide's "light matrix"): uniform cubic cells over the
//! scene's bounds, rebuilt when the lights change, lights binned as world-space spheres
//! (spots also against their cone). Object space shades texels anywhere in
//! the scene, visible or not yet, so its grid cannot follow the view.
//!
//! Cell size: at most 64 cells per axis (262,144 cells, 3 MiB of ranges and
//! counts), and otherwise half the median light radius: then a cell lists
//! about 2.5 times the lights that reach its points (a cell a radius wide
//! lists 5 times as many; finer cells cost more binning and memory for less
//! gain), and a light covers about 5^3 cells. When the lights' boxes would
//! still make more than [`ENTRY_BUDGET`] entries (many big lights), cells
//! grow by 1.25 until they fit. A uniform grid rather than a hashed one: the
//! scene's bounds are known and fixed, so every cell exists and a texel finds
//! its cell with one multiply, no probing.

use glam::{Mat4, UVec3, Vec3};

use super::{GpuLightGridParams, LightGrid};
use crate::render::frame::Frame;
use crate::render::scene_gpu::SceneGpu;
use crate::scene::{Aabb, Light, LightKind};
use crate::shaders::{ShaderError, ShaderLibrary, ShaderSource};

pub const SHADER: ShaderSource = ShaderSource::new("light_grid/world.wgsl", include_str!("world.wgsl"));

/// Most cells along one axis.
pub const MAX_CELLS_PER_AXIS: u32 = 64;
/// Entries (light, cell) the lights' boxes may cover before cells grow: 8 Mi
/// (32 MiB of list).
pub const ENTRY_BUDGET: u64 = 1 << 23;

/// The world grid: its GPU lists, the bounds it covers, and the geometry
/// chosen for the current lights.
pub struct WorldGrid {
    pub grid: LightGrid,
    /// The scene's bounds with a margin (texels dilated past a chart's
    /// border lie a little outside their triangle).
    bounds: Aabb,
    /// Geometry and entry bound for the current lights.
    current: Option<(GpuLightGridParams, u64)>,
    /// The list's capacity at the last build (a grown list is empty until
    /// built again).
    built_capacity: Option<u64>,
}

impl WorldGrid {
    pub fn new(device: &wgpu::Device, shaders: &mut ShaderLibrary, scene: &SceneGpu) -> Result<Self, ShaderError> {
        let bounds = covered_bounds(&scene.object_bounds);
        let (dims, _) = dims_for(&bounds, finest_cell(&bounds));
        let grid = LightGrid::new(device, shaders, scene, "world grid", SHADER, dims.x * dims.y * dims.z)?;
        Ok(Self { grid, bounds, current: None, built_capacity: None })
    }
}

/// What the grid covers: the union of the objects' bounds with a margin of
/// 1% of its longest side (and 1 mm).
pub fn covered_bounds(objects: &[Aabb]) -> Aabb {
    let mut bounds = objects.iter().fold(Aabb::EMPTY, |u, b| u.union(b));
    if bounds.is_empty() {
        bounds = Aabb { min: Vec3::ZERO, max: Vec3::ZERO };
    }
    let margin = 0.01 * bounds.extent().max_element() + 1e-3;
    Aabb { min: bounds.min - margin, max: bounds.max + margin }
}

/// The geometry of a grid over `bounds` for `lights` (see the module's doc)
/// and an upper bound on its entries (every cell of every light's box).
pub fn geometry(bounds: &Aabb, lights: &[Light]) -> (GpuLightGridParams, u64) {
    let local: Vec<&Light> = lights.iter().filter(|l| matches!(l.kind, LightKind::Point | LightKind::Spot)).collect();
    let longest = bounds.extent().max_element();
    let mut radii: Vec<f32> = local.iter().map(|l| l.radius).collect();
    radii.sort_by(f32::total_cmp);
    let mut size = match radii.get(radii.len() / 2) {
        Some(median) => finest_cell(bounds).max(0.5 * median),
        None => longest,
    };
    loop {
        let (dims, cell_size) = dims_for(bounds, size);
        let params = GpuLightGridParams {
            to_grid: Mat4::IDENTITY,
            dims,
            cell_count: dims.x * dims.y * dims.z,
            origin: bounds.min,
            cell_size,
            ..Default::default()
        };
        let entries: u64 = local.iter().map(|l| box_cells(&params, l.position, l.radius)).sum();
        if entries <= ENTRY_BUDGET || size >= longest {
            return (params, entries);
        }
        size *= 1.25;
    }
}

/// Reads: the scene's lights. Writes: the world grid's cells and lists
/// (timed as `world grid: count`, `world grid: scan`, `world grid: fill`).
/// The grid covers the scene's fixed bounds, so it depends on the lights
/// alone: it is built when they change (the geometry chosen again and the
/// list grown to its entry bound first), or when its list grew since the
/// last build, and otherwise kept as it is.
pub fn build_world_grid(frame: &mut Frame, world: &mut WorldGrid) {
    world.grid.collect_totals(frame.device);
    if !frame.lights_changed && world.current.is_some() && world.built_capacity == Some(world.grid.capacity()) {
        return;
    }
    if frame.lights_changed || world.current.is_none() {
        world.current = Some(geometry(&world.bounds, frame.lights));
    }
    let (params, bound) = world.current.expect("set above");
    world.grid.reserve(frame.device, bound);
    world.grid.build(frame, params, |l| box_cells(&params, l.position, l.radius));
    world.built_capacity = Some(world.grid.capacity());
}

/// The smallest cell side: the longest side over [`MAX_CELLS_PER_AXIS`] (a
/// hair more, so that rounding never asks for one more cell).
fn finest_cell(bounds: &Aabb) -> f32 {
    (bounds.extent().max_element() / MAX_CELLS_PER_AXIS as f32 * 1.0001).max(1e-6)
}

/// Cells per axis for cells of side `size` (at least [`finest_cell`]), and the side.
fn dims_for(bounds: &Aabb, size: f32) -> (UVec3, f32) {
    let size = size.max(finest_cell(bounds));
    let dims = (bounds.extent() / size).ceil().as_uvec3().clamp(UVec3::ONE, UVec3::splat(MAX_CELLS_PER_AXIS));
    (dims, size)
}

/// Cells of the box that `bin` in `world.wgsl` walks for a light at `c`.
fn box_cells(p: &GpuLightGridParams, c: Vec3, radius: f32) -> u64 {
    let r = radius * (1.0 + 1.0 / 1024.0) + 1e-4;
    let last = (p.dims - 1).as_vec3();
    let lo = ((c - r - p.origin) / p.cell_size - 1e-3).floor().clamp(Vec3::ZERO, last);
    let hi = ((c + r - p.origin) / p.cell_size + 1e-3).floor().clamp(Vec3::ZERO, last);
    let n = hi - lo + 1.0;
    (n.x * n.y * n.z) as u64
}

/// The world box of cell `cell` (the CPU twin of the cell in `world.wgsl`).
pub fn cell_bounds(p: &GpuLightGridParams, cell: u32) -> Aabb {
    let c = UVec3::new(cell % p.dims.x, (cell / p.dims.x) % p.dims.y, cell / (p.dims.x * p.dims.y));
    let min = p.origin + c.as_vec3() * p.cell_size;
    Aabb { min, max: min + p.cell_size }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(position: Vec3, radius: f32) -> Light {
        Light::point(position, radius)
    }

    fn scene_box() -> Aabb {
        covered_bounds(&[Aabb { min: Vec3::new(-20.0, 0.0, -10.0), max: Vec3::new(20.0, 10.0, 10.0) }])
    }

    /// `n` lights spread through the box.
    fn spread(n: usize, radius: f32) -> Vec<Light> {
        let b = scene_box();
        let step = Vec3::new(0.37, 0.61, 0.53);
        (0..n).map(|i| point(b.min + b.extent() * (step * i as f32).fract(), radius)).collect()
    }

    fn covers(p: &GpuLightGridParams, b: &Aabb) -> bool {
        p.origin == b.min && (p.origin + p.dims.as_vec3() * p.cell_size).cmpge(b.max).all()
    }

    #[test]
    fn cells_are_half_the_median_radius_within_64_per_axis() {
        let b = scene_box();
        let (p, _) = geometry(&b, &spread(100, 2.0));
        assert!((p.cell_size - 1.0).abs() < 1e-6, "{}", p.cell_size);
        assert!(covers(&p, &b), "{p:?}");
        // Tiny lights: the 64-cell limit wins along the longest side.
        let (p, _) = geometry(&b, &spread(100, 0.01));
        assert_eq!(p.dims.x, MAX_CELLS_PER_AXIS, "{p:?}");
        assert!(p.dims.max_element() <= MAX_CELLS_PER_AXIS && covers(&p, &b), "{p:?}");
        assert_eq!(p.cell_count, p.dims.x * p.dims.y * p.dims.z);
        // No point or spot light: one coarse grid.
        let (p, entries) = geometry(&b, &[]);
        assert_eq!((entries, covers(&p, &b)), (0, true), "{p:?}");
    }

    #[test]
    fn many_big_lights_coarsen_the_grid_to_the_budget() {
        let b = scene_box();
        // Many tiny lights set the median; 2000 lights reach the whole scene.
        let mut lights = spread(10_000, 0.1);
        lights.extend(spread(2_000, 30.0));
        let finest = geometry(&b, &spread(10, 0.1)).0.cell_size;
        let (p, entries) = geometry(&b, &lights);
        assert!(entries <= ENTRY_BUDGET, "{entries}");
        assert!(p.cell_size > 2.0 * finest, "cells did not grow: {} vs {finest}", p.cell_size);
        assert!(covers(&p, &b));
        // The bound counts the cells of each light's box.
        let one = box_cells(&p, Vec3::new(0.0, 5.0, 0.0), 6.0);
        assert!((8..=p.cell_count as u64).contains(&one), "{one}");
    }
}
