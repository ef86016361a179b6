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

/// With `--reuse 2` a static camera shades every visible tile in the first
/// frame, none in the second, and all again in the third (age 2 reached).
/// With `--reuse 1` every frame shades every visible tile. Changing a light
/// invalidates the cache.
#[test]
fn reuse_skips_young_tiles_and_light_changes_invalidate() {
    let ctx = common::gpu();
    let (scene, camera, mut lights) = common::floor_scene();
    let mut os = Renderer::new(&ctx, &scene, &options(PipelineKind::ObjectSpace, 2)).unwrap();
    for frame in 0..3 {
        os.render(&ctx, &camera, &lights, frame).unwrap();
    }
    lights[1].intensity *= 2.0;
    os.render(&ctx, &camera, &lights, 3).unwrap();
    let c = os.collect_counters(&ctx, true);
    assert_eq!(c.len(), 4);
    assert!(c[0].visible_tiles > 0);
    assert_eq!(c[0].shaded_tiles, c[0].visible_tiles, "first frame shades all");
    assert_eq!(c[0].new_tiles, c[0].visible_tiles, "first frame: every tile is new");
    assert_eq!(c[1].shaded_tiles, 0, "second frame reuses all");
    assert_eq!(c[1].reused_tiles, c[1].visible_tiles);
    assert_eq!(c[1].new_tiles, 0, "static camera: no new tiles");
    assert_eq!(c[2].shaded_tiles, c[2].visible_tiles, "age 2 reached: shade again");
    assert_eq!(c[3].shaded_tiles, c[3].visible_tiles, "a light changed: shade again");

    let mut every = Renderer::new(&ctx, &scene, &options(PipelineKind::ObjectSpace, 1)).unwrap();
    for frame in 0..2 {
        every.render(&ctx, &camera, &lights, frame).unwrap();
    }
    let c = every.collect_counters(&ctx, true);
    assert_eq!(c[1].shaded_tiles, c[1].visible_tiles);
}
