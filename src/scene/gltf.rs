//! glTF loading (placeholder until implemented).
use super::{Scene, SceneError};
use std::path::Path;

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    todo!("{}", path.display())
}
