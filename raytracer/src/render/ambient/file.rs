//! Radiance's ambient file (`-af`): the irradiance cache kept between
//! renders, so that frames of a walk-through, or a render after an
//! overture pass, reuse the hemispheres already sampled.
//!
//! The format is Radiance 5's (`ambio.c` 2.12, `ambient.h`): an
//! information header (`FORMAT=Radiance_ambval`), the magic number 559 in
//! two bytes, then 67-byte records in Radiance's portable encoding
//! (`portio.c`: big-endian integers, reals as a 4-byte mantissa and a
//! 1-byte exponent):
//!
//! | bytes | field |
//! | --- | --- |
//! | 1 | ambient level |
//! | 5 | weight |
//! | 15 | position |
//! | 4 | normal, as a 32-bit direction code (`dircode.c`) |
//! | 4 | first tangent axis `u`, the same |
//! | 4 | value, RGBE (`COLR`) |
//! | 10 | radii along `u` and `normal x u` |
//! | 10 | translational gradient |
//! | 10 | rotational gradient |
//! | 4 | leak-test directions (`corral`) |
//!
//! Files written by Radiance 5 can be read here and the other way round.
//! Like Radiance, a record that fails the consistency checks (`ambvalOK`)
//! ends the reading with a warning naming the byte where it starts; the
//! records before it are used. Radiance 3's format (magic 557) and
//! Radiance 6's spectral one (561) are refused with a message saying so.
//! Directions are stored to about 1e-4 (Radiance's direction codes,
//! shared with the compiled-mesh reader), reals to 31 bits and the value to
//! RGBE's 8 bits: a render that reads a file differs from the one that
//! wrote it within that precision.

use std::io::Write;
use std::path::Path;

use super::AmbientRecord;
use crate::geometry::Vec3;
use crate::image::hdr::{from_rgbe, to_rgbe};
use crate::render::medium::FHUGE;
use crate::render::options::RenderOptions;
use crate::scene::radbin::{decode_dir, encode_dir, put_flt, put_int, BinReader};
use crate::{Error, Result};

/// Magic number of Radiance 5's ambient files (`AMBMAGIC`).
pub const AMBIENT_MAGIC: i64 = 559;
/// Bytes per record (`AMBVALSIZ`).
pub const AMBIENT_RECORD_BYTES: usize = 67;
/// The header's format name (`AMBFMT`).
pub const AMBIENT_FORMAT: &str = "Radiance_ambval";

/// What an ambient file holds.
#[derive(Debug, Clone, Default)]
pub struct AmbientFile {
    pub records: Vec<AmbientRecord>,
    /// The information header's lines (the command that made it, ...).
    pub header: Vec<String>,
    /// Why reading stopped early, if it did (a damaged record, a partial
    /// one at the end).
    pub warnings: Vec<String>,
}

/// Appends one record in the file's encoding (`writambval`).
pub fn encode_record(r: &AmbientRecord, out: &mut Vec<u8>) {
    put_int(out, i64::from(r.level.min(255)), 1);
    put_flt(out, r.weight);
    for i in 0..3 {
        put_flt(out, r.point[i]);
    }
    put_int(out, i64::from(encode_dir(r.normal)), 4);
    put_int(out, i64::from(encode_dir(r.u)), 4);
    out.extend_from_slice(&to_rgbe(r.value));
    for v in [r.radii, r.gpos, r.gdir] {
        put_flt(out, v[0]);
        put_flt(out, v[1]);
    }
    put_int(out, i64::from(r.corral), 4);
}

/// Radiance's `ambvalOK`: whether a decoded record is usable.
fn consistent(r: &AmbientRecord, ndir: u32, udir: u32) -> bool {
    let bad = |x: f64| !(-FHUGE..=FHUGE).contains(&x);
    !(bad(r.point.x) || bad(r.point.y) || bad(r.point.z))
        && ndir != 0
        && udir != 0
        && r.weight > 0.0
        && r.weight <= 1.0
        && r.radii.iter().all(|&x| x > 0.0 && x < FHUGE)
        && [r.value.x, r.value.y, r.value.z]
            .iter()
            .all(|&c| (0.0..FHUGE).contains(&c))
        && !r.gpos.iter().chain(&r.gdir).any(|&x| bad(x))
}

/// Reads an ambient file (see the module documentation).
pub fn read_ambient_file(path: &Path) -> Result<AmbientFile> {
    let data = crate::input::read_input(path, crate::input::MAX_INPUT_BYTES)
        .map_err(|e| Error::io(path, e))?;
    parse_ambient_file(&data, path)
}

/// [`read_ambient_file`] from bytes (`path` names them in messages).
pub fn parse_ambient_file(data: &[u8], path: &Path) -> Result<AmbientFile> {
    let mut r = BinReader::new(data, path);
    let header = r.header(AMBIENT_FORMAT)?;
    let at = r.pos();
    let magic = r.int(2, "the ambient file's magic number")?;
    if magic != AMBIENT_MAGIC {
        let which = match magic {
            557 => " (Radiance 3's format)",
            561 => " (Radiance 6's spectral format)",
            _ => "",
        };
        return Err(r.error_at(
            at,
            format!("not a Radiance 5 ambient file: magic number {magic}{which}, expected {AMBIENT_MAGIC}"),
        ));
    }
    let mut out = AmbientFile {
        header,
        ..AmbientFile::default()
    };
    while r.remaining() >= AMBIENT_RECORD_BYTES {
        let start = r.pos();
        let what = "an ambient record";
        let level = u32::from(r.byte(what)?);
        let weight = r.flt(what)?;
        let point = Vec3::new(r.flt(what)?, r.flt(what)?, r.flt(what)?);
        let ndir = r.int(4, what)? as u32;
        let udir = r.int(4, what)? as u32;
        let c = r.bytes(4, what)?;
        let value = from_rgbe([c[0], c[1], c[2], c[3]]);
        let mut v2 = || -> Result<[f64; 2]> { Ok([r.flt(what)?, r.flt(what)?]) };
        let (radii, gpos, gdir) = (v2()?, v2()?, v2()?);
        let corral = r.u32(what)?;
        let rec = AmbientRecord {
            point,
            normal: decode_dir(ndir),
            u: decode_dir(udir),
            value,
            radii,
            gpos,
            gdir,
            level,
            weight,
            corral,
        };
        if !consistent(&rec, ndir, udir) {
            out.warnings.push(format!(
                "{}: ambient file corrupted near byte {start}: {} records read, the rest ignored",
                path.display(),
                out.records.len()
            ));
            return Ok(out);
        }
        out.records.push(rec);
    }
    if r.remaining() > 0 {
        out.warnings.push(format!(
            "{}: ambient file ends in a partial record ({} bytes) after {} records: ignored",
            path.display(),
            r.remaining(),
            out.records.len()
        ));
    }
    Ok(out)
}

/// The information header and magic number of a new ambient file.
pub fn ambient_file_header(o: &RenderOptions) -> Vec<u8> {
    let mut out = format!(
        "#?RADIANCE\nhybrid-rt -av {} {} {} -ab {} -aa {} -ad {} -as {} -ar {}\nSOFTWARE= hybrid-rt {}\nFORMAT={AMBIENT_FORMAT}\n\n",
        o.av.x,
        o.av.y,
        o.av.z,
        o.ab,
        o.aa,
        o.ad,
        o.as_,
        o.ar,
        env!("CARGO_PKG_VERSION"),
    )
    .into_bytes();
    put_int(&mut out, AMBIENT_MAGIC, 2);
    out
}

/// Appends `records` to the ambient file at `path`, creating it (with
/// its header) if it does not exist or is empty.
pub fn append_ambient_file(
    path: &Path,
    o: &RenderOptions,
    records: &[AmbientRecord],
) -> Result<()> {
    let fresh = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
    let mut bytes = if fresh {
        ambient_file_header(o)
    } else {
        Vec::new()
    };
    bytes.reserve(records.len() * AMBIENT_RECORD_BYTES);
    for r in records {
        encode_record(r, &mut bytes);
    }
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    f.write_all(&bytes).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::rng::Rng;
    use crate::scene::Color;

    fn record(seed: u64) -> AmbientRecord {
        let mut rng = Rng::new(seed);
        let mut unit = || {
            let v = Vec3::new(
                rng.next_f64() - 0.5,
                rng.next_f64() - 0.5,
                rng.next_f64() - 0.5,
            );
            v.normalize()
        };
        let normal = unit();
        let u = normal.cross(unit()).normalize();
        AmbientRecord {
            point: Vec3::new(1.5, -2e3, 3e-4),
            normal,
            u,
            value: Color::new(0.25, 1.5, 1e-3),
            radii: [0.125, 0.2],
            gpos: [-3.0, 0.5],
            gdir: [0.01, -0.02],
            level: 1,
            weight: 0.5,
            corral: 0xdead_beef,
        }
    }

    #[test]
    fn direction_codes_keep_directions_to_a_ten_thousandth() {
        let mut rng = Rng::new(7);
        for i in 0..20_000 {
            let v = if i < 6 {
                let mut a = [0.0; 3];
                a[i / 2] = if i % 2 == 0 { 1.0 } else { -1.0 };
                Vec3::from_array(a)
            } else {
                Vec3::new(
                    rng.next_f64() - 0.5,
                    rng.next_f64() - 0.5,
                    rng.next_f64() - 0.5,
                )
                .normalize()
            };
            let code = encode_dir(v);
            assert_ne!(code, 0, "{v:?}");
            let w = decode_dir(code);
            assert!((w.length() - 1.0).abs() < 1e-9, "{v:?} -> {w:?}");
            assert!(v.dot(w) > 1.0 - 1e-8, "{v:?} -> {w:?}");
        }
        assert_eq!(encode_dir(Vec3::ZERO), 0);
        assert_eq!(decode_dir(0), Vec3::ZERO);
    }

    #[test]
    fn records_survive_a_file_within_its_precision() {
        let recs: Vec<AmbientRecord> = (0..5).map(record).collect();
        let mut bytes = ambient_file_header(&RenderOptions::default());
        for r in &recs {
            encode_record(r, &mut bytes);
        }
        assert_eq!(
            bytes.len(),
            ambient_file_header(&RenderOptions::default()).len() + 5 * AMBIENT_RECORD_BYTES
        );
        let f = parse_ambient_file(&bytes, Path::new("t.amb")).unwrap();
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        assert!(f.header.iter().any(|l| l.starts_with("hybrid-rt -av")));
        assert_eq!(f.records.len(), 5);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-300);
        for (a, b) in recs.iter().zip(&f.records) {
            assert!((0..3).all(|i| close(a.point[i], b.point[i])), "{a:?} {b:?}");
            assert!(a.normal.dot(b.normal) > 1.0 - 1e-8 && a.u.dot(b.u) > 1.0 - 1e-8);
            for (x, y) in [(a.radii, b.radii), (a.gpos, b.gpos), (a.gdir, b.gdir)] {
                assert!(close(x[0], y[0]) && close(x[1], y[1]), "{x:?} {y:?}");
            }
            assert!(close(a.weight, b.weight));
            assert_eq!((a.level, a.corral), (b.level, b.corral));
            let rel = (a.value - b.value).abs() / a.value.max_element();
            assert!(
                rel.max_element() < 1.0 / 128.0,
                "{:?} {:?}",
                a.value,
                b.value
            );
        }
    }

    #[test]
    fn damaged_files_are_refused_or_read_up_to_the_damage() {
        let path = Path::new("bad.amb");
        let header = ambient_file_header(&RenderOptions::default());
        // Radiance 3's magic number.
        let mut old = header.clone();
        let n = old.len();
        old[n - 2..].copy_from_slice(&557i16.to_be_bytes());
        let e = parse_ambient_file(&old, path).unwrap_err().to_string();
        assert!(e.contains("bad.amb") && e.contains("Radiance 3"), "{e}");
        // Another format altogether.
        let e = parse_ambient_file(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n", path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("Radiance_ambval"), "{e}");
        assert!(parse_ambient_file(b"", path).is_err());
        assert!(parse_ambient_file(b"#?RADIANCE\n", path).is_err());
        // A record with weight 0 ends the reading; those before it count.
        let mut bytes = header.clone();
        encode_record(&record(1), &mut bytes);
        let mut bad = record(2);
        bad.weight = 0.0;
        encode_record(&bad, &mut bytes);
        encode_record(&record(3), &mut bytes);
        let f = parse_ambient_file(&bytes, path).unwrap();
        assert_eq!(f.records.len(), 1);
        assert!(f.warnings[0].contains(&format!("near byte {}", header.len() + 67)));
        // A partial record at the end is left out, with a warning.
        let mut bytes = header;
        encode_record(&record(1), &mut bytes);
        encode_record(&record(2), &mut bytes);
        bytes.truncate(bytes.len() - 10);
        let f = parse_ambient_file(&bytes, path).unwrap();
        assert_eq!(f.records.len(), 1);
        assert!(f.warnings[0].contains("partial record"), "{:?}", f.warnings);
    }

    #[test]
    fn appending_writes_one_header_and_accumulates() {
        let dir = std::env::temp_dir().join(format!("hybrid-rt-amb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.amb");
        let _ = std::fs::remove_file(&path);
        let o = RenderOptions::default();
        append_ambient_file(&path, &o, &[record(1), record(2)]).unwrap();
        append_ambient_file(&path, &o, &[]).unwrap();
        append_ambient_file(&path, &o, &[record(3)]).unwrap();
        let f = read_ambient_file(&path).unwrap();
        assert_eq!(f.records.len(), 3);
        assert!(f.warnings.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
