//! The interactive viewer (`shadespace view`, cargo feature `viewer`): a
//! window showing frames of the same [`Renderer`] that `render` uses, with a
//! fly, orbit or path camera, an egui panel that switches pipelines and
//! options without a restart, a live per-pass GPU timing graph, screenshots
//! with a sidecar that names the equivalent `render` command, and scripted
//! runs for tests. Scripted runs can also go headless (`--headless`): no
//! window and no window system, the same frame loop painting its panel into
//! an offscreen texture, for machines without a display.
//!
//! The command line owns how options become a scene, lights and a renderer;
//! the viewer asks it through [`Session`], so that a frame in the viewer and
//! `render` with the same options are built the same way.

pub mod camera;
pub mod memory;
pub mod present;
pub mod screenshot;
pub mod script;
pub mod settings;
pub mod timings;
pub mod ui;

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::gpu::{GpuContext, GpuOptions};
use crate::render::Renderer;
use crate::render::objectspace::{DebugView, ObjectSpace};
use crate::scene::bookmarks::{self, Bookmark, BookmarkRef};
use crate::scene::free_camera::LookAt;
use crate::scene::{Aabb, CameraPath, Light};
use camera::{CameraMode, FlyCamera, OrbitCamera};
use present::{EguiFrame, Presenter};
use screenshot::{ShotCamera, Sidecar};
use script::{Player, Script, Step};
use settings::Settings;
use timings::TimingHistory;

/// The camera of a view as `render` takes it.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewCamera {
    /// A frame of the options' camera path (`render --frame N`).
    PathFrame(u32),
    /// A free camera (`render --eye --target --fov`).
    Free(LookAt),
    /// A bookmark saved in a bookmark file (`render --camera bookmark:FILE:NAME`).
    Bookmark(BookmarkRef),
}

/// What the viewer needs from the command line: renderers and lights built
/// from [`Settings`] exactly as `render` builds them, and the `render`
/// command that reproduces a view.
pub trait Session {
    /// The `--pipeline` names.
    fn pipelines(&self) -> &[&'static str];
    /// The scene's object names, by object index.
    fn object_names(&self) -> &[String];
    /// The environments the panel offers (`--env` texts: `none`, `sky` and
    /// the command line's file, if any).
    fn environments(&self) -> &[String];
    /// A renderer for `settings`, configured as `render` configures it.
    fn renderer(&mut self, ctx: &GpuContext, settings: &Settings) -> anyhow::Result<Renderer>;
    /// The light set of `settings`.
    fn lights(&mut self, settings: &Settings) -> anyhow::Result<Vec<Light>>;
    /// The options' camera path.
    fn path(&self) -> &CameraPath;
    /// The scene's bounds (free cameras place their clip planes by them).
    fn bounds(&self) -> Aabb;
    /// The `shadespace render ...` command of a view.
    fn render_command(&self, settings: &Settings, camera: &ViewCamera) -> String;
}

/// How the viewer runs.
pub struct ViewerOptions {
    /// The settings of the first frame.
    pub settings: Settings,
    /// Rendered image size (the window starts at this size).
    pub size: (u32, u32),
    pub vsync: bool,
    /// Steps to play; the viewer exits after them (and `frames`).
    pub script: Option<Script>,
    /// Frames to render (after the script); the viewer then exits.
    pub frames: Option<u32>,
    /// Start with the panels hidden (F1 toggles them).
    pub hide_ui: bool,
    /// Where the last frame is saved before exiting.
    pub screenshot: Option<PathBuf>,
    /// Where the run's frame count and memory use are written as JSON.
    pub report: Option<PathBuf>,
    /// The bookmark file the panel saves to and loads from.
    pub bookmarks: PathBuf,
    /// No window: frames are painted into an offscreen texture of `size`
    /// (needs `script` or `frames`, which end the run).
    pub headless: bool,
    pub gpu: GpuOptions,
}

/// What a run did and the host memory it held, for `--report`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunReport {
    pub frames: u64,
    /// Renderers built (the first one included).
    pub renderer_builds: u64,
    /// Resident set size (`VmRSS`), KiB: before the window opened, after
    /// the first frame, and at the end (the window still open).
    pub rss_kib_start: u64,
    pub rss_kib_first_frame: u64,
    pub rss_kib_end: u64,
    /// A scripted run's resident set size, KiB, as each round of its steps
    /// ended: flat once the first rounds have built every kind of renderer
    /// when nothing leaks.
    pub rss_kib_rounds: Vec<u64>,
    /// Median GPU milliseconds per top-level pass over the last frames (the
    /// timing history, at most its length), as `bench` summarises them.
    pub gpu_pass_ms: Vec<(String, f64)>,
}

/// Opens the window and runs until it is closed or, for a scripted run,
/// until the script and `frames` are done.
pub fn run(session: Box<dyn Session>, options: ViewerOptions) -> anyhow::Result<RunReport> {
    let report = RunReport { rss_kib_start: memory::resident_kib().unwrap_or(0), ..Default::default() };
    let report_path = options.report.clone();
    let report = if options.headless {
        run_headless(session, options, report)?
    } else {
        let event_loop = EventLoop::new().context("cannot open a window (is DISPLAY set? --headless needs none)")?;
        event_loop.set_control_flow(ControlFlow::Poll);
        let mut app = App { session: Some(session), options: Some(options), viewer: None, error: None, report };
        event_loop.run_app(&mut app)?;
        if let Some(e) = app.error {
            return Err(e);
        }
        app.report
    };
    if let Some(path) = report_path {
        std::fs::write(&path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(report)
}

/// The frame loop without a window: frames until the script and `frames`
/// are done, each painted with its panel into the offscreen target.
fn run_headless(session: Box<dyn Session>, options: ViewerOptions, mut report: RunReport) -> anyhow::Result<RunReport> {
    anyhow::ensure!(
        options.script.is_some() || options.frames.is_some(),
        "--headless needs --frames or --script: without a window nothing else ends the run"
    );
    let mut viewer = Viewer::new(None, session, options)?;
    report.renderer_builds = 1;
    while let Flow::Continue = viewer.frame(&mut report)? {}
    viewer.finish(&mut report);
    Ok(report)
}

struct App {
    session: Option<Box<dyn Session>>,
    options: Option<ViewerOptions>,
    viewer: Option<Viewer>,
    error: Option<anyhow::Error>,
    report: RunReport,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        let (Some(session), Some(options)) = (self.session.take(), self.options.take()) else { return };
        match Viewer::new(Some(event_loop), session, options) {
            Ok(v) => {
                self.report.renderer_builds = 1;
                self.viewer = Some(v);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(v) = &mut self.viewer else { return };
        let result = match event {
            WindowEvent::CloseRequested => Ok(Flow::Exit),
            WindowEvent::RedrawRequested => v.frame(&mut self.report),
            other => {
                v.input(&other);
                Ok(Flow::Continue)
            }
        };
        match result {
            Ok(Flow::Continue) => {}
            Ok(Flow::Exit) => {
                v.finish(&mut self.report);
                event_loop.exit();
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(window) = self.viewer.as_ref().and_then(|v| v.window.as_ref()) {
            window.window.request_redraw();
        }
    }
}

/// Whether the viewer goes on after a frame.
enum Flow {
    Continue,
    Exit,
}

/// The open window and everything drawn in it.
struct Viewer {
    /// `None` when headless.
    window: Option<ViewerWindow>,
    ctx: GpuContext,
    presenter: Presenter,
    egui: egui::Context,
    session: Box<dyn Session>,
    renderer: Renderer,
    /// The settings `renderer` and `lights` were built with.
    built: Settings,
    /// The settings the panel and scripts edit; applied before each frame.
    wanted: Settings,
    lights: Vec<Light>,
    camera: CameraMode,
    /// The renderer's frame number (from 0 after each rebuild, as in `render`).
    frame: u64,
    timings: TimingHistory,
    keys: HashSet<KeyCode>,
    /// Cursor position while the right button turns the camera.
    drag: Option<(f64, f64)>,
    last_frame: Instant,
    /// When the viewer started (egui's clock when headless).
    started: Instant,
    ui_shown: bool,
    script: Option<ScriptRun>,
    /// Screenshots to take of the next frame.
    shots: Vec<PathBuf>,
    /// The last frame's egui output (a final screenshot with the panels repaints it).
    last_ui: Option<EguiFrame>,
    /// F12 screenshots taken (they are numbered).
    f12_shots: u32,
    bookmarks: Vec<Bookmark>,
    bookmark_file: PathBuf,
    status: String,
    device_line: String,
}

/// The window and egui's view of its events.
struct ViewerWindow {
    window: Arc<Window>,
    egui_input: egui_winit::State,
}

/// A non-interactive run: the script, then `frames`, then the screenshot.
struct ScriptRun {
    player: Option<Player>,
    /// Frames to render before the next step.
    frames_left: u32,
    /// Frames to render after the script.
    after: u32,
    screenshot: Option<PathBuf>,
}

impl Viewer {
    /// Opens a window on `event_loop`, or with none, a headless viewer.
    fn new(
        event_loop: Option<&ActiveEventLoop>,
        mut session: Box<dyn Session>,
        o: ViewerOptions,
    ) -> anyhow::Result<Self> {
        let instance = wgpu::Instance::new(crate::gpu::instance_descriptor());
        let egui = egui::Context::default();
        let (window, ctx, presenter) = match event_loop {
            Some(event_loop) => {
                let attributes = Window::default_attributes()
                    .with_title("shadespace")
                    .with_inner_size(winit::dpi::PhysicalSize::new(o.size.0, o.size.1));
                let window = Arc::new(event_loop.create_window(attributes).context("cannot open a window")?);
                let surface = instance.create_surface(window.clone()).context("cannot draw in the window")?;
                let ctx = GpuContext::with_instance(instance, &o.gpu, Some(&surface))?;
                let inner = window.inner_size();
                let presenter = Presenter::new(&ctx, surface, (inner.width, inner.height), o.vsync, o.size)?;
                let max_side = ctx.limits.max_texture_dimension_2d as usize;
                let egui_input = egui_winit::State::new(
                    egui.clone(),
                    egui::ViewportId::ROOT,
                    &window,
                    Some(window.scale_factor() as f32),
                    None,
                    Some(max_side),
                );
                (Some(ViewerWindow { window, egui_input }), ctx, presenter)
            }
            None => {
                let ctx = GpuContext::with_instance(instance, &o.gpu, None)?;
                let presenter = Presenter::offscreen(&ctx, o.size, o.size);
                (None, ctx, presenter)
            }
        };
        let renderer = session.renderer(&ctx, &o.settings)?;
        let lights = session.lights(&o.settings)?;
        let device_line = match presenter.present_mode() {
            Some(mode) => format!("{} ({mode:?})", ctx.info.name),
            None => format!("{} (headless)", ctx.info.name),
        };
        let scripted = o.script.is_some() || o.frames.is_some() || o.screenshot.is_some();
        let script = scripted.then(|| ScriptRun {
            player: o.script.map(Player::new),
            frames_left: 0,
            after: o.frames.unwrap_or(0),
            screenshot: o.screenshot,
        });
        // No bookmark file yet is the usual start; a broken one is reported.
        let (bookmarks, status) = match bookmarks::load(&o.bookmarks) {
            Ok(b) => (b, String::new()),
            Err(bookmarks::BookmarkError::Read { .. }) => (Vec::new(), String::new()),
            Err(e) => (Vec::new(), e.to_string()),
        };
        Ok(Self {
            window,
            ctx,
            presenter,
            egui,
            session,
            renderer,
            built: o.settings.clone(),
            wanted: o.settings,
            lights,
            camera: CameraMode::Path { frame: 0, playing: false },
            frame: 0,
            timings: TimingHistory::default(),
            keys: HashSet::new(),
            drag: None,
            last_frame: Instant::now(),
            started: Instant::now(),
            ui_shown: !o.hide_ui,
            script,
            shots: Vec::new(),
            last_ui: None,
            f12_shots: 0,
            bookmarks,
            bookmark_file: o.bookmarks,
            status,
            device_line,
        })
    }

    /// Renders, shows and, when asked, saves one frame.
    fn frame(&mut self, report: &mut RunReport) -> anyhow::Result<Flow> {
        let dt = self.last_frame.elapsed().as_secs_f32().min(0.25);
        self.last_frame = Instant::now();
        if let Some(flow) = self.advance_script(report)? {
            return Ok(flow);
        }
        if self.script.is_none() {
            self.fly(dt);
        }
        self.apply_settings(report)?;
        let path = self.session.path();
        let camera = self.camera.camera(path, &self.session.bounds());
        self.renderer.render(&self.ctx, &camera, &self.lights, self.frame)?;
        self.frame += 1;
        report.frames += 1;
        if let CameraMode::Path { frame, playing: true } = &mut self.camera {
            *frame = (*frame + 1) % path.frame_count().max(1);
        }
        self.timings.push(self.renderer.collect_timings(&self.ctx, false));
        self.timings.push_counters(self.renderer.collect_counters(&self.ctx, false));
        self.presenter.copy_image(&self.ctx, &self.renderer.targets.ldr);

        let (egui_frame, actions) = self.draw_ui();
        for path in std::mem::take(&mut self.shots) {
            self.save_shot(&path, &egui_frame)?;
        }
        self.presenter.present(&self.ctx, &egui_frame);
        self.last_ui = Some(egui_frame);
        for a in actions {
            self.act(a);
        }
        if report.frames == 1 {
            report.rss_kib_first_frame = memory::resident_kib().unwrap_or(0);
        }
        Ok(Flow::Continue)
    }

    /// Ends the run: the report's memory (the viewer still open: its memory
    /// is what is checked) and per-pass medians.
    fn finish(&self, report: &mut RunReport) {
        report.rss_kib_end = memory::resident_kib().unwrap_or(0);
        report.gpu_pass_ms = self.timings.median_pass_ms();
    }

    /// Plays script steps up to the next frame to render; `Some(Exit)` once
    /// the run is over (after its last frame is saved).
    fn advance_script(&mut self, report: &mut RunReport) -> anyhow::Result<Option<Flow>> {
        let Some(run) = &mut self.script else { return Ok(None) };
        while run.frames_left == 0 {
            let rounds_before = run.player.as_ref().map_or(0, Player::rounds_done);
            let step = run.player.as_mut().and_then(Player::next_step);
            let rounds = run.player.as_ref().map_or(0, Player::rounds_done);
            if rounds > rounds_before {
                report.rss_kib_rounds.push(memory::resident_kib().unwrap_or(0));
            }
            if let Some(step) = step {
                let current = self.camera.camera(self.session.path(), &self.session.bounds());
                let mut target = StepTarget { wanted: &mut self.wanted, camera: &mut self.camera, current };
                let (frames, shot) = apply_step(&step, &mut target, &mut self.ui_shown)?;
                run.frames_left = frames;
                self.shots.extend(shot);
            } else if run.after > 0 {
                run.frames_left = std::mem::take(&mut run.after);
            } else if self.last_ui.is_none() {
                // Nothing rendered yet: a screenshot needs one frame.
                run.frames_left = 1;
            } else {
                if let (Some(path), Some(last)) = (run.screenshot.take(), self.last_ui.take()) {
                    self.save_shot(&path, &last)?;
                }
                return Ok(Some(Flow::Exit));
            }
        }
        run.frames_left -= 1;
        Ok(None)
    }

    /// Builds what the wanted settings change (the renderer, the lights),
    /// then sets what the renderer changes live.
    fn apply_settings(&mut self, report: &mut RunReport) -> anyhow::Result<()> {
        if !self.wanted.same_renderer(&self.built) {
            self.rebuild(report)?;
        }
        self.apply_live()
    }

    /// Builds a renderer or lights for the wanted settings.
    fn rebuild(&mut self, report: &mut RunReport) -> anyhow::Result<()> {
        // The environment brings its light and its maps: both change.
        let (wanted, built) = (&self.wanted, &self.built);
        let lights_changed = (&wanted.lights, wanted.seed, &wanted.env) != (&built.lights, built.seed, &built.env);
        let renderer_changed =
            !Settings { lights: built.lights.clone(), seed: built.seed, ..wanted.clone() }.same_renderer(built);
        let built = (|| -> anyhow::Result<_> {
            let lights = if lights_changed { Some(self.session.lights(&self.wanted)?) } else { None };
            let renderer = if renderer_changed { Some(self.session.renderer(&self.ctx, &self.wanted)?) } else { None };
            Ok((lights, renderer))
        })();
        match built {
            Ok((lights, renderer)) => {
                if let Some(l) = lights {
                    self.lights = l;
                }
                if let Some(r) = renderer {
                    self.renderer = r;
                    self.frame = 0;
                    self.timings.clear();
                    report.renderer_builds += 1;
                }
                self.built = self.wanted.clone();
                self.status.clear();
                Ok(())
            }
            // A scripted run stops at a bad setting; by hand, the panel shows why and keeps the last good one.
            Err(e) if self.script.is_some() => Err(e),
            Err(e) => {
                self.status = format!("{e:#}");
                self.wanted = self.built.clone();
                Ok(())
            }
        }
    }

    /// Sets what the renderer changes without a rebuild: the exposure, and
    /// the object and level of the atlas page view.
    fn apply_live(&mut self) -> anyhow::Result<()> {
        self.renderer.exposure = self.wanted.exposure;
        self.built.exposure = self.wanted.exposure;
        if self.wanted.view != DebugView::AtlasPages {
            return Ok(());
        }
        let Some(os) = self.renderer.pipeline_mut::<ObjectSpace>() else { return Ok(()) };
        match os.set_atlas_pages(self.wanted.atlas_pages) {
            Ok(()) => self.built.atlas_pages = self.wanted.atlas_pages,
            // A scripted run stops at a bad choice; by hand, the panel says why.
            Err(e) if self.script.is_some() => return Err(e.into()),
            Err(e) => self.status = e.to_string(),
        }
        Ok(())
    }

    /// Shading-texture levels per scene object (0: shaded forward, or no
    /// object-space pipeline), for the atlas page view's sliders.
    fn atlas_levels(&self) -> Vec<usize> {
        let Some(os) = self.renderer.pipeline::<ObjectSpace>() else { return Vec::new() };
        os.layout.objects.iter().map(|o| o.as_ref().map_or(0, |a| a.levels.len())).collect()
    }

    /// Runs egui for this frame: the image under the panel (unless hidden).
    fn draw_ui(&mut self) -> (EguiFrame, Vec<ui::Action>) {
        let input = match &mut self.window {
            Some(w) => w.egui_input.take_egui_input(&w.window),
            None => self.headless_input(),
        };
        let view_camera = self.view_camera();
        let command = self.session.render_command(&self.wanted, &view_camera);
        let path_frames = self.session.path().frame_count();
        let (image, image_size) = (self.presenter.image_id(), self.presenter.image_size());
        let atlas_levels = self.atlas_levels();
        let mut actions = Vec::new();
        let egui = self.egui.clone();
        let output = egui.run_ui(input, |ui| {
            ui::background(ui.ctx(), image, image_size);
            if self.ui_shown {
                actions = ui::panel(
                    ui,
                    ui::PanelState {
                        settings: &mut self.wanted,
                        camera: &mut self.camera,
                        path_frames,
                        bookmarks: &mut self.bookmarks,
                        timings: &self.timings,
                        pipelines: self.session.pipelines(),
                        environments: self.session.environments(),
                        object_names: self.session.object_names(),
                        atlas_levels: &atlas_levels,
                        status: &self.status,
                        render_command: &command,
                        device: &self.device_line,
                    },
                );
            }
        });
        if let Some(w) = &mut self.window {
            w.egui_input.handle_platform_output(&w.window, output.platform_output);
        }
        let primitives = egui.tessellate(output.shapes, output.pixels_per_point);
        self.presenter.update_textures(&self.ctx, output.textures_delta);
        (EguiFrame { primitives, pixels_per_point: output.pixels_per_point }, actions)
    }

    /// egui's input without a window: no events, a screen of the offscreen
    /// target's size at one pixel per point (as Xvfb's), the time since start.
    fn headless_input(&self) -> egui::RawInput {
        let (width, height) = self.presenter.size();
        egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(width as f32, height as f32))),
            time: Some(self.started.elapsed().as_secs_f64()),
            ..Default::default()
        }
    }

    /// The current camera as `render` takes it.
    fn view_camera(&self) -> ViewCamera {
        match self.camera {
            CameraMode::Path { frame, .. } => ViewCamera::PathFrame(frame),
            _ => ViewCamera::Free(self.camera.look_at(self.session.path())),
        }
    }

    /// Saves the frame just rendered: the renderer's image, or with the
    /// panels shown, the window as painted.
    fn save_shot(&mut self, path: &std::path::Path, frame: &EguiFrame) -> anyhow::Result<()> {
        let image = if self.ui_shown {
            self.presenter.capture(&self.ctx, frame)?
        } else {
            self.renderer.read_image(&self.ctx)?
        };
        let view_camera = self.view_camera();
        let look = self.camera.look_at(self.session.path());
        let (mode, path_frame) = match self.camera {
            CameraMode::Path { frame, .. } => ("path", Some(frame)),
            CameraMode::Fly(_) => ("fly", None),
            CameraMode::Orbit(_) => ("orbit", None),
        };
        let sidecar = Sidecar {
            image: path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            width: image.width(),
            height: image.height(),
            ui_shown: self.ui_shown,
            camera: ShotCamera {
                mode,
                path_frame,
                eye: look.eye.to_array(),
                target: look.target.to_array(),
                fov: look.fov_deg,
            },
            settings: &self.built,
            render_command: self.session.render_command(&self.built, &view_camera),
        };
        screenshot::save(&image, path, &sidecar)?;
        println!("screenshot: {}", path.display());
        Ok(())
    }

    /// A window event: egui first, then the camera keys and mouse.
    fn input(&mut self, event: &WindowEvent) {
        let Some(w) = &mut self.window else { return };
        let egui_took = w.egui_input.on_window_event(&w.window, event).consumed;
        match event {
            WindowEvent::Resized(size) => self.presenter.resize(&self.ctx, size.width, size.height),
            WindowEvent::KeyboardInput { event, .. } if !egui_took => {
                let PhysicalKey::Code(code) = event.physical_key else { return };
                if event.state == ElementState::Released {
                    self.keys.remove(&code);
                    return;
                }
                if !self.keys.insert(code) {
                    return;
                }
                self.key(code);
            }
            WindowEvent::MouseInput { state, button: MouseButton::Right, .. } => {
                self.drag = (*state == ElementState::Pressed).then_some((f64::NAN, f64::NAN));
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let Some((x, y)) = self.drag {
                    let (dx, dy) = (position.x - x, position.y - y);
                    if dx.is_finite() && dy.is_finite() {
                        self.turn(dx as f32 * MOUSE_DEG_PER_PIXEL, -dy as f32 * MOUSE_DEG_PER_PIXEL);
                    }
                    self.drag = Some((position.x, position.y));
                }
            }
            WindowEvent::MouseWheel { delta, .. } if !egui_took => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                let scale = WHEEL_STEP.powf(lines);
                match &mut self.camera {
                    CameraMode::Fly(f) => f.speed *= scale,
                    CameraMode::Orbit(o) => o.zoom(1.0 / scale),
                    CameraMode::Path { .. } => {}
                }
            }
            _ => {}
        }
    }

    /// A key pressed (once per press).
    fn key(&mut self, code: KeyCode) {
        match code {
            KeyCode::F12 => {
                self.f12_shots += 1;
                self.shots.push(PathBuf::from(format!("shadespace-view-{:03}.png", self.f12_shots)));
            }
            KeyCode::F1 => self.ui_shown = !self.ui_shown,
            KeyCode::KeyF => self.act(ui::Action::Fly),
            KeyCode::KeyO => self.act(ui::Action::Orbit),
            KeyCode::KeyP => self.camera = CameraMode::Path { frame: 0, playing: true },
            KeyCode::KeyB => self.act(ui::Action::AddBookmark),
            KeyCode::Space => {
                if let CameraMode::Path { playing, .. } = &mut self.camera {
                    *playing = !*playing;
                }
            }
            KeyCode::ArrowLeft | KeyCode::ArrowRight => {
                let n = self.session.path().frame_count().max(1);
                if let CameraMode::Path { frame, .. } = &mut self.camera {
                    *frame = if code == KeyCode::ArrowRight { (*frame + 1) % n } else { (*frame + n - 1) % n };
                }
            }
            _ => {}
        }
    }

    /// Flies the free camera by the held keys (WASD, Q/E down/up, shift faster).
    fn fly(&mut self, dt: f32) {
        let held = |k| self.keys.contains(&k);
        let axis = |plus, minus| (held(plus) as i32 - held(minus) as i32) as f32;
        let (right, up, forward) = (
            axis(KeyCode::KeyD, KeyCode::KeyA),
            axis(KeyCode::KeyE, KeyCode::KeyQ),
            axis(KeyCode::KeyW, KeyCode::KeyS),
        );
        if right == 0.0 && up == 0.0 && forward == 0.0 {
            return;
        }
        let boost = if held(KeyCode::ShiftLeft) || held(KeyCode::ShiftRight) { 4.0 } else { 1.0 };
        let fly = self.fly_camera();
        let step = fly.speed * boost * dt;
        fly.fly(right * step, up * step, forward * step);
    }

    /// Turns the free camera (entering fly mode from the path).
    fn turn(&mut self, yaw_deg: f32, pitch_deg: f32) {
        match &mut self.camera {
            CameraMode::Orbit(o) => o.turn(-yaw_deg, -pitch_deg),
            _ => self.fly_camera().turn(yaw_deg, pitch_deg),
        }
    }

    /// The fly camera, entered from the current view if not flying.
    fn fly_camera(&mut self) -> &mut FlyCamera {
        if !matches!(self.camera, CameraMode::Fly(_)) {
            self.act(ui::Action::Fly);
        }
        match &mut self.camera {
            CameraMode::Fly(f) => f,
            _ => unreachable!("just entered fly mode"),
        }
    }

    /// Does what the panel or a key asked for.
    fn act(&mut self, action: ui::Action) {
        let bounds = self.session.bounds();
        let current = self.camera.camera(self.session.path(), &bounds);
        let scene_size = bounds.extent().length().max(1e-3);
        match action {
            ui::Action::Screenshot => self.key(KeyCode::F12),
            ui::Action::Fly => {
                self.camera = CameraMode::Fly(FlyCamera::from_camera(&current, scene_size * FLY_SPEED_PER_SCENE_SIZE))
            }
            ui::Action::Orbit => {
                let distance = (bounds.center() - current.position).length().max(1e-3);
                self.camera = CameraMode::Orbit(OrbitCamera::from_camera(&current, distance));
            }
            ui::Action::AddBookmark => {
                let look = self.camera.look_at(self.session.path());
                // Names without spaces or colons: `--camera bookmark:FILE:NAME` needs no quotes.
                let taken = |n: &str| self.bookmarks.iter().any(|b| b.name == n);
                let name = (1..).map(|k| format!("view-{k}")).find(|n| !taken(n)).expect("a free name");
                println!("{name}: {}", self.session.render_command(&self.built, &ViewCamera::Free(look)));
                self.bookmarks.push(Bookmark::new(name, &look));
            }
            ui::Action::GoTo(k) => {
                if let Some(b) = self.bookmarks.get(k) {
                    let speed = scene_size * FLY_SPEED_PER_SCENE_SIZE;
                    self.camera = CameraMode::Fly(FlyCamera::from_look_at(&b.look_at(), speed));
                }
            }
            ui::Action::SaveBookmarks => match bookmarks::save(&self.bookmark_file, &self.bookmarks) {
                Ok(()) => {
                    self.status = format!("bookmarks saved to {}", self.bookmark_file.display());
                    // What renders and benchmarks each saved view.
                    for b in &self.bookmarks {
                        let mark = BookmarkRef { file: self.bookmark_file.clone(), name: b.name.clone() };
                        let camera = ViewCamera::Bookmark(mark);
                        println!("{}: {}", b.name, self.session.render_command(&self.built, &camera));
                    }
                }
                Err(e) => self.status = e.to_string(),
            },
            ui::Action::LoadBookmarks => match bookmarks::load(&self.bookmark_file) {
                Ok(b) => self.bookmarks = b,
                Err(e) => self.status = e.to_string(),
            },
        }
    }
}

/// Degrees the camera turns per pixel of mouse movement.
const MOUSE_DEG_PER_PIXEL: f32 = 0.2;
/// Speed (fly) or distance (orbit) factor per wheel line.
const WHEEL_STEP: f32 = 1.25;
/// Fly speed per second as a share of the scene's bounding-box diagonal.
const FLY_SPEED_PER_SCENE_SIZE: f32 = 0.1;

/// What a script step changes.
struct StepTarget<'a> {
    wanted: &'a mut Settings,
    camera: &'a mut CameraMode,
    /// The camera being rendered (moves and turns on the path start from it).
    current: crate::scene::Camera,
}

/// Applies a script step to the wanted settings and the camera; returns the
/// frames to render before the next step and a screenshot to take.
fn apply_step(step: &Step, t: &mut StepTarget, ui_shown: &mut bool) -> anyhow::Result<(u32, Option<PathBuf>)> {
    use crate::render::Exposure;
    let (wanted, camera) = (&mut *t.wanted, &mut *t.camera);
    // Moves and turns fly from the current view, as the keys and mouse do.
    if matches!(step, Step::Move(_) | Step::Turn(_)) && !matches!(camera, CameraMode::Fly(_)) {
        *camera = CameraMode::Fly(FlyCamera::from_camera(&t.current, 1.0));
    }
    let os = &mut wanted.objectspace;
    match step {
        Step::Frames(n) => return Ok((*n, None)),
        Step::Screenshot(path) => return Ok((1, Some(path.clone()))),
        Step::Pipeline(p) => wanted.pipeline = p.clone(),
        Step::Lights(l) => wanted.lights = l.clone(),
        Step::Env(e) => wanted.env = e.clone(),
        Step::Seed(s) => wanted.seed = *s,
        Step::Exposure(e) => wanted.exposure = Exposure::Fixed(*e),
        Step::View(v) => wanted.view = v.parse().map_err(|e: String| anyhow::anyhow!(e))?,
        Step::TileSize(t) => os.tile_size = *t,
        Step::Reuse(r) => os.reuse = *r,
        Step::MipBias(b) => os.mip_bias = *b,
        Step::VariableRate(v) => os.variable_rate = *v,
        Step::TexelDensity(d) => os.texel_density = *d,
        Step::ShadeBudget(b) => os.shade_budget = *b,
        Step::AtlasBudget(m) => os.atlas_budget = *m,
        Step::AtlasObject(k) => wanted.atlas_pages.object = *k,
        Step::AtlasLevel(l) => wanted.atlas_pages.level = *l,
        Step::Camera { eye, target, fov } => {
            let look = LookAt { eye: (*eye).into(), target: (*target).into(), fov_deg: *fov };
            *camera = CameraMode::Fly(FlyCamera::from_look_at(&look, 1.0));
        }
        Step::Move([right, up, forward]) => {
            if let CameraMode::Fly(f) = camera {
                f.fly(*right, *up, *forward);
            }
        }
        Step::Turn([yaw, pitch]) => {
            if let CameraMode::Fly(f) = camera {
                f.turn(*yaw, *pitch);
            }
        }
        Step::PathFrame(k) => *camera = CameraMode::Path { frame: *k, playing: false },
        Step::Ui(shown) => *ui_shown = *shown,
    }
    Ok((0, None))
}
