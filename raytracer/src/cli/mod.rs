//! The `hybrid-rt` command-line program: `render`, `bench`, `sweep`,
//! `experiment`, `generate` and `compile`.
//!
//! Errors print as `error: <file:line: reason>` on stderr; the exit code
//! is 2 for usage errors and 1 for everything else. No input makes the
//! program panic.

/// `println!` that does not panic when standard output fails (a closed
/// pipe, a full disk): the failure is remembered and [`main`] exits 1.
macro_rules! outln {
    ($($t:tt)*) => {
        $crate::cli::common::stdout_line(format_args!($($t)*))
    };
}

mod args;
mod bench;
mod common;
mod compile;
mod console;
mod experiment;
mod generate;
mod parallel;
mod render;
mod sweep;
mod view;

pub use args::{
    translate, BenchArgs, Cli, Command, ExperimentArgs, ParallelArgs, RenderArgs, SweepArgs,
};
pub use parallel::summary as parallel_summary;

use std::io::Write;

use clap::Parser;

use crate::{Error, Result};

/// Entry point of the `hybrid-rt` binary; returns the process exit code.
pub fn main() -> i32 {
    init_logging();
    let argv = translate(std::env::args().collect());
    let cli = match Cli::try_parse_from(argv) {
        Ok(c) => c,
        Err(e) => {
            // Help and version are not errors.
            let code = if e.use_stderr() { 2 } else { 0 };
            if let Err(w) = e.print() {
                eprintln!("error: standard output: {w}");
                return 1;
            }
            return code;
        }
    };
    let result = match cli.command {
        Command::Render(a) => render::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Sweep(a) => sweep::run(&a),
        Command::Experiment(a) => experiment::run(&a),
        Command::Generate(a) => generate::run(&a),
        Command::Compile(a) => compile::run(&a),
    };
    // Everything written to standard output must have reached it.
    let result = result.and_then(|()| {
        let flushed = std::io::stdout().flush();
        if common::stdout_failed() || flushed.is_err() {
            let why = flushed
                .err()
                .map_or("write failed".to_string(), |e| e.to_string());
            return Err(Error::io("<standard output>", std::io::Error::other(why)));
        }
        Ok(())
    });
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            #[cfg(feature = "mpi")]
            if hybrid_sched::runtime::mpi::world().is_some() {
                // Other ranks may wait for this one: end the whole job.
                hybrid_sched::runtime::mpi::abort(e.exit_code());
            }
            e.exit_code()
        }
    }
}

/// Parses and checks a command line as [`main`] does before any file is
/// loaded or anything rendered (tests, fuzzing): [`translate`], clap, and
/// for `render` the checks of its options and view. Nothing is printed,
/// rendered or written; help and version requests are `Err` too.
pub fn check_command_line(args: Vec<String>) -> Result<()> {
    let cli = Cli::try_parse_from(translate(args)).map_err(|e| Error::Usage(e.to_string()))?;
    match cli.command {
        Command::Render(a) => render::check(&a),
        _ => Ok(()),
    }
}

/// `tracing` to stderr, filtered by `RUST_LOG` (default: warnings), in
/// colour only on a terminal and without `NO_COLOR` (<https://no-color.org>).
fn init_logging() {
    use std::io::IsTerminal;
    use tracing_subscriber::EnvFilter;
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"));
    let ansi = use_colour(
        std::io::stderr().is_terminal(),
        std::env::var_os("NO_COLOR").as_deref(),
    );
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .try_init();
}

/// Colour codes only on a terminal, and not when `NO_COLOR` is set to
/// anything but the empty string.
fn use_colour(terminal: bool, no_color: Option<&std::ffi::OsStr>) -> bool {
    terminal && no_color.is_none_or(|v| v.is_empty())
}

#[cfg(test)]
mod tests {
    use super::use_colour;
    use std::ffi::OsStr;

    #[test]
    fn colour_only_on_a_terminal_without_no_color() {
        assert!(use_colour(true, None));
        assert!(use_colour(true, Some(OsStr::new(""))));
        assert!(!use_colour(true, Some(OsStr::new("1"))));
        assert!(!use_colour(false, None));
        assert!(!use_colour(false, Some(OsStr::new("1"))));
    }
}
