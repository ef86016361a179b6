//! TEMPORARY stand-in until the culling module lands (no culling).
use crate::scene::{Aabb, Light};
use glam::Mat4;
pub struct Frustum;
impl Frustum {
    pub fn from_view_projection(_m: Mat4) -> Self {
        Frustum
    }
    pub fn intersects_aabb(&self, _b: &Aabb) -> bool {
        true
    }
}
pub struct LightLists {
    pub offsets: Vec<u32>,
    pub counts: Vec<u32>,
    pub indices: Vec<u32>,
}
pub fn lights_per_object(lights: &[Light], bounds: &[Aabb], _f: Option<&Frustum>) -> LightLists {
    let n = lights.len() as u32;
    LightLists {
        offsets: (0..bounds.len() as u32).map(|i| i * n).collect(),
        counts: vec![n; bounds.len()],
        indices: (0..bounds.len() as u32).flat_map(|_| 0..n).collect(),
    }
}
