//! Forward pipeline on a tiny scene: renders without validation errors and
//! the image shows lit geometry.

use crate::common;
use shadespace::render::{ForwardConfig, PipelineConfig, RenderOptions, Renderer};

#[test]
fn forward_renders_lit_floor() {
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    let options = RenderOptions {
        width: 128,
        height: 96,
        pipeline: PipelineConfig::Forward(ForwardConfig::default()),
        samples: 1,
    };
    let mut r = Renderer::new(&ctx, &scene, &options).unwrap();
    r.render(&ctx, &camera, &lights, 0).unwrap();
    let img = r.read_image(&ctx).unwrap();
    img.save(common::out_dir().join("forward_floor.png")).unwrap();
    let lum: Vec<u32> = img.pixels().map(|p| p[0] as u32 + p[1] as u32 + p[2] as u32).collect();
    let max = *lum.iter().max().unwrap();
    let min = *lum.iter().min().unwrap();
    assert!(max > 200, "image too dark: max {max}");
    assert!(max - min > 100, "image nearly uniform");
    ctx.check_errors().unwrap();
}
