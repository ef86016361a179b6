//! Procedural scenes, built in code and deterministic.
use super::Scene;

/// The default scene: a Sponza-like courtyard (placeholder until implemented).
pub fn atrium() -> Scene {
    todo!("atrium generator")
}

/// A Minecraft-like block world (placeholder until implemented).
pub fn voxels() -> Scene {
    todo!("voxels generator")
}
