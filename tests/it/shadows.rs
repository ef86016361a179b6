//! Shadow maps: a quad held above the floor shadows it from a spot light, a
//! point light and the sun, in forward and in object space; cached maps are
//! rendered once for a static scene (the sun's again when the camera moves)
//! and every frame when asked.

use crate::common;
use glam::{Mat4, Vec3};
use shadespace::gpu::GpuContext;
use shadespace::render::{ForwardConfig, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, ShadowRefresh};
use shadespace::scene::{Camera, Light, LightKind, Material, Object, Scene, checker};

const SIZE: u32 = 128;
/// The light, above and behind the occluder as the camera sees it.
const LIGHT: Vec3 = Vec3::new(0.0, 3.0, -1.5);
/// Height of the occluder (a 1 m quad centred above the origin).
const OCCLUDER_Y: f32 = 1.0;
/// The centre of the occluder's shadow on the floor: its penumbra is 0.75 m away.
const IN_SHADOW: Vec3 = Vec3::new(0.0, 0.0, 0.75);
/// Lit by the light, well outside the shadow and within the spot's inner cone.
const IN_LIGHT: Vec3 = Vec3::new(1.5, 0.0, 0.75);

/// The floor scene with a 1 m quad at `OCCLUDER_Y` above the origin.
fn occluder_scene() -> (Scene, Camera) {
    let (mut scene, camera, _) = common::floor_scene();
    let mut quad = common::floor_quad(1.0, OCCLUDER_Y);
    quad.name = "occluder".into();
    scene.meshes.push(quad);
    scene.materials.push(Material { base_color_texture: Some(1), ..Default::default() });
    scene.textures.push(checker::uv_checker("occluder", checker::object_tint(1), 16, 2));
    scene.objects.push(Object {
        name: "occluder".into(),
        mesh: 1,
        material: 1,
        transform: Mat4::IDENTITY,
        forward_only: false,
    });
    (scene, camera)
}

/// An ambient fill and one white light of `kind` at `LIGHT`, casting shadows
/// when `shadows` (a spot aims at the shadow's centre, 40-degree cone; the
/// sun shines the same way, and its shadow is the renderer's `sun_shadow`).
fn lights(kind: LightKind, shadows: bool) -> Vec<Light> {
    let light = Light {
        kind,
        color: Vec3::ONE,
        intensity: if kind == LightKind::Directional { 0.6 } else { 8.0 },
        position: LIGHT,
        direction: (IN_SHADOW - LIGHT).normalize(),
        radius: 8.0,
        cos_inner: 32f32.to_radians().cos(),
        cos_outer: 40f32.to_radians().cos(),
        casts_shadows: shadows,
    };
    vec![Light { kind: LightKind::Ambient, intensity: 0.05, ..light }, light]
}

fn forward() -> PipelineConfig {
    PipelineConfig::Forward(ForwardConfig::default())
}

fn objectspace() -> PipelineConfig {
    PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes: vec![Some(512), Some(128)], ..Default::default() })
}

/// Luminance (0..1) of the pixel that shows world point `p`.
fn luminance_at(image: &image::RgbaImage, camera: &Camera, p: Vec3) -> f32 {
    // Square images: aspect 1.
    let ndc = camera.view_projection(1.0).project_point3(p);
    let x = ((ndc.x * 0.5 + 0.5) * SIZE as f32) as u32;
    let y = ((0.5 - ndc.y * 0.5) * SIZE as f32) as u32;
    let [r, g, b, _] = image.get_pixel(x, y).0;
    (0.2126 * r as f32 + 0.7152 * g as f32 + 0.0722 * b as f32) / 255.0
}

fn render(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    pipeline: PipelineConfig,
    lights: &[Light],
) -> image::RgbaImage {
    let mut r = Renderer::new(ctx, scene, &RenderOptions { width: SIZE, height: SIZE, pipeline, samples: 1 }).unwrap();
    r.sun_shadow = lights.iter().any(|l| l.kind == LightKind::Directional && l.casts_shadows);
    r.render(ctx, camera, lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    image
}

/// In shadow: no brighter than a third of the unshadowed render there (the
/// ambient fill remains). In light: what the unshadowed render shows.
fn check(kind: LightKind, pipeline: PipelineConfig) {
    let ctx = common::gpu();
    let (scene, camera) = occluder_scene();
    let scene = match pipeline {
        PipelineConfig::ObjectSpace(_) => common::charted(&scene).0,
        _ => scene,
    };
    let label = format!("shadow-{kind:?}-{}", pipeline.name());
    let shadowed = render(&ctx, &scene, &camera, pipeline.clone(), &lights(kind, true));
    let unshadowed = render(&ctx, &scene, &camera, pipeline, &lights(kind, false));
    shadowed.save(common::out_dir().join(format!("{label}.png"))).unwrap();
    let at = |image: &image::RgbaImage, p| luminance_at(image, &camera, p);
    let (dark, dark_ref) = (at(&shadowed, IN_SHADOW), at(&unshadowed, IN_SHADOW));
    let (lit, lit_ref) = (at(&shadowed, IN_LIGHT), at(&unshadowed, IN_LIGHT));
    eprintln!("{label}: in shadow {dark:.3} (unshadowed {dark_ref:.3}), in light {lit:.3} (unshadowed {lit_ref:.3})");
    assert!(dark_ref > 0.3, "{label}: the light should reach the shadowed point without shadows");
    assert!(dark < dark_ref / 3.0, "{label}: shadowed point too bright");
    assert!((lit - lit_ref).abs() <= 2.0 / 255.0 && lit > 0.3, "{label}: lit point changed");
}

#[test]
fn spot_light_shadow_forward() {
    check(LightKind::Spot, forward());
}

#[test]
fn point_light_shadow_forward() {
    check(LightKind::Point, forward());
}

#[test]
fn spot_light_shadow_objectspace() {
    check(LightKind::Spot, objectspace());
}

#[test]
fn point_light_shadow_objectspace() {
    check(LightKind::Point, objectspace());
}

#[test]
fn sun_shadow_forward() {
    check(LightKind::Directional, forward());
}

#[test]
fn sun_shadow_objectspace() {
    check(LightKind::Directional, objectspace());
}

/// Per frame of `frames` (the camera moving sideways from frame `move_from`
/// on): how many point-light faces and sun cascades were rendered, from the
/// timing scopes, for a shadowed point light and the sun.
fn faces_rendered(refresh: ShadowRefresh, frames: u64, move_from: u64) -> Vec<(usize, usize)> {
    let ctx = common::gpu();
    let (scene, camera) = occluder_scene();
    let options = RenderOptions { width: 32, height: 32, pipeline: forward(), samples: 1 };
    let mut r = Renderer::new(&ctx, &scene, &options).unwrap();
    assert!(r.timing_enabled(), "the test adapter times passes");
    r.shadow_refresh = refresh;
    r.sun_shadow = true;
    let mut lights = lights(LightKind::Point, true);
    lights.push(Light { kind: LightKind::Directional, intensity: 0.3, ..lights[1] });
    for frame in 0..frames {
        let mut camera = camera;
        camera.position.x += frame.saturating_sub(move_from - 1) as f32 * 0.5;
        r.render(&ctx, &camera, &lights, frame).unwrap();
    }
    let timings = r.collect_timings(&ctx, true);
    assert_eq!(timings.len() as u64, frames);
    let count = |t: &shadespace::gpu::timing::FrameTimings, prefix: &str| {
        t.passes.iter().filter(|(name, _)| name.starts_with(prefix)).count()
    };
    timings.iter().map(|t| (count(t, "shadow maps/face "), count(t, "shadow maps/cascade "))).collect()
}

#[test]
fn static_shadows_render_once_on_change_and_every_frame_when_asked() {
    // Static camera and lights: once; the camera moves at frame 3: only the
    // sun's cascades follow it.
    let on_change = faces_rendered(ShadowRefresh::OnChange, 5, 3);
    assert_eq!(on_change, vec![(6, 4), (0, 0), (0, 0), (0, 4), (0, 4)]);
    assert_eq!(faces_rendered(ShadowRefresh::EveryFrame, 3, 3), vec![(6, 4); 3]);
}

/// The run report carries the shadow maps' memory: six 1024² faces of 4 bytes.
#[test]
fn report_counts_shadow_map_memory() {
    let ctx = common::gpu();
    let (scene, camera) = occluder_scene();
    let options = RenderOptions { width: 32, height: 32, pipeline: forward(), samples: 1 };
    let mut r = Renderer::new(&ctx, &scene, &options).unwrap();
    r.render(&ctx, &camera, &lights(LightKind::Point, true), 0).unwrap();
    let report = r.report();
    assert_eq!(report.memory["shadow_maps"], 6 * 1024 * 1024 * 4 + 4 + 512, "{report:?}");
    assert_eq!(report.setup["shadow_faces"], 6);
}
