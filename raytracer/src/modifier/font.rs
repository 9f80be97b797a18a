//! Radiance font files (`.fnt`) and text patterns, as Radiance's
//! `common/font.c` and `rt/text.c` read and evaluate them.
//!
//! # Font files
//!
//! Whitespace-separated integers (`#` comments allowed): for each glyph its
//! character code (1 to 255), its number of vertices `n` (0 to 32000), then
//! `n` vertex pairs `x y` (0 to 255 each), a polygon on a 256x256 cell with
//! `y` up. A glyph with no vertices is a space. A glyph's extent starts as
//! the point (128, 128) and grows to take in its vertices (Radiance's
//! quirk, kept: it matters to squeezed spacing). The font's mean width is
//! the integer mean of `right - left` over glyphs with nonzero width and
//! height.
//!
//! # Text patterns
//!
//! String arguments (`fndx`/`tndx` in text.c):
//!
//! ```text
//! brighttext / colortext:  fontfile textfile          (text from a file)
//!                          fontfile . word word ...   (one line)
//! mixtext:                 foremod backmod fontfile textfile
//!                          foremod backmod fontfile . word word ...
//! ```
//!
//! If there is more than one string after the font, the word right after
//! the font is ignored (by convention `.`) and the rest, joined with single
//! spaces, is the one line of text; otherwise that word names a text file
//! whose lines are the text (see [`read_text_file`]).
//!
//! Real arguments (`farg` in text.c; see [`TextKind`] and
//! [`split_text_args`]):
//!
//! ```text
//! 0..3  Ox Oy Oz   origin: the upper left corner of the first character
//! 3..6  Rx Ry Rz   right: one character cell to the right
//! 6..9  Dx Dy Dz   down: one line down
//! brighttext: 9 foreground, 10 background brightness, [11 spacing]
//! colortext:  9..12 foreground RGB, 12..15 background RGB, [15 spacing]
//! mixtext:    [9 spacing]
//! ```
//!
//! Fewer reals than the spacing's index is an error ("bad # arguments");
//! reals after the spacing are ignored. A point's position in the text is
//! its affine coordinates `(a, b)` in the basis `(R, D)` from the origin:
//! line `floor(b)`, and `a` in character cells. Without a spacing real each
//! character takes one cell (uniform spacing; a character missing from the
//! font takes none). With one, `s`: `trunc(255 s) < 0` squeezes the text
//! (each glyph's box, then `255|s|` units of gap), `> 0` spaces it
//! proportionally (groups of words separated by 3+ spaces are stretched to
//! average cells), `= 0` is uniform; and a cell along `R` is then
//! `mwidth + 255|s|` glyph units wide instead of 255.

use std::path::Path;
use std::sync::Arc;

use glam::DVec3;

use super::data::{is_int, Words};
use crate::{Error, Result, SourceLoc};

/// Radiance's `FTINY` (double precision).
const FTINY: f64 = 1e-6;

/// One character's outline.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Glyph {
    /// Polygon vertices `(x, y)` on the 256x256 cell, `y` up.
    verts: Vec<[u8; 2]>,
    left: u8,
    right: u8,
    top: u8,
    bottom: u8,
}

impl Glyph {
    /// A space (a glyph without vertices).
    pub fn is_space(&self) -> bool {
        self.verts.is_empty()
    }

    /// The extent `(left, right, bottom, top)`, including (128, 128).
    pub fn extent(&self) -> (u8, u8, u8, u8) {
        (self.left, self.right, self.bottom, self.top)
    }

    /// Radiance's `inglyph`: is `(x, y)` (glyph units, `[0, 255)`) inside?
    /// The straddle test uses the point snapped to the middle of its unit
    /// square, so vertices never lie exactly on the test ray.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let (xl, yl) = (x as i32, y as i32);
        if i32::from(self.left) > xl
            || i32::from(self.right) <= xl
            || i32::from(self.bottom) > yl
            || i32::from(self.top) <= yl
        {
            return false;
        }
        let (xlb, ylb) = (xl << 1 | 1, yl << 1 | 1);
        let mut crossings = 0u32;
        let n = self.verts.len();
        for k in 0..n {
            let p0 = self.verts[(k + n - 1) % n].map(i32::from);
            let p1 = self.verts[k].map(i32::from);
            if (p0[1] << 1 > ylb) != (p1[1] << 1 > ylb) {
                let tv = u8::from(p0[0] << 1 > xlb) | u8::from(p1[0] << 1 > xlb) << 1;
                if tv == 3 {
                    crossings += 1;
                } else if tv != 0 {
                    let (x0, y0) = (f64::from(p0[0]), f64::from(p0[1]));
                    let (x1, y1) = (f64::from(p1[0]), f64::from(p1[1]));
                    crossings +=
                        u32::from((p1[1] > p0[1]) ^ ((y0 - y) * (x1 - x) > (x0 - x) * (y1 - y)));
                }
            }
        }
        crossings & 1 == 1
    }
}

/// A Radiance polygon font: up to 255 glyphs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Font {
    glyphs: Vec<Option<Glyph>>,
    /// Mean glyph width and height (`mwidth`, `mheight`).
    mwidth: i64,
    mheight: i64,
}

impl Font {
    /// Reads the font file at `path`; `from` is the scene line naming it.
    pub fn load(path: &Path, from: &SourceLoc) -> Result<Font> {
        let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| {
            Error::parse(
                from.clone(),
                format!("cannot open font file \"{}\": {e}", path.display()),
            )
        })?;
        Self::parse(&bytes, path)
    }

    /// Parses a font file's contents; `file` names it in errors.
    pub fn parse(bytes: &[u8], file: &Path) -> Result<Font> {
        let err = |line: usize, reason: String| Error::parse(SourceLoc::new(file, line), reason);
        let int = |w: &[u8]| -> Option<i64> {
            if w.len() >= 64 || !is_int(w) {
                return None;
            }
            std::str::from_utf8(w)
                .ok()?
                .parse::<i32>()
                .ok()
                .map(i64::from)
        };
        let mut words = Words::new(bytes);
        let mut glyphs: Vec<Option<Glyph>> = vec![None; 256];
        let (mut wsum, mut hsum, mut ngly) = (0i64, 0i64, 0i64);
        while let Some((w, line)) = words.next_word() {
            let Some(gn) = int(w) else {
                return Err(err(
                    line,
                    format!("non-integer {:?} in font file", String::from_utf8_lossy(w)),
                ));
            };
            if !(1..=255).contains(&gn) {
                return Err(err(line, format!("illegal character ({gn}) in font file")));
            }
            let slot = &mut glyphs[gn as usize];
            if slot.is_some() {
                return Err(err(
                    line,
                    format!("duplicate character ({gn}) in font file"),
                ));
            }
            let nv = match words.next_word() {
                Some((w, l)) => int(w).filter(|n| (0..=32000).contains(n)).ok_or(l),
                None => Err(words.line()),
            }
            .map_err(|l| {
                err(
                    l,
                    format!("bad # vertices for character ({gn}) in font file"),
                )
            })?;
            let mut g = Glyph {
                verts: Vec::with_capacity(nv as usize),
                left: 128,
                right: 128,
                top: 128,
                bottom: 128,
            };
            for _ in 0..nv {
                let mut v = [0u8; 2];
                for c in &mut v {
                    *c = match words.next_word() {
                        Some((w, l)) => int(w)
                            .filter(|n| (0..=255).contains(n))
                            .map(|n| n as u8)
                            .ok_or(l),
                        None => Err(words.line()),
                    }
                    .map_err(|l| err(l, format!("bad vertex for character ({gn}) in font file")))?;
                }
                g.left = g.left.min(v[0]);
                g.right = g.right.max(v[0]);
                g.bottom = g.bottom.min(v[1]);
                g.top = g.top.max(v[1]);
                g.verts.push(v);
            }
            if g.right != g.left && g.top != g.bottom {
                ngly += 1;
                wsum += i64::from(g.right - g.left);
                hsum += i64::from(g.top - g.bottom);
            }
            *slot = Some(g);
        }
        let (mwidth, mheight) = if ngly > 0 {
            (wsum / ngly, hsum / ngly)
        } else {
            (0, 0)
        };
        Ok(Font {
            glyphs,
            mwidth,
            mheight,
        })
    }

    /// The glyph for byte `c`, if the font has one.
    pub fn glyph(&self, c: u8) -> Option<&Glyph> {
        self.glyphs[c as usize].as_ref()
    }

    /// Mean glyph width (`mwidth`), in glyph units.
    pub fn mean_width(&self) -> i64 {
        self.mwidth
    }

    /// Mean glyph height (`mheight`), in glyph units.
    pub fn mean_height(&self) -> i64 {
        self.mheight
    }

    /// `uniftext`: every character with a glyph takes 255 units.
    fn uniform(&self, s: &[u8]) -> Vec<i64> {
        let mut spc = Vec::with_capacity(s.len() + 1);
        spc.push(0);
        spc.extend(
            s.iter()
                .map(|&c| if self.glyph(c).is_some() { 255 } else { 0 }),
        );
        spc
    }

    /// `squeeztext`: glyph boxes `cis` apart (half before the first and
    /// after the last), spaces `mwidth` wide.
    fn squeeze(&self, s: &[u8], cis: i64) -> Vec<i64> {
        let n = s.len();
        let mut spc = vec![0i64; n + 1];
        let (mut k, mut t) = (0, 0);
        let next = |t: &mut usize, k: &mut usize, spc: &mut [i64], count: bool| {
            while *t < n {
                let g = self.glyph(s[*t]);
                *t += 1;
                if g.is_some() {
                    return g;
                }
                if count {
                    *k += 1;
                    spc[*k] = 0;
                } else {
                    spc[*k] = 0;
                    *k += 1;
                }
            }
            None
        };
        let mut gp = next(&mut t, &mut k, &mut spc, false);
        let cis = cis / 2;
        spc[k] = cis;
        while let Some(g) = gp {
            if g.is_space() {
                k += 1;
                spc[k] = self.mwidth;
            } else {
                spc[k] += cis - i64::from(g.left);
                k += 1;
                spc[k] = i64::from(g.right) + cis;
            }
            gp = next(&mut t, &mut k, &mut spc, true);
        }
        spc[k] += cis;
        spc
    }

    /// `proptext`: squeeze, then stretch each run of characters (ending at
    /// a gap of more than `nsi` - 1 spaces) to `mwidth + cis` per character.
    fn proportional(&self, s: &[u8], cis: i64, nsi: usize) -> Vec<i64> {
        let n = s.len();
        let mut spc = self.squeeze(s, cis);
        let is_space = |c: u8| self.glyph(c).is_some_and(Glyph::is_space);
        let (mut sp, mut tp) = (1, 0);
        while tp < n {
            let (mut len, mut alen, mut nsp) = (0i64, 0i64, sp);
            let (mut end, mut tab) = (tp, tp);
            while end < n {
                tab = end + 1;
                alen += spc[nsp];
                nsp += 1;
                if self.glyph(s[end]).is_some() {
                    while tab < n && is_space(s[tab]) {
                        alen += spc[nsp];
                        nsp += 1;
                        tab += 1;
                    }
                    len += (tab - end) as i64;
                }
                if nsi > 0 && tab - end > nsi {
                    break;
                }
                end = tab;
            }
            len = len.saturating_mul(self.mwidth + cis).saturating_sub(alen);
            while sp < nsp {
                let a = len / (nsp - sp) as i64;
                spc[sp] += a;
                sp += 1;
                len -= a;
            }
            tp = tab;
        }
        spc
    }
}

/// One line of text with its character spacing: `spc[0]` is the offset of
/// the first character's cell, `spc[k + 1]` the step from character `k`'s
/// cell to the next (glyph units).
#[derive(Debug, Clone, PartialEq)]
struct Line {
    text: Vec<u8>,
    spc: Vec<i64>,
    width: i64,
}

/// Which text primitive a layout is for: where its spacing real and its
/// string arguments sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextKind {
    /// `brighttext`: reals 9, 10 are the foreground and background
    /// brightness, 11 the optional spacing.
    Bright,
    /// `colortext`: reals 9..12 foreground RGB, 12..15 background RGB, 15
    /// the optional spacing.
    Color,
    /// `mixtext`: real 9 the optional spacing; strings 0 and 1 name the
    /// foreground and background modifiers (`void` allowed).
    Mix,
}

impl TextKind {
    /// Index of the optional spacing real (text.c's `sndx`), which is also
    /// the least number of reals.
    pub fn spacing_index(self) -> usize {
        match self {
            TextKind::Bright => 11,
            TextKind::Color => 15,
            TextKind::Mix => 9,
        }
    }

    /// Index of the font among the string arguments (`fndx`).
    pub fn font_index(self) -> usize {
        match self {
            TextKind::Mix => 2,
            _ => 0,
        }
    }

    /// Index of the text file (or `.`) among the strings (`tndx`).
    pub fn text_index(self) -> usize {
        self.font_index() + 1
    }
}

/// Where a text pattern's text comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TextSource {
    /// The words after the `.`, joined by single spaces: one line.
    Inline(String),
    /// A text file to read with [`read_text_file`] (found on Radiance's
    /// library path, like the font).
    File(String),
}

/// A text primitive's arguments sorted out, as `gettext` and `do_text`
/// use them.
#[derive(Debug, Clone, PartialEq)]
pub struct TextArgs {
    /// `mixtext`'s foreground and background modifier names.
    pub modifiers: Option<(String, String)>,
    pub font: String,
    pub text: TextSource,
    /// Reals for [`TextLayout::new`]: origin, right, down and, if given,
    /// the spacing (9 or 10 numbers).
    pub placement: Vec<f64>,
    /// Foreground value: 1 brightness (brighttext), 3 RGB (colortext), none
    /// (mixtext).
    pub fore: Vec<f64>,
    /// Background value, as `fore`.
    pub back: Vec<f64>,
}

/// Sorts a text primitive's string and real arguments (`loc` names the
/// primitive in errors: "bad # arguments").
pub fn split_text_args(
    kind: TextKind,
    strings: &[String],
    reals: &[f64],
    loc: &SourceLoc,
) -> Result<TextArgs> {
    let (t, s) = (kind.text_index(), kind.spacing_index());
    if strings.len() < t + 1 || reals.len() < s {
        return Err(Error::parse(
            loc.clone(),
            format!(
                "bad # arguments: {} needs at least {} strings and {s} reals",
                match kind {
                    TextKind::Bright => "brighttext",
                    TextKind::Color => "colortext",
                    TextKind::Mix => "mixtext",
                },
                t + 1
            ),
        ));
    }
    let text = if strings.len() > t + 1 {
        TextSource::Inline(strings[t + 1..].join(" "))
    } else {
        TextSource::File(strings[t].clone())
    };
    let mut placement = reals[..9].to_vec();
    placement.extend(reals.get(s).copied());
    let (fore, back) = match kind {
        TextKind::Bright => (vec![reals[9]], vec![reals[10]]),
        TextKind::Color => (reals[9..12].to_vec(), reals[12..15].to_vec()),
        TextKind::Mix => (vec![], vec![]),
    };
    Ok(TextArgs {
        modifiers: (kind == TextKind::Mix).then(|| (strings[0].clone(), strings[1].clone())),
        font: strings[kind.font_index()].clone(),
        text,
        placement,
        fore,
        back,
    })
}

/// Reads a text pattern's text file as `gettext` does with `fgets` into a
/// 512-byte buffer: lines longer than 511 bytes are split, one trailing
/// newline is removed from each piece (a `\r` stays). Bytes that are not
/// UTF-8 are replaced. `from` names the primitive in errors.
pub fn read_text_file(path: &Path, from: &SourceLoc) -> Result<Vec<String>> {
    let bytes = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES).map_err(|e| {
        Error::parse(
            from.clone(),
            format!("cannot open text file \"{}\": {e}", path.display()),
        )
    })?;
    let mut lines = Vec::new();
    let mut rest = &bytes[..];
    while !rest.is_empty() {
        let take = rest
            .iter()
            .take(511)
            .position(|&c| c == b'\n')
            .map_or(rest.len().min(511), |i| i + 1);
        let (piece, tail) = rest.split_at(take);
        let piece = piece.strip_suffix(b"\n").unwrap_or(piece);
        lines.push(String::from_utf8_lossy(piece).into_owned());
        rest = tail;
    }
    Ok(lines)
}

/// One text pattern's layout, built once per scene from its arguments (as
/// text.c's `gettext`).
#[derive(Debug, Clone)]
pub struct TextLayout {
    font: Arc<Font>,
    origin: DVec3,
    /// Dotted with a point's offset from the origin: its coordinate along
    /// R in cells (R's component across D, scaled by 1/|.|^2).
    right: DVec3,
    /// Likewise along D, in lines.
    down: DVec3,
    /// Glyph units per cell along `right` (255, or `mwidth + 255|s|` when a
    /// spacing real is given).
    cell: f64,
    lines: Vec<Line>,
}

impl TextLayout {
    /// `lines` is the text (the string arguments' line, or a text file's
    /// lines), `reals` the placement `Ox Oy Oz Rx Ry Rz Dx Dy Dz [spacing]`
    /// ([`TextArgs::placement`]); `loc` names the primitive in errors.
    pub fn new(
        font: Arc<Font>,
        lines: Vec<String>,
        reals: &[f64],
        loc: &SourceLoc,
    ) -> Result<TextLayout> {
        if !(9..=10).contains(&reals.len()) {
            return Err(Error::parse(
                loc.clone(),
                format!(
                    "bad # arguments: text placement needs 9 or 10 reals, got {}",
                    reals.len()
                ),
            ));
        }
        if reals.iter().any(|r| !r.is_finite()) {
            return Err(Error::parse(loc.clone(), "text placement is not finite"));
        }
        let v = |i: usize| DVec3::new(reals[i], reals[i + 1], reals[i + 2]);
        let (origin, r, d) = (v(0), v(3), v(6));
        let dxr = d.cross(r);
        let right = dxr.cross(d);
        let rr = right.dot(right);
        if rr.is_nan() || rr <= FTINY * FTINY * FTINY * FTINY {
            return Err(Error::parse(loc.clone(), "illegal motion vector"));
        }
        let right = right * (d.dot(d) / rr);
        let down = r.cross(dxr);
        let down = down * (r.dot(r) / down.dot(down));
        let spacing = reals.get(9).copied();
        let cell = match spacing {
            Some(s) => font.mwidth as f64 + 255.0 * s.abs(),
            None => 255.0,
        };
        // C's `i = d * 255.0` (an int); saturate rather than overflow.
        let cis = (spacing.unwrap_or(0.0) * 255.0).clamp(i32::MIN as f64, i32::MAX as f64) as i64;
        let lines = lines
            .into_iter()
            .map(|l| {
                let mut text = l.into_bytes();
                // A C string ends at its first NUL.
                if let Some(z) = text.iter().position(|&c| c == 0) {
                    text.truncate(z);
                }
                let spc = match cis {
                    c if c < 0 => font.squeeze(&text, -c),
                    c if c > 0 => font.proportional(&text, c, 3),
                    _ => font.uniform(&text),
                };
                let width = spc.iter().sum();
                Line { text, spc, width }
            })
            .collect();
        Ok(TextLayout {
            font,
            origin,
            right,
            down,
            cell,
            lines,
        })
    }

    /// Number of lines.
    pub fn num_lines(&self) -> usize {
        self.lines.len()
    }

    /// A line's width in glyph units (the sum of its spacing).
    pub fn line_width(&self, line: usize) -> Option<i64> {
        self.lines.get(line).map(|l| l.width)
    }

    /// The point's text coordinates `(a, b)`: `p = O + a R + b D` (plus a
    /// part across both, ignored).
    pub fn text_coords(&self, p: DVec3) -> (f64, f64) {
        let v = p - self.origin;
        (v.dot(self.right), v.dot(self.down))
    }

    /// True if the point (already in the pattern's coordinates, i.e. after
    /// its transform) is inside a character's glyph: text.c's `intext()`.
    pub fn inside(&self, p: DVec3) -> bool {
        let (a, b) = self.text_coords(p);
        let x = a * self.cell;
        let mut h = x as i64;
        let line = b as i64;
        if x < 0.0 || b < 0.0 {
            return false;
        }
        let frac = x - h as f64;
        let y = (line as f64 + 1.0 - b) * 255.0;
        let Some(l) = usize::try_from(line).ok().and_then(|i| self.lines.get(i)) else {
            return false;
        };
        if h >= l.width {
            return false;
        }
        for (k, &step) in l.spc.iter().enumerate() {
            h -= step;
            if h < 0 {
                break;
            }
            if h < 255 {
                let glyph = l.text.get(k).and_then(|&c| self.font.glyph(c));
                if glyph.is_some_and(|g| g.contains(h as f64 + frac, y)) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
#[path = "font_tests.rs"]
mod tests;
