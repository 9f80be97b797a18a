//! Loading a scene: files dispatched on their extension, or text from
//! memory, all read through one [`Builder`].

use std::path::Path;

use super::build::{Builder, LoadOptions};
use super::Scene;
use crate::input;
use crate::{Error, Result};

/// Loads a scene from files, dispatching on the extension: `.obj` is
/// Wavefront, `.oct` and `.octf` Radiance octrees, anything else (`.rad`,
/// `.mat`, `.norm`, no extension) Radiance scene text, and `-` standard
/// input. Files are read in order into one scene, as `oconv` does.
/// Function, data, picture and font files are found beside the scene file
/// that names them, then along `RAYPATH`.
pub fn load(paths: &[impl AsRef<Path>]) -> Result<Scene> {
    load_with(paths, &LoadOptions::from_env())
}

/// [`load`] with explicit options.
pub fn load_with(paths: &[impl AsRef<Path>], options: &LoadOptions) -> Result<Scene> {
    let mut b = Builder::new();
    b.mods.search_path = options.search_path.clone();
    b.exp.search_path = options.search_path.clone();
    for p in paths {
        let p = p.as_ref();
        if p == Path::new("-") {
            let bytes = input::read_capped(std::io::stdin().lock(), input::MAX_INPUT_BYTES)
                .map_err(|e| Error::io("<standard input>", e))?;
            b.add_rad_text(
                &String::from_utf8_lossy(&bytes),
                Path::new("<standard input>"),
            )?;
            continue;
        }
        match p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("obj") => b.add_obj_file(p)?,
            Some("oct" | "octf") => b.add_octree_file(p)?,
            _ => b.add_rad_file(p)?,
        }
    }
    b.finish()
}

/// Loads Radiance scene text. `name` is used in messages and as the place
/// relative file names (in `!xform`, `instance`) are resolved from.
pub fn load_rad_str(text: &str, name: impl AsRef<Path>) -> Result<Scene> {
    let mut b = Builder::new();
    b.add_rad_text(text, name.as_ref())?;
    b.finish()
}

/// Loads a Wavefront OBJ file's text from memory (tests, fuzzing); every
/// `mtllib` it names reads `mtl` (`None`: the library is missing, a
/// warning). `name` is used in messages.
pub fn load_obj_str(obj: &str, mtl: Option<&str>, name: impl AsRef<Path>) -> Result<Scene> {
    let mut b = Builder::new();
    b.add_obj_text(obj, name.as_ref(), mtl)?;
    b.finish()
}
