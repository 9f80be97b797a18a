//! Tone mapping linear radiance to 8-bit pixels, and PNG output.
//!
//! Two operators: a fixed (or automatic) exposure, and the global operator
//! of Reinhard, Stark, Shirley and Ferwerda, "Photographic Tone
//! Reproduction for Digital Images" (SIGGRAPH 2002), equations 1 to 4.

use std::io::Write;
use std::path::Path;

use super::{brightness, Film};
use crate::geometry::Color;
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
    /// Reinhard et al.'s global photographic operator: a per-pixel scale.
    Reinhard(Reinhard),
}

/// The tone operator chosen on the command line (`--tone`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ToneOperator {
    /// Reinhard et al. 2002: the log-average luminance to the key 0.18, white burnt out at the maximum (or --tone-white percentile).
    Reinhard,
    /// One multiplier for the whole picture: --exposure, or the mean brightness to 0.5 like pfilt.
    Exposure,
}

/// Reinhard et al. 2002, global operator: the luminance `Lw` of each pixel
/// (Radiance's [`brightness`]) is scaled to `L = key / Lavg * Lw`, where
/// `Lavg = exp(mean(ln(delta + Lw)))` is the log-average luminance (eq. 1
/// and 2), then compressed to `Ld = L (1 + L / Lwhite^2) / (1 + L)` (eq.
/// 4), where `Lwhite` is the scaled luminance at the chosen percentile
/// (100: the brightest pixel, which then maps to exactly 1). The pixel's
/// RGB is multiplied by `Ld / Lw`, keeping its chromaticity.
///
/// `delta` is `1e-4` times the largest luminance, so the operator does
/// not depend on the picture's units: a picture multiplied by any
/// positive factor maps to the same pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reinhard {
    /// The key: what the log-average luminance maps to before compression (0.18).
    pub key: f64,
    /// Percentile of the scaled luminances that burns out to white (100: the maximum).
    pub white_percentile: f64,
}

impl Default for Reinhard {
    fn default() -> Self {
        Self {
            key: 0.18,
            white_percentile: 100.0,
        }
    }
}

/// [`Reinhard`] fitted to one picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReinhardFit {
    /// The log-average luminance `Lavg`.
    pub log_average: f64,
    /// `key / Lavg`: the linear scale before compression.
    pub scale: f64,
    /// The scaled luminance that maps to 1.
    pub white: f64,
}

/// A luminance usable by the operator: finite and not negative, else 0.
fn lum(c: Color) -> f64 {
    let l = brightness(c);
    if l.is_finite() && l > 0.0 {
        l
    } else {
        0.0
    }
}

impl Reinhard {
    /// The operator's constants for `film`. A black picture fits with
    /// scale 0 (it stays black).
    pub fn fit(&self, film: &Film) -> ReinhardFit {
        let mut lums: Vec<f64> = film.pixels().iter().map(|&c| lum(c)).collect();
        let max = lums.iter().copied().fold(0.0, f64::max);
        if lums.is_empty() || max <= 0.0 {
            return ReinhardFit {
                log_average: 0.0,
                scale: 0.0,
                white: 1.0,
            };
        }
        let delta = 1e-4 * max;
        let mean_log = lums.iter().map(|&l| (delta + l).ln()).sum::<f64>() / lums.len() as f64;
        let log_average = mean_log.exp();
        let key = if self.key.is_finite() && self.key > 0.0 {
            self.key
        } else {
            0.18
        };
        let scale = key / log_average;
        let p = if self.white_percentile.is_finite() {
            self.white_percentile.clamp(0.0, 100.0)
        } else {
            100.0
        };
        let white_lum = if p >= 100.0 {
            max
        } else {
            // Nearest rank.
            let k = ((p / 100.0 * lums.len() as f64).ceil() as usize).clamp(1, lums.len()) - 1;
            let (_, v, _) = lums.select_nth_unstable_by(k, f64::total_cmp);
            *v
        };
        let white = (scale * white_lum).max(f64::MIN_POSITIVE.sqrt());
        ReinhardFit {
            log_average,
            scale,
            white,
        }
    }
}

impl ReinhardFit {
    /// The display luminance `Ld` of world luminance `lw` (0 at 0,
    /// increasing, 1 at white).
    pub fn display(&self, lw: f64) -> f64 {
        let l = self.scale * lw;
        if !(l.is_finite() && l > 0.0) {
            return 0.0;
        }
        l * (1.0 + l / (self.white * self.white)) / (1.0 + l)
    }

    /// The multiplier of a pixel's RGB: `Ld / Lw` (0 for black pixels).
    pub fn pixel_scale(&self, c: Color) -> f64 {
        let lw = lum(c);
        if lw > 0.0 {
            self.display(lw) / lw
        } else {
            0.0
        }
    }
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
    /// black (or non-finite) image falls back to 1. For [`Exposure::Reinhard`]
    /// it is the linear part, `key / Lavg`, before compression.
    pub fn exposure_for(&self, film: &Film) -> f64 {
        match self.exposure {
            Exposure::Fixed(e) => e,
            Exposure::Reinhard(r) => r.fit(film).scale,
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
        let mut out = Vec::with_capacity(film.pixels().len() * 3);
        let mut push =
            |c: Color| out.extend([self.encode(c.x), self.encode(c.y), self.encode(c.z)]);
        if let Exposure::Reinhard(r) = self.exposure {
            let fit = r.fit(film);
            for &c in film.pixels() {
                push(c * fit.pixel_scale(c));
            }
        } else {
            let e = self.exposure_for(film);
            for &c in film.pixels() {
                push(c * e);
            }
        }
        out
    }
}

/// The sRGB chunk's fallbacks (PNG 1.2, section 11.3.3.5): gAMA 45455
/// and the BT.709 primaries with a D65 white point.
fn srgb_chromaticities() -> png::SourceChromaticities {
    let f = png::ScaledFloat::from_scaled;
    png::SourceChromaticities {
        white: (f(31270), f(32900)),
        red: (f(64000), f(33000)),
        green: (f(30000), f(60000)),
        blue: (f(15000), f(6000)),
    }
}

/// Encodes `film` as an 8-bit RGB PNG tagged with its colour space: an
/// sRGB chunk (with its gAMA and cHRM fallbacks) for the sRGB curve, or a
/// gAMA chunk of `1/G` for [`Transfer::Gamma`]`(G)`.
pub fn encode_png<W: Write>(film: &Film, tone: &ToneMap, w: W) -> std::io::Result<()> {
    let (wd, ht) = (film.width(), film.height());
    let (w32, h32) = match (u32::try_from(wd), u32::try_from(ht)) {
        (Ok(a), Ok(b)) => (a, b),
        _ => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{wd}x{ht}: image too large for PNG"),
            ))
        }
    };
    let buf = tone.to_rgb8(film);
    let mut enc = png::Encoder::new(w, w32, h32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    match tone.transfer {
        Transfer::Srgb => {
            enc.set_source_gamma(png::ScaledFloat::from_scaled(45455));
            enc.set_source_chromaticities(srgb_chromaticities());
            enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        }
        Transfer::Gamma(g) => {
            // PNG stores 100000 times the value, rounded.
            let scaled = (1e5 / g).round().clamp(1.0, u32::MAX as f64) as u32;
            enc.set_source_gamma(png::ScaledFloat::from_scaled(scaled))
        }
    }
    let to_io = |e: png::EncodingError| match e {
        png::EncodingError::IoError(io) => io,
        other => std::io::Error::other(other.to_string()),
    };
    let mut writer = enc.write_header().map_err(to_io)?;
    writer.write_image_data(&buf).map_err(to_io)?;
    writer.finish().map_err(to_io)
}

/// Writes `film` as an 8-bit RGB PNG (see [`encode_png`]).
pub fn write_png(film: &Film, path: &Path, tone: &ToneMap) -> Result<()> {
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    encode_png(film, tone, &mut w).map_err(|e| Error::io(path, e))?;
    w.flush().map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A film of grey pixels with the given luminances (row-major, one row).
    fn grey(lums: &[f64]) -> Film {
        let mut f = Film::new(lums.len(), 1);
        for (x, &l) in lums.iter().enumerate() {
            f.set(x, 0, Color::splat(l / brightness(Color::ONE)));
        }
        f
    }

    fn wide_film() -> Film {
        // Seven decades of luminance, not sorted.
        grey(&[3.0, 0.01, 250.0, 0.5, 1e-3, 40.0, 7.0, 0.08, 1e4, 0.2])
    }

    #[test]
    fn reinhard_is_monotone_and_maps_white_to_one() {
        let film = wide_film();
        let fit = Reinhard::default().fit(&film);
        let mut lums: Vec<f64> = film.pixels().iter().map(|&c| brightness(c)).collect();
        lums.sort_by(f64::total_cmp);
        let shown: Vec<f64> = lums.iter().map(|&l| fit.display(l)).collect();
        for w in shown.windows(2) {
            assert!(w[0] < w[1], "{shown:?}");
        }
        // Finer steps too, between and beyond the pixels.
        let mut last = 0.0;
        for i in 1..=200 {
            let l = 1e-4 * 1.1f64.powi(i);
            let d = fit.display(l);
            assert!(d > last, "{l}: {d} after {last}");
            last = d;
        }
        let max = *lums.last().unwrap();
        assert!(
            (fit.display(max) - 1.0).abs() < 1e-12,
            "{}",
            fit.display(max)
        );
        assert!(fit.display(0.0) == 0.0);
    }

    #[test]
    fn reinhard_maps_the_log_average_to_the_key_mid_range() {
        let film = wide_film();
        let r = Reinhard::default();
        let fit = r.fit(&film);
        let lums: Vec<f64> = film.pixels().iter().map(|&c| brightness(c)).collect();
        let delta = 1e-4 * lums.iter().copied().fold(0.0, f64::max);
        let log_avg =
            (lums.iter().map(|&l| (delta + l).ln()).sum::<f64>() / lums.len() as f64).exp();
        assert!((fit.log_average - log_avg).abs() < 1e-9 * log_avg);
        // Before compression the log-average becomes the key ...
        assert!((fit.scale * log_avg - r.key).abs() < 1e-12);
        // ... and after it sits in the middle of the display range,
        // key / (1 + key) up to the white term.
        let d = fit.display(log_avg);
        let expect = r.key / (1.0 + r.key);
        assert!(d >= expect && d < expect * 1.001, "{d} vs {expect}");
        // 8-bit sRGB: middle grey, not black or white.
        let tone = ToneMap {
            exposure: Exposure::Reinhard(r),
            transfer: Transfer::Srgb,
        };
        let code = tone.encode(d);
        assert!((100..=130).contains(&code), "{code}");
    }

    #[test]
    fn reinhard_does_not_depend_on_units() {
        let film = wide_film();
        let mut scaled = film.clone();
        for y in 0..film.height() {
            for c in scaled.row_mut(y) {
                *c *= 1000.0;
            }
        }
        let tone = ToneMap {
            exposure: Exposure::Reinhard(Reinhard::default()),
            transfer: Transfer::Srgb,
        };
        assert_eq!(tone.to_rgb8(&film), tone.to_rgb8(&scaled));
    }

    #[test]
    fn reinhard_white_percentile_burns_out_the_brightest() {
        let film = wide_film();
        let all = Reinhard::default().fit(&film);
        let p90 = Reinhard {
            white_percentile: 90.0,
            ..Reinhard::default()
        }
        .fit(&film);
        // Nearest rank: the 9th of 10 sorted luminances (250) is white.
        let l250 = brightness(film.get(2, 0));
        assert!((p90.display(l250) - 1.0).abs() < 1e-12);
        assert!(p90.display(brightness(film.get(8, 0))) > 1.0);
        assert!(all.display(l250) < 1.0);
        // The same linear part either way.
        assert_eq!(all.scale, p90.scale);
    }

    #[test]
    fn reinhard_has_no_nan_on_black_equal_or_broken_pictures() {
        let tone = ToneMap {
            exposure: Exposure::Reinhard(Reinhard::default()),
            transfer: Transfer::Srgb,
        };
        let black = Film::new(4, 3);
        assert!(tone.to_rgb8(&black).iter().all(|&v| v == 0));
        let fit = Reinhard::default().fit(&black);
        assert!(fit.scale.is_finite() && fit.white.is_finite());

        let equal = grey(&[2.5; 6]);
        let fit = Reinhard::default().fit(&equal);
        for v in [fit.scale, fit.white, fit.display(2.5), fit.log_average] {
            assert!(v.is_finite(), "{fit:?}");
        }
        // Every pixel is the brightest: all white.
        assert!((fit.display(2.5) - 1.0).abs() < 1e-12);
        let px = tone.to_rgb8(&equal);
        assert!(px.iter().all(|&v| v == 255), "{px:?}");

        let mut odd = grey(&[1.0, 2.0, 3.0, 4.0]);
        odd.set(0, 0, Color::new(f64::NAN, 1.0, 1.0));
        odd.set(1, 0, Color::splat(f64::INFINITY));
        odd.set(2, 0, Color::splat(-5.0));
        let fit = Reinhard::default().fit(&odd);
        assert!(fit.scale.is_finite() && fit.scale > 0.0, "{fit:?}");
        let _ = tone.to_rgb8(&odd); // no panic
        assert_eq!(&tone.to_rgb8(&odd)[6..9], &[0, 0, 0]);
    }

    /// The chunks of a PNG: (type, data).
    fn chunks(png: &[u8]) -> Vec<(String, Vec<u8>)> {
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        let mut out = Vec::new();
        let mut i = 8;
        while i + 8 <= png.len() {
            let n = u32::from_be_bytes(png[i..i + 4].try_into().unwrap()) as usize;
            let ty = String::from_utf8_lossy(&png[i + 4..i + 8]).into_owned();
            out.push((ty, png[i + 8..i + 8 + n].to_vec()));
            i += 12 + n;
        }
        out
    }

    fn find<'a>(c: &'a [(String, Vec<u8>)], ty: &str) -> Option<&'a [u8]> {
        c.iter().find(|(t, _)| t == ty).map(|(_, d)| d.as_slice())
    }

    #[test]
    fn png_carries_srgb_or_gamma_chunks() {
        let film = wide_film();
        let mut srgb = Vec::new();
        let tone = ToneMap::default();
        encode_png(&film, &tone, &mut srgb).unwrap();
        let c = chunks(&srgb);
        assert_eq!(find(&c, "sRGB"), Some(&[0u8][..]), "perceptual intent");
        assert_eq!(find(&c, "gAMA"), Some(&45455u32.to_be_bytes()[..]));
        let chrm = find(&c, "cHRM").expect("cHRM");
        let v: Vec<u32> = chrm
            .chunks_exact(4)
            .map(|b| u32::from_be_bytes(b.try_into().unwrap()))
            .collect();
        assert_eq!(v, [31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000]);
        // The chunks come before the pixels.
        let pos = |t: &str| c.iter().position(|(x, _)| x == t).unwrap();
        assert!(pos("sRGB") < pos("IDAT") && pos("gAMA") < pos("IDAT"));

        let mut g = Vec::new();
        let tone = ToneMap {
            transfer: Transfer::Gamma(2.2),
            ..ToneMap::default()
        };
        encode_png(&film, &tone, &mut g).unwrap();
        let c = chunks(&g);
        assert!(find(&c, "sRGB").is_none() && find(&c, "cHRM").is_none());
        assert_eq!(find(&c, "gAMA"), Some(&45455u32.to_be_bytes()[..]));
        let mut g18 = Vec::new();
        let tone = ToneMap {
            transfer: Transfer::Gamma(1.8),
            ..ToneMap::default()
        };
        encode_png(&film, &tone, &mut g18).unwrap();
        // 1/1.8 = 0.55556 (PNG stores 100000 times the value).
        assert_eq!(
            find(&chunks(&g18), "gAMA"),
            Some(&55556u32.to_be_bytes()[..])
        );
        // The pixels read back as the tone map's.
        let img = image::load_from_memory(&g18).unwrap().to_rgb8();
        assert_eq!(img.into_raw(), tone.to_rgb8(&film));
    }
}
