//! Feeds arbitrary bytes to the view readers, as a view file and as
//! command-line view options; a view that validates must give rays and an
//! aspect fit without panicking.
#![no_main]

use hybrid_rt::scene::View;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    for v in [
        View::from_file_text(&text, "/nonexistent-fuzz-dir/fuzz.vf"),
        View::from_options(&text),
    ]
    .into_iter()
    .flatten()
    {
        for (x, y) in [(0.0, 0.0), (0.5, 0.5), (1.0, 0.3), (0.999, 1.0)] {
            let _ = v.ray(x, y);
        }
        let _ = v.fit_aspect(512, 512);
    }
});
