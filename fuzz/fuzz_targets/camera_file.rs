//! Camera files (`cameras.json`): any bytes give the cameras of a scene or an
//! error, never a panic; loaded paths can be sampled.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::path;

fuzz_target!(|data: &[u8]| {
    let file = input_file::input_file("cameras.json", data);
    if let Ok(cameras) = path::load_cameras_json(&file, "sponza-thesis") {
        for frame in [0, 1, 299, 300, 10_000] {
            let _ = cameras.path.camera_at(frame);
        }
    }
});
