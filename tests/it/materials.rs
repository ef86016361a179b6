//! Normal maps and the GGX metallic-roughness model in every pipeline: on
//! the atrium with detailed textures (`--textures detailed`: high-frequency
//! albedo and a normal map on every surface) each pipeline agrees with
//! forward within FLIP 0.02, in both lighting models; the normal map and the
//! model visibly change the image (so the agreement is not that of two
//! images that ignore them); and object space reports how many of its pixels
//! are under-shaded.

use crate::common;
use shadespace::metrics;
use shadespace::render::{
    ClusteredConfig, DeferredComputeConfig, DeferredConfig, ForwardConfig, ForwardMultipassConfig, ObjectSpaceConfig,
    PipelineConfig, RenderOptions, Renderer, ShadingModel,
};
use shadespace::scene::detail::add_detailed_textures;

const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// Mean FLIP allowed against forward (as `agreement.rs` and the issue ask).
const AGREEMENT_FLIP: f32 = 0.02;
const LIGHTS: &str = "small:24+big:2";

fn detailed_frame() -> common::PathFrame {
    let mut frame = common::path_frame("atrium", LIGHTS, WIDTH, HEIGHT);
    add_detailed_textures(&mut frame.scene);
    frame
}

fn render(
    ctx: &shadespace::gpu::GpuContext,
    scene: &shadespace::scene::Scene,
    frame: &common::PathFrame,
    shading: ShadingModel,
    pipeline: PipelineConfig,
) -> (image::RgbaImage, Renderer) {
    let mut r =
        Renderer::new(ctx, scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap();
    r.shading = shading;
    r.render(ctx, &frame.camera, &frame.lights, 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    (image, r)
}

fn pipelines(texture_sizes: Vec<Option<u32>>) -> Vec<PipelineConfig> {
    vec![
        PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig::default()),
        PipelineConfig::DeferredCompute(DeferredComputeConfig::default()),
        PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, ..Default::default() }),
    ]
}

fn check_model(shading: ShadingModel) {
    let ctx = common::gpu();
    let frame = detailed_frame();
    let (charted, sizes) = common::charted(&frame.scene);
    let forward = PipelineConfig::Forward(ForwardConfig::default());
    let (reference, _) = render(&ctx, &frame.scene, &frame, shading, forward);
    let out = common::out_dir();
    for pipeline in pipelines(sizes) {
        let label = format!("detailed-{shading:?}-{}", pipeline.name());
        let scene = if matches!(pipeline, PipelineConfig::ObjectSpace(_)) { &charted } else { &frame.scene };
        let (test, _) = render(&ctx, scene, &frame, shading, pipeline);
        let (err, map) = metrics::compare(&reference, &test);
        eprintln!("{label}: against forward: {err:?}");
        if err.flip_mean > AGREEMENT_FLIP {
            test.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!("{label}: FLIP {} > {AGREEMENT_FLIP} against forward; images in {}", err.flip_mean, out.display());
        }
    }
}

#[test]
fn normal_mapped_phong_agrees_across_pipelines() {
    check_model(ShadingModel::Phong);
}

#[test]
fn normal_mapped_pbr_agrees_across_pipelines() {
    check_model(ShadingModel::Pbr);
}

/// The normal map, metals and the GGX model each change forward's image
/// (measured at 320x180: the map on against off FLIP 0.013 / 41.6 dB, where
/// pipelines agree to 0.003 / 64 dB), so that the agreement above is not
/// that of images ignoring them.
#[test]
fn normal_maps_and_the_lighting_model_change_the_image() {
    let ctx = common::gpu();
    let frame = detailed_frame();
    let forward = || PipelineConfig::Forward(ForwardConfig::default());
    let (mapped, _) = render(&ctx, &frame.scene, &frame, ShadingModel::Phong, forward());
    let mut flat = frame.scene.clone();
    flat.materials.iter_mut().for_each(|m| m.normal_texture = None);
    let (unmapped, _) = render(&ctx, &flat, &frame, ShadingModel::Phong, forward());
    let (no_map, _) = metrics::compare(&mapped, &unmapped);
    eprintln!("normal map on against off: {no_map:?}");
    assert!(no_map.flip_mean > 0.005 && no_map.psnr_db < 50.0, "the normal map barely changes the image: {no_map:?}");
    let mut metal = frame.scene.clone();
    metal.materials.iter_mut().for_each(|m| (m.metallic, m.roughness) = (1.0, 0.3));
    let (pbr_metal, _) = render(&ctx, &metal, &frame, ShadingModel::Pbr, forward());
    let (phong_metal, _) = render(&ctx, &metal, &frame, ShadingModel::Phong, forward());
    let (model, _) = metrics::compare(&pbr_metal, &phong_metal);
    eprintln!("GGX metals against Phong: {model:?}");
    assert!(model.flip_mean > 2.0 * AGREEMENT_FLIP, "GGX metals look like Phong: {model:?}");
}

/// The under-shading share: a pixel is under-shaded when its level holds
/// fewer than one shading texel per pixel. Sharpening by two levels (mip
/// bias -2: two texels per pixel or more, where the texture is large
/// enough) leaves almost none; coarsening by two levels makes most of them so
/// (not all: pixels already at an object's coarsest level stay there).
#[test]
fn object_space_reports_its_under_shaded_pixels() {
    let ctx = common::gpu();
    let frame = detailed_frame();
    let (charted, sizes) = common::charted(&frame.scene);
    let share = |mip_bias: f32| {
        let config = ObjectSpaceConfig { texture_sizes: sizes.clone(), mip_bias, ..Default::default() };
        let (_, mut r) = render(&ctx, &charted, &frame, ShadingModel::Phong, PipelineConfig::ObjectSpace(config));
        let counters = r.collect_counters(&ctx, true);
        let (_, named) = counters.last().expect("a frame's counters");
        named["under_shaded_share"]
    };
    let (sharp, default, coarse) = (share(-2.0), share(0.0), share(2.0));
    eprintln!("under-shaded share: bias -2 {sharp:.3}, 0 {default:.3}, +2 {coarse:.3}");
    assert!(sharp < 0.05, "bias -2 leaves {sharp} under-shaded");
    assert!(coarse > 0.7, "bias +2 leaves only {coarse} under-shaded");
    assert!(sharp < default && default < coarse);
}

/// Material textures (glTF 2.0's emissive, metallic-roughness and occlusion
/// textures): a floor written as a glTF file by the test, seen from straight
/// above, whose textures each have two clearly different halves: one white
/// (the texture leaves the factor as it is) and one not. Emissive: black
/// where x < 0 (the left half of the image); metallic-roughness (packed
/// with occlusion into one image, as exporters do): a smooth dielectric
/// (blue 0, green 64) where z < 0 (the top half), against metallic 1 and
/// roughness 0.9 from the factors; occlusion (red): 64 where x < 0.
mod textured_floor {
    use std::path::{Path, PathBuf};

    use glam::{Vec2, Vec3};
    use image::{Rgba, RgbaImage};
    use serde_json::json;
    use shadespace::scene::{Camera, Light, LightKind, Scene};

    pub const WIDTH: u32 = 320;
    pub const HEIGHT: u32 = 180;
    /// The floor's side (metres) and the camera's height above it.
    const SIDE: f32 = 8.0;
    const EYE_HEIGHT: f32 = 3.5;
    const TEXELS: u32 = 64;
    pub const EMISSIVE_FACTOR: Vec3 = Vec3::new(0.5, 0.25, 0.1);
    pub const EMISSIVE_STRENGTH: f32 = 2.0;
    pub const OCCLUSION_STRENGTH: f32 = 0.8;

    /// Writes the floor as `dir/floor.gltf` (with its buffer and two PNG
    /// textures) and returns the path.
    pub fn write(dir: &Path) -> PathBuf {
        let half = TEXELS / 2;
        let emissive =
            RgbaImage::from_fn(TEXELS, TEXELS, |x, _| Rgba(if x < half { [0, 0, 0, 255] } else { [255; 4] }));
        let orm = RgbaImage::from_fn(TEXELS, TEXELS, |x, y| {
            let occlusion = if x < half { 64 } else { 255 };
            let (roughness, metallic) = if y < half { (64, 0) } else { (255, 255) };
            Rgba([occlusion, roughness, metallic, 255])
        });
        let material = json!({
            "name": "floor",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.9,
                "metallicRoughnessTexture": { "index": 1 } },
            "emissiveFactor": EMISSIVE_FACTOR.to_array(),
            "emissiveTexture": { "index": 0 },
            "occlusionTexture": { "index": 1, "strength": OCCLUSION_STRENGTH },
            "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": EMISSIVE_STRENGTH } }
        });
        write_with(dir, &[("emissive.png", emissive), ("orm.png", orm)], material, "KHR_materials_emissive_strength")
    }

    /// Writes the floor (UV0 from (0, 0) at its -x, -z corner to (1, 1)) as
    /// `dir/floor.gltf` with textures `images` (texture K is image K) and
    /// `material`, and returns the path.
    pub fn write_with(
        dir: &Path,
        images: &[(&str, RgbaImage)],
        material: serde_json::Value,
        extension: &str,
    ) -> PathBuf {
        for (name, image) in images {
            image.save(dir.join(name)).unwrap();
        }
        let h = SIDE / 2.0;
        let corners = [Vec2::new(-h, -h), Vec2::new(h, -h), Vec2::new(h, h), Vec2::new(-h, h)];
        let mut bin: Vec<u8> = Vec::new();
        let mut floats = |v: &[f32]| bin.extend(v.iter().flat_map(|f| f.to_le_bytes()));
        floats(&corners.iter().flat_map(|c| [c.x, 0.0, c.y]).collect::<Vec<_>>());
        floats(&corners.iter().flat_map(|_| [0.0, 1.0, 0.0]).collect::<Vec<_>>());
        floats(&corners.iter().flat_map(|c| [(c.x + h) / SIDE, (c.y + h) / SIDE]).collect::<Vec<_>>());
        bin.extend([0u32, 2, 1, 0, 3, 2].iter().flat_map(|i| i.to_le_bytes()));
        std::fs::write(dir.join("floor.bin"), &bin).unwrap();
        let doc = json!({
            "asset": { "version": "2.0" },
            "extensionsUsed": [extension],
            "buffers": [{ "byteLength": bin.len(), "uri": "floor.bin" }],
            "bufferViews": [
                { "buffer": 0, "byteOffset": 0, "byteLength": 48 },
                { "buffer": 0, "byteOffset": 48, "byteLength": 48 },
                { "buffer": 0, "byteOffset": 96, "byteLength": 32 },
                { "buffer": 0, "byteOffset": 128, "byteLength": 24 }
            ],
            "accessors": [
                { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                  "min": [-h, 0.0, -h], "max": [h, 0.0, h] },
                { "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3" },
                { "bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2" },
                { "bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR" }
            ],
            "images": images.iter().map(|(name, _)| json!({ "uri": name })).collect::<Vec<_>>(),
            "textures": (0..images.len()).map(|k| json!({ "source": k })).collect::<Vec<_>>(),
            "materials": [material],
            "meshes": [{ "name": "floor", "primitives": [{
                "attributes": { "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 }, "indices": 3, "material": 0 }] }],
            "nodes": [{ "name": "floor", "mesh": 0 }],
            "scenes": [{ "nodes": [0] }],
            "scene": 0
        });
        let path = dir.join("floor.gltf");
        std::fs::write(&path, serde_json::to_vec_pretty(&doc).unwrap()).unwrap();
        path
    }

    /// Straight down onto the floor's centre, +x to the right, -z up.
    pub fn camera() -> Camera {
        Camera {
            position: Vec3::new(0.0, EYE_HEIGHT, 0.0),
            forward: Vec3::NEG_Y,
            up: Vec3::NEG_Z,
            fov_y: 60f32.to_radians(),
            near: 0.1,
            far: 20.0,
        }
    }

    /// Ambient (so that occlusion shows), a dim sun and four coloured point
    /// lights, one over each quarter.
    pub fn lights() -> Vec<Light> {
        let light = |kind, color: Vec3, intensity, position| Light {
            kind,
            color,
            intensity,
            position,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            radius: 4.0,
            cos_inner: 0.9,
            cos_outer: 0.8,
            casts_shadows: false,
        };
        let mut lights = vec![
            light(LightKind::Ambient, Vec3::ONE, 0.3, Vec3::ZERO),
            light(LightKind::Directional, Vec3::ONE, 0.2, Vec3::ZERO),
        ];
        for (k, (x, z)) in [(-2.0, -1.2), (2.0, -1.2), (-2.0, 1.2), (2.0, 1.2)].into_iter().enumerate() {
            let color = [Vec3::new(1.0, 0.8, 0.6), Vec3::new(0.6, 0.8, 1.0), Vec3::ONE, Vec3::new(0.9, 1.0, 0.7)][k];
            lights.push(light(LightKind::Point, color, 1.5, Vec3::new(x, 1.0, z)));
        }
        lights
    }

    /// The floor's UV0 seen at the centre of pixel (`x`, `y`).
    pub fn uv_at(x: u32, y: u32) -> Vec2 {
        let t = (camera().fov_y / 2.0).tan();
        let ndc = Vec2::new((x as f32 + 0.5) / WIDTH as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / HEIGHT as f32 * 2.0);
        let world = Vec2::new(ndc.x * t * WIDTH as f32 / HEIGHT as f32, -ndc.y * t) * EYE_HEIGHT;
        (world + SIDE / 2.0) / SIDE
    }

    /// One of the three textures, the scene without it, and the halves of
    /// the image where it is not white (it changes the image) and white (it
    /// does not), each a band of pixels clear of the seam between them.
    #[derive(Clone, Copy, Debug)]
    pub enum Slot {
        Emissive,
        MetallicRoughness,
        Occlusion,
    }

    impl Slot {
        pub const ALL: [Slot; 3] = [Slot::Emissive, Slot::MetallicRoughness, Slot::Occlusion];

        pub fn without(self, scene: &Scene) -> Scene {
            let mut s = scene.clone();
            for m in &mut s.materials {
                match self {
                    Slot::Emissive => m.emissive_texture = None,
                    Slot::MetallicRoughness => m.metallic_roughness_texture = None,
                    Slot::Occlusion => m.occlusion_texture = None,
                }
            }
            s
        }

        /// Whether the pixel's UV lies in the texture's non-white half
        /// (`Some(true)`), its white half (`Some(false)`), or near the seam.
        pub fn textured(self, uv: Vec2) -> Option<bool> {
            let c = match self {
                Slot::Emissive | Slot::Occlusion => uv.x,
                Slot::MetallicRoughness => uv.y,
            };
            if (c - 0.5).abs() < 0.05 { None } else { Some(c < 0.5) }
        }
    }

    /// Mean absolute difference (8-bit units, over RGB) between `a` and `b`
    /// over the pixels of `slot`'s non-white half (`textured`) or white half.
    pub fn half_difference(a: &RgbaImage, b: &RgbaImage, slot: Slot, textured: bool) -> f64 {
        difference_where(a, b, |uv| slot.textured(uv) == Some(textured))
    }

    /// Mean absolute difference (8-bit units, over RGB) between `a` and `b`
    /// over the pixels whose floor UV passes `keep` (more than 1,000 of them).
    pub fn difference_where(a: &RgbaImage, b: &RgbaImage, keep: impl Fn(Vec2) -> bool) -> f64 {
        let (mut sum, mut n) = (0.0, 0usize);
        for (x, y, p) in a.enumerate_pixels() {
            if keep(uv_at(x, y)) {
                let q = b.get_pixel(x, y);
                sum += (0..3).map(|c| (p[c] as f64 - q[c] as f64).abs()).sum::<f64>() / 3.0;
                n += 1;
            }
        }
        assert!(n > 1000, "only {n} pixels where the floor's UV passes");
        sum / n as f64
    }
}

fn render_floor(
    ctx: &shadespace::gpu::GpuContext,
    scene: &shadespace::scene::Scene,
    shading: ShadingModel,
    pipeline: PipelineConfig,
) -> image::RgbaImage {
    use textured_floor::{HEIGHT, WIDTH, camera, lights};
    let mut r =
        Renderer::new(ctx, scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap();
    r.shading = shading;
    r.render(ctx, &camera(), &lights(), 0).unwrap();
    let image = r.read_image(ctx).unwrap();
    ctx.check_errors().unwrap();
    image
}

/// With the material textures: (1) the loader reads them (factor, strength,
/// textures); (2) in forward, removing one texture changes the image in the
/// half where that texture is not white and leaves the other half as it was;
/// (3) every pipeline agrees with forward within FLIP 0.02, and in each
/// texture's half stays within a quarter of that texture's own effect of
/// forward's image (so a pipeline that ignored a texture would fail even
/// where the FLIP mean would not show it).
///
/// Measured on lavapipe (320x180), Phong / GGX: mean FLIP against forward
/// 0.0055 / 0.0063 multi-pass, 0 / 0 clustered, 0.0080 / 0.0086 deferred,
/// 0.0057 / 0.0056 tiled deferred on the G-buffer, 0.00001 / 0.00001 tiled
/// deferred on compute visibility, 0.0036 / 0.0037 object space; each
/// texture's effect in forward (mean absolute difference, 8-bit units, in
/// its non-white half) emissive 52.7 / 66.7, metallic-roughness 13.9 / 20.9,
/// occlusion 8.0 / 12.2, and 0.000 in the white halves; every pipeline
/// within 0.09 of forward in each non-white half.
fn check_material_textures(shading: ShadingModel) {
    use shadespace::render::VisibilityMethod;
    use textured_floor::{EMISSIVE_FACTOR, EMISSIVE_STRENGTH, OCCLUSION_STRENGTH, Slot, half_difference};
    let dir = tempfile::tempdir().unwrap();
    let scene = shadespace::scene::load(textured_floor::write(dir.path()).to_str().unwrap()).unwrap();
    let m = &scene.materials[scene.objects[0].material];
    assert!(m.emissive.abs_diff_eq(EMISSIVE_FACTOR * EMISSIVE_STRENGTH, 1e-6), "{}", m.emissive);
    assert!(m.emissive_texture.is_some() && m.metallic_roughness_texture.is_some());
    assert_eq!(m.occlusion_texture, m.metallic_roughness_texture, "one packed image");
    assert_eq!(m.occlusion_strength, OCCLUSION_STRENGTH);

    let ctx = common::gpu();
    let out = common::out_dir();
    let forward = || PipelineConfig::Forward(ForwardConfig::default());
    let reference = render_floor(&ctx, &scene, shading, forward());
    reference.save(out.join(format!("textured-floor-{shading:?}-forward.png"))).unwrap();
    let mut effects = Vec::new();
    for slot in Slot::ALL {
        let without = render_floor(&ctx, &slot.without(&scene), shading, forward());
        let (changed, kept) =
            (half_difference(&reference, &without, slot, true), half_difference(&reference, &without, slot, false));
        eprintln!(
            "{shading:?} {slot:?}: textured against factor only: {changed:.2} where not white, {kept:.3} where white"
        );
        assert!(changed > 4.0, "{shading:?}: the {slot:?} texture barely changes its half ({changed})");
        assert!(kept < 0.1, "{shading:?}: the {slot:?} texture changes its white half ({kept})");
        effects.push(changed);
    }

    let (charted, sizes) = common::charted(&scene);
    let pipelines = [
        PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig::default()),
        PipelineConfig::DeferredCompute(DeferredComputeConfig::default()),
        PipelineConfig::DeferredCompute(DeferredComputeConfig {
            visibility: VisibilityMethod::Compute,
            ..Default::default()
        }),
        PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes: sizes, ..Default::default() }),
    ];
    for (k, pipeline) in pipelines.into_iter().enumerate() {
        let label = format!("textured-floor-{shading:?}-{}-{k}", pipeline.name());
        let s = if matches!(pipeline, PipelineConfig::ObjectSpace(_)) { &charted } else { &scene };
        let test = render_floor(&ctx, s, shading, pipeline);
        let (err, map) = metrics::compare(&reference, &test);
        let halves: Vec<f64> = Slot::ALL.iter().map(|&slot| half_difference(&reference, &test, slot, true)).collect();
        eprintln!(
            "{label}: against forward: {err:?}; in the textures' halves {halves:.2?} (their effects {effects:.2?})"
        );
        let fails = err.flip_mean > AGREEMENT_FLIP || halves.iter().zip(&effects).any(|(d, e)| *d > 0.25 * e);
        if fails {
            test.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!(
                "{label}: FLIP {} (bound {AGREEMENT_FLIP}), halves {halves:?} against effects {effects:?}; images in {}",
                err.flip_mean,
                out.display()
            );
        }
    }
}

#[test]
fn material_textures_phong() {
    check_material_textures(ShadingModel::Phong);
}

#[test]
fn material_textures_pbr() {
    check_material_textures(ShadingModel::Pbr);
}

/// `KHR_texture_transform` in every pipeline: the floor's base colour is
/// red where u < 0.5 and green elsewhere; with offset (0.5, 0) and scale
/// (0.5, 1) the whole floor samples the green half, so each pipeline's
/// image must be green where, without the transform, the floor is red.
#[test]
fn texture_transform_moves_the_texture_in_every_pipeline() {
    use textured_floor::uv_at;
    let dir = tempfile::tempdir().unwrap();
    let red_green = image::RgbaImage::from_fn(64, 64, |x, _| {
        image::Rgba(if x < 32 { [230, 20, 20, 255] } else { [20, 230, 20, 255] })
    });
    let material = |transform: serde_json::Value| {
        serde_json::json!({ "name": "floor", "pbrMetallicRoughness": {
            "baseColorTexture": { "index": 0, "extensions": { "KHR_texture_transform": transform } },
            "metallicFactor": 0.0, "roughnessFactor": 0.8 } })
    };
    let images = [("red-green.png", red_green)];
    let load = |name: &str, transform| {
        let sub = dir.path().join(name);
        std::fs::create_dir_all(&sub).unwrap();
        let path = textured_floor::write_with(&sub, &images, material(transform), "KHR_texture_transform");
        shadespace::scene::load(path.to_str().unwrap()).unwrap()
    };
    let plain = load("identity", serde_json::json!({}));
    let moved = load("moved", serde_json::json!({ "offset": [0.5, 0.0], "scale": [0.5, 1.0] }));
    // Mean red minus green over the pixels whose UV0 has u < 0.45 (the red half, clear of the seam).
    let red_minus_green = |image: &image::RgbaImage| {
        let (mut sum, mut n) = (0.0, 0u32);
        for (x, y, p) in image.enumerate_pixels() {
            let uv = uv_at(x, y);
            if uv.x < 0.45 && uv.min_element() > 0.0 && uv.y < 1.0 {
                sum += p[0] as f64 - p[1] as f64;
                n += 1;
            }
        }
        assert!(n > 1000, "only {n} pixels in the red half");
        sum / n as f64
    };
    let ctx = common::gpu();
    let forward = || PipelineConfig::Forward(ForwardConfig::default());
    let before = red_minus_green(&render_floor(&ctx, &plain, ShadingModel::Pbr, forward()));
    assert!(before > 40.0, "without the transform the half is red: red - green {before:.1}");
    let (charted, sizes) = common::charted(&moved);
    for pipeline in std::iter::once(forward()).chain(pipelines(sizes)) {
        let name = pipeline.name();
        let scene = if matches!(pipeline, PipelineConfig::ObjectSpace(_)) { &charted } else { &moved };
        let after = red_minus_green(&render_floor(&ctx, scene, ShadingModel::Pbr, pipeline));
        eprintln!("{name}: red - green in the red half: {before:.1} without the transform, {after:.1} with it");
        assert!(after < -40.0, "{name}: the transform did not move the texture: red - green {after:.1}");
    }
}

/// Alpha masking (glTF `MASK`) in every pipeline, with and without depth
/// pre-passes: the floor's base colour texture is red with alpha 0 where
/// u < 0.5 and green with alpha 1 elsewhere, and a blue floor lies 1 m
/// below it, lit through the cut half by a shadow-casting point light above.
/// Where u < 0.45 every pipeline must show the lower floor as it looks with
/// no upper floor at all (so the mask cut the upper floor from the view and
/// from the light's shadow map); where u > 0.55, the upper floor as it
/// looks when opaque; and every pipeline must agree with forward within
/// FLIP 0.02. The compute rasterizer (deferred-compute's and object space's
/// `--visibility compute`) tests alpha too.
///
/// Measured on lavapipe (320x180): mean absolute difference (8-bit units)
/// 0.00 in both halves in every pipeline, FLIP against forward 0.0045 at
/// most (deferred-compute; object space 0.0027); the cut half differs from
/// the opaque floor's image by 55.2, and by 42.9 from the lower floor's
/// alone when the shadow maps ignore the mask.
#[test]
fn alpha_mask_cuts_surfaces_and_shadows_in_every_pipeline() {
    use glam::{Mat4, Vec3, Vec4};
    use shadespace::render::VisibilityMethod;
    use shadespace::scene::{Light, LightKind, Material, Object, Scene};
    use textured_floor::{HEIGHT, WIDTH, camera};

    let dir = tempfile::tempdir().unwrap();
    let cut_green = image::RgbaImage::from_fn(64, 64, |x, _| {
        image::Rgba(if x < 32 { [230, 20, 20, 0] } else { [20, 230, 20, 255] })
    });
    let material = serde_json::json!({ "name": "floor", "alphaMode": "MASK", "alphaCutoff": 0.5,
        "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.0, "roughnessFactor": 0.8 } });
    let path = textured_floor::write_with(
        dir.path(),
        &[("cut-green.png", cut_green)],
        material,
        "KHR_materials_emissive_strength",
    );
    let mut masked = shadespace::scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!(masked.materials[masked.objects[0].material].alpha_cutoff, Some(0.5));
    // The lower floor: the same quad, half as large again and 1 m down, blue and opaque.
    masked.materials.push(Material {
        name: "lower".into(),
        base_color: Vec4::new(0.2, 0.3, 0.9, 1.0),
        ..Default::default()
    });
    masked.objects.push(Object {
        name: "lower".into(),
        mesh: masked.objects[0].mesh,
        material: masked.materials.len() - 1,
        transform: Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0)) * Mat4::from_scale(Vec3::new(1.5, 1.0, 1.5)),
        forward_only: false,
    });
    let mut opaque = masked.clone();
    opaque.materials[opaque.objects[0].material].alpha_cutoff = None;
    let mut lower_only: Scene = masked.clone();
    lower_only.objects.remove(0);

    let light = |kind, intensity, position, casts_shadows| Light {
        kind,
        color: Vec3::ONE,
        intensity,
        position,
        direction: Vec3::NEG_Y,
        radius: 8.0,
        cos_inner: 0.9,
        cos_outer: 0.8,
        casts_shadows,
    };
    // Over the cut half: its light reaches the lower floor only through the cut.
    let lights = [
        light(LightKind::Ambient, 0.1, Vec3::ZERO, false),
        light(LightKind::Point, 4.0, Vec3::new(-2.0, 2.0, 0.0), true),
    ];
    let ctx = common::gpu();
    let render = |scene: &Scene, pipeline: PipelineConfig| -> image::RgbaImage {
        let mut r =
            Renderer::new(&ctx, scene, &RenderOptions { width: WIDTH, height: HEIGHT, pipeline, samples: 1 }).unwrap();
        r.render(&ctx, &camera(), &lights, 0).unwrap();
        let image = r.read_image(&ctx).unwrap();
        ctx.check_errors().unwrap();
        image
    };
    // Mean absolute difference (8-bit, RGB) over the pixels whose upper-floor
    // UV lies in the cut half (u < 0.45) or the solid half (u > 0.55).
    let half_difference = |a: &image::RgbaImage, b: &image::RgbaImage, cut: bool| {
        textured_floor::difference_where(a, b, |uv| if cut { uv.x < 0.45 } else { uv.x > 0.55 })
    };

    let forward = |depth_prepass| PipelineConfig::Forward(ForwardConfig { depth_prepass });
    let reference = render(&masked, forward(true));
    let solid = render(&opaque, forward(true));
    let out = common::out_dir();
    reference.save(out.join("alpha-mask-forward.png")).unwrap();
    let effect = half_difference(&reference, &solid, true);
    eprintln!("alpha mask: the cut half differs from the opaque floor's by {effect:.1}");
    assert!(effect > 40.0, "the mask barely changes the cut half ({effect:.1})");

    let os = |visibility_prepass, visibility| {
        PipelineConfig::ObjectSpace(ObjectSpaceConfig { visibility_prepass, visibility, ..Default::default() })
    };
    let deferred_compute = |depth_prepass, visibility| {
        PipelineConfig::DeferredCompute(DeferredComputeConfig { depth_prepass, visibility, ..Default::default() })
    };
    let (raster, compute) = (VisibilityMethod::Raster, VisibilityMethod::Compute);
    let pipelines = [
        forward(true),
        forward(false),
        PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig::default()),
        deferred_compute(true, raster),
        deferred_compute(false, raster),
        deferred_compute(false, compute),
        os(true, raster),
        os(false, raster),
        os(false, compute),
    ];
    // Object space renders the scene with its charts, and their texture sizes.
    let render_with = |scene: &Scene, pipeline: &PipelineConfig| match pipeline {
        PipelineConfig::ObjectSpace(c) => {
            let (charted, texture_sizes) = common::charted(scene);
            render(&charted, PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, ..c.clone() }))
        }
        _ => render(scene, pipeline.clone()),
    };
    for (k, pipeline) in pipelines.iter().enumerate() {
        let label = format!("alpha-mask-{k}-{}", pipeline.name());
        let test = render_with(&masked, pipeline);
        let cut = half_difference(&test, &render_with(&lower_only, pipeline), true);
        let kept = half_difference(&test, &render_with(&opaque, pipeline), false);
        let (err, map) = metrics::compare(&reference, &test);
        eprintln!(
            "{label}: cut half against no upper floor {cut:.2}, solid half against the opaque floor {kept:.2}, {err:?}"
        );
        if cut > 2.0 || kept > 2.0 || err.flip_mean > AGREEMENT_FLIP {
            test.save(out.join(format!("{label}.png"))).unwrap();
            map.save(out.join(format!("{label}-flip.png"))).unwrap();
            panic!(
                "{label}: cut half {cut:.2}, solid half {kept:.2} (bound 2), FLIP {} (bound {AGREEMENT_FLIP}); images in {}",
                err.flip_mean,
                out.display()
            );
        }
    }
}
