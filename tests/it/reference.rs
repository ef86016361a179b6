//! Supersampled references (`src/reference/`): at one sample they are
//! forward's image; at 4x4 they agree with a forward frame 4 times larger,
//! box-filtered in linear light, far better than one sample does, texture
//! detail included (each sample's textures at its own footprint); they are
//! cached by their inputs; `render --reference` refuses what it cannot do.

use crate::common;
use std::process::Command;

use shadespace::gpu::{GpuContext, readback};
use shadespace::reference::{self, ReferenceCache, ReferenceSettings, ReferenceView, References};
use shadespace::render::{
    DeferredComputeConfig, Exposure, ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer,
    ShadingModel,
};

fn settings(width: u32, height: u32) -> ReferenceSettings {
    ReferenceSettings { width, height, shading: ShadingModel::Phong, sun_shadow: false, exposure: Exposure::Fixed(1.0) }
}

/// Forward's frame of `f` at `w`x`h`: its linear HDR (RGB) and its image.
fn forward(ctx: &GpuContext, f: &common::PathFrame, w: u32, h: u32) -> (Vec<f32>, image::RgbaImage) {
    rendered(ctx, &f.scene, f, PipelineConfig::Forward(ForwardConfig::default()), w, h, 0.0)
}

/// `pipeline`'s frame of `f`'s view of `scene` at `w`x`h` with texture
/// level bias `bias`: its linear HDR (RGB) and its image.
fn rendered(
    ctx: &GpuContext,
    scene: &shadespace::scene::Scene,
    f: &common::PathFrame,
    pipeline: PipelineConfig,
    w: u32,
    h: u32,
    bias: f32,
) -> (Vec<f32>, image::RgbaImage) {
    let options = RenderOptions { width: w, height: h, pipeline, samples: 1 };
    let mut r = Renderer::new(ctx, scene, &options).unwrap();
    r.texture_lod_bias = bias;
    r.render(ctx, &f.camera, &f.lights, 0).unwrap();
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    let hdr = bytes
        .chunks_exact(8)
        .flat_map(|t| (0..3).map(move |k| half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32()))
        .collect();
    (hdr, r.read_image(ctx).unwrap())
}

/// `n` x `n` blocks of a `w * n` x `h * n` linear RGB frame averaged: a
/// `w` x `h` frame with the same sample points as an `n` x `n` reference.
fn box_filtered(big: &[f32], w: u32, h: u32, n: u32) -> Vec<f32> {
    let mut resolved = vec![0.0f32; (w * h * 3) as usize];
    for y in 0..h * n {
        for x in 0..w * n {
            for k in 0..3 {
                let v = big[((y * w * n + x) * 3 + k) as usize];
                resolved[(((y / n) * w + x / n) * 3 + k) as usize] += v / (n * n) as f32;
            }
        }
    }
    resolved
}

/// Forward's `n` x `n` jittered frames averaged with textures sampled at
/// level bias `bias`: the reference's method with another bias (0 was its
/// first method's).
fn jittered_mean(ctx: &GpuContext, f: &common::PathFrame, w: u32, h: u32, n: u32, bias: f32) -> Vec<f32> {
    let options =
        RenderOptions { width: w, height: h, pipeline: PipelineConfig::Forward(ForwardConfig::default()), samples: 1 };
    let mut r = Renderer::new(ctx, &f.scene, &options).unwrap();
    r.texture_lod_bias = bias;
    let mut sum = vec![0.0f32; (w * h * 3) as usize];
    for j in 0..n {
        for i in 0..n {
            r.jitter = glam::Vec2::new(reference::offset(i, n), reference::offset(j, n));
            r.render(ctx, &f.camera, &f.lights, 0).unwrap();
            let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
            for (p, t) in bytes.chunks_exact(8).enumerate() {
                for k in 0..3 {
                    sum[p * 3 + k] += half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32() / (n * n) as f32;
                }
            }
        }
    }
    sum
}

/// Largest absolute difference of two linear RGB images.
fn max_abs(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

/// Mean absolute difference of two linear RGB images.
fn mean_abs(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs())).sum::<f64>() / a.len() as f64
}

#[test]
fn one_sample_is_forwards_image() {
    let ctx = common::gpu();
    let f = common::path_frame("atrium", "small:8", 96, 54);
    let mut refs = References::new(&ctx, &f.scene, settings(96, 54), ReferenceCache::disabled());
    let r = refs.render(&ReferenceView { camera: &f.camera, lights: &f.lights, samples: 1 }).unwrap();
    let (hdr, image) = forward(&ctx, &f, 96, 54);
    assert_eq!(r.hdr, hdr, "one centred sample is forward's HDR frame");
    // The CPU tone map is the GPU's (within a rounding step).
    let worst = image.as_raw().iter().zip(r.image().as_raw()).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    assert!(worst <= 1, "tone-mapped reference differs from forward's image by {worst}");
}

#[test]
fn four_by_four_matches_a_frame_four_times_larger_box_filtered() {
    let ctx = common::gpu();
    let (w, h, n) = (64u32, 36u32, 4u32);
    let f = common::path_frame("atrium", "small:8", w, h);
    let mut refs = References::new(&ctx, &f.scene, settings(w, h), ReferenceCache::disabled());
    let r = refs.render(&ReferenceView { camera: &f.camera, lights: &f.lights, samples: n }).unwrap();
    // Forward at 4x the size, each 4x4 block averaged: the same sample points.
    let (big, _) = forward(&ctx, &f, w * n, h * n);
    let resolved = box_filtered(&big, w, h, n);
    let (one, _) = forward(&ctx, &f, w, h);
    let (reference_error, one_sample_error) = (mean_abs(&r.hdr, &resolved), mean_abs(&one, &resolved));
    eprintln!(
        "mean |HDR difference| from the box-filtered 4x frame: 4x4 {reference_error:.5}, 1x1 {one_sample_error:.5}"
    );
    // The same sample points, textures at the same footprints: much closer
    // than one sample (the bound on texture detail is the next test's).
    assert!(reference_error < 0.4 * one_sample_error, "{reference_error} against {one_sample_error}");
}

/// The atrium with `--textures detailed` (512-texel bricks and grain
/// repeating every metre, seen down to several texels a pixel); `masked`:
/// every material also alpha-masked by its albedo's grain (alpha 1 where a
/// texel is brighter than its texture's mean, cutoff 0.5), so coverage
/// depends on the level the mask is sampled at.
fn detailed_atrium(w: u32, h: u32, masked: bool) -> common::PathFrame {
    let mut f = common::path_frame("atrium", "small:8", w, h);
    let first_detail = f.scene.textures.len();
    shadespace::scene::detail::add_detailed_textures(&mut f.scene);
    if masked {
        for t in &mut f.scene.textures[first_detail + 1..] {
            let luma = |p: &[u8]| u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2]);
            let mean = t.rgba8.chunks_exact(4).map(luma).sum::<u32>() / (t.width * t.height);
            for p in t.rgba8.chunks_exact_mut(4) {
                p[3] = if luma(p) > mean { 255 } else { 0 };
            }
        }
        for m in &mut f.scene.materials {
            m.alpha_cutoff = Some(0.5);
        }
    }
    f
}

/// PSNR of linear RGB `a` against `truth`, with the truth's largest value as
/// the peak.
fn psnr(a: &[f32], truth: &[f32]) -> f64 {
    let mse = a.iter().zip(truth).map(|(x, y)| f64::from(x - y).powi(2)).sum::<f64>() / a.len() as f64;
    let peak = truth.iter().fold(0.0f32, |m, &v| m.max(v));
    10.0 * (f64::from(peak).powi(2) / mse).log10()
}

/// On fine texture detail the reference is the frame N times larger,
/// box-filtered: each sample's textures (albedo, normal map, alpha mask)
/// filtered at its own footprint, a pixel of that frame. The first method
/// (level bias 0: every sample at the whole pixel's footprint) is measurably
/// blurrier, and so further away. Bounds: 2.5x the mean differences and
/// 4 dB under the PSNRs measured on lavapipe (mean |difference| 3.8e-5,
/// 62.1 dB; masked 3.2e-4, 47.5 dB, its cut edges tested per sample at
/// derivatives of 2x2 quads of the small frame's pixels); bias 0 measured
/// 15x and 11x further (49.7 and 32.8 dB).
#[test]
fn textures_are_filtered_at_each_samples_footprint() {
    let ctx = common::gpu();
    let (w, h, n) = (64u32, 36u32, 4u32);
    for (masked, bound, min_db) in [(false, 1e-4, 58.0), (true, 8e-4, 43.5)] {
        let f = detailed_atrium(w, h, masked);
        let mut refs = References::new(&ctx, &f.scene, settings(w, h), ReferenceCache::disabled());
        let r = refs.render(&ReferenceView { camera: &f.camera, lights: &f.lights, samples: n }).unwrap();
        let (big, _) = forward(&ctx, &f, w * n, h * n);
        let truth = box_filtered(&big, w, h, n);
        let old = jittered_mean(&ctx, &f, w, h, n, 0.0);
        let (error, old_error) = (mean_abs(&r.hdr, &truth), mean_abs(&old, &truth));
        let (db, old_db) = (psnr(&r.hdr, &truth), psnr(&old, &truth));
        let (worst, old_worst) = (max_abs(&r.hdr, &truth), max_abs(&old, &truth));
        let mean = truth.iter().map(|&v| f64::from(v)).sum::<f64>() / truth.len() as f64;
        eprintln!(
            "detailed textures{}: {n}x{n} reference against forward at {}x{} box-filtered (mean HDR {mean:.4}): \
             mean |difference| {error:.6}, PSNR {db:.1} dB, max {worst:.5}; \
             bias 0: {old_error:.6}, {old_db:.1} dB, max {old_worst:.5}",
            if masked { ", alpha-masked" } else { "" },
            w * n,
            h * n
        );
        assert!(error < bound, "masked {masked}: the reference is {error} from the box-filtered large frame");
        assert!(db > min_db, "masked {masked}: the reference is {db:.1} dB from the box-filtered large frame");
        assert!(
            old_error > 5.0 * error,
            "masked {masked}: bias 0 ({old_error}) is not measurably further than the reference ({error})"
        );
    }
}

/// The bias means the same in every pipeline: with a bias of -2 each
/// pipeline's frame of the alpha-masked detailed atrium (the bias moves its
/// coverage and its shading) moves to forward's frame at that bias, far
/// from where it was: measured at most 0.023 of forward's shift from it
/// (deferred-compute with compute visibility, whose derivatives are per
/// pixel, not per quad), where deferred with its G-buffer's albedo sampled
/// without the bias stayed 0.25 of it away. Object space samples textures
/// per atlas texel, not per pixel, so it is held only to moving as far.
#[test]
fn the_texture_lod_bias_means_the_same_in_every_pipeline() {
    use shadespace::render::VisibilityMethod;
    let ctx = common::gpu();
    let (w, h, bias) = (64u32, 36u32, -2.0);
    let f = detailed_atrium(w, h, true);
    let (charted, sizes) = common::charted(&f.scene);
    let forward = |b| rendered(&ctx, &charted, &f, PipelineConfig::Forward(ForwardConfig::default()), w, h, b).0;
    let (plain, biased) = (forward(0.0), forward(bias));
    let shift = mean_abs(&plain, &biased);
    let mut pipelines = common::every_pipeline(sizes);
    for p in pipelines.clone() {
        match p {
            PipelineConfig::DeferredCompute(c) => {
                pipelines.push(PipelineConfig::DeferredCompute(DeferredComputeConfig {
                    visibility: VisibilityMethod::Compute,
                    ..c
                }))
            }
            PipelineConfig::ObjectSpace(c) => pipelines
                .push(PipelineConfig::ObjectSpace(ObjectSpaceConfig { visibility: VisibilityMethod::Compute, ..c })),
            _ => {}
        }
    }
    for pipeline in pipelines.into_iter().skip(1) {
        let name = format!("{} {:?}", pipeline.name(), pipeline.visibility());
        let object_space = matches!(pipeline, PipelineConfig::ObjectSpace(_));
        let (p0, _) = rendered(&ctx, &charted, &f, pipeline.clone(), w, h, 0.0);
        let (p2, _) = rendered(&ctx, &charted, &f, pipeline, w, h, bias);
        let (moved, off) = (mean_abs(&p0, &p2), mean_abs(&p2, &biased));
        eprintln!(
            "{name}: bias {bias} moves it {moved:.6} (forward {shift:.6}); \
             {off:.6} from forward's biased frame (unbiased: {:.6})",
            mean_abs(&p0, &plain)
        );
        assert!(moved > 0.8 * shift, "{name}: the bias moves it {moved}, forward {shift}");
        if !object_space {
            assert!(off < 0.1 * shift, "{name}: {off} from forward's biased frame, shift {shift}");
        }
    }
}

#[test]
fn references_are_cached_by_their_inputs() {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().unwrap();
    let f = common::path_frame("atrium", "small:4", 48, 27);
    let mut refs = References::new(&ctx, &f.scene, settings(48, 27), ReferenceCache::in_dir(dir.path()));
    let view = ReferenceView { camera: &f.camera, lights: &f.lights, samples: 2 };
    let (first, cached) = refs.get(&view).unwrap();
    assert!(!cached);
    let (again, cached) = refs.get(&view).unwrap();
    assert!(cached, "the second request is served from the cache");
    assert_eq!(first, again);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // Any input changes the key: samples, camera, lights, the scene's materials.
    let key = refs.key(&view);
    assert_ne!(key, refs.key(&ReferenceView { samples: 3, ..view }));
    let mut moved = f.camera;
    moved.position.x += 0.01;
    assert_ne!(key, refs.key(&ReferenceView { camera: &moved, ..view }));
    assert_ne!(key, refs.key(&ReferenceView { lights: &f.lights[1..], ..view }));
    let mut glossy = f.scene.clone();
    glossy.materials[0].shininess *= 2.0;
    let other = References::new(&ctx, &glossy, settings(48, 27), ReferenceCache::disabled());
    assert_ne!(key, other.key(&view));
}

#[test]
fn render_reference_writes_an_image_and_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ref.png");
    let run = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_shadespace"))
            .args(["render", "--size", "32x18", "--out", out.to_str().unwrap()])
            .args(extra)
            .env("SHADESPACE_CACHE_DIR", dir.path())
            .output()
            .unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert!(!text.contains("panicked"), "{text}");
        (out.status.code(), text)
    };
    let (code, text) = run(&["--reference", "4"]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("rendered"), "{text}");
    assert_eq!(image::open(&out).unwrap().width(), 32);
    let (code, text) = run(&["--reference", "4"]);
    assert_eq!(code, Some(0), "{text}");
    assert!(text.contains("from the cache"), "{text}");
    assert!(dir.path().join("references").is_dir());
    for (args, says) in [
        (&["--reference", "2"][..], "--reference"),
        (&["--reference", "4", "--pipeline", "deferred"][..], "--pipeline"),
        (&["--reference", "4", "--bloom", "0.5"][..], "--bloom"),
    ] {
        let (code, text) = run(args);
        assert_eq!(code, Some(2), "{args:?}: {text}");
        assert!(text.contains(says), "{args:?}: {text}");
    }
}
