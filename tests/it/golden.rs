//! Golden images of the procedural scenes (forward pipeline), determinism, and
//! object space against forward on them.
//!
//! Goldens were rendered on lavapipe; other adapters rasterize slightly
//! differently, hence a FLIP threshold rather than exact equality. Set
//! `SHADESPACE_BLESS=1` to (re)write them after an intended change.

use crate::common;
use std::path::PathBuf;

use shadespace::metrics;
use shadespace::render::{ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod};

const WIDTH: u32 = 192;
const HEIGHT: u32 = 108;
/// Mean FLIP allowed between a render and its golden image.
const GOLDEN_FLIP: f32 = 0.02;
/// Object space against forward at 320x180 on lavapipe: FLIP <= 0.05 and
/// PSNR >= 35 dB (issue 3's bound). Measured with conservative triangle maps
/// and filtering within chart islands: atrium 0.0165 / 42.3 dB (shadowed
/// 0.0174 / 41.7), voxels 0.0087 / 52.8 dB; before them the voxels' chart
/// borders (each block face is a chart) brought it to 0.0285 / 33.7 dB.
const AGREEMENT_FLIP: f32 = 0.05;
const AGREEMENT_PSNR: f64 = 35.0;

#[derive(Clone, Copy)]
enum Pipeline {
    Forward,
    ObjectSpace(VisibilityMethod),
}

/// The light set of the goldens (no shadowed lights: the directional light
/// casts none, so shadows leave the goldens as they were).
const LIGHTS: &str = "small:24+big:2";

fn render(ctx: &shadespace::gpu::GpuContext, name: &str, pipeline: Pipeline) -> image::RgbaImage {
    render_at(ctx, name, LIGHTS, pipeline, WIDTH, HEIGHT)
}

fn render_at(
    ctx: &shadespace::gpu::GpuContext,
    name: &str,
    spec: &str,
    pipeline: Pipeline,
    width: u32,
    height: u32,
) -> image::RgbaImage {
    let common::PathFrame { scene, camera, lights } = common::path_frame(name, spec, width, height);
    let (scene, texture_sizes) = common::charted(&scene);
    let pipeline = match pipeline {
        Pipeline::Forward => PipelineConfig::Forward(ForwardConfig::default()),
        Pipeline::ObjectSpace(visibility) => {
            PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, visibility, ..Default::default() })
        }
    };
    let options = RenderOptions { width, height, pipeline };
    let image = render_with(ctx, &scene, &options, &camera, &lights);
    assert_eq!(image.dimensions(), (width, height));
    image
}

fn render_with(
    ctx: &shadespace::gpu::GpuContext,
    scene: &shadespace::scene::Scene,
    options: &RenderOptions,
    camera: &shadespace::scene::Camera,
    lights: &[shadespace::scene::Light],
) -> image::RgbaImage {
    let mut r = Renderer::new(ctx, scene, options).unwrap();
    r.render(ctx, camera, lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    image
}

fn golden_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(format!("{name}.png"))
}

/// Forward's image of `name`'s path frame at `width`x`height` under `spec`,
/// rendered once for all the tests that need it.
fn forward_once(
    ctx: &shadespace::gpu::GpuContext,
    name: &str,
    spec: &str,
    width: u32,
    height: u32,
) -> image::RgbaImage {
    let key = format!("golden forward {name} {spec} {width}x{height}");
    common::rendered_once(&key, || render_at(ctx, name, spec, Pipeline::Forward, width, height))
}

fn check_golden(name: &str) {
    let ctx = common::gpu();
    let actual = forward_once(&ctx, name, LIGHTS, WIDTH, HEIGHT);
    let path = golden_path(name);
    if std::env::var_os("SHADESPACE_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        actual.save(&path).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let golden = image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (render it with SHADESPACE_BLESS=1)", path.display()))
        .to_rgba8();
    let (err, map) = metrics::compare(&golden, &actual);
    eprintln!("{name}: against its golden image: {err:?}");
    if err.flip_mean > GOLDEN_FLIP {
        let out = common::out_dir();
        actual.save(out.join(format!("{name}-actual.png"))).unwrap();
        map.save(out.join(format!("{name}-difference.png"))).unwrap();
        panic!(
            "{name}: mean FLIP {} > {GOLDEN_FLIP} ({err:?}); actual and difference in {}",
            err.flip_mean,
            out.display()
        );
    }
    // Lit geometry, not a blank or one-colour image.
    let lum: Vec<u32> = actual.pixels().map(|p| p[0] as u32 + p[1] as u32 + p[2] as u32).collect();
    assert!(lum.iter().max().unwrap() - lum.iter().min().unwrap() > 150, "{name}: nearly uniform image");
}

#[test]
fn golden_atrium() {
    check_golden("atrium");
}

#[test]
fn golden_voxels() {
    check_golden("voxels");
}

/// A fresh render equals the golden test's render of the same frame (by
/// another renderer, maybe in another thread), bit for bit.
#[test]
fn same_inputs_give_the_same_image() {
    let ctx = common::gpu();
    let a = forward_once(&ctx, "atrium", LIGHTS, WIDTH, HEIGHT);
    let b = render(&ctx, "atrium", Pipeline::Forward);
    assert!(a == b, "two renders of the same frame differ");
}

fn check_agreement(name: &str, spec: &str, visibility: VisibilityMethod) {
    let ctx = common::gpu();
    let reference = forward_once(&ctx, name, spec, 320, 180);
    let test = render_at(&ctx, name, spec, Pipeline::ObjectSpace(visibility), 320, 180);
    let (err, map) = metrics::compare(&reference, &test);
    let out = common::out_dir();
    let vis = visibility.name();
    test.save(out.join(format!("{name}-objectspace-{vis}.png"))).unwrap();
    reference.save(out.join(format!("{name}-forward.png"))).unwrap();
    map.save(out.join(format!("{name}-objectspace-{vis}-flip.png"))).unwrap();
    eprintln!("{name} ({spec}): object space ({vis} visibility) vs forward: {err:?}");
    assert!(err.flip_mean <= AGREEMENT_FLIP && err.psnr_db >= AGREEMENT_PSNR, "{name}: {err:?}");
}

#[test]
fn objectspace_agrees_with_forward_atrium() {
    check_agreement("atrium", LIGHTS, VisibilityMethod::Raster);
}

#[test]
fn objectspace_agrees_with_forward_voxels() {
    check_agreement("voxels", LIGHTS, VisibilityMethod::Raster);
}

#[test]
fn objectspace_with_compute_visibility_agrees_with_forward_atrium() {
    check_agreement("atrium", LIGHTS, VisibilityMethod::Compute);
}

#[test]
fn objectspace_with_compute_visibility_agrees_with_forward_voxels() {
    check_agreement("voxels", LIGHTS, VisibilityMethod::Compute);
}

/// Object space evaluates the same shadow term per texel.
#[test]
fn objectspace_agrees_with_forward_shadowed_atrium() {
    check_agreement("atrium", "shadowed:3+small:8", VisibilityMethod::Raster);
}
