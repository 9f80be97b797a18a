//! The `hybrid-rt` program: exit codes, messages, outputs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CORNELL: &str = include_str!("data/radiance-cornell.rad");
const CORNELL_VF: &str = include_str!("data/radiance-cornell.vf");

fn exe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_hybrid-rt"))
}

/// A fresh directory for one test's files.
fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn run(args: &[&str]) -> Output {
    exe().args(args).output().expect("run hybrid-rt")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn cornell_files(dir: &Path) -> (String, String) {
    let rad = write(dir, "cornell.rad", CORNELL);
    let vf = write(dir, "cornell.vf", CORNELL_VF);
    (
        rad.to_string_lossy().into_owned(),
        vf.to_string_lossy().into_owned(),
    )
}

#[test]
fn renders_png_hdr_and_stats() {
    let d = tmpdir("ok");
    let (rad, vf) = cornell_files(&d);
    let png = d.join("c.png");
    let hdr = d.join("c.hdr");
    let json = d.join("s.json");
    let o = run(&[
        "render",
        &rad,
        "--view-file",
        &vf,
        "--width",
        "48",
        "--height",
        "48",
        "-o",
        png.to_str().unwrap(),
        "--stats",
        json.to_str().unwrap(),
        "-ds",
        "0.3",
        "-dj",
        "0.5",
        "-lr",
        "6",
        "-lw",
        "0.005",
        "-av",
        "0.01",
        "0.01",
        "0.01",
        "-ps",
        "1",
        "--seed",
        "3",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&png).expect("valid PNG").to_rgb8();
    assert_eq!(img.dimensions(), (48, 48));
    // Red wall on the left, blue on the right.
    let (l, r) = (img.get_pixel(2, 24), img.get_pixel(45, 24));
    assert!(l[0] > l[2] && r[2] > r[0], "{l:?} {r:?}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(stats["rays"]["primary"], 48 * 48);
    assert_eq!(stats["options"]["ds"], 0.3);
    assert!(stats["effects"]["refraction"]["enabled"].as_bool().unwrap());
    assert!(stats["octree"]["leaf_nodes"].as_u64().unwrap() > 0);

    let o = run(&[
        "render",
        &rad,
        "-vf",
        &vf,
        "--width",
        "32",
        "--height",
        "16",
        "-o",
        hdr.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&hdr).unwrap();
    assert!(bytes.starts_with(b"#?RADIANCE\n"));
    let pic = hybrid_rt::image::hdr::read_hdr(&mut &bytes[..]).expect("valid HDR");
    // The view is square: the resolution shrinks to 16x16.
    assert_eq!((pic.film.width(), pic.film.height()), (16, 16));
    assert!(
        pic.header
            .iter()
            .any(|l| l.starts_with("VIEW= -vtv -vp 0.49 0 0")),
        "{:?}",
        pic.header
    );
    assert!(pic.header.iter().any(|l| l.starts_with("EXPOSURE=")));
    // Linear radiance: the light (radiance 100) appears at the top centre.
    assert!(pic.film.get(8, 0).x > 90.0, "{}", pic.film.get(8, 0));
}

#[test]
fn radiance_view_options_on_the_command_line() {
    let d = tmpdir("vopts");
    let (rad, _) = cornell_files(&d);
    let png = d.join("v.png");
    let o = run(&[
        "render",
        &rad,
        "-vtv",
        "-vp",
        "0.49",
        "0",
        "0",
        "-vd",
        "-1",
        "0",
        "0",
        "-vu",
        "0",
        "0",
        "1",
        "-vh",
        "60",
        "-vv",
        "60",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Each bad input: (args after "render", expected exit code, text the
/// message must contain).
#[test]
fn bad_inputs_exit_with_code_and_location() {
    let d = tmpdir("bad");
    let (rad, vf) = cornell_files(&d);
    let bad_scene = write(&d, "bad.rad", "void plastic p\n0\n0\n5 1 1 oops 0 0\n");
    let bad_view = write(&d, "bad.vf", "rview -vtv\n-vp 0 0 zero\n");
    let out = d.join("o.png").to_string_lossy().into_owned();
    let bs = bad_scene.to_string_lossy().into_owned();
    let bv = bad_view.to_string_lossy().into_owned();
    let missing = d.join("missing.rad").to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, i32, String)> = vec![
        (
            vec![&missing, "--view-file", &vf, "-o", &out],
            1,
            "missing.rad".into(),
        ),
        (
            vec![&bs, "--view-file", &vf, "-o", &out],
            1,
            format!("{bs}:4"),
        ),
        (
            vec![&rad, "--view-file", &bv, "-o", &out],
            1,
            format!("{bv}:2"),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-dj", "2"],
            2,
            "-dj".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-ds", "NaN"],
            2,
            "-ds".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-ab", "99"],
            2,
            "-ab 99".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-aa", "2"],
            2,
            "-aa".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-ad", "0", "-ab", "1"],
            2,
            "-ad 0".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-as", "x"],
            2,
            "-as".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-pn", "0"],
            2,
            "-pn".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-pt", "-0.1"],
            2,
            "-pt".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "--width", "0"],
            2,
            "resolution".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "--exposure", "0"],
            2,
            "exposure".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", "x.jpg"],
            2,
            "x.jpg".into(),
        ),
        (vec![&rad, "-o", &out], 2, "no view".into()),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "--width", "many"],
            2,
            "many".into(),
        ),
        (
            vec![&rad, "--view", "-vtv -vh 400", "-o", &out],
            1,
            "-vh".into(),
        ),
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "-av", "1", "1"],
            2,
            "".into(),
        ),
    ];
    for (args, code, text) in cases {
        let mut full = vec!["render"];
        full.extend(args.iter().copied());
        let o = run(&full);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{full:?}: {err}");
        assert!(
            err.contains(&text),
            "{full:?}: message {err:?} lacks {text:?}"
        );
        assert!(!err.contains("panicked"), "{full:?}: {err}");
        if code == 1 {
            assert!(err.starts_with("error: "), "{full:?}: {err}");
        }
    }
    assert!(!Path::new(&out).exists(), "no output after errors");
}

#[test]
fn view_option_value_starting_with_a_dash() {
    let d = tmpdir("vdash");
    let (rad, _) = cornell_files(&d);
    let png = d.join("d.png");
    let o = run(&[
        "render",
        &rad,
        "--view",
        "-vtv",
        "--view",
        "-vp 0.49 0 0 -vd -1 0 0",
        "--width",
        "4",
        "--height",
        "4",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["bench", "--scene", d.join("none.rad").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("none.rad"));
}

#[test]
fn help_and_unknown_command() {
    let o = run(&["--help"]);
    assert_eq!(o.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&o.stdout).contains("render"));
    let o = run(&["paint"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn parallel_render_writes_the_sequential_picture_and_a_report() {
    let d = tmpdir("parallel");
    let (rad, vf) = cornell_files(&d);
    let seq = d.join("seq.hdr");
    let par = d.join("par.hdr");
    let json = d.join("par.json");
    let base = [
        "render",
        &rad,
        "--view-file",
        &vf,
        "--width",
        "40",
        "--height",
        "40",
    ];
    let o = run(&[&base[..], &["-o", seq.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        &base[..],
        &[
            "--procs",
            "3",
            "--policy",
            "round-robin",
            "--cache",
            "10%",
            "--distribution",
            "octree",
            "--tile",
            "8",
            "--parallel-stats",
            json.to_str().unwrap(),
            "-o",
            par.to_str().unwrap(),
        ],
    ]
    .concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&seq).unwrap(), std::fs::read(&par).unwrap());
    let err = stderr(&o);
    assert!(err.contains("parallel render: 3 processors"), "{err}");
    assert!(err.contains("hit%"), "{err}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(stats["stats"]["procs"].as_array().unwrap().len(), 3);
    assert_eq!(stats["procs"].as_array().unwrap().len(), 3);
}

#[test]
fn bad_parallel_options_are_usage_errors() {
    let d = tmpdir("parallel-bad");
    let (rad, vf) = cornell_files(&d);
    let out = d.join("x.png");
    for (flag, value, says) in [
        ("--procs", "0", "--procs 0"),
        ("--policy", "fastest", "--policy"),
        ("--cache", "lots", "--cache"),
        ("--distribution", "diagonal", "--distribution"),
        ("--runtime", "quantum", "--runtime"),
        ("--tile", "0", "--tile 0"),
        ("--time-limit", "0", "--time-limit 0"),
    ] {
        let mut args = vec![
            "render",
            &rad,
            "--view-file",
            &vf,
            "--width",
            "8",
            "--height",
            "8",
        ];
        if flag != "--procs" {
            args.extend(["--procs", "2"]);
        }
        args.extend([flag, value, "-o", out.to_str().unwrap()]);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{flag} {value}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{flag} {value}: {}", stderr(&o));
        assert!(!out.exists());
    }
}

#[test]
fn experiments_run_on_a_small_scene_and_repeat_byte_for_byte() {
    let dir = tmpdir("experiments");
    let args = |out: &Path| -> Vec<String> {
        [
            "experiment",
            "all",
            "--scene",
            "cornell",
            "--width",
            "24",
            "--height",
            "24",
            "--max-procs",
            "4",
            "--detail-procs",
            "3",
            "--cache-procs",
            "2",
            "--cache-size",
            "12",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.to_string_lossy().into_owned()])
        .collect()
    };
    let (a, b) = (dir.join("a"), dir.join("b"));
    for out in [&a, &b] {
        let argv = args(out);
        let o = run(&argv.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{}", stderr(&o));
    }
    for name in hybrid_rt::experiment::NAMES {
        for ext in ["md", "json"] {
            let f = format!("{name}.{ext}");
            let x = std::fs::read(a.join(&f)).unwrap_or_else(|e| panic!("{f}: {e}"));
            let y = std::fs::read(b.join(&f)).unwrap();
            assert!(!x.is_empty(), "{f} is empty");
            assert_eq!(x, y, "{f} differs between two identical runs");
        }
    }
    for svg in [
        "speedup.svg",
        "efficiency-time.svg",
        "cache.svg",
        "breakdown.svg",
    ] {
        let x = std::fs::read_to_string(a.join(svg)).unwrap();
        assert!(x.starts_with("<svg"), "{svg}");
        assert_eq!(x, std::fs::read_to_string(b.join(svg)).unwrap());
    }
    let speedup = std::fs::read_to_string(a.join("speedup.md")).unwrap();
    assert!(speedup.contains("| 4 |"), "{speedup}");
    let cache = std::fs::read_to_string(a.join("cache.md")).unwrap();
    assert!(cache.contains("load-aware"), "{cache}");

    // Usage errors name the problem.
    let bad = run(&[
        "experiment",
        "fig99",
        "--scene",
        "cornell",
        "--out",
        &dir.to_string_lossy(),
    ]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("fig99"));
    let bad = run(&["experiment", "table1", "--network", "token-ring"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("parsytec-cc"));
}

#[test]
fn simulated_render_from_the_command_line() {
    let dir = tmpdir("sim-render");
    let (rad, vf) = cornell_files(&dir);
    let seq = dir.join("seq.hdr");
    let sim = dir.join("sim.hdr");
    let common = [
        "render",
        &rad,
        "--view-file",
        &vf,
        "--width",
        "20",
        "--height",
        "20",
    ];
    let o = run(&[&common[..], &["-o", &seq.to_string_lossy()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&[
        &common[..],
        &[
            "-o",
            &sim.to_string_lossy(),
            "--procs",
            "4",
            "--runtime",
            "sim",
            "--network",
            "parsytec-cc",
            "--policy",
            "load-aware",
            "--distribution",
            "predicted",
        ],
    ]
    .concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("virtual time")
            || String::from_utf8_lossy(&o.stdout).contains("virtual time")
    );
    assert_eq!(std::fs::read(&seq).unwrap(), std::fs::read(&sim).unwrap());
    let bad = run(&[
        &common[..],
        &[
            "-o",
            "x.png",
            "--procs",
            "2",
            "--runtime",
            "sim",
            "--network",
            "ethernet",
        ],
    ]
    .concat());
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("--network"));
}

#[cfg(not(feature = "mpi"))]
#[test]
fn mpi_runtime_needs_the_mpi_feature() {
    let d = tmpdir("no-mpi");
    let (rad, vf) = cornell_files(&d);
    let out = d.join("x.png");
    for procs in [None, Some("2")] {
        let mut args = vec![
            "render",
            &rad,
            "--view-file",
            &vf,
            "--width",
            "8",
            "--height",
            "8",
            "--runtime",
            "mpi",
            "-o",
            out.to_str().unwrap(),
        ];
        if let Some(n) = procs {
            args.extend(["--procs", n]);
        }
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--features mpi"), "{}", stderr(&o));
        assert!(!out.exists());
    }
}

#[test]
fn bench_scaling_prints_the_curve_and_checks_every_picture() {
    let d = tmpdir("scaling");
    let (rad, vf) = cornell_files(&d);
    let bench = |extra: &[&str]| {
        let mut args = vec!["bench", "--scene", &rad, "--view-file", &vf];
        args.extend_from_slice(extra);
        run(&args)
    };
    let o = bench(&[
        "--width",
        "24",
        "--height",
        "24",
        "--scaling",
        "1,2",
        "--repeat",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("equals the sequential one"), "{out}");
    for row in [
        "| sequential |",
        "| replicated | 1 |",
        "| replicated | 2 |",
        "| octree | 2 |",
    ] {
        assert!(out.contains(row), "{row} missing in\n{out}");
    }
    let o = bench(&["--scaling", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn sweep_reference_options_are_checked() {
    let d = tmpdir("sweep-reference");
    let (rad, vf) = cornell_files(&d);
    let out = d.join("out");
    for bad in ["-ab", "-zz 1", "dt 0.1"] {
        let o = run(&[
            "sweep",
            &rad,
            "--view-file",
            &vf,
            "--out",
            out.to_str().unwrap(),
            "--reference",
            bad,
        ]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--reference"), "{bad}: {}", stderr(&o));
    }
}

/// `-` reads the scene from standard input (`xform ... | hybrid-rt render -`),
/// and a scene file may have any name (`.mat`, none): Radiance text.
#[test]
fn scene_from_standard_input_and_any_file_name() {
    use std::io::Write;
    let d = tmpdir("stdin");
    let mat = write(&d, "lamp.mat", "void light lamp\n0\n0\n3 10 10 10\n");
    let mut child = exe()
        .args([
            "render",
            mat.to_str().unwrap(),
            "-",
            "--view",
            "-vtv -vp 0 -3 0 -vd 0 1 0 -vu 0 0 1 -vh 40 -vv 40",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
        ])
        .arg(d.join("out.hdr"))
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"lamp sphere \"ball #1\"\n0\n0\n4 0 0 0 1\n")
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(d.join("out.hdr").is_file());
    std::fs::remove_dir_all(&d).ok();
}
