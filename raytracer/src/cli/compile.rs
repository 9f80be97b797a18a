//! `hybrid-rt compile`: scene files into one compiled scene (see
//! [`crate::compiled`]), as Radiance's `oconv` makes an octree.

use std::path::PathBuf;

use clap::Args;

use crate::accel::OctreeParams;
use crate::compiled::{self, Storage};
use crate::{Error, Result};

#[derive(Debug, Args)]
pub struct CompileArgs {
    /// Radiance scene files (.rad text, .oct octrees), read in order as one scene.
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// The compiled scene to write.
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// View files to store with the scene (repeatable); `render` uses the
    /// first when given no view, and `--distribution predicted` cuts the
    /// octree by the work predicted here from the one rendered.
    #[arg(long = "view-file", value_name = "FILE")]
    pub view_files: Vec<PathBuf>,
    /// Store an object in every cell that lists it (default: once, in the
    /// first; the others name it).
    #[arg(long)]
    pub copies: bool,
    /// Objects a cell may hold before it is split (oconv -n).
    #[arg(long = "cell-objects", default_value_t = OctreeParams::default().max_objects)]
    pub cell_objects: usize,
}

pub(super) fn run(a: &CompileArgs) -> Result<()> {
    if a.scenes.contains(&a.output) {
        return Err(Error::Usage(format!(
            "{}: the output is also a scene file",
            a.output.display()
        )));
    }
    if a.cell_objects == 0 {
        return Err(Error::Usage("--cell-objects must be at least 1".into()));
    }
    let views = a
        .view_files
        .iter()
        .map(|p| {
            let text = crate::input::read_input_text(p, 1 << 20).map_err(|e| Error::io(p, e))?;
            crate::scene::View::from_file_text(&text, p)?;
            Ok(text)
        })
        .collect::<Result<Vec<_>>>()?;
    let params = OctreeParams {
        max_objects: a.cell_objects,
        ..OctreeParams::default()
    };
    let storage = if a.copies {
        Storage::Copies
    } else {
        Storage::Once
    };
    // Records name files (function files, data, instanced octrees) that
    // a render reads again: absolute names find them from anywhere.
    let scenes = a
        .scenes
        .iter()
        .map(|p| std::path::absolute(p).map_err(|e| Error::io(p, e)))
        .collect::<Result<Vec<_>>>()?;
    let t0 = std::time::Instant::now();
    let s = compiled::compile_with(
        &scenes,
        views,
        &params,
        storage,
        Some(&crate::parallel::predict::for_compiled_scene),
        &a.output,
    )?;
    eprintln!(
        "{}: {} objects in {} cells ({} listings), {} bytes: replicated {}, index {}, cells {} ({:.2} s)",
        a.output.display(),
        s.objects,
        s.cells,
        s.object_refs,
        s.file_bytes,
        s.replicated_bytes,
        s.index_bytes,
        s.cell_bytes,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
