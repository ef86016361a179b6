//! TEMPORARY stand-in until the camera path module lands.
use super::Camera;
pub struct CameraPath(pub Camera);
impl CameraPath {
    pub fn frame_count(&self) -> u32 {
        1
    }
    pub fn camera_at(&self, _frame: u32) -> Camera {
        self.0
    }
}
