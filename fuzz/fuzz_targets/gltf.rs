//! glTF and GLB loading: any bytes give a scene or an error, never a panic;
//! a small loaded scene can be framed.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::{framing, gltf};

/// Framing searches 72 angles over up to 4,096 vertices: on the corpus's
/// real models it was a fifth of this target's time (profiled). Small scenes
/// reach framing's edge cases just as well (as in the OBJ target).
const MAX_FRAMED_VERTICES: usize = 64;

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "input.glb" } else { "input.gltf" };
    if let Ok(scene) = gltf::load(&input_file::input_file(name, data)) {
        let positions = scene.world_positions();
        if positions.len() <= MAX_FRAMED_VERTICES {
            let _ = framing::frame(&positions, 16.0 / 9.0);
        }
    }
});
