//! The procedural terrain (issue 26, item 4) at its small size: every
//! pipeline renders it and agrees with forward, its patch borders show no
//! seam in object space although neighbouring patches are shaded at
//! different levels, and its precals change only their footprint.

use crate::common;

use glam::Vec3;
use shadespace::materials::{self, MaterialsSpec};
use shadespace::metrics;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::{ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
use shadespace::scene::generate::terrain::{Precals, TerrainSpec};
use shadespace::scene::{Camera, Light, LightKind, Scene, path};

const WIDTH: u32 = 256;
const HEIGHT: u32 = 144;
const LIGHTS: &str = "small:16+big:2";

/// The small terrain seen from its path frame `frame` (0: low over a valley,
/// looking across the terrain; 600: high above it).
fn view(frame: u32) -> Camera {
    let scene = TerrainSpec::SMALL.scene();
    let cameras = path::cameras_for_scene("terrain-small", &scene, WIDTH as f32 / HEIGHT as f32).unwrap();
    cameras.path.camera_at(frame)
}

fn lights(scene: &Scene, camera: &Camera) -> Vec<Light> {
    let spec = LIGHTS.parse().unwrap();
    shadespace::scene::lights::build_lights(&spec, &scene.bounds(), camera, WIDTH as f32 / HEIGHT as f32, 3).unwrap()
}

/// Renders `scene` (charted) in `pipeline`; object space gets `sizes` and
/// `mip_bias`, and also returns its per-pixel object ids.
fn render(
    scene: &Scene,
    sizes: &[Option<u32>],
    pipeline: &str,
    mip_bias: f32,
    camera: &Camera,
    lights: &[Light],
) -> (image::RgbaImage, Option<Vec<[u32; 2]>>) {
    let ctx = common::gpu();
    let pipeline = match PipelineConfig::from_name(pipeline).unwrap() {
        PipelineConfig::ObjectSpace(_) => PipelineConfig::ObjectSpace(ObjectSpaceConfig {
            texture_sizes: sizes.to_vec(),
            mip_bias,
            ..Default::default()
        }),
        other => other,
    };
    let mut r = Renderer::new(&ctx, scene, &RenderOptions::new(WIDTH, HEIGHT, pipeline)).unwrap();
    r.render(&ctx, camera, lights, 0).unwrap();
    let image = r.read_image(&ctx).unwrap();
    let ids = r.pipeline::<ObjectSpace>().map(|os| os.read_mark_state(&ctx).unwrap().visibility);
    ctx.check_errors().unwrap();
    (image, ids)
}

/// Every pipeline renders the small terrain, lit and covering the lower part
/// of the frame, within FLIP 0.03 of forward (lavapipe, path frame 0:
/// conventional pipelines 0.0000-0.0026, object space 0.0097).
#[test]
fn every_pipeline_renders_the_small_terrain() {
    let camera = view(0);
    let (scene, sizes) = common::charted_for(&TerrainSpec::SMALL.scene(), &camera, WIDTH, HEIGHT);
    let lights = lights(&scene, &camera);
    let (forward, _) = render(&scene, &sizes, "forward", 0.0, &camera, &lights);
    let lit = forward.pixels().filter(|p| p.0[..3].iter().any(|&c| c > 8)).count();
    assert!(lit as f32 > 0.3 * (WIDTH * HEIGHT) as f32, "terrain covers {lit} pixels");
    for name in ["forward-multipass", "deferred", "deferred-compute", "clustered", "objectspace"] {
        let (image, _) = render(&scene, &sizes, name, 0.0, &camera, &lights);
        image.save(common::out_dir().join(format!("terrain-small-{name}.png"))).unwrap();
        let (err, _) = metrics::compare(&forward, &image);
        eprintln!("terrain-small: {name} against forward: FLIP {:.4}, {:.1} dB", err.flip_mean, err.psnr_db);
        assert!(err.flip_mean <= 0.03, "{name}: {err:?}");
    }
}

/// Patch borders in object space against forward: the pixels on a patch
/// border (a neighbour sees another patch's triangle that shares a vertex
/// with the pixel's own: the same surface, not a ridge in front of a farther
/// patch) are at most [`crate::seams::MAX_BORDER_GAP_DB`] worse than the
/// other pixels around them (within 3 pixels: the same distances and angles),
/// at mip bias 0 and 2, as `seams.rs` holds chart borders. Path frame 0 looks
/// low across the terrain, where the visible patches' textures run from 64
/// to 1024 texels (lavapipe: 611 border pixels at 38.5 / 30.8 dB at bias 0 /
/// 2, pixels around them 42.2 / 30.9 dB; at bias 2 the distant patches are
/// shaded 2 levels coarser than the screen, down to single tiles).
/// The albedo and normals agree across borders by construction (the unit
/// tests of `scene::generate::terrain`); this holds the shading and gather.
#[test]
fn patch_borders_show_no_seam() {
    let camera = view(0);
    let (scene, sizes) = common::charted_for(&TerrainSpec::SMALL.scene(), &camera, WIDTH, HEIGHT);
    let lights = lights(&scene, &camera);
    let (forward, _) = render(&scene, &sizes, "forward", 0.0, &camera, &lights);
    // The world positions of triangle `t` of object `o` (1-based, as the ids).
    let corners = |o: u32, t: u32| -> [Vec3; 3] {
        let mesh = &scene.meshes[scene.objects[o as usize - 1].mesh];
        std::array::from_fn(|k| mesh.positions[mesh.indices[3 * t as usize + k] as usize])
    };
    let touch = |a: [Vec3; 3], b: [Vec3; 3]| a.iter().any(|p| b.iter().any(|q| p.distance(*q) < 1e-3));
    for bias in [0.0, 2.0] {
        let (test, ids) = render(&scene, &sizes, "objectspace", bias, &camera, &lights);
        let ids = ids.unwrap();
        let (w, h) = (WIDTH as i32, HEIGHT as i32);
        let at = |x: i32, y: i32| ids[(y * w + x) as usize];
        let mut border = vec![false; ids.len()];
        let mut inside = vec![false; ids.len()];
        let mut sizes_met = std::collections::BTreeSet::new();
        for y in 0..h {
            for x in 0..w {
                let [o, t] = at(x, y);
                if o == 0 {
                    continue;
                }
                sizes_met.insert(sizes[o as usize - 1].unwrap());
                let mut seam = false;
                let mut other = false;
                for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1)] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w || ny >= h {
                        continue;
                    }
                    let [o2, t2] = at(nx, ny);
                    if o2 != 0 && o2 != o {
                        other = true;
                        seam |= touch(corners(o, t), corners(o2, t2));
                    }
                }
                border[(y * w + x) as usize] = seam;
                inside[(y * w + x) as usize] = !other;
            }
        }
        // Compared with the pixels around the borders (within 3 pixels), at
        // the same distances and angles: farther patches err more anyway.
        let near_border = |i: usize| {
            let (x, y) = ((i as i32) % w, (i as i32) / w);
            (-3..=3).any(|dy| {
                (-3..=3).any(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    nx >= 0 && ny >= 0 && nx < w && ny < h && border[(ny * w + nx) as usize]
                })
            })
        };
        let around: Vec<bool> = (0..ids.len()).map(|i| inside[i] && near_border(i)).collect();
        let (border_db, pixels) = crate::seams::psnr(&forward, &test, &border);
        let (inside_db, _) = crate::seams::psnr(&forward, &test, &around);
        eprintln!(
            "terrain-small, mip bias {bias}: {pixels} patch-border pixels {border_db:.1} dB, others {inside_db:.1} dB; \
             texture sides in view {sizes_met:?}"
        );
        assert!(sizes_met.len() >= 3, "the patches in view share too few levels: {sizes_met:?}");
        assert!(pixels > 200, "only {pixels} border pixels");
        let gap = crate::seams::MAX_BORDER_GAP_DB;
        assert!(border_db >= inside_db - gap, "seam: borders {border_db:.1} dB, others around them {inside_db:.1} dB");
    }
}

/// `--materials bands`: the terrain's eight bands as layers lit each with
/// its own BRDF change the image (lavapipe, path frame 0: FLIP 0.112
/// against the baked bands alone; `deferred-compute` 0.0016 and object
/// space 0.0167 from forward), and the pipelines agree with forward as
/// with the baked bands.
#[test]
fn bands_shade_the_terrain_in_layers() {
    let camera = view(0);
    let (plain, sizes) = common::charted_for(&TerrainSpec::SMALL.scene(), &camera, WIDTH, HEIGHT);
    let mut banded = plain.clone();
    materials::apply(&mut banded, &MaterialsSpec::Bands).unwrap();
    assert!(banded.materials.iter().all(|m| m.layers.len() == 10), "eight bands, the base and the precals");
    let lights = lights(&plain, &camera);
    let (baked, _) = render(&plain, &sizes, "forward", 0.0, &camera, &lights);
    let (forward, _) = render(&banded, &sizes, "forward", 0.0, &camera, &lights);
    let (change, _) = metrics::compare(&baked, &forward);
    eprintln!("terrain-small bands against the baked bands: FLIP {:.4}", change.flip_mean);
    assert!(change.flip_mean > 0.01, "the layers changed little: {change:?}");
    for name in ["deferred-compute", "objectspace"] {
        let (image, _) = render(&banded, &sizes, name, 0.0, &camera, &lights);
        let (err, _) = metrics::compare(&forward, &image);
        eprintln!("terrain-small bands: {name} against forward: FLIP {:.4}, {:.1} dB", err.flip_mean, err.psnr_db);
        assert!(err.flip_mean <= 0.03, "{name}: {err:?}");
    }
}

/// The precals (roads, power line, scorch marks) change the image only on
/// their footprint: forward and object space with and without them differ
/// only at pixels that the footprint (white albedo there, black elsewhere,
/// under ambient light only) lights, grown by 2 pixels for filtering, and
/// they do change some pixels (lavapipe, path frame 600, high above the
/// terrain: 1,273 pixels in forward, 1,436 in object space, whose coarser
/// levels spread a precal's edge over more pixels; none outside). Under
/// `--materials bands` too, whose top layer shows them over the bands
/// (forward: 647 pixels, none outside).
#[test]
fn precals_change_only_their_footprint() {
    let camera = view(600);
    let scene_of = |precals| TerrainSpec { precals, ..TerrainSpec::SMALL }.scene();
    let ambient = vec![Light {
        kind: LightKind::Ambient,
        color: Vec3::ONE,
        intensity: 1.0,
        position: Vec3::ZERO,
        direction: Vec3::NEG_Y,
        radius: 1.0,
        cos_inner: 1.0,
        cos_outer: 1.0,
        casts_shadows: false,
    }];
    let (footprint, sizes) = common::charted_for(&scene_of(Precals::Footprint), &camera, WIDTH, HEIGHT);
    let (mask, _) = render(&footprint, &sizes, "forward", 0.0, &camera, &ambient);
    let covered: Vec<bool> = mask.pixels().map(|p| p.0[..3].iter().any(|&c| c > 0)).collect();
    let (w, h) = (WIDTH as i32, HEIGHT as i32);
    let grown = |x: i32, y: i32| {
        (-2..=2).any(|dy| {
            (-2..=2).any(|dx| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0 && ny >= 0 && nx < w && ny < h && covered[(ny * w + nx) as usize]
            })
        })
    };
    let (with, _) = common::charted_for(&scene_of(Precals::On), &camera, WIDTH, HEIGHT);
    let (without, _) = common::charted_for(&scene_of(Precals::Off), &camera, WIDTH, HEIGHT);
    let lights = lights(&with, &camera);
    let banded = |s: &Scene| {
        let mut s = s.clone();
        materials::apply(&mut s, &MaterialsSpec::Bands).unwrap();
        s
    };
    let (with_bands, without_bands) = (banded(&with), banded(&without));
    let runs =
        [("forward", &with, &without), ("objectspace", &with, &without), ("forward", &with_bands, &without_bands)];
    for (k, (pipeline, with, without)) in runs.into_iter().enumerate() {
        let pipeline_label = if k == 2 { "forward, bands" } else { pipeline };
        let (a, _) = render(with, &sizes, pipeline, 0.0, &camera, &lights);
        let (b, _) = render(without, &sizes, pipeline, 0.0, &camera, &lights);
        let (mut changed, mut outside) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let (p, q) = (a.get_pixel(x as u32, y as u32), b.get_pixel(x as u32, y as u32));
                if (0..3).any(|c| p[c].abs_diff(q[c]) > 2) {
                    changed += 1;
                    outside += !grown(x, y) as u32;
                }
            }
        }
        let pipeline = pipeline_label;
        eprintln!("terrain-small precals, {pipeline}: {changed} pixels changed, {outside} outside the footprint");
        assert!(changed > 300, "{pipeline}: the precals changed only {changed} pixels");
        assert_eq!(outside, 0, "{pipeline}: {outside} pixels changed outside the precals' footprint");
    }
}
