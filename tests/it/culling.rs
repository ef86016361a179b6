//! Cluster culling of the compute rasterizer (`--culling`, docs/culling.md):
//! with culling `none`, `frustum` and `occlusion` the visibility buffer holds
//! the same ids, pixel for pixel, along camera paths of the tiny city and
//! Sponza, including jumps along the path after which the late pass of
//! two-pass occlusion must draw what became visible; and the counters show
//! most clusters culled down the city's street.

use crate::common;
use std::path::Path;

use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::{Counters, Culling};
use shadespace::scene::{BackFaces, Camera, Scene, path};

const SPONZA: &str = "../shared/scenes/sponza-thesis";

/// One view's ids (object + 1, triangle per pixel) in each culling mode
/// ([`Culling::ALL`] order), and the occlusion frame's cull counters.
struct View {
    ids: Vec<Vec<[u32; 2]>>,
    counters: Counters,
}

/// Renders `cameras` in turn, each with every culling mode, from one
/// object-space renderer with compute visibility and counting (the ids need
/// no atlas: every object but the first is shaded forward). Occlusion keeps
/// its history across the occlusion frames, as along a path.
fn views(ctx: &GpuContext, scene: &Scene, cameras: &[Camera], size: (u32, u32)) -> Vec<View> {
    let mut renderer = common::counting_renderer(ctx, scene, size);
    let mut out = Vec::new();
    for (i, camera) in cameras.iter().enumerate() {
        let mut ids = Vec::new();
        for (k, culling) in Culling::ALL.into_iter().enumerate() {
            renderer.culling = culling;
            renderer.render(ctx, camera, &[], (i * Culling::ALL.len() + k) as u64).unwrap();
            ids.push(renderer.pipeline::<ObjectSpace>().unwrap().read_mark_state(ctx).unwrap().visibility);
        }
        let occlusion_frame = (i * Culling::ALL.len() + 2) as u64;
        // Object space reports its counters and the rasterizer's apart.
        let counters: Counters = renderer
            .collect_counters(ctx, true)
            .into_iter()
            .filter(|(frame, _)| *frame == occlusion_frame)
            .flat_map(|(_, c)| c)
            .collect();
        assert!(counters.contains_key("cull_tested"), "no cull counters: {counters:?}");
        out.push(View { ids, counters });
    }
    ctx.check_errors().unwrap();
    out
}

/// Asserts that every culling mode gave the ids of `none` in each view, and
/// that something was covered.
fn same_ids(name: &str, views: &[View]) {
    for (i, v) in views.iter().enumerate() {
        let covered = v.ids[0].iter().filter(|p| p[0] != 0).count();
        assert!(covered > 0, "{name} view {i}: nothing covered");
        for (k, culling) in Culling::ALL.into_iter().enumerate().skip(1) {
            let differ: Vec<usize> = (0..v.ids[0].len()).filter(|&p| v.ids[k][p] != v.ids[0][p]).collect();
            assert!(
                differ.is_empty(),
                "{name} view {i}: culling {} changes {} of {covered} covered pixels, first at index {}: {:?} against {:?}",
                culling.name(),
                differ.len(),
                differ[0],
                v.ids[k][differ[0]],
                v.ids[0][differ[0]]
            );
        }
        let c = &v.counters;
        eprintln!(
            "{name} view {i}: {covered} pixels covered; clusters tested {}, frustum {}, cone {}, occlusion {}, drawn {} ({} late)",
            c["cull_tested"],
            c["cull_frustum"],
            c["cull_cone"],
            c["cull_occlusion"],
            c["cull_drawn"],
            c["cull_drawn_late"]
        );
    }
}

fn path_cameras(spec: &str, scene: &Scene, choice: path::CameraChoice, frames: &[u32]) -> Vec<Camera> {
    let cameras = path::cameras_for_scene(spec, scene, 16.0 / 9.0).unwrap();
    let path = cameras.select(choice).unwrap();
    frames.iter().map(|&t| path.camera_at(t)).collect()
}

/// The tiny city down its street (frames 0, 2, 4, then a jump to 60) and
/// from above: the same ids in every mode; on the street, once occlusion
/// has a frame of history (the first frame's early pass draws nothing, so
/// the late one draws all it does not cull and the second frame draws all
/// early), most clusters of the objects in view are culled, by the frustum
/// and by occlusion, and after the jump the late pass draws clusters the
/// early one did not.
#[test]
fn culling_keeps_the_ids_and_culls_most_clusters_down_the_city_street() {
    let ctx = common::gpu();
    let mut scene = common::load("city:2");
    // Both faces drawn: the frustum and occlusion alone (the cones below).
    scene.set_back_faces(BackFaces::Draw);
    let street = path_cameras("city:2", &scene, path::CameraChoice::Path, &[0, 2, 4, 60]);
    let views_street = views(&ctx, &scene, &street, (192, 108));
    same_ids("city:2 street", &views_street);
    for v in &views_street[2..] {
        let c = &v.counters;
        assert!(c["cull_frustum"] > 0.0 && c["cull_occlusion"] > 0.0, "{c:?}");
        assert!(c["cull_drawn"] < 0.5 * c["cull_tested"], "most clusters drawn on the street: {c:?}");
        assert_eq!(c["cull_cone"], 0.0, "cones tested though back faces are drawn");
    }
    assert!(views_street[3].counters["cull_drawn_late"] > 0.0, "the jump drew nothing late");
    let above = path_cameras("city:2", &scene, path::CameraChoice::Flyover, &[0, 30]);
    same_ids("city:2 fly-over", &views(&ctx, &scene, &above, (192, 108)));
}

/// With back faces culled, normal cones cull clusters too, and the ids
/// still match the unculled rasterizer's (which culls the faces one by one).
#[test]
fn cone_culling_keeps_the_ids_of_back_face_culling() {
    let ctx = common::gpu();
    let mut scene = common::load("city:2");
    scene.set_back_faces(BackFaces::Cull);
    let cameras = path_cameras("city:2", &scene, path::CameraChoice::Path, &[0, 20]);
    let views = views(&ctx, &scene, &cameras, (192, 108));
    same_ids("city:2 street, back faces culled", &views);
    assert!(views.iter().all(|v| v.counters["cull_cone"] > 0.0), "no cluster culled by its cone");
}

#[test]
fn culling_keeps_the_ids_along_sponzas_path() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let scene = common::load(SPONZA);
    let cameras = path_cameras(SPONZA, &scene, path::CameraChoice::Path, &[0, 10, 120]);
    same_ids("sponza", &views(&ctx, &scene, &cameras, (192, 108)));
}
