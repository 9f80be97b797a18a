//! Radiance octrees (`.oct`, `FORMAT=Radiance_octree`, made by `oconv`),
//! read the way Radiance's `readoct.c` does.
//!
//! Layout after the information header (see Radiance's `writeoct.c`): the
//! format number (`OCTMAGIC + objsize`, 2 bytes); the cube (origin x, y, z
//! and size, as text strings); the scene file names, each a string, ended
//! by an empty string; the object count (`objsize` bytes); the octree in
//! pre-order. A normal octree lists its scene files (to be read again as
//! Radiance text: they may be in-line commands starting with `!`); a frozen
//! one (`oconv -f`) lists none and stores its objects after the tree as
//! binary object records (see [`super::radbin`]).
//!
//! We only need the objects: the tree is checked and skipped.

#![cfg_attr(not(test), allow(dead_code))] // the builder wires these in

use std::path::Path;

use glam::DVec3;

use super::rad::RawPrim;
use super::radbin::BinReader;
use crate::{Error, Result, SourceLoc};

/// `OCTMAGIC` in Radiance's `octree.h` (the format number less `objsize`).
pub(crate) const OCT_MAGIC: i64 = 4 * 8 + 251;
/// The header's `FORMAT=` value.
pub(crate) const OCT_FORMAT: &str = "Radiance_octree";

/// What an octree holds.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum OctreeContents {
    /// Scene files to read as Radiance text, in order (names as written by
    /// `oconv`: relative to where it ran, or `!command` lines).
    Files(Vec<String>),
    /// A frozen octree's objects, in file order (their loc: the `.oct`
    /// path, line 0).
    Frozen(Vec<RawPrim>),
}

/// Everything [`parse_octree`] reads.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct OctreeFile {
    pub header: Vec<String>,
    pub cube_origin: DVec3,
    pub cube_size: f64,
    /// The object count the file records (for a normal octree, how many
    /// objects its files held when it was made).
    pub objects: usize,
    pub contents: OctreeContents,
}

/// Reads an octree's contents. `from` is where it was named (for the error
/// if it cannot be read).
pub(crate) fn read_octree(path: &Path, from: Option<&SourceLoc>) -> Result<OctreeContents> {
    let data =
        crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| match from {
            Some(loc) => Error::parse(
                loc.clone(),
                format!("cannot read octree file '{}': {e}", path.display()),
            ),
            None => Error::io(path, e),
        })?;
    Ok(parse_octree(&data, path)?.contents)
}

/// Decodes an octree from its bytes; `path` is used in messages.
pub(crate) fn parse_octree(data: &[u8], path: &Path) -> Result<OctreeFile> {
    let mut r = BinReader::new(data, path);
    let header = r.header(OCT_FORMAT)?;
    let objsize = r.magic(OCT_MAGIC, "octree")?;
    let mut org = [0.0; 3];
    for (i, o) in org.iter_mut().enumerate() {
        *o = r.str_real(&format!("octree cube origin {}", ["x", "y", "z"][i]))?;
    }
    let at = r.pos();
    let size = r.str_real("octree cube size")?;
    if size <= 0.0 {
        return Err(r.error_at(at, format!("illegal octree cube size {size}")));
    }
    let mut files = Vec::new();
    loop {
        let f = r.str("a scene file name")?;
        if f.is_empty() {
            break;
        }
        files.push(f);
    }
    let at = r.pos();
    let n = r.int(objsize, "the object count")?;
    let objects =
        usize::try_from(n).map_err(|_| r.error_at(at, format!("bad object count {n}")))?;
    r.skip_tree(objsize, "octree")?;
    let contents = if files.is_empty() {
        let at = r.pos();
        let objs = r.scene(objsize)?;
        if objs.len() != objects {
            return Err(r.error_at(
                at,
                format!(
                    "frozen octree stores {} objects but its header count says {objects}",
                    objs.len()
                ),
            ));
        }
        OctreeContents::Frozen(objs)
    } else {
        OctreeContents::Files(files)
    };
    Ok(OctreeFile {
        header,
        cube_origin: DVec3::from_array(org),
        cube_size: size,
        objects,
        contents,
    })
}
