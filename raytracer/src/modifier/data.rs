//! Radiance data files (`.dat`) and pictures as N-dimensional data, as
//! Radiance's `data.c` reads and interpolates them (`getdata`, `getpict`,
//! `datavalue`).
//!
//! A data file is whitespace-separated words (`#` starts a comment that runs
//! to the end of the line; numbers may be laid out in any way):
//!
//! ```text
//! N                       number of dimensions, 1 to 5
//! begin end count         one line per dimension, evenly spaced points, or
//! 0 0 count p0 p1 ...     the count coordinates of unevenly spaced points
//! v v v ...               count0 * count1 * ... values, later dimensions
//!                         changing faster
//! ```
//!
//! Words after the last value are ignored, as Radiance ignores them.
//! Coordinates and values are kept in single precision (Radiance's
//! `DATATYPE` is `float`) and interpolated in double precision, so
//! [`DataArray::value`] returns what `datavalue()` returns.
//!
//! Outside the grid Radiance neither clamps nor extrapolates linearly
//! forever: along each dimension it extrapolates linearly from the two end
//! points for one division, then tapers harmonically towards zero. Exactly
//! (with `x` the position in grid steps and `i` the clamped cell):
//! `x > i + 2`: `(2*y1 - y0) / (x - (i - 1))`;
//! `x < i - 1`: `(2*y0 - y1) / (i - x)`; otherwise linear. Past the high
//! end this jumps (to a third) at one division out; that is Radiance 5's
//! behaviour and is kept. (Radiance 6's rewrite, `data_interp`, flips the
//! sign of the low-side taper; we follow 5.x.)

use std::path::Path;

use crate::image::hdr::read_hdr;
use crate::{Error, Result, SourceLoc};

/// Radiance's `MAXDDIM`: the most dimensions a data file may have.
pub const MAX_DIMS: usize = 5;

/// Radiance's `fgetval` word buffer: words this long or longer are errors.
const MAX_WORD: usize = 64;

/// C's `isspace` in the "C" locale.
fn is_space(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
}

/// The words of a Radiance text input (data files, fonts), read as
/// `fgetval` reads them: white space separates words, `#` starts a comment
/// running to the end of the line and also ends a word.
pub(crate) struct Words<'a> {
    text: &'a [u8],
    pos: usize,
    /// Line of the read position, counting from 1.
    line: usize,
}

impl<'a> Words<'a> {
    pub(crate) fn new(text: &'a [u8]) -> Self {
        Self {
            text,
            pos: 0,
            line: 1,
        }
    }

    /// The line the reader has reached (for "unexpected end of file").
    pub(crate) fn line(&self) -> usize {
        self.line
    }

    /// The next word and the line it starts on.
    pub(crate) fn next_word(&mut self) -> Option<(&'a [u8], usize)> {
        loop {
            while let Some(&c) = self.text.get(self.pos) {
                if !is_space(c) {
                    break;
                }
                if c == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            }
            if self.text.get(self.pos) != Some(&b'#') {
                break;
            }
            while let Some(&c) = self.text.get(self.pos) {
                self.pos += 1;
                if c == b'\n' {
                    self.line += 1;
                    break;
                }
            }
        }
        if self.pos >= self.text.len() {
            return None;
        }
        let start = self.pos;
        while let Some(&c) = self.text.get(self.pos) {
            if is_space(c) || c == b'#' {
                break;
            }
            self.pos += 1;
        }
        Some((&self.text[start..self.pos], self.line))
    }
}

/// Radiance's `isint`: an optional sign and at least one digit.
pub(crate) fn is_int(s: &[u8]) -> bool {
    let digits = match s.first() {
        Some(b'+' | b'-') => &s[1..],
        _ => s,
    };
    !digits.is_empty() && digits.iter().all(u8::is_ascii_digit)
}

/// Radiance's `isflt`: `[+-]digits[.digits][e[+-]digits]` with at least one
/// digit before the exponent (`.5` and `5.` are numbers, `.` is not).
pub(crate) fn is_flt(s: &[u8]) -> bool {
    let mut i = usize::from(matches!(s.first(), Some(b'+' | b'-')));
    let mut start = i;
    while s.get(i).is_some_and(u8::is_ascii_digit) {
        i += 1;
    }
    if s.get(i) == Some(&b'.') {
        i += 1;
        start += 1;
        while s.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
    }
    if i == start {
        return false;
    }
    match s.get(i) {
        None => true,
        Some(b'e' | b'E') => is_int(&s[i + 1..]),
        Some(_) => false,
    }
}

/// Reads numbers from a data file with `file:line` errors.
struct Reader<'a> {
    words: Words<'a>,
    file: &'a Path,
    /// Line of the last word read.
    last_line: usize,
}

impl<'a> Reader<'a> {
    fn err(&self, line: usize, reason: impl Into<String>) -> Error {
        Error::parse(SourceLoc::new(self.file, line), reason)
    }

    fn word(&mut self, what: &str) -> Result<(&'a str, usize)> {
        let Some((w, line)) = self.words.next_word() else {
            return Err(self.err(
                self.words.line(),
                format!("unexpected end of file: expected {what}"),
            ));
        };
        self.last_line = line;
        let text = std::str::from_utf8(w).unwrap_or("");
        if text.is_empty() || w.len() >= MAX_WORD {
            let shown = String::from_utf8_lossy(&w[..w.len().min(20)]).into_owned();
            return Err(self.err(
                line,
                format!("bad format: expected {what}, found {shown:?}"),
            ));
        }
        Ok((text, line))
    }

    fn int(&mut self, what: &str) -> Result<(i64, usize)> {
        let (w, line) = self.word(what)?;
        match w.parse::<i32>() {
            Ok(v) if is_int(w.as_bytes()) => Ok((i64::from(v), line)),
            _ => Err(self.err(
                line,
                format!("bad format: expected {what} (an integer), found {w:?}"),
            )),
        }
    }

    /// A number as Radiance stores it: `atof` (double) rounded to `float`.
    fn float(&mut self, what: &str) -> Result<f32> {
        let (w, line) = self.word(what)?;
        match w.parse::<f64>() {
            Ok(v) if is_flt(w.as_bytes()) => Ok(v as f32),
            _ => Err(self.err(
                line,
                format!("bad format: expected {what} (a number), found {w:?}"),
            )),
        }
    }
}

/// One dimension of a data array.
#[derive(Debug, Clone, PartialEq)]
struct Dim {
    /// First coordinate.
    org: f32,
    /// Last coordinate minus the first (negative for decreasing
    /// coordinates), computed in single precision as Radiance does.
    siz: f32,
    /// Number of points, at least 2.
    ne: usize,
    /// Coordinates of unevenly spaced points (monotonic), if given.
    p: Option<Vec<f32>>,
}

impl Dim {
    fn even(org: f32, siz: f32, ne: usize) -> Self {
        Self {
            org,
            siz,
            ne,
            p: None,
        }
    }

    /// `datavalue`'s independent variable: the cell `i` (0 to `ne - 2`)
    /// and the position `x` in grid steps (outside `[i, i + 1]` when `pt`
    /// lies outside the cell).
    fn locate(&self, pt: f64) -> (usize, f64) {
        let last = self.ne - 2;
        match &self.p {
            None => {
                let x = (pt - f64::from(self.org)) / f64::from(self.siz) * (self.ne - 1) as f64;
                // C's `i = x` (truncation); out-of-range values saturate.
                let i = (x as i64).clamp(0, last as i64) as usize;
                (i, x)
            }
            Some(p) => {
                let (mut lower, mut upper) = if self.siz > 0.0 {
                    (0, self.ne)
                } else {
                    (self.ne, 0)
                };
                let mut i;
                loop {
                    i = (lower + upper) >> 1;
                    if pt >= f64::from(p[i]) {
                        lower = i;
                    } else {
                        upper = i;
                    }
                    if i == (lower + upper) >> 1 {
                        break;
                    }
                }
                let i = i.min(last);
                let x = i as f64 + (pt - f64::from(p[i])) / f64::from(p[i + 1] - p[i]);
                (i, x)
            }
        }
    }
}

/// `datavalue`'s blend of the values `y0` at cell `i` and `y1` at `i + 1`
/// for position `x` (in grid steps): linear within one division of the
/// cell, then a harmonic taper to zero (Radiance 5's formulas, verbatim).
fn blend(i: usize, x: f64, y0: f64, y1: f64) -> f64 {
    let i = i as f64;
    if x > i + 2.0 {
        (2.0 * y1 - y0) / (x - (i - 1.0))
    } else if x < i - 1.0 {
        (2.0 * y0 - y1) / (i - x)
    } else {
        y0 * ((i + 1.0) - x) + y1 * (x - i)
    }
}

/// A Radiance data file: values on an N-dimensional grid (Radiance's
/// `DATARRAY` of type `DATATY`).
#[derive(Debug, Clone, PartialEq)]
pub struct DataArray {
    dims: Vec<Dim>,
    /// Row-major values, the last dimension changing fastest.
    values: Vec<f32>,
}

impl DataArray {
    /// Reads the data file at `path`; `from` is the scene line that names
    /// it (for "cannot open" errors). Errors in the file name its line.
    pub fn load(path: &Path, from: &SourceLoc) -> Result<DataArray> {
        let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| {
            Error::parse(
                from.clone(),
                format!("cannot open data file \"{}\": {e}", path.display()),
            )
        })?;
        Self::parse(&bytes, path)
    }

    /// Parses the contents of a data file; `file` names it in errors.
    pub fn parse(bytes: &[u8], file: &Path) -> Result<DataArray> {
        let mut r = Reader {
            words: Words::new(bytes),
            file,
            last_line: 1,
        };
        let (nd, line) = r.int("the number of dimensions")?;
        if !(1..=MAX_DIMS as i64).contains(&nd) {
            return Err(r.err(
                line,
                format!("bad number of dimensions {nd} (1 to {MAX_DIMS})"),
            ));
        }
        // Every value or coordinate takes at least one byte, so a count
        // above the file's length can never be satisfied: refuse it before
        // allocating.
        let budget = bytes.len();
        let mut dims = Vec::with_capacity(nd as usize);
        let mut total: usize = 1;
        for d in 0..nd as usize {
            let org = r.float("a dimension's beginning")?;
            let end = r.float("a dimension's end")?;
            let (ne, line) = r.int("a dimension's number of points")?;
            if ne < 2 {
                return Err(r.err(
                    line,
                    format!("dimension {} has {ne} points (at least 2 needed)", d + 1),
                ));
            }
            let ne = ne as usize;
            total = total
                .checked_mul(ne)
                .filter(|&t| t <= budget)
                .ok_or_else(|| {
                    r.err(
                        line,
                        format!(
                            "{ne} points in dimension {} is more than the file holds",
                            d + 1
                        ),
                    )
                })?;
            let siz = end - org;
            if siz != 0.0 {
                dims.push(Dim::even(org, siz, ne));
                continue;
            }
            // `0 0 n` (or any equal begin and end): n coordinates follow.
            let mut p = Vec::with_capacity(ne);
            for _ in 0..ne {
                p.push(r.float("a point coordinate")?);
            }
            if let Some(j) = (1..ne - 1).find(|&j| (p[j - 1] < p[j]) != (p[j] < p[j + 1])) {
                return Err(r.err(
                    r.last_line,
                    format!(
                        "bad format: coordinates of dimension {} are not monotonic (at point {})",
                        d + 1,
                        j + 1
                    ),
                ));
            }
            dims.push(Dim {
                org: p[0],
                siz: p[ne - 1] - p[0],
                ne,
                p: Some(p),
            });
        }
        let mut values = Vec::with_capacity(total);
        for _ in 0..total {
            values.push(r.float("a data value")?);
        }
        Ok(DataArray { dims, values })
    }

    /// Number of dimensions (independent variables).
    pub fn dims(&self) -> usize {
        self.dims.len()
    }

    /// Number of points along each dimension.
    pub fn counts(&self) -> Vec<usize> {
        self.dims.iter().map(|d| d.ne).collect()
    }

    /// The coordinate range `(first, last)` of dimension `d` (`last < first`
    /// for decreasing coordinates).
    pub fn range(&self, d: usize) -> (f64, f64) {
        let dim = &self.dims[d];
        (f64::from(dim.org), f64::from(dim.org) + f64::from(dim.siz))
    }

    /// The stored values, the last dimension changing fastest.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Radiance's `datavalue()` at `x` (len == dims()). Missing coordinates
    /// count as 0 and extra ones are ignored; the caller checks the number
    /// of variables against [`dims`](Self::dims) when it loads the scene
    /// (Radiance's "dimension error").
    pub fn value(&self, x: &[f64]) -> f64 {
        debug_assert_eq!(x.len(), self.dims.len(), "data point dimension");
        self.interp(0, 0, x)
    }

    /// `datavalue` on the sub-array of dimensions `level..` starting at
    /// `base`.
    fn interp(&self, level: usize, base: usize, x: &[f64]) -> f64 {
        let dim = &self.dims[level];
        let (i, xi) = dim.locate(x.get(level).copied().unwrap_or(0.0));
        let (y0, y1) = if level + 1 == self.dims.len() {
            (
                f64::from(self.values[base + i]),
                f64::from(self.values[base + i + 1]),
            )
        } else {
            let stride: usize = self.dims[level + 1..].iter().map(|d| d.ne).product();
            (
                self.interp(level + 1, base + i * stride, x),
                self.interp(level + 1, base + (i + 1) * stride, x),
            )
        };
        blend(i, xi, y0, y1)
    }
}

/// A Radiance picture as three 2-D data arrays (red, green, blue), as
/// `getpict` makes it for `colorpict`, `mixpict` and `texdata`-like uses.
///
/// Picture coordinates: `(0, 0)` is the lower-left corner; the shorter side
/// (after the header's `PIXASPECT`) runs from 0 to 1 and the longer one from
/// 0 to its length relative to the shorter one: a picture `W` pixels wide
/// and `H` high (pixel aspect 1) spans `u` in `[0, W/H]`, `v` in `[0, 1]` if
/// `W > H`, else `u` in `[0, 1]`, `v` in `[0, H/W]`. Pixel centres are *not*
/// where the samples sit: Radiance puts the first column's value at `u = 0`
/// and the last column's at `u = umax` (likewise rows), interpolates
/// bilinearly between them, and extrapolates outside as [`DataArray`] does.
#[derive(Debug, Clone, PartialEq)]
pub struct PictureData {
    /// Dimension 0: rows, from the bottom (`v`); dimension 1: columns (`u`).
    rows: Dim,
    cols: Dim,
    /// RGB per pixel, bottom row first, as `colrval` decodes RGBE.
    pixels: Vec<[f32; 3]>,
}

impl PictureData {
    /// Reads the Radiance picture at `path`; `from` is the scene line that
    /// names it (for "cannot open" errors).
    pub fn load(path: &Path, from: &SourceLoc) -> Result<PictureData> {
        let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| {
            Error::parse(
                from.clone(),
                format!("cannot open picture file \"{}\": {e}", path.display()),
            )
        })?;
        Self::parse(&bytes, path)
    }

    /// Parses a picture held in memory; `file` names it in errors.
    pub fn parse(bytes: &[u8], file: &Path) -> Result<PictureData> {
        let bad = |reason: String| {
            Error::parse(
                SourceLoc::new(file, 0),
                format!("bad picture file: {reason}"),
            )
        };
        check_resolution(bytes).map_err(bad)?;
        let img = read_hdr(&mut &bytes[..]).map_err(|e| bad(e.to_string()))?;
        // Radiance's `headaspect`: the product of all PIXASPECT= lines.
        let mut aspect = 1.0f64;
        for l in &img.header {
            if let Some(v) = l.strip_prefix("PIXASPECT=") {
                aspect *= v.trim().parse::<f64>().unwrap_or(0.0);
            }
        }
        if aspect.is_nan() || aspect <= 1e-6 {
            return Err(bad(format!("pixel aspect {aspect}")));
        }
        let (w, h) = (img.film.width(), img.film.height());
        if w < 2 || h < 2 {
            return Err(bad(format!(
                "{w}x{h} pixels: at least 2x2 are needed to interpolate"
            )));
        }
        let (vsiz, usiz) = if w as f64 <= h as f64 * aspect {
            ((aspect * h as f64 / w as f64) as f32, 1.0f32)
        } else {
            (1.0f32, (w as f64 / h as f64 / aspect) as f32)
        };
        let mut pixels = Vec::with_capacity(w * h);
        for y in (0..h).rev() {
            for x in 0..w {
                let c = img.film.get(x, y);
                pixels.push([c.x as f32, c.y as f32, c.z as f32]);
            }
        }
        Ok(PictureData {
            rows: Dim::even(0.0, vsiz, h),
            cols: Dim::even(0.0, usiz, w),
            pixels,
        })
    }

    /// The picture's colour at picture coordinates (u, v), Radiance's
    /// convention: `datavalue` of each channel at `(v, u)` (rows are
    /// Radiance's first dimension). `colorpict`'s first coordinate variable
    /// is `u` and its second `v`.
    pub fn value(&self, u: f64, v: f64) -> [f64; 3] {
        let (i, xi) = self.rows.locate(v);
        let (j, xj) = self.cols.locate(u);
        let w = self.cols.ne;
        let px = |r: usize, c: usize| self.pixels[r * w + c];
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let row = |r: usize| blend(j, xj, f64::from(px(r, j)[k]), f64::from(px(r, j + 1)[k]));
            *o = blend(i, xi, row(i), row(i + 1));
        }
        out
    }

    /// Width over height in picture coordinates (`umax / vmax`).
    pub fn aspect(&self) -> f64 {
        f64::from(self.cols.siz) / f64::from(self.rows.siz)
    }

    /// The coordinate ranges' far ends `(umax, vmax)`; both start at 0 and
    /// the smaller is 1.
    pub fn extent(&self) -> (f64, f64) {
        (f64::from(self.cols.siz), f64::from(self.rows.siz))
    }

    /// Picture size in pixels `(width, height)`.
    pub fn resolution(&self) -> (usize, usize) {
        (self.cols.ne, self.rows.ne)
    }
}

/// Refuses a resolution line that promises more pixels than the file could
/// hold, before the picture reader allocates them (a run-length encoded
/// scanline takes at least 8 bytes per 127 pixels, a flat one 4 per pixel).
fn check_resolution(bytes: &[u8]) -> std::result::Result<(), String> {
    let Some(end) = bytes.windows(2).position(|w| w == b"\n\n") else {
        return Ok(()); // the reader reports the missing header end
    };
    let rest = &bytes[end + 2..];
    let line_end = rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len());
    let line = String::from_utf8_lossy(&rest[..line_end]);
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() != 4 {
        return Ok(());
    }
    let (Ok(a), Ok(b)) = (f[1].parse::<usize>(), f[3].parse::<usize>()) else {
        return Ok(());
    };
    let limit = bytes.len().saturating_mul(16).saturating_add(16);
    match a.checked_mul(b) {
        Some(n) if n <= limit => Ok(()),
        _ => Err(format!(
            "resolution {} is more than the file's {} bytes can hold",
            line.trim(),
            bytes.len()
        )),
    }
}

#[cfg(test)]
#[path = "data_tests.rs"]
mod tests;
