//! Triangle-index maps cover every texel a triangle touches (the rule of
//! `trimap.wgsl` and its CPU twin), and the GPU builds the pages paging
//! backs exactly as the CPU rule says, on every adapter. Thin
//! chart parts narrower than a texel (what coarse levels make of pillar
//! capitals and mouldings) would otherwise own only the few texels whose
//! centres they hold, and bilinear taps between them would find no triangle:
//! the dark seams object space showed along chart borders on lavapipe.

use crate::common;
use glam::{Mat4, Vec2, Vec3};
use shadespace::render::objectspace::trimap::cpu::covering_triangle;
use shadespace::render::objectspace::trimap::grid::ChartGrid;
use shadespace::render::objectspace::{ObjectSpace, TrimapSearch};
use shadespace::render::{ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::generate::city::CitySpec;
use shadespace::scene::lights::default_ambient;
use shadespace::scene::{Camera, Light, Material, Mesh, Object, Scene};

/// Side of the object's shading texture (level 0) in texels.
const SIZE: u32 = 128;

/// Slivers in texel units of level 0: a long one 0.1 texel wide at a shallow
/// slope, a steep one, and one smaller than a texel that holds no texel centre.
fn slivers() -> Vec<[Vec2; 3]> {
    vec![
        [Vec2::new(2.0, 10.0), Vec2::new(120.0, 18.0), Vec2::new(120.0, 18.1)],
        [Vec2::new(40.3, 30.0), Vec2::new(52.0, 120.0), Vec2::new(52.15, 120.0)],
        [Vec2::new(90.1, 60.1), Vec2::new(90.3, 60.1), Vec2::new(90.1, 60.3)],
    ]
}

/// Whether triangle `t` and the square [x, x+1] x [y, y+1] overlap
/// (separating axes: the square's two and the triangle's three edge normals).
fn overlaps(t: &[Vec2; 3], x: f32, y: f32) -> bool {
    let square = [Vec2::new(x, y), Vec2::new(x + 1.0, y), Vec2::new(x + 1.0, y + 1.0), Vec2::new(x, y + 1.0)];
    let mut axes = vec![Vec2::X, Vec2::Y];
    for i in 0..3 {
        let e = t[(i + 1) % 3] - t[i];
        axes.push(Vec2::new(-e.y, e.x));
    }
    axes.iter().all(|a| {
        let (t_lo, t_hi) = t.iter().map(|p| p.dot(*a)).fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
        let (s_lo, s_hi) =
            square.iter().map(|p| p.dot(*a)).fold((f32::MAX, f32::MIN), |(l, h), v| (l.min(v), h.max(v)));
        t_hi >= s_lo && s_hi >= t_lo
    })
}

#[test]
fn every_texel_a_triangle_touches_is_covered() {
    let ctx = common::gpu();
    let triangles = slivers();
    let uv: Vec<Vec2> = triangles.iter().flatten().map(|p| *p / SIZE as f32).collect();
    let mut mesh = Mesh {
        name: "slivers".into(),
        positions: uv.iter().map(|u| Vec3::new(u.x, 0.0, u.y)).collect(),
        uv0: uv.clone(),
        uv1: Some(uv),
        indices: (0..triangles.len() as u32 * 3).collect(),
        ..Default::default()
    };
    mesh.generate_missing_attributes();
    let scene = Scene {
        name: "slivers".into(),
        meshes: vec![mesh],
        materials: vec![Material::default()],
        objects: vec![Object {
            name: "slivers".into(),
            mesh: 0,
            material: 0,
            transform: Mat4::IDENTITY,
            forward_only: false,
        }],
        ..Default::default()
    };
    let uv = scene.meshes[0].uv1.clone().unwrap();
    let indices = scene.meshes[0].indices.clone();
    let grid = ChartGrid::new(&uv, &indices);
    let ids: Vec<u32> =
        (0..SIZE * SIZE).map(|i| covering_triangle(&grid, &uv, &indices, SIZE, [i % SIZE, i / SIZE])).collect();

    let mut touched = 0;
    for y in 0..SIZE {
        for x in 0..SIZE {
            let id = ids[(y * SIZE + x) as usize];
            let (fx, fy) = (x as f32, y as f32);
            if triangles.iter().any(|t| overlaps(t, fx, fy)) {
                touched += 1;
                assert_ne!(id, 0, "texel ({x}, {y}) touches a sliver but holds no triangle");
            }
            // Beyond the conservative coverage and the one ring of dilation
            // (two texels past a sliver's box), nothing.
            let near = triangles.iter().any(|t| {
                let lo = t[0].min(t[1]).min(t[2]) - 2.0;
                let hi = t[0].max(t[1]).max(t[2]) + 2.0;
                fx + 1.0 > lo.x && fx < hi.x && fy + 1.0 > lo.y && fy < hi.y
            });
            if !near {
                assert_eq!(id, 0, "texel ({x}, {y}) is far from every sliver but holds triangle {}", id - 1);
            }
        }
    }
    // The long sliver alone touches more than 118 texels.
    assert!(touched > 200, "only {touched} texels touched: the slivers are not where the test expects");

    // The GPU builds the pages that a view of the plane backs, texel for texel as the CPU rule.
    let camera = Camera {
        position: Vec3::new(0.5, 1.2, 0.5),
        forward: Vec3::NEG_Y,
        up: Vec3::Z,
        fov_y: 60f32.to_radians(),
        near: 0.01,
        far: 10.0,
    };
    let config = ObjectSpaceConfig { texture_sizes: vec![Some(SIZE)], ..Default::default() };
    let options = RenderOptions { width: 256, height: 256, pipeline: PipelineConfig::ObjectSpace(config), samples: 1 };
    let mut renderer = Renderer::new(&ctx, &scene, &options).unwrap();
    let light = Light { color: Vec3::ONE, intensity: 1.0, ..default_ambient() };
    renderer.render(&ctx, &camera, &[light], 0).unwrap();
    let os = renderer.pipeline::<ObjectSpace>().unwrap();
    let (size, gpu) = os.read_triangle_map(&ctx, 0, 0).unwrap();
    ctx.check_errors().unwrap();
    assert_eq!(size, SIZE);
    let (mut compared, mut covered) = (0, 0);
    for (i, (gpu, cpu)) in gpu.iter().zip(&ids).enumerate() {
        if let Some(gpu) = gpu {
            assert_eq!(gpu, cpu, "texel ({}, {}): GPU {gpu}, CPU {cpu}", i as u32 % SIZE, i as u32 / SIZE);
            compared += 1;
            covered += (*cpu != 0) as usize;
        }
    }
    // Only the pages under the slivers are backed (the plane is nothing
    // else): at the default pages of 8x8, 23 of them.
    assert!(compared >= 1024 && covered > 200, "only {compared} texels on backed pages, {covered} covered");
}

/// The city's `building1` (fine facades, hundreds of small charts) at a
/// 32-texel texture, its coarse levels' 3x3 neighbourhoods spanning many
/// chart-grid cells: the ring search, on the default grids and on grids of
/// twice the cells per side, with 4 lanes and with 1, builds the maps the
/// neighbourhood search builds and the CPU rule says, weighing fewer
/// triangles (`trimap_weighed`).
#[test]
fn the_ring_search_builds_the_same_maps_weighing_fewer_triangles() {
    let ctx = common::gpu();
    let city = CitySpec::DEFAULT.scene();
    let mesh = city.meshes.iter().find(|m| m.name == "building1").expect("the city has building1").clone();
    let (uv, indices) = (mesh.uv1.clone().expect("the city's meshes carry their charts"), mesh.indices.clone());
    let scene = Scene {
        name: "building".into(),
        meshes: vec![mesh],
        materials: vec![Material::default()],
        objects: vec![Object {
            name: "building".into(),
            mesh: 0,
            material: 0,
            transform: Mat4::IDENTITY,
            forward_only: false,
        }],
        ..Default::default()
    };
    let camera = Camera {
        position: Vec3::new(12.0, 9.0, 30.0),
        forward: Vec3::new(-12.0, -1.0, -30.0).normalize(),
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 200.0,
    };
    let light = Light { color: Vec3::ONE, intensity: 1.0, ..default_ambient() };
    const SIDE: u32 = 32;
    let build = |search, grid, lanes| {
        let config = ObjectSpaceConfig {
            texture_sizes: vec![Some(SIDE)],
            trimap_search: search,
            trimap_grid: grid,
            trimap_lanes: Some(lanes),
            ..Default::default()
        };
        let pipeline = PipelineConfig::ObjectSpace(config);
        let options = RenderOptions { width: 128, height: 128, pipeline, samples: 1 };
        let mut renderer = Renderer::new(&ctx, &scene, &options).unwrap();
        renderer.render(&ctx, &camera, &[light], 0).unwrap();
        let weighed = renderer.collect_counters(&ctx, true)[0].1["trimap_weighed"];
        let os = renderer.pipeline::<ObjectSpace>().unwrap();
        let (size, map) = os.read_triangle_map(&ctx, 0, 0).unwrap();
        ctx.check_errors().unwrap();
        assert_eq!(size, SIDE);
        (map, weighed)
    };
    let (before, before_weighed) = build(TrimapSearch::Neighbourhood, 1, 4);
    let grid = ChartGrid::new(&uv, &indices);
    let built = before.iter().enumerate().filter_map(|(i, t)| t.map(|t| (i as u32, t))).collect::<Vec<_>>();
    assert!(built.len() >= 256, "only {} texels on backed pages", built.len());
    for &(i, t) in &built {
        assert_eq!(t, covering_triangle(&grid, &uv, &indices, SIDE, [i % SIDE, i / SIDE]), "texel {i}");
    }
    for (grid, lanes) in [(1, 4), (2, 4), (2, 1)] {
        let (map, weighed) = build(TrimapSearch::Rings, grid, lanes);
        for &(i, t) in &built {
            assert_eq!(map[i as usize], Some(t), "texel {i}: grid x{grid}, {lanes} lanes");
        }
        assert!(
            weighed * 2.0 < before_weighed,
            "grid x{grid}, {lanes} lanes: {weighed} triangles weighed, {before_weighed} by the neighbourhood search"
        );
    }
}
