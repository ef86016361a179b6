//! Anisotropic filtering. Object space's anisotropic gathering
//! (`--os-aniso`, issue 24): on a textured floor seen at a grazing angle, the
//! level of isotropic object space follows each pixel's longer footprint
//! axis, so the distant floor is shaded and read far coarser across the view
//! than the pixel needs (blur); with up to 8 taps along that axis the level
//! follows the shorter one, and the distant floor comes closer to the
//! supersampled truth. The conventional pipelines' anisotropic texture
//! filtering (`--aniso`, the material sampler's `anisotropy_clamp`) does the
//! same for their texture samples, where the adapter filters anisotropically.
//!
//! The truth here is forward at 8x8 the size, box-filtered in linear HDR:
//! unlike `render --reference`, whose sub-pixel frames sample textures at
//! the level of a whole pixel's footprint (isotropic, as one sample does),
//! it samples the checker texture at the sub-pixels' own footprints, so it
//! does not share the blur these options remove.

use std::sync::OnceLock;

use crate::common;

use glam::Vec3;
use shadespace::gpu::{GpuContext, readback};
use shadespace::render::{
    DeferredComputeConfig, ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod,
};
use shadespace::scene::{Camera, Light, Scene};

const WIDTH: u32 = 128;
const HEIGHT: u32 = 96;
/// Sub-pixels per pixel side of the truth.
const SUPERSAMPLE: u32 = 8;

/// The renderer's last frame's linear HDR, RGB per pixel, row-major.
fn read_hdr(ctx: &GpuContext, r: &Renderer) -> Vec<Vec3> {
    let bytes = readback::read_texture(ctx, &r.targets.hdr, 8).unwrap();
    bytes
        .chunks_exact(8)
        .map(|t| {
            let c = |k: usize| half::f16::from_le_bytes([t[2 * k], t[2 * k + 1]]).to_f32();
            Vec3::new(c(0), c(1), c(2))
        })
        .collect()
}

/// One frame's linear HDR (as [`read_hdr`]) and its renderer.
fn render_hdr(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    lights: &[Light],
    (width, height): (u32, u32),
    pipeline: PipelineConfig,
) -> (Vec<Vec3>, Renderer) {
    let mut r = Renderer::new(ctx, scene, &RenderOptions::new(width, height, pipeline)).unwrap();
    r.render(ctx, camera, lights, 0).unwrap();
    (read_hdr(ctx, &r), r)
}

/// The floor low and far: the camera 0.8 m above it looking along it, the
/// floor's far edge on the image's middle row.
fn grazing_camera() -> Camera {
    let position = Vec3::new(0.0, 0.8, 4.0);
    Camera {
        position,
        forward: (Vec3::new(0.0, 0.0, -4.0) - position).normalize(),
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 100.0,
    }
}

/// The floor scene's truth from [`grazing_camera`]: forward at
/// [`SUPERSAMPLE`]^2 sub-pixels a pixel, box-filtered (computed once for
/// the tests that compare with it).
fn truth(ctx: &GpuContext, scene: &Scene, lights: &[Light]) -> &'static [Vec3] {
    static TRUTH: OnceLock<Vec<Vec3>> = OnceLock::new();
    TRUTH.get_or_init(|| {
        let big = (WIDTH * SUPERSAMPLE, HEIGHT * SUPERSAMPLE);
        let forward = PipelineConfig::Forward(ForwardConfig::default());
        let (sub, _) = render_hdr(ctx, scene, &grazing_camera(), lights, big, forward);
        let n = SUPERSAMPLE as usize;
        (0..(WIDTH * HEIGHT) as usize)
            .map(|i| {
                let (x, y) = (i % WIDTH as usize, i / WIDTH as usize);
                let sum: Vec3 = (0..n * n).map(|k| sub[(y * n + k / n) * big.0 as usize + x * n + k % n]).sum();
                sum / (n * n) as f32
            })
            .collect()
    })
}

/// The rows of [`grazing_camera`]'s view that see the floor far (its far
/// edge is on the image's middle row) and near.
const FAR: std::ops::Range<u32> = HEIGHT / 2..HEIGHT * 3 / 4;
const NEAR: std::ops::Range<u32> = HEIGHT * 3 / 4..HEIGHT;

/// Mean absolute error per channel against `truth` over the floor's pixels
/// in rows `rows` (background pixels, black in the truth, left out).
fn error(image: &[Vec3], truth: &[Vec3], rows: std::ops::Range<u32>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for y in rows {
        for x in 0..WIDTH {
            let i = (y * WIDTH + x) as usize;
            if truth[i] != Vec3::ZERO {
                sum += f64::from((image[i] - truth[i]).abs().element_sum()) / 3.0;
                n += 1;
            }
        }
    }
    assert!(n > 500, "rows with too few floor pixels ({n})");
    sum / n as f64
}

/// The floor from [`grazing_camera`]: rows 48-71 see it at 6 to 22
/// degrees (footprints 2.7 to 10 times longer than wide), rows 72-95 at 22
/// to 36. Measured on lavapipe, mean absolute error of linear HDR per
/// channel against the 8x8 truth: rows 48-71 0.01038 with aniso 1, 0.00363
/// with aniso 8 (0.35x); rows 72-95 0.00655 and 0.00175; shaded texels 5,440
/// and 27,520 (5.1x). The bound, 0.5x on the far rows, leaves a margin. A
/// gather that filters every tap at the pixel's chart point (the finer
/// level, one point) measured 0.01160 far: worse than aniso 1.
#[test]
fn aniso_8_brings_the_grazing_floor_closer_to_the_supersampled_truth() {
    let ctx = common::gpu();
    let (scene, _, lights) = common::floor_scene();
    let camera = grazing_camera();
    let truth = truth(&ctx, &scene, &lights);
    let objectspace = |aniso| {
        let config = ObjectSpaceConfig { texture_sizes: vec![Some(2048)], aniso, ..Default::default() };
        let pipeline = PipelineConfig::ObjectSpace(config);
        let (hdr, mut r) = render_hdr(&ctx, &scene, &camera, &lights, (WIDTH, HEIGHT), pipeline);
        let counters = r.collect_counters(&ctx, true);
        let (_, named) = counters.last().expect("a frame's counters");
        // Every page the taps need was backed: no pixel fell back to forward.
        assert_eq!(named["pages_failed"], 0.0, "aniso {aniso}: {named:?}");
        (hdr, named["shaded_texels"])
    };
    let ((iso, iso_texels), (aniso, aniso_texels)) = (objectspace(1), objectspace(8));
    let (far, near) = (FAR, NEAR);
    let (far_iso, far_aniso) = (error(&iso, truth, far.clone()), error(&aniso, truth, far));
    let (near_iso, near_aniso) = (error(&iso, truth, near.clone()), error(&aniso, truth, near));
    let message = format!(
        "error against the truth, far floor: aniso 1 {far_iso:.5}, aniso 8 {far_aniso:.5}; near floor: \
         {near_iso:.5}, {near_aniso:.5}; shaded texels {iso_texels} and {aniso_texels}"
    );
    eprintln!("{message}");
    assert!(far_aniso <= 0.5 * far_iso, "aniso 8 should halve the far floor's error or better: {message}");
    // Nearer, the footprints are less long (1.7 to 2.7): better still.
    assert!(near_aniso < near_iso, "{message}");
    // Finer levels along the shorter axis cost texels.
    assert!(aniso_texels > iso_texels, "{message}");
}

/// `--aniso 16` (`Renderer::texture_anisotropy`) in the conventional
/// pipelines, on the floor of [`aniso_8_brings_the_grazing_floor_closer_to_the_supersampled_truth`]:
/// forward (implicit derivatives), deferred-compute's G-buffer (the same)
/// and deferred-compute with compute visibility (each pixel's surface
/// rebuilt from its ids, sampled with the gradients it computes), each
/// renderer drawing the frame with anisotropy 1 and then 16 (sampler state:
/// the same shaders). Where the adapter filters anisotropically the far
/// floor must come closer to the truth; where it does not (wgpu then
/// creates the sampler isotropic, silently) the frames must be the same
/// and raise no validation error. Object space shades texels at explicit
/// levels (isotropic footprints): its frame must not change either way.
#[test]
fn texture_anisotropy_sharpens_the_grazing_floor_in_the_conventional_pipelines() {
    let ctx = common::gpu();
    let (scene, _, lights) = common::floor_scene();
    let camera = grazing_camera();
    let truth = truth(&ctx, &scene, &lights);
    let supported = ctx.has_anisotropic_filtering();
    let compute = DeferredComputeConfig { visibility: VisibilityMethod::Compute, ..Default::default() };
    let objectspace = ObjectSpaceConfig { texture_sizes: vec![Some(2048)], ..Default::default() };
    let pipelines = [
        ("forward", PipelineConfig::Forward(ForwardConfig::default())),
        ("deferred-compute", PipelineConfig::DeferredCompute(DeferredComputeConfig::default())),
        ("deferred-compute, compute visibility", PipelineConfig::DeferredCompute(compute)),
        ("objectspace", PipelineConfig::ObjectSpace(objectspace)),
    ];
    for (name, pipeline) in pipelines {
        let shades_texels = matches!(pipeline, PipelineConfig::ObjectSpace(_));
        // Samples taken in compute with explicit gradients.
        let compute =
            matches!(&pipeline, PipelineConfig::DeferredCompute(c) if c.visibility == VisibilityMethod::Compute);
        let (iso, mut r) = render_hdr(&ctx, &scene, &camera, &lights, (WIDTH, HEIGHT), pipeline);
        r.texture_anisotropy = 16;
        r.render(&ctx, &camera, &lights, 1).unwrap();
        let aniso = read_hdr(&ctx, &r);
        ctx.check_errors().unwrap();
        let (far_iso, far_aniso) = (error(&iso, truth, FAR), error(&aniso, truth, FAR));
        let message = format!(
            "{name} on {}: far floor's error against the truth {far_iso:.5} with --aniso 1, {far_aniso:.5} with 16",
            ctx.info.name
        );
        eprintln!("{message}");
        if shades_texels || !supported {
            let why = if shades_texels { "object space's texels" } else { "no anisotropic filtering" };
            assert!(iso == aniso, "{why}: the frame should not change with --aniso: {message}");
        } else if compute && ctx.info.name.contains("llvmpipe") {
            // llvmpipe (Mesa 22.3) filters anisotropic samples taken with
            // explicit gradients in compute shaders worse than isotropic
            // ones (0.01383 against 0.01013: rows of aliasing; it does not
            // follow the gradients given): only that the sampler reached
            // the pass is checked there.
            assert!(iso != aniso, "the compute pass should sample with the anisotropic sampler: {message}");
        } else {
            assert!(
                far_aniso <= 0.7 * far_iso,
                "--aniso 16 should cut the far floor's error by 30 % or more: {message}"
            );
        }
    }
}
