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
//! quincunx pattern), and the refinement rpict carries from one interval
//! to the next (its `b`, which forces subdivision after a subdivided
//! interval and chains decisions across the whole picture) is local here:
//! an interval is refined whole when a neighbouring interval of its row
//! or column has ends that differ by more than `-pt`. Without it, small
//! highlights between equal grid samples were lost: the suite's chrome
//! figures (`mesh_cyl2` at 256 x 171) had 0.976 of the reference's mean
//! with `-ps 3` against 0.993 traced in full, and have 0.992 with it. So
//! every decision depends only on traced values in a grid cell and its
//! neighbours, and pixel values depend only on the pixel's position: any
//! region, rendered alone (with the grid cells it touches and one more on
//! each side as an apron), gets the same values as the whole picture,
//! whatever the tiling. [`Grid::fill_region`] is that
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
/// `pt`, interpolating the others. `b` > 0 forces the midpoint (and passes
/// `(b - 1) / 2` and `b / 2` on to the halves), as rpict's `b`: an interval
/// next to one with a big difference is refined too.
fn fill_interval(
    v: &mut [Color],
    offset: usize,
    pt: f64,
    b: usize,
    sample: &mut dyn FnMut(usize) -> Color,
) {
    let len = v.len() - 1;
    if len <= 1 {
        return;
    }
    let h = len >> 1;
    v[h] = if b > 0 || big_diff(v[0], v[len], pt) {
        sample(offset + h)
    } else {
        let ratio = h as f64 / len as f64;
        v[len] * ratio + v[0] * (1.0 - ratio)
    };
    fill_interval(&mut v[..=h], offset, pt, b.saturating_sub(1) / 2, sample);
    fill_interval(&mut v[h..], offset + h, pt, b / 2, sample);
}

/// How far an interval of `len` pixels is forced to be refined when a
/// neighbouring interval's ends differ (`neighbour`): all the way.
fn forced(neighbour: bool, len: usize) -> usize {
    if neighbour {
        len
    } else {
        0
    }
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
            // The grid samples just outside, for the outer intervals'
            // neighbours (they depend only on their position).
            let before = (ka > 0).then(|| sample(self.x.line(ka - 1), y));
            let after = (kb + 2 <= self.x.cells()).then(|| sample(self.x.line(kb + 2), y));
            let at = |k: usize, values: &[Color]| values[self.x.line(k) - lo];
            for k in ka..=kb {
                let (a, b) = (self.x.line(k) - lo, self.x.line(k + 1) - lo);
                let left = if k == ka {
                    before.is_some_and(|c| big_diff(c, at(k, &values), self.pt))
                } else {
                    big_diff(at(k - 1, &values), at(k, &values), self.pt)
                };
                let right = if k == kb {
                    after.is_some_and(|c| big_diff(at(k + 1, &values), c, self.pt))
                } else {
                    big_diff(at(k + 1, &values), at(k + 2, &values), self.pt)
                };
                let force = forced(left || right, b - a);
                fill_interval(&mut values[a..=b], a + lo, self.pt, force, &mut |x| {
                    sample(x, y)
                });
            }
        }
        Scanline { y, x0: lo, values }
    }

    /// Computes the pixels of the rectangle `xs` x `ys` (row 0 at the top),
    /// tracing with `sample(x, y)` the pixels the adaptive scheme needs
    /// (also outside the rectangle: in the grid cells it touches, and on
    /// their grid rows one cell more on each side) and
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
        // The grid columns spanning `xs`, and one grid cell more on each
        // side: a column's refinement looks at its neighbours' ends.
        let span = if self.x.cells() == 0 {
            0..0
        } else {
            let first = self.x.cell(xs.start).saturating_sub(1);
            let last = (self.x.cell(xs.end - 1) + 2).min(self.x.cells());
            self.x.line(first)..self.x.line(last)
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
            // Whether column `x`'s ends differ (None outside the picture).
            let differs = |x: Option<usize>| {
                x.filter(|&x| x < self.x.n).is_some_and(|x| {
                    big_diff(top.values[x - top.x0], bot.values[x - bot.x0], self.pt)
                })
            };
            for x in xs.clone() {
                col.clear();
                col.resize(bot_y - top_y + 1, Color::ZERO);
                col[0] = top.values[x - top.x0];
                col[bot_y - top_y] = bot.values[x - bot.x0];
                let neighbour = differs(x.checked_sub(1)) || differs(Some(x + 1));
                let force = forced(neighbour, bot_y - top_y);
                fill_interval(&mut col, top_y, self.pt, force, &mut |y| sample(x, y));
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

    /// rpict refines next to where it refined (its `b`); here a cell next
    /// to one whose ends differ is refined whole, so a highlight between
    /// equal grid samples is found beside an edge, and only there.
    #[test]
    fn refines_next_to_a_difference() {
        let (w, h, ps) = (33, 9, 4);
        let spot = |x0: usize| {
            move |x: usize, y: usize| {
                let edge = if x >= 24 { 2.0 } else { 1.0 };
                let spot = if (x, y) == (x0, 4) { 50.0 } else { 0.0 };
                Color::splat(edge + spot)
            }
        };
        let grid = Grid::new(w, h, ps, 0.05);
        let found = |x0: usize| {
            let f = spot(x0);
            let mut v = Color::ZERO;
            grid.fill_region(
                0..w,
                0..h,
                &mut None,
                &mut |x, y| f(x, y),
                &mut |x, y, c| {
                    if (x, y) == (x0, 4) {
                        v = c;
                    }
                },
            );
            v.x > 40.0
        };
        // The edge lies between grid columns 20 and 24: the cell 16..20
        // next to it is refined, the cell 4..8 far from it is not.
        assert!(found(18), "a highlight next to the edge");
        assert!(!found(6), "a highlight far from any difference");
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
        // Cells next to a big difference are refined whole, so the steep
        // gradient at the bottom costs a good part of them.
        assert!(n4 * 4 < n1 * 3, "{n4} of {n1} traced");
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
