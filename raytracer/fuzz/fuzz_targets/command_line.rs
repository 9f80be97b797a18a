//! Feeds arbitrary argument vectors (the input split at NUL bytes) through
//! the program's command-line translation, clap parser and option and view
//! checks, without loading or rendering anything.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let mut argv = vec!["hybrid-rt".to_string()];
    argv.extend(text.split('\0').map(String::from));
    let _ = hybrid_rt::cli::check_command_line(argv);
});
