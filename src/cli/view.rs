//! `shadespace view` (feature `viewer`): the command line's side of the
//! viewer. The viewer's [`Session`] is answered with the functions `render`
//! itself uses (`setup`, `render_options`, `configure`), so that a frame in
//! the window and `render` with the same options match.

use std::path::PathBuf;
use std::str::FromStr;

use clap::{Args, ValueEnum};
use shadespace::gpu::{GpuContext, GpuOptions};
use shadespace::render::objectspace::atlas_view::AtlasPages;
use shadespace::render::objectspace::{DebugView, MAX_ATLAS_BUDGET_MI};
use shadespace::render::{Exposure, Renderer};
use shadespace::scene::environment::{EnvSpec, Environment};
use shadespace::scene::{Aabb, CameraPath, Light, LightSpec, path};
use shadespace::viewer::camera::look_at_args;
use shadespace::viewer::script::Script;
use shadespace::viewer::settings::{ObjectSpaceSettings, Settings, exposure_arg};
use shadespace::viewer::{self, Session, ViewCamera, ViewerOptions};

use super::lights::{env_spec, light_set, under_lights};
use super::options::{PipelineName, SceneArgs};
use super::output::shell_quote;
use super::parse::{mip_bias, on_off, shade_budget, texel_density, tile_size, variable_rate};
use super::setup::{Setup, configure, render_options, setup};
use super::{Failure, input};

/// `view`'s options: the scene's, then the viewer's.
#[derive(Args)]
pub struct ViewArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Object space: the debug view shown first (`shade`, `chart-uv`,
    /// `mip-level`, `tile-mask`, `cache-age`, `atlas-pages`; the panel switches it).
    #[arg(help_heading = "Viewer", long, default_value = "shade", value_parser = DebugView::from_str)]
    view: DebugView,
    /// Object space, `--view atlas-pages`: the object shown first (index, see
    /// `shadespace charts`; the panel switches it).
    #[arg(help_heading = "Viewer", long, default_value_t = 0)]
    atlas_object: usize,
    /// Object space, `--view atlas-pages`: the mip level shown first.
    #[arg(help_heading = "Viewer", long, default_value_t = 0)]
    atlas_level: usize,
    /// `on`: wait for the display's refresh; `off`: present at once.
    #[arg(help_heading = "Viewer", long, default_value = "on", value_parser = on_off, action = clap::ArgAction::Set)]
    vsync: bool,
    /// Play this script (JSON: camera moves and option changes, see
    /// `viewer::script`), then exit.
    #[arg(help_heading = "Viewer", long)]
    script: Option<PathBuf>,
    /// Render this many frames (after the script), then exit.
    #[arg(help_heading = "Viewer", long)]
    frames: Option<u32>,
    /// Start with the control panel hidden (F1 shows it).
    #[arg(help_heading = "Viewer", long)]
    hide_ui: bool,
    /// No window: run the same frame loop, painting the panel into an
    /// offscreen texture of `--size` (needs `--frames` or `--script`). For
    /// machines without a display, e.g. to compare the viewer's GPU times
    /// with `bench` there (`--report`).
    #[arg(help_heading = "Viewer", long)]
    headless: bool,
    /// Save the last frame here (PNG, and a JSON sidecar beside it) and exit.
    #[arg(help_heading = "Viewer", long)]
    screenshot: Option<PathBuf>,
    /// Write the frame count, renderer builds and host memory (RSS at the
    /// start, after the first frame and at the end) here as JSON.
    #[arg(help_heading = "Viewer", long)]
    report: Option<PathBuf>,
    /// The bookmark file the panel saves to and loads from (JSON; `render`
    /// and `bench` read a view from it with `--camera bookmark:FILE:NAME`).
    #[arg(help_heading = "Viewer", long, default_value = "shadespace-bookmarks.json")]
    bookmarks: PathBuf,
}

/// The viewer's flags, which `render` does not take: left out of the
/// equivalent `render` command.
const VIEWER_FLAGS: [&str; 7] =
    ["--view", "--vsync", "--script", "--frames", "--screenshot", "--report", "--bookmarks"];
/// The viewer's flags without a value, left out of the `render` command too.
const VIEWER_SWITCHES: [&str; 2] = ["--hide-ui", "--headless"];
/// Flags the viewer's settings replace in the `render` command.
const SETTING_FLAGS: [&str; 15] = [
    "--pipeline",
    "--lights",
    "--seed",
    "--env",
    "--exposure",
    "--tile-size",
    "--reuse",
    "--mip-bias",
    "--variable-rate",
    "--texel-density",
    "--shade-budget",
    "--atlas-budget",
    "--texture-size",
    "--atlas-object",
    "--atlas-level",
];
/// The camera flags a free camera replaces.
const CAMERA_FLAGS: [&str; 5] = ["--camera", "--eye", "--target", "--orbit", "--fov"];
/// The decoupled-rate flags, replaced once the panel sets `--reuse` itself.
const RATE_FLAGS: [&str; 2] = ["--shade-hz", "--frame-hz"];
/// Where the panel's density slider starts when texture sizes follow the
/// screen (no `--texel-density`): the former default; moving it sizes every
/// object at the density it shows.
const PANEL_TEXEL_DENSITY: f32 = 256.0;

/// Opens the window (or runs headless) and prints the run's report.
pub fn run(a: ViewArgs) -> Result<(), Failure> {
    if a.headless && a.script.is_none() && a.frames.is_none() {
        let why = "--headless needs --frames or --script: without a window nothing else ends the run";
        return input(Err(anyhow::anyhow!(why)));
    }
    let session = ViewSession::new(&a.scene)?;
    let settings = Settings {
        atlas_pages: AtlasPages { object: a.atlas_object, level: a.atlas_level },
        ..session.initial_settings(a.view)
    };
    let script = a.script.as_deref().map(Script::load).transpose().map_err(Failure::Input)?;
    let options = ViewerOptions {
        settings,
        size: a.scene.size,
        vsync: a.vsync,
        script,
        frames: a.frames,
        hide_ui: a.hide_ui,
        headless: a.headless,
        screenshot: a.screenshot,
        report: a.report,
        bookmarks: a.bookmarks,
        gpu: GpuOptions { adapter: a.scene.gpu.adapter.clone() },
    };
    let report = viewer::run(Box::new(session), options)?;
    println!(
        "{} frames, {} renderer builds; host memory (RSS): {} KiB at the start, {} KiB after the first frame, {} KiB at the end",
        report.frames, report.renderer_builds, report.rss_kib_start, report.rss_kib_first_frame, report.rss_kib_end
    );
    if !report.gpu_pass_ms.is_empty() {
        let total: f64 = report.gpu_pass_ms.iter().map(|(_, ms)| ms).sum();
        let passes: Vec<String> = report.gpu_pass_ms.iter().map(|(name, ms)| format!("{name} {ms:.3}")).collect();
        // Over the frames whose timings came back (read without waiting).
        println!(
            "GPU medians of the last {} frames at most: {total:.3} ms in passes ({})",
            viewer::timings::HISTORY_FRAMES,
            passes.join(", ")
        );
    }
    Ok(())
}

/// The options as typed, and the scenes built from them so far.
struct ViewSession {
    base: SceneArgs,
    /// The scene options as typed (the words after `view`).
    words: Vec<String>,
    /// The last setup without charts and the last with them (keyed by the
    /// texel density): switching pipelines reuses them instead of loading
    /// and charting the scene again.
    plain: Option<Setup>,
    charted: Option<(Option<u32>, Setup)>,
    path: CameraPath,
    bounds: Aabb,
    cameras: path::SceneCameras,
    pipelines: Vec<&'static str>,
    object_names: Vec<String>,
    /// `--exposure`, or its default for how the scene is seen (as `render`).
    exposure: Exposure,
    /// The panel's environments: `none`, `sky`, and the command line's file.
    environments: Vec<String>,
    /// The last environment loaded (a file is read once, not per renderer).
    environment: Option<(EnvSpec, Option<Environment>)>,
}

impl ViewSession {
    fn new(a: &SceneArgs) -> Result<Self, Failure> {
        let s = setup(a)?;
        let bounds = s.scene.bounds();
        let aspect = a.size.0 as f32 / a.size.1 as f32;
        let cameras = input(path::cameras_for_scene(&a.scene, &s.scene, aspect))?;
        let mut environments = vec![EnvSpec::None.to_string(), EnvSpec::Sky.to_string()];
        if let Some(file @ EnvSpec::File(_)) = &a.env {
            environments.push(file.to_string());
        }
        let mut session = Self {
            base: a.clone(),
            words: std::env::args().skip_while(|w| w != "view").skip(1).collect(),
            plain: None,
            charted: None,
            path: s.path.clone(),
            bounds,
            cameras,
            pipelines: PipelineName::value_variants().iter().map(|p| p.name()).collect(),
            object_names: s.scene.objects.iter().map(|o| o.name.clone()).collect(),
            exposure: s.exposure,
            environments,
            environment: None,
        };
        session.keep(a, s);
        Ok(session)
    }

    /// The settings of the command line.
    fn initial_settings(&self, view: DebugView) -> Settings {
        let (a, os) = (&self.base, &self.base.objectspace);
        Settings {
            pipeline: a.pipeline.name().to_string(),
            // `auto` as the set it stands for, so that the panel offers its kind and count.
            lights: a
                .lights
                .parse::<LightSpec>()
                .map_or(a.lights.clone(), |spec| spec.resolve(&self.cameras.source).to_string()),
            seed: a.seed,
            env: env_spec(a, &self.cameras.source).to_string(),
            exposure: self.exposure,
            view,
            atlas_pages: AtlasPages::default(),
            objectspace: ObjectSpaceSettings {
                tile_size: os.tile_size,
                reuse: os.shade_hz.map_or(os.reuse, |hz| (os.frame_hz / hz).round().max(1.0) as u32),
                mip_bias: os.mip_bias,
                variable_rate: os.variable_rate,
                // The slider's start when the sizes follow the screen.
                texel_density: os.texel_density.unwrap_or(PANEL_TEXEL_DENSITY),
                shade_budget: os.shade_budget,
                atlas_budget: os.atlas_budget,
            },
        }
    }

    /// The command line's options with `settings` in place (checked as the
    /// command line checks them).
    fn args_for(&self, settings: &Settings) -> anyhow::Result<SceneArgs> {
        let mut a = self.base.clone();
        a.pipeline = PipelineName::from_str(&settings.pipeline, false)
            .map_err(|_| anyhow::anyhow!("no pipeline '{}' ({})", settings.pipeline, self.pipelines.join(", ")))?;
        a.lights = settings.lights.clone();
        a.seed = settings.seed;
        a.env = Some(checked(settings.env.parse())?);
        a.exposure = Some(settings.exposure);
        let (os, wanted) = (&mut a.objectspace, &settings.objectspace);
        os.tile_size = checked(tile_size(&wanted.tile_size.to_string()))?;
        if wanted.reuse != self.initial_settings(settings.view).objectspace.reuse {
            anyhow::ensure!(wanted.reuse >= 1, "reuse {} is not at least 1", wanted.reuse);
            (os.reuse, os.shade_hz) = (wanted.reuse, None);
        }
        os.mip_bias = checked(mip_bias(&wanted.mip_bias.to_string()))?;
        os.variable_rate = checked(variable_rate(&wanted.variable_rate.to_string()))?;
        if let Some(m) = wanted.atlas_budget {
            anyhow::ensure!(
                (1..=MAX_ATLAS_BUDGET_MI).contains(&m),
                "atlas budget {m} Mi texels is not from 1 to 16384"
            );
        }
        os.atlas_budget = wanted.atlas_budget;
        os.shade_budget = wanted.shade_budget.map(|m| checked(shade_budget(&m.to_string()))).transpose()?;
        // A density set in the panel replaces the command line's sizing.
        if wanted.texel_density != self.initial_settings(settings.view).objectspace.texel_density {
            os.texel_density = Some(checked(texel_density(&wanted.texel_density.to_string()))?);
            os.texture_size = None;
        }
        Ok(a)
    }

    /// Keeps a setup for the next renderers of its kind.
    fn keep(&mut self, a: &SceneArgs, s: Setup) {
        if s.texture_sizes.is_some() {
            self.charted = Some((a.objectspace.texel_density.map(f32::to_bits), s));
        } else {
            self.plain = Some(s);
        }
    }

    /// The environment of `a` (its `--env` loaded, or the last one again).
    fn environment_for(&mut self, a: &SceneArgs) -> Result<Option<Environment>, Failure> {
        let spec = env_spec(a, &self.cameras.source);
        match &self.environment {
            Some((loaded, env)) if *loaded == spec => Ok(env.clone()),
            _ => {
                let env = input(spec.load())?;
                self.environment = Some((spec, env.clone()));
                Ok(env)
            }
        }
    }

    /// The setup (scene, charts) for `a`, built only if no kept one fits.
    fn setup_for(&mut self, a: &SceneArgs) -> Result<&mut Setup, Failure> {
        let charted = a.pipeline == PipelineName::Objectspace;
        let density = a.objectspace.texel_density.map(f32::to_bits);
        let fits =
            if charted { self.charted.as_ref().is_some_and(|(d, _)| *d == density) } else { self.plain.is_some() };
        if !fits {
            // Drop the old one first: two charted scenes at once would double the peak.
            if charted {
                self.charted = None;
            }
            let s = setup(a)?;
            self.keep(a, s);
        }
        Ok(if charted { &mut self.charted.as_mut().expect("kept").1 } else { self.plain.as_mut().expect("kept") })
    }
}

impl Session for ViewSession {
    fn pipelines(&self) -> &[&'static str] {
        &self.pipelines
    }

    fn object_names(&self) -> &[String] {
        &self.object_names
    }

    fn environments(&self) -> &[String] {
        &self.environments
    }

    fn renderer(&mut self, ctx: &GpuContext, settings: &Settings) -> anyhow::Result<Renderer> {
        let a = self.args_for(settings)?;
        let env = self.environment_for(&a).map_err(Failure::into_error)?;
        let lights = light_set(&a, &self.cameras, &self.bounds, &self.path).map_err(Failure::into_error)?.0;
        let s = self.setup_for(&a).map_err(Failure::into_error)?;
        // A kept scene takes the environment asked for now.
        s.scene.environment = under_lights(env, &lights);
        let mut renderer = Renderer::new(ctx, &s.scene, &render_options(&a, s, settings.view, ctx.device.features()))?;
        configure(&mut renderer, &a, s);
        // A kept setup holds the exposure of the options it was built for.
        renderer.exposure = settings.exposure;
        Ok(renderer)
    }

    fn lights(&mut self, settings: &Settings) -> anyhow::Result<Vec<Light>> {
        let a = self.args_for(settings)?;
        Ok(light_set(&a, &self.cameras, &self.bounds, &self.path).map_err(Failure::into_error)?.0)
    }

    fn path(&self) -> &CameraPath {
        &self.path
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn render_command(&self, settings: &Settings, camera: &ViewCamera) -> String {
        let free = !matches!(camera, ViewCamera::PathFrame(_));
        let initial = self.initial_settings(settings.view);
        let reuse_changed = settings.objectspace.reuse != initial.objectspace.reuse;
        let density_changed = settings.objectspace.texel_density != initial.objectspace.texel_density;
        let mut drop: Vec<&str> = VIEWER_FLAGS.into_iter().chain(SETTING_FLAGS).collect();
        if free {
            drop.extend(CAMERA_FLAGS);
        }
        if reuse_changed {
            drop.extend(RATE_FLAGS);
        }
        let mut words = vec!["shadespace".to_string(), "render".to_string()];
        words.extend(without_flags(&self.words, &drop));
        let os = &settings.objectspace;
        let mut add = |flag: &str, value: String| words.extend([flag.to_string(), value]);
        add("--pipeline", settings.pipeline.clone());
        add("--lights", settings.lights.clone());
        add("--seed", settings.seed.to_string());
        add("--env", settings.env.clone());
        add("--exposure", exposure_arg(settings.exposure));
        add("--tile-size", os.tile_size.to_string());
        if reuse_changed || self.base.objectspace.shade_hz.is_none() {
            add("--reuse", os.reuse.to_string());
        }
        add("--mip-bias", os.mip_bias.to_string());
        add("--variable-rate", os.variable_rate.to_string());
        match (self.base.objectspace.texture_size, self.base.objectspace.texel_density) {
            _ if density_changed => add("--texel-density", os.texel_density.to_string()),
            (Some(size), _) => add("--texture-size", size.to_string()),
            (None, Some(d)) => add("--texel-density", d.to_string()),
            // Sizes that follow the screen: the default, no flag.
            (None, None) => {}
        }
        if let Some(m) = os.shade_budget {
            add("--shade-budget", m.to_string());
        }
        if let Some(m) = os.atlas_budget {
            add("--atlas-budget", m.to_string());
        }
        if settings.view != DebugView::Shade {
            add("--view", settings.view.name().to_string());
        }
        if settings.view == DebugView::AtlasPages {
            add("--atlas-object", settings.atlas_pages.object.to_string());
            add("--atlas-level", settings.atlas_pages.level.to_string());
        }
        match camera {
            ViewCamera::PathFrame(k) => add("--frame", k.to_string()),
            ViewCamera::Free(look) => words.extend(look_at_args(look)),
            ViewCamera::Bookmark(mark) => add("--camera", mark.to_string()),
        }
        words.iter().map(|w| shell_quote(w)).collect::<Vec<_>>().join(" ")
    }
}

/// A value parser's result as an error the viewer shows.
fn checked<T>(r: Result<T, String>) -> anyhow::Result<T> {
    r.map_err(anyhow::Error::msg)
}

/// `words` without the flags in `drop` and their values (`--flag value`
/// or `--flag=value`); `--hide-ui` and `--headless` (no value) go too.
fn without_flags(words: &[String], drop: &[&str]) -> Vec<String> {
    let mut out = Vec::new();
    let mut skip_value = false;
    for w in words {
        if std::mem::take(&mut skip_value) {
            continue;
        }
        if VIEWER_SWITCHES.contains(&w.as_str())
            || drop.iter().any(|f| w.strip_prefix(f).is_some_and(|rest| rest.starts_with('=')))
        {
            continue;
        }
        if drop.contains(&w.as_str()) {
            skip_value = true;
            continue;
        }
        out.push(w.clone());
    }
    out
}

impl PipelineName {
    /// The `--pipeline` name.
    fn name(self) -> &'static str {
        match self {
            Self::Forward => "forward",
            Self::ForwardMultipass => "forward-multipass",
            Self::Clustered => "clustered",
            Self::Deferred => "deferred",
            Self::DeferredCompute => "deferred-compute",
            Self::Objectspace => "objectspace",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drops_flags_and_their_values() {
        let words: Vec<String> =
            ["--scene", "voxels", "--pipeline=forward", "--seed", "3", "--hide-ui", "--size", "320x240", "--headless"]
                .map(String::from)
                .into();
        assert_eq!(without_flags(&words, &["--pipeline", "--seed"]), ["--scene", "voxels", "--size", "320x240"]);
    }
}
