//! The quality experiment's error breakdown by pixel class
//! (`experiments::breakdown`): object space's `classify` pass gives every
//! pixel one class, consistent with its visibility buffer and its level
//! rule, and the classes' error and flicker add up to the frames' totals.

use crate::common;

use shadespace::experiments::breakdown::{self, FACTORS, PathSums};
use shadespace::metrics::breakdown::total;
use shadespace::metrics::temporal::path_quality_by;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::objectspace::debug::{Coverage, IslandTaps, ShadeSource};
use shadespace::render::{ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod};
use shadespace::scene::{LightSpec, lights, path};

const SCENE: &str = "atrium";
const SIZE: (u32, u32) = (96, 64);
const SAMPLES: u32 = 4;

/// The atrium at 96x64 with 4 samples, object space shading at 30 Hz of 60
/// (reuse 2, spread: half the tiles are a frame old) with compute
/// visibility (a layer per sample, as the GPU machine runs the quality
/// experiment) against forward as the "reference", path frames 24-26 (the
/// first one warms up). Measured on lavapipe: about 4 s on a loaded machine.
#[test]
fn pixel_classes_cover_every_pixel_and_their_error_adds_up() {
    let ctx = common::gpu();
    let scene = common::load(SCENE);
    let aspect = SIZE.0 as f32 / SIZE.1 as f32;
    let cameras = path::cameras_for_scene(SCENE, &scene, aspect).unwrap().select(path::CameraChoice::Path).unwrap();
    let spec: LightSpec = "small:8".parse().unwrap();
    let lights = lights::build_lights(&spec, &scene.bounds(), &cameras.camera_at(0), aspect, 7).unwrap();
    let options = |pipeline| RenderOptions { width: SIZE.0, height: SIZE.1, pipeline, samples: SAMPLES };
    let (charted, texture_sizes) = common::charted(&scene);
    let config = ObjectSpaceConfig {
        texture_sizes,
        reuse: 2,
        spread_reshading: true,
        visibility: VisibilityMethod::Compute,
        ..Default::default()
    };
    let mut os = Renderer::new(&ctx, &charted, &options(PipelineConfig::ObjectSpace(config))).unwrap();
    let mut forward = Renderer::new(&ctx, &scene, &options(PipelineConfig::Forward(ForwardConfig::default()))).unwrap();
    let (mut images, mut references, mut classes) = (Vec::new(), Vec::new(), Vec::new());
    let pixels = (SIZE.0 * SIZE.1) as usize;
    let n = SAMPLES as usize;
    for (i, f) in (24..27).enumerate() {
        let camera = cameras.camera_at(f);
        os.render(&ctx, &camera, &lights, i as u64).unwrap();
        forward.render(&ctx, &camera, &lights, i as u64).unwrap();
        if i == 0 {
            continue;
        }
        images.push(os.read_image(&ctx).unwrap());
        references.push(forward.read_image(&ctx).unwrap());
        let frame = os.read_pixel_classes(&ctx).unwrap().unwrap();
        assert_eq!(frame.len(), pixels);
        let pipeline = os.pipeline::<ObjectSpace>().unwrap();
        let ids = pipeline.visibility_buffer().read_samples(&ctx).unwrap();
        for (p, c) in frame.iter().enumerate() {
            let samples = &ids[p * n..p * n + n];
            let background = samples.iter().all(|s| s[0] == 0);
            assert_eq!(c.coverage == Coverage::Background, background, "pixel {p}: {c:?}, samples {samples:?}");
            if c.coverage == Coverage::Interior {
                // One chart surface: one object (its triangles may differ).
                assert!(samples.iter().all(|s| s[0] == samples[0][0]), "pixel {p}: {c:?}, samples {samples:?}");
            }
            if c.coverage == Coverage::Edge {
                assert!(samples.iter().any(|s| *s != samples[0]), "pixel {p}: {c:?}, samples {samples:?}");
            }
            if c.coverage == Coverage::Interior && c.source == Some(ShadeSource::Atlas) {
                // The level rule: round(log2(texels per pixel at level 0)),
                // so between the finest and the coarsest level a level
                // holds 0.71 to 1.41 texels per pixel.
                // Levels from the finest the object's slot holds, as the passes count them.
                let object = pipeline.layout.objects[samples[0][0] as usize - 1].as_ref().unwrap();
                let levels = (object.levels.len() - object.first) as u32;
                assert!(c.level < levels, "pixel {p}: {c:?}");
                let t = c.texels_per_pixel;
                assert!(t.is_finite() && t > 0.0, "pixel {p}: {c:?}");
                let minor = c.texels_per_pixel_minor;
                assert!(minor > 0.0 && minor <= t, "pixel {p}: {c:?}");
                if c.level > 0 && c.level + 1 < levels {
                    assert!((0.70..=1.42).contains(&t), "pixel {p}: {c:?}");
                }
            }
        }
        classes.push(frame);
    }
    let atlas = |f: fn(&shadespace::render::objectspace::debug::PixelClass) -> bool| {
        classes.iter().flatten().filter(|c| c.source == Some(ShadeSource::Atlas) && f(c)).count()
    };
    assert!(classes.iter().flatten().any(|c| c.coverage == Coverage::Edge), "4 samples: some edges");
    assert!(atlas(|c| c.age == 0) > 0 && atlas(|c| c.age > 0) > 0, "30 Hz: fresh and reused shades");
    // Chart borders: some pixels' filter taps leave their island, most do not.
    let (inside, border) = (atlas(|c| c.taps == IslandTaps::All), atlas(|c| c.taps == IslandTaps::Some));
    assert!(border > 0 && inside > border, "taps all in the island {inside}, some outside {border}");

    let (q, per_frame) = path_quality_by(&images, &references, |t, flip| {
        let labels = breakdown::labels(&classes[t], &references[t]);
        for (f, l) in labels.iter().enumerate() {
            assert!(l.iter().all(|&k| usize::from(k) < FACTORS[f].classes.len()));
        }
        let mut sums = PathSums::new();
        sums.add_frame(&labels, (&images, &references), t, flip).unwrap();
        sums
    });
    let mut sums = PathSums::new();
    for frame in &per_frame {
        sums.merge(frame);
    }
    for (factor, classes) in FACTORS.iter().zip(&sums.factors) {
        let all = total(classes);
        assert_eq!(all.pixels, 2 * pixels as u64, "{}: every pixel of each frame once", factor.name);
        assert_eq!(all.pair_pixels, pixels as u64, "{}: every pixel of the pair once", factor.name);
        let flip = all.flip / all.pixels as f64;
        assert!(
            (flip - q.flip_mean).abs() <= 1e-4 * q.flip_mean,
            "{}: FLIP {flip} against {}",
            factor.name,
            q.flip_mean
        );
        let flicker = all.flicker / (3 * all.pair_pixels) as f64;
        assert!(
            (flicker - q.flicker.mean).abs() < 1e-9,
            "{}: flicker {flicker} against {}",
            factor.name,
            q.flicker.mean
        );
    }
    // Background is the first class of every factor, with the same pixels.
    let background: Vec<u64> = sums.factors.iter().map(|c| c[0].pixels).collect();
    assert!(background.iter().all(|&b| b == background[0]), "{background:?}");
}
