//! Feeds arbitrary bytes to the Radiance scene parser: it must return `Ok`
//! or an `Err` naming file and line, never panic, hang or exhaust memory.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    // A directory that does not exist: `!xform file` and `instance` names
    // resolve to nothing, so the fuzzer cannot wander the file system.
    let _ = hybrid_rt::scene::load_rad_str(&text, "/nonexistent-fuzz-dir/fuzz.rad");
});
