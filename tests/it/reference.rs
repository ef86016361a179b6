//! Supersampled references (`src/reference/`): at one sample they are
//! forward's image; at 4x4 they agree with a forward frame 4 times larger,
//! box-filtered in linear light, far better than one sample does; they are
//! cached by their inputs; `render --reference` refuses what it cannot do.

use crate::common;
use std::process::Command;

use shadespace::gpu::{GpuContext, readback};
use shadespace::reference::{ReferenceCache, ReferenceSettings, ReferenceView, References};
use shadespace::render::{Exposure, ForwardConfig, PipelineConfig, RenderOptions, Renderer, ShadingModel};

fn settings(width: u32, height: u32) -> ReferenceSettings {
    ReferenceSettings { width, height, shading: ShadingModel::Phong, sun_shadow: false, exposure: Exposure::Fixed(1.0) }
}

/// Forward's frame of `f` at `w`x`h`: its linear HDR (RGB) and its image.
fn forward(ctx: &GpuContext, f: &common::PathFrame, w: u32, h: u32) -> (Vec<f32>, image::RgbaImage) {
    let options =
        RenderOptions { width: w, height: h, pipeline: PipelineConfig::Forward(ForwardConfig::default()), samples: 1 };
    let mut r = Renderer::new(ctx, &f.scene, &options).unwrap();
    r.render(ctx, &f.camera, &f.lights, 0).unwrap();
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    let hdr = bytes
        .chunks_exact(8)
        .flat_map(|t| (0..3).map(move |k| half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32()))
        .collect();
    (hdr, r.read_image(ctx).unwrap())
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
    let mut resolved = vec![0.0f32; (w * h * 3) as usize];
    for y in 0..h * n {
        for x in 0..w * n {
            for k in 0..3 {
                let v = big[((y * w * n + x) * 3 + k) as usize];
                resolved[(((y / n) * w + x / n) * 3 + k) as usize] += v / (n * n) as f32;
            }
        }
    }
    let (one, _) = forward(&ctx, &f, w, h);
    let (reference_error, one_sample_error) = (mean_abs(&r.hdr, &resolved), mean_abs(&one, &resolved));
    eprintln!(
        "mean |HDR difference| from the box-filtered 4x frame: 4x4 {reference_error:.5}, 1x1 {one_sample_error:.5}"
    );
    // Texture levels differ (a pixel's footprint against a quarter of it), so
    // not equal; but the sample positions are the same, so much closer than one sample.
    assert!(reference_error < 0.4 * one_sample_error, "{reference_error} against {one_sample_error}");
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
