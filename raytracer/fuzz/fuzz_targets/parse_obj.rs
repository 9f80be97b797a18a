//! Feeds arbitrary bytes to the OBJ and MTL readers: the input is split at
//! the first NUL byte into an OBJ text and the MTL text every `mtllib` it
//! names reads. Either must load or give an error naming file and line,
//! never panic or hang.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let (obj, mtl) = text.split_once('\0').unwrap_or((&text, ""));
    let _ = hybrid_rt::scene::load_obj_str(obj, Some(mtl), "/nonexistent-fuzz-dir/fuzz.obj");
});
