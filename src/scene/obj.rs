//! OBJ loading (placeholder until implemented).
use super::{Scene, SceneError};
use std::path::Path;

pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    todo!("{}", path.display())
}

pub fn load_folder(path: &Path) -> Result<Scene, SceneError> {
    todo!("{}", path.display())
}
