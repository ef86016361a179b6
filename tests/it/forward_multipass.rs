//! Multi-pass forward against single-pass forward on the floor scene: with
//! 10,000 point lights (10,000+ draws in one frame, no validation errors),
//! and with an emissive floor (emission added once).

use crate::common;
use glam::Vec3;
use shadespace::metrics;
use shadespace::render::{ForwardConfig, ForwardMultipassConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{Light, LightKind};

const LIGHTS: usize = 10_000;

#[test]
fn ten_thousand_lights_match_forward() {
    let ctx = common::gpu();
    let (scene, camera, base) = common::floor_scene();
    // A 100 x 100 grid of dim, small point lights just above the 8 m floor,
    // after the floor scene's ambient light.
    let mut lights = vec![base[0]];
    lights.extend((0..LIGHTS).map(|i| {
        let (x, z) = ((i % 100) as f32 * 0.08 - 3.96, (i / 100) as f32 * 0.08 - 3.96);
        let color = Vec3::new(0.5 + 0.5 * (i % 7) as f32 / 6.0, 0.5, 0.5 + 0.5 * (i % 5) as f32 / 4.0);
        Light {
            kind: LightKind::Point,
            intensity: 0.02,
            position: Vec3::new(x, 0.15, z),
            radius: 0.4,
            color,
            ..base[1]
        }
    }));
    let render = |pipeline, lights: &[Light]| {
        let mut r =
            Renderer::new(&ctx, &scene, &RenderOptions { width: 64, height: 40, pipeline, samples: 1 }).unwrap();
        r.render(&ctx, &camera, lights, 0).unwrap();
        let image = r.read_image(&ctx).unwrap();
        (image, r.collect_counters(&ctx, true))
    };
    let (reference, _) = render(PipelineConfig::Forward(ForwardConfig::default()), &lights);
    let multipass = PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default());
    let (test, counters) = render(multipass.clone(), &lights);
    ctx.check_errors().unwrap();
    // One draw per light (each reaches the one object) and one for the ambient light.
    assert_eq!(counters.len(), 1);
    assert_eq!(counters[0].1["light_draws"], (LIGHTS + 1) as f64);
    let (err, _) = metrics::compare(&reference, &test);
    eprintln!("floor, {LIGHTS} lights, forward-multipass against forward: {err:?}");
    test.save(common::out_dir().join("forward_multipass_10k.png")).unwrap();
    assert!(err.flip_mean <= 0.02, "{err:?}");
    // The point lights, not the ambient light alone, make the image.
    let (ambient_only, _) = render(multipass, &lights[..1]);
    let lum = |i: &image::RgbaImage| i.pixels().map(|p| p[0] as u64 + p[1] as u64 + p[2] as u64).sum::<u64>();
    assert!(lum(&test) > 2 * lum(&ambient_only), "{} vs {}", lum(&test), lum(&ambient_only));
}

/// An emissive object's emission is drawn once (its own pair), not once per
/// light: with and without lights the image matches forward's.
#[test]
fn emission_is_added_once() {
    let ctx = common::gpu();
    let (mut scene, camera, lights) = common::floor_scene();
    scene.materials[0].emissive = Vec3::new(0.3, 0.15, 0.05);
    let render = |pipeline, lights: &[Light]| {
        let mut r =
            Renderer::new(&ctx, &scene, &RenderOptions { width: 64, height: 40, pipeline, samples: 1 }).unwrap();
        r.render(&ctx, &camera, lights, 0).unwrap();
        (r.read_image(&ctx).unwrap(), r.collect_counters(&ctx, true))
    };
    for lights in [&lights[..], &[]] {
        let (reference, _) = render(PipelineConfig::Forward(ForwardConfig::default()), lights);
        let (test, counters) = render(PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()), lights);
        assert_eq!(counters[0].1["light_draws"], (lights.len() + 1) as f64, "one draw per light and one emission");
        let (err, _) = metrics::compare(&reference, &test);
        eprintln!("emissive floor, {} lights, forward-multipass against forward: {err:?}", lights.len());
        assert!(err.max_abs <= 1, "{err:?}");
        assert!(reference.pixels().any(|p| p[0] > 60), "the floor glows");
    }
    ctx.check_errors().unwrap();
}
