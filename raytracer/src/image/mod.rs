//! Images: the film a render writes into, tone mapping to 8-bit PNG, and
//! Radiance HDR (RGBE) output.
//!
//! The film stores linear RGB radiance (Radiance's units, W/sr/m² per
//! channel) in `f64`, row-major with row 0 at the **top** of the picture.
//! Output format is chosen by the file extension ([`ImageFormat::from_path`]).

pub mod compare;
mod film;
pub mod hdr;
pub mod tonemap;

pub use film::{brightness, Film};
pub use tonemap::{Exposure, ToneMap, Transfer};

use std::path::Path;

use crate::{Error, Result};

/// Output formats, chosen by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB (or gamma) PNG, tone mapped.
    Png,
    /// Radiance RGBE picture (`#?RADIANCE`), linear radiance.
    Hdr,
}

impl ImageFormat {
    /// `.png` or `.hdr` (also Radiance's `.pic`), case-insensitive; anything
    /// else is a usage error naming the accepted extensions.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("hdr") | Some("pic") => Ok(ImageFormat::Hdr),
            _ => Err(Error::Usage(format!(
                "{}: unknown output image type (use a .png or .hdr file name)",
                path.display()
            ))),
        }
    }
}

/// Extra information written into an HDR header.
#[derive(Debug, Clone, Default)]
pub struct HdrInfo {
    /// Radiance view options (`-vtv -vp ...`), written as a `VIEW=` line.
    pub view: Option<String>,
    /// Software name for the header comment.
    pub software: Option<String>,
}

/// Writes `film` to `path` in the format its extension names.
/// PNG output is tone mapped with `tone`; HDR output stays linear radiance,
/// multiplied by `tone`'s exposure only if it was given explicitly (and
/// then recorded in the `EXPOSURE=` line).
pub fn write_image(film: &Film, path: &Path, tone: &ToneMap, info: &HdrInfo) -> Result<()> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => tonemap::write_png(film, path, tone),
        ImageFormat::Hdr => {
            let exposure = match tone.exposure {
                Exposure::Fixed(e) => e,
                Exposure::Auto => 1.0,
            };
            let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
            let mut w = std::io::BufWriter::new(file);
            hdr::write_hdr(&mut w, film, exposure, info).map_err(|e| Error::io(path, e))?;
            use std::io::Write;
            w.flush().map_err(|e| Error::io(path, e))
        }
    }
}
