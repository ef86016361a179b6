//! Camera paths (placeholder until implemented).
pub struct CameraPath;
