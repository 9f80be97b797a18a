//! What every subcommand shares: standard output that cannot panic,
//! render options from Radiance's arguments, scene warnings, usage errors.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

use super::args;
use crate::render::RenderOptions;
use crate::{Error, Result};

/// Set when a line could not be written to standard output.
static STDOUT_FAILED: AtomicBool = AtomicBool::new(false);

/// Writes one line to standard output (see `outln!`).
pub(crate) fn stdout_line(args: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    if writeln!(out, "{args}").is_err() {
        STDOUT_FAILED.store(true, Ordering::Relaxed);
    }
}

/// Whether a line could not be written to standard output.
pub(super) fn stdout_failed() -> bool {
    STDOUT_FAILED.load(Ordering::Relaxed)
}

/// Render options from Radiance arguments and a seed.
pub(super) fn options_from(radiance: &args::RadianceArgs, seed: u64) -> Result<RenderOptions> {
    let mut o = match &radiance.quality {
        Some(q) => RenderOptions::preset(&args::value_name(q))?,
        None => RenderOptions::default(),
    };
    o.seed = seed;
    for (name, values) in radiance.given() {
        o.set(name, &values)?;
    }
    o.validate()?;
    Ok(o)
}

/// Prints the scene loader's warnings.
pub(super) fn print_scene_warnings(scene: &crate::scene::Scene) {
    for (loc, msg) in &scene.warnings {
        eprintln!("warning: {loc}: {msg}");
    }
}

pub(super) fn usage(msg: impl Into<String>) -> Error {
    Error::Usage(msg.into())
}
