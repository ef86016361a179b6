//! The shared Sponza (../shared/scenes/sponza-thesis): renders, and object
//! space agrees with forward. Skips with a message where the folder is absent.

use crate::common;
use std::path::Path;

use shadespace::metrics;
use shadespace::render::{ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{LightSpec, lights, path};

const SPONZA: &str = "../shared/scenes/sponza-thesis";

#[test]
fn sponza_forward_and_objectspace_agree() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let scene = common::load(SPONZA);
    let bounds = scene.bounds();
    let camera = path::cameras_for_scene(SPONZA, &scene, 480.0 / 270.0)
        .unwrap()
        .select(path::CameraChoice::Path)
        .unwrap()
        .camera_at(0);
    let (w, h) = (480, 270);
    let spec: LightSpec = "small:32".parse().unwrap();
    let lights = lights::build_lights(&spec, &bounds, &camera, w as f32 / h as f32, 1).unwrap();
    let (scene, texture_sizes) = common::charted_for(&scene, &camera, w, h);
    let objectspace = ObjectSpaceConfig { texture_sizes, ..Default::default() };
    let mut images = Vec::new();
    for pipeline in [PipelineConfig::Forward(ForwardConfig::default()), PipelineConfig::ObjectSpace(objectspace)] {
        let name = pipeline.name();
        let options = RenderOptions { width: w, height: h, pipeline, samples: 1 };
        let mut r = Renderer::new(&ctx, &scene, &options).unwrap();
        r.render(&ctx, &camera, &lights, 0).unwrap();
        let image = r.read_image(&ctx).unwrap();
        image.save(common::out_dir().join(format!("sponza-{name}.png"))).unwrap();
        images.push(image);
    }
    let lum: Vec<u32> = images[0].pixels().map(|p| p[0] as u32 + p[1] as u32 + p[2] as u32).collect();
    assert!(lum.iter().max().unwrap() - lum.iter().min().unwrap() > 150, "nearly uniform image");
    let (err, map) = metrics::compare(&images[0], &images[1]);
    map.save(common::out_dir().join("sponza-objectspace-flip.png")).unwrap();
    eprintln!("sponza: object space vs forward at {w}x{h}: {err:?}");
    // The issue asks FLIP <= 0.05 and PSNR >= 35 dB at full size (measured at 1920x1080 on
    // the H100: FLIP 0.003, 43.7 dB, BENCHMARKS.md); at this test size distant surfaces are
    // strongly minified, so PSNR is held to 30 dB here.
    assert!(err.flip_mean <= 0.05 && err.psnr_db >= 30.0, "{err:?}");
}
