//! genprism and genrev against the output of Radiance's own programs (the
//! regression-test scenes' `expanded/*.oconv.rad`, where every in-line
//! command was run by Radiance 5.4a), argument errors, and random
//! arguments.

use std::path::{Path, PathBuf};

use proptest::prelude::*;

use super::super::rad::{Expander, RawPrim};
use crate::SourceLoc;

/// Radiance's regression-test scenes with their `expanded/` files, if this
/// checkout has them.
fn suite() -> Option<PathBuf> {
    crate::testdata::radiance_tests().filter(|d| d.join("expanded").is_dir())
}

/// The records of scene text (commands run by our built-ins).
fn expand(text: &str, file: &Path, search_path: Vec<PathBuf>) -> crate::Result<Vec<RawPrim>> {
    let mut exp = Expander::with_search_path(search_path);
    let mut out = Vec::new();
    exp.parse_text(text, file, &mut out)?;
    Ok(out)
}

/// The records oconv read for `arg` in `expanded/<scene>.oconv.rad`.
fn expanded_section(suite: &Path, scene: &str, arg: &str) -> Vec<RawPrim> {
    let path = suite.join("expanded").join(format!("{scene}.oconv.rad"));
    let text = std::fs::read_to_string(&path).unwrap();
    let start = text
        .find(&format!("# ======== oconv argument: {arg}\n"))
        .unwrap_or_else(|| panic!("no section for {arg} in {}", path.display()));
    let rest = &text[start..];
    let rest = &rest[rest.find('\n').unwrap() + 1..];
    let end = rest.find("# ======== ").unwrap_or(rest.len());
    expand(&rest[..end], &path, Vec::new()).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    // The expanded files print 12 significant digits.
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-6)
}

/// Compares records in order: type, modifier, id, strings, integers and
/// reals. Radiance's xform appends its transform to a texture's strings
/// (`-i 1 -ry 52 ...`), ours keeps it aside (`post`): then the leading
/// strings must agree and the rest start with `-i 1`. Returns the number
/// of records compared and the largest relative difference of a real.
fn compare(ours: &[RawPrim], theirs: &[RawPrim]) -> (usize, f64) {
    assert_eq!(
        ours.len(),
        theirs.len(),
        "record counts differ: ours {:?}\ntheirs {:?}",
        ours.iter().map(|p| &p.id).collect::<Vec<_>>(),
        theirs.iter().map(|p| &p.id).collect::<Vec<_>>()
    );
    let mut worst = 0.0f64;
    for (o, t) in ours.iter().zip(theirs) {
        let what = format!("{} {} {}", t.modifier, t.ptype, t.id);
        assert_eq!(
            (&o.modifier, &o.ptype, &o.id),
            (&t.modifier, &t.ptype, &t.id),
            "{what}"
        );
        if o.post.is_some() && t.strs.len() > o.strs.len() {
            assert_eq!(o.strs[..], t.strs[..o.strs.len()], "{what}");
            assert_eq!(
                t.strs[o.strs.len()..o.strs.len() + 2],
                ["-i", "1"],
                "{what}"
            );
        } else {
            assert_eq!(o.strs, t.strs, "{what}");
        }
        assert_eq!(o.ints, t.ints, "{what}");
        assert_eq!(o.reals.len(), t.reals.len(), "{what}");
        for (k, (&a, &b)) in o.reals.iter().zip(&t.reals).enumerate() {
            assert!(close(a, b), "{what} real {k}: ours {a:e}, Radiance's {b:e}");
            if a != b {
                worst = worst.max((a - b).abs() / a.abs().max(b.abs()).max(1e-6));
            }
        }
    }
    (ours.len(), worst)
}

// ---------------------------------------------------------------------------
// genprism

#[test]
fn genprism_rect_opening_matches_radiance() {
    // `!genprism wall_mat end_wall 10 ... -l 0 0 .2 -c | xform -ry -90 -t -8 0 0`
    let Some(s) = suite() else { return };
    let file = s.join("rect_opening.rad");
    let text = std::fs::read_to_string(&file).unwrap();
    let ours = expand(&text, &file, vec![s.join("lib")]).unwrap();
    for scene in ["glass", "dielectric"] {
        let theirs = expanded_section(&s, scene, "rect_opening.rad");
        let (n, worst) = compare(&ours, &theirs);
        assert_eq!(n, 11);
        eprintln!(
            "rect_opening.rad ({scene}): {n} records match, worst relative difference {worst:e}"
        );
    }
}

#[test]
fn genprism_diorama_walls_matches_radiance() {
    // diorama_walls.rad is this command's output, pasted and then edited by
    // hand: wall.5 commented out and wall.6 .. wall.9 given other materials.
    let Some(s) = suite() else { return };
    let cmd = "!genprism black_outside wall 10 -.1 -.1 -.1 5.1 3.1 5.1 3.1 -.1 -.1 -.1 \
               0 0 3 0 3 5 0 5 0 0 -l 0 0 8 -c | xform -ry -90\n";
    let ours = expand(cmd, Path::new("walls.rad"), Vec::new()).unwrap();
    let file = s.join("diorama_walls.rad");
    let mut theirs = expand(&std::fs::read_to_string(&file).unwrap(), &file, Vec::new()).unwrap();
    assert_eq!(ours.len(), 11);
    assert_eq!(theirs.len(), 10);
    let (n, _) = compare(&ours[..6], &theirs[..6]);
    for t in &mut theirs[6..] {
        t.modifier = "black_outside".to_string();
    }
    let (m, worst) = compare(&ours[7..], &theirs[6..]);
    eprintln!(
        "diorama_walls.rad: {} records match (wall.5 is commented out there), worst relative difference {worst:e}",
        n + m
    );
}

fn prism(cmd: &str) -> crate::Result<Vec<RawPrim>> {
    expand(&format!("!{cmd}\n"), Path::new("p.rad"), Vec::new())
}

fn reals(p: &RawPrim) -> Vec<f64> {
    p.reals.clone()
}

#[test]
fn genprism_plain_shapes() {
    // A unit square extruded by 2 along z: ends, then four sides.
    let out = prism("genprism m s 4 0 0 1 0 1 1 0 1 -l 0 0 2").unwrap();
    let ids: Vec<&str> = out.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(ids, ["s.b", "s.t", "s.1", "s.2", "s.3", "s.4"]);
    assert!(out
        .iter()
        .all(|p| p.ptype == "polygon" && p.modifier == "m"));
    assert_eq!(
        reals(&out[0]),
        [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]
    );
    assert_eq!(
        reals(&out[1]),
        [0., 1., 2., 1., 1., 2., 1., 0., 2., 0., 0., 2.]
    );
    assert_eq!(
        reals(&out[5]),
        [0., 1., 0., 0., 1., 2., 0., 0., 2., 0., 0., 0.]
    );
    // -e drops the ends, -c the closing side; a second -e toggles back.
    let out = prism("genprism m s 3 0 0 1 0 0 1 -e -c").unwrap();
    let ids: Vec<&str> = out.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(ids, ["s.1", "s.2"]);
    assert_eq!(prism("genprism m s 3 0 0 1 0 0 1 -e -e").unwrap().len(), 5);
}

#[test]
fn genprism_rounded_shapes() {
    // A 2x2 square rounded by .1, 1 high (clockwise seen from above, so
    // outward facing): every convex corner gets a sphere at both ends,
    // every edge a cylinder.
    let out = prism("genprism m s 4 0 0 0 2 2 2 2 0 -r .1").unwrap();
    let ids: Vec<&str> = out.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(
        ids,
        [
            "s.b", "s.bc1", "s.be1", "s.bc2", "s.be2", "s.bc3", "s.be3", "s.bc4", "s.be4", "s.t",
            "s.tc1", "s.te1", "s.tc2", "s.te2", "s.tc3", "s.te3", "s.tc4", "s.te4", "s.1", "s.e1",
            "s.2", "s.e2", "s.3", "s.e3", "s.4", "s.e4"
        ]
    );
    let eps = 1e-12;
    // The bottom face is inset by the radius.
    let b = reals(&out[0]);
    for (got, want) in b
        .iter()
        .zip([0.1, 0.1, 0., 0.1, 1.9, 0., 1.9, 1.9, 0., 1.9, 0.1, 0.])
    {
        assert!((got - want).abs() < eps, "{b:?}");
    }
    // Corner spheres sit a radius above the base at the inset corners.
    let c = reals(&out[1]);
    for (got, want) in c.iter().zip([0.1, 0.1, 0.1, 0.1]) {
        assert!((got - want).abs() < eps, "{c:?}");
    }
    // The side s.1 is in the plane x = 0, between the rounded edges.
    let s1 = reals(&out[18]);
    for (got, want) in s1
        .iter()
        .zip([0., 0.1, 0.1, 0., 0.1, 0.9, 0., 1.9, 0.9, 0., 1.9, 0.1])
    {
        assert!((got - want).abs() < eps, "{s1:?}");
    }
}

#[test]
fn genprism_reads_a_vertex_file() {
    let d = std::env::temp_dir().join(format!("hybrid-rt-genprism-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("tri.pts"), "0 0\n1 0\n0 1\nnot numbers\n5 5\n").unwrap();
    let scene = d.join("s.rad");
    let out = expand("!genprism m t tri.pts -l 0 0 3\n", &scene, Vec::new()).unwrap();
    assert_eq!(out.len(), 5);
    assert_eq!(reals(&out[0]), [0., 0., 0., 1., 0., 0., 0., 1., 0.]);
    let e = expand("!genprism m t nothere.pts\n", &scene, Vec::new()).unwrap_err();
    assert!(e.to_string().contains("cannot open vertex file"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[track_caller]
fn assert_err(cmd: &str, needle: &str) {
    let loc = SourceLoc::new("p.rad", 1);
    match prism(cmd) {
        Err(e) => {
            let s = e.to_string();
            assert!(s.contains(needle) && s.contains("p.rad:1"), "{cmd}: {s}");
            let _ = &loc;
        }
        Ok(p) => panic!("{cmd}: accepted, {} records", p.len()),
    }
}

#[test]
fn genprism_argument_errors() {
    for (cmd, needle) in [
        ("genprism m s", "genprism: too few arguments"),
        ("genprism m s -", "standard input"),
        ("genprism m s 3 0 0 1 0 0", "3 vertices need 6 coordinates"),
        ("genprism m s 2 0 0 1 0", "not enough vertices"),
        ("genprism m s 3x 0 0 1 0 0 1", "bad vertex count"),
        ("genprism m s 2000 0 0", "at most 1024"),
        ("genprism m s 3 0 0 1 0 0 z", "bad real argument 'z'"),
        (
            "genprism m s 3 0 0 1 0 0 1 -l 0 0",
            "-l is missing a number",
        ),
        (
            "genprism m s 3 0 0 1 0 0 1 -l 0 0 0",
            "zero extrusion vector",
        ),
        ("genprism m s 3 0 0 1 0 0 1 -r", "-r is missing a number"),
        (
            "genprism m s 3 0 0 1 0 0 1 -r 2",
            "rounding radius 2 greater than the height 1",
        ),
        ("genprism m s 3 0 0 1 0 0 1 -x", "unexpected argument '-x'"),
        ("genprism m s 3 0 0 1 0 0 1 7", "unexpected argument '7'"),
        ("genprism m s 3 0 0 0 0 0 1 -r .1", "degenerate side"),
        ("genprism m s 3 0 0 1 0 2 0 -r .1", "overlapping sides"),
        (
            "genprism m s 3 0 0 1e308 0 0 1e308 -l 1e308 0 1",
            "non-finite",
        ),
        (
            "genbox m b 1 1 1 | genprism m s 3 0 0 1 0 0 1",
            "cannot read from a pipe",
        ),
    ] {
        assert_err(cmd, needle);
    }
}

// ---------------------------------------------------------------------------
// genrev

#[test]
fn genrev_torus_matches_radiance() {
    // `!genrev striped torus "sin(2*PI*t)" "2+cos(2*PI*t)" 32 -s | xform -ry 52 -s .2 -t -4 2.5 1.5`:
    // a texfunc before each of the 32 surfaces.
    let Some(s) = suite() else { return };
    let file = s.join("torus.rad");
    let text = std::fs::read_to_string(&file).unwrap();
    let ours = expand(&text, &file, vec![s.join("lib")]).unwrap();
    let theirs = expanded_section(&s, "glass", "torus.rad");
    let (n, worst) = compare(&ours, &theirs);
    assert_eq!(n, 3 + 64);
    assert_eq!(ours.iter().filter(|p| p.ptype == "texfunc").count(), 32);
    eprintln!("torus.rad: {n} records match (3 materials, 32 texfunc, 32 surfaces), worst relative difference {worst:e}");
}

#[test]
fn genrev_saucer_matches_radiance() {
    // saucer.rad is the output of the command in its comment.
    let Some(s) = suite() else { return };
    let cmd = "!genrev mat seg '-.25+.9*cos(PI/6*(1-t))' '.9*sin(PI/6*(1-t))' 55\n";
    let ours = expand(cmd, Path::new("saucer.rad"), Vec::new()).unwrap();
    let file = s.join("saucer.rad");
    let theirs: Vec<RawPrim> = expand(&std::fs::read_to_string(&file).unwrap(), &file, Vec::new())
        .unwrap()
        .into_iter()
        .filter(|p| p.id.starts_with("seg."))
        .collect();
    let (n, worst) = compare(&ours, &theirs);
    assert_eq!(n, 55);
    eprintln!("saucer.rad: {n} records match, worst relative difference {worst:e}");
}

fn rev(cmd: &str) -> Vec<RawPrim> {
    prism(cmd).unwrap_or_else(|e| panic!("{cmd}: {e}"))
}

#[test]
fn genrev_surface_types() {
    // Up the z axis at radius 1: cylinders; down: tubes.
    let out = rev("genrev m c 't' '1' 2");
    assert_eq!(out.len(), 2);
    assert_eq!(
        (out[0].ptype.as_str(), out[0].id.as_str()),
        ("cylinder", "c.1")
    );
    assert_eq!(out[1].reals, [0., 0., 0.5, 0., 0., 1., 1.]);
    assert_eq!(rev("genrev m c 1-t 1 1")[0].ptype, "tube");
    // Flat, outward: a ring with normal -z; inward: +z.
    let out = rev("genrev m d 0 1+t 1");
    assert_eq!(
        (out[0].ptype.as_str(), &out[0].reals[..]),
        ("ring", &[0., 0., 0., 0., 0., -1., 1., 2.][..])
    );
    assert_eq!(rev("genrev m d 0 2-t 1")[0].reals[5], 1.0);
    // Sloped: cones up, cups down.
    assert_eq!(rev("genrev m k t 1+t 1")[0].ptype, "cone");
    assert_eq!(rev("genrev m k -t 1+t 1")[0].ptype, "cup");
    // A segment that does not move is left out, keeping its number.
    let ids: Vec<String> = rev("genrev m p 'if(t-.6,t,.5)' 1 3")
        .into_iter()
        .map(|p| p.id)
        .collect();
    assert_eq!(ids, ["p.2", "p.3"]);
    // -s: a Phong texfunc before each surface, which uses it.
    let out = rev("genrev m c t 1 2 -s");
    assert_eq!(out.len(), 4);
    assert_eq!(
        (
            out[0].modifier.as_str(),
            out[0].ptype.as_str(),
            out[0].id.as_str()
        ),
        ("m", "texfunc", "Phong")
    );
    assert_eq!(out[0].strs, ["rev_dx", "rev_dy", "rev_dz", "rev.cal"]);
    // Straight up: the normal's z part does not change (0, 0), the r
    // part is constant 1 (no radius change: 0 then 1 because UP).
    assert_eq!(out[0].reals, [0., 0., 0., 1.]);
    assert_eq!(
        (out[1].modifier.as_str(), out[1].ptype.as_str()),
        ("Phong", "cylinder")
    );
}

#[test]
fn genrev_definitions_and_files() {
    // -e definitions, genrev's own functions and PI.
    let out = rev("genrev m s 'zz(t)' 'bezier(1,2,2,1,t)' 4 -e 'zz(x) = 2*x; k = PI'");
    assert_eq!(out.len(), 4);
    assert_eq!(out[3].reals[5], 2.0);
    assert_eq!(out[0].reals[6], 1.0);
    assert!(
        (out[0].reals[7] - (1. + 0.75 * 0.75 * 0.25 * 3. + 0.25 * 0.25 * 0.75 * 3.) + 1. - 1.)
            .abs()
            < 1e-12
    );
    let h = rev("genrev m s t 'hermite(1,2,0,0,t)+0*bspline(1,1,1,1,t)' 2");
    assert_eq!(h[0].reals[7], 1.5);
    // -f finds its file beside the scene.
    let d = std::env::temp_dir().join(format!("hybrid-rt-genrev-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("prof.cal"), "rad(t) = 1 + t*t;\n").unwrap();
    let scene = d.join("s.rad");
    let out = expand("!genrev m s t 'rad(t)' 2 -f prof.cal\n", &scene, Vec::new()).unwrap();
    assert_eq!(out[1].reals[7], 2.0);
    let e = expand("!genrev m s t 'rad(t)' 2 -f none.cal\n", &scene, Vec::new()).unwrap_err();
    assert!(
        e.to_string()
            .contains("cannot find function file 'none.cal'"),
        "{e}"
    );
    std::fs::write(d.join("bad.cal"), "\nrad(t) = 1 +;\n").unwrap();
    let e = expand("!genrev m s t 'rad(t)' 2 -f bad.cal\n", &scene, Vec::new()).unwrap_err();
    assert!(e.to_string().contains("bad.cal:2"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn genrev_argument_errors() {
    for (cmd, needle) in [
        ("genrev m s t 1", "genrev: too few arguments"),
        ("genrev m s t 1 0", "positive integer, not '0'"),
        ("genrev m s t 1 -3", "positive integer"),
        ("genrev m s t 1 x", "positive integer, not 'x'"),
        ("genrev m s t 1 99999999999", "at most"),
        ("genrev m s t 1 4 -x", "unexpected argument '-x'"),
        ("genrev m s t 1 4 -e", "-e is missing its argument"),
        ("genrev m s t 1 4 -f", "-f is missing its argument"),
        ("genrev m s 't+' 1 4", "in z(t) 't+'"),
        ("genrev m s t 'q(t)' 4", "q"),
        ("genrev m s t 1 4 -e 'a = = 2'", "in -e"),
        ("genrev m s 't' 'f(t)' 4 -e 'f(x) = f(x)'", "evaluating r("),
        ("genrev m s 0 0 4 -s", ""),
        (
            // A first segment that does not move has no normal (0/0),
            // which the next one's smoothing uses.
            "genrev m s 'if(t-.4,t,0)' 1 3 -s",
            "non-finite",
        ),
        (
            "genbox m b 1 1 1 | genrev m s t 1 2",
            "cannot read from a pipe",
        ),
    ] {
        if needle.is_empty() {
            // Nothing moves: no records, no error (as genrev).
            assert!(rev(cmd).is_empty());
            continue;
        }
        assert_err(cmd, needle);
    }
}

/// Words that make up random command lines: numbers, options, junk.
fn arg_word() -> impl Strategy<Value = String> {
    prop_oneof![
        (-3i32..6).prop_map(|v| v.to_string()),
        (-1e3f64..1e3).prop_map(|v| format!("{v}")),
        Just("-l".to_string()),
        Just("-r".to_string()),
        Just("-e".to_string()),
        Just("-c".to_string()),
        Just("-s".to_string()),
        Just("-f".to_string()),
        Just("-".to_string()),
        Just("1e308".to_string()),
        Just("0".to_string()),
        Just("'t*t'".to_string()),
        Just("'sin(t)'".to_string()),
        Just("'1/0'".to_string()),
        Just("\"2+cos(PI*t)\"".to_string()),
        "[a-z0-9.()*+-]{0,6}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Any argument list gives records or an error, never a panic.
    #[test]
    fn generators_never_panic(
        prog in prop_oneof![Just("genprism"), Just("genrev")],
        words in proptest::collection::vec(arg_word(), 0..14),
    ) {
        let cmd = format!("!{prog} m n {}\n", words.join(" "));
        let _ = expand(&cmd, Path::new("p.rad"), Vec::new());
    }
}

#[test]
fn commands_split_like_sh() {
    use super::super::rad::split_command;
    let s = split_command(r#"genrev m n "2+cos(PI*t)" 'a b;c' x\ y '' | xform -s 2"#).unwrap();
    assert_eq!(
        s,
        [
            vec!["genrev", "m", "n", "2+cos(PI*t)", "a b;c", "x y", ""],
            vec!["xform", "-s", "2"]
        ]
    );
    assert_eq!(split_command(r#"a "\$x\"""#).unwrap(), [vec!["a", "$x\""]]);
    for bad in [
        "a 'b",
        "a \"b",
        "a \"$HOME\"",
        "a $x",
        "a > b",
        "a; b",
        "a (b)",
    ] {
        assert!(split_command(bad).is_err(), "{bad}");
    }
}
