//! Lights and the seeded light-set generators of the four classic scenarios
//! (small, big, big shadowed, mixed), parsed from `--lights SPEC`.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// The four light types of the shared lighting model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    Ambient,
    Directional,
    Point,
    Spot,
}

/// One light. Fields a kind does not use are ignored (an ambient light uses
/// only `color` and `intensity`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    pub intensity: f32,
    /// World position (point, spot).
    #[serde(default)]
    pub position: Vec3,
    /// Unit direction the light travels (directional, spot).
    #[serde(default = "default_direction")]
    pub direction: Vec3,
    /// Range: the attenuation `1/(1+d²)` is cut off at this distance (point, spot).
    #[serde(default = "default_radius")]
    pub radius: f32,
    /// Cosine of the spot's inner cone half-angle (full intensity inside).
    #[serde(default = "default_inner")]
    pub cos_inner: f32,
    /// Cosine of the spot's outer cone half-angle (zero outside).
    #[serde(default = "default_outer")]
    pub cos_outer: f32,
    /// Whether the light casts shadows (shadow maps come with a later pipeline stage).
    #[serde(default)]
    pub casts_shadows: bool,
}

fn default_direction() -> Vec3 {
    Vec3::NEG_Y
}
fn default_radius() -> f32 {
    10.0
}
fn default_inner() -> f32 {
    0.95
}
fn default_outer() -> f32 {
    0.85
}
