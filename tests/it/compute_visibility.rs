//! The compute rasterizer (`--visibility compute`) against the hardware
//! visibility pass: the (object, triangle) ids of both agree on at least
//! 99.9 % of the covered pixels of the procedural scenes and Sponza, and every
//! pixel where they differ lies on an edge between two surfaces in one of the
//! two buffers (where rounding decides which triangle a pixel centre is in).
//! Cameras inside objects and triangles crossing the near plane included.

use crate::common;
use std::path::Path;

use glam::Vec3;
use shadespace::gpu::GpuContext;
use shadespace::render::objectspace::ObjectSpace;
use shadespace::render::{Culling, ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod};
use shadespace::scene::{BackFaces, Camera, Scene, Texture, path};

const SPONZA: &str = "../shared/scenes/sponza-thesis";
/// Least share of covered pixels whose ids must agree.
const MIN_AGREEMENT: f64 = 0.999;

/// The visibility buffer (object + 1, triangle per pixel) of object space
/// with `method`. The ids need no shading atlas: every object but the first
/// is shaded forward (the atlas cannot be empty), so no charts are built.
fn ids(ctx: &GpuContext, scene: &Scene, camera: &Camera, size: (u32, u32), method: VisibilityMethod) -> Vec<[u32; 2]> {
    ids_with(ctx, scene, std::slice::from_ref(camera), size, method, true).remove(0)
}

/// [`ids`] of each of `cameras` from one renderer (a view's ids depend on
/// nothing of the frames before it), the raster path with or without its
/// depth pre-pass.
fn ids_with(
    ctx: &GpuContext,
    scene: &Scene,
    cameras: &[Camera],
    size: (u32, u32),
    method: VisibilityMethod,
    visibility_prepass: bool,
) -> Vec<Vec<[u32; 2]>> {
    let mut texture_sizes = vec![None; scene.objects.len()];
    texture_sizes[0] = Some(128);
    let objectspace = ObjectSpaceConfig { texture_sizes, visibility: method, visibility_prepass, ..Default::default() };
    let options =
        RenderOptions { width: size.0, height: size.1, pipeline: PipelineConfig::ObjectSpace(objectspace), samples: 1 };
    let mut renderer = Renderer::new(ctx, scene, &options).unwrap();
    let mut views = Vec::new();
    for (frame, camera) in cameras.iter().enumerate() {
        renderer.render(ctx, camera, &[], frame as u64).unwrap();
        views.push(renderer.pipeline::<ObjectSpace>().unwrap().read_mark_state(ctx).unwrap().visibility);
    }
    views
}

/// Whether pixel `i` has a 4-neighbour with other ids in `buffer`.
fn on_edge(buffer: &[[u32; 2]], width: usize, i: usize) -> bool {
    let (x, y) = (i % width, i / width);
    let height = buffer.len() / width;
    let mut neighbours = Vec::with_capacity(4);
    if x > 0 {
        neighbours.push(i - 1);
    }
    if x + 1 < width {
        neighbours.push(i + 1);
    }
    if y > 0 {
        neighbours.push(i - width);
    }
    if y + 1 < height {
        neighbours.push(i + width);
    }
    neighbours.into_iter().any(|n| buffer[n] != buffer[i])
}

/// Renders `camera`'s view both ways, prints the figures and checks them;
/// returns (covered pixels, differing pixels).
fn compare(ctx: &GpuContext, name: &str, scene: &Scene, camera: &Camera, size: (u32, u32)) -> (usize, usize) {
    compare_views(ctx, scene, &[(name.to_string(), *camera)], size)[0]
}

/// [`compare`] for several named views of `scene`, each path's renderer
/// built once for all of them.
fn compare_views(ctx: &GpuContext, scene: &Scene, views: &[(String, Camera)], size: (u32, u32)) -> Vec<(usize, usize)> {
    let cameras: Vec<Camera> = views.iter().map(|(_, c)| *c).collect();
    let raster = ids_with(ctx, scene, &cameras, size, VisibilityMethod::Raster, true);
    let compute = ids_with(ctx, scene, &cameras, size, VisibilityMethod::Compute, true);
    views.iter().zip(raster.iter().zip(&compute)).map(|((name, _), (r, c))| compare_ids(name, r, c, size)).collect()
}

/// Checks one view's raster and compute ids against each other; returns
/// (covered pixels, pixels that differ).
fn compare_ids(name: &str, raster: &[[u32; 2]], compute: &[[u32; 2]], size: (u32, u32)) -> (usize, usize) {
    let width = size.0 as usize;
    let covered = (0..raster.len()).filter(|&i| raster[i][0] != 0 || compute[i][0] != 0).count();
    let differ: Vec<usize> = (0..raster.len()).filter(|&i| raster[i] != compute[i]).collect();
    let interior: Vec<usize> =
        differ.iter().copied().filter(|&i| !on_edge(raster, width, i) && !on_edge(compute, width, i)).collect();
    let agreement = 1.0 - differ.len() as f64 / covered.max(1) as f64;
    eprintln!(
        "{name}: {} of {covered} covered pixels differ ({:.4} % agree), {} of them off edges",
        differ.len(),
        agreement * 100.0,
        interior.len()
    );
    assert!(covered > 0, "{name}: nothing covered");
    assert!(agreement >= MIN_AGREEMENT, "{name}: only {:.4} % of covered pixels agree", agreement * 100.0);
    let describe =
        |i: usize| format!("({}, {}): raster {:?}, compute {:?}", i % width, i / width, raster[i], compute[i]);
    assert!(
        interior.is_empty(),
        "{name}: ids differ off edges at {}",
        interior.iter().take(4).map(|&i| describe(i)).collect::<Vec<_>>().join("; ")
    );
    (covered, differ.len())
}

fn path_camera(spec: &str, scene: &Scene, t: u32) -> Camera {
    let cameras = path::cameras_for_scene(spec, scene, 16.0 / 9.0).unwrap();
    cameras.select(path::CameraChoice::Path).unwrap().camera_at(t)
}

#[test]
fn ids_agree_with_raster_on_the_procedural_scenes() {
    let ctx = common::gpu();
    for name in ["atrium", "voxels"] {
        let scene = common::load(name);
        let views = [0, 40].map(|frame| (format!("{name} frame {frame}"), path_camera(name, &scene, frame)));
        compare_views(&ctx, &scene, &views, (256, 144));
    }
}

/// Alpha masks (`ALPHA_MASK`): every material of the procedural scenes cut
/// into stripes by its base colour texture (alpha 1 and 0, 16 texels each
/// of 64): the compute rasterizer tests alpha per pixel as the raster pass
/// discards, so the ids agree as without masks, and they differ only on
/// edges (the stripes' borders are edges: where the mip level the two
/// paths derive differs, a pixel there may flip).
#[test]
fn ids_agree_with_raster_with_alpha_masks() {
    let ctx = common::gpu();
    for name in ["atrium", "voxels"] {
        let mut scene = common::load(name);
        let alpha = |x: u32| if (x / 16).is_multiple_of(2) { 255 } else { 0 };
        let rgba8 = (0..64 * 64).flat_map(|i| [200, 200, 200, alpha(i % 64)]).collect();
        scene.textures.push(Texture { name: "stripes".into(), width: 64, height: 64, rgba8 });
        let stripes = scene.textures.len() - 1;
        for m in &mut scene.materials {
            (m.base_color_texture, m.alpha_cutoff) = (Some(stripes), Some(0.5));
        }
        let views = [0, 40].map(|frame| (format!("{name} frame {frame}, masked"), path_camera(name, &scene, frame)));
        compare_views(&ctx, &scene, &views, (256, 144));
    }
}

#[test]
fn ids_agree_with_raster_on_sponza() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let scene = common::load(SPONZA);
    let views = [0, 100].map(|frame| (format!("sponza frame {frame}"), path_camera(SPONZA, &scene, frame)));
    compare_views(&ctx, &scene, &views, (320, 180));
}

/// Sponza with every surface cut into disks over its UV layout (the
/// alpha-mask stress case of BENCHMARKS.md): where the compute rasterizer's
/// ids differ from the raster pass's off edges, both name the same object,
/// another of its triangles (coplanar triangles seen through the holes, at
/// equal or nearly equal depth, which the two break differently), never
/// another object or the background, and at most 0.05 % of the pixels do:
/// the alpha test decides as the raster passes do. Measured on lavapipe at
/// path frame 120, 640x360: 61 such pixels against the pre-pass raster
/// path, 26 without the pre-pass, none in another object. (Before the id
/// pass after the pre-pass cut masked triangles too, 393 did: a triangle cut
/// away where a coplanar one of its object had left the same depth passed
/// the `Equal` test.)
#[test]
fn masked_sponza_ids_differ_only_between_triangles_of_one_object() {
    if !Path::new(SPONZA).is_dir() {
        eprintln!("SKIPPED: {SPONZA} is absent");
        return;
    }
    let ctx = common::gpu();
    let mut scene = common::load(SPONZA);
    // Disks of radius 6 in cells of 16 texels, about 44 % opaque.
    let inside = |x: u32, y: u32| {
        let (cx, cy) = ((x / 16 * 16 + 8) as f32, (y / 16 * 16 + 8) as f32);
        (x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2) <= 36.0
    };
    let rgba8 = (0..256 * 256).flat_map(|i| [200, 200, 200, if inside(i % 256, i / 256) { 255 } else { 0 }]).collect();
    scene.textures.push(Texture { name: "disks".into(), width: 256, height: 256, rgba8 });
    let disks = scene.textures.len() - 1;
    for m in &mut scene.materials {
        (m.base_color_texture, m.alpha_cutoff) = (Some(disks), Some(0.5));
    }
    let camera = path_camera(SPONZA, &scene, 120);
    let size = (640, 360);
    let compute = ids(&ctx, &scene, &camera, size, VisibilityMethod::Compute);
    for prepass in [true, false] {
        let raster =
            ids_with(&ctx, &scene, std::slice::from_ref(&camera), size, VisibilityMethod::Raster, prepass).remove(0);
        let interior: Vec<usize> = (0..raster.len())
            .filter(|&i| raster[i] != compute[i] && !on_edge(&raster, 640, i) && !on_edge(&compute, 640, i))
            .collect();
        let other_object: Vec<usize> = interior.iter().copied().filter(|&i| raster[i][0] != compute[i][0]).collect();
        eprintln!(
            "pre-pass {prepass}: {} pixels differ off edges, {} of them in another object",
            interior.len(),
            other_object.len()
        );
        let describe =
            |&i: &usize| format!("({}, {}): raster {:?}, compute {:?}", i % 640, i / 640, raster[i], compute[i]);
        let examples: Vec<String> = other_object.iter().take(4).map(describe).collect();
        assert!(other_object.is_empty(), "pre-pass {prepass}: ids name other objects off edges: {examples:?}");
        let share = interior.len() as f64 / raster.len() as f64;
        assert!(share <= 0.0005, "pre-pass {prepass}: {:.3} % of the pixels differ off edges", share * 100.0);
    }
}

/// The camera inside voxel blocks and on a floor (triangles crossing the near
/// plane, which must be clipped, not dropped): same ids as the raster path.
#[test]
fn ids_agree_inside_objects_and_across_the_near_plane() {
    let ctx = common::gpu();
    let voxels = common::load("voxels");
    let base = path_camera("voxels", &voxels, 0);
    let mut views = Vec::new();
    for object in [0, voxels.objects.len() / 2] {
        // Off the centre: from a block's exact centre its edges project onto
        // pixel diagonals, where the two faces' depths tie and rounding alone
        // picks one (35 such pixels of 19200 differ there).
        let inside = voxels.object_bounds(object).center() + Vec3::new(0.13, 0.07, -0.05);
        for forward in [Vec3::X, Vec3::new(0.3, -0.5, 1.0).normalize()] {
            let camera = Camera { position: inside, forward, ..base };
            views.push((format!("inside voxel object {object} facing {forward}"), camera));
        }
    }
    compare_views(&ctx, &voxels, &views, (160, 120));
    // Eye 2 cm above the 8 m floor, near plane 10 cm: the floor's two
    // triangles both cross the near plane (corners lie behind the eye); what
    // is left is a band below the horizon (nearer floor is clipped away).
    let (floor, camera, _) = common::floor_scene();
    let camera =
        Camera { position: Vec3::new(0.3, 0.02, 1.0), forward: Vec3::new(0.1, -0.2, -1.0).normalize(), ..camera };
    let (covered, _) = compare(&ctx, "eye on the floor", &floor, &camera, (160, 120));
    assert!(covered > 160 * 120 / 8, "the floor covers only {covered} pixels");
    // A 2 km floor: its near-clipped corners project far beyond the guard
    // band, so it takes the homogeneous path.
    let mut huge = floor.clone();
    huge.meshes[0] = common::floor_quad(2000.0, 0.0);
    let (covered, _) = compare(&ctx, "eye on a 2 km floor", &huge, &camera, (160, 120));
    assert!(covered > 160 * 120 / 8, "the floor covers only {covered} pixels");
}

/// The counting variant's counts for one frame of the floor seen from
/// straight above (the floor fills the view): every pixel written exactly
/// once by one of its two triangles, both queued as big triangles over the
/// whole 160x120 screen (5 x 4 tiles each), and the back-facing count follows
/// the winding.
#[test]
fn counts_add_up_on_a_floor_filling_the_view() {
    let ctx = common::gpu();
    let (floor, camera, _) = common::floor_scene();
    let camera = Camera { position: Vec3::new(0.2, 2.0, 0.1), forward: Vec3::NEG_Y, up: Vec3::Z, ..camera };
    let (width, height) = (160u32, 120u32);
    let counts = |scene: &Scene| {
        let mut renderer = common::counting_renderer(&ctx, scene, (width, height));
        renderer.render(&ctx, &camera, &[], 0).unwrap();
        let mut counts = std::collections::BTreeMap::new();
        for (_, c) in renderer.collect_counters(&ctx, true) {
            counts.extend(c);
        }
        counts
    };
    let pixels = (width * height) as f64;
    let front = counts(&floor);
    let mut flipped = floor.clone();
    for tri in flipped.meshes[0].indices.chunks_mut(3) {
        tri.swap(1, 2);
    }
    let back = counts(&flipped);
    for c in [&front, &back] {
        assert_eq!(c["vis_pixels_written"], pixels, "{c:?}");
        assert_eq!(c["vis_atomics_per_pixel"], 1.0);
        assert_eq!(c["vis_small_triangles"], 0.0);
        assert_eq!(c["vis_big_triangles"], 2.0);
        assert_eq!(c["vis_big_tiles"], 40.0);
        assert_eq!(c["vis_overflow_triangles"], 0.0);
        // Each triangle's box is the screen; its squares that pass hold at
        // least every pixel it covers, at most the whole screen.
        assert!(c["vis_big_pixels_tested"] >= pixels && c["vis_big_pixels_tested"] <= 2.0 * pixels, "{c:?}");
    }
    let facing = [front["vis_back_facing_writes"], back["vis_back_facing_writes"]];
    assert!(facing == [0.0, pixels] || facing == [pixels, 0.0], "back-facing writes {facing:?}");
}

/// With back faces culled, both rasterizers cull the same triangles: the
/// ids agree on the voxels (closed blocks) and on Sponza, and the floor seen
/// from below (its back) is culled by both while from above it covers the
/// view.
#[test]
fn ids_agree_with_raster_with_back_faces_culled() {
    let ctx = common::gpu();
    let mut voxels = common::load("voxels");
    voxels.set_back_faces(BackFaces::Cull);
    compare(&ctx, "voxels culled, frame 40", &voxels, &path_camera("voxels", &voxels, 40), (256, 144));
    if Path::new(SPONZA).is_dir() {
        let mut sponza = common::load(SPONZA);
        sponza.set_back_faces(BackFaces::Cull);
        compare(&ctx, "sponza culled, frame 100", &sponza, &path_camera(SPONZA, &sponza, 100), (320, 180));
    }
    let (mut floor, camera, _) = common::floor_scene();
    floor.set_back_faces(BackFaces::Cull);
    let above = Camera { position: Vec3::new(0.2, 2.0, 0.1), forward: Vec3::NEG_Y, up: Vec3::Z, ..camera };
    let below = Camera { position: Vec3::new(0.2, -2.0, 0.1), forward: Vec3::Y, up: Vec3::Z, ..camera };
    let (covered, _) = compare(&ctx, "floor culled, from above", &floor, &above, (160, 120));
    assert_eq!(covered, 160 * 120, "the floor's front covers the view");
    for method in VisibilityMethod::ALL {
        let ids = ids(&ctx, &floor, &below, (160, 120), method);
        assert!(ids.iter().all(|id| id[0] == 0), "{method:?}: the floor's back is drawn");
    }
}

/// Renders frame number `frame` of `camera`'s view; its ids and counters.
fn ids_and_counts_of(
    ctx: &GpuContext,
    renderer: &mut Renderer,
    camera: &Camera,
    frame: u64,
) -> (Vec<[u32; 2]>, shadespace::render::Counters) {
    renderer.render(ctx, camera, &[], frame).unwrap();
    let ids = renderer.pipeline::<ObjectSpace>().unwrap().read_mark_state(ctx).unwrap().visibility;
    let counts =
        renderer.collect_counters(ctx, true).into_iter().filter(|(f, _)| *f == frame).flat_map(|(_, c)| c).collect();
    (ids, counts)
}

/// The ids and the rasterizer's counters of `camera`'s view with the load
/// before each pixel's atomic (`Renderer::vis_depth_test`) on, then off,
/// from one renderer culling with `culling` (stateless modes only: both
/// frames draw the same clusters).
fn ids_and_counts(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    size: (u32, u32),
    culling: Culling,
) -> Vec<(Vec<[u32; 2]>, shadespace::render::Counters)> {
    let mut renderer = common::counting_renderer(ctx, scene, size);
    renderer.culling = culling;
    let mut out = Vec::new();
    for (frame, depth_test) in [true, false].into_iter().enumerate() {
        renderer.vis_depth_test = depth_test;
        out.push(ids_and_counts_of(ctx, &mut renderer, camera, frame as u64));
    }
    out
}

/// The load before each pixel's atomicMax skips the atomics that would not
/// win and changes no id: on Sponza (no culling) and down the tiny city's
/// street (frustum culling: the cluster lists' dispatch), the ids with and
/// without it are the same, every covered pixel is either written or
/// rejected (the same total as the atomics without the test), and with it
/// fewer than 3/4 of them issue an atomic (in whatever order the threads
/// run, the first surface drawn at a pixel is written, later ones only where
/// nearer). Neither scene has alpha masks, whose triangles load before their
/// atomic either way.
#[test]
fn depth_test_before_the_atomic_keeps_the_ids_with_fewer_atomics() {
    let ctx = common::gpu();
    let mut views = vec![("city:2 street, frame 4", common::load("city:2"), "city:2", 4, Culling::Frustum)];
    if Path::new(SPONZA).is_dir() {
        views.push(("sponza, frame 100", common::load(SPONZA), SPONZA, 100, Culling::None));
    } else {
        eprintln!("SKIPPED Sponza: {SPONZA} is absent");
    }
    for (name, scene, spec, t, culling) in &views {
        let camera = path_camera(spec, scene, *t);
        let frames = ids_and_counts(&ctx, scene, &camera, (192, 108), *culling);
        let ((ids_on, on), (ids_off, off)) = (&frames[0], &frames[1]);
        let differ = (0..ids_on.len()).filter(|&i| ids_on[i] != ids_off[i]).count();
        assert_eq!(differ, 0, "{name}: the depth test changes {differ} pixels' ids");
        assert!(ids_on.iter().any(|id| id[0] != 0), "{name}: nothing covered");
        let (written, rejects) = (on["vis_pixels_written"], on["vis_depth_rejects"]);
        eprintln!(
            "{name}: atomics per pixel {:.2} without the test, {:.2} with it ({} of {} covered pixels rejected by the load)",
            off["vis_atomics_per_pixel"],
            on["vis_atomics_per_pixel"],
            rejects,
            written + rejects
        );
        assert_eq!(off["vis_depth_rejects"], 0.0, "{name}: loads reject without the test: {off:?}");
        assert_eq!(written + rejects, off["vis_pixels_written"], "{name}: covered pixels differ: {on:?} / {off:?}");
        assert!(written < 0.75 * off["vis_pixels_written"], "{name}: the test skips too few atomics: {on:?}");
    }
}

/// The ids and the rasterizer's counters of one frame of `camera`'s view,
/// with triangles over `small_area` pixels drawn as big by `workgroups`
/// workgroups.
fn ids_drawn_with(
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    size: (u32, u32),
    (small_area, workgroups): (u32, u32),
) -> (Vec<[u32; 2]>, shadespace::render::Counters) {
    let mut renderer = common::counting_renderer(ctx, scene, size);
    renderer.vis_small_area = small_area;
    renderer.vis_big_workgroups = workgroups;
    ids_and_counts_of(ctx, &mut renderer, camera, 0)
}

/// Which triangles count as big (`--vis-small-area`) and how many
/// workgroups draw them (`--vis-big-workgroups`) change no id: on Sponza
/// (alpha masks, fetched once per triangle or tile) and on floors crossing the near plane (fixed-point and
/// homogeneous edges), every triangle drawn by its own thread, the default,
/// and every triangle over 32 pixels drawn as big by 3 workgroups (each
/// looping over many tiles): the same ids, the same covered pixels.
#[test]
fn big_triangle_settings_keep_the_ids() {
    let ctx = common::gpu();
    let (floor, camera, _) = common::floor_scene();
    let on_floor =
        Camera { position: Vec3::new(0.3, 0.02, 1.0), forward: Vec3::new(0.1, -0.2, -1.0).normalize(), ..camera };
    let mut huge = floor.clone();
    huge.meshes[0] = common::floor_quad(2000.0, 0.0);
    let mut views = vec![("eye on the floor", floor, on_floor), ("eye on a 2 km floor", huge, on_floor)];
    if Path::new(SPONZA).is_dir() {
        let sponza = common::load(SPONZA);
        views.push(("sponza, frame 100", sponza.clone(), path_camera(SPONZA, &sponza, 100)));
    } else {
        eprintln!("SKIPPED Sponza: {SPONZA} is absent");
    }
    let covered = |c: &shadespace::render::Counters| c["vis_pixels_written"] + c["vis_depth_rejects"];
    for (name, scene, camera) in &views {
        let size = (192, 108);
        let settings = [(u32::MAX, 1), (256, 32768), (32, 3)];
        let runs: Vec<_> = settings.iter().map(|&s| ids_drawn_with(&ctx, scene, camera, size, s)).collect();
        let (ids, counts) = &runs[1];
        assert!(ids.iter().any(|id| id[0] != 0), "{name}: nothing covered");
        for ((other, other_counts), (small_area, workgroups)) in runs.iter().zip(settings) {
            let differ = (0..ids.len()).filter(|&i| ids[i] != other[i]).count();
            let run = format!("{name}, big above {small_area} pixels, {workgroups} workgroups");
            eprintln!(
                "{run}: {} big triangles, {} tiles",
                other_counts["vis_big_triangles"], other_counts["vis_big_tiles"]
            );
            assert_eq!(differ, 0, "{run}: {differ} pixels' ids differ from the default's");
            if !scene.has_alpha_masks() {
                assert_eq!(covered(other_counts), covered(counts), "{run}: {other_counts:?} / {counts:?}");
            }
        }
        assert_eq!(runs[0].1["vis_big_triangles"], 0.0, "{name}: a big triangle with no limit");
        assert!(
            runs[2].1["vis_big_triangles"] >= counts["vis_big_triangles"],
            "{name}: fewer big triangles over 32 px"
        );
        assert!(counts["vis_big_triangles"] > 0.0, "{name}: no big triangle by default");
    }
}
