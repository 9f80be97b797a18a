//! Radiance's `xform`, built in: transform options, arrays, renaming, and
//! applying a similarity transform to raw primitives.
//!
//! Semantics follow the xform(1) manual: transforms run in the order given;
//! `-a n xf` makes `n` copies stepping by `xf` (the first copy untransformed);
//! `-i n xf` applies `xf` `n` times; a mirror (or a negative scale) reverses
//! polygon vertex order so surfaces keep their orientation, as Radiance does.

use glam::DVec3;

use super::rad::{Expander, RawPrim};
use crate::geometry::shape::Transform;
use crate::geometry::Vec3;
use crate::{Error, Result, SourceLoc};

/// Transforms are the geometry module's similarity [`Transform`]; these
/// helpers add what `xform` needs on top.
pub type Xf = Transform;

/// `t` applied `n` times (square-and-multiply; powers of one transform commute).
pub(crate) fn pow(t: Xf, n: usize) -> Xf {
    let (mut r, mut b, mut n) = (Xf::IDENTITY, t, n);
    while n > 0 {
        if n & 1 == 1 {
            r = r.then(&b);
        }
        b = b.then(&b);
        n >>= 1;
    }
    r
}

/// Transforms a direction (rotation and mirror only, no scale).
fn dir(t: &Xf, v: DVec3) -> DVec3 {
    t.vector(v) / t.scale
}

fn arg_f64(args: &[String], i: usize, opt: &str, loc: &SourceLoc) -> Result<f64> {
    let s = args
        .get(i)
        .ok_or_else(|| Error::parse(loc.clone(), format!("xform option {opt}: missing number")))?;
    super::rad::parse_real(s)
        .map_err(|r| Error::parse(loc.clone(), format!("xform option {opt}: {r}")))
}

/// Tries to read one plain transform option at `args[*i]` (`-t`, `-rx`,
/// `-ry`, `-rz`, `-s`, `-mx`, `-my`, `-mz`), advancing `i` past it.
pub(crate) fn parse_plain(args: &[String], i: &mut usize, loc: &SourceLoc) -> Result<Option<Xf>> {
    let opt = args[*i].as_str();
    let xf = match opt {
        "-t" => {
            let v = DVec3::new(
                arg_f64(args, *i + 1, opt, loc)?,
                arg_f64(args, *i + 2, opt, loc)?,
                arg_f64(args, *i + 3, opt, loc)?,
            );
            *i += 4;
            Xf::IDENTITY.translate(v)
        }
        "-rx" | "-ry" | "-rz" => {
            let a = arg_f64(args, *i + 1, opt, loc)?;
            *i += 2;
            match opt {
                "-rx" => Xf::IDENTITY.rotate_x(a),
                "-ry" => Xf::IDENTITY.rotate_y(a),
                _ => Xf::IDENTITY.rotate_z(a),
            }
        }
        "-s" => {
            let s = arg_f64(args, *i + 1, opt, loc)?;
            *i += 2;
            if !(s.abs() > 1e-12 && s.abs() < 1e12) {
                return Err(Error::parse(
                    loc.clone(),
                    format!("xform option -s: scale {s} is degenerate"),
                ));
            }
            let t = Xf::IDENTITY
                .scale(s.abs())
                .map_err(|r| Error::parse(loc.clone(), format!("xform option -s: {r}")))?;
            // A negative scale is a point reflection: three mirrors.
            if s < 0.0 {
                t.mirror_x().mirror_y().mirror_z()
            } else {
                t
            }
        }
        "-mx" => {
            *i += 1;
            Xf::IDENTITY.mirror_x()
        }
        "-my" => {
            *i += 1;
            Xf::IDENTITY.mirror_y()
        }
        "-mz" => {
            *i += 1;
            Xf::IDENTITY.mirror_z()
        }
        _ => return Ok(None),
    };
    Ok(Some(xf))
}

fn count_arg(args: &[String], i: usize, opt: &str, loc: &SourceLoc) -> Result<usize> {
    let s = args
        .get(i)
        .ok_or_else(|| Error::parse(loc.clone(), format!("xform option {opt}: missing count")))?;
    let n: usize = s
        .parse()
        .map_err(|_| Error::parse(loc.clone(), format!("xform option {opt}: bad count '{s}'")))?;
    if n > 1_000_000 {
        return Err(Error::parse(
            loc.clone(),
            format!("xform option {opt}: count {n} is too large"),
        ));
    }
    Ok(n)
}

/// One step of a transform sequence: `xf` repeated; an array makes a copy
/// for each of `0..count` applications, an iteration applies it `count` times.
#[derive(Debug, Clone)]
struct Segment {
    count: usize,
    array: bool,
    xf: Xf,
}

/// Parses transform options from `args[*i..]` until a word that is not one,
/// returning the segments (the first one plain, count 1).
fn parse_segments(
    args: &[String],
    i: &mut usize,
    loc: &SourceLoc,
    allow_arrays: bool,
) -> Result<Vec<Segment>> {
    let mut segs = vec![Segment {
        count: 1,
        array: false,
        xf: Xf::IDENTITY,
    }];
    while *i < args.len() {
        match args[*i].as_str() {
            "-a" if allow_arrays => {
                let n = count_arg(args, *i + 1, "-a", loc)?;
                *i += 2;
                segs.push(Segment {
                    count: n,
                    array: true,
                    xf: Xf::IDENTITY,
                });
            }
            "-a" => {
                return Err(Error::parse(
                    loc.clone(),
                    "arrays (-a) are not allowed in an instance transform",
                ))
            }
            "-i" => {
                let n = count_arg(args, *i + 1, "-i", loc)?;
                *i += 2;
                segs.push(Segment {
                    count: n,
                    array: false,
                    xf: Xf::IDENTITY,
                });
            }
            _ => match parse_plain(args, i, loc)? {
                Some(xf) => {
                    let last = segs.last_mut().expect("segments start non-empty");
                    last.xf = last.xf.then(&xf);
                }
                None => break,
            },
        }
    }
    Ok(segs)
}

/// The transform in an `instance`/`mesh` record's string arguments (after
/// the file name). Everything must be a transform option.
pub(crate) fn parse_instance_xf(args: &[String], loc: &SourceLoc) -> Result<Xf> {
    let mut i = 0;
    let segs = parse_segments(args, &mut i, loc, false)?;
    if i < args.len() {
        return Err(Error::parse(
            loc.clone(),
            format!("unknown transform option '{}'", args[i]),
        ));
    }
    Ok(segs
        .iter()
        .fold(Xf::IDENTITY, |acc, s| acc.then(&pow(s.xf, s.count))))
}

const SURFACES: &[&str] = &[
    "polygon", "sphere", "bubble", "cone", "cup", "cylinder", "tube", "ring", "instance", "mesh",
    "source",
];

pub(crate) fn is_surface(ptype: &str) -> bool {
    SURFACES.contains(&ptype)
}

/// Applies `xf` to one raw primitive, and `invert` (xform -I) to surfaces.
pub(crate) fn transform_prim(p: &RawPrim, xf: &Xf, invert: bool) -> Result<RawPrim> {
    let mut q = p.clone();
    let bad = |want: &str| {
        Error::parse(
            p.loc.clone(),
            format!(
                "{} '{}': expected {want} real arguments, got {}",
                p.ptype,
                p.id,
                p.reals.len()
            ),
        )
    };
    let v3 = |r: &[f64], k: usize| DVec3::new(r[k], r[k + 1], r[k + 2]);
    let put = |r: &mut Vec<f64>, k: usize, v: DVec3| {
        r[k] = v.x;
        r[k + 1] = v.y;
        r[k + 2] = v.z;
    };
    let flip = |a: &str, b: &str, t: &str| -> String {
        if !invert {
            t.to_string()
        } else if t == a {
            b.to_string()
        } else {
            a.to_string()
        }
    };
    match p.ptype.as_str() {
        "polygon" => {
            if p.reals.len() % 3 != 0 || p.reals.len() < 9 {
                return Err(bad("a multiple of 3 (at least 9)"));
            }
            let n = p.reals.len() / 3;
            let reverse = xf.is_mirror() != invert;
            for k in 0..n {
                let src = if reverse { n - 1 - k } else { k };
                put(&mut q.reals, 3 * k, xf.point(v3(&p.reals, 3 * src)));
            }
        }
        "sphere" | "bubble" => {
            if p.reals.len() != 4 {
                return Err(bad("4"));
            }
            put(&mut q.reals, 0, xf.point(v3(&p.reals, 0)));
            q.reals[3] = p.reals[3] * xf.scale;
            q.ptype = flip("sphere", "bubble", &p.ptype);
        }
        "cone" | "cup" => {
            if p.reals.len() != 8 {
                return Err(bad("8"));
            }
            put(&mut q.reals, 0, xf.point(v3(&p.reals, 0)));
            put(&mut q.reals, 3, xf.point(v3(&p.reals, 3)));
            q.reals[6] = p.reals[6] * xf.scale;
            q.reals[7] = p.reals[7] * xf.scale;
            q.ptype = flip("cone", "cup", &p.ptype);
        }
        "cylinder" | "tube" => {
            if p.reals.len() != 7 {
                return Err(bad("7"));
            }
            put(&mut q.reals, 0, xf.point(v3(&p.reals, 0)));
            put(&mut q.reals, 3, xf.point(v3(&p.reals, 3)));
            q.reals[6] = p.reals[6] * xf.scale;
            q.ptype = flip("cylinder", "tube", &p.ptype);
        }
        "ring" => {
            if p.reals.len() != 8 {
                return Err(bad("8"));
            }
            put(&mut q.reals, 0, xf.point(v3(&p.reals, 0)));
            let n = dir(xf, v3(&p.reals, 3));
            put(&mut q.reals, 3, if invert { -n } else { n });
            q.reals[6] = p.reals[6] * xf.scale;
            q.reals[7] = p.reals[7] * xf.scale;
        }
        "source" => {
            if p.reals.len() != 4 {
                return Err(bad("4"));
            }
            put(&mut q.reals, 0, dir(xf, v3(&p.reals, 0)));
        }
        "mist" if p.reals.len() > 2 => {
            // xform's m_mist: extinction is per unit length.
            for r in &mut q.reals[..3] {
                *r /= xf.scale;
            }
        }
        "spotlight" if p.reals.len() == 7 => {
            put(&mut q.reals, 4, dir(xf, v3(&p.reals, 4)));
        }
        "instance" | "mesh" => {
            q.post = Some(p.post.unwrap_or(Xf::IDENTITY).then(xf));
        }
        "brighttext" | "colortext" | "mixtext" => {
            transform_text_reals(&mut q.reals, xf);
        }
        t if PATTERNS.contains(&t) => {
            // Radiance's xform appends its transform to a pattern's.
            q.post = Some(p.post.unwrap_or(Xf::IDENTITY).then(xf));
        }
        _ => {}
    }
    Ok(q)
}

/// Runs `xform args` (the words after the program name). `piped` is the
/// output of a preceding pipeline stage (xform's standard input).
pub(crate) fn run_xform(
    exp: &mut Expander,
    args: &[String],
    piped: Option<Vec<RawPrim>>,
    loc: &SourceLoc,
    out: &mut Vec<RawPrim>,
) -> Result<()> {
    let mut i = 0;
    let mut invert = false;
    let mut prefix: Option<String> = None;
    let mut newmod: Option<String> = None;
    while i < args.len() {
        match args[i].as_str() {
            // -c (do not expand commands) and -e (expand): we always expand.
            "-c" | "-e" => i += 1,
            "-I" => {
                invert = true;
                i += 1;
            }
            "-n" | "-m" => {
                let v = args
                    .get(i + 1)
                    .ok_or_else(|| {
                        Error::parse(
                            loc.clone(),
                            format!("xform option {}: missing name", args[i]),
                        )
                    })?
                    .clone();
                if args[i] == "-n" {
                    prefix = Some(v);
                } else {
                    newmod = Some(v);
                }
                i += 2;
            }
            "-f" => {
                return Err(Error::parse(
                    loc.clone(),
                    "xform option -f (arguments from a file) is not supported",
                ))
            }
            _ => break,
        }
    }
    let segs = parse_segments(args, &mut i, loc, true)?;
    let files = &args[i..];
    if let Some(opt) = files.iter().find(|f| f.starts_with('-')) {
        return Err(Error::parse(
            loc.clone(),
            format!("xform: unknown option '{opt}'"),
        ));
    }
    let mut input = Vec::new();
    if files.is_empty() {
        match piped {
            Some(p) => input = p,
            None => {
                return Err(Error::parse(
                    loc.clone(),
                    "xform without a file name reads its standard input, which a scene file cannot provide; \
                     name the file to transform or pipe genbox into it",
                ))
            }
        }
    } else {
        let base = super::rad::base_dir_of(&loc.file);
        for f in files {
            exp.parse_file(&base.join(f), Some(loc), &mut input)?;
        }
    }

    // Enumerate array elements: indices over the array segments.
    let arrays: Vec<usize> = segs.iter().filter(|s| s.array).map(|s| s.count).collect();
    let total: usize = arrays
        .iter()
        .try_fold(1usize, |a, &n| a.checked_mul(n))
        .unwrap_or(usize::MAX);
    exp.reserve(
        total
            .saturating_mul(input.len())
            .saturating_sub(input.len()),
        loc,
    )?;
    if input.is_empty() {
        return Ok(());
    }
    let mut idx = vec![0usize; arrays.len()];
    for _ in 0..total {
        let mut xf = Xf::IDENTITY;
        let mut a = 0;
        for s in &segs {
            let n = if s.array {
                a += 1;
                idx[a - 1]
            } else {
                s.count
            };
            xf = xf.then(&pow(s.xf, n));
        }
        let suffix: String = idx.iter().map(|k| format!(".{k}")).collect();
        for p in &input {
            let mut q = transform_prim(p, &xf, invert)?;
            if is_surface(&q.ptype) {
                if let Some(m) = &newmod {
                    q.modifier = m.clone();
                }
                if let Some(pre) = &prefix {
                    q.id = format!("{pre}.{}", q.id);
                }
                q.id.push_str(&suffix);
            } else if q.ptype == "mist" {
                // xform's m_mist: the sources' names get the prefix (each
                // part of a relay `a>b`).
                if let Some(pre) = &prefix {
                    for name in &mut q.strs {
                        *name = name
                            .split('>')
                            .map(|part| format!("{pre}.{part}"))
                            .collect::<Vec<_>>()
                            .join(">");
                    }
                }
            }
            out.push(q);
        }
        // Odometer increment, last array fastest.
        for d in (0..idx.len()).rev() {
            idx[d] += 1;
            if idx[d] < arrays[d] {
                break;
            }
            idx[d] = 0;
        }
    }
    Ok(())
}

/// Pattern, texture and mixture types.
pub(crate) const PATTERNS: &[&str] = &[
    "brightfunc",
    "colorfunc",
    "texfunc",
    "texdata",
    "brightdata",
    "colordata",
    "colorpict",
    "brighttext",
    "colortext",
    "mixfunc",
    "mixdata",
    "mixpict",
    "mixtext",
    "specfunc",
    "specdata",
    "specpict",
];

/// Text patterns' placement through `xform` (Radiance's xform moves the
/// origin and scales and turns the two vectors).
pub(crate) fn transform_text_reals(reals: &mut [f64], xf: &Xf) {
    if reals.len() < 9 {
        return;
    }
    let v = |r: &[f64], k: usize| Vec3::new(r[k], r[k + 1], r[k + 2]);
    let o = xf.point(v(reals, 0));
    let r = xf.vector(v(reals, 3));
    let d = xf.vector(v(reals, 6));
    for (k, w) in [(0, o), (3, r), (6, d)] {
        reals[k] = w.x;
        reals[k + 1] = w.y;
        reals[k + 2] = w.z;
    }
}
