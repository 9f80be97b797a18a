//! Radiance's portable binary primitives, as frozen octrees (`oconv -f`)
//! and compiled meshes (`obj2mesh`) store them.
//!
//! - integers: `siz` bytes, big-endian, sign-extended on reading
//!   (`putint`/`getint` in Radiance's `portio.c`);
//! - reals: a 4-byte mantissa (the `frexp` fraction times `0x7fffffff`)
//!   followed by a 1-byte exponent (`putflt`/`getflt`);
//! - strings: bytes up to and including a NUL (`putstr`/`getstr`);
//! - the information header (`#?RADIANCE` ... `FORMAT=...`, ended by an
//!   empty line) that precedes every Radiance binary file;
//! - object records (`writescene`/`readscene` in `sceneio.c`): a table of
//!   type names (ended by an empty string), then per object its type index
//!   (1 byte), modifier index (`objsize` bytes, -1 = `void`), name, string
//!   arguments (2-byte count) and real arguments (2-byte count); a type
//!   index of -1 ends the list. Radiance is built without integer
//!   arguments (`IARGS`), so records have none.
//!
//! Reading never panics and never loops without consuming input: every
//! failure is a [`crate::Error::Parse`] naming the file (line 0) and the
//! byte offset.

#![cfg_attr(not(test), allow(dead_code))] // the builder wires these in

use std::path::Path;

use super::rad::RawPrim;
use crate::{Error, Result, SourceLoc};

/// Largest object index size (`MAXOBJSIZ` in Radiance's `octree.h`).
pub(crate) const MAX_OBJSIZE: usize = 8;
/// Longest information header accepted (bytes).
const MAX_HEADER: usize = 1 << 20;

/// A cursor over the bytes of one binary Radiance file.
#[derive(Debug, Clone)]
pub(crate) struct BinReader<'a> {
    data: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> BinReader<'a> {
    pub fn new(data: &'a [u8], path: &'a Path) -> Self {
        Self { data, pos: 0, path }
    }

    /// Byte offset of the next read.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    pub fn at_end(&self) -> bool {
        self.pos >= self.data.len()
    }

    /// A parse error for this file (line 0) with `reason`.
    pub fn error(&self, reason: impl Into<String>) -> Error {
        Error::parse(SourceLoc::new(self.path, 0), reason)
    }

    /// A parse error naming the byte offset `at`.
    pub fn error_at(&self, at: usize, reason: impl std::fmt::Display) -> Error {
        self.error(format!("{reason} (at byte {at})"))
    }

    fn truncated(&self, what: &str) -> Error {
        self.error(format!(
            "truncated file: expected {what} at byte {} but the file ends there ({} bytes)",
            self.pos,
            self.data.len()
        ))
    }

    /// The next `n` bytes.
    pub fn bytes(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if n > self.remaining() {
            return Err(self.truncated(what));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    pub fn skip(&mut self, n: usize, what: &str) -> Result<()> {
        self.bytes(n, what).map(|_| ())
    }

    pub fn byte(&mut self, what: &str) -> Result<u8> {
        Ok(self.bytes(1, what)?[0])
    }

    /// A `siz`-byte big-endian integer, sign-extended (`getint`). `siz` is
    /// 1 to 8.
    pub fn int(&mut self, siz: usize, what: &str) -> Result<i64> {
        debug_assert!((1..=8).contains(&siz));
        let b = self.bytes(siz.clamp(1, 8), what)?;
        let mut r: i64 = if b[0] & 0x80 != 0 { -1 } else { 0 };
        for &c in b {
            r = (r << 8) | i64::from(c);
        }
        Ok(r)
    }

    /// A 4-byte integer taken as unsigned (vertex coordinates, uv).
    pub fn u32(&mut self, what: &str) -> Result<u32> {
        let b = self.bytes(4, what)?;
        Ok(u32::from_be_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// A count stored in `siz` bytes: must be in `0..=limit` (the format's
    /// own limit), and the `each` bytes per item it announces must fit in
    /// the rest of the file (checked before anything is allocated).
    pub fn count(&mut self, siz: usize, limit: usize, each: usize, what: &str) -> Result<usize> {
        let at = self.pos;
        let n = self.int(siz, what)?;
        if n < 0 || n as u64 > limit as u64 {
            return Err(self.error_at(at, format!("bad {what} {n} (expected 0 to {limit})")));
        }
        let n = n as usize;
        let need = n.saturating_mul(each);
        if need > self.remaining() {
            return Err(self.error_at(
                at,
                format!(
                    "truncated or damaged file: {what} {n} needs at least {need} more bytes, \
                     only {} remain",
                    self.remaining()
                ),
            ));
        }
        Ok(n)
    }

    /// A real number (`getflt`): 4-byte mantissa, 1-byte exponent.
    pub fn flt(&mut self, what: &str) -> Result<f64> {
        let l = self.int(4, what)?;
        let e = self.int(1, what)?;
        if l == 0 {
            return Ok(0.0);
        }
        let d = (l as f64 + if l > 0 { 0.5 } else { -0.5 }) * (1.0 / 2147483647.0);
        Ok(d * 2f64.powi(e as i32))
    }

    /// A NUL-terminated string (`getstr`), which must be UTF-8.
    pub fn str(&mut self, what: &str) -> Result<String> {
        let at = self.pos;
        let rest = &self.data[self.pos..];
        let Some(len) = rest.iter().position(|&c| c == 0) else {
            self.pos = self.data.len();
            return Err(self.error_at(
                at,
                format!("truncated file: {what} has no terminating NUL byte"),
            ));
        };
        let s = std::str::from_utf8(&rest[..len])
            .map_err(|_| self.error_at(at, format!("{what} is not valid UTF-8")))?;
        self.pos += len + 1;
        Ok(s.to_string())
    }

    /// A real number written as text in a string (`atof(getstr())`, the
    /// cube origin and size).
    pub fn str_real(&mut self, what: &str) -> Result<f64> {
        let at = self.pos;
        let s = self.str(what)?;
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.error_at(at, format!("{what}: '{s}' is not a finite number"))),
        }
    }

    /// Reads the information header: a first line starting with `#?`,
    /// lines up to an empty one. A `FORMAT=` line, if present, must name
    /// `format`. Returns the header lines (without the magic line).
    pub fn header(&mut self, format: &str) -> Result<Vec<String>> {
        if !self.data[self.pos..].starts_with(b"#?") {
            return Err(self.error(format!(
                "not a Radiance {format} file: it does not start with a '#?' information header"
            )));
        }
        let start = self.pos;
        let limit = self.data.len().min(start.saturating_add(MAX_HEADER));
        let region = &self.data[start..limit];
        let Some(end) = region.windows(2).position(|w| w == b"\n\n") else {
            return Err(self.error(format!(
                "truncated or damaged information header: no empty line ends it within {} bytes",
                region.len()
            )));
        };
        let text = String::from_utf8_lossy(&region[..end]);
        let mut lines: Vec<String> = text.lines().skip(1).map(str::to_string).collect();
        self.pos = start + end + 2;
        for l in &lines {
            if let Some(f) = l.strip_prefix("FORMAT=") {
                if f.trim() != format {
                    return Err(self.error(format!(
                        "wrong file format '{}': expected '{format}'",
                        f.trim()
                    )));
                }
            }
        }
        lines.retain(|l| !l.is_empty());
        Ok(lines)
    }

    /// The format number after the header: `magic + objsize`, with the
    /// object index size 1 to [`MAX_OBJSIZE`]. Returns `objsize`.
    pub fn magic(&mut self, magic: i64, kind: &str) -> Result<usize> {
        let at = self.pos;
        let m = self.int(2, "the format number")?;
        let objsize = m - magic;
        if !(1..=MAX_OBJSIZE as i64).contains(&objsize) {
            return Err(self.error_at(
                at,
                format!(
                    "incompatible {kind} format: format number {m}, expected {} to {}",
                    magic + 1,
                    magic + MAX_OBJSIZE as i64
                ),
            ));
        }
        Ok(objsize as usize)
    }

    /// Skips a pre-order octree (`puttree` output: 0 empty, 1 a set of
    /// `objsize`-byte object indices with its count first, 2 eight
    /// children), checking its structure. Iterative: deep or damaged trees
    /// cannot overflow the stack. Returns the number of leaf sets.
    pub fn skip_tree(&mut self, objsize: usize, what: &str) -> Result<usize> {
        let mut pending: usize = 1;
        let mut sets = 0;
        while pending > 0 {
            // Each pending node takes at least one byte.
            if pending > self.remaining() {
                return Err(self.truncated(what));
            }
            let at = self.pos;
            match self.byte(what)? {
                0 => pending -= 1,
                1 => {
                    let n = self.count(objsize, usize::MAX, objsize, "octree set size")?;
                    self.skip(n * objsize, what)?;
                    sets += 1;
                    pending -= 1;
                }
                2 => pending += 7,
                c => {
                    return Err(self.error_at(
                        at,
                        format!("damaged {what}: node type {c} (expected 0, 1 or 2)"),
                    ))
                }
            }
        }
        Ok(sets)
    }

    /// Reads binary object records (`readscene`): the type table, then
    /// objects up to the terminator. Modifier indices are resolved to names
    /// among the objects read (the first is index 0; -1 is `void`). Each
    /// record's location is this file, line 0.
    pub fn scene(&mut self, objsize: usize) -> Result<Vec<RawPrim>> {
        let mut types = Vec::new();
        loop {
            let t = self.str("an object type name")?;
            if t.is_empty() {
                break;
            }
            types.push(t);
        }
        // Smallest record: type, modifier, empty name, two counts.
        let min_record = 1 + objsize + 1 + 2 + 2;
        let mut objs: Vec<(RawPrim, i64, usize)> = Vec::new();
        loop {
            let at = self.pos;
            let t = self.int(1, "an object type index (or the end of the objects)")?;
            if t == -1 {
                break;
            }
            if t < 0 || t as usize >= types.len() {
                return Err(self.error_at(
                    at,
                    format!(
                        "object {}: type index {t} is not in the type table ({} types)",
                        objs.len(),
                        types.len()
                    ),
                ));
            }
            if self.remaining() < min_record - 1 {
                return Err(self.truncated("an object record"));
            }
            let omod = self.int(objsize, "an object's modifier index")?;
            let id = self.str("an object name")?;
            // Each string takes at least its NUL byte.
            let ns = self.count(2, i16::MAX as usize, 1, "string argument count")?;
            let mut strs = Vec::with_capacity(ns);
            for _ in 0..ns {
                strs.push(self.str("a string argument")?);
            }
            let nr = self.count(2, i16::MAX as usize, 5, "real argument count")?;
            let mut reals = Vec::with_capacity(nr);
            for _ in 0..nr {
                let fat = self.pos;
                let v = self.flt("a real argument")?;
                if !v.is_finite() {
                    return Err(
                        self.error_at(fat, format!("object '{id}': real argument out of range"))
                    );
                }
                reals.push(v);
            }
            let prim = RawPrim {
                modifier: String::new(),
                ptype: types[t as usize].clone(),
                id,
                strs,
                ints: Vec::new(),
                reals,
                loc: SourceLoc::new(self.path, 0),
                post: None,
            };
            objs.push((prim, omod, at));
        }
        let names: Vec<String> = objs.iter().map(|(p, _, _)| p.id.clone()).collect();
        objs.into_iter()
            .map(|(mut p, omod, at)| {
                p.modifier = if omod == -1 {
                    "void".to_string()
                } else if omod >= 0 && (omod as u64) < names.len() as u64 {
                    names[omod as usize].clone()
                } else {
                    return Err(self.error_at(
                        at,
                        format!(
                            "{} '{}': modifier index {omod} is not one of the {} stored objects",
                            p.ptype,
                            p.id,
                            names.len()
                        ),
                    ));
                };
                if p.ptype == "alias" {
                    // Stored as readobj keeps it: either the referent as
                    // modifier (same modifier as the referent) and no
                    // arguments, or its own modifier and the referent's
                    // name. Our records keep the referent in strs[0].
                    if p.strs.len() > 1 || !p.reals.is_empty() {
                        return Err(self.error_at(
                            at,
                            format!(
                                "alias '{}': {} string and {} real arguments (expected at most one string)",
                                p.id,
                                p.strs.len(),
                                p.reals.len()
                            ),
                        ));
                    }
                    if p.strs.is_empty() {
                        p.strs.push(std::mem::replace(&mut p.modifier, "inherit".into()));
                    }
                }
                Ok(p)
            })
            .collect()
    }
}

/// Appends a `siz`-byte big-endian integer (`putint`).
pub(crate) fn put_int(out: &mut Vec<u8>, i: i64, siz: usize) {
    for k in (0..siz).rev() {
        out.push((i >> (8 * k as u32).min(63)) as u8);
    }
}

/// Appends a real number (`putflt`): mantissa and exponent, clamped as
/// Radiance does on overflow and flushed to zero on underflow.
pub(crate) fn put_flt(out: &mut Vec<u8>, f: f64) {
    let (frac, e) = frexp(f);
    let (mut m, mut e) = ((frac * 2147483647.0) as i64, e);
    if e > 127 {
        m = if m > 0 { 0x7fff_ffff } else { -0x7fff_ffff };
        e = 127;
    } else if e < -128 {
        m = 0;
        e = 0;
    }
    put_int(out, m, 4);
    put_int(out, i64::from(e), 1);
}

/// Appends a NUL-terminated string (`putstr`).
pub(crate) fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(s.as_bytes());
    out.push(0);
}

/// `frexp`: `f = frac * 2^e` with `0.5 <= |frac| < 1` (0 and non-finite
/// values give `(f, 0)`).
pub(crate) fn frexp(f: f64) -> (f64, i32) {
    if f == 0.0 || !f.is_finite() {
        return (f, 0);
    }
    let (f, bias) = if f.abs() < f64::MIN_POSITIVE {
        (f * 2f64.powi(64), -64)
    } else {
        (f, 0)
    };
    let bits = f.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let e = exp - 1022;
    let frac = f64::from_bits((bits & !(0x7ff << 52)) | (1022u64 << 52));
    (frac, e + bias)
}

/// Appends object records as `writescene` does: the type table (the
/// distinct types of `objs`, in first-use order), the objects, the
/// terminator. Modifiers must be `void` or the name of an earlier object
/// (the latest one of that name is referenced).
pub(crate) fn put_scene(out: &mut Vec<u8>, objs: &[RawPrim], objsize: usize) {
    let mut types: Vec<&str> = Vec::new();
    for o in objs {
        if !types.contains(&o.ptype.as_str()) {
            types.push(&o.ptype);
        }
    }
    for t in &types {
        put_str(out, t);
    }
    put_str(out, "");
    for (k, o) in objs.iter().enumerate() {
        let t = types.iter().position(|t| *t == o.ptype).unwrap_or(0);
        put_int(out, t as i64, 1);
        let m = objs[..k]
            .iter()
            .rposition(|p| p.id == o.modifier)
            .map_or(-1, |i| i as i64);
        put_int(out, m, objsize);
        put_str(out, &o.id);
        put_int(out, o.strs.len() as i64, 2);
        for s in &o.strs {
            put_str(out, s);
        }
        put_int(out, o.reals.len() as i64, 2);
        for &r in &o.reals {
            put_flt(out, r);
        }
    }
    put_int(out, -1, 1);
}

/// Radiance's `decodedir` (`dircode.c`): a unit direction from its 32-bit
/// code (two 13-bit components, which axis is largest, three signs).
pub(crate) fn decode_dir(dc: u32) -> crate::geometry::Vec3 {
    const DCSCALE: f64 = 11585.2;
    const F1X: u32 = 0o10;
    const F2Z: u32 = 0o20;
    if dc == 0 {
        return crate::geometry::Vec3::ZERO;
    }
    let d1 = (f64::from(dc >> 5 & 0x1fff) + 0.5) / DCSCALE;
    let d2 = (f64::from(dc >> 18 & 0x1fff) + 0.5) / DCSCALE;
    let der = (1.0 - d1 * d1 - d2 * d2).max(0.0).sqrt();
    let mut v = if dc & F1X != 0 {
        if dc & F2Z != 0 {
            crate::geometry::Vec3::new(d1, der, d2)
        } else {
            crate::geometry::Vec3::new(d1, d2, der)
        }
    } else if dc & F2Z != 0 {
        crate::geometry::Vec3::new(der, d1, d2)
    } else {
        crate::geometry::Vec3::new(d2, d1, der)
    };
    if dc & 1 != 0 {
        v.x = -v.x;
    }
    if dc & 2 != 0 {
        v.y = -v.y;
    }
    if dc & 4 != 0 {
        v.z = -v.z;
    }
    v
}

/// Radiance's `encodedir`, the inverse of [`decode_dir`] (for tests and
/// writers). `dv` must be normalised.
pub(crate) fn encode_dir(dv: crate::geometry::Vec3) -> u32 {
    const DCSCALE: f64 = 11585.2;
    let mut dc: u32 = 0;
    let mut cd = [0u32; 3];
    for i in 0..3 {
        if dv[i] < 0.0 {
            cd[i] = (dv[i] * -DCSCALE) as u32;
            dc |= 1 << i;
        } else {
            cd[i] = (dv[i] * DCSCALE) as u32;
        }
    }
    if cd == [0, 0, 0] {
        return 0;
    }
    let cm = if cd[0] <= cd[1] {
        dc |= 0o10 | cd[0] << 5;
        cd[1]
    } else {
        dc |= cd[1] << 5;
        cd[0]
    };
    if cd[2] <= cm {
        dc |= 0o20 | cd[2] << 18;
    } else {
        dc |= cm << 18;
    }
    if dc == 0 {
        dc = 0o10;
    }
    dc
}
