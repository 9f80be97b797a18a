//! Comparing a render with a reference picture made elsewhere (Radiance's
//! regression images): the figures its README uses, so the tolerances it
//! measured between two Radiance runs apply.
//!
//! - mean ratio: mean luminance of the render / mean of the reference;
//! - nRMSE: RMS of the per-pixel luminance difference / the reference's
//!   mean, after both are smoothed with the same box filter (sampling
//!   noise and sub-pixel aliasing differ between renderers; structure
//!   does not).
//!
//! Luminance is Radiance's: 179 (0.265074 R + 0.670115 G + 0.064811 B).

use std::path::Path;

use super::hdr::{read_hdr, write_hdr};
use super::Film;
use crate::geometry::Color;
use crate::{Error, Result};

/// Radiance's luminous efficacy times its RGB luminance weights.
pub fn luminance(c: Color) -> f64 {
    179.0 * (0.265074 * c.x + 0.670115 * c.y + 0.064811 * c.z)
}

/// A reference picture with its exposure divided out.
#[derive(Debug, Clone)]
pub struct Reference {
    pub film: Film,
    /// Product of the header's `EXPOSURE=` values (divided out of `film`).
    pub exposure: f64,
    /// The header's `VIEW=` line, if any (Radiance's view options).
    pub view: Option<String>,
}

impl Reference {
    /// Reads a Radiance picture and divides out its exposure.
    pub fn load(path: &Path) -> Result<Reference> {
        let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES)
            .map_err(|e| Error::io(path, e))?;
        let img = read_hdr(&mut std::io::Cursor::new(bytes)).map_err(|e| Error::io(path, e))?;
        let mut exposure = 1.0;
        let mut view = None;
        for line in &img.header {
            if let Some(v) = line.trim().strip_prefix("EXPOSURE=") {
                let e: f64 = v.trim().parse().map_err(|_| {
                    Error::parse(
                        crate::SourceLoc::new(path, 0),
                        format!("bad EXPOSURE line '{line}'"),
                    )
                })?;
                if e > 0.0 && e.is_finite() {
                    exposure *= e;
                }
            }
            if let Some(v) = line.trim().strip_prefix("VIEW=") {
                view = Some(v.trim().to_string());
            }
        }
        let mut film = img.film;
        for y in 0..film.height() {
            for c in film.row_mut(y) {
                *c /= exposure;
            }
        }
        Ok(Reference {
            film,
            exposure,
            view,
        })
    }
}

/// How a render compares with a reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Comparison {
    /// Mean luminance of the render over that of the reference.
    pub mean_ratio: f64,
    /// The reference's mean luminance (cd/m2).
    pub reference_mean: f64,
    /// RMS of the smoothed per-pixel luminance difference over the
    /// reference's mean.
    pub nrmse: f64,
    /// Radius of the box filter applied before `nrmse` (0 = none).
    pub smoothing: usize,
}

/// The luminance of every pixel, box-filtered with `radius`.
fn smoothed(f: &Film, radius: usize) -> Vec<f64> {
    let (w, h) = (f.width(), f.height());
    let lum: Vec<f64> = f.pixels().iter().map(|&c| luminance(c)).collect();
    if radius == 0 {
        return lum;
    }
    let r = radius as isize;
    let mut out = vec![0.0; w * h];
    for y in 0..h as isize {
        for x in 0..w as isize {
            let (mut sum, mut n) = (0.0, 0.0);
            for dy in -r..=r {
                for dx in -r..=r {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx >= 0 && yy >= 0 && xx < w as isize && yy < h as isize {
                        sum += lum[yy as usize * w + xx as usize];
                        n += 1.0;
                    }
                }
            }
            out[y as usize * w + x as usize] = sum / n;
        }
    }
    out
}

/// Compares `render` with `reference` (same size) after smoothing both
/// with a box of `radius` pixels.
pub fn compare(render: &Film, reference: &Film, radius: usize) -> Result<Comparison> {
    if (render.width(), render.height()) != (reference.width(), reference.height()) {
        return Err(Error::Other(format!(
            "cannot compare a {}x{} render with a {}x{} reference",
            render.width(),
            render.height(),
            reference.width(),
            reference.height()
        )));
    }
    let n = (render.width() * render.height()).max(1) as f64;
    let a = smoothed(render, radius);
    let b = smoothed(reference, radius);
    let mean_a = render.pixels().iter().map(|&c| luminance(c)).sum::<f64>() / n;
    let mean_b = reference
        .pixels()
        .iter()
        .map(|&c| luminance(c))
        .sum::<f64>()
        / n;
    let mse = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        / n;
    Ok(Comparison {
        mean_ratio: mean_a / mean_b,
        reference_mean: mean_b,
        nrmse: mse.sqrt() / mean_b,
        smoothing: radius,
    })
}

/// Reduces `f` by `k` as `pfilt -1 -r rad -x /k -y /k` does: each output
/// pixel is a Gaussian-weighted mean of the input pixels around it,
/// weight `exp(-d^2)` with `d` the distance in output pixels over `rad`
/// (Radiance's `pf3.c`), summed out to 2 `rad`. The suite's references
/// were made by such a step (`-r 1` down to 128 pixels), which blurs more
/// than a box: thin high-contrast stripes compared after a box reduction
/// differ from the reference by far more than any rendering error.
pub fn pfilt_reduce(f: &Film, k: usize, rad: f64) -> Film {
    let k = k.max(1);
    let rad = if rad > 0.0 { rad } else { 1.0 };
    let (w, h) = (f.width() / k, f.height() / k);
    let mut out = Film::new(w, h);
    let scale = 1.0 / k as f64;
    let reach = (2.0 * rad * k as f64).ceil() as isize + 1;
    for r in 0..h {
        for c in 0..w {
            let (xc, yc) = ((c * k + k / 2) as isize, (r * k + k / 2) as isize);
            let mut sum = Color::ZERO;
            let mut wsum = 0.0;
            for y in (yc - reach).max(0)..(yc + reach).min(f.height() as isize) {
                let dy = (scale * (y as f64 + 0.5) - (r as f64 + 0.5)) / rad;
                for x in (xc - reach).max(0)..(xc + reach).min(f.width() as isize) {
                    let dx = (scale * (x as f64 + 0.5) - (c as f64 + 0.5)) / rad;
                    let d2 = dx * dx + dy * dy;
                    if d2 > 4.0 {
                        continue;
                    }
                    let wgt = (-d2).exp();
                    sum += f.get(x as usize, y as usize) * wgt;
                    wsum += wgt;
                }
            }
            out.set(c, r, if wsum > 0.0 { sum / wsum } else { sum });
        }
    }
    out
}

/// Writes the signed luminance difference (render - reference) as a
/// picture: red where the render is brighter, blue where darker, scaled
/// by the reference's mean.
pub fn write_difference(render: &Film, reference: &Film, path: &Path) -> Result<()> {
    let (w, h) = (
        render.width().min(reference.width()),
        render.height().min(reference.height()),
    );
    let mean = reference
        .pixels()
        .iter()
        .map(|&c| luminance(c))
        .sum::<f64>()
        / (reference.pixels().len().max(1) as f64);
    let mut d = Film::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v =
                (luminance(render.get(x, y)) - luminance(reference.get(x, y))) / mean.max(1e-12);
            d.set(
                x,
                y,
                if v > 0.0 {
                    Color::new(v, 0.0, 0.0)
                } else {
                    Color::new(0.0, 0.0, -v)
                },
            );
        }
    }
    let f = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::new(f);
    write_hdr(&mut w, &d, 1.0, &super::HdrInfo::default()).map_err(|e| Error::io(path, e))?;
    std::io::Write::flush(&mut w).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod pfilt_tests {
    use super::*;

    /// A flat picture stays flat; a single bright pixel spreads over its
    /// neighbours symmetrically and keeps its energy's share.
    #[test]
    fn gaussian_reduction_is_normalised_and_symmetric() {
        let mut f = Film::new(16, 16);
        for y in 0..16 {
            for x in 0..16 {
                f.set(x, y, Color::splat(2.0));
            }
        }
        let g = pfilt_reduce(&f, 2, 1.0);
        assert!(g.pixels().iter().all(|c| (c.x - 2.0).abs() < 1e-12));
        let mut f = Film::new(16, 16);
        f.set(7, 7, Color::splat(1.0));
        f.set(8, 8, Color::splat(1.0));
        f.set(7, 8, Color::splat(1.0));
        f.set(8, 7, Color::splat(1.0));
        let g = pfilt_reduce(&f, 2, 1.0);
        let (a, b) = (g.get(3, 3).x, g.get(4, 4).x);
        assert!(a > 0.0 && (a - b).abs() < 1e-12 && (g.get(3, 4).x - a).abs() < 1e-12);
        // Blurrier than a box: the neighbours of the bright block get some.
        assert!(g.get(2, 3).x > 0.0);
    }
}
