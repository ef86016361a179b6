//! A light set built in code instead of `--lights`: a warm key spot that
//! casts shadows, a cool fill, and a ring of small coloured point lights
//! around a model, rendered with tiled deferred shading. The set is also
//! written as a JSON light file, which `shadespace render --lights FILE` reads.
//!
//! `cargo run --example custom_lights -- [MODEL] [OUT.png]`

use glam::Vec3;
use shadespace::{GpuContext, GpuOptions, Light, LightKind, PipelineConfig, Stage};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let model = args.next().unwrap_or_else(|| "tests/data/corpus/teapot.obj".into());
    let out = args.next().unwrap_or_else(|| "custom_lights.png".into());
    let stage = Stage::load(&model, 640, 360)?;
    let bounds = stage.scene.bounds();
    let (centre, size) = (bounds.center(), bounds.extent().length());

    // Attenuation is 1 / (1 + d²) in scene units: scale intensities with the
    // square of the distance so that the set lights a model of any size.
    let aimed = |kind: LightKind, position: Vec3, color: Vec3, strength: f32| Light {
        kind,
        color,
        intensity: strength * (1.0 + position.distance_squared(centre)),
        direction: (centre - position).normalize(),
        radius: 3.0 * size,
        cos_inner: 0.94,
        cos_outer: 0.87,
        ..Light::point(position, 3.0 * size)
    };
    let mut lights = vec![
        Light { kind: LightKind::Ambient, intensity: 0.05, ..Light::point(Vec3::ZERO, 1.0) },
        Light {
            casts_shadows: true,
            ..aimed(LightKind::Spot, centre + size * Vec3::new(-1.0, 1.2, 1.0), Vec3::new(1.0, 0.85, 0.6), 1.0)
        },
        aimed(LightKind::Point, centre + size * Vec3::new(1.2, 0.3, 0.8), Vec3::new(0.5, 0.7, 1.0), 0.3),
    ];
    for k in 0..12 {
        let angle = k as f32 / 12.0 * std::f32::consts::TAU;
        let at = centre + 0.45 * size * Vec3::new(angle.cos(), 0.1, angle.sin());
        let hue = Vec3::new(angle.cos(), (angle + 2.1).cos(), (angle + 4.2).cos()) * 0.5 + 0.5;
        lights.push(Light { color: hue, intensity: 1.0 + (0.3 * size).powi(2), ..Light::point(at, 0.3 * size) });
    }
    std::fs::write("custom_lights.json", serde_json::to_string_pretty(&lights)?)?;

    let ctx = GpuContext::new(&GpuOptions::default())?;
    let mut renderer = stage.renderer(&ctx, PipelineConfig::from_name("deferred-compute").expect("a pipeline"))?;
    renderer.render(&ctx, &stage.camera(0), &lights, 0)?;
    renderer.read_image(&ctx)?.save(&out)?;
    println!("{} lights -> {out} (and custom_lights.json)", lights.len());
    Ok(())
}
