//! The control panel (egui): pipeline, lights and environment, object-space options, debug
//! view, exposure, camera and bookmarks, and the timing graph. It edits the
//! viewer's state in place and returns what the viewer itself must do.

use egui::{Color32, Rect, Sense, Stroke, Ui, pos2, vec2};

use super::camera::CameraMode;
use super::settings::{LightKind, MAX_LIGHTS, Settings};
use super::timings::{TimingHistory, top_level};
use crate::render::Exposure;
use crate::render::objectspace::{DebugView, MAX_ATLAS_BUDGET_MI};
use crate::scene::bookmarks::Bookmark;

/// Width of the panel, points.
const PANEL_WIDTH: f32 = 280.0;
/// Height of the timing graph, points.
const GRAPH_HEIGHT: f32 = 110.0;

/// What the panel shows and edits.
pub struct PanelState<'a> {
    /// The settings the next frame is rendered with.
    pub settings: &'a mut Settings,
    pub camera: &'a mut CameraMode,
    /// Frames of the camera path.
    pub path_frames: u32,
    pub bookmarks: &'a mut Vec<Bookmark>,
    pub timings: &'a TimingHistory,
    /// The `--pipeline` names.
    pub pipelines: &'a [&'static str],
    /// The `--env` choices.
    pub environments: &'a [String],
    /// The scene's object names, by object index.
    pub object_names: &'a [String],
    /// Shading-texture levels per object (0: shaded forward; empty without
    /// the object-space pipeline).
    pub atlas_levels: &'a [usize],
    /// The last error or notice, shown at the top.
    pub status: &'a str,
    /// The `shadespace render` command of the current view.
    pub render_command: &'a str,
    /// Adapter and present mode, one line.
    pub device: &'a str,
}

/// What the viewer does after the panel was drawn.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Screenshot,
    /// Enter the fly or orbit camera from the current view.
    Fly,
    Orbit,
    AddBookmark,
    /// Go to bookmark K.
    GoTo(usize),
    SaveBookmarks,
    LoadBookmarks,
}

/// Paints the rendered image (`size` pixels) under the panel, as large as
/// the window holds it without changing its shape (a resized window shows
/// bars, not a stretched frame; the renderer keeps `--size`).
pub fn background(ctx: &egui::Context, image: egui::TextureId, size: (u32, u32)) {
    let uv = Rect::from_min_max(pos2(0.0, 0.0), pos2(1.0, 1.0));
    let window = ctx.content_rect();
    let painter = ctx.layer_painter(egui::LayerId::background());
    painter.rect_filled(window, 0.0, Color32::BLACK);
    painter.image(image, fit(window, size), uv, Color32::WHITE);
}

/// The largest rectangle of `size`'s aspect ratio centred in `window`.
fn fit(window: Rect, size: (u32, u32)) -> Rect {
    let image = vec2(size.0.max(1) as f32, size.1.max(1) as f32);
    let scale = (window.width() / image.x).min(window.height() / image.y);
    Rect::from_center_size(window.center(), image * scale)
}

/// Draws the panel; returns the actions asked for.
pub fn panel(ui: &mut Ui, s: PanelState) -> Vec<Action> {
    let mut actions = Vec::new();
    egui::Panel::left("controls").default_size(PANEL_WIDTH).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| {
            ui.label(s.device);
            if !s.status.is_empty() {
                ui.colored_label(Color32::from_rgb(255, 190, 80), s.status);
            }
            pipeline(ui, s.settings, s.pipelines);
            timing_graph(ui, s.timings);
            tile_counters(ui, s.timings);
            counters(ui, s.timings);
            lights(ui, s.settings, s.environments);
            if s.settings.pipeline == "objectspace" {
                objectspace(ui, s.settings);
                if s.settings.view == DebugView::AtlasPages {
                    atlas_pages(ui, s.settings, s.object_names, s.atlas_levels);
                }
            }
            exposure(ui, &mut s.settings.exposure);
            camera(ui, s.camera, s.path_frames, &mut actions);
            bookmarks(ui, s.bookmarks, &mut actions);
            ui.separator();
            if ui.button("Screenshot (F12)").clicked() {
                actions.push(Action::Screenshot);
            }
            ui.collapsing("render command", |ui| {
                ui.add(egui::Label::new(egui::RichText::new(s.render_command).monospace().small()).wrap());
            });
        });
    });
    actions
}

fn pipeline(ui: &mut Ui, settings: &mut Settings, pipelines: &[&'static str]) {
    egui::ComboBox::from_label("pipeline").selected_text(settings.pipeline.clone()).show_ui(ui, |ui| {
        for p in pipelines {
            ui.selectable_value(&mut settings.pipeline, p.to_string(), *p);
        }
    });
}

fn lights(ui: &mut Ui, settings: &mut Settings, environments: &[String]) {
    egui::CollapsingHeader::new("lights").default_open(true).show(ui, |ui| {
        match LightKind::parse(&settings.lights) {
            Some((mut kind, mut count)) => {
                egui::ComboBox::from_label("kind").selected_text(kind.name()).show_ui(ui, |ui| {
                    for k in LightKind::ALL {
                        ui.selectable_value(&mut kind, k, k.name());
                    }
                });
                ui.add(egui::Slider::new(&mut count, 0..=MAX_LIGHTS).logarithmic(true).text("count"));
                settings.lights = kind.spec(count);
            }
            // Mixed sets and light files are kept as given.
            None => {
                ui.label(format!("set: {}", settings.lights));
                if ui.button("replace with small:32").clicked() {
                    settings.lights = LightKind::Small.spec(32);
                }
            }
        }
        ui.add(egui::DragValue::new(&mut settings.seed).prefix("seed "));
        // Lights every material and fills the background (`--env`).
        egui::ComboBox::from_label("environment").selected_text(settings.env.clone()).show_ui(ui, |ui| {
            for e in environments {
                ui.selectable_value(&mut settings.env, e.clone(), e);
            }
        });
    });
}

fn objectspace(ui: &mut Ui, settings: &mut Settings) {
    egui::CollapsingHeader::new("object space").default_open(true).show(ui, |ui| {
        let os = &mut settings.objectspace;
        egui::ComboBox::from_label("tile size").selected_text(os.tile_size.to_string()).show_ui(ui, |ui| {
            for t in [8, 16, 32, 64] {
                ui.selectable_value(&mut os.tile_size, t, t.to_string());
            }
        });
        ui.add(egui::Slider::new(&mut os.reuse, 1..=8).text("reuse (frames)"));
        ui.add(egui::Slider::new(&mut os.mip_bias, -4.0..=4.0).step_by(0.25).text("mip bias"));
        ui.add(egui::Slider::new(&mut os.variable_rate, 0.0..=4.0).step_by(0.25).text("variable rate"));
        ui.add(egui::Slider::new(&mut os.texel_density, 16.0..=2048.0).logarithmic(true).text("texels/m"));
        let mut limited = os.shade_budget.is_some();
        ui.checkbox(&mut limited, "shade budget");
        if limited {
            let mut m = os.shade_budget.unwrap_or(1.0);
            ui.add(egui::Slider::new(&mut m, 0.01..=100.0).logarithmic(true).text("M texels"));
            os.shade_budget = Some(m);
        } else {
            os.shade_budget = None;
        }
        // Off: the default atlas for the image size. A change builds a new renderer.
        let mut sized = os.atlas_budget.is_some();
        ui.checkbox(&mut sized, "atlas budget");
        if sized {
            let mut m = os.atlas_budget.unwrap_or(4);
            ui.add(egui::Slider::new(&mut m, 1..=MAX_ATLAS_BUDGET_MI).logarithmic(true).text("Mi texels"));
            os.atlas_budget = Some(m);
        } else {
            os.atlas_budget = None;
        }
        egui::ComboBox::from_label("view").selected_text(settings.view.name()).show_ui(ui, |ui| {
            for v in DebugView::ALL {
                ui.selectable_value(&mut settings.view, v, v.name());
            }
        });
    });
}

/// The atlas page view's object (by index, with its name) and level; only
/// objects with a shading texture, only the levels it has.
fn atlas_pages(ui: &mut Ui, settings: &mut Settings, names: &[String], levels: &[usize]) {
    egui::CollapsingHeader::new("atlas pages").default_open(true).show(ui, |ui| {
        let Some(last) = levels.len().checked_sub(1) else { return };
        let pages = &mut settings.atlas_pages;
        let before = pages.object;
        ui.add(egui::Slider::new(&mut pages.object, 0..=last).text("object"));
        // Step over objects shaded forward, in the direction the slider moved.
        let up = pages.object >= before;
        while levels.get(pages.object) == Some(&0) {
            match (up, pages.object) {
                (true, k) if k < last => pages.object += 1,
                (false, k) if k > 0 => pages.object -= 1,
                _ => break,
            }
        }
        let name = names.get(pages.object).map_or("", String::as_str);
        ui.label(format!("object {}: {name}", pages.object));
        match levels.get(pages.object).copied().unwrap_or(0) {
            0 => {
                ui.label("shaded forward: no shading texture");
            }
            n => {
                pages.level = pages.level.min(n - 1);
                ui.add(egui::Slider::new(&mut pages.level, 0..=n - 1).text("level"));
            }
        }
        ui.label("dark checker: pages with no physical page");
    });
}

fn exposure(ui: &mut Ui, exposure: &mut Exposure) {
    ui.horizontal(|ui| {
        let mut auto = *exposure == Exposure::Auto;
        ui.checkbox(&mut auto, "auto exposure");
        match (auto, *exposure) {
            (true, _) => *exposure = Exposure::Auto,
            (false, Exposure::Auto) => *exposure = Exposure::Fixed(1.0),
            (false, Exposure::Fixed(mut e)) => {
                ui.add(egui::Slider::new(&mut e, 0.05..=20.0).logarithmic(true).text("exposure"));
                *exposure = Exposure::Fixed(e);
            }
        }
    });
}

fn camera(ui: &mut Ui, mode: &mut CameraMode, path_frames: u32, actions: &mut Vec<Action>) {
    egui::CollapsingHeader::new("camera").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            let on_path = matches!(mode, CameraMode::Path { .. });
            if ui.selectable_label(on_path, "path").clicked() && !on_path {
                *mode = CameraMode::Path { frame: 0, playing: false };
            }
            if ui.selectable_label(matches!(mode, CameraMode::Fly(_)), "fly").clicked() {
                actions.push(Action::Fly);
            }
            if ui.selectable_label(matches!(mode, CameraMode::Orbit(_)), "orbit").clicked() {
                actions.push(Action::Orbit);
            }
        });
        match mode {
            CameraMode::Path { frame, playing } => {
                ui.horizontal(|ui| {
                    if ui.button(if *playing { "pause" } else { "play" }).clicked() {
                        *playing = !*playing;
                    }
                    if ui.button("<").clicked() {
                        *frame = (*frame + path_frames.max(1) - 1) % path_frames.max(1);
                    }
                    if ui.button(">").clicked() {
                        *frame = (*frame + 1) % path_frames.max(1);
                    }
                });
                ui.add(egui::Slider::new(frame, 0..=path_frames.saturating_sub(1)).text("frame"));
            }
            CameraMode::Fly(f) => {
                ui.add(egui::Slider::new(&mut f.speed, 0.01..=100.0).logarithmic(true).text("speed"));
                ui.add(egui::Slider::new(&mut f.fov_deg, 10.0..=120.0).text("fov"));
            }
            CameraMode::Orbit(o) => {
                ui.add(egui::Slider::new(&mut o.distance, 0.1..=500.0).logarithmic(true).text("distance"));
                ui.add(egui::Slider::new(&mut o.fov_deg, 10.0..=120.0).text("fov"));
            }
        }
    });
}

fn bookmarks(ui: &mut Ui, bookmarks: &mut [Bookmark], actions: &mut Vec<Action>) {
    ui.collapsing("bookmarks", |ui| {
        ui.horizontal(|ui| {
            if ui.button("add").clicked() {
                actions.push(Action::AddBookmark);
            }
            if ui.button("save").clicked() {
                actions.push(Action::SaveBookmarks);
            }
            if ui.button("load").clicked() {
                actions.push(Action::LoadBookmarks);
            }
        });
        for (k, b) in bookmarks.iter().enumerate() {
            if ui.button(&b.name).clicked() {
                actions.push(Action::GoTo(k));
            }
        }
    });
}

/// A colour per pass, distinct for neighbours.
fn pass_colour(k: usize) -> Color32 {
    let hue = (k as f32 * 0.618_034).fract();
    egui::ecolor::Hsva::new(hue, 0.65, 0.9, 1.0).into()
}

/// The GPU time of each frame, stacked by pass, newest on the right.
fn timing_graph(ui: &mut Ui, timings: &TimingHistory) {
    ui.label(format!(
        "GPU {:.2} ms per frame (mean of the last {})",
        timings.mean_frame_ms(),
        timings.frames().count()
    ));
    let (response, painter) = ui.allocate_painter(vec2(ui.available_width(), GRAPH_HEIGHT), Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 0.0, Color32::from_black_alpha(160));
    let scale = timings.graph_scale_ms().max(1e-3);
    let names = timings.pass_names();
    let bar = rect.width() / super::timings::HISTORY_FRAMES as f32;
    let frames: Vec<_> = timings.frames().collect();
    let first_x = rect.right() - bar * frames.len() as f32;
    for (i, f) in frames.iter().enumerate() {
        let x = first_x + bar * i as f32;
        let mut y = rect.bottom();
        for (name, ms) in top_level(f) {
            let h = ((ms / scale) as f32 * rect.height()).min(y - rect.top());
            let k = names.iter().position(|n| n == name).unwrap_or(0);
            painter.rect_filled(Rect::from_min_max(pos2(x, y - h), pos2(x + bar.max(1.0), y)), 0.0, pass_colour(k));
            y -= h;
        }
    }
    painter.text(
        rect.left_top() + vec2(2.0, 2.0),
        egui::Align2::LEFT_TOP,
        format!("{scale:.2} ms"),
        egui::FontId::monospace(10.0),
        Color32::WHITE,
    );
    painter.rect_stroke(rect, 0.0, Stroke::new(1.0, Color32::GRAY), egui::StrokeKind::Inside);
    for (k, (name, ms)) in timings.mean_pass_ms().into_iter().enumerate() {
        if !name.contains('/') {
            ui.colored_label(pass_colour(k), format!("{name:<16} {ms:7.3} ms"));
        }
    }
}

/// Object space's tile counters: visible, shaded, reused and new tiles, and
/// overshading (visible tile texels per screen pixel, the study's measure;
/// after reuse, the shaded ones per pixel), as `bench` reports them.
fn tile_counters(ui: &mut Ui, timings: &TimingHistory) {
    let c = timings.counters();
    let get = |name: &str| c.get(name).copied();
    let (Some(visible), Some(shaded), Some(reused), Some(new), Some(overshading), Some(shaded_per_pixel)) = (
        get("visible_tiles"),
        get("shaded_tiles"),
        get("reused_tiles"),
        get("new_tiles"),
        get("overshading"),
        get("shaded_texels_per_pixel"),
    ) else {
        return;
    };
    ui.monospace(format!("tiles {visible:.0} visible, {shaded:.0} shaded, {reused:.0} reused, {new:.0} new"));
    ui.monospace(format!("overshading {overshading:.2} texels/pixel ({shaded_per_pixel:.2} shaded)"));
}

fn counters(ui: &mut Ui, timings: &TimingHistory) {
    let c = timings.counters();
    if c.is_empty() {
        return;
    }
    ui.collapsing("counters", |ui| {
        for (name, v) in c {
            ui.monospace(format!("{name:<20} {v:.2}"));
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_image_keeps_its_shape_in_a_resized_window() {
        let window = Rect::from_min_size(pos2(0.0, 0.0), vec2(1000.0, 400.0));
        // 16:9 in a wide window: full height, centred, bars left and right.
        let r = fit(window, (320, 180));
        assert!((r.height() - 400.0).abs() < 1e-3 && (r.width() - 400.0 * 16.0 / 9.0).abs() < 1e-3);
        assert!((r.center().x - 500.0).abs() < 1e-3);
        // A window of the image's own size shows it pixel for pixel.
        let same = Rect::from_min_size(pos2(0.0, 0.0), vec2(320.0, 180.0));
        assert_eq!(fit(same, (320, 180)), same);
    }
}
