//! Culling that draws the plain way where it would cost more than it saves
//! (`--cull-plain-above`, `render::passes::cluster_draws`), and the shadow
//! maps culled by cluster (`render::passes::shadows::cull`), on the tiny
//! city (lavapipe, small): the images, and the shadow maps texel for texel,
//! are those without culling; the counters say which way each frame drew.

use crate::common;

use glam::Vec3;
use shadespace::gpu::{GpuContext, readback};
use shadespace::render::passes::cluster_draws::INDEXED_FEATURES;
use shadespace::render::passes::shadows::FACE_SIZE;
use shadespace::render::{Counters, Culling, PipelineConfig, RenderOptions, Renderer, ShadowRefresh};
use shadespace::scene::{self, Camera, Light, LightKind, Scene, path};

const SIZE: (u32, u32) = (128, 72);

/// The cameras at `frames` of `choice`'s path of the tiny city.
fn cameras(scene: &Scene, choice: path::CameraChoice, frames: &[u32]) -> Vec<Camera> {
    let cameras = path::cameras_for_scene("city:2", scene, SIZE.0 as f32 / SIZE.1 as f32).unwrap();
    let path = cameras.select(choice).unwrap();
    frames.iter().map(|&t| path.camera_at(t)).collect()
}

/// Renders frame `number` and waits for its counters (the next frame's
/// choice of plain or culled draws then follows from them).
fn frame(ctx: &GpuContext, r: &mut Renderer, camera: &Camera, lights: &[Light], number: u64) -> (Vec<u32>, Counters) {
    r.render(ctx, camera, lights, number).unwrap();
    let counters = r.collect_counters(ctx, true).into_iter().filter(|(f, _)| *f == number).flat_map(|(_, c)| c);
    let image = r.read_image(ctx).unwrap();
    (image.pixels().map(|p| u32::from_le_bytes(p.0)).collect(), counters.collect())
}

/// Forward along the tiny city's fly-over (98 % of the clusters in view
/// kept) and down its street (about 40 %), each view drawn without culling
/// and with occlusion: the same image every time; at the default share
/// (0.6) the fly-over draws the plain way from its second culled frame (no
/// cluster draws), at a share of 1 its next frame draws clusters, and the
/// street, after it, goes back to the cluster draws on its second frame,
/// its first (plain, chosen from the fly-over's counts) having kept every
/// cluster's visibility for it. Comparing the kept share the wrong way
/// round (plain below the limit) fails it (tried).
#[test]
fn culling_draws_the_plain_way_where_it_keeps_most_clusters() {
    let ctx = common::gpu();
    let mut scene = common::load("city:2");
    // Both faces drawn, so that the fly-over keeps most clusters (its
    // shells' back faces would be culled by their cones).
    scene.set_back_faces(scene::BackFaces::Draw);
    let above = cameras(&scene, path::CameraChoice::Flyover, &[0, 3, 6]);
    let street = cameras(&scene, path::CameraChoice::Path, &[0, 2]);
    let lights = scene::lights::build_lights(&"small:8".parse().unwrap(), &scene.bounds(), &above[0], 1.0, 3).unwrap();
    let forward = PipelineConfig::from_name("forward").unwrap();
    let mut r = Renderer::new(&ctx, &scene, &RenderOptions::new(SIZE.0, SIZE.1, forward)).unwrap();
    let indexed = ctx.has(INDEXED_FEATURES);
    let mut number = 0;
    // Per camera, (culled frame's counters) after checking its image against no culling.
    let mut walk = |r: &mut Renderer, cameras: &[Camera]| -> Vec<Counters> {
        let mut out = Vec::new();
        for camera in cameras {
            r.culling = Culling::None;
            let (plain, _) = frame(&ctx, r, camera, &lights, number);
            r.culling = Culling::Occlusion;
            let (culled, c) = frame(&ctx, r, camera, &lights, number + 1);
            number += 2;
            let differ = plain.iter().zip(&culled).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "frame {}: {differ} pixels differ from no culling: {c:?}", number - 1);
            out.push(c);
        }
        out
    };
    let fly = walk(&mut r, &above[..2]);
    assert_eq!(fly[0]["cull_plain"], 0.0, "the first frame has no counts to go by: {:?}", fly[0]);
    let c = &fly[1];
    assert!(c["cull_drawn"] > 0.6 * c["cull_tested"], "{c:?}");
    assert_eq!(c["cull_plain"], 1.0, "the fly-over keeps most clusters: {c:?}");
    if indexed {
        assert_eq!(c["cull_draws"], 0.0, "{c:?}");
    }
    r.cull_plain_above = 1.0;
    let c = &walk(&mut r, &above[2..])[0];
    assert_eq!(c["cull_plain"], 0.0, "never plain at a share of 1: {c:?}");
    r.cull_plain_above = 0.6;
    let walk_street = walk(&mut r, &street);
    assert_eq!(walk_street[0]["cull_plain"], 1.0, "chosen from the fly-over: {:?}", walk_street[0]);
    let c = &walk_street[1];
    assert!(c["cull_drawn"] < 0.6 * c["cull_tested"], "{c:?}");
    assert_eq!(c["cull_plain"], 0.0, "the street culls most clusters: {c:?}");
    if indexed {
        // Runs of clusters: more draws than the plain way's runs of instances.
        let (draws, plain) = (c["cull_draws"], c["cull_plain_draws"]);
        assert!(draws > plain && plain > 0.0, "{c:?}");
    }
    ctx.check_errors().unwrap();
}

/// Every layer of the shadow atlas, as read back.
fn atlas(ctx: &GpuContext, r: &Renderer, layers: u32) -> Vec<Vec<u8>> {
    let texture = r.scene.shadow_atlas.atlas_texture();
    (0..layers).map(|l| readback::read_texture_level(ctx, texture, 4, 0, l, (FACE_SIZE, FACE_SIZE)).unwrap()).collect()
}

/// A shadowed point light (six cube faces) and a shadowed spot light (one
/// face) over the tiny city's crossing, rendered every frame: with culling
/// the faces' clusters outside them are dropped and the kept ones drawn
/// indexed, and every layer of the atlas is the same texel for texel as
/// without culling, as is the image; in a frame after a culling that kept
/// more than the share (0 here), the faces draw the plain way, the same
/// again. Culling every caster by the first face's frustum instead of its
/// own (`cull.wgsl`'s `range_view_proj`) fails it (tried). (The faces cull
/// by their frustum with `--culling frustum` and `occlusion` alike.)
#[test]
fn shadow_maps_culled_by_cluster_are_the_same() {
    let ctx = common::gpu();
    if !ctx.has(INDEXED_FEATURES) {
        eprintln!("SKIPPED: the adapter lacks {INDEXED_FEATURES:?}: the shadow maps are not culled");
        return;
    }
    let scene = common::load("city:2");
    let camera = cameras(&scene, path::CameraChoice::Flyover, &[0])[0];
    let centre = scene.bounds().center();
    let point = Light {
        kind: LightKind::Point,
        color: Vec3::ONE,
        intensity: 40.0,
        position: Vec3::new(centre.x + 32.0, 12.0, centre.z + 32.0),
        direction: Vec3::NEG_Y,
        radius: 24.0,
        cos_inner: 1.0,
        cos_outer: 1.0,
        casts_shadows: true,
    };
    let spot = Light {
        kind: LightKind::Spot,
        position: Vec3::new(centre.x - 20.0, 30.0, centre.z),
        direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
        radius: 50.0,
        cos_inner: 30f32.to_radians().cos(),
        cos_outer: 40f32.to_radians().cos(),
        ..point
    };
    let lights = [Light { kind: LightKind::Ambient, intensity: 0.05, casts_shadows: false, ..point }, point, spot];
    let forward = PipelineConfig::from_name("forward").unwrap();
    let mut r = Renderer::new(&ctx, &scene, &RenderOptions::new(64, 64, forward)).unwrap();
    r.shadow_refresh = ShadowRefresh::EveryFrame;
    r.cull_plain_above = 1.0;
    r.culling = Culling::None;
    let (image, _) = frame(&ctx, &mut r, &camera, &lights, 0);
    assert_eq!(r.report().setup["shadow_faces"], 7);
    let maps = atlas(&ctx, &r, 7);
    let cast = maps.iter().filter(|m| m.chunks_exact(4).any(|t| t != [0; 4])).count();
    assert!(cast >= 2, "{cast} faces hold a caster");
    for (number, culling, share) in [(1, Culling::Frustum, 1.0), (2, Culling::Occlusion, 0.0)] {
        r.culling = culling;
        r.cull_plain_above = share;
        let (culled, c) = frame(&ctx, &mut r, &camera, &lights, number);
        assert_eq!(r.report().setup["shadow_cluster_culling"], 1);
        for (face, (a, b)) in maps.iter().zip(atlas(&ctx, &r, 7)).enumerate() {
            let differ = a.chunks_exact(4).zip(b.chunks_exact(4)).filter(|(a, b)| a != b).count();
            assert_eq!(differ, 0, "frame {number}: face {face}: {differ} texels differ from no culling: {c:?}");
        }
        assert_eq!(image, culled, "frame {number}: the image differs from no culling");
        let (tested, kept) = (c["shadow_cull_tested"], c["shadow_cull_drawn"]);
        assert!(c["shadow_cull_frustum"] > 0.0 && kept > 0.0 && kept < tested, "frame {number}: {c:?}");
        let plain = number == 2;
        assert_eq!(c["shadow_cull_plain"], f64::from(u8::from(plain)), "frame {number}: {c:?}");
        if plain {
            assert_eq!(c["shadow_cull_draws"], 0.0, "{c:?}");
        } else {
            let draws = c["shadow_cull_draws"];
            assert!(draws > 0.0 && draws < kept, "frame {number}: runs of clusters: {c:?}");
            assert!(c["shadow_cull_plain_draws"] > 0.0, "frame {number}: {c:?}");
        }
        eprintln!("shadow culling, frame {number}: {c:?}");
    }
    ctx.check_errors().unwrap();
}
