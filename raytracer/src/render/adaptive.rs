//! Adaptive pixel sampling after `rpict` (`-ps`, `-pt`): samples on a grid
//! of spacing `-ps`, then each interval between two known values is split
//! in two, the middle pixel traced where the ends differ by more than `-pt`
//! (Radiance's `bigdiff`) and interpolated otherwise, recursively
//! (`fillsample` in rpict.c). Scanlines on the grid rows are filled first
//! (`fillscanline`), then every column between two grid rows
//! (`fillscanbar`).
//!
//! Unlike rpict, the grid is a fixed rectangular one (rows and columns at
//! multiples of `-ps`, plus the last row and column; rpict staggers a
//! quincunx pattern) and no sampling density is carried from one interval
//! to the next (rpict's `b` forces subdivision next to a subdivided
//! interval, which chains decisions across the whole picture). So every
//! decision depends only on traced values inside one grid cell, and pixel
//! values depend only on the pixel's position: any region, rendered alone
//! (with the grid cells it touches as an apron), gets the same values as
//! the whole picture, whatever the tiling. [`Grid::fill_region`] is that
//! region renderer; given a fully traced picture as its sampler it
//! reproduces the adaptive picture exactly (what the distributed renderers
//! do).

use std::ops::Range;

use crate::scene::Color;

/// Radiance's `bigdiff`: whether `a` and `b` differ in some channel by
/// more than `md` times the other's value.
pub fn big_diff(a: Color, b: Color, md: f64) -> bool {
    (0..3).any(|i| a[i] - b[i] > md * b[i] || b[i] - a[i] > md * a[i])
}

/// The sampling grid along one image axis of `n` pixels.
#[derive(Debug, Clone, Copy)]
struct Axis {
    n: usize,
    ps: usize,
}

impl Axis {
    /// Number of grid intervals (0 for a single pixel).
    fn cells(self) -> usize {
        (self.n - 1).div_ceil(self.ps)
    }
    /// Position of grid line `k` (the last one is the last pixel).
    fn line(self, k: usize) -> usize {
        (k * self.ps).min(self.n - 1)
    }
    /// The interval holding pixel `p`.
    fn cell(self, p: usize) -> usize {
        (p / self.ps).min(self.cells().saturating_sub(1))
    }
}

/// `fillsample`: `v[0]` and `v[len]` are known; fills `v[1..len]`, tracing
/// (with `sample(offset + i)`) the midpoints whose ends differ by more than
/// `pt`, interpolating the others.
fn fill_interval(v: &mut [Color], offset: usize, pt: f64, sample: &mut dyn FnMut(usize) -> Color) {
    let len = v.len() - 1;
    if len <= 1 {
        return;
    }
    let h = len >> 1;
    v[h] = if big_diff(v[0], v[len], pt) {
        sample(offset + h)
    } else {
        let ratio = h as f64 / len as f64;
        v[len] * ratio + v[0] * (1.0 - ratio)
    };
    fill_interval(&mut v[..=h], offset, pt, sample);
    fill_interval(&mut v[h..], offset + h, pt, sample);
}

/// One filled grid row: pixels `x0..x0 + values.len()` of row `y`.
#[derive(Debug, Clone, Default)]
pub struct Scanline {
    y: usize,
    x0: usize,
    values: Vec<Color>,
}

/// The adaptive sampler of a `width` x `height` picture.
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    x: Axis,
    y: Axis,
    pt: f64,
}

impl Grid {
    /// `ps` >= 1 (1: every pixel traced), `pt` >= 0.
    pub fn new(width: usize, height: usize, ps: u32, pt: f64) -> Self {
        let ps = ps.max(1) as usize;
        Self {
            x: Axis { n: width, ps },
            y: Axis { n: height, ps },
            pt,
        }
    }

    /// Row ranges of the bands a sequential renderer goes through (one grid
    /// interval each, the last band holding the last row too).
    pub fn bands(&self) -> Vec<Range<usize>> {
        let cells = self.y.cells();
        if cells == 0 {
            return std::iter::once(0..self.y.n).collect();
        }
        (0..cells)
            .map(|k| {
                let end = if k + 1 == cells {
                    self.y.n
                } else {
                    self.y.line(k + 1)
                };
                self.y.line(k)..end
            })
            .collect()
    }

    /// Grid row `y` filled over columns `xs` (grid lines), reusing `carry`
    /// if it is that very row.
    fn scanline(
        &self,
        y: usize,
        xs: Range<usize>,
        carry: &mut Option<Scanline>,
        sample: &mut dyn FnMut(usize, usize) -> Color,
    ) -> Scanline {
        if let Some(s) = carry.take() {
            if s.y == y && s.x0 == xs.start && s.values.len() == xs.len() + 1 {
                return s;
            }
        }
        let (lo, hi) = (xs.start, xs.end);
        let mut values = vec![Color::ZERO; hi - lo + 1];
        if self.x.cells() == 0 {
            values[0] = sample(lo, y);
        } else {
            let (ka, kb) = (self.x.cell(lo), self.x.cell(hi.max(1) - 1));
            for k in ka..=kb + 1 {
                let x = self.x.line(k);
                values[x - lo] = sample(x, y);
            }
            for k in ka..=kb {
                let (a, b) = (self.x.line(k) - lo, self.x.line(k + 1) - lo);
                fill_interval(&mut values[a..=b], a + lo, self.pt, &mut |x| sample(x, y));
            }
        }
        Scanline { y, x0: lo, values }
    }

    /// Computes the pixels of the rectangle `xs` x `ys` (row 0 at the top),
    /// tracing with `sample(x, y)` the pixels the adaptive scheme needs
    /// (also outside the rectangle, in the grid cells it touches) and
    /// passing every pixel of the rectangle once to `write(x, y, value)`.
    /// `carry` keeps the last grid row filled (reused when the next call
    /// starts on it, as consecutive bands of [`Grid::bands`] do).
    pub fn fill_region(
        &self,
        xs: Range<usize>,
        ys: Range<usize>,
        carry: &mut Option<Scanline>,
        sample: &mut dyn FnMut(usize, usize) -> Color,
        write: &mut dyn FnMut(usize, usize, Color),
    ) {
        if xs.is_empty() || ys.is_empty() {
            return;
        }
        // The grid columns spanning `xs`.
        let span = if self.x.cells() == 0 {
            0..0
        } else {
            self.x.line(self.x.cell(xs.start))..self.x.line(self.x.cell(xs.end - 1) + 1)
        };
        if self.y.cells() == 0 {
            let s = self.scanline(0, span, carry, sample);
            for x in xs {
                write(x, 0, s.values[x - s.x0]);
            }
            return;
        }
        let cells = self.y.cells();
        let mut col = Vec::new();
        for k in self.y.cell(ys.start)..=self.y.cell(ys.end - 1) {
            let (top_y, bot_y) = (self.y.line(k), self.y.line(k + 1));
            let top = self.scanline(top_y, span.clone(), carry, sample);
            let bot = self.scanline(bot_y, span.clone(), &mut None, sample);
            let last = if k + 1 == cells { bot_y } else { bot_y - 1 };
            let rows = top_y.max(ys.start)..last.min(ys.end - 1) + 1;
            for x in xs.clone() {
                col.clear();
                col.resize(bot_y - top_y + 1, Color::ZERO);
                col[0] = top.values[x - top.x0];
                col[bot_y - top_y] = bot.values[x - bot.x0];
                fill_interval(&mut col, top_y, self.pt, &mut |y| sample(x, y));
                for y in rows.clone() {
                    write(x, y, col[y - top_y]);
                }
            }
            *carry = Some(bot);
        }
    }
}

/// The adaptive picture of `-ps` `ps` and `-pt` `pt` from a picture whose
/// every pixel was traced: the same picture, bit for bit, as sampling
/// adaptively with the same per-pixel values (renderers that trace pixels
/// out of order use this; they pay for every pixel).
pub fn resample(full: &crate::image::Film, ps: u32, pt: f64) -> crate::image::Film {
    let (w, h) = (full.width(), full.height());
    let mut out = crate::image::Film::new(w, h);
    if w == 0 || h == 0 {
        return out;
    }
    let grid = Grid::new(w, h, ps, pt);
    let mut carry = None;
    for band in grid.bands() {
        grid.fill_region(
            0..w,
            band,
            &mut carry,
            &mut |x, y| full.get(x, y),
            &mut |x, y, c| out.set(x, y, c),
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A picture with a sharp edge and smooth gradients.
    fn truth(x: usize, y: usize) -> Color {
        let (fx, fy) = (x as f64, y as f64);
        let edge = if fx + 0.5 * fy > 20.0 { 4.0 } else { 0.5 };
        Color::splat(edge + 0.01 * fx + 0.002 * fy * fy)
    }

    fn render(
        grid: &Grid,
        w: usize,
        h: usize,
        tiles: &[(Range<usize>, Range<usize>)],
    ) -> (Vec<Color>, usize) {
        let mut img = vec![Color::splat(-1.0); w * h];
        let mut traced = 0;
        for (xs, ys) in tiles {
            let mut carry = None;
            grid.fill_region(
                xs.clone(),
                ys.clone(),
                &mut carry,
                &mut |x, y| {
                    traced += 1;
                    truth(x, y)
                },
                &mut |x, y, c| {
                    assert_eq!(img[y * w + x], Color::splat(-1.0), "pixel {x},{y} twice");
                    img[y * w + x] = c;
                },
            );
        }
        (img, traced)
    }

    #[test]
    fn big_diff_is_radiances() {
        let a = Color::new(1.0, 1.0, 1.0);
        assert!(!big_diff(a, Color::new(1.04, 1.0, 0.97), 0.05));
        assert!(big_diff(a, Color::new(1.06, 1.0, 1.0), 0.05));
        assert!(big_diff(a, Color::new(1.0, 1.0, 0.94), 0.05));
        assert!(!big_diff(Color::ZERO, Color::ZERO, 0.0));
        assert!(big_diff(Color::ZERO, Color::splat(1e-9), 0.05));
    }

    #[test]
    fn any_tiling_gives_the_same_picture() {
        for (w, h, ps) in [
            (37, 29, 4),
            (16, 16, 3),
            (1, 9, 4),
            (9, 1, 2),
            (5, 5, 8),
            (1, 1, 4),
        ] {
            let grid = Grid::new(w, h, ps, 0.05);
            let (whole, traced) = render(&grid, w, h, &[(0..w, 0..h)]);
            assert!(
                whole.iter().all(|c| c.x >= 0.0),
                "{w}x{h}: a pixel unwritten"
            );
            // Band by band with a carried scanline (the sequential renderer).
            let mut banded = vec![Color::ZERO; w * h];
            let mut carry = None;
            let mut traced_bands = 0;
            for b in grid.bands() {
                grid.fill_region(
                    0..w,
                    b,
                    &mut carry,
                    &mut |x, y| {
                        traced_bands += 1;
                        truth(x, y)
                    },
                    &mut |x, y, c| banded[y * w + x] = c,
                );
            }
            assert_eq!(whole, banded, "{w}x{h} -ps {ps}: bands");
            assert!(traced_bands <= traced + w, "{traced_bands} vs {traced}");
            for t in [1, 2, 5, 7, 16] {
                let mut tiles = Vec::new();
                for y0 in (0..h).step_by(t) {
                    for x0 in (0..w).step_by(t) {
                        tiles.push((x0..(x0 + t).min(w), y0..(y0 + t).min(h)));
                    }
                }
                let (tiled, _) = render(&grid, w, h, &tiles);
                assert_eq!(whole, tiled, "{w}x{h} -ps {ps}, tiles of {t}");
            }
        }
    }

    #[test]
    fn traces_fewer_pixels_where_smooth_and_keeps_the_edge() {
        let (w, h) = (64, 48);
        let full = Grid::new(w, h, 1, 0.05);
        let (exact, n1) = render(&full, w, h, &[(0..w, 0..h)]);
        assert_eq!(n1, w * h);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(exact[y * w + x], truth(x, y));
            }
        }
        let grid = Grid::new(w, h, 4, 0.05);
        let (img, n4) = render(&grid, w, h, &[(0..w, 0..h)]);
        assert!(n4 * 2 < n1, "{n4} of {n1} traced");
        // The edge is sharp: interpolated values never straddle it by more
        // than the threshold (each pixel is within 5% of its true value).
        let worst = (0..w * h)
            .map(|i| ((img[i].x - exact[i].x) / exact[i].x).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.05, "worst relative error {worst}");
        // -pt 0 traces every pixel whose neighbours differ at all.
        let strict = Grid::new(w, h, 4, 0.0);
        let (img0, _) = render(&strict, w, h, &[(0..w, 0..h)]);
        assert_eq!(img0, exact);
    }
}
