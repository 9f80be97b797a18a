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
use crate::cal::{Inputs, Library};
use crate::{Error, Result, SourceLoc};

/// genprism's `FTINY`.
const PRISM_TINY: f64 = 1e-6;
/// genprism's `MAXVERT`: its vertex array holds no more.
const MAX_VERTS: usize = 1024;
/// genrev's `FTINY`.
const REV_TINY: f64 = 1e-9;

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

/// Pushes one generated record, counting it against the scene's limit and
/// refusing non-finite values (arguments so large that the arithmetic
/// overflows, degenerate segments).
fn emit(exp: &mut Expander, prog: &str, p: RawPrim, out: &mut Vec<RawPrim>) -> Result<()> {
    if p.reals.iter().any(|r| !r.is_finite()) {
        return Err(Error::parse(
            p.loc.clone(),
            format!(
                "{prog}: {} '{}' gets a non-finite coordinate (arguments too large, or a degenerate shape)",
                p.ptype, p.id
            ),
        ));
    }
    exp.reserve(1, &p.loc)?;
    out.push(p);
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
        let bytes = crate::input::read_input(&path, crate::input::MAX_INPUT_BYTES)
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
    for p in prims {
        emit(exp, "genprism", p, out)?;
    }
    Ok(())
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

const REV_USAGE: &str = "usage: genrev material name 'z(t)' 'r(t)' nseg [-e expr] [-f file] [-s]";

/// What genrev defines before reading the user's definitions.
const REV_PRELUDE: &str = "
    PI : 3.14159265358979323846;
    hermite(p0, p1, r0, r1, t) = p0*((2*t-3)*t*t+1) + p1*(-2*t+3)*t*t
        + r0*((t-2)*t+1)*t + r1*(t-1)*t*t;
    bezier(p0, p1, p2, p3, t) = p0 * (1+t*(-3+t*(3-t))) + p1 * 3*t*(1+t*(-2+t))
        + p2 * 3*t*t*(1-t) + p3 * t*t*t;
    bspline(pp, p0, p1, pn, t) = pp * (1/6+t*(-1/2+t*(1/2-1/6*t)))
        + p0 * (2/3+t*t*(-1+1/2*t)) + p1 * (1/6+t*(1/2+t*(1/2-1/2*t)))
        + pn * (1/6*t*t*t);
";

/// genrev's `computen`: the unit normal (z and r parts) of the segment from
/// `(z0, r0)` to `(z1, r1)`.
fn rev_normal(z0: f64, r0: f64, z1: f64, r1: f64) -> (f64, f64) {
    let dz = r0 - r1;
    let dr = z1 - z0;
    let len = (dr * dr + dz * dz).sqrt();
    (dz / len, dr / len)
}

/// Runs `genrev args` (the words after the program name).
pub(crate) fn run_genrev(
    exp: &mut Expander,
    args: &[String],
    loc: &SourceLoc,
    out: &mut Vec<RawPrim>,
) -> Result<()> {
    let err = |why: String| Error::parse(loc.clone(), format!("genrev: {why}"));
    if args.len() < 5 {
        return Err(err(format!("too few arguments; {REV_USAGE}")));
    }
    let (mat, name) = (&args[0], &args[1]);
    let mut lib = Library::new(exp.search_path.clone())?;
    let g = lib.global();
    lib.define(g, REV_PRELUDE, &SourceLoc::new("<genrev>", 1))?;
    let mut smooth = false;
    let mut i = 5;
    while i < args.len() {
        match args[i].as_str() {
            "-s" => smooth = true,
            opt @ ("-e" | "-f") => {
                let Some(arg) = args.get(i + 1) else {
                    return Err(err(format!(
                        "option {opt} is missing its argument; {REV_USAGE}"
                    )));
                };
                i += 1;
                if opt == "-e" {
                    lib.define(g, arg, loc)
                        .map_err(|e| err(format!("in -e '{arg}': {e}")))?;
                } else {
                    let path = find_file(arg, loc, &exp.search_path)
                        .ok_or_else(|| err(format!("cannot find function file '{arg}'")))?;
                    let text = crate::input::read_input(&path, crate::input::MAX_INPUT_BYTES)
                        .map_err(|e| {
                            err(format!(
                                "cannot read function file '{}': {e}",
                                path.display()
                            ))
                        })?;
                    lib.define(
                        g,
                        &String::from_utf8_lossy(&text),
                        &SourceLoc::new(&path, 1),
                    )
                    .map_err(|e| err(format!("in -f {arg}: {e}")))?;
                }
            }
            other => return Err(err(format!("unexpected argument '{other}'; {REV_USAGE}"))),
        }
        i += 1;
    }
    // Like genrev, the curve is two functions of t defined after the
    // user's definitions, under names no one else can write.
    lib.define(g, &format!("Z`SYS`(t)={};", args[2]), loc)
        .map_err(|e| err(format!("in z(t) '{}': {e}", args[2])))?;
    lib.define(g, &format!("R`SYS`(t)={};", args[3]), loc)
        .map_err(|e| err(format!("in r(t) '{}': {e}", args[3])))?;
    let nseg: usize = match args[4].parse::<i64>() {
        Ok(n) if n > 0 => usize::try_from(n).unwrap_or(usize::MAX),
        _ => {
            return Err(err(format!(
                "the number of segments must be a positive integer, not '{}'; {REV_USAGE}",
                args[4]
            )))
        }
    };
    if nseg > super::rad::MAX_PRIMITIVES {
        return Err(err(format!(
            "{nseg} segments; at most {} primitives are allowed",
            super::rad::MAX_PRIMITIVES
        )));
    }
    let zf = lib.function(g, "Z`SYS`", 1, loc)?;
    let rf = lib.function(g, "R`SYS`", 1, loc)?;
    let prog = lib.finish().map_err(|e| err(e.to_string()))?;
    let no_args: [f64; 0] = [];
    let inputs = Inputs::new(&no_args);
    let at = |t: f64| -> Result<(f64, f64)> {
        let z = prog
            .call(zf, &[t], &inputs)
            .map_err(|e| err(format!("evaluating z({t}): {e}")))?;
        let r = prog
            .call(rf, &[t], &inputs)
            .map_err(|e| err(format!("evaluating r({t}): {e}")))?;
        Ok((z, r))
    };

    const OUT: u8 = 1;
    const IN: u8 = 2;
    const UP: u8 = 4;
    const DOWN: u8 = 8;
    let modname = if smooth { "Phong" } else { mat.as_str() };
    let mut prims = Vec::new();
    let (mut lastnz, mut lastnr) = (0.0, 0.0);
    let (mut lastz, mut lastr) = at(0.0)?;
    let (mut z, mut r) = at(1.0 / nseg as f64)?;
    let (mut nz, mut nr) = rev_normal(lastz, lastr, z, r);
    for i in 1..=nseg {
        let (nextz, nextr, nextnz, nextnr);
        if i < nseg {
            (nextz, nextr) = at((i + 1) as f64 / nseg as f64)?;
            (nextnz, nextnr) = rev_normal(z, r, nextz, nextr);
        } else {
            // genrev leaves the next point as it was, unused.
            (nextz, nextr) = (z, r);
            (nextnz, nextnr) = (0.0, 0.0);
        }
        let mut orient = 0;
        if z < lastz - REV_TINY {
            orient |= DOWN;
        } else if z > lastz + REV_TINY {
            orient |= UP;
        }
        if r < lastr - REV_TINY {
            orient |= IN;
        } else if r > lastr + REV_TINY {
            orient |= OUT;
        }
        if orient != 0 {
            if smooth {
                let mut reals = Vec::with_capacity(4);
                if orient & (UP | DOWN) != 0 {
                    let t = (nextnz - lastnz) / (z - lastz);
                    reals.extend([t, lastnz - t * lastz]);
                } else {
                    reals.extend([0.0, if orient & IN != 0 { 1.0 } else { -1.0 }]);
                }
                if orient & (OUT | IN) != 0 {
                    let t = (nextnr - lastnr) / (r - lastr);
                    reals.extend([t, lastnr - t * lastr]);
                } else {
                    reals.extend([0.0, if orient & UP != 0 { 1.0 } else { -1.0 }]);
                }
                let mut tex = record(mat, "texfunc", "Phong".to_string(), reals, loc);
                tex.strs = ["rev_dx", "rev_dy", "rev_dz", "rev.cal"]
                    .map(String::from)
                    .to_vec();
                emit(exp, "genrev", tex, &mut prims)?;
            }
            let id = format!("{name}.{i}");
            let (ptype, reals) = if orient & (IN | OUT) == 0 {
                let ptype = if orient & DOWN != 0 {
                    "tube"
                } else {
                    "cylinder"
                };
                (ptype, vec![0.0, 0.0, lastz, 0.0, 0.0, z, r])
            } else if orient & (UP | DOWN) == 0 {
                let dir = if orient & IN != 0 { 1.0 } else { -1.0 };
                ("ring", vec![0.0, 0.0, z, 0.0, 0.0, dir, lastr, r])
            } else {
                let ptype = if orient & DOWN != 0 { "cup" } else { "cone" };
                (ptype, vec![0.0, 0.0, lastz, 0.0, 0.0, z, lastr, r])
            };
            emit(
                exp,
                "genrev",
                record(modname, ptype, id, reals, loc),
                &mut prims,
            )?;
        }
        (lastz, lastr) = (z, r);
        (z, r) = (nextz, nextr);
        (lastnz, lastnr) = (nz, nr);
        (nz, nr) = (nextnz, nextnr);
    }
    out.append(&mut prims);
    Ok(())
}

#[cfg(test)]
#[path = "generators_tests.rs"]
mod tests;
