//! The deferred pipelines against forward on the tiny floor scene, where the
//! lights are placed to reach their rare paths: tiles reached by more lights
//! than their list holds (tiled deferred shades in batches), many chunks of
//! lights, 10,000 lights, and every kind of light volume (eye inside and
//! outside, cones, wide spots drawn as spheres, volumes past the far plane).

use crate::common;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use shadespace::gpu::GpuContext;
use shadespace::metrics;
use shadespace::render::deferred::Deferred;
use shadespace::render::deferred_compute::{SMALL_TILES_MOST_LIGHTS, TILE_LIGHT_CAPACITY, TileChoice};
use shadespace::render::{
    DeferredComputeConfig, DeferredConfig, ForwardConfig, PipelineConfig, RenderOptions, Renderer,
};
use shadespace::scene::{Camera, Light, LightKind, Scene};

/// Mean FLIP allowed against forward (as in `agreement.rs`).
const AGREEMENT_FLIP: f32 = 0.02;

fn point(position: Vec3, radius: f32, color: Vec3, intensity: f32) -> Light {
    Light {
        kind: LightKind::Point,
        color,
        intensity,
        position,
        direction: Vec3::NEG_Y,
        radius,
        cos_inner: 1.0,
        cos_outer: 1.0,
        casts_shadows: false,
    }
}

fn spot(position: Vec3, direction: Vec3, radius: f32, cos_outer: f32, intensity: f32) -> Light {
    Light {
        kind: LightKind::Spot,
        direction: direction.normalize(),
        cos_inner: (cos_outer + 0.05).min(1.0),
        cos_outer,
        ..point(position, radius, Vec3::new(1.0, 0.9, 0.7), intensity)
    }
}

/// Where [`scattered_lights`] puts lights above the floor.
struct Scatter {
    count: u32,
    /// Half the side of the square they cover, centred on the floor.
    half_side: f32,
    heights: std::ops::Range<f32>,
    radii: std::ops::Range<f32>,
    intensity: f32,
    seed: u64,
}

/// Lights at seeded random places, every fourth a spot light pointing
/// about down (cones of 20 to 60 degrees), plus an ambient light.
fn scattered_lights(s: Scatter) -> Vec<Light> {
    let mut rng = ChaCha8Rng::seed_from_u64(s.seed);
    let mut lights = vec![Light { kind: LightKind::Ambient, ..point(Vec3::ZERO, 1.0, Vec3::ONE, 0.05) }];
    let h = s.half_side;
    for i in 0..s.count {
        let position = Vec3::new(rng.random_range(-h..h), rng.random_range(s.heights.clone()), rng.random_range(-h..h));
        let radius = rng.random_range(s.radii.clone());
        let color = Vec3::new(rng.random_range(0.2..1.0), rng.random_range(0.2..1.0), rng.random_range(0.2..1.0));
        lights.push(if i % 4 == 1 {
            let cone: f32 = rng.random_range(20f32..60.0);
            let tilt = Vec3::new(rng.random_range(-0.3..0.3), -1.0, rng.random_range(-0.3..0.3));
            spot(position, tilt, radius, cone.to_radians().cos(), s.intensity)
        } else {
            point(position, radius, color, s.intensity)
        });
    }
    lights
}

/// The lights whose lit region holds `p` (what the tile around `p` must list).
fn lights_reaching(lights: &[Light], p: Vec3) -> usize {
    lights
        .iter()
        .filter(|l| match l.kind {
            LightKind::Point => l.position.distance(p) < l.radius,
            LightKind::Spot => {
                let d = p - l.position;
                d.length() < l.radius && d.normalize().dot(l.direction) > l.cos_outer
            }
            _ => false,
        })
        .count()
}

fn render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    lights: &[Light],
    size: (u32, u32),
    pipeline: PipelineConfig,
) -> (image::RgbaImage, Renderer) {
    let options = RenderOptions { width: size.0, height: size.1, pipeline, samples: 1 };
    let mut r = Renderer::new(ctx, scene, &options).unwrap();
    r.render(ctx, camera, lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    (image, r)
}

/// Renders with forward and with both deferred pipelines, checks their
/// agreement, and returns the `deferred` renderer (for its volume counts).
fn check_against_forward(
    ctx: &GpuContext,
    name: &str,
    (scene, camera, lights): (&Scene, &Camera, &[Light]),
    size: (u32, u32),
) -> Renderer {
    let forward = PipelineConfig::Forward(ForwardConfig::default());
    let (reference, _) = render(ctx, scene, camera, lights, size, forward);
    let brightest = reference.pixels().map(|p| p[0] as u32 + p[1] as u32 + p[2] as u32).max().unwrap();
    assert!(brightest > 150, "{name}: the reference is nearly black");
    let out = common::out_dir();
    let mut deferred = None;
    // Tiled deferred with each tile side (`--dc-tile`), then deferred.
    let tiles = |tile| PipelineConfig::DeferredCompute(DeferredComputeConfig { tile, ..Default::default() });
    for (pipeline, tag) in [
        (tiles(TileChoice::Sixteen), "-tile16"),
        (tiles(TileChoice::Eight), "-tile8"),
        (PipelineConfig::Deferred(DeferredConfig::default()), ""),
    ] {
        let label = format!("{name}-{}{tag}", pipeline.name());
        let (test, renderer) = render(ctx, scene, camera, lights, size, pipeline);
        let (err, map) = metrics::compare(&reference, &test);
        eprintln!("{label}: {} lights, against forward: {err:?}", lights.len());
        if err.flip_mean > AGREEMENT_FLIP {
            reference.save(out.join(format!("{name}-forward.png"))).unwrap();
            test.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!("{label}: FLIP {} > {AGREEMENT_FLIP} against forward; images in {}", err.flip_mean, out.display());
        }
        deferred = Some(renderer);
    }
    deferred.expect("deferred ran last")
}

/// `--dc-tile auto` (the default) takes 8x8 tiles for up to
/// `SMALL_TILES_MOST_LIGHTS` point and spot lights and 16x16 past them,
/// building the lighting pass again when a frame's lights cross that count,
/// and draws what a renderer with that side fixed draws (the pass for 8x8
/// tiles dispatched for 16x16 ones would leave three quarters of the
/// pixels unlit).
#[test]
fn auto_tiles_follow_the_light_count() {
    let ctx = common::gpu();
    let (scene, camera, _) = common::floor_scene();
    let scatter = |count, seed| {
        scattered_lights(Scatter { count, half_side: 4.0, heights: 0.05..0.3, radii: 0.6..1.2, intensity: 0.03, seed })
    };
    let most = SMALL_TILES_MOST_LIGHTS as u32;
    let (few, many) = (scatter(most, 5), scatter(most + 1, 6));
    let size = (72, 40);
    let auto_tiles = PipelineConfig::DeferredCompute(DeferredComputeConfig::default());
    let options = RenderOptions { width: size.0, height: size.1, pipeline: auto_tiles, samples: 1 };
    let mut auto = Renderer::new(&ctx, &scene, &options).unwrap();
    let mut images = Vec::new();
    for (frame, lights, side) in [(0, &few, 8), (1, &many, 16), (2, &few, 8)] {
        auto.render(&ctx, &camera, lights, frame).unwrap();
        let image = auto.read_image(&ctx).unwrap();
        let point_lights = lights.len() - 1;
        assert_eq!(auto.report().setup["tile_size"], side, "frame {frame}: {point_lights} point and spot lights");
        let lit = image.pixels().filter(|p| p[0] as u32 + p[1] as u32 + p[2] as u32 > 60).count();
        let pixels = (size.0 * size.1) as usize;
        assert!(lit * 4 > pixels, "frame {frame}: only {lit} of {pixels} pixels lit");
        let tile = if side == 8 { TileChoice::Eight } else { TileChoice::Sixteen };
        let fixed = PipelineConfig::DeferredCompute(DeferredComputeConfig { tile, ..Default::default() });
        let (expected, _) = render(&ctx, &scene, &camera, lights, size, fixed);
        assert!(image.as_raw() == expected.as_raw(), "frame {frame}: not the image of {side}x{side} tiles");
        images.push(image);
    }
    assert!(images[0] != images[1], "the two light sets drew the same image: the lights do not show");
    ctx.check_errors().unwrap();
}

/// 2,000 lights crowd the middle of the floor: the tile under the centre is
/// reached by more lights than its list holds, so tiled deferred shades it
/// in several batches, over eight chunks of lights.
#[test]
fn crowded_tiles_shade_in_batches() {
    let (scene, camera, _) = common::floor_scene();
    let lights = scattered_lights(Scatter {
        count: 2_000,
        half_side: 1.5,
        heights: 0.2..1.0,
        radii: 0.8..1.6,
        intensity: 0.0015,
        seed: 3,
    });
    let centre = lights_reaching(&lights, Vec3::ZERO);
    assert!(
        centre > TILE_LIGHT_CAPACITY as usize,
        "only {centre} lights reach the floor's centre: the test would not overflow a tile's list"
    );
    check_against_forward(&common::gpu(), "crowded", (&scene, &camera, &lights), (160, 120));
}

/// No cap on the light count: 10,000 small lights over the whole floor (40
/// chunks, 10,000 volumes).
#[test]
fn ten_thousand_lights() {
    let (scene, camera, _) = common::floor_scene();
    let lights = scattered_lights(Scatter {
        count: 10_000,
        half_side: 4.0,
        heights: 0.05..0.3,
        radii: 0.15..0.4,
        intensity: 0.03,
        seed: 4,
    });
    check_against_forward(&common::gpu(), "ten-thousand", (&scene, &camera, &lights), (64, 48));
}

/// One light of each volume kind: the eye inside a point light's sphere and
/// a spot light's cone (both reaching past the far plane, which is just
/// beyond the floor), a point light and a spot light seen from outside, a
/// spot light too wide for a cone, and a light behind the eye (culled).
#[test]
fn every_kind_of_light_volume() {
    let (scene, mut camera, _) = common::floor_scene();
    camera.far = 12.0;
    let eye = camera.position;
    let lights = vec![
        Light { kind: LightKind::Ambient, ..point(Vec3::ZERO, 1.0, Vec3::ONE, 0.03) },
        Light {
            kind: LightKind::Directional,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            ..point(Vec3::ZERO, 1.0, Vec3::ONE, 0.1)
        },
        point(eye + Vec3::new(0.5, -0.5, 0.0), 40.0, Vec3::new(0.3, 0.4, 1.0), 6.0),
        spot(eye + Vec3::new(-0.2, 0.0, 0.1), -eye, 40.0, 0.97, 60.0),
        point(Vec3::new(2.0, 0.5, -2.0), 2.0, Vec3::new(1.0, 0.3, 0.2), 3.0),
        spot(Vec3::new(-2.0, 2.0, -1.0), Vec3::new(0.2, -1.0, 0.1), 4.0, 0.9, 8.0),
        spot(Vec3::new(1.0, 1.5, 1.5), Vec3::NEG_Y, 3.0, 0.2, 4.0),
        point(eye + Vec3::new(0.0, 0.0, 10.0), 2.0, Vec3::ONE, 50.0),
    ];
    let ctx = common::gpu();
    let renderer = check_against_forward(&ctx, "volume-kinds", (&scene, &camera, &lights), (160, 120));
    let counts = renderer.pipeline::<Deferred>().unwrap().volumes().read_counts(&ctx).unwrap();
    // Point outside (with the wide spot), point inside, spot outside, spot inside.
    assert_eq!(counts, [2, 1, 1, 1], "instances per volume list");
}
