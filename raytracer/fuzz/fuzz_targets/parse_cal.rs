//! Feeds arbitrary bytes to the function language: the input is split at
//! the first NUL byte into a `.cal` file and an expression; what parses is
//! compiled and evaluated. Errors are fine; panics, hangs and stack
//! overflows are not.
#![no_main]

use hybrid_rt::cal::{Inputs, Library};
use hybrid_rt::SourceLoc;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let (cal, expr) = text.split_once('\0').unwrap_or((&text, "0"));
    let Ok(mut lib) = Library::new(Vec::new()) else {
        return;
    };
    let ctx = lib.global();
    let loc = SourceLoc::new("fuzz.cal", 1);
    if lib.define(ctx, cal, &loc).is_err() {
        return;
    }
    let Ok(e) = lib.expr(ctx, expr, &loc) else {
        return;
    };
    if let Ok(program) = lib.finish() {
        let _ = program.eval(e, &Inputs::new(&[0.5, 1.5]));
    }
});
