//! Fuzz smoke run on stable Rust: seeded, deterministic mutations of the
//! project's own example scenes and small hand-written seeds, for each kind
//! of input the program reads (Radiance scenes, OBJ with MTL, view files
//! and view options, `.cal` files, command lines). Every input is parsed in
//! process (scenes that load are also rendered at 4x4 pixels, views that
//! validate give rays, `.cal` functions are called) under `catch_unwind`,
//! while a watchdog thread watches the time each one takes; the run fails
//! on any panic or any input taking longer than the limit, printing the
//! input.
//!
//! `FUZZ_CASES` sets the number of inputs per kind (default 300, a few
//! seconds in the test build); `FUZZ_SEED` the seed (default 22);
//! `FUZZ_TIMEOUT_S` the per-input limit (default 10 s); `FUZZ_SHOW=1`
//! prints the errors of refused scenes and command lines. The documented
//! run (see the book's "Scenes" chapter) is
//!
//! ```text
//! FUZZ_CASES=10000 cargo test --release -p hybrid-rt --test fuzz_smoke -- --nocapture
//! ```
//!
//! The cargo-fuzz targets in `raytracer/fuzz/` feed the same entry points
//! with libFuzzer on nightly.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use proptest::prelude::Rng;
use proptest::test_runner::{RngAlgorithm, TestRng};

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn cases() -> usize {
    env_or("FUZZ_CASES", 300)
}

fn rng(kind: &str) -> TestRng {
    let seed: u64 = env_or("FUZZ_SEED", 22);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    for (k, b) in kind.bytes().enumerate() {
        bytes[8 + k % 24] ^= b;
    }
    TestRng::from_seed(RngAlgorithm::ChaCha, &bytes)
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes")
}

/// The input being run and since when, for the watchdog.
type Current = Arc<Mutex<Option<(Instant, String)>>>;

/// Runs inputs under `catch_unwind` with a watchdog thread that ends the
/// process (failing the test) when one input runs past the limit.
struct Harness {
    kind: &'static str,
    current: Current,
    panics: Vec<(String, String)>,
    errors: usize,
    inputs: usize,
    start: Instant,
}

impl Harness {
    fn new(kind: &'static str) -> Harness {
        let limit = Duration::from_secs_f64(env_or("FUZZ_TIMEOUT_S", 10.0));
        let current: Current = Arc::new(Mutex::new(None));
        let watched = Arc::clone(&current);
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(50));
            // The harness is gone: nothing more to watch.
            if Arc::strong_count(&watched) == 1 {
                return;
            }
            let guard = watched.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((since, input)) = guard.as_ref() {
                if since.elapsed() > limit {
                    eprintln!(
                        "fuzz smoke: {kind}: an input ran longer than {limit:?} (a hang):\n{input:?}"
                    );
                    std::process::exit(3);
                }
            }
        });
        Harness {
            kind,
            current,
            panics: Vec::new(),
            errors: 0,
            inputs: 0,
            start: Instant::now(),
        }
    }

    /// Runs one input; `f` returns whether the input was refused (an `Err`).
    fn run(&mut self, shown: String, f: impl FnOnce() -> bool) {
        *self.current.lock().unwrap_or_else(|e| e.into_inner()) =
            Some((Instant::now(), shown.clone()));
        let r = catch_unwind(AssertUnwindSafe(f));
        *self.current.lock().unwrap_or_else(|e| e.into_inner()) = None;
        self.inputs += 1;
        match r {
            Ok(true) => self.errors += 1,
            Ok(false) => {}
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                self.panics.push((shown, msg));
            }
        }
    }

    fn finish(self) {
        eprintln!(
            "fuzz smoke: {}: {} inputs ({} refused with an error), {} panics, 0 hangs, {:.1} s",
            self.kind,
            self.inputs,
            self.errors,
            self.panics.len(),
            self.start.elapsed().as_secs_f64()
        );
        for (input, msg) in self.panics.iter().take(5) {
            eprintln!("panic: {msg}\ninput: {input:?}\n");
        }
        assert!(self.panics.is_empty(), "{} panics", self.panics.len());
    }
}

/// Numbers and words that reach edge cases.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "3",
    "4",
    "5",
    "8",
    "9",
    "12",
    ".5",
    "1e308",
    "-1e308",
    "1e-320",
    "1e30",
    "nan",
    "inf",
    "-inf",
    "99999999999999999999",
    "180",
    "360",
    "1e10",
    "0x10",
];

fn pick<'a>(rng: &mut TestRng, from: &[&'a str]) -> &'a str {
    from[(rng.next_u64() % from.len() as u64) as usize]
}

fn below(rng: &mut TestRng, n: usize) -> usize {
    (rng.next_u64() % n.max(1) as u64) as usize
}

/// `base` with 1 to 8 random edits: byte replacements, insertions and
/// deletions, words from `dict` or [`NUMBERS`] inserted or replacing a
/// word, lines deleted, duplicated or swapped, and cuts.
fn mutate(rng: &mut TestRng, base: &str, dict: &[&str]) -> String {
    let mut b = base.as_bytes().to_vec();
    // Mostly one or two edits, so that many inputs get past the lexer.
    let edits = match below(rng, 8) {
        0..=3 => 1,
        4 | 5 => 2,
        _ => 3 + below(rng, 6),
    };
    for _ in 0..edits {
        let at = below(rng, b.len() + 1);
        let op = match below(rng, 20) {
            0..=5 => 5,
            6 | 7 => 3,
            n => n % 10,
        };
        match op {
            0 if at < b.len() => b[at] = rng.next_u64() as u8,
            1 => b.insert(at, rng.next_u64() as u8),
            2 if at < b.len() => {
                let end = (at + 1 + below(rng, 16)).min(b.len());
                b.drain(at..end);
            }
            3 | 4 => {
                let w = if below(rng, 2) == 0 {
                    pick(rng, dict)
                } else {
                    pick(rng, NUMBERS)
                };
                let word = format!(" {w} ");
                b.splice(at..at, word.bytes());
            }
            5 => {
                // Replace the word at `at` with a number.
                let start = b[..at]
                    .iter()
                    .rposition(|c| c.is_ascii_whitespace())
                    .map_or(0, |k| k + 1);
                let end = b[at..]
                    .iter()
                    .position(|c| c.is_ascii_whitespace())
                    .map_or(b.len(), |k| at + k);
                let w = pick(rng, NUMBERS);
                b.splice(start..end, w.bytes());
            }
            6 | 7 => {
                let text = String::from_utf8_lossy(&b).into_owned();
                let mut lines: Vec<&str> = text.lines().collect();
                if !lines.is_empty() {
                    let i = below(rng, lines.len());
                    let j = below(rng, lines.len());
                    match below(rng, 3) {
                        0 => {
                            lines.remove(i);
                        }
                        1 => lines.insert(j, lines[i]),
                        _ => lines.swap(i, j),
                    }
                }
                b = lines.join("\n").into_bytes();
            }
            8 => b.truncate(at),
            _ => {}
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

/// A seed cut to its first `lines` lines (the large example scenes).
fn head(text: &str, lines: usize) -> String {
    text.lines().take(lines).collect::<Vec<_>>().join("\n")
}

const RAD_WORDS: &[&str] = &[
    "void",
    "plastic",
    "metal",
    "glass",
    "dielectric",
    "interface",
    "light",
    "glow",
    "illum",
    "mirror",
    "trans",
    "spotlight",
    "polygon",
    "sphere",
    "bubble",
    "cone",
    "cup",
    "cylinder",
    "tube",
    "ring",
    "source",
    "instance",
    "mesh",
    "alias",
    "inherit",
    "brightfunc",
    "colorfunc",
    "texfunc",
    "mixfunc",
    "brightdata",
    "colorpict",
    "brighttext",
    "antimatter",
    "mist",
    "prism1",
    "prism2",
    ">",
    "if(Dz,Dx,-Dx)",
    "!xform",
    "!genbox",
    "!gensurf",
    "!genrev",
    "!genworm",
    "!genprism",
    "-t",
    "-s",
    "-rz",
    "-a",
    "-i",
    "-e",
    "-f",
    "|",
    "\n",
    "#",
    "/dev/zero",
    "/dev/null",
    ".",
    "/",
    "cornell.rad",
    "chair.rad",
    "x.cal",
    "'",
    "\"",
    "`",
];

fn rad_seeds() -> Vec<String> {
    let mut seeds = Vec::new();
    for name in ["caster.rad", "chair.rad", "cornell.rad", "table.rad"] {
        seeds.push(std::fs::read_to_string(examples().join(name)).unwrap());
    }
    for name in ["conference.rad", "studio.rad"] {
        seeds.push(head(
            &std::fs::read_to_string(examples().join(name)).unwrap(),
            120,
        ));
    }
    seeds.push(
        "void plastic m 0 0 5 .5 .5 .5 0 0\n\
         void dielectric d 0 0 5 .9 .9 .9 1.5 0\n\
         void brightfunc b 2 'A1*Dx+1' . 0 1 2\n\
         b glass g 0 0 4 .9 .9 .9 1.5\n\
         m sphere s 0 0 4 0 0 0 1\n\
         d cone c 0 0 8 0 0 0 0 0 1 1 .5\n\
         g ring r 0 0 8 0 0 0 0 0 1 0 1\n\
         !xform -rz 30 -t 1 0 0 -a 3 -t 0 1 0 chair.rad\n\
         !genbox m box 1 2 3 -r .1\n\
         m instance i 1 cornell.rad 0 0\n"
            .into(),
    );
    // Virtual sources: a lamp and a sun relayed by a mirror and a
    // bending prism, a mist naming a relay and the sun.
    seeds.push(
        "void light l 0 0 3 10 10 10\n\
         l polygon lamp 0 0 12 .9 -.1 3  .9 .1 3  1.1 .1 3  1.1 -.1 3\n\
         l source sun 0 0 4 .3 0 1 .5\n\
         void mirror mi 0 0 3 .8 .8 .8\n\
         mi polygon wall 0 0 12 3 -5 .01  3 -5 5  3 5 5  3 5 .01\n\
         void prism1 pr 5 .5 if(Dz,1-Px,Dx) if(Dz,-Py,Dy) if(Dz,4-Pz,Dz) . 0 0\n\
         pr polygon pane 0 0 12 -5 -5 2  -5 5 2  5 5 2  5 -5 2\n\
         void prism2 pp 9 .4 Dx Dy Dz .25 -Dx Dy Dz . 0 0\n\
         pp ring disk 0 0 8 0 0 1 0 0 1 0 1\n\
         void mist fog 3 wall>lamp sun pane>wall>lamp 0 6 .1 .1 .1 .8 .8 .8\n\
         fog sphere cloud 0 0 4 0 0 1 .8\n"
            .into(),
    );
    seeds
}

/// Renders `scene` at 4x4 pixels from two views: errors are fine, panics
/// are not.
fn render_tiny(scene: &hybrid_rt::scene::Scene) {
    use hybrid_rt::render::{RenderOptions, Renderer};
    use hybrid_rt::scene::View;
    let Ok(r) = Renderer::new(scene, RenderOptions::default()) else {
        return;
    };
    for opts in [
        "-vp 0 -5 1 -vd 0 1 0",
        "-vth -vp 0.1 0.2 0.3 -vd 0 0 1 -vu 0 1 0",
    ] {
        if let Ok(v) = View::from_options(opts) {
            let _ = r.render(&v, 4, 4);
        }
    }
}

#[test]
fn radiance_scenes() {
    let seeds = rad_seeds();
    // Named as if beside the examples: includes of the examples resolve.
    let name = examples().join("fuzz.rad");
    let mut rng = rng("rad");
    let mut h = Harness::new("rad");
    for k in 0..cases() {
        let text = mutate(&mut rng, &seeds[k % seeds.len()], RAD_WORDS);
        h.run(text.clone(), || {
            match hybrid_rt::scene::load_rad_str(&text, &name) {
                Ok(scene) => {
                    // A scene that loads must also render (4x4 pixels).
                    render_tiny(&scene);
                    false
                }
                Err(e) => {
                    if std::env::var_os("FUZZ_SHOW").is_some() {
                        eprintln!("{e}");
                    }
                    true
                }
            }
        });
    }
    h.finish();
}

const OBJ_WORDS: &[&str] = &[
    "v", "vt", "vn", "f", "l", "p", "o", "g", "s", "usemtl", "mtllib", "newmtl", "Ka", "Kd", "Ks",
    "Ke", "Tf", "Ns", "Ni", "d", "Tr", "illum", "map_Kd", "spectral", "xyz", "/", "//", "-1/-1/-1",
    "1//1", "1/1", "\n", "\\\n", "#", "a", "b", "-halo",
];

const OBJ_SEED: &str = "# a cube\nmtllib m.mtl\no cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1 1\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\nvn 0 0 -1\n\
usemtl a\nf 1/1/2 4/2/2 3/3/2 2/1/2\nf 5/1/1 6/2/1 7/3/1 8/1/1\ng side\nusemtl b\n\
f 1 2 6 5\nf -4 -3 -2 -1\ns off\nf 2//1 3//1 7//1 6//1\nusemtl c\nf 4 8 7 3\nl 1 2\np 3\n";

const MTL_SEED: &str = "newmtl a\nKa 0 0 0\nKd 0.8 0.2 0.2\nKs 0.5 0.5 0.5\nNs 50\nillum 2\n\
newmtl b\nKd 0.5\nd 0.5\nNi 1.5\nillum 4\nnewmtl c\nKe 10 10 10\nmap_Kd tex.png\n\
newmtl glass\nTf 1 1 1\nNi 1.52\nillum 7\nTr 0.1\n";

#[test]
fn obj_and_mtl() {
    let mut rng = rng("obj");
    let mut h = Harness::new("OBJ/MTL");
    for k in 0..cases() {
        // Mutate the OBJ, the MTL, or both.
        let obj = if k % 3 != 1 {
            mutate(&mut rng, OBJ_SEED, OBJ_WORDS)
        } else {
            OBJ_SEED.to_string()
        };
        let mtl = if k % 3 != 0 {
            mutate(&mut rng, MTL_SEED, OBJ_WORDS)
        } else {
            MTL_SEED.to_string()
        };
        h.run(
            format!("{obj}\n--- MTL ---\n{mtl}"),
            || match hybrid_rt::scene::load_obj_str(
                &obj,
                Some(&mtl),
                "/nonexistent-fuzz-dir/fuzz.obj",
            ) {
                Ok(scene) => {
                    render_tiny(&scene);
                    false
                }
                Err(_) => true,
            },
        );
    }
    h.finish();
}

const VIEW_WORDS: &[&str] = &[
    "-vtv",
    "-vtl",
    "-vta",
    "-vth",
    "-vtc",
    "-vts",
    "-vtx",
    "-vt",
    "-vp",
    "-vd",
    "-vu",
    "-vh",
    "-vv",
    "-vs",
    "-vl",
    "-vo",
    "-va",
    "-vf",
    "rview",
    "rpict",
    "VIEW=",
    "\n",
    "#",
    "/dev/zero",
    "cornell.vf",
    "fuzz.vf",
];

#[test]
fn view_files_and_options() {
    let mut seeds = Vec::new();
    for name in [
        "cornell.vf",
        "studio.vf",
        "conference.vf",
        "conference-detail.vf",
    ] {
        seeds.push(std::fs::read_to_string(examples().join(name)).unwrap());
    }
    seeds.push("rview -vth -vp 1 2 3 -vd 0 0 -1 -vu 0 1 0 -vh 180 -vv 180 -vo 1 -va 10\n".into());
    seeds.push("-vtl -vh 10 -vv 5\nrpict -vs .2 -vl -.1\nVIEW= -vtc -vh 360 -vv 90\n".into());
    seeds.push("-vts -vh 270 -vv 270 -vf cornell.vf\n-vta -vh 360 -vv 360\n".into());
    let name = examples().join("fuzz.vf");
    let mut rng = rng("view");
    let mut h = Harness::new("view");
    for k in 0..cases() {
        let text = mutate(&mut rng, &seeds[k % seeds.len()], VIEW_WORDS);
        h.run(text.clone(), || {
            use hybrid_rt::scene::View;
            // As a file and as command-line options.
            let r = if k % 2 == 0 {
                View::from_file_text(&text, &name)
            } else {
                View::from_options(&text)
            };
            match r {
                Ok(v) => {
                    for (x, y) in [(0.0, 0.0), (0.5, 0.5), (1.0, 0.3), (0.999, 1.0)] {
                        let _ = v.ray(x, y);
                    }
                    let _ = v.fit_aspect(512, 512);
                    let _ = View::from_options(&v.to_options());
                    false
                }
                Err(_) => true,
            }
        });
    }
    h.finish();
}

const CAL_WORDS: &[&str] = &[
    "a", "b", "f", "g", "x", "=", ":", ";", "(", ")", ",", "+", "-", "*", "/", "^", "{", "}", "$1",
    "$27", "Px", "Dx", "Nz", "A1", "arg(0)", "arg(99)", "if", "select", "noise3", "fnoise3",
    "rand", "sqrt", "log", "exp", "f(x)", "g(a,b)", "f(f(1))", "\n", "`", "c`P.", "max", "min",
    "floor", "ceil", "fractal3", "hermite", "bezier", "bspline", "and", "or",
];

const CAL_SEEDS: &[&str] = &[
    "{ a test file }\nf(x) = x * x + 1;\ng(a, b) = if(a - b, a, b);\nk : 3;\n\
     h = f(Px) + g(Dx, Dy) * k;\nwave = sin(2*PI*Px) * .5 + .5;\n",
    "sq(x) : x*x;\nfib(n) = if(n-1.5, fib(n-1)+fib(n-2), 1);\nv = fib(10);\n\
     s = select(2, 1, 2, 3);\nr = rand(Px*10);\n",
    "nx = Nx; ny = Ny; nz = Nz;\ndot(v1,v2) : v1(1)*v2(1) + v1(2)*v2(2) + v1(3)*v2(3);\n\
     len = sqrt(dot(Dx, Dx));\nn3 = noise3(Px, Py, Pz) + fnoise3(Px, Py, Pz);\n\
     c`P. = 2;\nt = arg(0) + arg(1);\n",
];

/// The names a `.cal` text defines, roughly (`name =`, `name :`, `name(`).
fn defined_names(text: &str) -> Vec<String> {
    let mut names = Vec::new();
    for stmt in text.split(';') {
        let lhs = stmt.split(['=', ':']).next().unwrap_or("");
        let name = lhs.split('(').next().unwrap_or("").trim();
        let name = name.rsplit(['}', '\n']).next().unwrap_or("").trim();
        if !name.is_empty() && name.len() < 40 && !names.iter().any(|n| n == name) {
            names.push(name.to_string());
        }
    }
    names
}

#[test]
fn cal_files() {
    use hybrid_rt::cal::{Inputs, Library, N_INPUTS};
    use hybrid_rt::SourceLoc;
    let mut rng = rng("cal");
    let mut h = Harness::new("cal");
    for k in 0..cases() {
        let text = mutate(&mut rng, CAL_SEEDS[k % CAL_SEEDS.len()], CAL_WORDS);
        let expr = mutate(&mut rng, "f(Px) + g(1, 2) * k - h", CAL_WORDS);
        h.run(format!("{text}\n--- expression ---\n{expr}"), || {
            let Ok(mut lib) = Library::new(Vec::new()) else {
                return true;
            };
            let ctx = lib.global();
            let loc = SourceLoc::new("fuzz.cal", 1);
            if lib.define(ctx, &text, &loc).is_err() {
                return true;
            }
            let mut funcs = Vec::new();
            for name in defined_names(&text) {
                if let Some(n) = lib.arity(ctx, &name) {
                    if let Ok(f) = lib.function(ctx, &name, n, &loc) {
                        funcs.push((f, n));
                    }
                }
            }
            let e = lib.expr(ctx, &expr, &loc).ok();
            let Ok(program) = lib.finish() else {
                return true;
            };
            let mut inputs = Inputs::new(&[0.25, -0.5, 3.0]);
            for (i, v) in inputs.values.iter_mut().enumerate().take(N_INPUTS) {
                *v = (i as f64 * 0.37).sin();
            }
            let mut refused = false;
            for (f, n) in funcs {
                let args: Vec<f64> = (0..n).map(|i| 0.5 + i as f64).collect();
                refused |= program.call(f, &args, &inputs).is_err();
            }
            if let Some(e) = e {
                refused |= program.eval(e, &inputs).is_err();
            }
            refused
        });
    }
    h.finish();
}

const CLI_WORDS: &[&str] = &[
    "render",
    "bench",
    "sweep",
    "experiment",
    "-o",
    "--output",
    "x.png",
    "x.hdr",
    "x.pic",
    "x.txt",
    "-",
    "-vf",
    "--view-file",
    "--view",
    "-vtl",
    "-vtv",
    "-vth",
    "-vh",
    "-vv",
    "-vp",
    "-vd",
    "-vu",
    "-x",
    "-y",
    "--width",
    "--height",
    "-ab",
    "-ad",
    "-as",
    "-aa",
    "-ar",
    "-av",
    "-ps",
    "-pt",
    "-pj",
    "-pn",
    "-dj",
    "-ds",
    "-dt",
    "-dc",
    "-lr",
    "-lw",
    "-st",
    "-ss",
    "-me",
    "-ma",
    "-mg",
    "-ms",
    "-af",
    "-i",
    "-e",
    "-t",
    "--procs",
    "--tile",
    "--policy",
    "local",
    "load-aware",
    "replicated",
    "--seed",
    "--exposure",
    "+1",
    "--gamma",
    "--stats",
    "-q",
    "--quality",
    "high",
    "--help",
    "-h",
    "--version",
    "cornell",
    "studio",
];

fn cli_seeds() -> Vec<Vec<String>> {
    let ex = examples();
    let scene = ex.join("cornell.rad").display().to_string();
    let vf = ex.join("cornell.vf").display().to_string();
    let seeds: Vec<Vec<&str>> = vec![
        vec!["render", &scene, "-vf", &vf, "-o", "x.png"],
        vec![
            "render", &scene, "-vf", &vf, "-ab", "2", "-ad", "64", "-o", "x.hdr",
        ],
        vec![
            "render",
            &scene,
            "--view",
            "-vtv -vp 0 0 1 -vd 0 1 0",
            "--width",
            "64",
            "--height",
            "32",
            "-o",
            "x.png",
        ],
        vec![
            "render",
            &scene,
            "-vf",
            &vf,
            "--procs",
            "2",
            "--policy",
            "load-aware",
            "-o",
            "x.png",
        ],
        vec![
            "render", &scene, "-vth", "-vh", "180", "-vv", "180", "-ps", "4", "-o", "x.png",
        ],
        vec![
            "render",
            &scene,
            "-vf",
            &vf,
            "--exposure",
            "+1",
            "--gamma",
            "2.2",
            "-o",
            "x.png",
        ],
        vec!["bench", "cornell", "--procs", "2"],
        vec!["sweep", "cornell", "--out", "/nonexistent-fuzz-dir"],
    ];
    seeds
        .into_iter()
        .map(|s| s.into_iter().map(String::from).collect())
        .collect()
}

#[test]
fn command_lines() {
    let seeds = cli_seeds();
    let mut rng = rng("cli");
    let mut h = Harness::new("command line");
    for k in 0..cases() {
        let mut args = seeds[k % seeds.len()].clone();
        for _ in 0..1 + below(&mut rng, 4) {
            let at = below(&mut rng, args.len() + 1);
            let word = if below(&mut rng, 2) == 0 {
                pick(&mut rng, CLI_WORDS)
            } else {
                pick(&mut rng, NUMBERS)
            }
            .to_string();
            match below(&mut rng, 6) {
                0 => args.insert(at, word),
                1 => {
                    // An option with a number.
                    args.insert(at.min(args.len()), pick(&mut rng, NUMBERS).to_string());
                    args.insert(at.min(args.len()), pick(&mut rng, CLI_WORDS).to_string());
                }
                2 if at < args.len() => args[at] = word,
                3 if at < args.len() => {
                    args.remove(at);
                }
                _ if at < args.len() => args[at] = mutate(&mut rng, &args[at], CLI_WORDS),
                _ => {}
            }
        }
        let mut argv = vec!["hybrid-rt".to_string()];
        argv.extend(args);
        h.run(
            format!("{argv:?}"),
            || match hybrid_rt::cli::check_command_line(argv.clone()) {
                Ok(()) => false,
                Err(e) => {
                    if std::env::var_os("FUZZ_SHOW").is_some() {
                        eprintln!("{}", e.to_string().lines().next().unwrap_or(""));
                    }
                    true
                }
            },
        );
    }
    h.finish();
}
