//! The scene model and its loaders.
//!
//! - [`load`]: Radiance `.rad` files and Wavefront `.obj` files, several
//!   forming one scene (like `oconv`: later files may use earlier materials);
//! - [`load_rad_str`]: scene text from memory (tests, examples);
//! - [`view`]: Radiance views (`-vtv -vp ...`, view files) and primary rays;
//! - [`generate`]: the built-in procedural scenes (Cornell box, studio,
//!   conference room), written as Radiance text.
//!
//! Every input error names file, line and reason; no input makes a loader
//! panic, and scene files never run shell commands.

mod build;
mod genbox;
pub mod generate;
mod model;
mod modifiers;
mod obj;
mod octfile;
mod rad;
mod radbin;
mod rtm;
pub mod view;
mod xform;

use std::path::Path;

pub use model::*;
pub use view::{View, ViewType};

use crate::{Error, Result, SourceLoc};

/// Loads a scene from files, dispatching on the extension (`.rad`, `.obj`).
/// Files are read in order into one scene.
pub fn load(paths: &[impl AsRef<Path>]) -> Result<Scene> {
    let mut b = build::Builder::new();
    for p in paths {
        let p = p.as_ref();
        match p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("rad") => b.add_rad_file(p)?,
            Some("obj") => b.add_obj_file(p)?,
            _ => {
                return Err(Error::parse(
                    SourceLoc::new(p, 0),
                    "unknown scene file type: expected a .rad (Radiance) or .obj (Wavefront) file",
                ))
            }
        }
    }
    b.finish()
}

/// Loads Radiance scene text. `name` is used in messages and as the place
/// relative file names (in `!xform`, `instance`) are resolved from.
pub fn load_rad_str(text: &str, name: impl AsRef<Path>) -> Result<Scene> {
    let mut b = build::Builder::new();
    b.add_rad_text(text, name.as_ref())?;
    b.finish()
}

#[cfg(test)]
mod binformat_tests;
#[cfg(test)]
mod tests;
