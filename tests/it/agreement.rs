//! Every conventional pipeline against single-pass forward (the reference)
//! on the procedural scenes at a small size: they share the scene data and
//! the lighting code, so they must agree within FLIP 0.02, with shadowed
//! lights too (one shadow term in the shared lighting code, one set of shadow
//! maps). (Object space, which filters texel shades, has its own looser
//! bound in `golden.rs`.)

use crate::common;
use shadespace::metrics;
use shadespace::render::{
    ClusteredConfig, DeferredComputeConfig, DeferredConfig, ForwardConfig, ForwardMultipassConfig, PipelineConfig,
    RenderOptions, Renderer, VisibilityMethod,
};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// Mean FLIP allowed between a conventional pipeline and forward.
const AGREEMENT_FLIP: f32 = 0.02;

/// The pipelines under test, each with the settings it is checked in.
fn pipelines() -> Vec<PipelineConfig> {
    vec![
        PipelineConfig::Forward(ForwardConfig { depth_prepass: false }),
        PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig { depth_prepass: false }),
        PipelineConfig::DeferredCompute(DeferredComputeConfig::default()),
        PipelineConfig::DeferredCompute(DeferredComputeConfig { depth_prepass: false, ..Default::default() }),
        PipelineConfig::DeferredCompute(DeferredComputeConfig {
            visibility: VisibilityMethod::Compute,
            ..Default::default()
        }),
    ]
}

/// The light set of the unshadowed checks.
const LIGHTS: &str = "small:24+big:2";
/// Three big shadowed lights (point and spot faces) among small ones.
const SHADOWED_LIGHTS: &str = "shadowed:3+small:8";

/// Renders the frame with `pipeline`; `sun`: the sun casts shadows.
fn render(
    ctx: &shadespace::gpu::GpuContext,
    frame: &common::PathFrame,
    sun: bool,
    pipeline: PipelineConfig,
) -> image::RgbaImage {
    let mut r = Renderer::new(ctx, &frame.scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline }).unwrap();
    r.sun_shadow = sun;
    r.render(ctx, &frame.camera, &frame.lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    image
}

/// Forward's image of `name`'s path frame under `spec`, rendered once for
/// the tests that compare against it.
fn forward_once(ctx: &shadespace::gpu::GpuContext, name: &str, spec: &str, sun: bool) -> image::RgbaImage {
    common::rendered_once(&format!("agreement forward {name} {spec} sun {sun}"), || {
        let frame = common::path_frame(name, spec, WIDTH, HEIGHT);
        render(ctx, &frame, sun, PipelineConfig::Forward(ForwardConfig::default()))
    })
}

fn check(name: &str, spec: &str, sun: bool) {
    let ctx = common::gpu();
    let frame = common::path_frame(name, spec, WIDTH, HEIGHT);
    let reference = forward_once(&ctx, name, spec, sun);
    check_frame(&ctx, name, spec, sun, &frame, &reference);
}

/// Every pipeline of [`pipelines`] against forward's `reference` image of `frame`.
fn check_frame(
    ctx: &shadespace::gpu::GpuContext,
    name: &str,
    spec: &str,
    sun: bool,
    frame: &common::PathFrame,
    reference: &image::RgbaImage,
) {
    let out = common::out_dir();
    for (i, pipeline) in pipelines().into_iter().enumerate() {
        let sun = if sun { "-sun" } else { "" };
        let label = format!("{name}-{spec}{sun}-{i}-{}", pipeline.name());
        let settings = format!("{pipeline:?}");
        let test = render(ctx, frame, !sun.is_empty(), pipeline);
        let (err, map) = metrics::compare(reference, &test);
        eprintln!("{label} ({settings}): against forward: {err:?}");
        if err.flip_mean > AGREEMENT_FLIP {
            test.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!("{label}: FLIP {} > {AGREEMENT_FLIP} against forward; images in {}", err.flip_mean, out.display());
        }
    }
}

#[test]
fn conventional_pipelines_agree_with_forward_atrium() {
    check("atrium", LIGHTS, false);
}

#[test]
fn conventional_pipelines_agree_with_forward_voxels() {
    check("voxels", LIGHTS, false);
}

#[test]
fn conventional_pipelines_agree_with_forward_shadowed_atrium_with_sun() {
    check("atrium", SHADOWED_LIGHTS, true);
}

#[test]
fn conventional_pipelines_agree_with_forward_shadowed_voxels() {
    check("voxels", SHADOWED_LIGHTS, false);
}

/// With back faces culled (`Scene::cull_back_faces`), every pipeline culls
/// the same faces as forward (the compute rasterizer by the sign of the
/// homogeneous determinant, the raster pipelines by their cull mode), and on
/// the closed meshes of the atrium culling changes almost nothing visible
/// (measured: FLIP 0.0008), so the winding is the one the scenes are built with.
#[test]
fn conventional_pipelines_agree_with_forward_with_back_faces_culled() {
    let ctx = common::gpu();
    let both = forward_once(&ctx, "atrium", LIGHTS, false);
    let mut culled = common::path_frame("atrium", LIGHTS, WIDTH, HEIGHT);
    culled.scene.cull_back_faces = true;
    let forward = render(&ctx, &culled, false, PipelineConfig::Forward(ForwardConfig::default()));
    let (err, _) = metrics::compare(&both, &forward);
    eprintln!("atrium, forward, culled against both faces: {err:?}");
    assert!(err.flip_mean < 0.005, "culling back faces changed the atrium: {err:?}");
    check_frame(&ctx, "atrium-culled", LIGHTS, false, &culled, &forward);
}
