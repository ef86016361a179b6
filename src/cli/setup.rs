//! The setup every rendering command shares: the scene, its charts, cameras
//! and lights as the options describe them, and the renderer they configure.

use anyhow::Context;
use glam::Vec3;
use shadespace::bench::BenchSetup;
use shadespace::charts::{self, ChartCache, SceneCharts, TextureSizing};
use shadespace::gpu::{GpuContext, GpuOptions};
use shadespace::render::objectspace::atlas::MAX_TEXTURE_SIZE;
use shadespace::render::objectspace::{DebugView, ExtraViews, GatherInput, MAX_DENSITY_SIZE};
use shadespace::render::{
    ClusteredConfig, DeferredComputeConfig, DeferredConfig, Exposure, ForwardConfig, ForwardMultipassConfig,
    ObjectSpaceConfig, PipelineConfig, RenderOptions, Renderer, VisibilityMethod,
};
use shadespace::scene::bookmarks::BookmarkRef;
use shadespace::scene::free_camera::{LookAt, OrbitSpec};
use shadespace::scene::path::SceneCameras;
use shadespace::scene::{self, Aabb, Camera, CameraPath, Light, Scene, path};

use super::lights::{env_spec, light_set, under_lights};
use super::options::{GpuArgs, ObjectSpaceArgs, PipelineName, SceneArgs, TextureChoice};
use super::parse::Views;
use super::{Failure, input};

/// The scene, its cameras and its lights, as the options describe them.
pub struct Setup {
    pub scene: Scene,
    /// Object space: shading-texture side per object.
    pub texture_sizes: Option<Vec<Option<u32>>>,
    pub path: CameraPath,
    pub camera_label: String,
    pub lights: Vec<Light>,
    pub lights_spec: String,
    /// Object space: views besides the camera's.
    pub extra_views: ExtraViews,
    /// `--exposure`, or its default for how the scene is seen.
    pub exposure: Exposure,
}

/// Loads the scene and builds what the options ask of it (validating the
/// options that depend on one another).
pub fn setup(a: &SceneArgs) -> Result<Setup, Failure> {
    let os = &a.objectspace;
    let (page, tile) = (os.page_size, os.tile_size);
    if !page.is_power_of_two() || page > 4 * tile {
        return input(Err(anyhow::anyhow!(
            "--page-size {page}: expected a power of two at most four times the tile size ({tile})"
        )));
    }
    if os.views.is_some() && a.visibility.0 == Some(VisibilityMethod::Raster) {
        return input(Err(anyhow::anyhow!("--views needs compute visibility, not --visibility raster")));
    }
    if os.views.is_some() && a.msaa > 1 {
        return input(Err(anyhow::anyhow!(
            "--views renders its views at one sample per pixel: not with --msaa {}",
            a.msaa
        )));
    }
    if os.os_gather == GatherInput::Record && (os.views.is_some() || a.msaa > 1) {
        let with = if os.views.is_some() { "--views".to_string() } else { format!("--msaa {}", a.msaa) };
        return input(Err(anyhow::anyhow!(
            "--os-gather record needs one view and one sample per pixel: not with {with}"
        )));
    }
    if os.os_gather == GatherInput::Record && os.os_aniso > 1 {
        return input(Err(anyhow::anyhow!(
            "--os-gather record reads one tap a pixel: not with --os-aniso {}",
            os.os_aniso
        )));
    }
    let mut scene = input(scene::load(&a.scene))?;
    scene.set_back_faces(a.back_faces.faces(a.cull_back_faces));
    if a.textures == TextureChoice::Detailed {
        scene::detail::add_detailed_textures(&mut scene);
    }
    scene::gloss::apply(&mut scene, a.gloss);
    input(shadespace::materials::apply(&mut scene, &a.materials))?;
    for name in &a.objectspace.forward_only {
        let Some(o) = scene.objects.iter_mut().find(|o| &o.name == name) else {
            let known: Vec<_> = scene.objects.iter().map(|o| o.name.as_str()).collect();
            return input(Err(anyhow::anyhow!("--forward-only: no object '{name}' (objects: {})", known.join(", "))));
        };
        o.forward_only = true;
    }
    let bounds = scene.bounds();
    let aspect = a.size.0 as f32 / a.size.1 as f32;
    let cameras = input(path::cameras_for_scene(&a.scene, &scene, aspect))?;
    let (path, camera_label) = camera_path(a, &cameras, &bounds)?;
    let extra_views = match a.objectspace.views {
        None => ExtraViews::None,
        Some(Views::Stereo(eye_distance)) => ExtraViews::Stereo { eye_distance },
        Some(Views::Fixed) => {
            let own = match a.camera.parse() {
                Ok(path::CameraChoice::Fixed(k)) => Some(k),
                _ => None,
            };
            let others = cameras.fixed.iter().enumerate().filter(|(k, _)| Some(*k) != own).map(|(_, c)| *c);
            ExtraViews::Cameras(others.collect())
        }
    };
    let (lights, lights_spec) = light_set(a, &cameras, &bounds, &path)?;
    let env = env_spec(a, &cameras.source);
    scene.environment = under_lights(input(env.load())?, &lights);
    let (scene, texture_sizes) = if a.pipeline == PipelineName::Objectspace {
        // Textures follow the screen along the path and in the extra views.
        let mut views = charts::path_cameras(&path);
        if let ExtraViews::Cameras(others) = &extra_views {
            views.extend(others);
        }
        let (charted, charts) = chart(&scene, &a.objectspace, &views, a.size)?;
        (charted, Some(charts.texture_sizes()))
    } else {
        (scene, None)
    };
    let exposure =
        a.exposure.unwrap_or(if cameras.source.seen_from_outside() { Exposure::Auto } else { Exposure::default() });
    Ok(Setup { scene, texture_sizes, path, camera_label, lights, lights_spec, extra_views, exposure })
}

/// The camera path the options ask for, and its label for reports: a free
/// camera (`--eye`, `--orbit`) or one of the scene's (`--camera`).
fn camera_path(a: &SceneArgs, cameras: &SceneCameras, bounds: &Aabb) -> Result<(CameraPath, String), Failure> {
    let f = &a.free_camera;
    let fov = f.fov;
    if let (Some(eye), Some(target)) = (f.eye, f.target) {
        let camera = LookAt { eye, target, fov_deg: fov }.camera(bounds);
        let camera = input(camera.context("--eye, --target"))?;
        let label = format!("eye {} target {} fov {fov}", xyz(eye), xyz(target));
        return Ok((CameraPath::Fixed(camera), label));
    }
    if let Some(o) = f.orbit {
        let spec = OrbitSpec { radius: o.radius, height: o.height, frames: o.frames, target: f.target, fov_deg: fov };
        let turntable = input(spec.turntable(bounds).context("--orbit"))?;
        let label = format!("orbit {},{},{} target {} fov {fov}", o.radius, o.height, o.frames, xyz(turntable.target));
        return Ok((CameraPath::Turntable(turntable), label));
    }
    if let Some(mark) = input(BookmarkRef::from_camera_arg(&a.camera).context("--camera"))? {
        let look = input(mark.find().context("--camera"))?;
        let camera = input(look.camera(bounds).with_context(|| format!("--camera {mark}")))?;
        return Ok((CameraPath::Fixed(camera), a.camera.clone()));
    }
    let choice: path::CameraChoice = input(a.camera.parse().context("--camera"))?;
    Ok((input(cameras.select(choice).context("--camera"))?, a.camera.clone()))
}

fn xyz(v: Vec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

impl Setup {
    /// The run's description for a [`shadespace::bench::RunReport`].
    pub fn bench_setup<'a>(&'a self, a: &SceneArgs) -> BenchSetup<'a> {
        BenchSetup {
            scene_name: &self.scene.name,
            objects: self.scene.objects.len(),
            lights_spec: &self.lights_spec,
            seed: a.seed,
            camera: &self.camera_label,
        }
    }
}

/// Renderer options from the command line, for object space the texture
/// sizes the charts gave, and for `--visibility auto` the adapter's features.
pub fn render_options(a: &SceneArgs, s: &Setup, view: DebugView, features: wgpu::Features) -> RenderOptions {
    let visibility = a.visibility.0.unwrap_or_else(|| VisibilityMethod::preferred_for(features, a.msaa));
    let pipeline = match a.pipeline {
        PipelineName::Forward => PipelineConfig::Forward(ForwardConfig { depth_prepass: !a.no_depth_prepass }),
        PipelineName::ForwardMultipass => PipelineConfig::ForwardMultipass(ForwardMultipassConfig::default()),
        PipelineName::Clustered => PipelineConfig::Clustered(ClusteredConfig::default()),
        PipelineName::Objectspace => PipelineConfig::ObjectSpace(ObjectSpaceConfig {
            tile_size: a.objectspace.tile_size,
            reuse: match a.objectspace.shade_hz {
                Some(hz) => (a.objectspace.frame_hz / hz).round().max(1.0) as u32,
                None => a.objectspace.reuse,
            },
            spread_reshading: a.objectspace.shade_hz.is_some(),
            page_size: a.objectspace.page_size,
            mip_bias: a.objectspace.mip_bias,
            shade_budget_texels: a.objectspace.shade_budget.map(|m| (m * 1.0e6) as u64),
            variable_rate: a.objectspace.variable_rate,
            level_blend: a.objectspace.level_blend,
            view,
            texture_sizes: s.texture_sizes.clone().unwrap_or_default(),
            extra_views: s.extra_views.clone(),
            atlas_budget_texels: a.objectspace.atlas_budget.map(|m| m << 20),
            visibility_prepass: !a.objectspace.no_visibility_prepass,
            visibility,
            count_visibility: a.count_visibility,
            marking: a.objectspace.marking,
            count_mark_atomics: a.objectspace.count_marks,
            paging_chain: a.objectspace.os_paging,
            trimap_lanes: a.objectspace.os_trimap_lanes,
            trimap_store: a.objectspace.os_trimap_store,
            trimap_search: a.objectspace.os_trimap_search,
            trimap_grid: a.objectspace.os_trimap_grid,
            trimap_share: a.objectspace.os_trimap_share,
            gather_input: a.objectspace.os_gather,
            gather_filter: a.objectspace.os_filter,
            aniso: a.objectspace.os_aniso,
            msaa_gather: a.objectspace.os_msaa_gather,
            texel_samples: a.objectspace.os_texel_samples,
            ..Default::default()
        }),
        PipelineName::Deferred => PipelineConfig::Deferred(DeferredConfig { depth_prepass: !a.no_depth_prepass }),
        PipelineName::DeferredCompute => PipelineConfig::DeferredCompute(DeferredComputeConfig {
            depth_prepass: !a.no_depth_prepass,
            visibility,
            count_visibility: a.count_visibility,
            tile: a.dc_tile,
        }),
    };
    RenderOptions { width: a.size.0, height: a.size.1, pipeline, samples: a.msaa }
}

/// The texture sizing per object the options ask for: `--texture-size`,
/// `--texel-density`, or by default sides that follow the screen: the most
/// pixels per metre each object can cover in `views` at `size`
/// ([`charts::screen`]).
fn sizings(
    scene: &Scene,
    a: &ObjectSpaceArgs,
    views: &[Camera],
    size: (u32, u32),
) -> Result<Vec<TextureSizing>, Failure> {
    let uniform = |s: TextureSizing| Ok(vec![s; scene.objects.len()]);
    match (a.texture_size, a.texel_density) {
        (Some(size), _) if size.is_power_of_two() && (8..=MAX_TEXTURE_SIZE).contains(&size) => {
            uniform(TextureSizing::Fixed(size))
        }
        (Some(size), _) => {
            input(Err(anyhow::anyhow!("--texture-size {size} is not a power of two from 8 to {MAX_TEXTURE_SIZE}")))
        }
        // The value parser has checked the density.
        (None, Some(d)) => uniform(TextureSizing::Density { texels_per_metre: d, min: 64, max: MAX_DENSITY_SIZE }),
        (None, None) => Ok(charts::screen_sizings(scene, views, size.0, size.1, 64, MAX_DENSITY_SIZE)),
    }
}

/// Charts every object shaded in object space, its texture sized for
/// `views` at `size` unless the options fix the sizes; returns the scene
/// with its charts in `uv1` and the charts (texture sizes, sources).
pub fn chart(
    scene: &Scene,
    a: &ObjectSpaceArgs,
    views: &[Camera],
    size: (u32, u32),
) -> Result<(Scene, SceneCharts), Failure> {
    let sizings = sizings(scene, a, views, size)?;
    let settings = charts::ChartSettings::default();
    let charts =
        charts::chart_scene_sized(scene, &sizings, &charts::PACKING_SIZING, &settings, &ChartCache::from_env())?;
    Ok((charts.apply(scene), charts))
}

/// The GPU `--adapter` names (or the fastest one).
pub fn open_gpu(a: &GpuArgs) -> Result<GpuContext, Failure> {
    Ok(GpuContext::new(&GpuOptions { adapter: a.adapter.clone() })?)
}

/// The renderer for `options`; an option the adapter or pipeline cannot do
/// (`--msaa` included) is the input's fault (exit status 2).
pub fn new_renderer(ctx: &GpuContext, scene: &Scene, options: &RenderOptions) -> Result<Renderer, Failure> {
    Renderer::new(ctx, scene, options)
        .map_err(|e| if e.is_bad_option() { Failure::Input(e.into()) } else { Failure::Other(e.into()) })
}

/// The renderer settings the scene options choose (besides the pipeline).
pub fn configure(renderer: &mut Renderer, a: &SceneArgs, s: &Setup) {
    renderer.exposure = s.exposure;
    renderer.bloom = a.bloom;
    renderer.shadow_refresh = a.shadow_refresh;
    renderer.sun_shadow = a.sun_shadow;
    renderer.shading = a.shading;
    renderer.texture_anisotropy = a.aniso;
    if let Some(culling) = a.culling {
        renderer.culling = culling;
    }
    renderer.cluster_draws = a.cluster_draws;
    renderer.vis_depth_test = a.vis_depth_test;
    renderer.vis_small_area = a.vis_small_area;
    if let Some(n) = a.vis_big_workgroups {
        renderer.vis_big_workgroups = n;
    }
    renderer.cull_plain_above = a.cull_plain_above;
}
