//! Object-space pipeline against forward on a tiny scene.
mod common;

use shadespace::metrics;
use shadespace::render::objectspace::ObjectSpaceOptions;
use shadespace::render::{PipelineKind, RenderOptions, Renderer};

fn options(pipeline: PipelineKind, reuse: u32) -> RenderOptions {
    RenderOptions {
        pipeline,
        width: 160,
        height: 120,
        depth_prepass: true,
        objectspace: Some(ObjectSpaceOptions { reuse, texture_sizes: vec![Some(512)], ..Default::default() }),
    }
}

#[test]
fn objectspace_matches_forward_on_floor() {
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    let mut fwd = Renderer::new(&ctx, &scene, &options(PipelineKind::Forward, 1)).unwrap();
    fwd.render(&ctx, &camera, &lights, 0).unwrap();
    let reference = fwd.read_image(&ctx).unwrap();
    let mut os = Renderer::new(&ctx, &scene, &options(PipelineKind::ObjectSpace, 1)).unwrap();
    os.render(&ctx, &camera, &lights, 0).unwrap();
    let test = os.read_image(&ctx).unwrap();
    let counters = os.collect_counters(&ctx, true);
    let out = common::out_dir();
    reference.save(out.join("os_floor_forward.png")).unwrap();
    test.save(out.join("os_floor_objectspace.png")).unwrap();
    let (err, map) = metrics::compare(&reference, &test);
    map.save(out.join("os_floor_flip.png")).unwrap();
    eprintln!("{err:?} {counters:?}");
    assert!(counters[0].visible_tiles > 0);
    assert!(err.flip_mean < 0.05, "{err:?}");
}
