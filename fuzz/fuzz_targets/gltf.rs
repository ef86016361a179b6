//! glTF and GLB loading: any bytes give a scene or an error, never a panic;
//! a loaded scene can be framed.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::{framing, gltf};

fuzz_target!(|data: &[u8]| {
    let name = if data.starts_with(b"glTF") { "input.glb" } else { "input.gltf" };
    if let Ok(scene) = gltf::load(&input_file::input_file(name, data)) {
        let _ = framing::frame(&scene.world_positions(), 16.0 / 9.0);
    }
});
