//! Bloom on the floor scene with one very bright light: it spreads light
//! into pixels that are black without it, keeps the HDR image finite and its
//! mean brightness (the composite is a lerp), and strength 0 leaves the
//! image bit-identical to no bloom.

use crate::common;
use glam::Vec3;
use shadespace::gpu::readback;
use shadespace::render::{ForwardConfig, PipelineConfig, RenderError, RenderOptions, Renderer};
use shadespace::scene::Light;

const WIDTH: u32 = 128;
const HEIGHT: u32 = 96;

/// The tone-mapped image and the HDR target's RGB values.
fn frame(ctx: &shadespace::gpu::GpuContext, r: &mut Renderer, lights: &[Light]) -> (image::RgbaImage, Vec<[f32; 3]>) {
    let (_, camera, _) = common::floor_scene();
    r.render(ctx, &camera, lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
    let hdr = halves.chunks_exact(4).map(|p| [p[0].to_f32(), p[1].to_f32(), p[2].to_f32()]).collect();
    ctx.check_errors().unwrap();
    (image, hdr)
}

fn mean(hdr: &[[f32; 3]]) -> f64 {
    hdr.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / hdr.len() as f64
}

#[test]
fn bloom_spreads_a_bright_light_and_strength_zero_is_off() {
    let ctx = common::gpu();
    let (scene, _, mut lights) = common::floor_scene();
    // A very bright, small light just above the floor's far edge (the black
    // background lies right behind it on screen).
    lights.push(Light { position: Vec3::new(0.0, 0.2, -3.7), intensity: 400.0, radius: 1.5, ..lights[1] });
    let pipeline = PipelineConfig::Forward(ForwardConfig::default());
    let mut r =
        Renderer::new(&ctx, &scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap();
    assert_eq!(r.bloom, 0.0, "bloom is off by default");
    let (plain, plain_hdr) = frame(&ctx, &mut r, &lights);

    r.bloom = 0.3;
    let (bloomed, bloomed_hdr) = frame(&ctx, &mut r, &lights);
    image_out(&plain, "bloom-off.png");
    image_out(&bloomed, "bloom-on.png");
    assert!(bloomed_hdr.iter().flatten().all(|v| v.is_finite()), "bloom made a non-finite value");
    let lum = |p: &image::Rgba<u8>| p[0] as u32 + p[1] as u32 + p[2] as u32;
    let black = plain.pixels().filter(|p| lum(p) == 0).count();
    let lit = plain.pixels().zip(bloomed.pixels()).filter(|(a, b)| lum(a) == 0 && lum(b) >= 30).count();
    eprintln!("{black} black pixels without bloom, {lit} of them lit (sum of channels >= 30) with bloom 0.3");
    assert!(black > 1000, "the test needs black background: {black} pixels");
    assert!(lit >= 50, "bloom lit only {lit} of the black pixels");
    // The glow fades with distance: brighter just above the floor's edge
    // behind the light (mid-column) than in the top corner.
    let edge = (0..HEIGHT).find(|&y| lum(plain.get_pixel(WIDTH / 2, y)) > 0).expect("the floor is on screen");
    let (near, far) = (lum(bloomed.get_pixel(WIDTH / 2, edge.saturating_sub(2))), lum(bloomed.get_pixel(0, 0)));
    eprintln!("glow: {near} just above the light, {far} in the corner");
    assert!(near > far + 60, "glow {near} near the light, {far} in the corner");
    // Light moves into the glow; the image's mean stays (edges lose a little).
    let (m0, m1) = (mean(&plain_hdr), mean(&bloomed_hdr));
    eprintln!("mean HDR (sum of channels): {m0:.4} without bloom, {m1:.4} with");
    assert!((m1 / m0 - 1.0).abs() < 0.1, "mean {m0} -> {m1}");

    r.bloom = 0.0;
    let (off_again, _) = frame(&ctx, &mut r, &lights);
    assert!(off_again == plain, "bloom 0 after bloom 0.3 differs from no bloom");

    for bad in [1.5, -0.5, f32::NAN] {
        r.bloom = bad;
        let (_, camera, _) = common::floor_scene();
        let result = r.render(&ctx, &camera, &lights, 1);
        assert!(matches!(result, Err(RenderError::BadBloom(_))), "bloom {bad} was accepted");
    }
}

fn image_out(image: &image::RgbaImage, name: &str) {
    image.save(common::out_dir().join(name)).unwrap();
}
