//! Radiance's `genprism` and `genrev`, built in. They write the records
//! Radiance's programs (`src/gen/genprism.c`, `src/gen/genrev.c`) write:
//! the same types, names, order and real values, computed with the same
//! operations in the same order.
//!
//! - `genprism mat name { N x1 y1 .. xN yN | vfile } [-l lx ly lz] [-r radius] [-e] [-c]`:
//!   a prism extruded from a polygon in the xy plane along `-l` (default
//!   `0 0 1`): end caps `name.b` and `name.t` (unless `-e`), sides `name.1`
//!   .. `name.N` (the closing side left out with `-c`); with `-r` the
//!   edges are rounded by spheres and cylinders (`name.bc1`, `name.be1`,
//!   `name.tc1`, `name.te1`, `name.e1`, ...).
//! - `genrev mat name 'z(t)' 'r(t)' nseg [-e expr] [-f file] [-s]`: a
//!   surface of revolution about z from `t = 0` to `1` in `nseg` segments
//!   `name.1` ..: cones, cups, cylinders, tubes or rings; with `-s` each is
//!   preceded by a `texfunc` smoothing its normal (`Phong`, with `rev.cal`).
//!
//! Reading vertices from standard input (`genprism ... -`) is not
//! supported: there is none for a scene file.

use std::path::{Path, PathBuf};

use super::rad::{base_dir_of, parse_real, Expander, RawPrim};
use crate::{Error, Result, SourceLoc};

/// genprism's `FTINY`.
const PRISM_TINY: f64 = 1e-6;
/// genprism's `MAXVERT`: its vertex array holds no more.
const MAX_VERTS: usize = 1024;

fn record(modifier: &str, ptype: &str, id: String, reals: Vec<f64>, loc: &SourceLoc) -> RawPrim {
    RawPrim {
        modifier: modifier.to_string(),
        ptype: ptype.to_string(),
        id,
        strs: Vec::new(),
        ints: Vec::new(),
        reals,
        loc: loc.clone(),
        post: None,
    }
}

/// A file named by a generator: absolute, or beside the scene file, then
/// along the search path.
fn find_file(name: &str, loc: &SourceLoc, search_path: &[PathBuf]) -> Option<PathBuf> {
    let given = Path::new(name);
    if given.is_absolute() {
        return given.is_file().then(|| given.to_path_buf());
    }
    std::iter::once(base_dir_of(&loc.file))
        .chain(search_path.iter().cloned())
        .map(|d| d.join(given))
        .find(|p| p.is_file())
}

/// Pushes generated records, refusing non-finite values (arguments so large
/// that the arithmetic overflows, degenerate segments).
fn emit(
    exp: &mut Expander,
    prog: &str,
    prims: Vec<RawPrim>,
    loc: &SourceLoc,
    out: &mut Vec<RawPrim>,
) -> Result<()> {
    if let Some(p) = prims
        .iter()
        .find(|p| p.reals.iter().any(|r| !r.is_finite()))
    {
        return Err(Error::parse(
            loc.clone(),
            format!(
                "{prog}: {} '{}' gets a non-finite coordinate (arguments too large, or a degenerate shape)",
                p.ptype, p.id
            ),
        ));
    }
    exp.reserve(prims.len(), loc)?;
    out.extend(prims);
    Ok(())
}

// ---------------------------------------------------------------------------
// genprism

const PRISM_USAGE: &str = "usage: genprism material name { N x1 y1 .. xN yN | vfile } \
                           [-l lx ly lz] [-r radius] [-c] [-e]";

/// genprism's options and vertices.
struct Prism {
    verts: Vec<[f64; 2]>,
    lvect: [f64; 3],
    llen: f64,
    do_ends: bool,
    complete: bool,
    crad: f64,
}

/// Runs `genprism args` (the words after the program name).
pub(crate) fn run_genprism(
    exp: &mut Expander,
    args: &[String],
    loc: &SourceLoc,
    out: &mut Vec<RawPrim>,
) -> Result<()> {
    let err = |why: String| Error::parse(loc.clone(), format!("genprism: {why}"));
    let real = |w: &str| parse_real(w).map_err(|r| err(format!("{r}; {PRISM_USAGE}")));
    if args.len() < 3 {
        return Err(err(format!("too few arguments; {PRISM_USAGE}")));
    }
    let mut verts = Vec::new();
    let mut an;
    let first = &args[2];
    if first == "-" {
        return Err(err(
            "reading vertices from standard input ('-') is not supported in a scene file; \
             give them on the command line or in a file"
                .to_string(),
        ));
    } else if first.as_bytes().first().is_some_and(u8::is_ascii_digit) {
        let n: usize = first
            .parse()
            .map_err(|_| err(format!("bad vertex count '{first}'; {PRISM_USAGE}")))?;
        if n > MAX_VERTS {
            return Err(err(format!(
                "{n} vertices; at most {MAX_VERTS} are allowed"
            )));
        }
        if args.len() < 3 + 2 * n {
            return Err(err(format!(
                "{n} vertices need {} coordinates, only {} given; {PRISM_USAGE}",
                2 * n,
                args.len() - 3
            )));
        }
        for k in 0..n {
            verts.push([real(&args[3 + 2 * k])?, real(&args[4 + 2 * k])?]);
        }
        an = 3 + 2 * n;
    } else {
        let path = find_file(first, loc, &exp.search_path)
            .ok_or_else(|| err(format!("cannot open vertex file '{first}'")))?;
        let bytes = std::fs::read(&path)
            .map_err(|e| err(format!("cannot read vertex file '{}': {e}", path.display())))?;
        // Like fscanf("%lf %lf"): pairs of numbers up to the first thing
        // that is not one.
        let text = String::from_utf8_lossy(&bytes);
        let mut words = text.split_whitespace();
        while let (Some(x), Some(y)) = (words.next(), words.next()) {
            let (Ok(x), Ok(y)) = (parse_real(x), parse_real(y)) else {
                break;
            };
            if verts.len() == MAX_VERTS {
                return Err(err(format!(
                    "vertex file '{first}' has more than {MAX_VERTS} vertices"
                )));
            }
            verts.push([x, y]);
        }
        an = 3;
    }
    if verts.len() < 3 {
        return Err(err("not enough vertices (at least 3)".to_string()));
    }
    let mut p = Prism {
        verts,
        lvect: [0.0, 0.0, 1.0],
        llen: 1.0,
        do_ends: true,
        complete: false,
        crad: 0.0,
    };
    // Like genprism, an option is known by the letter after the '-'.
    while an < args.len() {
        let opt = &args[an];
        let need = |k: usize| -> Result<&String> {
            args.get(an + k)
                .ok_or_else(|| err(format!("option {opt} is missing a number; {PRISM_USAGE}")))
        };
        match opt.as_bytes() {
            [b'-', b'l', ..] => {
                for k in 0..3 {
                    p.lvect[k] = real(need(k + 1)?)?;
                }
                an += 3;
                let l = p.lvect;
                p.llen = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
                if p.llen <= PRISM_TINY {
                    return Err(err("zero extrusion vector (-l)".to_string()));
                }
            }
            [b'-', b'r', ..] => {
                p.crad = real(need(1)?)?;
                an += 1;
            }
            [b'-', b'e', ..] => p.do_ends = !p.do_ends,
            [b'-', b'c', ..] => p.complete = !p.complete,
            _ => return Err(err(format!("unexpected argument '{opt}'; {PRISM_USAGE}"))),
        }
        an += 1;
    }
    let prims = if p.crad > PRISM_TINY {
        if p.crad > p.lvect[2].abs() {
            return Err(err(format!(
                "rounding radius {} greater than the height {}",
                p.crad, p.lvect[2]
            )));
        }
        rounded_prism(&p, &args[0], &args[1], loc).map_err(err)?
    } else {
        plain_prism(&p, &args[0], &args[1], loc)
    };
    emit(exp, "genprism", prims, loc, out)
}

/// The prism without rounding.
fn plain_prism(p: &Prism, mat: &str, name: &str, loc: &SourceLoc) -> Vec<RawPrim> {
    let (v, l) = (&p.verts, p.lvect);
    let n = v.len();
    let mut prims = Vec::new();
    if p.do_ends {
        let bottom = v.iter().flat_map(|q| [q[0], q[1], 0.0]).collect();
        prims.push(record(mat, "polygon", format!("{name}.b"), bottom, loc));
        let top = v
            .iter()
            .rev()
            .flat_map(|q| [q[0] + l[0], q[1] + l[1], l[2]])
            .collect();
        prims.push(record(mat, "polygon", format!("{name}.t"), top, loc));
    }
    let sides = if p.complete { n - 1 } else { n };
    for n0 in 0..sides {
        let (a, b) = (v[n0], v[(n0 + 1) % n]);
        let reals = vec![
            a[0],
            a[1],
            0.0,
            a[0] + l[0],
            a[1] + l[1],
            l[2],
            b[0] + l[0],
            b[1] + l[1],
            l[2],
            b[0],
            b[1],
            0.0,
        ];
        prims.push(record(
            mat,
            "polygon",
            format!("{name}.{}", n0 + 1),
            reals,
            loc,
        ));
    }
    prims
}

/// The prism with rounded edges (genprism's `compute_rounding`,
/// `printrends` and `rside`).
fn rounded_prism(
    p: &Prism,
    mat: &str,
    name: &str,
    loc: &SourceLoc,
) -> std::result::Result<Vec<RawPrim>, String> {
    let (v, l, crad) = (&p.verts, p.lvect, p.crad);
    let n = v.len();
    // Edge unit vectors: u[i] points from vertex i back to vertex i-1.
    let mut u = vec![[0.0f64; 2]; n];
    let mut v0 = v[n - 1];
    for i in 0..n {
        let v1 = v[i];
        u[i] = [v0[0] - v1[0], v0[1] - v1[1]];
        let len = (u[i][0] * u[i][0] + u[i][1] * u[i][1]).sqrt();
        if len <= PRISM_TINY {
            return Err(format!("degenerate side in prism (vertex {})", i + 1));
        }
        u[i][0] /= len;
        u[i][1] /= len;
        v0 = v1;
    }
    // Corner trim sizes.
    let mut a = vec![0.0f64; n];
    let mut w1 = u[0];
    for i in (0..n).rev() {
        let w0 = u[i];
        let d = w0[0] * w1[0] + w0[1] * w1[1];
        if 1.0 + d <= PRISM_TINY {
            return Err(format!("overlapping sides in prism (vertex {})", i + 1));
        }
        if 1.0 - d <= 0.0 {
            a[i] = 0.0;
        } else {
            a[i] = ((1.0 - d) / (1.0 + d)).sqrt();
            if (w1[0] * w0[1] - w1[1] * w0[0] > 0.0) != (l[2] > 0.0) {
                a[i] = -a[i];
            }
        }
        w1 = w0;
    }
    // The rounded corner's centre in the bottom and top planes.
    let bot = |i: usize| {
        [
            v[i][0] + crad * (a[i] * u[i][0] - u[i][1]),
            v[i][1] + crad * (a[i] * u[i][1] + u[i][0]),
        ]
    };
    let top = |i: usize| {
        [
            v[i][0] + l[0] + crad * (a[i] * u[i][0] - u[i][1]),
            v[i][1] + l[1] + crad * (a[i] * u[i][1] + u[i][0]),
        ]
    };
    let mut prims = Vec::new();
    if p.do_ends {
        for (end, z, corner) in [
            ("b", crad, &bot as &dyn Fn(usize) -> [f64; 2]),
            ("t", l[2] - crad, &top),
        ] {
            let face: Vec<f64> = if end == "b" {
                (0..n).flat_map(|i| [bot(i)[0], bot(i)[1], 0.0]).collect()
            } else {
                (0..n)
                    .rev()
                    .flat_map(|i| [top(i)[0], top(i)[1], l[2]])
                    .collect()
            };
            prims.push(record(mat, "polygon", format!("{name}.{end}"), face, loc));
            let cl = corner(n - 1);
            let mut c0 = [cl[0], cl[1], z];
            for (i, &ai) in a.iter().enumerate() {
                let c1 = if i < n - 1 {
                    let c = corner(i);
                    [c[0], c[1], z]
                } else {
                    [cl[0], cl[1], z]
                };
                if ai > 0.0 {
                    let reals = vec![c1[0], c1[1], c1[2], crad];
                    prims.push(record(
                        mat,
                        "sphere",
                        format!("{name}.{end}c{}", i + 1),
                        reals,
                        loc,
                    ));
                }
                let reals = vec![c0[0], c0[1], c0[2], c1[0], c1[1], c1[2], crad];
                prims.push(record(
                    mat,
                    "cylinder",
                    format!("{name}.{end}e{}", i + 1),
                    reals,
                    loc,
                ));
                c0 = c1;
            }
        }
    }
    let sides = if p.complete { n - 1 } else { n };
    for n0 in 0..sides {
        let n1 = (n0 + 1) % n;
        let s = (l[1] * u[n1][0] - l[0] * u[n1][1]) / p.llen;
        let t = if !(-PRISM_TINY..=PRISM_TINY).contains(&s) {
            let c = (1.0 - s * s).sqrt();
            [(c - 1.0) * u[n1][1], (1.0 - c) * u[n1][0], s]
        } else {
            [0.0; 3]
        };
        let (p0, p1) = (v[n0], v[n1]);
        let reals = vec![
            p0[0] + crad * (t[0] - a[n0] * u[n1][0]),
            p0[1] + crad * (t[1] - a[n0] * u[n1][1]),
            crad * (t[2] + 1.0),
            p0[0] + l[0] + crad * (t[0] - a[n0] * u[n1][0]),
            p0[1] + l[1] + crad * (t[1] - a[n0] * u[n1][1]),
            l[2] + crad * (t[2] - 1.0),
            p1[0] + l[0] + crad * (t[0] + a[n1] * u[n1][0]),
            p1[1] + l[1] + crad * (t[1] + a[n1] * u[n1][1]),
            l[2] + crad * (t[2] - 1.0),
            p1[0] + crad * (t[0] + a[n1] * u[n1][0]),
            p1[1] + crad * (t[1] + a[n1] * u[n1][1]),
            crad * (t[2] + 1.0),
        ];
        prims.push(record(
            mat,
            "polygon",
            format!("{name}.{}", n0 + 1),
            reals,
            loc,
        ));
        if a[n1] < 0.0 {
            continue;
        }
        let (b, e) = (bot(n1), top(n1));
        let reals = vec![b[0], b[1], crad, e[0], e[1], l[2] - crad, crad];
        prims.push(record(
            mat,
            "cylinder",
            format!("{name}.e{}", n0 + 1),
            reals,
            loc,
        ));
    }
    Ok(prims)
}

// ---------------------------------------------------------------------------
// genrev

/// Runs `genrev args` (the words after the program name).
pub(crate) fn run_genrev(
    _exp: &mut Expander,
    _args: &[String],
    loc: &SourceLoc,
    _out: &mut Vec<RawPrim>,
) -> Result<()> {
    Err(Error::parse(loc.clone(), "genrev: not implemented yet"))
}

#[cfg(test)]
#[path = "generators_tests.rs"]
mod tests;
