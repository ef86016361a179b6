//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod gltf;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{LazyLock, Mutex};

use glam::{Mat4, Vec2, Vec3, Vec4};
use shadespace::gpu::{GpuContext, GpuOptions};
use shadespace::scene::{Camera, Light, LightKind, Material, Mesh, Object, Scene, checker};

/// Devices the tests share, as many as the test threads CI runs (its two
/// cores): lavapipe runs each device's work, and compiles each shader the
/// first time it runs, on that device's one queue thread, so with a single
/// device two tests wait on each other's shader compiles.
const DEVICES: usize = 2;

/// The GPU context of a test: each test thread (libtest runs each test on
/// its own) takes the shared device that the fewest running tests hold, of
/// [`DEVICES`], and keeps it until its thread ends, so a test's resources all
/// live on one device and a compute pipeline is compiled once per device
/// (`gpu::pipelines`), not in every test. Taking devices in turn instead
/// left one device's queue thread with three long tests and the other idle
/// at times: the cores then stood half idle. Panics when none can be opened
/// (CI installs lavapipe first, so "no adapter" is a real failure, not a
/// skip). Tests running at once on one device share its validation errors:
/// one that calls `check_errors` may report another's, so the suite still
/// fails.
pub fn gpu() -> GpuContext {
    static SHARED: [LazyLock<GpuContext>; DEVICES] = [const { LazyLock::new(open) }; DEVICES];
    static HOLDERS: Mutex<[usize; DEVICES]> = Mutex::new([0; DEVICES]);
    /// A test thread's hold on one device, given up when the thread ends.
    struct Hold(usize);
    impl Drop for Hold {
        fn drop(&mut self) {
            HOLDERS.lock().unwrap_or_else(|e| e.into_inner())[self.0] -= 1;
        }
    }
    thread_local! {
        static MINE: Hold = {
            let mut holders = HOLDERS.lock().unwrap_or_else(|e| e.into_inner());
            let least = (0..DEVICES).min_by_key(|&i| holders[i]).unwrap_or(0);
            holders[least] += 1;
            Hold(least)
        };
    }
    MINE.with(|hold| SHARED[hold.0].clone())
}

fn open() -> GpuContext {
    GpuContext::new(&GpuOptions::default()).unwrap_or_else(|e| panic!("cannot open a GPU adapter: {e}"))
}

/// Where tests write images (actual, difference) for inspection.
pub fn out_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("images");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A quad of `size` metres on the XZ plane at height `y`, facing up, with a
/// unique chart (uv1) filling the unit square.
pub fn floor_quad(size: f32, y: f32) -> Mesh {
    let h = size / 2.0;
    let positions = vec![Vec3::new(-h, y, -h), Vec3::new(h, y, -h), Vec3::new(h, y, h), Vec3::new(-h, y, h)];
    let uv = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    let mut mesh = Mesh {
        name: "floor".into(),
        positions,
        normals: vec![Vec3::Y; 4],
        uv0: uv.iter().map(|u| *u * size).collect(),
        uv1: Some(uv),
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    };
    mesh.generate_missing_attributes();
    mesh
}

/// A small scene: a textured floor with a few point lights above it.
pub fn floor_scene() -> (Scene, Camera, Vec<Light>) {
    let scene = Scene {
        name: "floor".into(),
        meshes: vec![floor_quad(8.0, 0.0)],
        materials: vec![Material { base_color_texture: Some(0), ..Default::default() }],
        textures: vec![checker::uv_checker("floor", checker::object_tint(0), 64, 8)],
        objects: vec![Object {
            name: "floor".into(),
            mesh: 0,
            material: 0,
            transform: Mat4::IDENTITY,
            forward_only: false,
        }],
        ..Default::default()
    };
    let camera = Camera {
        position: Vec3::new(0.0, 4.0, 6.0),
        forward: (Vec3::ZERO - Vec3::new(0.0, 4.0, 6.0)).normalize(),
        up: Vec3::Y,
        fov_y: 60f32.to_radians(),
        near: 0.1,
        far: 100.0,
    };
    let point = |x: f32, z: f32, color: Vec3| Light {
        kind: LightKind::Point,
        color,
        intensity: 4.0,
        position: Vec3::new(x, 1.0, z),
        direction: Vec3::NEG_Y,
        radius: 4.0,
        cos_inner: 0.9,
        cos_outer: 0.8,
        casts_shadows: false,
    };
    let lights = vec![
        Light { kind: LightKind::Ambient, color: Vec3::ONE, intensity: 0.05, ..point(0.0, 0.0, Vec3::ONE) },
        point(-2.0, 0.0, Vec3::new(1.0, 0.3, 0.2)),
        point(2.0, 1.0, Vec3::new(0.2, 0.5, 1.0)),
    ];
    let _ = Vec4::ONE;
    (scene, camera, lights)
}

/// Charts `scene` as the CLI does with `--texel-density 256` (uv1 set on
/// every mesh) and returns it with the shading-texture sizes. Chart generation is
/// cached under the test target folder.
pub fn charted(scene: &Scene) -> (Scene, Vec<Option<u32>>) {
    use shadespace::charts::{self, ChartCache, TextureSizing};
    let cache = ChartCache::in_dir(Path::new(env!("CARGO_TARGET_TMPDIR")).join("charts"));
    let sizing = TextureSizing::Density { texels_per_metre: 256.0, min: 64, max: 8192 };
    let c = charts::chart_scene(scene, &sizing, &cache).unwrap();
    (c.apply(scene), c.texture_sizes())
}

/// Per object of `scene`, the chart island of each triangle of its mesh
/// (what the GPU's `triangle_charts` holds), for the CPU twins.
pub fn chart_islands(scene: &Scene) -> Vec<Vec<u32>> {
    use shadespace::charts::islands::triangle_islands;
    use shadespace::render::objectspace::cpu::chart_uvs;
    scene
        .objects
        .iter()
        .map(|o| {
            let mesh = &scene.meshes[o.mesh];
            triangle_islands(&mesh.indices, chart_uvs(mesh))
        })
        .collect()
}

/// Charts `scene` as the CLI does by default for `camera` at
/// `width`x`height`: each object's texture sized for the most pixels per
/// metre the camera shows it at (generated charts packed as the CLI packs
/// them), cached as [`charted`] caches.
pub fn charted_for(scene: &Scene, camera: &Camera, width: u32, height: u32) -> (Scene, Vec<Option<u32>>) {
    use shadespace::charts::{self, ChartCache, ChartSettings};
    let cache = ChartCache::in_dir(Path::new(env!("CARGO_TARGET_TMPDIR")).join("charts"));
    let sizings = charts::screen_sizings(scene, &[*camera], width, height, 64, 8192);
    let settings = ChartSettings::default();
    let c = charts::chart_scene_sized(scene, &sizings, &charts::PACKING_SIZING, &settings, &cache).unwrap();
    (c.apply(scene), c.texture_sizes())
}

/// A scene seen from its camera path's frame 0, lit by a light spec placed
/// for that camera at `width`x`height` (seed 7): what the agreement and
/// golden tests render.
pub struct PathFrame {
    pub scene: Scene,
    pub camera: Camera,
    pub lights: Vec<Light>,
}

/// Loads `name` (a procedural scene or a path) as a [`PathFrame`] lit by `spec`.
/// `scene::load(name)` (a generated scene's name or a path), loaded once per
/// test process and cloned: the tests draw the same few scenes dozens of
/// times, and parsing Sponza or generating the atrium or the city each time
/// cost the suite about half a minute of CPU.
pub fn load(name: &str) -> Scene {
    static LOADED: LazyLock<Mutex<HashMap<String, Scene>>> = LazyLock::new(Default::default);
    if let Some(scene) = LOADED.lock().unwrap_or_else(|e| e.into_inner()).get(name) {
        return scene.clone();
    }
    // Loaded outside the lock: two tests loading one scene at once load it twice.
    let scene = shadespace::scene::load(name).unwrap_or_else(|e| panic!("cannot load {name}: {e}"));
    LOADED.lock().unwrap_or_else(|e| e.into_inner()).entry(name.to_string()).or_insert_with(|| scene.clone());
    scene
}

pub fn path_frame(name: &str, spec: &str, width: u32, height: u32) -> PathFrame {
    path_frame_seeded(name, spec, width, height, 7)
}

/// As [`path_frame`], with the lights placed from `seed`.
pub fn path_frame_seeded(name: &str, spec: &str, width: u32, height: u32, seed: u64) -> PathFrame {
    use shadespace::scene::{LightSpec, lights, path};
    let scene = load(name);
    let bounds = scene.bounds();
    let cameras = path::cameras_for_scene(name, &scene, width as f32 / height as f32).unwrap();
    let camera = cameras.select(path::CameraChoice::Path).unwrap().camera_at(0);
    let spec: LightSpec = spec.parse().unwrap();
    let lights = lights::build_lights(&spec, &bounds, &camera, width as f32 / height as f32, seed).unwrap();
    PathFrame { scene, camera, lights }
}

/// `count` cameras along `name`'s path, 12 frames apart from frame 0, and
/// the lights `spec` places for the first at `aspect` (seed 7): the views
/// the marking and paging tests step through.
pub fn path_views(name: &str, scene: &Scene, aspect: f32, count: u32, spec: &str) -> (Vec<Camera>, Vec<Light>) {
    use shadespace::scene::{LightSpec, lights, path};
    let path = path::cameras_for_scene(name, scene, aspect).unwrap().select(path::CameraChoice::Path).unwrap();
    let cameras: Vec<Camera> = (0..count).map(|f| path.camera_at(f * 12)).collect();
    let spec: LightSpec = spec.parse().unwrap();
    let lights = lights::build_lights(&spec, &scene.bounds(), &cameras[0], aspect, 7).unwrap();
    (cameras, lights)
}

/// An image that several tests compare against (a forward reference of a
/// path frame, say), rendered once per test process by whichever test asks
/// first and shared with the others: the suite is one binary, so a frame
/// that several tests need is not rendered again. `key` must name every
/// input of `render`; tests asking for a key being rendered wait for it.
pub fn rendered_once(key: &str, render: impl FnOnce() -> image::RgbaImage) -> image::RgbaImage {
    use std::collections::HashMap;
    use std::sync::{Arc, LazyLock, Mutex, OnceLock};
    type Images = Mutex<HashMap<String, Arc<OnceLock<image::RgbaImage>>>>;
    static IMAGES: LazyLock<Images> = LazyLock::new(Default::default);
    let slot = IMAGES.lock().unwrap_or_else(|e| e.into_inner()).entry(key.to_string()).or_default().clone();
    slot.get_or_init(render).clone()
}

/// Every pipeline with its default configuration, forward first; object
/// space with `texture_sizes` (from [`charted`]).
pub fn every_pipeline(texture_sizes: Vec<Option<u32>>) -> Vec<shadespace::render::PipelineConfig> {
    use shadespace::render::*;
    vec![
        PipelineConfig::Forward(ForwardConfig::default()),
        PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineConfig::Deferred(DeferredConfig::default()),
        PipelineConfig::DeferredCompute(DeferredComputeConfig::default()),
        PipelineConfig::ObjectSpace(ObjectSpaceConfig { texture_sizes, ..Default::default() }),
    ]
}

/// An object-space renderer of `scene` at `size` with compute visibility
/// that counts its rasterizer's work; only the first object is in the atlas
/// (the ids need no charts: the others are shaded forward).
pub fn counting_renderer(ctx: &GpuContext, scene: &Scene, size: (u32, u32)) -> shadespace::render::Renderer {
    use shadespace::render::passes::visibility::VisibilityMethod;
    use shadespace::render::{ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer};
    let mut texture_sizes = vec![None; scene.objects.len()];
    texture_sizes[0] = Some(64);
    let config = ObjectSpaceConfig {
        texture_sizes,
        visibility: VisibilityMethod::Compute,
        count_visibility: true,
        ..Default::default()
    };
    let options = RenderOptions::new(size.0, size.1, PipelineConfig::ObjectSpace(config));
    Renderer::new(ctx, scene, &options).unwrap()
}
