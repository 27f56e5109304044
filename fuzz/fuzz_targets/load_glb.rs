//! Feeds arbitrary bytes to the glTF/GLB loader: it must return `Ok` or `Err`, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = ispm::scene::load::load_from_slice(data, "fuzz.glb", None);
});
