//! Cluster culling in the hardware raster pipelines (`--culling`,
//! `render::passes::cluster_draws`): forward and deferred give the same
//! image, and object space's raster visibility the same ids, with culling
//! and without, pixel for pixel, along the tiny city's street (with a jump,
//! after which the late pass must draw what became visible) and Sponza's
//! path, with the indexed cluster draws where the adapter has their
//! features (lavapipe has) and, forward on the city, with the list draws;
//! and the counters show most clusters culled down the street.

use crate::common;
use std::path::Path;

use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::passes::cluster_draws::INDEXED_FEATURES;
use shadespace::render::{
    ClusterDraws, Counters, Culling, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod,
};
use shadespace::scene::{self, Camera, Light, Scene, path};

const SPONZA: &str = "../shared/scenes/sponza-thesis";
const SIZE: (u32, u32) = (192, 108);

/// The cameras at `frames` of `spec`'s street path and its lights.
fn path_views(spec: &str, scene: &Scene, frames: &[u32]) -> (Vec<Camera>, Vec<Light>) {
    let cameras = path::cameras_for_scene(spec, scene, SIZE.0 as f32 / SIZE.1 as f32).unwrap();
    let path = cameras.select(path::CameraChoice::Path).unwrap();
    let cameras: Vec<Camera> = frames.iter().map(|&t| path.camera_at(t)).collect();
    let spec = "small:16+big:2".parse().unwrap();
    let lights = scene::lights::build_lights(&spec, &scene.bounds(), &cameras[0], 1.0, 3).unwrap();
    (cameras, lights)
}

/// One view: per culling mode, what `read` read (the image or the ids) and
/// the pixels it covers; the last mode's counters.
struct View {
    frames: Vec<(Vec<u32>, usize)>,
    counters: Counters,
}

/// Per camera, the frame in each of `modes` (`none` first) from one renderer
/// of `pipeline` drawing culled clusters with `draws` (occlusion keeps its
/// history across the cameras, as along a path), read by `read` as
/// (pixels, covered pixels).
fn views(
    ctx: &GpuContext,
    scene: &Scene,
    (pipeline, draws): (PipelineConfig, ClusterDraws),
    (cameras, lights): &(Vec<Camera>, Vec<Light>),
    modes: &[Culling],
    read: impl Fn(&Renderer) -> (Vec<u32>, usize),
) -> Vec<View> {
    let name = pipeline.name();
    let mut renderer = Renderer::new(ctx, scene, &RenderOptions::new(SIZE.0, SIZE.1, pipeline)).unwrap();
    renderer.cluster_draws = draws;
    let mut out = Vec::new();
    for (i, camera) in cameras.iter().enumerate() {
        let mut frames = Vec::new();
        for (k, &culling) in modes.iter().enumerate() {
            renderer.culling = culling;
            renderer.render(ctx, camera, lights, (i * modes.len() + k) as u64).unwrap();
            frames.push(read(&renderer));
        }
        let last = (i * modes.len() + modes.len() - 1) as u64;
        let counters: Counters = renderer
            .collect_counters(ctx, true)
            .into_iter()
            .filter(|(frame, c)| *frame == last && c.contains_key("cull_tested"))
            .flat_map(|(_, c)| c)
            .collect();
        assert!(counters.contains_key("cull_tested"), "{name}: no cull counters: {counters:?}");
        out.push(View { frames, counters });
    }
    // The depth pre-pass and the pass after it draw the lists.
    let setup = renderer.report().setup;
    if let Some(passes) = setup.get("cluster_draw_passes") {
        assert_eq!(*passes, 2, "{name}");
    }
    // The indexed draws wherever the adapter has their features.
    let indexed = draws == ClusterDraws::Indexed && ctx.has(INDEXED_FEATURES);
    assert_eq!(setup["cluster_draws_indexed"], indexed as u64, "{name} {draws:?}");
    ctx.check_errors().unwrap();
    out
}

/// The image as RGBA words, and its lit pixels.
fn image(ctx: &GpuContext) -> impl Fn(&Renderer) -> (Vec<u32>, usize) + '_ {
    |r| {
        let image = r.read_image(ctx).unwrap();
        let lit = image.pixels().filter(|p| p.0[..3].iter().any(|&v| v > 8)).count();
        (image.pixels().map(|p| u32::from_le_bytes(p.0)).collect(), lit)
    }
}

/// Asserts that every mode gave the frame of the first (`none`), which
/// covers some pixels.
fn same_frames(name: &str, modes: &[Culling], views: &[View]) {
    for (i, v) in views.iter().enumerate() {
        let (none, covered) = &v.frames[0];
        assert!(*covered > 1000, "{name} view {i}: {covered} pixels covered");
        for (k, culling) in modes.iter().enumerate().skip(1) {
            let differ = none.iter().zip(&v.frames[k].0).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "{name} view {i}: culling {} changes {differ} of {covered} pixels", culling.name());
        }
        let c = &v.counters;
        eprintln!(
            "{name} view {i}: clusters tested {}, frustum {}, occlusion {}, drawn {} ({} late), indexed draws {:?}",
            c["cull_tested"],
            c["cull_frustum"],
            c["cull_occlusion"],
            c["cull_drawn"],
            c["cull_drawn_late"],
            c.get("cull_draws")
        );
    }
}

/// The tiny city down its street: forward along frames 0, 2, 4 and a jump
/// to 60 in every mode, the same image; once occlusion has two frames of
/// history (the first frame's early pass draws nothing, so the late one
/// draws all it does not cull and the second frame draws all early), most
/// clusters are culled, by the frustum and by occlusion, and after the jump
/// the late pass draws clusters. Deferred, and object space's raster
/// visibility ids, at frames 0, 2 and 60 with and without occlusion (the
/// jump draws late in each).
#[test]
fn raster_culling_keeps_the_image_and_culls_most_clusters_down_the_city_street() {
    let ctx = common::gpu();
    let scene = common::load("city:2");
    let street = path_views("city:2", &scene, &[0, 2, 4, 60]);
    let forward = PipelineConfig::from_name("forward").unwrap();
    let v = views(&ctx, &scene, (forward.clone(), ClusterDraws::Indexed), &street, &Culling::ALL, image(&ctx));
    same_frames("city forward", &Culling::ALL, &v);
    for View { counters: c, .. } in &v[2..] {
        assert!(c["cull_frustum"] > 0.0 && c["cull_occlusion"] > 0.0, "{c:?}");
        assert!(c["cull_drawn"] < 0.5 * c["cull_tested"], "most clusters drawn on the street: {c:?}");
    }
    // Indexed draws: one per run of consecutive clusters kept, so fewer
    // draws than clusters (the first view draws all it keeps late).
    if ctx.has(INDEXED_FEATURES) {
        let (draws, drawn) = (v[0].counters["cull_draws"], v[0].counters["cull_drawn"]);
        assert!(draws > 0.0 && draws < drawn, "{draws} indexed draws of {drawn} clusters");
    }
    assert!(v[3].counters["cull_drawn_late"] > 0.0, "the jump drew nothing late");

    let jump = path_views("city:2", &scene, &[0, 2, 60]);
    let modes = [Culling::None, Culling::Occlusion];
    let v = views(&ctx, &scene, (forward, ClusterDraws::List), &jump, &modes, image(&ctx));
    same_frames("city forward list draws", &modes, &v);
    assert!(v[2].counters["cull_drawn_late"] > 0.0, "list draws: the jump drew nothing late");
    let deferred = PipelineConfig::from_name("deferred").unwrap();
    let v = views(&ctx, &scene, (deferred, ClusterDraws::Indexed), &jump, &modes, image(&ctx));
    same_frames("city deferred", &modes, &v);
    assert!(v[2].counters["cull_drawn_late"] > 0.0, "deferred: the jump drew nothing late");
    // Object space's ids need no atlas: every object but the first is shaded forward.
    let mut texture_sizes = vec![None; scene.objects.len()];
    texture_sizes[0] = Some(64);
    let config = ObjectSpaceConfig { texture_sizes, visibility: VisibilityMethod::Raster, ..Default::default() };
    let ids = |r: &Renderer| {
        let ids = r.pipeline::<ObjectSpace>().unwrap().read_mark_state(&ctx).unwrap().visibility;
        let covered = ids.iter().filter(|p| p[0] != 0).count();
        (ids.into_iter().flatten().collect(), covered)
    };
    let object_space = (PipelineConfig::ObjectSpace(config), ClusterDraws::Indexed);
    let v = views(&ctx, &scene, object_space, &jump, &modes, ids);
    same_frames("city object space raster ids", &modes, &v);
    assert!(v[2].counters["cull_drawn_late"] > 0.0, "object space: the jump drew nothing late");
}

/// Sponza (alpha-masked leaves: the lists are drawn by both pipelines of
/// each pass) along its path with a jump, in forward and deferred, with and
/// without occlusion.
#[test]
fn raster_culling_keeps_the_image_along_sponzas_path() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let scene = common::load(SPONZA);
    let cameras = path_views(SPONZA, &scene, &[0, 120]);
    let modes = [Culling::None, Culling::Occlusion];
    for name in ["forward", "deferred"] {
        let pipeline = PipelineConfig::from_name(name).unwrap();
        let v = views(&ctx, &scene, (pipeline, ClusterDraws::Indexed), &cameras, &modes, image(&ctx));
        same_frames(&format!("sponza {name}"), &modes, &v);
    }
}
