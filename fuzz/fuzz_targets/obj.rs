//! OBJ loading: any bytes give a scene or an error, never a panic; a loaded
//! scene can be framed.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::{framing, obj};

fuzz_target!(|data: &[u8]| {
    if let Ok(scene) = obj::load_file(&input_file::input_file("input.obj", data)) {
        let _ = framing::frame(&scene.world_positions(), 16.0 / 9.0);
    }
});
