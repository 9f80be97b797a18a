//! Choosing an output format by file extension and encoding a film in it.

use std::path::Path;

use super::tonemap::{self, Exposure, ToneMap};
use super::{exr, hdr, pfm, Film, HdrInfo};
use crate::{Error, Result};

/// Output formats, chosen by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB (or gamma) PNG, tone mapped.
    Png,
    /// Radiance RGBE picture (`#?RADIANCE`), linear radiance.
    Hdr,
    /// OpenEXR, 32-bit float RGB, linear radiance.
    Exr,
    /// Portable float map, 32-bit float RGB, linear radiance.
    Pfm,
}

/// The extensions [`ImageFormat::from_path`] accepts, for messages.
pub const IMAGE_EXTENSIONS: &str = ".png, .hdr (or .pic), .exr or .pfm";

impl ImageFormat {
    /// `.png`, `.hdr` (also Radiance's `.pic`), `.exr` or `.pfm`,
    /// case-insensitive; anything else is a usage error naming the
    /// accepted extensions.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("hdr") | Some("pic") => Ok(ImageFormat::Hdr),
            Some("exr") => Ok(ImageFormat::Exr),
            Some("pfm") => Ok(ImageFormat::Pfm),
            _ => Err(Error::Usage(format!(
                "{}: unknown output image type (use a {IMAGE_EXTENSIONS} file name)",
                path.display()
            ))),
        }
    }

    /// Whether the format holds linear radiance (everything but PNG).
    pub fn is_linear(self) -> bool {
        self != ImageFormat::Png
    }
}

/// Writes `film` to `path` in the format its extension names (see
/// [`encode_image`]).
pub fn write_image(film: &Film, path: &Path, tone: &ToneMap, info: &HdrInfo) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    encode_image(film, format, tone, info, &mut w).map_err(|e| Error::io(path, e))?;
    use std::io::Write;
    w.flush().map_err(|e| Error::io(path, e))
}

/// Encodes `film` as `format` into `w`.
/// PNG output is tone mapped with `tone`; HDR output stays linear radiance,
/// multiplied by `tone`'s exposure only if it was given explicitly (and
/// then recorded in the `EXPOSURE=` line); EXR and PFM hold the film's
/// radiance as it is.
pub fn encode_image<W: std::io::Write>(
    film: &Film,
    format: ImageFormat,
    tone: &ToneMap,
    info: &HdrInfo,
    w: &mut W,
) -> std::io::Result<()> {
    match format {
        ImageFormat::Png => tonemap::encode_png(film, tone, w),
        ImageFormat::Hdr => {
            let exposure = match tone.exposure {
                Exposure::Fixed(e) => e,
                Exposure::Auto | Exposure::Reinhard(_) => 1.0,
            };
            hdr::write_hdr(w, film, exposure, info)
        }
        ImageFormat::Exr => exr::encode_exr(film, info, w),
        ImageFormat::Pfm => pfm::encode_pfm(film, w),
    }
}
