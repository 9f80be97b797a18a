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
    // The sequential renderer traces through its hierarchy and builds no
    // octree.
    assert!(stats["octree"].is_null(), "{}", stats["octree"]);
    assert!(stats["time"]["octree_build_s"].is_null());
    assert!(stats["time"]["bvh_build_s"].as_f64().unwrap() > 0.0);

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
        (
            vec![&rad, "--view-file", &vf, "-o", &out, "--up", "w"],
            2,
            "-x, -y, -z".into(),
        ),
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
            "--flight-bytes",
            "4M",
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
    // `--fetch-limit auto` (the default) with a budgeted cache: the
    // Cornell box's budget over 32 is under the floor, 64 KiB.
    assert_eq!(stats["options"]["fetch_limit"], "Auto", "{stats}");
    assert_eq!(stats["fetch_limit_bytes"], 64 << 10, "{stats}");
    assert!(err.contains("fetch limit 64.0 KiB a task"), "{err}");
}

/// Soft shadows (`-ds 0.05 -dt 0`: every patch of an area light tested, a
/// bundle's rays traced ahead as packets by the sequential renderer's
/// hierarchy, and by a processor holding the whole scene) give the
/// picture processors give tracing one ray at a time through the octree
/// and their hierarchies over copies, byte for byte.
#[test]
fn soft_shadows_traced_as_packets_equal_one_ray_at_a_time() {
    let d = tmpdir("packets");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let (rad, vf) = (root.join("studio.rad"), root.join("studio.vf"));
    let base = [
        "render",
        rad.to_str().unwrap(),
        "-vf",
        vf.to_str().unwrap(),
        "-x",
        "48",
        "-y",
        "48",
        "-ds",
        "0.05",
        "-dt",
        "0",
    ];
    let seq = d.join("seq.hdr");
    let o = run(&[&base[..], &["-o", seq.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let seq = std::fs::read(&seq).unwrap();
    for (name, procs) in [("whole", "1"), ("copies", "2")] {
        let par = d.join(format!("{name}.hdr"));
        let o = run(&[
            &base[..],
            &[
                "--procs",
                procs,
                "--distribution",
                "octree",
                "-o",
                par.to_str().unwrap(),
            ],
        ]
        .concat());
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(seq == std::fs::read(&par).unwrap(), "{name} differs");
    }
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
        ("--fetch-limit", "lots", "--fetch-limit"),
        ("--distribution", "diagonal", "--distribution"),
        ("--runtime", "quantum", "--runtime"),
        ("--tile", "0", "--tile 0"),
        ("--time-limit", "0", "--time-limit 0"),
        ("--flight-bytes", "10%", "--flight-bytes"),
        ("--complete-cache", "101", "from 0 to 100, or off"),
        ("--complete-cache", "half", "--complete-cache"),
        ("--serve-data", "sometimes", "on-arrival, between-steps"),
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

/// `render` of the Cornell box files at 20 x 20 (options and `-o` follow).
fn cornell_20x20<'a>(rad: &'a str, vf: &'a str) -> [&'a str; 8] {
    [
        "render",
        rad,
        "--view-file",
        vf,
        "--width",
        "20",
        "--height",
        "20",
    ]
}

#[test]
fn simulated_render_from_the_command_line() {
    let dir = tmpdir("sim-render");
    let (rad, vf) = cornell_files(&dir);
    let seq = dir.join("seq.hdr");
    let sim = dir.join("sim.hdr");
    let common = cornell_20x20(&rad, &vf);
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

/// `-ab` with `--procs` on the simulator and on threads: the irradiance
/// cache in waves (one epoch each) writes the sequential picture, byte for
/// byte, and says how it ran.
#[test]
fn parallel_inter_reflection_writes_the_sequential_picture() {
    let d = tmpdir("ab-parallel");
    let (rad, vf) = cornell_files(&d);
    let ab = ["-ab", "1", "-aa", ".2", "-ad", "32", "-as", "8"];
    let render = |name: &str, extra: &[&str]| {
        let out = d.join(name);
        let mut args = cornell_20x20(&rad, &vf).to_vec();
        args.extend(ab);
        args.extend_from_slice(extra);
        args.extend(["-o", out.to_str().unwrap()]);
        let o = run(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        (std::fs::read(&out).unwrap(), stderr(&o))
    };
    let (want, _) = render("seq.hdr", &[]);
    let (sim, e) = render("sim.hdr", &["--procs", "3", "--runtime", "sim"]);
    assert!(
        sim == want,
        "the simulated render differs from the sequential one"
    );
    assert!(
        e.contains("parallel render: 3 processors, sim runtime")
            && e.contains("simulated on")
            && e.contains("irradiance cache:"),
        "{e}"
    );
    let (threads, e) = render("threads.hdr", &["--procs", "2"]);
    assert!(
        threads == want,
        "the threaded render differs from the sequential one"
    );
    assert!(
        e.contains("parallel render: 2 processors, threads runtime"),
        "{e}"
    );
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
        "| octree, served between steps | 2 |",
        "| octree, the paper's cache and service | 2 |",
        "| 2 sequential renders at once (what the machine allows) | 2 |",
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

/// A Radiance picture's header (up to the empty line) and its resolution line.
fn picture_header(bytes: &[u8]) -> (String, String) {
    let end = bytes
        .windows(2)
        .position(|w| w == b"\n\n")
        .expect("a header ending in an empty line");
    let header = String::from_utf8_lossy(&bytes[..end]).into_owned();
    let rest = &bytes[end + 2..];
    let nl = rest.iter().position(|&b| b == b'\n').unwrap();
    (header, String::from_utf8_lossy(&rest[..nl]).into_owned())
}

fn view_line(header: &str) -> String {
    header
        .lines()
        .find(|l| l.starts_with("VIEW="))
        .expect("a VIEW= line")
        .to_string()
}

#[test]
fn rpict_sizes_and_the_picture_on_standard_output() {
    let d = tmpdir("stdout");
    let (rad, vf) = cornell_files(&d);
    let hdr = d.join("c.hdr");
    let long = run(&[
        "render",
        &rad,
        "-vf",
        &vf,
        "--width",
        "20",
        "--height",
        "12",
        "-o",
        hdr.to_str().unwrap(),
    ]);
    assert!(long.status.success(), "{}", stderr(&long));
    assert!(long.stdout.is_empty(), "nothing on stdout with -o FILE");
    let file = std::fs::read(&hdr).unwrap();
    for out in [None, Some("-")] {
        let mut args = vec!["render", &rad, "-vf", &vf, "-x", "20", "-y", "12"];
        if let Some(o) = out {
            args.extend(["-o", o]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(o.stdout.starts_with(b"#?RADIANCE\n"), "{out:?}");
        // -x -y are --width --height: the same picture.
        assert_eq!(o.stdout, file, "{out:?}");
        let (_, res) = picture_header(&o.stdout);
        assert_eq!(res, "-Y 12 +X 12");
        assert!(!stderr(&o).contains("#?RADIANCE"));
    }
}

#[test]
fn error_file_receives_the_diagnostics() {
    let d = tmpdir("errfile");
    // A curved mirror: the renderer warns that it relays no sources.
    let rad = write(
        &d,
        "ball.rad",
        "void mirror m 0 0 3 1 1 1\nm sphere ball 0 0 4 0 3 0 1\n",
    );
    let log = d.join("log.txt");
    let args = |out: &str| {
        vec![
            "render".to_string(),
            rad.to_string_lossy().into_owned(),
            "-x".into(),
            "4".into(),
            "-y".into(),
            "4".into(),
            "-e".into(),
            log.to_string_lossy().into_owned(),
            "-o".into(),
            out.into(),
        ]
    };
    let png = d.join("b.png");
    let a = args(png.to_str().unwrap());
    let o = exe().args(&a).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "", "diagnostics go to the file");
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains("warning: mirror surface \"ball\""), "{text}");
    assert!(text.contains("view: Radiance's default"), "{text}");
    // Appended, errors too (and the exit code stays).
    let o = exe()
        .args(args(&d.join("x.jpg").to_string_lossy()))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o), "");
    let text2 = std::fs::read_to_string(&log).unwrap();
    assert!(text2.starts_with(&text), "appended");
    assert!(text2[text.len()..].contains("error: "), "{text2}");
}

#[test]
fn view_file_may_be_a_radiance_picture() {
    let d = tmpdir("vfpic");
    let (rad, _) = cornell_files(&d);
    let first = d.join("a.hdr");
    let o = run(&[
        "render",
        &rad,
        "-vtv",
        "-vp",
        "0.4",
        "0.1",
        "0.1",
        "-vd",
        "-1",
        "0.1",
        "0",
        "-vh",
        "70",
        "-vv",
        "50",
        "-x",
        "12",
        "-y",
        "12",
        "-o",
        first.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = std::fs::read(&first).unwrap();
    let o = run(&[
        "render",
        &rad,
        "-vf",
        first.to_str().unwrap(),
        "-x",
        "12",
        "-y",
        "12",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (ha, _) = picture_header(&a);
    let (hb, _) = picture_header(&o.stdout);
    assert_eq!(view_line(&ha), view_line(&hb));
    assert!(view_line(&ha).contains("-vh 70 -vv 50"));
    assert_eq!(a, o.stdout, "the same view renders the same picture");
    // A picture without a VIEW= line, and one whose header never ends.
    let mut no_view = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1\n".to_vec();
    no_view.extend([0xff, 0x00, 0x80, 0x81]);
    let endless = [b"#?RADIANCE\n".to_vec(), vec![b'x'; 100_000]].concat();
    for (name, bytes, says) in [
        ("none.hdr", no_view, "VIEW="),
        ("endless.hdr", endless, "header"),
    ] {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        let o = run(&["render", &rad, "-vf", p.to_str().unwrap(), "-o", "x.png"]);
        assert_eq!(o.status.code(), Some(1), "{name}");
        assert!(stderr(&o).contains(name), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{name}: {}", stderr(&o));
    }
    // Not a regular file: refused, not read forever.
    #[cfg(unix)]
    {
        let o = run(&["render", &rad, "-vf", "/dev/zero", "-o", "x.png"]);
        assert_eq!(o.status.code(), Some(1));
        assert!(
            stderr(&o).contains("/dev/zero: not a regular file"),
            "{}",
            stderr(&o)
        );
    }
}

#[test]
fn default_view_beside_the_scene_else_radiance_s() {
    let d = tmpdir("defview");
    let (rad, vf) = cornell_files(&d);
    let o = run(&["render", &rad, "-x", "8", "-y", "8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!("view: {vf} (beside the scene)")),
        "{}",
        stderr(&o)
    );
    let with_vf = run(&["render", &rad, "-vf", &vf, "-x", "8", "-y", "8"]);
    assert_eq!(o.stdout, with_vf.stdout);
    assert!(!stderr(&with_vf).contains("view:"), "only when chosen");
    std::fs::remove_file(&vf).unwrap();
    let o = run(&["render", &rad, "-x", "8", "-y", "8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o)
        .contains("view: Radiance's default (-vtv -vp 0 0 0 -vd 0 1 0 -vu 0 0 1 -vh 45 -vv 45"));
    let (h, _) = picture_header(&o.stdout);
    assert!(view_line(&h).contains("-vp 0 0 0 -vd 0 1 0 -vu 0 0 1 -vh 45 -vv 45"));
}

#[test]
fn obj_scenes_are_framed_automatically() {
    let d = tmpdir("objframe");
    // A unit cube away from the origin: Radiance's default view (from the
    // origin along +y) would miss it.
    let mut obj = String::new();
    for z in [9.0, 11.0] {
        for (x, y) in [(4.0, -6.0), (6.0, -6.0), (6.0, -4.0), (4.0, -4.0)] {
            obj += &format!("v {x} {y} {z}\n");
        }
    }
    obj += "f 1 2 3 4\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let scene = write(&d, "box.obj", &obj);
    let scene = scene.to_str().unwrap();
    let mut views = Vec::new();
    for up in [None, Some("z"), Some("-x")] {
        let mut args = vec!["render", scene, "-av", "1", "1", "1", "-x", "9", "-y", "9"];
        if let Some(u) = up {
            args.extend(["--up", u]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let err = stderr(&o);
        let want = format!("view: framing the scene's bounds, up {}", up.unwrap_or("y"));
        assert!(err.contains(&want), "{err}");
        let img = hybrid_rt::image::hdr::read_hdr(&mut std::io::Cursor::new(&o.stdout)).unwrap();
        let centre = img.film.get(4, 4);
        assert!(
            centre.min_element() > 0.0,
            "{up:?}: the centre sees the box"
        );
        let (h, _) = picture_header(&o.stdout);
        views.push(view_line(&h));
    }
    assert_ne!(views[0], views[1]);
    assert_ne!(views[1], views[2]);
    assert!(views[0].contains("-vu 0 1 0"), "{}", views[0]);
    assert!(views[2].contains("-vu -1 0 0"), "{}", views[2]);
}

#[test]
fn enumerated_options_list_every_value() {
    let o = run(&["render", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    for value in ["replicated", "load-aware", "parsytec-cc", "draft"] {
        assert!(help.contains(value), "render --help lacks {value}");
    }
    let d = tmpdir("enums");
    let (rad, vf) = cornell_files(&d);
    for (flag, all) in [
        (
            "--policy",
            &[
                "local",
                "via-master",
                "to-origin",
                "round-robin",
                "load-aware",
            ][..],
        ),
        (
            "--distribution",
            &["octree", "predicted", "replicated", "worst"][..],
        ),
        ("--runtime", &["threads", "sequential", "sim", "mpi"][..]),
        ("--quality", &["draft", "normal", "high"][..]),
    ] {
        let o = run(&["render", &rad, "-vf", &vf, flag, "bogus", "-o", "x.png"]);
        assert_eq!(o.status.code(), Some(2));
        let err = stderr(&o);
        for v in all {
            assert!(err.contains(v), "{flag}: {err} lacks {v}");
        }
    }
    // The other spellings still work, in any case.
    for (flag, value) in [("--policy", "RR"), ("--distribution", "shared")] {
        let o = run(&[
            "render", &rad, "-vf", &vf, "-x", "4", "-y", "4", "--procs", "2", flag, value,
        ]);
        assert!(o.status.success(), "{flag} {value}: {}", stderr(&o));
    }
    let o = run(&["experiment", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    for value in ["table1", "flow", "calibrate"] {
        assert!(help.contains(value), "experiment --help lacks {value}");
    }
}

/// Every `hybrid-rt` command in the README's code (blocks and spans):
/// the words after `cargo run ... -p hybrid-rt --` or
/// `target/release/hybrid-rt`, up to a shell operator.
fn readme_commands(readme: &str) -> Vec<Vec<String>> {
    let mut snippets = Vec::new();
    let mut fence: Option<String> = None;
    for line in readme.lines() {
        if line.trim_start().starts_with("```") {
            match fence.take() {
                Some(block) => snippets.push(block.replace("\\\n", " ")),
                None => fence = Some(String::new()),
            }
            continue;
        }
        match &mut fence {
            Some(block) => {
                block.push_str(line);
                block.push('\n');
            }
            None => {
                snippets.extend(line.split('`').skip(1).step_by(2).map(str::to_string));
            }
        }
    }
    let mut commands = Vec::new();
    for snippet in &snippets {
        for line in snippet.lines() {
            // No bare program name: it is not on the PATH after the quick start.
            for sub in ["render", "bench", "sweep", "experiment"] {
                let bare = format!("hybrid-rt {sub}");
                for (i, _) in line.match_indices(&bare) {
                    assert!(
                        line[..i].ends_with("release/"),
                        "README runs a bare `hybrid-rt`: {line}"
                    );
                }
            }
            for marker in ["-p hybrid-rt -- ", "target/release/hybrid-rt"] {
                for (i, _) in line.match_indices(marker) {
                    let rest = &line[i + marker.len()..];
                    let rest = if marker.starts_with("-p") {
                        rest
                    } else if let Some(r) = rest.strip_prefix(' ') {
                        r
                    } else {
                        continue;
                    };
                    let end = rest.find(['|', ';', '>', '&']).unwrap_or(rest.len());
                    commands.push(shell_words(&rest[..end]));
                }
            }
        }
    }
    commands
}

/// Splits a command line into words as a shell does for plain and quoted words.
fn shell_words(s: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word: Option<String> = None;
    let mut quote: Option<char> = None;
    for c in s.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.get_or_insert_with(String::new).push(c),
            (None, '"' | '\'') => {
                quote = Some(c);
                word.get_or_insert_with(String::new);
            }
            (None, c) if c.is_whitespace() => words.extend(word.take()),
            (None, c) => word.get_or_insert_with(String::new).push(c),
        }
    }
    words.extend(word);
    words
}

#[test]
fn readme_commands_parse() {
    use clap::Parser;
    let readme = include_str!("../../README.md");
    let commands = readme_commands(readme);
    assert!(commands.len() >= 10, "found only {commands:?}");
    for words in commands {
        let argv: Vec<String> = std::iter::once("hybrid-rt".to_string())
            .chain(words.iter().cloned())
            .collect();
        match hybrid_rt::cli::Cli::try_parse_from(hybrid_rt::cli::translate(argv)) {
            Ok(_) => {}
            Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelp => {}
            Err(e) => panic!("README command {words:?} does not parse: {e}"),
        }
    }
}

#[test]
fn readme_command_extraction() {
    let md = "text `cargo run --release -p hybrid-rt -- render a.rad --view \"-vtv -vp 0 0 1\" -o x.png` and\n\
              ```sh\n\
              mpirun -np 2 target/release/hybrid-rt bench --scene studio \\\n    --width 8 | tee log\n\
              ```\n";
    assert_eq!(
        readme_commands(md),
        vec![
            shell_words("render a.rad --view '-vtv -vp 0 0 1' -o x.png"),
            shell_words("bench --scene studio --width 8"),
        ]
    );
    assert_eq!(shell_words("a \"b c\" 'd'"), vec!["a", "b c", "d"]);
    // A bare program name is caught.
    let bare = std::panic::catch_unwind(|| readme_commands("see `hybrid-rt render --help`"));
    assert!(bare.is_err());
}

/// The experiments beyond the paper need their render options, and say
/// which: `interreflection` `-ab` with an irradiance cache, `hemispheres`
/// `-ab` without one.
#[test]
fn extra_experiments_name_the_options_they_need() {
    let dir = tmpdir("extra-experiments");
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    let tiny = ["--scene", "cornell", "--width", "8", "--height", "8"];
    for (name, extra, says) in [
        ("interreflection", &[][..], "give -ab 1 or more"),
        (
            "interreflection",
            &["-ab", "1", "-aa", "0"][..],
            "-aa above 0",
        ),
        ("hemispheres", &[][..], "with -aa 0"),
        ("hemispheres", &["-ab", "1"][..], "with -aa 0"),
    ] {
        let mut args = vec!["experiment", name];
        args.extend(tiny);
        args.extend(extra);
        args.extend(["--out", out]);
        let o = run(&args);
        assert_eq!(o.status.code(), Some(2), "{name} {extra:?}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(says),
            "{name} {extra:?}: {}",
            stderr(&o)
        );
    }
}
