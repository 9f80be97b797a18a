//! Tone mapping linear radiance to 8-bit pixels, and PNG output.

use std::path::Path;

use super::Film;
use crate::scene::Color;
use crate::{Error, Result};

/// Brightness the auto exposure maps the image mean to (Radiance's `pfilt`
/// default: it scales the picture so its average brightness becomes 0.5).
pub const AUTO_EXPOSURE_LEVEL: f64 = 0.5;

/// How radiance is scaled before display.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// Like `pfilt` without `-e`: mean brightness maps to [`AUTO_EXPOSURE_LEVEL`].
    Auto,
    /// A fixed multiplier (Radiance's `-e` as a factor, not in stops).
    Fixed(f64),
}

/// Display transfer curve applied after exposure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Transfer {
    /// The sRGB curve (IEC 61966-2-1).
    Srgb,
    /// A pure power law `v^(1/gamma)` (Radiance's display tools use 2.2).
    Gamma(f64),
}

/// Exposure plus transfer curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToneMap {
    pub exposure: Exposure,
    pub transfer: Transfer,
}

impl Default for ToneMap {
    fn default() -> Self {
        Self {
            exposure: Exposure::Auto,
            transfer: Transfer::Srgb,
        }
    }
}

impl ToneMap {
    /// The multiplier this tone map applies to `film`. Auto exposure of a
    /// black (or non-finite) image falls back to 1.
    pub fn exposure_for(&self, film: &Film) -> f64 {
        match self.exposure {
            Exposure::Fixed(e) => e,
            Exposure::Auto => {
                let mean = film.mean_brightness();
                if mean.is_finite() && mean > 0.0 {
                    AUTO_EXPOSURE_LEVEL / mean
                } else {
                    1.0
                }
            }
        }
    }

    /// Maps one linear value (already multiplied by the exposure) to 0..=255.
    pub fn encode(&self, v: f64) -> u8 {
        let v = if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = match self.transfer {
            Transfer::Srgb => {
                if v <= 0.0031308 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                }
            }
            Transfer::Gamma(g) => v.powf(1.0 / g),
        };
        (d * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
    }

    /// The whole film as 8-bit RGB, row-major from the top.
    pub fn to_rgb8(&self, film: &Film) -> Vec<u8> {
        let e = self.exposure_for(film);
        let mut out = Vec::with_capacity(film.pixels().len() * 3);
        for &c in film.pixels() {
            let c: Color = c * e;
            out.extend([self.encode(c.x), self.encode(c.y), self.encode(c.z)]);
        }
        out
    }
}

/// Writes `film` as an 8-bit RGB PNG.
pub fn write_png(film: &Film, path: &Path, tone: &ToneMap) -> Result<()> {
    let (w, h) = (film.width(), film.height());
    let (w32, h32) = match (u32::try_from(w), u32::try_from(h)) {
        (Ok(a), Ok(b)) => (a, b),
        _ => return Err(Error::Usage(format!("{w}x{h}: image too large for PNG"))),
    };
    let buf = tone.to_rgb8(film);
    let img = image::RgbImage::from_raw(w32, h32, buf)
        .ok_or_else(|| Error::Other("internal error: PNG buffer size mismatch".into()))?;
    // Encoded in memory and written at once: `save_with_format` drops its
    // buffered writer unflushed, so a full disk went unreported.
    let mut bytes = std::io::Cursor::new(Vec::new());
    img.write_to(&mut bytes, image::ImageFormat::Png)
        .map_err(|e| Error::Other(format!("{}: {e}", path.display())))?;
    std::fs::write(path, bytes.into_inner()).map_err(|e| Error::io(path, e))
}
