//! Alpha-blended materials (`passes::blended`) on the panes scene
//! (`scene::generate::panes`: red over green over blue over a wall): each
//! pipeline, at one sample and at four, composites the panes back to front
//! (each pixel's HDR colour against the analytic "over" of the panes its
//! ray crosses, under an ambient light); object space shades the panes in
//! its atlas and agrees with forward under a sun and a point light too.

use glam::{Vec3, Vec4};
use shadespace::color::{linear_to_srgb8, srgb8_to_linear};
use shadespace::gpu::{GpuContext, readback};
use shadespace::render::{
    DeferredComputeConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod, check_samples,
};
use shadespace::scene::generate::{PANES, PANES_BACKDROP, panes};
use shadespace::scene::{Camera, Light, LightKind, Scene};

use crate::common;

const SIZE: u32 = 128;
/// Largest |HDR difference| from the analytic composite, per channel.
/// Measured on lavapipe: at most 0.0015 in every pipeline at 1 and 4 samples
/// (half-float storage and the sRGB texels' decode); bound with margin.
const COMPOSITE_BOUND: f32 = 0.006;
/// Pixels whose ray passes this close (metres) to an edge of a pane or of
/// the wall are left out of the analytic check (they mix surfaces).
const EDGE_MARGIN: f32 = 0.04;

fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 0.0, 4.0),
        forward: Vec3::NEG_Z,
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 20.0,
    }
}

fn light(kind: LightKind, intensity: f32) -> Light {
    Light {
        kind,
        color: Vec3::ONE,
        intensity,
        position: Vec3::new(0.5, 0.8, 2.0),
        direction: Vec3::new(0.3, -0.4, -1.0).normalize(),
        radius: 6.0,
        cos_inner: 1.0,
        cos_outer: 1.0,
        casts_shadows: false,
    }
}

/// The resolved HDR frame of `pipeline` (linear RGB per pixel).
fn render(ctx: &GpuContext, scene: &Scene, lights: &[Light], pipeline: PipelineConfig, samples: u32) -> Vec<Vec3> {
    let options = RenderOptions { width: SIZE, height: SIZE, pipeline, samples };
    let mut r = Renderer::new(ctx, scene, &options).unwrap();
    r.render(ctx, &camera(), lights, 0).unwrap();
    let png = common::out_dir().join(format!("blending-{}-{samples}.png", r.pipeline_name()));
    r.read_image(ctx).unwrap().save(png).unwrap();
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    let half = |t: &[u8], k: usize| half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32();
    bytes.chunks_exact(8).map(|t| Vec3::new(half(t, 0), half(t, 1), half(t, 2))).collect()
}

/// What a flat-coloured surface of linear colour `c` reflects of a unit
/// ambient light: its texel as stored (sRGB, 8 bits) and decoded.
fn stored(c: Vec3) -> Vec3 {
    Vec3::from(c.to_array().map(|x| srgb8_to_linear(linear_to_srgb8(x))))
}

/// Per pixel: `None` near an edge, else the surfaces its ray crosses,
/// nearest first (indices into `PANES`), and whether it reaches the wall.
fn coverage(x: u32, y: u32) -> Option<(Vec<usize>, bool)> {
    let cam = camera();
    let inverse = cam.view_projection(1.0).inverse();
    let ndc =
        Vec4::new((x as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / SIZE as f32 * 2.0, 0.5, 1.0);
    let p = inverse * ndc;
    let dir = (p.truncate() / p.w - cam.position).normalize();
    let hit = |z: f32| {
        let t = (z - cam.position.z) / dir.z;
        (cam.position + dir * t).truncate()
    };
    // Inside (true), outside (false) or too close to the edge (None).
    let inside = |q: glam::Vec2, min: glam::Vec2, max: glam::Vec2| {
        let d = (q - min).min(max - q).min_element();
        if d.abs() < EDGE_MARGIN { None } else { Some(d > 0.0) }
    };
    let mut panes = Vec::new();
    for (i, pane) in PANES.iter().enumerate() {
        if inside(hit(pane.z), pane.min, pane.max)? {
            panes.push(i);
        }
    }
    let wall = inside(hit(-1.0), glam::Vec2::new(-2.0, -1.5), glam::Vec2::new(2.0, 1.5))?;
    Some((panes, wall))
}

/// The analytic composite under a unit ambient light of `panes` (nearest
/// first) over the wall (or the black background), in the order given.
fn composite(panes: &[usize], wall: bool) -> Vec3 {
    let mut c = if wall { stored(PANES_BACKDROP) } else { Vec3::ZERO };
    for &i in panes.iter().rev() {
        let a = PANES[i].opacity;
        c = a * stored(PANES[i].color) + (1.0 - a) * c;
    }
    c
}

/// The pixels away from edges, each with its analytic composite under a
/// unit ambient light and the panes its ray crosses (nearest first).
fn analytic_pixels() -> Vec<(usize, Vec3, Vec<usize>)> {
    let mut pixels = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            if let Some((panes, wall)) = coverage(x, y) {
                pixels.push(((y * SIZE + x) as usize, composite(&panes, wall), panes));
            }
        }
    }
    pixels
}

/// The analytic check can tell the orders apart: many pixels see all three
/// panes, and where two or more overlap the composite in the other order
/// is many bounds away, so drawing in object order (the panes are listed
/// nearest first) or unsorted fails the pipelines' tests below.
#[test]
fn the_composite_tells_the_orders_apart() {
    let pixels = analytic_pixels();
    let three = pixels.iter().filter(|p| p.2.len() == 3).count();
    assert!(three > 200, "{three} pixels see all three panes");
    let swapped = pixels
        .iter()
        .filter(|p| p.2.len() >= 2)
        .map(|p| {
            let reversed: Vec<usize> = p.2.iter().rev().copied().collect();
            (composite(&reversed, true) - p.1).abs().max_element()
        })
        .fold(0.0f32, f32::max);
    eprintln!("the panes composited in the other order: {swapped:.4} away");
    assert!(swapped > 10.0 * COMPOSITE_BOUND, "the other order differs by {swapped} only");
}

/// `pipeline` (object space: with the scene charted), at one sample and,
/// where the adapter has them and the visibility is raster, at four, shows
/// at every pixel away from edges the analytic back-to-front composite of
/// the panes its ray crosses within `COMPOSITE_BOUND`.
fn composites_in_order(pipeline: PipelineConfig) {
    let ctx = common::gpu();
    let name = pipeline.name();
    let (scene, pipeline) = match pipeline {
        PipelineConfig::ObjectSpace(c) => {
            let (scene, texture_sizes) = common::charted(&panes());
            (scene, PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, ..c }))
        }
        p => (panes(), p),
    };
    let compute = match &pipeline {
        PipelineConfig::ObjectSpace(c) => c.visibility == VisibilityMethod::Compute,
        PipelineConfig::DeferredCompute(c) => c.visibility == VisibilityMethod::Compute,
        _ => false,
    };
    let lights = [light(LightKind::Ambient, 1.0)];
    let pixels = analytic_pixels();
    let samples = [1, 4].into_iter().filter(|&n| n == 1 || check_samples(&ctx, n).is_ok());
    for n in samples {
        let hdr = render(&ctx, &scene, &lights, pipeline.clone(), n);
        let worst = pixels.iter().map(|(i, expected, _)| (hdr[*i] - *expected).abs().max_element()).fold(0.0, f32::max);
        eprintln!("{name} (compute visibility: {compute}) at {n} samples: largest |HDR - composite| {worst:.5}");
        assert!(worst <= COMPOSITE_BOUND, "{name} at {n} samples: {worst}");
    }
}

#[test]
fn panes_composite_in_order_in_forward() {
    composites_in_order(PipelineConfig::from_name("forward").unwrap());
}

#[test]
fn panes_composite_in_order_in_forward_multipass() {
    composites_in_order(PipelineConfig::from_name("forward-multipass").unwrap());
}

#[test]
fn panes_composite_in_order_in_clustered() {
    composites_in_order(PipelineConfig::from_name("clustered").unwrap());
}

#[test]
fn panes_composite_in_order_in_deferred() {
    composites_in_order(PipelineConfig::from_name("deferred").unwrap());
}

#[test]
fn panes_composite_in_order_in_deferred_compute() {
    composites_in_order(PipelineConfig::from_name("deferred-compute").unwrap());
}

/// With compute visibility, which writes no depth target: the blended
/// pass lays the opaque depth down first.
#[test]
fn panes_composite_in_order_in_deferred_compute_with_compute_visibility() {
    let c = DeferredComputeConfig { visibility: VisibilityMethod::Compute, ..Default::default() };
    composites_in_order(PipelineConfig::DeferredCompute(c));
}

#[test]
fn panes_composite_in_order_in_objectspace() {
    composites_in_order(PipelineConfig::from_name("objectspace").unwrap());
}

#[test]
fn panes_composite_in_order_in_objectspace_with_compute_visibility() {
    let c = ObjectSpaceConfig { visibility: VisibilityMethod::Compute, ..Default::default() };
    composites_in_order(PipelineConfig::ObjectSpace(c));
}

/// Under an ambient light, a sun and a point light, object space (the
/// panes and the wall shaded into its atlas, the panes gathered over the
/// frame) agrees with forward: mean |HDR difference| measured 0.00021 on
/// lavapipe, bound 0.002; largest 0.00195 measured, bound 0.02.
#[test]
fn objectspace_agrees_with_forward_on_panes() {
    let ctx = common::gpu();
    let scene = panes();
    let charted = common::charted(&scene);
    let lights = [light(LightKind::Ambient, 0.3), light(LightKind::Directional, 1.2), light(LightKind::Point, 3.0)];
    let forward = render(&ctx, &scene, &lights, PipelineConfig::from_name("forward").unwrap(), 1);
    let os = PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes: charted.1.clone(), ..Default::default() });
    let objectspace = render(&ctx, &charted.0, &lights, os, 1);
    let diffs: Vec<f32> = forward.iter().zip(&objectspace).map(|(a, b)| (*a - *b).abs().max_element()).collect();
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let worst = diffs.iter().copied().fold(0.0, f32::max);
    eprintln!("objectspace against forward on the panes: mean |HDR difference| {mean:.5}, largest {worst:.5}");
    assert!(mean <= 0.002 && worst <= 0.02, "mean {mean}, largest {worst}");
    // The panes are lit: the point light brightens the red pane's centre.
    assert!(forward.iter().any(|c| c.x > 0.3), "the frame is lit");
}

/// Object space shades the panes into its atlas (their fragments mark
/// their tiles, though they are not in the visibility buffer): the panes
/// scene has more visible and shaded tiles than its wall alone (measured on
/// lavapipe: 172 against 48), and no pixel of it is shaded forward for want of a page.
#[test]
fn objectspace_shades_blended_panes_in_its_atlas() {
    let ctx = common::gpu();
    let lights = [light(LightKind::Ambient, 1.0)];
    let with_panes = panes();
    let mut wall = panes();
    wall.objects.truncate(1);
    let counters = |scene: &Scene| {
        let (charted, sizes) = common::charted(scene);
        let pipeline = PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes: sizes, ..Default::default() });
        let options = RenderOptions { width: SIZE, height: SIZE, pipeline, samples: 1 };
        let mut r = Renderer::new(&ctx, &charted, &options).unwrap();
        r.render(&ctx, &camera(), &lights, 0).unwrap();
        r.collect_counters(&ctx, true).pop().unwrap().1
    };
    let (panes, wall) = (counters(&with_panes), counters(&wall));
    eprintln!("visible tiles: {} with the panes, {} of the wall alone", panes["visible_tiles"], wall["visible_tiles"]);
    assert!(wall["visible_tiles"] > 0.0);
    for key in ["visible_tiles", "shaded_tiles"] {
        assert!(panes[key] > 1.5 * wall[key], "{key}: {} with the panes, {} without", panes[key], wall[key]);
    }
    assert_eq!(panes["pages_failed"], 0.0);
}
