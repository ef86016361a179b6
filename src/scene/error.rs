//! Errors of scene loading. Every variant names the file and the problem, so
//! that the CLI can print it and exit with status 2.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{0}: no such file or folder")]
    NotFound(PathBuf),
    #[error("{0}: unknown scene format (expected .gltf, .glb, .obj or a folder of .obj files)")]
    UnknownFormat(PathBuf),
    #[error("{path}: cannot parse: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: invalid scene: {problem}")]
    Invalid { path: PathBuf, problem: String },
    #[error("{path}: cannot read")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
