//! OBJ loading: any bytes give a scene or an error, never a panic; a small
//! loaded scene can be framed.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::{framing, obj};

/// Framing searches 72 angles over up to 4,096 vertices: on every input it
/// held this target to 350 executions a second, against 10,000 for glTF
/// (whose inputs rarely load); at 64 vertices it was still 15 % of this
/// target's time (profiled). Small scenes reach framing's edge cases
/// (degenerate, huge or non-finite positions) just as well.
const MAX_FRAMED_VERTICES: usize = 16;

fuzz_target!(|data: &[u8]| {
    if let Ok(scene) = obj::load_file(&input_file::input_file("input.obj", data)) {
        let positions = scene.world_positions();
        if positions.len() <= MAX_FRAMED_VERTICES {
            let _ = framing::frame(&positions, 16.0 / 9.0);
        }
    }
});
