//! Radiance HDR pictures: 32-bit RGBE pixels with run-length encoded
//! scanlines, as Radiance's `color.c` writes and reads them.

use std::io::{self, BufRead, Write};

use super::film::{Film, HdrInfo};
use crate::geometry::Color;

/// Radiance's shortest and longest run-length encodable scanline.
const MIN_ELEN: usize = 8;
const MAX_ELEN: usize = 0x7fff;
/// Shortest run worth encoding as a run.
const MIN_RUN: usize = 4;

/// One colour as shared-exponent RGBE (Radiance's `setcolr`).
pub fn to_rgbe(c: Color) -> [u8; 4] {
    let c = Color::new(finite_pos(c.x), finite_pos(c.y), finite_pos(c.z));
    let d = c.max_element();
    if d <= 1e-32 {
        return [0; 4];
    }
    let (m, e) = frexp(d);
    let s = m * 256.0 / d;
    if e + 128 > 255 {
        return [255, 255, 255, 255];
    }
    if e + 128 < 1 {
        return [0; 4];
    }
    [
        (c.x * s) as u8,
        (c.y * s) as u8,
        (c.z * s) as u8,
        (e + 128) as u8,
    ]
}

/// Decodes one RGBE pixel (Radiance's `colr_color`).
pub fn from_rgbe(p: [u8; 4]) -> Color {
    if p[3] == 0 {
        return Color::ZERO;
    }
    let f = 2f64.powi(p[3] as i32 - (128 + 8));
    Color::new(
        (p[0] as f64 + 0.5) * f,
        (p[1] as f64 + 0.5) * f,
        (p[2] as f64 + 0.5) * f,
    )
}

fn finite_pos(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        0.0
    }
}

/// `frexp` for positive finite `d`: `d = m * 2^e` with `m` in [0.5, 1).
fn frexp(d: f64) -> (f64, i32) {
    let mut e = d.log2().floor() as i32 + 1;
    let mut m = d / 2f64.powi(e);
    // Correct the rare off-by-one of log2 rounding.
    if m >= 1.0 {
        m /= 2.0;
        e += 1;
    } else if m < 0.5 {
        m *= 2.0;
        e -= 1;
    }
    (m, e)
}

/// Writes a complete Radiance picture: header (`#?RADIANCE`, software,
/// optional `VIEW=`, `EXPOSURE=`, `FORMAT=32-bit_rle_rgbe`), the
/// resolution string `-Y H +X W`, and run-length encoded scanlines top to
/// bottom. Pixels are the film's radiance times `exposure`, which the
/// `EXPOSURE=` line records (as Radiance does, so readers can undo it).
pub fn write_hdr<W: Write>(
    w: &mut W,
    film: &Film,
    exposure: f64,
    info: &HdrInfo,
) -> io::Result<()> {
    let exposure = if exposure.is_finite() && exposure > 0.0 {
        exposure
    } else {
        1.0
    };
    writeln!(w, "#?RADIANCE")?;
    writeln!(
        w,
        "SOFTWARE= {}",
        info.software.as_deref().unwrap_or("hybrid-rt")
    )?;
    if let Some(view) = &info.view {
        // A header line must not contain a newline.
        writeln!(w, "VIEW= {}", view.replace(['\n', '\r'], " "))?;
    }
    writeln!(w, "EXPOSURE={exposure:e}")?;
    writeln!(w, "FORMAT=32-bit_rle_rgbe")?;
    writeln!(w)?;
    writeln!(w, "-Y {} +X {}", film.height(), film.width())?;
    let mut scan: Vec<[u8; 4]> = Vec::with_capacity(film.width());
    let mut comp: Vec<u8> = Vec::with_capacity(film.width());
    let mut out: Vec<u8> = Vec::with_capacity(film.width() * 4 + 16);
    for y in 0..film.height() {
        scan.clear();
        scan.extend(film.row(y).iter().map(|&c| to_rgbe(c * exposure)));
        out.clear();
        encode_scanline(&scan, &mut comp, &mut out);
        w.write_all(&out)?;
    }
    Ok(())
}

/// Encodes one scanline: new-style RLE (per component) when the width
/// allows it, flat RGBE otherwise.
fn encode_scanline(scan: &[[u8; 4]], comp: &mut Vec<u8>, out: &mut Vec<u8>) {
    let n = scan.len();
    if !(MIN_ELEN..=MAX_ELEN).contains(&n) {
        for p in scan {
            out.extend_from_slice(p);
        }
        return;
    }
    out.extend_from_slice(&[2, 2, (n >> 8) as u8, (n & 255) as u8]);
    for i in 0..4 {
        comp.clear();
        comp.extend(scan.iter().map(|p| p[i]));
        rle_component(comp, out);
    }
}

/// Run-length encodes one component: runs of at least [`MIN_RUN`] equal
/// bytes as `(128 + count, byte)`, everything else as `(count, bytes...)`.
fn rle_component(data: &[u8], out: &mut Vec<u8>) {
    let n = data.len();
    let mut i = 0;
    while i < n {
        // Find the next run worth encoding.
        let mut beg = i;
        let mut run = 0;
        while beg < n {
            run = 1;
            while beg + run < n && run < 127 && data[beg + run] == data[beg] {
                run += 1;
            }
            if run >= MIN_RUN {
                break;
            }
            beg += run;
        }
        if beg >= n {
            beg = n;
            run = 0;
        }
        // Literals before the run.
        while i < beg {
            let c = (beg - i).min(128);
            out.push(c as u8);
            out.extend_from_slice(&data[i..i + c]);
            i += c;
        }
        if run >= MIN_RUN {
            out.push((128 + run) as u8);
            out.push(data[beg]);
            i = beg + run;
        }
    }
}

/// A decoded Radiance picture.
#[derive(Debug, Clone)]
pub struct HdrImage {
    /// Header lines between the magic line and the blank line.
    pub header: Vec<String>,
    pub film: Film,
}

fn bad(msg: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, msg.into())
}

/// Reads a picture in the form [`write_hdr`] produces (`-Y H +X W`
/// orientation; new-style RLE or flat scanlines). Used by tests and tools
/// to check output.
pub fn read_hdr<R: BufRead>(r: &mut R) -> io::Result<HdrImage> {
    let mut line = String::new();
    r.read_line(&mut line)?;
    if !line.starts_with("#?") {
        return Err(bad("not a Radiance picture (no #? magic line)"));
    }
    let mut header = Vec::new();
    loop {
        line.clear();
        if r.read_line(&mut line)? == 0 {
            return Err(bad("unexpected end of header"));
        }
        let l = line.trim_end_matches(['\n', '\r']);
        if l.is_empty() {
            break;
        }
        header.push(l.to_string());
    }
    if !header.iter().any(|l| l == "FORMAT=32-bit_rle_rgbe") {
        return Err(bad("missing FORMAT=32-bit_rle_rgbe"));
    }
    line.clear();
    r.read_line(&mut line)?;
    let f: Vec<&str> = line.split_whitespace().collect();
    let (h, w) = match f.as_slice() {
        ["-Y", h, "+X", w] => (
            h.parse::<usize>().map_err(|_| bad("bad height"))?,
            w.parse::<usize>().map_err(|_| bad("bad width"))?,
        ),
        _ => {
            return Err(bad(format!(
                "unsupported resolution line {:?}",
                line.trim()
            )))
        }
    };
    let mut film = Film::new(w, h);
    let mut scan = vec![[0u8; 4]; w];
    for y in 0..h {
        read_scanline(r, &mut scan)?;
        for (x, p) in scan.iter().enumerate() {
            film.set(x, y, from_rgbe(*p));
        }
    }
    Ok(HdrImage { header, film })
}

fn read_byte<R: BufRead>(r: &mut R) -> io::Result<u8> {
    let mut b = [0u8; 1];
    r.read_exact(&mut b)?;
    Ok(b[0])
}

fn read_scanline<R: BufRead>(r: &mut R, scan: &mut [[u8; 4]]) -> io::Result<()> {
    let n = scan.len();
    if n == 0 {
        return Ok(());
    }
    let mut first = [0u8; 4];
    r.read_exact(&mut first)?;
    if !(MIN_ELEN..=MAX_ELEN).contains(&n) || first[0] != 2 || first[1] != 2 || first[2] & 128 != 0
    {
        scan[0] = first;
        for p in scan.iter_mut().skip(1) {
            r.read_exact(p)?;
        }
        return Ok(());
    }
    if ((first[2] as usize) << 8 | first[3] as usize) != n {
        return Err(bad("scanline length mismatch"));
    }
    for i in 0..4 {
        let mut x = 0;
        while x < n {
            let c = read_byte(r)? as usize;
            if c > 128 {
                let run = c - 128;
                let v = read_byte(r)?;
                if x + run > n {
                    return Err(bad("run overflows scanline"));
                }
                for p in &mut scan[x..x + run] {
                    p[i] = v;
                }
                x += run;
            } else {
                if c == 0 || x + c > n {
                    return Err(bad("bad literal count"));
                }
                for p in &mut scan[x..x + c] {
                    p[i] = read_byte(r)?;
                }
                x += c;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgbe_round_trip_is_within_one_part_in_256() {
        for &c in &[
            Color::new(1.0, 0.5, 0.25),
            Color::new(1e-6, 3e-7, 0.0),
            Color::new(12345.0, 1.0, 100.0),
            Color::new(0.999, 0.999, 0.999),
        ] {
            let d = from_rgbe(to_rgbe(c));
            let m = c.max_element();
            assert!((d - c).abs().max_element() <= m / 128.0, "{c} -> {d}");
        }
        assert_eq!(to_rgbe(Color::ZERO), [0; 4]);
        assert_eq!(to_rgbe(Color::new(f64::NAN, -1.0, f64::INFINITY)), [0; 4]);
    }

    #[test]
    fn file_round_trip_with_runs_and_literals() {
        for &w in &[3usize, 8, 37, 300] {
            let h = 5;
            let mut film = Film::new(w, h);
            for y in 0..h {
                for x in 0..w {
                    // Mix of long runs (constant blocks) and varying literals.
                    let v = if x < w / 2 {
                        0.5
                    } else {
                        (x * 7 + y) as f64 * 0.01
                    };
                    film.set(x, y, Color::new(v, v * 0.5, 2.0 * v));
                }
            }
            let info = HdrInfo {
                view: Some("-vtv -vp 0 0 0".into()),
                software: None,
            };
            let mut buf = Vec::new();
            write_hdr(&mut buf, &film, 1.0, &info).unwrap();
            let img = read_hdr(&mut &buf[..]).unwrap();
            assert!(img.header.iter().any(|l| l == "VIEW= -vtv -vp 0 0 0"));
            assert!(img.header.iter().any(|l| l.starts_with("EXPOSURE=")));
            assert_eq!((img.film.width(), img.film.height()), (w, h));
            for y in 0..h {
                for x in 0..w {
                    let (a, b) = (film.get(x, y), img.film.get(x, y));
                    assert!((a - b).abs().max_element() <= a.max_element() / 128.0 + 1e-12);
                }
            }
        }
    }

    #[test]
    fn rle_compresses_constant_scanlines() {
        let film = Film::new(1000, 1);
        let mut buf = Vec::new();
        write_hdr(&mut buf, &film, 1.0, &HdrInfo::default()).unwrap();
        // 4 components x ceil(1000/127) runs x 2 bytes + 4 header bytes, plus the text header.
        assert!(buf.len() < 200, "{} bytes", buf.len());
    }
}
