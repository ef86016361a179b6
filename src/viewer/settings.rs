//! What the viewer's controls change: the pipeline, the light set, the
//! environment, the object-space options, the debug view and the exposure. The command line
//! gives the first settings; the panel and scripts change them; the
//! [`super::Session`] turns them into a renderer, exactly as `render` would.

use serde::Serialize;

use crate::render::Exposure;
use crate::render::objectspace::DebugView;
use crate::render::objectspace::atlas_view::AtlasPages;

/// The most lights the panel offers (the light-count slider's end).
pub const MAX_LIGHTS: u32 = 10_000;

/// The settings a renderer is built from, besides the scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Settings {
    /// The `--pipeline` name.
    pub pipeline: String,
    /// The `--lights` text (`small:32`, `big:4+small:100`, ...).
    pub lights: String,
    /// The `--seed` of the light placement.
    pub seed: u64,
    /// The `--env` text: `none`, `sky` or the command line's file.
    pub env: String,
    #[serde(serialize_with = "exposure_text")]
    pub exposure: Exposure,
    /// Object space: the image shown (`--view`).
    #[serde(serialize_with = "view_name")]
    pub view: DebugView,
    /// Object space, `--view atlas-pages`: the object and mip level shown
    /// (`--atlas-object`, `--atlas-level`; changed without a rebuild).
    pub atlas_pages: AtlasPages,
    pub objectspace: ObjectSpaceSettings,
}

/// The object-space options the panel offers (the `render` flags of the same names).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ObjectSpaceSettings {
    pub tile_size: u32,
    pub reuse: u32,
    pub mip_bias: f32,
    /// Up to this many levels coarser where triangles are flat (0: off).
    pub variable_rate: f32,
    /// Texels per metre (changing it charts the scene again).
    pub texel_density: f32,
    /// Most texels shaded per frame, in millions; `None`: no limit.
    pub shade_budget: Option<f64>,
    /// The physical atlas in Mi texels; `None`: the default for the image size.
    pub atlas_budget: Option<u64>,
}

impl Settings {
    /// Whether a renderer built for `self` also serves `other` (only what a
    /// renderer changes live differs: the exposure, the atlas page view's
    /// object and level).
    pub fn same_renderer(&self, other: &Settings) -> bool {
        Settings { exposure: other.exposure, atlas_pages: other.atlas_pages, ..self.clone() } == *other
    }
}

/// A light set of `count` lights of one kind: the panel's light editor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    Small,
    Big,
    Shadowed,
}

impl LightKind {
    pub const ALL: [Self; 3] = [Self::Small, Self::Big, Self::Shadowed];

    /// The `--lights` word.
    pub fn name(self) -> &'static str {
        match self {
            Self::Small => "small",
            Self::Big => "big",
            Self::Shadowed => "shadowed",
        }
    }

    /// The `--lights` text of `count` lights of this kind.
    pub fn spec(self, count: u32) -> String {
        format!("{}:{count}", self.name())
    }

    /// The kind and count of a one-kind `--lights` text (`small:32`); `None`
    /// for other sets (mixed, several kinds, files).
    pub fn parse(spec: &str) -> Option<(Self, u32)> {
        let (kind, count) = spec.split_once(':')?;
        let kind = Self::ALL.into_iter().find(|k| k.name() == kind)?;
        Some((kind, count.parse().ok()?))
    }
}

/// The `--exposure` text: `auto` or the multiplier.
pub fn exposure_arg(e: Exposure) -> String {
    match e {
        Exposure::Auto => "auto".to_string(),
        Exposure::Fixed(v) => v.to_string(),
    }
}

fn exposure_text<S: serde::Serializer>(e: &Exposure, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&exposure_arg(*e))
}

fn view_name<S: serde::Serializer>(v: &DebugView, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(v.name())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_kind_light_specs_round_trip() {
        assert_eq!(LightKind::parse("small:32"), Some((LightKind::Small, 32)));
        assert_eq!(LightKind::parse(&LightKind::Shadowed.spec(7)), Some((LightKind::Shadowed, 7)));
        assert_eq!(LightKind::parse("mixed:2:5"), None);
        assert_eq!(LightKind::parse("small:1+big:2"), None);
    }
}
