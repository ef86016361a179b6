//! Triangle-index maps cover every texel a triangle touches, on every
//! adapter: with the hardware's conservative rasterization where it exists,
//! with the emulation (enlarged triangles) elsewhere, lavapipe included. Thin
//! chart parts narrower than a texel (what coarse levels make of pillar
//! capitals and mouldings) would otherwise own only the few texels whose
//! centres they hold, and bilinear taps between them would find no triangle:
//! the dark seams object space showed along chart borders on lavapipe.
mod common;

use glam::{Mat4, Vec2, Vec3};
use shadespace::gpu::readback;
use shadespace::render::objectspace::atlas::AtlasLayout;
use shadespace::render::objectspace::trimap;
use shadespace::render::scene_gpu::SceneGpu;
use shadespace::scene::{Material, Mesh, Object, Scene};
use shadespace::shaders::ShaderLibrary;

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
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene);
    let layout = AtlasLayout::new(&[Some(SIZE)], 8, 4096, SIZE).unwrap();
    let mut shaders = ShaderLibrary::new().unwrap();
    let map = trimap::build(&ctx.device, &ctx.queue, &mut shaders, &scene_gpu, &layout).unwrap();
    let l = &layout.objects[0].as_ref().unwrap().levels[0];
    let bytes = readback::read_texture_region(&ctx, &map, 4, (l.x, l.y, l.page), (SIZE, SIZE)).unwrap();
    ctx.check_errors().unwrap();
    let ids: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);

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
}
