//! `hybrid-rt generate`: writes a built-in scene (the seeded city of any
//! size, the studio, the Cornell box) as Radiance text, with its view file
//! beside it.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use crate::scene::generate;
use crate::{Error, Result};

/// The scenes `generate` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GenerateKind {
    /// Streets of buildings with windows: real geometry, any size (--size).
    City,
    /// The paper's studio (about 4,600 primitives).
    Studio,
    /// The Cornell box.
    Cornell,
}

#[derive(Debug, Args)]
pub struct GenerateArgs {
    /// Which scene.
    #[arg(value_enum)]
    pub kind: GenerateKind,
    /// Seed of the scene's random choices (same seed and size, same bytes).
    #[arg(long, default_value_t = generate::DEFAULT_SEED)]
    pub seed: u64,
    /// Triangles wanted (city: at least this many; a quadrilateral counts two).
    #[arg(long, default_value_t = 100_000)]
    pub size: usize,
    /// The scene file to write; its view goes beside it (`.vf`).
    #[arg(short = 'o', long = "output", value_name = "FILE.rad")]
    pub output: PathBuf,
}

pub(super) fn run(a: &GenerateArgs) -> Result<()> {
    let (text, view) = match a.kind {
        GenerateKind::City => {
            let (text, stats) = generate::city_with_stats(a.seed, a.size);
            eprintln!(
                "city: {} buildings, {} primitives, {} triangles, {} light sources, {:.0} m across",
                stats.buildings, stats.primitives, stats.triangles, stats.lights, stats.extent
            );
            (text, generate::city_view(a.size))
        }
        GenerateKind::Studio => (
            generate::studio(a.seed),
            generate::studio_view().to_string(),
        ),
        GenerateKind::Cornell => (
            generate::cornell(a.seed),
            generate::cornell_view().to_string(),
        ),
    };
    let vf = a.output.with_extension("vf");
    if vf == a.output {
        return Err(Error::Usage(format!(
            "{}: the scene file must not end in .vf (its view is written there)",
            a.output.display()
        )));
    }
    std::fs::write(&a.output, text).map_err(|e| Error::io(&a.output, e))?;
    std::fs::write(&vf, view).map_err(|e| Error::io(&vf, e))?;
    eprintln!("wrote {} and {}", a.output.display(), vf.display());
    Ok(())
}
