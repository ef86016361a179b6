//! Cluster culling in the hardware raster pipelines (`--culling`,
//! `render::passes::cluster_draws`): forward and deferred give the same
//! image with culling `none`, `frustum` and `occlusion`, pixel for pixel,
//! along the tiny city's street (with a jump, after which the late pass must
//! draw what became visible) and Sponza's path; and the counters show most
//! clusters culled down the street.

use crate::common;
use std::path::Path;

use shadespace::gpu::GpuContext;
use shadespace::render::{Counters, Culling, PipelineConfig, RenderOptions, Renderer};
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

/// Per camera, the image in each culling mode ([`Culling::ALL`] order) from
/// one renderer of `pipeline` (occlusion keeps its history across the
/// cameras, as along a path), and the occlusion frame's counters.
fn images(
    ctx: &GpuContext,
    scene: &Scene,
    pipeline: &str,
    cameras: &[Camera],
    lights: &[Light],
) -> Vec<(Vec<image::RgbaImage>, Counters)> {
    let config = PipelineConfig::from_name(pipeline).unwrap();
    let mut renderer = Renderer::new(ctx, scene, &RenderOptions::new(SIZE.0, SIZE.1, config)).unwrap();
    let mut out = Vec::new();
    for (i, camera) in cameras.iter().enumerate() {
        let mut images = Vec::new();
        for (k, culling) in Culling::ALL.into_iter().enumerate() {
            renderer.culling = culling;
            renderer.render(ctx, camera, lights, (i * Culling::ALL.len() + k) as u64).unwrap();
            images.push(renderer.read_image(ctx).unwrap());
        }
        let occlusion_frame = (i * Culling::ALL.len() + 2) as u64;
        let counters: Counters = renderer
            .collect_counters(ctx, true)
            .into_iter()
            .filter(|(frame, _)| *frame == occlusion_frame)
            .flat_map(|(_, c)| c)
            .collect();
        assert!(counters.contains_key("cull_tested"), "{pipeline}: no cull counters: {counters:?}");
        // The pre-pass and the shading (or G-buffer) pass draw the lists.
        assert_eq!(renderer.report().setup["cluster_draw_passes"], 2, "{pipeline}");
        out.push((images, counters));
    }
    ctx.check_errors().unwrap();
    out
}

/// Asserts that every culling mode gave the image of `none`, which is lit.
fn same_images(name: &str, views: &[(Vec<image::RgbaImage>, Counters)]) {
    for (i, (images, c)) in views.iter().enumerate() {
        let lit = images[0].pixels().filter(|p| p.0[..3].iter().any(|&v| v > 8)).count();
        assert!(lit > 1000, "{name} view {i}: {lit} pixels lit");
        for (k, culling) in Culling::ALL.into_iter().enumerate().skip(1) {
            let differ = images[0].pixels().zip(images[k].pixels()).filter(|(a, b)| a != b).count();
            if differ > 0 {
                let dir = common::out_dir();
                images[0].save(dir.join(format!("hwcull-{name}-{i}-none.png"))).unwrap();
                images[k].save(dir.join(format!("hwcull-{name}-{i}-{}.png", culling.name()))).unwrap();
            }
            assert_eq!(differ, 0, "{name} view {i}: culling {} changes {differ} of {lit} lit pixels", culling.name());
        }
        eprintln!(
            "{name} view {i}: clusters tested {}, frustum {}, occlusion {}, drawn {} ({} late)",
            c["cull_tested"], c["cull_frustum"], c["cull_occlusion"], c["cull_drawn"], c["cull_drawn_late"]
        );
    }
}

/// The tiny city down its street (frames 0, 2, 4, then a jump to 60), in
/// forward and deferred: the same image in every mode; once occlusion has
/// two frames of history (the first frame's early pass draws nothing, so
/// the late one draws all it does not cull and the second frame draws all
/// early), most clusters are culled, by the frustum and by occlusion, and
/// after the jump the late pass draws clusters.
#[test]
fn raster_culling_keeps_the_image_and_culls_most_clusters_down_the_city_street() {
    let ctx = common::gpu();
    let scene = scene::load("city:2").unwrap();
    let (cameras, lights) = path_views("city:2", &scene, &[0, 2, 4, 60]);
    for pipeline in ["forward", "deferred"] {
        let views = images(&ctx, &scene, pipeline, &cameras, &lights);
        same_images(&format!("city-{pipeline}"), &views);
        for (_, c) in &views[2..] {
            assert!(c["cull_frustum"] > 0.0 && c["cull_occlusion"] > 0.0, "{pipeline}: {c:?}");
            assert!(c["cull_drawn"] < 0.5 * c["cull_tested"], "{pipeline}: most clusters drawn on the street: {c:?}");
        }
        assert!(views[3].1["cull_drawn_late"] > 0.0, "{pipeline}: the jump drew nothing late");
    }
}

/// Sponza (alpha-masked leaves: the lists are drawn by both pipelines of
/// each pass) along its path with a jump, in forward and deferred.
#[test]
fn raster_culling_keeps_the_image_along_sponzas_path() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let scene = scene::load(SPONZA).unwrap();
    let (cameras, lights) = path_views(SPONZA, &scene, &[0, 120]);
    for pipeline in ["forward", "deferred"] {
        same_images(&format!("sponza-{pipeline}"), &images(&ctx, &scene, pipeline, &cameras, &lights));
    }
}
