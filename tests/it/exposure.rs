//! Automatic exposure: the GPU's log-average matches a CPU computation over
//! the read-back HDR frame, and a scene lit a thousand times too dimly or
//! too brightly comes out with its log-average luminance at mid-grey.

use crate::common;
use shadespace::gpu::{GpuContext, readback};
use shadespace::render::passes::exposure::KEY;
use shadespace::render::{Exposure, ForwardConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::{Camera, Light, Scene};

const SIZE: u32 = 96;
/// Largest allowed |log2(measured log-average / KEY)| in the tone-mapped
/// image, a tenth of a stop: 8-bit quantisation, undone through the tone
/// curve, moves it by less than 0.01 stops on these scenes.
const STOPS: f32 = 0.1;

/// Renders `scene` from `camera` at SIZE x SIZE with `exposure`.
fn render(ctx: &GpuContext, scene: &Scene, camera: &Camera, lights: &[Light], exposure: Exposure) -> Renderer {
    let options = RenderOptions {
        width: SIZE,
        height: SIZE,
        pipeline: PipelineConfig::Forward(ForwardConfig::default()),
        samples: 1,
    };
    let mut r = Renderer::new(ctx, scene, &options).unwrap();
    r.exposure = exposure;
    r.render(ctx, camera, lights, 0).unwrap();
    ctx.check_errors().unwrap();
    r
}

fn scaled(lights: &[Light], scale: f32) -> Vec<Light> {
    lights.iter().map(|l| Light { intensity: l.intensity * scale, ..*l }).collect()
}

fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The exposure the pass should find: over the HDR pixels brighter than
/// 2^-24, KEY / 2^(mean log2 luminance), as the shader computes it.
fn cpu_exposure(ctx: &GpuContext, r: &Renderer) -> f32 {
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    let texels: &[half::f16] = bytemuck::cast_slice(&bytes);
    let (mut sum, mut n) = (0.0f64, 0u32);
    for t in texels.chunks_exact(4) {
        let lum = luminance([t[0].to_f32(), t[1].to_f32(), t[2].to_f32()]).min(65504.0);
        if lum > 2f32.powi(-24) {
            sum += lum.log2() as f64;
            n += 1;
        }
    }
    if n == 0 { 1.0 } else { KEY / (sum / n as f64).exp2() as f32 }
}

/// The log-average luminance of the lit pixels of the tone-mapped image,
/// undoing the sRGB encoding and Reinhard's curve: what the exposure made of
/// the frame.
fn exposed_log_average(image: &image::RgbaImage) -> f32 {
    let decode = |c: u8| {
        let v = c as f32 / 255.0;
        let linear = if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) };
        let mapped = linear.min(0.998);
        mapped / (1.0 - mapped)
    };
    let logs: Vec<f32> = image
        .pixels()
        .filter(|p| p.0[..3].iter().any(|&c| c > 0))
        .map(|p| luminance([decode(p.0[0]), decode(p.0[1]), decode(p.0[2])]).log2())
        .collect();
    (logs.iter().sum::<f32>() / logs.len() as f32).exp2()
}

#[test]
fn gpu_log_average_matches_the_cpu() {
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    for scale in [1e-3, 1.0, 1e3] {
        let r = render(&ctx, &scene, &camera, &scaled(&lights, scale), Exposure::Auto);
        let (gpu, cpu) = (r.read_exposure(&ctx).unwrap(), cpu_exposure(&ctx, &r));
        eprintln!("lights x{scale}: exposure {gpu} (CPU {cpu})");
        assert!((gpu / cpu - 1.0).abs() < 1e-3, "lights x{scale}: GPU exposure {gpu}, CPU {cpu}");
    }
    // A fixed exposure is what it says; no light at all leaves the frame alone.
    let r = render(&ctx, &scene, &camera, &lights, Exposure::Fixed(2.5));
    assert_eq!(r.read_exposure(&ctx).unwrap(), 2.5);
    let r = render(&ctx, &scene, &camera, &[], Exposure::Auto);
    assert_eq!(r.read_exposure(&ctx).unwrap(), 1.0);
}

#[test]
fn dark_and_bright_scenes_come_out_mid_grey() {
    let ctx = common::gpu();
    let (scene, camera, lights) = common::floor_scene();
    for scale in [1e-3, 1e3] {
        let lights = scaled(&lights, scale);
        let fixed = render(&ctx, &scene, &camera, &lights, Exposure::Fixed(1.0)).read_image(&ctx).unwrap();
        let auto = render(&ctx, &scene, &camera, &lights, Exposure::Auto).read_image(&ctx).unwrap();
        auto.save(common::out_dir().join(format!("auto-exposure-x{scale}.png"))).unwrap();
        let (before, after) = (exposed_log_average(&fixed), exposed_log_average(&auto));
        eprintln!("lights x{scale}: log-average {before:.4} with exposure 1, {after:.4} with auto");
        assert!((before / KEY).log2().abs() > 3.0, "lights x{scale}: not a dark or bright scene ({before})");
        assert!((after / KEY).log2().abs() < STOPS, "lights x{scale}: log-average {after}, not {KEY}");
    }
}

/// `--exposure auto` on the command line: a 5 cm model comes out at
/// mid-grey, and the exposure found is printed; a bad value names the flag.
#[test]
fn auto_exposure_from_the_command_line() {
    use common::gltf::{Placement, teapot, write_gltf};
    let dir = tempfile::tempdir().unwrap();
    let placement = Placement { scale: 0.015, ..Default::default() };
    let scene = write_gltf(dir.path(), "tiny", &teapot(), &placement);
    let out = dir.path().join("auto.png");
    let run = |exposure: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_shadespace"))
            .args(["render", "--scene", scene.to_str().unwrap(), "--size", "160x90", "--exposure", exposure])
            .args(["--out", out.to_str().unwrap()])
            .output()
            .unwrap()
    };
    let result = run("auto");
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    assert!(stdout.contains("exposure auto:"), "{stdout}");
    let average = exposed_log_average(&image::open(&out).unwrap().to_rgba8());
    eprintln!("tiny model, --exposure auto: log-average {average:.4}");
    assert!((average / KEY).log2().abs() < STOPS, "log-average {average}");
    let result = run("bright");
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--exposure") && stderr.contains("auto or a positive finite number"), "{stderr}");
}
