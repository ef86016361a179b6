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
/// Mean FLIP allowed between a render and its golden image. The goldens
/// are lavapipe's renders, and lavapipe reproduces them exactly (measured:
/// FLIP 0.0 for both scenes); the bound is an absolute margin for another
/// Mesa build's rasterization (other adapters were not measured). Catches a
/// point light's attenuation 1 / (1 + d) instead of 1 / (1 + d^2) in
/// `lighting.wgsl`, which every pipeline shares, so that no agreement test
/// can see it: atrium 0.0163 (which the former bound of 0.02 let
/// through), voxels 0.321.
const GOLDEN_FLIP: f32 = 0.005;

/// What object space may differ from forward by on one frame at 320x180:
/// mean FLIP at most `flip`, PSNR at least `psnr` dB. Issue 3 asked for
/// FLIP 0.05 and 35 dB; each test's bound is tighter, its value measured
/// on lavapipe plus 25 % of FLIP and less 1 dB of PSNR (26 % more squared
/// error), so that a wrong filter fails it.
#[derive(Clone, Copy, Debug)]
struct Bound {
    flip: f32,
    psnr: f64,
}

/// Measured + 25 % / - 1 dB: atrium 0.0164 / 41.75 dB, with the raster or
/// the compute visibility buffer (the same ids, the same image).
const ATRIUM: Bound = Bound { flip: 0.0205, psnr: 40.75 };
/// Measured + 25 % / - 1 dB: shadowed atrium 0.0173 / 41.27 dB.
const SHADOWED_ATRIUM: Bound = Bound { flip: 0.0216, psnr: 40.27 };
/// Measured + 25 % / - 1 dB: voxels 0.00719 / 56.73 dB (raster visibility)
/// with textures sized for the screen, as `render` sizes them; at the former
/// 256 texels per metre the blocks nearest the camera were shaded coarser
/// than the screen: 0.00763-0.00794 / 53.03-53.31 dB (two runs differed).
/// The atrium's images are the same at either sizing.
const VOXELS: Bound = Bound { flip: 0.0090, psnr: 55.73 };
/// Measured + 25 % / - 1 dB: voxels 0.00738 / 53.85 dB (compute visibility:
/// a few edge pixels see another face than raster's; 0.00805-0.00818 /
/// 51.55-51.59 dB at 256 texels per metre).
const VOXELS_COMPUTE: Bound = Bound { flip: 0.0092, psnr: 52.85 };

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
    let (scene, texture_sizes) = common::charted_for(&scene, &camera, width, height);
    let pipeline = match pipeline {
        Pipeline::Forward => PipelineConfig::Forward(ForwardConfig::default()),
        Pipeline::ObjectSpace(visibility) => {
            PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, visibility, ..Default::default() })
        }
    };
    let options = RenderOptions { width, height, pipeline, samples: 1 };
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

/// Catches the attenuation fault of [`GOLDEN_FLIP`]: 0.0163.
#[test]
fn golden_atrium() {
    check_golden("atrium");
}

/// Catches the attenuation fault of [`GOLDEN_FLIP`]: 0.321.
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

fn check_agreement(name: &str, spec: &str, visibility: VisibilityMethod, bound: Bound) {
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
    assert!(err.flip_mean <= bound.flip && err.psnr_db >= bound.psnr, "{name}: {err:?}, bound {bound:?}");
}

/// Catches the gather's bilinear weights of taps (x+1, y) and (x, y+1)
/// swapped in `gather.wgsl`: 0.0249 / 38.40 dB.
#[test]
fn objectspace_agrees_with_forward_atrium() {
    check_agreement("atrium", LIGHTS, VisibilityMethod::Raster, ATRIUM);
}

/// Catches the gather's island filter dropped (every tap kept, across
/// chart borders; each block face is a chart): 0.0129 / 41.60 dB. The
/// swapped weights stay under the bound here (0.00875 / 52.20 dB: flat
/// faces, neighbouring texels alike); the stage twins catch them.
#[test]
fn objectspace_agrees_with_forward_voxels() {
    check_agreement("voxels", LIGHTS, VisibilityMethod::Raster, VOXELS);
}

/// Catches the swapped gather weights: 0.0249 / 38.40 dB.
#[test]
fn objectspace_with_compute_visibility_agrees_with_forward_atrium() {
    check_agreement("atrium", LIGHTS, VisibilityMethod::Compute, ATRIUM);
}

/// Catches the gather's island filter dropped: 0.0131 / 41.46 dB.
#[test]
fn objectspace_with_compute_visibility_agrees_with_forward_voxels() {
    check_agreement("voxels", LIGHTS, VisibilityMethod::Compute, VOXELS_COMPUTE);
}

/// Object space evaluates the same shadow term per texel. Catches the
/// swapped gather weights: 0.0261 / 37.81 dB.
#[test]
fn objectspace_agrees_with_forward_shadowed_atrium() {
    check_agreement("atrium", "shadowed:3+small:8", VisibilityMethod::Raster, SHADOWED_ATRIUM);
}
