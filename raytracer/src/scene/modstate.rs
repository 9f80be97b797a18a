//! What patterns load while a scene is read: the function library, the
//! modifiers so far and the files they loaded (see [`super::modifiers`]).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::model::MaterialId;
use super::rad::RawPrim;
use crate::cal::Library;
use crate::modifier::data::{DataArray, PictureData};
use crate::modifier::font::Font;
use crate::modifier::{Modifier, ModifierId, Patterns, Picture, MAX_DATA_DIMS};
use crate::{Error, Result};

/// What patterns load while a scene is read.
#[derive(Default)]
pub(crate) struct ModState {
    /// Where files are searched after the naming file's own directory.
    pub search_path: Vec<PathBuf>,
    /// The function library, created on the first modifier that needs it
    /// (a scene without functions never builds one).
    pub(super) lib: Option<Library>,
    pub(super) modifiers: Vec<Modifier>,
    pub(super) data: HashMap<PathBuf, Arc<DataArray>>,
    pub(super) picts: HashMap<PathBuf, Arc<PictureData>>,
    pub(super) fonts: HashMap<PathBuf, Arc<Font>>,
    /// Materials made for a surface whose modifier is a pattern in front
    /// of a material: (chain, material) -> the patterned copy.
    pub(super) derived: HashMap<(Vec<ModifierId>, MaterialId), MaterialId>,
}

impl ModState {
    pub fn new(search_path: Vec<PathBuf>) -> Self {
        Self {
            search_path,
            ..Default::default()
        }
    }

    pub(super) fn lib(&mut self) -> Result<&mut Library> {
        if self.lib.is_none() {
            self.lib = Some(Library::new(self.search_path.clone())?);
        }
        Ok(self.lib.as_mut().expect("just created"))
    }

    /// Finds a file the way Radiance does: as given if absolute, else
    /// beside the scene file, else along the search path.
    pub(super) fn find(&self, name: &str, base: &Path) -> Option<PathBuf> {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.is_file().then(|| p.to_path_buf());
        }
        std::iter::once(base.to_path_buf())
            .chain(self.search_path.iter().cloned())
            .map(|d| d.join(p))
            .find(|c| c.is_file())
    }

    pub(super) fn locate(&self, name: &str, what: &str, p: &RawPrim) -> Result<PathBuf> {
        self.find(name, &p.base_dir()).ok_or_else(|| {
            Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': cannot find {what} '{name}' (looked beside the scene file and in RAYPATH{})",
                    p.ptype,
                    p.id,
                    if self.search_path.is_empty() {
                        ", which is not set".to_string()
                    } else {
                        format!(
                            ": {}",
                            self.search_path
                                .iter()
                                .map(|d| d.display().to_string())
                                .collect::<Vec<_>>()
                                .join(":")
                        )
                    }
                ),
            )
        })
    }

    pub(super) fn data(&mut self, name: &str, p: &RawPrim) -> Result<Arc<DataArray>> {
        let path = self.locate(name, "data file", p)?;
        if let Some(d) = self.data.get(&path) {
            return Ok(d.clone());
        }
        let d = Arc::new(DataArray::load(&path, &p.loc)?);
        if d.dims() == 0 || d.dims() > MAX_DATA_DIMS {
            return Err(Error::parse(
                p.loc.clone(),
                format!(
                    "{} '{}': data file '{}' has {} dimensions (1 to {MAX_DATA_DIMS} are supported)",
                    p.ptype,
                    p.id,
                    path.display(),
                    d.dims()
                ),
            ));
        }
        self.data.insert(path, d.clone());
        Ok(d)
    }

    /// A picture, read once. A missing one is not an error here (Radiance
    /// reads pictures when a ray first needs them): the pattern records
    /// why, and a warning says so.
    pub(super) fn pict(&mut self, name: &str, p: &RawPrim) -> Result<Picture> {
        let path = match self.locate(name, "picture", p) {
            Ok(path) => path,
            Err(Error::Parse { reason, .. }) => return Ok(Err(reason.into())),
            Err(e) => return Err(e),
        };
        if let Some(d) = self.picts.get(&path) {
            return Ok(Ok(d.clone()));
        }
        let d = Arc::new(PictureData::load(&path, &p.loc)?);
        self.picts.insert(path, d.clone());
        Ok(Ok(d))
    }

    pub(super) fn font(&mut self, name: &str, p: &RawPrim) -> Result<Arc<Font>> {
        let path = self.locate(name, "font", p)?;
        if let Some(d) = self.fonts.get(&path) {
            return Ok(d.clone());
        }
        let d = Arc::new(Font::load(&path, &p.loc)?);
        self.fonts.insert(path, d.clone());
        Ok(d)
    }

    /// Compiles every function and hands over the scene's patterns.
    pub fn finish(self) -> Result<Patterns> {
        let program = match self.lib {
            Some(lib) => lib.finish()?,
            None => crate::cal::Program::empty(),
        };
        Ok(Patterns {
            modifiers: self.modifiers,
            program,
            failures: Default::default(),
        })
    }
}
