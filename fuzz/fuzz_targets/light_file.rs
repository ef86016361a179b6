//! Light files (`--lights FILE.json`): any bytes give lights or an error,
//! never a panic.
#![no_main]

mod input_file;

use libfuzzer_sys::fuzz_target;
use shadespace::scene::lights;

fuzz_target!(|data: &[u8]| {
    let _ = lights::load_light_file(&input_file::input_file("lights.json", data));
});
