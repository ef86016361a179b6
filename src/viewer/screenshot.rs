//! Screenshots: the PNG and a JSON sidecar beside it (`shot.png` ->
//! `shot.json`) holding the camera, the settings and the `shadespace render`
//! command line that draws the same image.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;

use super::settings::Settings;

/// What the sidecar records about the view.
#[derive(Clone, Debug, Serialize)]
pub struct ShotCamera {
    /// `path`, `fly` or `orbit`.
    pub mode: &'static str,
    /// The camera path's frame (path mode only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub path_frame: Option<u32>,
    pub eye: [f32; 3],
    pub target: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov: f32,
}

/// The sidecar document.
#[derive(Clone, Debug, Serialize)]
pub struct Sidecar<'a> {
    pub image: String,
    pub width: u32,
    pub height: u32,
    /// Whether the control panels are in the image.
    pub ui_shown: bool,
    pub camera: ShotCamera,
    pub settings: &'a Settings,
    /// The command that renders the same frame without the viewer (the
    /// image without panels).
    pub render_command: String,
}

/// The sidecar's path: the image's with the extension `json`.
pub fn sidecar_path(image: &Path) -> PathBuf {
    image.with_extension("json")
}

/// Writes the PNG and its sidecar.
pub fn save(image: &image::RgbaImage, path: &Path, sidecar: &Sidecar) -> anyhow::Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    }
    image
        .save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    let json = sidecar_path(path);
    std::fs::write(&json, serde_json::to_string_pretty(sidecar)?)
        .with_context(|| format!("{}: cannot write", json.display()))
}
