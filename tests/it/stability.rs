//! Object space's temporal stability (issue 24 item 4): along consecutive
//! path frames, its flicker against the supersampled reference
//! (`metrics::temporal`) falls when a pixel blends the two levels around its
//! footprint (`--level-blend 1`, trilinear) instead of reading the rounded
//! level alone, whose shade jumps where the level changes, and when the
//! gather filters each level with the cubic B-spline (`--os-filter
//! bspline`) instead of bilinearly.

use crate::common;

use shadespace::metrics::temporal::path_quality;
use shadespace::reference::{ReferenceCache, ReferenceSettings, ReferenceView, References};
use shadespace::render::objectspace::GatherFilter;
use shadespace::render::{
    Exposure, ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, ShadingModel,
};
use shadespace::scene::{self, LightSpec, Scene, lights, path};

const SCENE: &str = "atrium";
const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;
/// Path frames measured (consecutive: the camera moves a little each frame).
const FRAMES: std::ops::Range<u32> = 24..28;

/// Mean flicker of `pipeline` over [`FRAMES`] against `reference`, with one
/// frame rendered before the first measured one.
fn flicker(
    ctx: &shadespace::GpuContext,
    scene: &Scene,
    pipeline: PipelineConfig,
    cameras: &path::CameraPath,
    lights: &[shadespace::Light],
    reference: &[image::RgbaImage],
) -> (f64, f64) {
    let mut r = Renderer::new(ctx, scene, &RenderOptions::new(WIDTH, HEIGHT, pipeline)).unwrap();
    let mut images = Vec::new();
    for (i, f) in (FRAMES.start - 1..FRAMES.end).enumerate() {
        r.render(ctx, &cameras.camera_at(f), lights, i as u64).unwrap();
        if f >= FRAMES.start {
            images.push(r.read_image(ctx).unwrap());
        }
    }
    let q = path_quality(&images, reference);
    (q.flicker.mean, q.flip_mean)
}

/// The atrium with detailed textures at 160x90, path frames 24-27, 8 small
/// lights, Phong. Measured on lavapipe against the reference whose samples
/// filter textures at their own footprints (`reference` METHOD_VERSION 2):
/// flicker (mean 8-bit steps a channel) forward 1.4005, object space 1.4039
/// with the rounded level and 1.3988 with level blend 1: blending takes
/// 0.0052 steps off, more than the 0.0034 object space adds over forward;
/// FLIP 0.03052 and 0.03038 (forward 0.02970). The bound, measured less
/// 25 %: at least 0.0039 steps less. With the B-spline filter (rounded
/// level) 1.3874: 0.0165 steps off, FLIP 0.03116 (2 % more); the bound,
/// measured less 25 %: 0.0124. (Against the first reference, textures at
/// the whole pixel's footprint, object space added 0.0428 steps, blending
/// took 0.0112 off and the B-spline 0.0315.) On lavapipe 18 s idle before
/// the B-spline run was added, 34 s with it on a loaded machine (the 4x4
/// references are most of it).
#[test]
fn level_blending_and_the_bspline_filter_cut_the_flicker_object_space_adds() {
    let ctx = common::gpu();
    let mut scene = common::load(SCENE);
    scene::detail::add_detailed_textures(&mut scene);
    let aspect = WIDTH as f32 / HEIGHT as f32;
    let cameras = path::cameras_for_scene(SCENE, &scene, aspect).unwrap().select(path::CameraChoice::Path).unwrap();
    let spec: LightSpec = "small:8".parse().unwrap();
    let lights = lights::build_lights(&spec, &scene.bounds(), &cameras.camera_at(0), aspect, 7).unwrap();
    let settings = ReferenceSettings {
        width: WIDTH,
        height: HEIGHT,
        shading: ShadingModel::Phong,
        sun_shadow: false,
        exposure: Exposure::default(),
    };
    let mut references = References::new(&ctx, &scene, settings, ReferenceCache::disabled());
    let reference: Vec<image::RgbaImage> = FRAMES
        .map(|f| {
            let camera = cameras.camera_at(f);
            references.render(&ReferenceView { camera: &camera, lights: &lights, samples: 4 }).unwrap().image()
        })
        .collect();
    let forward =
        flicker(&ctx, &scene, PipelineConfig::Forward(ForwardConfig::default()), &cameras, &lights, &reference);
    let (charted, texture_sizes) = common::charted(&scene);
    let objectspace = |level_blend, gather_filter| {
        let config = ObjectSpaceConfig {
            texture_sizes: texture_sizes.clone(),
            level_blend,
            gather_filter,
            ..Default::default()
        };
        flicker(&ctx, &charted, PipelineConfig::ObjectSpace(config), &cameras, &lights, &reference)
    };
    let (nearest, blended) = (objectspace(0.0, GatherFilter::Bilinear), objectspace(1.0, GatherFilter::Bilinear));
    let bspline = objectspace(0.0, GatherFilter::Bspline);
    eprintln!(
        "flicker, FLIP: forward {forward:?}, object space nearest level {nearest:?}, level blend 1 {blended:?}, \
         B-spline filter {bspline:?}"
    );
    assert!(nearest.0 > forward.0, "object space adds no flicker over forward here: nothing to show");
    assert!(
        nearest.0 - blended.0 >= 0.0039,
        "flicker: nearest level {}, level blend 1 {} (forward {}): blending should take at least 0.0039 steps off",
        nearest.0,
        blended.0,
        forward.0
    );
    // Blending does not cost error against the reference.
    assert!(blended.1 <= nearest.1, "FLIP: nearest {}, blended {}", nearest.1, blended.1);
    // The B-spline's blur, which hardly follows the texel grid's phase,
    // takes most of the rest off (bilinear's blur follows it).
    assert!(
        nearest.0 - bspline.0 >= 0.0124,
        "flicker: bilinear {}, B-spline {} (forward {}): the B-spline should take at least 0.0124 steps off",
        nearest.0,
        bspline.0,
        forward.0
    );
    // For a little more error (its blur).
    assert!(bspline.1 <= nearest.1 * 1.05, "FLIP: bilinear {}, B-spline {}", nearest.1, bspline.1);
}
