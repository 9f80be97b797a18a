//! Tests of the function language against hand-worked values and values
//! derived from Radiance's C code.

use std::path::{Path, PathBuf};

use super::*;
use crate::SourceLoc;

fn here() -> SourceLoc {
    SourceLoc::new("scene.rad", 7)
}

fn library() -> Library {
    Library::new(Vec::new()).expect("prelude compiles")
}

/// Evaluates `expr` in the global context after `defs`, with `inputs`.
fn eval_with(defs: &str, expr: &str, values: [f64; N_INPUTS], args: &[f64]) -> f64 {
    try_eval(defs, expr, values, args).unwrap_or_else(|e| panic!("{expr}: {e}"))
}

fn try_eval(defs: &str, expr: &str, values: [f64; N_INPUTS], args: &[f64]) -> Result<f64, String> {
    let mut lib = library();
    let g = lib.global();
    lib.define_text(g, defs, Path::new("test.cal"), 0)
        .map_err(|e| e.to_string())?;
    let e = lib.expr(g, expr, &here()).map_err(|e| e.to_string())?;
    let p = lib.finish().map_err(|e| e.to_string())?;
    p.eval(e, &Inputs { values, args })
        .map_err(|e| e.to_string())
}

fn ev(expr: &str) -> f64 {
    eval_with("", expr, [0.0; N_INPUTS], &[])
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

/// A fresh directory under the system's temporary one.
fn temp_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "hybrid-rt-cal-{}-{tag}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn cal_arithmetic_and_precedence() {
    assert_eq!(ev("1+2*3"), 7.0);
    assert_eq!(ev("(1+2)*3"), 9.0);
    assert_eq!(ev("10-4-3"), 3.0);
    assert_eq!(ev("8/4/2"), 1.0);
    // `^` is right-associative: 2^(3^2).
    assert_eq!(ev("2^3^2"), 512.0);
    // calcomp's getE4 binds the sign to the operand before `^`: (-2)^2.
    assert_eq!(ev("-2^2"), 4.0);
    assert_eq!(ev("2^-1"), 0.5);
    assert_eq!(ev("-(-3)"), 3.0);
    assert_eq!(ev("+4"), 4.0);
    assert_eq!(ev("2*-3"), -6.0);
    assert_eq!(ev(".5"), 0.5);
    assert_eq!(ev("1e-3"), 0.001);
    assert_eq!(ev("2."), 2.0);
    assert_eq!(ev("1.5E+2"), 150.0);
    assert_eq!(ev("  { a { nested } comment } 3 "), 3.0);
    // calcomp: division by zero gives 0 (with a warning).
    assert_eq!(ev("1/0"), 0.0);
    // calcomp: an illegal power gives 0.
    assert_eq!(ev("(-8)^(1/3)"), 0.0);
    assert_eq!(ev("10^400"), 0.0);
    // calcomp does not accept a second sign.
    assert!(try_eval("", "--2", [0.0; N_INPUTS], &[]).is_err());
}

#[test]
fn cal_definitions_functions_recursion() {
    let defs = "
        a = 2; b : a*3;
        sq2(x) = x*x;
        fact(n) = if(n-.5, n*fact(n-1), 1);
        x = 1; x = 5 { a later definition replaces }
    ";
    let z = [0.0; N_INPUTS];
    assert_eq!(eval_with(defs, "b", z, &[]), 6.0);
    assert_eq!(eval_with(defs, "sq2(a+1)", z, &[]), 9.0);
    assert_eq!(eval_with(defs, "fact(5)", z, &[]), 120.0);
    assert_eq!(eval_with(defs, "fact(10)", z, &[]), 3628800.0);
    assert_eq!(eval_with(defs, "x", z, &[]), 5.0);
    // The final `;` may be missing, empty statements are fine.
    assert_eq!(eval_with(";; y = 3;; z = y+1", "z", z, &[]), 4.0);
}

#[test]
fn cal_channels_and_named_inputs() {
    let mut v = [0.0; N_INPUTS];
    for (i, x) in v.iter_mut().enumerate() {
        *x = i as f64 + 0.5;
    }
    assert_eq!(eval_with("", "Dx", v, &[]), v[chan::DX]);
    assert_eq!(eval_with("", "$1", v, &[]), v[chan::DX]);
    assert_eq!(eval_with("", "Pz", v, &[]), v[chan::PZ]);
    assert_eq!(eval_with("", "$9", v, &[]), v[chan::PZ]);
    assert_eq!(eval_with("", "T", v, &[]), v[chan::T]);
    assert_eq!(eval_with("", "Rdot", v, &[]), v[chan::RDOT]);
    assert_eq!(eval_with("", "S", v, &[]), v[chan::S]);
    assert_eq!(eval_with("", "Kz", v, &[]), v[chan::KZ]);
    assert_eq!(eval_with("", "Ts", v, &[]), v[chan::TS]);
    assert_eq!(eval_with("", "Lv", v, &[]), v[chan::LV]);
    assert_eq!(eval_with("", "$27", v, &[]), v[chan::LV]);
    assert_eq!(eval_with("", "NxP", v, &[]), v[chan::NXP]);
    assert_eq!(eval_with("", "RdotP", v, &[]), v[chan::RDOTP]);
    assert_eq!(eval_with("", "CbP", v, &[]), v[chan::CBP]);
    assert_eq!(eval_with("", "DzA", v, &[]), v[chan::DZA]);
    assert!(try_eval("", "$28", v, &[]).is_err());
    assert!(try_eval("", "$0", v, &[]).is_err());
}

#[test]
fn cal_function_arguments() {
    let mut v = [0.0; N_INPUTS];
    v[chan::DX] = 1.0;
    v[chan::DY] = 2.0;
    v[chan::DZ] = 3.0;
    v[chan::NX] = 4.0;
    v[chan::NY] = 5.0;
    v[chan::NZ] = 6.0;
    // 1*4 + 2*5 + 3*6
    assert_eq!(eval_with("", "dot(D, N)", v, &[]), 32.0);
    // D x N = (2*6-3*5, 3*4-1*6, 1*5-2*4) = (-3, 6, -3)
    assert_eq!(eval_with("", "cross(1, D, N)", v, &[]), -3.0);
    assert_eq!(eval_with("", "cross(2, D, N)", v, &[]), 6.0);
    assert_eq!(eval_with("", "cross(3, D, N)", v, &[]), -3.0);
    // A function passed on through a parameter, and a built-in passed.
    let defs = "twice(f, x) = f(f(x)); pass(g, y) = twice(g, y); inc(x) = x+1;";
    assert_eq!(eval_with(defs, "pass(inc, 1)", v, &[]), 3.0);
    assert_eq!(eval_with(defs, "twice(sqrt, 16)", v, &[]), 2.0);
    // A value where a function is wanted is a run-time error.
    assert!(try_eval(defs, "twice(Dx, 1)", v, &[]).is_err());
    // A function used as a value is a compile error when it is plain.
    assert!(try_eval("", "D + 1", v, &[]).is_err());
    assert!(try_eval("", "Dx(1)", v, &[]).is_err());
}

#[test]
fn cal_lazy_arguments() {
    // `never` would recurse forever; the body never uses its argument.
    let defs = "never(x) = never(x+1); first(a, b) = a; pick(c, a, b) = if(c, a, b);";
    let z = [0.0; N_INPUTS];
    assert_eq!(eval_with(defs, "first(2, never(1))", z, &[]), 2.0);
    assert_eq!(eval_with(defs, "pick(1, 3, never(1))", z, &[]), 3.0);
    assert_eq!(eval_with(defs, "pick(-1, never(1), 4)", z, &[]), 4.0);
    assert_eq!(eval_with(defs, "if(0, never(1), 5)", z, &[]), 5.0);
    assert_eq!(eval_with(defs, "select(1, 6, never(1))", z, &[]), 6.0);
    assert!(try_eval(defs, "first(never(1), 2)", z, &[]).is_err());
}

#[test]
fn cal_select_min_max() {
    assert_eq!(ev("select(2, 10, 20, 30)"), 20.0);
    assert_eq!(ev("select(2.4, 10, 20, 30)"), 20.0);
    assert_eq!(ev("select(2.6, 10, 20, 30)"), 30.0);
    // select(0, ...) is the count of choices.
    assert_eq!(ev("select(0, 10, 20, 30)"), 3.0);
    // Out of range is calcomp's domain error: 0.
    assert_eq!(ev("select(4, 10, 20, 30)"), 0.0);
    assert_eq!(ev("select(-1, 10, 20, 30)"), 0.0);
    assert_eq!(ev("min(3, 1, 2)"), 1.0);
    assert_eq!(ev("max(3, 1, 2, 7, -1)"), 7.0);
    assert_eq!(ev("min(4)"), 4.0);
}

#[test]
fn cal_arg() {
    let z = [0.0; N_INPUTS];
    let args = [10.0, 20.0, 30.0];
    assert_eq!(eval_with("", "arg(0)", z, &args), 3.0);
    assert_eq!(eval_with("", "AC", z, &args), 3.0);
    assert_eq!(eval_with("", "arg(2)", z, &args), 20.0);
    assert_eq!(eval_with("", "arg(2.6)", z, &args), 30.0);
    assert_eq!(eval_with("", "A1 + A3", z, &args), 40.0);
    // func.c: n < 1 is the count; beyond the count is an error.
    assert_eq!(eval_with("", "arg(-3)", z, &args), 3.0);
    let e = try_eval("", "A4", z, &args).unwrap_err();
    assert!(e.contains("missing real argument 4"), "{e}");
}

#[test]
fn cal_every_builtin() {
    assert_eq!(ev("sqrt(16)"), 4.0);
    assert_eq!(ev("sin(0.5)"), 0.5f64.sin());
    assert_eq!(ev("cos(0.5)"), 0.5f64.cos());
    assert_eq!(ev("tan(0.5)"), 0.5f64.tan());
    assert_eq!(ev("asin(1)"), std::f64::consts::FRAC_PI_2);
    assert_eq!(ev("acos(0)"), std::f64::consts::FRAC_PI_2);
    assert_eq!(ev("atan(1)"), std::f64::consts::FRAC_PI_4);
    assert_eq!(ev("atan2(1, 1)"), std::f64::consts::FRAC_PI_4);
    assert_eq!(ev("atan2(1, -1)"), 3.0 * std::f64::consts::FRAC_PI_4);
    assert_eq!(ev("exp(1)"), std::f64::consts::E);
    assert_eq!(ev("log(exp(2))"), 2.0);
    assert_eq!(ev("log10(1000)"), 3.0);
    assert_eq!(ev("floor(-1.5)"), -2.0);
    assert_eq!(ev("ceil(-1.5)"), -1.0);
    assert_eq!(ev("if(1, 2, 3)"), 2.0);
    assert_eq!(ev("if(0, 2, 3)"), 3.0);
    assert_eq!(ev("if(-1, 2, 3)"), 3.0);
    // erf(0.5), erfc(0.5) to 16 digits (Abramowitz & Stegun's tables give
    // erf(0.5) = 0.5204998778).
    assert!(close(ev("erf(0.5)"), 0.5204998778130465));
    assert!(close(ev("erfc(0.5)"), 0.4795001221869535));
    assert_eq!(ev("erf(0)"), 0.0);
    // hermite(1,2,3,4,.5): 1*((1-3)*.25+1) + 2*(-1+3)*.25 + 3*((.5-2)*.5+1)*.5
    // + 4*(.5-1)*.25 = 0.5 + 1 + 0.375 - 0.5
    assert_eq!(ev("hermite(1, 2, 3, 4, .5)"), 1.375);
    // Domain and range errors give 0, as calcomp's libfunc does.
    assert_eq!(ev("sqrt(-1)"), 0.0);
    assert_eq!(ev("log(0)"), 0.0);
    assert_eq!(ev("log(-1)"), 0.0);
    assert_eq!(ev("acos(2)"), 0.0);
    assert_eq!(ev("exp(1000)"), 0.0);
    assert_eq!(ev("1 + sqrt(-1)"), 1.0);
    // calcomp's errno is sticky: an error inside a library call's arguments
    // zeroes that call too.
    assert_eq!(ev("max(1 + sqrt(-1), 0.5)"), 0.0);
    assert_eq!(ev("if(1, 2 + 1/0, 3)"), 0.0);
    // rayinit's safe forms.
    assert_eq!(ev("Sqrt(-1)"), 0.0);
    assert_eq!(ev("Exp(-1000)"), 0.0);
    assert_eq!(ev("Acos(2)"), 0.0);
    assert_eq!(ev("Atan2(0, 0)"), 0.0);
}

#[test]
fn cal_warnings_counted() {
    let mut lib = library();
    let g = lib.global();
    let e = lib.expr(g, "sqrt(Px)", &here()).unwrap();
    let p = lib.finish().unwrap();
    let mut inp = Inputs::new(&[]);
    inp.values[chan::PX] = -4.0;
    assert_eq!(p.eval(e, &inp).unwrap(), 0.0);
    assert_eq!(p.warnings(), 1);
    inp.values[chan::PX] = 4.0;
    assert_eq!(p.eval(e, &inp).unwrap(), 2.0);
    assert_eq!(p.warnings(), 1);
}

/// calcomp's `l_rand`, worked through in double precision (an independent
/// port of calfunc.c's four lines, run outside this crate): for x = 0,
/// x*(1/(1+0)+e) = 0; 0 + .785398163397447 - floor(0) = .785398163397447;
/// 1e5/that = 127323.95447351627; its fraction is .95447351636...
#[test]
fn cal_rand_against_c() {
    assert!(close(ev("rand(0)"), 0.954473516496364));
    assert!(close(ev("rand(0.5)"), 0.2343470132254879));
    assert!(close(ev("rand(1)"), 0.35008305980591103));
    assert!(close(ev("rand(-2.5)"), 0.22564915163820842));
    assert!(close(ev("rand(123.456)"), 0.658230833694688));
}

/// noise3.c's `frand`: for frand(0), s = 0<<13 ^ 0 = 0, so the polynomial
/// is 1376312589, which `& 0x7fffffff` leaves alone, and the result is
/// 1 - 1376312589/2^30 = -0.28179098386317...; frand(1) and frand(-7) come
/// from the same steps with 64-bit wrapping products (an independent port).
#[test]
fn cal_frand_against_c() {
    assert_eq!(noise::frand(0), 1.0 - 1376312589.0 / 1073741824.0);
    assert!(close(noise::frand(0), -0.2817909838631749));
    assert!(close(noise::frand(1), -0.2263730512931943));
    assert!(close(noise::frand(-7), 0.018403123132884502));
}

/// Radiance 5's noise3 (noise3.c 2.14) is Perlin's improved noise, which
/// is 0 at every lattice point; its partials are backward differences over
/// 0.0005. Off the lattice the expected values come from an independent
/// Python port of noise3.c 2.14's `perlin_noise`, `noise3partial` and
/// `fnoise3` (EPSILON .0005; with .001 the same port gives the earlier
/// Radiance's fnoise3(0.5, 0.25, 0.125) = -0.7006690010076829).
#[test]
fn cal_noise_against_c() {
    assert_eq!(ev("noise3(1, 2, 3)"), 0.0);
    assert_eq!(ev("noise3(-4, 0, 7)"), 0.0);
    let cases: [([f64; 3], [f64; 4]); 3] = [
        (
            [0.5, 0.25, 0.125],
            [
                -1.3155529491812035,
                -0.6674905177851964,
                -0.13254968119300048,
                -0.08358576893806458,
            ],
        ),
        (
            [-1.3, 2.7, 0.01],
            [
                2.016165819725635,
                -0.9367198390284048,
                0.02539796161282748,
                -0.10024579294338018,
            ],
        ),
        (
            [10.1, -3.3, 5.5],
            [
                0.5206864184833515,
                -0.12291085459825712,
                0.006318497656199185,
                -0.1739783859200002,
            ],
        ),
    ];
    for (p, f) in cases {
        let a = format!("{}, {}, {}", p[0], p[1], p[2]);
        assert!(close(ev(&format!("noise3x({a})")), f[0]), "{a}");
        assert!(close(ev(&format!("noise3y({a})")), f[1]), "{a}");
        assert!(close(ev(&format!("noise3z({a})")), f[2]), "{a}");
        assert!(close(ev(&format!("noise3({a})")), f[3]), "{a}");
        assert!(close(ev(&format!("noise3a({a})")), f[0]), "{a}");
        assert!(close(ev(&format!("noise3d(3, {a})")), f[2]), "{a}");
    }
    assert!(close(ev("fnoise3(0.5, 0.25, 0.125)"), -0.2619491657206533));
    assert!(close(ev("fnoise3(-1.3, 2.7, 0.01)"), -0.13085776401369742));
    assert!(close(ev("fnoise3(3.3, 6.6, 9.9)"), -0.059519024884313786));
    // The partials are the slope of noise3 (central differences agree).
    let h = 1e-4;
    let slope =
        (ev("noise3(0.5 + 1e-4, 0.25, 0.125)") - ev("noise3(0.5 - 1e-4, 0.25, 0.125)")) / (2.0 * h);
    assert!(
        (slope - ev("noise3x(0.5, 0.25, 0.125)")).abs() < 2e-3,
        "{slope}"
    );
}

#[test]
fn cal_contexts() {
    let dir = temp_dir("ctx");
    std::fs::write(dir.join("a.cal"), "k = 1; fa(x) = x + k; PI = 3;").unwrap();
    std::fs::write(dir.join("b.cal"), "k = 2; fb(x) = x + k;").unwrap();
    let mut lib = library();
    let a = lib.load_file("a.cal", &dir, &here()).unwrap();
    let b = lib.load_file("b.cal", &dir, &here()).unwrap();
    assert_ne!(a, b);
    assert_eq!(lib.context_name(a), "a");
    assert_eq!(lib.context_name(lib.global()), "");
    // Loaded once.
    assert_eq!(lib.load_file("a.cal", &dir, &here()).unwrap(), a);
    assert_eq!(lib.load_file(".", &dir, &here()).unwrap(), lib.global());
    assert!(lib.is_defined(a, "fa"));
    assert!(!lib.is_defined(b, "fa"));
    assert!(lib.is_defined(b, "grey"));
    assert!(lib.is_defined(b, "sqrt"));
    assert!(!lib.is_defined(lib.global(), "k"));
    let ea = lib.expr(a, "k", &here()).unwrap();
    let eb = lib.expr(b, "k", &here()).unwrap();
    let pa = lib.expr(a, "PI", &here()).unwrap();
    let pb = lib.expr(b, "PI", &here()).unwrap();
    let fa = lib.function(a, "fa", 1, &here()).unwrap();
    let fb = lib.function(b, "fb", 1, &here()).unwrap();
    let grey = lib.function(b, "grey", 3, &here()).unwrap();
    let p = lib.finish().unwrap();
    let inp = Inputs::new(&[]);
    assert_eq!(p.eval(ea, &inp).unwrap(), 1.0);
    assert_eq!(p.eval(eb, &inp).unwrap(), 2.0);
    assert_eq!(p.eval(pa, &inp).unwrap(), 3.0);
    assert_eq!(p.eval(pb, &inp).unwrap(), std::f64::consts::PI);
    assert_eq!(p.call(fa, &[10.0], &inp).unwrap(), 11.0);
    assert_eq!(p.call(fb, &[10.0], &inp).unwrap(), 12.0);
    assert!(close(
        p.call(grey, &[1.0, 1.0, 1.0], &inp).unwrap(),
        0.265074126 + 0.670114631 + 0.064811243
    ));
    // A name defined only in a file is undefined globally.
    let mut lib = library();
    lib.load_file("a.cal", &dir, &here()).unwrap();
    let g = lib.global();
    lib.expr(g, "k", &here()).unwrap();
    let e = lib.finish().unwrap_err().to_string();
    assert!(e.contains("scene.rad:7:1") && e.contains("`k`"), "{e}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn cal_search_path_and_missing_file() {
    let dir = temp_dir("path");
    let libdir = dir.join("lib");
    std::fs::create_dir_all(&libdir).unwrap();
    std::fs::write(libdir.join("c.cal"), "c = 7;").unwrap();
    let mut lib = Library::new(vec![libdir.clone()]).unwrap();
    let c = lib.load_file("c.cal", &dir, &here()).unwrap();
    let abs = lib
        .load_file(
            libdir.join("c.cal").to_str().unwrap(),
            Path::new("/"),
            &here(),
        )
        .unwrap();
    assert_eq!(c, abs);
    let e = lib
        .load_file("nope.cal", &dir, &here())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("scene.rad:7") && e.contains("nope.cal"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn cal_errors_name_file_line_column() {
    let dir = temp_dir("err");
    std::fs::write(dir.join("bad.cal"), "a = 1;\nb = 2;\n  c = (3 + ;\n").unwrap();
    let mut lib = library();
    let e = lib
        .load_file("bad.cal", &dir, &here())
        .unwrap_err()
        .to_string();
    let want = format!("{}:3:12", dir.join("bad.cal").display());
    assert!(e.starts_with(&want), "{e} (want {want})");
    // A file that failed is not taken as loaded the next time.
    assert!(lib.load_file("bad.cal", &dir, &here()).is_err());
    std::fs::write(dir.join("undef.cal"), "a = 1;\n\nf(x) = x + nothere;\n").unwrap();
    let u = lib.load_file("undef.cal", &dir, &here()).unwrap();
    // Unreachable: no error yet.
    let g = lib.global();
    let ok = lib.expr(g, "1", &here()).unwrap();
    let _ = ok;
    let _f = lib.function(u, "f", 1, &here()).unwrap();
    let e = lib.finish().unwrap_err().to_string();
    let want = format!("{}:3:12", dir.join("undef.cal").display());
    assert!(e.starts_with(&want) && e.contains("nothere"), "{e}");
    // Expression text: the record's line, the column in the text.
    let mut lib = library();
    let g = lib.global();
    let e = lib.expr(g, ".5+.2*(Px", &here()).unwrap_err().to_string();
    assert!(e.starts_with("scene.rad:7:10"), "{e}");
    let e = lib.expr(g, "1 + 2 #", &here()).unwrap_err().to_string();
    assert!(e.starts_with("scene.rad:7:7"), "{e}");
    let e = lib.expr(g, "{ open", &here()).unwrap_err().to_string();
    assert!(e.starts_with("scene.rad:7:1"), "{e}");
    lib.function(g, "nosuchfunc", 3, &here()).unwrap();
    let e = lib.finish().unwrap_err().to_string();
    assert!(
        e.starts_with("scene.rad:7") && e.contains("nosuchfunc"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn cal_unreachable_undefined_is_fine() {
    let mut lib = library();
    let g = lib.global();
    lib.define_text(g, "broken = nothing + 1; fine = 2;", Path::new("t.cal"), 0)
        .unwrap();
    let e = lib.expr(g, "fine", &here()).unwrap();
    let p = lib.finish().unwrap();
    assert_eq!(p.eval(e, &Inputs::new(&[])).unwrap(), 2.0);
}

#[test]
fn cal_recursion_depth_error() {
    let mut lib = library();
    let g = lib.global();
    lib.define_text(
        g,
        "up(x) = up(x+1) + Px;\nloop = loop + Px;",
        Path::new("rec.cal"),
        0,
    )
    .unwrap();
    let e1 = lib.expr(g, "up(1)", &here()).unwrap();
    let e2 = lib.expr(g, "loop", &here()).unwrap();
    let p = lib.finish().unwrap();
    let inp = Inputs::new(&[]);
    let m = p.eval(e1, &inp).unwrap_err().to_string();
    assert!(
        m.contains("rec.cal:1:1") && m.contains("`up`") && m.contains("recursion"),
        "{m}"
    );
    let m = p.eval(e2, &inp).unwrap_err().to_string();
    assert!(m.contains("rec.cal:2:1") && m.contains("`loop`"), "{m}");
    // Exponential but shallow recursion is bounded too.
    let r = try_eval(
        "fib(n) = if(n-1.5, fib(n-1) + fib(n-2), 1) + Px*0;",
        "fib(60)",
        [0.0; N_INPUTS],
        &[],
    );
    assert!(r.is_err());
    assert_eq!(
        eval_with(
            "fib(n) = if(n-1.5, fib(n-1) + fib(n-2), 1);",
            "fib(20)",
            [0.0; N_INPUTS],
            &[]
        ),
        10946.0
    );
}

#[test]
fn cal_hostile_input_is_an_error() {
    let mut lib = library();
    let g = lib.global();
    for text in [
        "(".repeat(100_000),
        format!("{}1", "-(".repeat(50_000)),
        "1+".repeat(100_000) + "1",
        "2^".repeat(100_000) + "2",
        "f(".repeat(100_000),
        "{".repeat(100_000),
        "1e99999999999".to_string(),
        "\u{0}\u{ff}é".to_string(),
        "$99999999999999999999999".to_string(),
    ] {
        let _ = lib.expr(g, &text, &here());
        let _ = lib.define_text(g, &text, Path::new("x.cal"), 0);
    }
    assert_eq!(ev("1e99999"), f64::INFINITY);
}

#[test]
fn cal_rayinit_definitions() {
    let mut v = [0.0; N_INPUTS];
    let args = [0.5, 2.0, 3.0];
    let z = [0.0; N_INPUTS];
    assert_eq!(eval_with("", "A1", z, &args), 0.5);
    assert_eq!(eval_with("", "bound(0, 2, 1)", z, &[]), 1.0);
    assert_eq!(eval_with("", "bound(0, -2, 1)", z, &[]), 0.0);
    assert_eq!(eval_with("", "bound(0, .3, 1)", z, &[]), 0.3);
    assert_eq!(eval_with("", "noneg(-2)", z, &[]), 0.0);
    assert_eq!(eval_with("", "noneg(2)", z, &[]), 2.0);
    assert!(close(
        eval_with("", "grey(.2, .4, .6)", z, &[]),
        0.265074126 * 0.2 + 0.670114631 * 0.4 + 0.064811243 * 0.6
    ));
    // rayinit's hermite (a user definition, which hides the built-in).
    assert_eq!(eval_with("", "hermite(1, 2, 3, 4, .5)", z, &[]), 1.375);
    assert_eq!(eval_with("", "hermite(1, 2, 3, 4, 0)", z, &[]), 1.0);
    assert_eq!(eval_with("", "hermite(1, 2, 3, 4, 1)", z, &[]), 2.0);
    assert_eq!(eval_with("", "mod(7, 3)", z, &[]), 1.0);
    assert_eq!(eval_with("", "tri(5, 2)", z, &[]), 1.0);
    assert_eq!(eval_with("", "abs(-3) + sgn(-2) + sq(3)", z, &[]), 11.0);
    assert_eq!(
        eval_with("", "and(1, -1) + or(-1, 1) + not(1) + xor(1, 1)", z, &[]),
        -2.0
    );
    assert!(close(
        eval_with("", "DEGREE*180", z, &[]),
        std::f64::consts::PI
    ));
    // U, V on a surface with normal (0,0,1) at P = (1,2,3): crosslen = 0,
    // so U = Px, V = Py.
    v[chan::NZ] = 1.0;
    v[chan::PX] = 1.0;
    v[chan::PY] = 2.0;
    v[chan::PZ] = 3.0;
    assert_eq!(eval_with("", "U", v, &[]), 1.0);
    assert_eq!(eval_with("", "V", v, &[]), 2.0);
    // Normal (1,0,0): crosslen = 1, U = Py*1 - Px*0 = 2, V = Pz - 0 = 3.
    v[chan::NZ] = 0.0;
    v[chan::NX] = 1.0;
    assert_eq!(eval_with("", "U", v, &[]), 2.0);
    assert_eq!(eval_with("", "V", v, &[]), 3.0);
    // Idx: perturbed normal (0,0,1), up vector (0,1,0) as the last three
    // real arguments: Vu = (arg(AC-1)*NzP - arg(AC)*NyP, arg(AC)*NxP -
    // arg(AC-2)*NzP, arg(AC-2)*NyP - arg(AC-1)*NxP) = (1, 0, 0), so
    // Vn = (1,0,0), Un = NP x Vn = (0,1,0); with D = (0.6, 0.8, 0),
    // Idx = -D.Un = -0.8, Idy = -D.Vn = -0.6, Idz = RdotP.
    let mut v = [0.0; N_INPUTS];
    v[chan::NZP] = 1.0;
    v[chan::DX] = 0.6;
    v[chan::DY] = 0.8;
    v[chan::RDOTP] = 0.25;
    let up = [9.0, 0.0, 1.0, 0.0];
    assert!(close(eval_with("", "Idx", v, &up), -0.8));
    assert!(close(eval_with("", "Idy", v, &up), -0.6));
    assert_eq!(eval_with("", "Idz", v, &up), 0.25);
}

/// Every .cal file of the shared Radiance test scenes loads, and every
/// definition in it compiles (with our prelude, and with the real
/// rayinit.cal when it is there).
#[test]
fn cal_shared_files_load() {
    let Some(dir) = crate::testdata::radiance_tests() else {
        eprintln!("shared Radiance scenes absent; skipped");
        return;
    };
    let libdir = dir.join("lib");
    let mut files: Vec<PathBuf> = Vec::new();
    for d in [&dir, &libdir] {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "cal") {
                files.push(p);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 10, "{files:?}");
    for search in [Vec::new(), vec![libdir.clone()]] {
        let mut lib = Library::new(search).unwrap();
        let mut wanted = Vec::new();
        for f in &files {
            let ctx = lib
                .load_file(f.to_str().unwrap(), &dir, &here())
                .unwrap_or_else(|e| panic!("{e}"));
            let names: Vec<(String, usize)> = lib.contexts[ctx.0 as usize]
                .defs
                .iter()
                .map(|(n, &d)| (n.clone(), lib.defs[d].nparams))
                .collect();
            for (name, arity) in names {
                wanted.push((
                    f.clone(),
                    name.clone(),
                    lib.function(ctx, &name, arity, &here()),
                ));
            }
        }
        let p = lib.finish().unwrap_or_else(|e| panic!("{e}"));
        // Evaluate each once with plausible inputs.
        let mut v = [0.0; N_INPUTS];
        v[chan::DX] = 0.36;
        v[chan::DY] = 0.48;
        v[chan::DZ] = -0.8;
        v[chan::NZ] = 1.0;
        v[chan::NZP] = 1.0;
        v[chan::PX] = 0.3;
        v[chan::PY] = 0.7;
        v[chan::RDOT] = 0.8;
        v[chan::RDOTP] = 0.8;
        v[chan::TS] = 2.0;
        let args = [1.5, 0.1, 0.2, 0.3, 0.5, 0.6, 0.0, 1.0, 0.0];
        for (f, name, id) in wanted {
            let r = p.call(
                id.unwrap(),
                &[0.1, 0.2, 0.3, 0.4, 0.5],
                &Inputs {
                    values: v,
                    args: &args,
                },
            );
            if let Err(e) = r {
                let e = e.to_string();
                // Called here with numbers where rayinit's dot, cross take
                // functions, or reading more real arguments than given.
                assert!(
                    e.contains("missing real argument") || e.contains("not a function"),
                    "{}: {name}: {e}",
                    f.display()
                );
            }
        }
    }
}

#[test]
fn cal_real_rayinit_matches_prelude() {
    let Some(dir) = crate::testdata::radiance_tests() else {
        return;
    };
    let exprs = [
        "A1",
        "bound(0,A2,1)",
        "noneg(-A1)",
        "grey(A1,A2,A3)",
        "hermite(1,2,3,4,A1)",
        "U",
        "V",
        "Idx",
        "Idy",
        "Idz",
        "turbulence(Px,Py,Pz,.1)",
        "nrand(Px)",
        "dot(D,N)",
        "cross(2,P,N)",
        "bezier(1,2,3,4,A1)",
        "bspline(1,2,3,4,A1)",
        "fade(1,2,A2)",
    ];
    let mut v = [0.0; N_INPUTS];
    for (i, x) in v.iter_mut().enumerate() {
        *x = ((i * 7 % 11) as f64 - 5.0) / 7.0;
    }
    let args = [0.3, 0.6, 0.9, 0.2, 1.0, 0.5];
    let run = |search: Vec<PathBuf>| {
        let mut lib = Library::new(search).unwrap();
        let g = lib.global();
        let ids: Vec<ExprId> = exprs
            .iter()
            .map(|e| lib.expr(g, e, &here()).unwrap())
            .collect();
        let p = lib.finish().unwrap();
        ids.iter()
            .map(|&e| {
                p.eval(
                    e,
                    &Inputs {
                        values: v,
                        args: &args,
                    },
                )
                .unwrap()
            })
            .collect::<Vec<f64>>()
    };
    let ours = run(Vec::new());
    let theirs = run(vec![dir.join("lib")]);
    for ((e, a), b) in exprs.iter().zip(&ours).zip(&theirs) {
        assert_eq!(a.to_bits(), b.to_bits(), "{e}: {a} vs {b}");
    }
}

#[test]
fn cal_function_may_name_a_variable() {
    let mut lib = library();
    let g = lib.global();
    let f = lib.function(g, "U", 3, &here()).unwrap();
    let n = lib.function(g, "noop", 1, &here()).unwrap();
    let b = lib.function(g, "sqrt", 1, &here()).unwrap();
    let p = lib.finish().unwrap();
    let mut inp = Inputs::new(&[]);
    inp.values[chan::PX] = 4.0;
    assert_eq!(p.call(f, &[1.0, 2.0, 3.0], &inp).unwrap(), 4.0);
    assert_eq!(p.call(n, &[5.0], &inp).unwrap(), 5.0);
    assert_eq!(p.call(b, &[9.0], &inp).unwrap(), 3.0);
    // Too few arguments is a run-time error.
    assert!(p.call(n, &[], &inp).is_err());
}

#[test]
fn cal_constants_fold() {
    let mut lib = library();
    let g = lib.global();
    let e = lib
        .expr(g, "PI*2 + sqrt(4) + hermite(1,2,3,4,.5)", &here())
        .unwrap();
    let p = lib.finish().unwrap();
    assert_eq!(
        p.eval(e, &Inputs::new(&[])).unwrap(),
        std::f64::consts::PI * 2.0 + 2.0 + 1.375
    );
    assert_eq!(Program::empty().node_count(), 0);
}

#[test]
fn cal_program_is_shareable() {
    let mut lib = library();
    let g = lib.global();
    let e = lib
        .expr(g, "1 - .35*(1+fnoise3(3*Px,3*Py,3*Pz))", &here())
        .unwrap();
    let p = std::sync::Arc::new(lib.finish().unwrap());
    let hs: Vec<_> = (0..2)
        .map(|k| {
            let p = p.clone();
            std::thread::spawn(move || {
                let mut inp = Inputs::new(&[]);
                inp.values[chan::PX] = k as f64 * 0.1;
                p.eval(e, &inp).unwrap()
            })
        })
        .collect();
    for h in hs {
        assert!(h.join().unwrap().is_finite());
    }
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        #[test]
        fn cal_random_text_never_panics(s in "\\PC{0,80}") {
            let mut lib = library();
            let g = lib.global();
            let _ = lib.expr(g, &s, &here());
            let _ = lib.define_text(g, &s, Path::new("p.cal"), 0);
            if let Ok(p) = lib.finish() {
                let _ = p;
            }
        }

        #[test]
        fn cal_random_expressions_evaluate(
            s in "[-+*/^(),.0-9a-zA-Z$ ]{0,60}",
            px in -10.0f64..10.0,
        ) {
            let mut lib = library();
            let g = lib.global();
            if let Ok(e) = lib.expr(g, &s, &here()) {
                if let Ok(p) = lib.finish() {
                    let mut inp = Inputs::new(&[1.0, 2.0]);
                    inp.values[chan::PX] = px;
                    let _ = p.eval(e, &inp);
                }
            }
        }
    }
}

#[test]
fn cal_define_from_text() {
    let mut lib = library();
    let g = lib.global();
    lib.define(g, "k : 3; f(t) = k*t + 1;", &here()).unwrap();
    // A later definition replaces an earlier one.
    lib.define(g, "k : 4", &here()).unwrap();
    let f = lib.function(g, "f", 1, &here()).unwrap();
    let p = lib.finish().unwrap();
    assert_eq!(p.call(f, &[2.0], &Inputs::new(&[])).unwrap(), 9.0);
    // Errors name the text's place (line of `loc`, column in the text),
    // and nothing of a text that fails to parse is added.
    let mut lib = library();
    let g = lib.global();
    let e = lib
        .define(g, "bad = 1;\n q(t) = t +* 2;", &here())
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.rad:8"), "{e}");
    assert!(!lib.is_defined(g, "bad"));
}
