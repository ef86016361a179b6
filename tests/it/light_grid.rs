//! The GPU light grids against a brute-force CPU assignment: the clusters
//! (through the clustered pipeline) and the world grid (through object
//! space) are built on the GPU for several light sets, read back, and every
//! light that reaches a cell (its sphere touches the cell's box, exactly;
//! for a spot, also some point of the box sampled inside its cone) must be
//! in that cell's list. Extra (conservative) entries are counted and printed.

use crate::common;
use glam::{Mat4, Vec3};
use shadespace::gpu::GpuContext;
use shadespace::render::clustered::Clustered;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::passes::light_grid::clusters::ClusterDims;
use shadespace::render::passes::light_grid::{GpuLightGridParams, GridContents, LightGrid, clusters, world};
use shadespace::render::scene_gpu::order_lights;
use shadespace::render::{ClusteredConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{Aabb, Camera, Light, LightKind, LightSpec, Scene, lights, path};

const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;

/// Which grid a test reads, and the CPU twin of its cells.
#[derive(Clone, Copy)]
enum Grid {
    Clusters,
    World,
}

impl Grid {
    fn cell_bounds(self, p: &GpuLightGridParams, cell: u32) -> Aabb {
        match self {
            Grid::Clusters => clusters::cell_bounds(p, cell),
            Grid::World => world::cell_bounds(p, cell),
        }
    }
}

/// A simple xorshift, so light sets built here are reproducible.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0 as f32 / u32::MAX as f32
    }
}

fn generated(spec: &str, scene: &Scene, camera: &Camera) -> Vec<Light> {
    let spec: LightSpec = spec.parse().unwrap();
    lights::build_lights(&spec, &scene.bounds(), camera, WIDTH as f32 / HEIGHT as f32, 3).unwrap()
}

/// The light sets under test, by name.
fn light_sets(scene: &Scene, camera: &Camera) -> Vec<(&'static str, Vec<Light>)> {
    let mut rng = Rng(0x9e3779b9);
    // Spots everywhere, pointing every way, 5 to 70 degrees wide.
    let mut spots = generated("big:40+small:200", scene, camera);
    for l in spots.iter_mut().filter(|l| l.kind == LightKind::Point) {
        l.kind = LightKind::Spot;
        l.direction = Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5).normalize_or(Vec3::NEG_Y);
        l.cos_outer = (5.0 + 65.0 * rng.next()).to_radians().cos();
        l.cos_inner = 1.0f32.min(l.cos_outer + 0.05);
    }
    // The camera inside lights: big and small spheres around the eye, and a
    // spot at the eye looking along the view.
    let mut inside = generated("small:50", scene, camera);
    let at_eye = |kind, radius| Light {
        kind,
        position: camera.position + Vec3::new(0.05, -0.02, 0.03) * radius,
        radius,
        direction: camera.forward,
        ..inside[2]
    };
    inside.extend([at_eye(LightKind::Point, 0.5), at_eye(LightKind::Point, 8.0), at_eye(LightKind::Spot, 6.0)]);
    // Lights reaching every cell among small ones: each is dealt to many
    // work items of the build (`light_grid::CELLS_PER_ITEM`), a slice apiece.
    let mut whole = generated("small:64", scene, camera);
    let bounds = scene.bounds();
    let everywhere = |offset: f32| Light {
        position: bounds.center() + Vec3::splat(offset),
        radius: bounds.extent().length(),
        ..whole[2]
    };
    whole.extend([everywhere(0.0), everywhere(0.5)]);
    vec![
        ("small:64", generated("small:64", scene, camera)),
        ("big:12", generated("big:12", scene, camera)),
        ("spots", spots),
        ("camera inside lights", inside),
        ("lights over the whole scene", whole),
        // More entries than the world grid's first list holds (it is
        // sized up to fit before the first build).
        ("small:10000", generated("small:10000", scene, camera)),
    ]
}

/// Lights of `set` in the GPU's order and the index of the first non-global.
fn gpu_order(set: &[Light]) -> (Vec<Light>, usize) {
    let (ordered, globals) = order_lights(set);
    (ordered, globals as usize)
}

/// Whether a spot's cone reaches some sampled point of `b` (grid space):
/// 6^3 points over the box, and the box's point nearest the apex.
fn cone_reaches(apex: Vec3, dir: Vec3, radius: f32, cos_outer: f32, b: &Aabb) -> bool {
    let lit = |p: Vec3| {
        let d = p - apex;
        let len = d.length();
        len < radius && (len == 0.0 || d.dot(dir) / len > cos_outer)
    };
    if lit(apex.clamp(b.min, b.max)) {
        return true;
    }
    (0..216).any(|i| {
        let t = Vec3::new((i % 6) as f32, ((i / 6) % 6) as f32, (i / 36) as f32) / 5.0;
        lit(b.min + t * (b.max - b.min))
    })
}

/// Lights (GPU indices) that reach each cell, by brute force: every light
/// against every cell for the clusters; for the world grid (up to 262,144
/// cells) every light against every cell of its bounding box grown by one
/// cell, outside which a box cannot touch its sphere.
fn reference(grid: Grid, p: &GpuLightGridParams, lights: &[Light], first: usize) -> Vec<Vec<u32>> {
    let mut required = vec![Vec::new(); p.cell_count as usize];
    let to_grid: Mat4 = p.to_grid;
    for (i, l) in lights.iter().enumerate().skip(first) {
        let c = to_grid.transform_point3(l.position);
        let dir = to_grid.transform_vector3(l.direction).normalize_or_zero();
        let cells: Box<dyn Iterator<Item = u32>> = match grid {
            Grid::Clusters => Box::new(0..p.cell_count),
            Grid::World => {
                let last = (p.dims - 1).as_ivec3();
                let lo = ((c - l.radius - p.origin) / p.cell_size).floor().as_ivec3() - 1;
                let hi = ((c + l.radius - p.origin) / p.cell_size).floor().as_ivec3() + 1;
                let (lo, hi) = (lo.clamp(glam::IVec3::ZERO, last), hi.clamp(glam::IVec3::ZERO, last));
                let dims = p.dims.as_ivec3();
                Box::new((lo.z..=hi.z).flat_map(move |z| {
                    (lo.y..=hi.y).flat_map(move |y| (lo.x..=hi.x).map(move |x| ((z * dims.y + y) * dims.x + x) as u32))
                }))
            }
        };
        for cell in cells {
            let b = grid.cell_bounds(p, cell);
            let touches = c.distance_squared(c.clamp(b.min, b.max)) <= l.radius * l.radius;
            let reaches = touches && (l.kind != LightKind::Spot || cone_reaches(c, dir, l.radius, l.cos_outer, &b));
            if reaches {
                required[cell as usize].push(i as u32);
            }
        }
    }
    required
}

/// Compares one read-back grid with the reference; returns (required
/// entries, extra entries, cells that fall back to all lights).
fn compare(name: &str, grid: Grid, g: &GridContents, lights: &[Light], first: usize) -> (usize, usize, usize) {
    let required = reference(grid, &g.params, lights, first);
    let (mut needed, mut extra, mut fallback) = (0, 0, 0);
    let mut listed = 0u64;
    for (cell, req) in required.iter().enumerate() {
        listed += g.cells[cell][1] as u64;
        needed += req.len();
        if !g.fits(cell) {
            fallback += 1;
            continue;
        }
        let mut got = g.lights_of(cell).to_vec();
        got.sort_unstable();
        let n = got.len();
        got.dedup();
        assert_eq!(got.len(), n, "{name}: cell {cell} lists a light twice: {:?}", g.lights_of(cell));
        for &l in &got {
            assert!((first..lights.len()).contains(&(l as usize)), "{name}: cell {cell} lists light {l}");
        }
        for &l in req {
            assert!(
                got.binary_search(&l).is_ok(),
                "{name}: light {l} ({:?}, r {}) reaches cell {cell} {:?} but the GPU list lacks it (has {got:?})",
                lights[l as usize].kind,
                lights[l as usize].radius,
                grid.cell_bounds(&g.params, cell as u32),
            );
        }
        extra += got.len() - req.len();
    }
    assert_eq!(listed.min(u32::MAX as u64), g.total as u64, "{name}: cell counts do not sum to the scan's total");
    (needed, extra, fallback)
}

/// Renders up to 4 frames of each light set with `renderer` and checks the
/// grid after each; the list must have grown to fit by the last. Returns
/// how many sets overflowed the list on their first frame.
fn check(ctx: &GpuContext, grid: Grid, renderer: &mut Renderer, camera: &Camera, sets: &[(&str, Vec<Light>)]) -> usize {
    let read = |r: &Renderer| -> GridContents {
        let g: &LightGrid = match grid {
            Grid::Clusters => r.pipeline::<Clustered>().unwrap().light_grid(),
            Grid::World => r.pipeline::<ObjectSpace>().unwrap().light_grid(),
        };
        g.read_back(ctx).unwrap()
    };
    let mut frame = 0;
    let mut overflowed = 0;
    for (name, set) in sets {
        let (ordered, first) = gpu_order(set);
        for attempt in 0..4 {
            renderer.render(ctx, camera, set, frame).unwrap();
            frame += 1;
            let g = read(renderer);
            ctx.check_errors().unwrap();
            let (needed, extra, fallback) = compare(name, grid, &g, &ordered, first);
            eprintln!(
                "{name} (frame {attempt}): {} cells ({:?}), {} lights: {needed} entries needed, {extra} extra ({:.0}%), \
                 total {} of capacity {}, {fallback} cells over capacity",
                g.params.cell_count,
                g.params.dims,
                ordered.len() - first,
                100.0 * extra as f64 / needed.max(1) as f64,
                g.total,
                g.params.capacity,
            );
            assert!(needed > 0, "{name}: no light reaches any cell; the test checks nothing");
            if attempt == 0 && fallback > 0 {
                overflowed += 1;
            }
            if fallback == 0 {
                break;
            }
            assert!(g.total > g.params.capacity, "{name}: cells fall back although the list is not full");
            assert!(attempt < 3, "{name}: the list did not grow to fit");
        }
    }
    overflowed
}

fn atrium() -> (Scene, Camera) {
    let scene = common::load("atrium");
    let cameras = path::cameras_for_scene("atrium", &scene, WIDTH as f32 / HEIGHT as f32).unwrap();
    let camera = cameras.select(path::CameraChoice::Path).unwrap().camera_at(0);
    (scene, camera)
}

#[test]
fn clusters_hold_every_light_that_reaches_them() {
    let ctx = common::gpu();
    let (scene, camera) = atrium();
    let sets = light_sets(&scene, &camera);
    let renderer = |clusters| {
        let pipeline = PipelineConfig::Clustered(ClusteredConfig { clusters });
        Renderer::new(&ctx, &scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap()
    };
    check(&ctx, Grid::Clusters, &mut renderer(ClusterDims::default()), &camera, &sets);
    // More entries than the first list holds: overflow, fall back, grow. Eight
    // times the default cells make a thousand big lights enough, so each
    // pixel shades ~70 lights on the CPU driver instead of ~400 for big:6000.
    let fine = ClusterDims { tiles_x: 32, tiles_y: 18, slices: 48 };
    let big = [("big:1000 in fine clusters", generated("big:1000", &scene, &camera))];
    let overflowed = check(&ctx, Grid::Clusters, &mut renderer(fine), &camera, &big);
    assert_eq!(overflowed, 1, "big:1000 in {fine:?} should overflow the first list");
}

#[test]
fn world_grid_holds_every_light_that_reaches_it() {
    let ctx = common::gpu();
    let (scene, camera) = atrium();
    let sets = light_sets(&scene, &camera);
    let (charted, texture_sizes) = common::charted(&scene);
    let pipeline = PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, ..Default::default() });
    let mut r =
        Renderer::new(&ctx, &charted, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap();
    check(&ctx, Grid::World, &mut r, &camera, &sets);
}

/// The world grid depends on the lights alone (its cells cover the scene's
/// fixed bounds): frames with the same lights keep the first build, even
/// as the camera moves, and moving one light builds it again, with the
/// moved light in the cells it now reaches.
#[test]
fn the_world_grid_is_built_again_only_when_the_lights_change() {
    let ctx = common::gpu();
    let (scene, camera, mut lights) = common::floor_scene();
    let config = ObjectSpaceConfig { texture_sizes: vec![Some(256)], ..Default::default() };
    let options = RenderOptions { width: 64, height: 64, pipeline: PipelineConfig::ObjectSpace(config), samples: 1 };
    let mut r = Renderer::new(&ctx, &scene, &options).unwrap();
    let builds = |r: &Renderer| r.pipeline::<ObjectSpace>().unwrap().light_grid().builds();
    let moved_camera = Camera { position: camera.position + Vec3::X, ..camera };
    for frame in 0..3 {
        r.render(&ctx, if frame == 1 { &moved_camera } else { &camera }, &lights, frame).unwrap();
    }
    assert_eq!(builds(&r), 1, "static lights: built once");
    let point = lights.iter().position(|l| l.kind == LightKind::Point).expect("the floor has point lights");
    lights[point].position += Vec3::new(1.5, 0.0, -1.0);
    r.render(&ctx, &camera, &lights, 3).unwrap();
    assert_eq!(builds(&r), 2, "a light moved: built again");
    let g = r.pipeline::<ObjectSpace>().unwrap().light_grid().read_back(&ctx).unwrap();
    let (ordered, first) = gpu_order(&lights);
    let (needed, _, fallback) = compare("moved light", Grid::World, &g, &ordered, first);
    assert!(needed > 0 && fallback == 0, "{needed} entries needed, {fallback} cells over capacity");
    r.render(&ctx, &camera, &lights, 4).unwrap();
    ctx.check_errors().unwrap();
    assert_eq!(builds(&r), 2, "the same lights again: kept");
}
