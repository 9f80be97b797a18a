//! The committed experiment outputs equal what the code writes now, byte
//! for byte (DESIGN.md's invariant; EXPERIMENTS.md claims only what these
//! tests hold).
//!
//! Each test reruns `hybrid-rt experiment all` with the arguments that
//! wrote a directory under `experiments/` and compares every file, and the
//! set of files, with the committed ones; a difference prints a unified diff
//! and the command that regenerates the directory. The simulated
//! experiments measure nothing on the wall clock (compute is priced by the
//! committed cost model, `experiments/cost-model.json`), so nothing needs
//! to be left out of the comparison.
//!
//! - `experiments/ci/cornell`: seconds in a debug build, run everywhere;
//! - `experiments/ci/studio`: the studio scene small, about 6 s of CPU in a
//!   release build; release only (`scripts/test.sh` runs it);
//! - `experiments/ci/studio-soft`: the paper-like workload (the studio
//!   with soft shadows, `-ds 0.05 -dt 0`: 33 shadow rays per bundle) on a
//!   tiny picture; release only;
//! - `experiments/hemispheres`: hemisphere rays migrating through a
//!   distributed scene (the Cornell box, 1 to 32 simulated processors),
//!   about 20 s in a release build; release only;
//! - `experiments/interreflection`: diffuse inter-reflection with an
//!   irradiance cache on a distributed scene, simulated (the Cornell box, 1
//!   to 32 processors), about 35 s in a release build; release only;
//! - `experiments/studio`, `experiments/studio-soft` (the paper-like
//!   workload at full size) and `experiments/conference`: minutes each,
//!   ignored by default; `cargo test --release -p hybrid-rt --test
//!   experiments_committed -- --ignored` checks them.
//!
//! And `experiment calibrate`, which writes the committed model, writes a
//! file the simulator accepts.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A fresh directory for one test's files.
fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "hybrid-rt-experiments-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn files(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// A unified diff of two files: `diff -u` where it exists, else the first
/// differing line.
fn unified_diff(committed: &Path, fresh: &Path) -> String {
    if let Ok(o) = Command::new("diff")
        .arg("-u")
        .arg(committed)
        .arg(fresh)
        .output()
    {
        if !o.stdout.is_empty() {
            let text = String::from_utf8_lossy(&o.stdout);
            // A whole regenerated plot is thousands of lines: the head says enough.
            return text.lines().take(80).collect::<Vec<_>>().join("\n");
        }
    }
    let a = std::fs::read_to_string(committed).unwrap_or_default();
    let b = std::fs::read_to_string(fresh).unwrap_or_default();
    match a.lines().zip(b.lines()).position(|(x, y)| x != y) {
        Some(i) => format!(
            "line {}:\n- {}\n+ {}",
            i + 1,
            a.lines().nth(i).unwrap_or(""),
            b.lines().nth(i).unwrap_or("")
        ),
        None => format!(
            "lengths differ: {} and {} lines",
            a.lines().count(),
            b.lines().count()
        ),
    }
}

/// Runs `hybrid-rt experiment all ARGS --out TMP` and compares TMP with
/// `experiments/DIR`.
fn check(dir: &str, args: &[&str]) {
    check_experiment("all", dir, args)
}

/// Runs `hybrid-rt experiment NAME ARGS --out TMP` and compares TMP with
/// `experiments/DIR`.
fn check_experiment(name: &str, dir: &str, args: &[&str]) {
    let out = tmpdir(&dir.replace('/', "-"));
    let o = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"))
        .current_dir(repo())
        .args(["experiment", name])
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .expect("run hybrid-rt");
    assert!(
        o.status.success(),
        "hybrid-rt experiment {name} {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
    let committed = repo().join("experiments").join(dir);
    let regenerate = format!(
        "cargo run --release -p hybrid-rt -- experiment {name} {} --out experiments/{dir}",
        args.join(" ")
    );
    let (want, got) = (files(&committed), files(&out));
    assert_eq!(
        want, got,
        "experiments/{dir}: the set of files differs from what the code writes; regenerate with\n  {regenerate}"
    );
    let mut report = String::new();
    for f in &want {
        let (a, b) = (committed.join(f), out.join(f));
        if std::fs::read(&a).unwrap() != std::fs::read(&b).unwrap() {
            report += &format!("\n== {f}\n{}\n", unified_diff(&a, &b));
        }
    }
    assert!(
        report.is_empty(),
        "experiments/{dir} differs from what the code writes now{report}\nIf the change is intended, regenerate it with\n  {regenerate}\nand with it the other directories of experiments/ (ci/cornell, ci/studio, ci/studio-soft, studio, studio-soft, conference: the commands are in this test file and in EXPERIMENTS.md), and update EXPERIMENTS.md where its figures changed"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// The arguments of `experiments/ci/cornell` (all eleven experiments on a
/// tiny picture).
const CORNELL: &[&str] = &[
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
];

/// The arguments of `experiments/ci/studio`.
const STUDIO_SMALL: &[&str] = &[
    "--scene",
    "studio",
    "--width",
    "64",
    "--height",
    "48",
    "--max-procs",
    "8",
    "--detail-procs",
    "4",
    "--cache-procs",
    "4",
    "--cache-size",
    "32",
];

/// The paper-like workload's render options: soft shadows from the
/// studio's large area sources, every patch tested (EXPERIMENTS.md).
const SOFT: &[&str] = &["-ds", "0.05", "-dt", "0"];

/// The arguments of `experiments/ci/studio-soft`.
const STUDIO_SOFT_SMALL: &[&str] = &[
    "--scene",
    "studio",
    "--width",
    "32",
    "--height",
    "24",
    "--max-procs",
    "8",
    "--detail-procs",
    "4",
    "--cache-procs",
    "4",
    "--cache-size",
    "16",
    "-ds",
    "0.05",
    "-dt",
    "0",
];

#[test]
fn cornell_experiments_equal_the_committed_files() {
    check("ci/cornell", CORNELL);
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "release only (a minute in debug): scripts/test.sh runs it with --release"
)]
fn small_studio_experiments_equal_the_committed_files() {
    check("ci/studio", STUDIO_SMALL);
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "release only (minutes in debug): scripts/test.sh runs it with --release"
)]
fn small_paper_like_experiments_equal_the_committed_files() {
    check("ci/studio-soft", STUDIO_SOFT_SMALL);
}

/// The arguments of `experiments/interreflection`: diffuse inter-reflection
/// with an irradiance cache (`-ab 1 -ad 64 -as 16`) on the simulated
/// cluster, 1 to 32 processors.
const INTERREFLECTION: &[&str] = &[
    "--scene",
    "cornell",
    "--width",
    "64",
    "--height",
    "64",
    "--max-procs",
    "32",
    "-ab",
    "1",
    "-ad",
    "64",
    "-as",
    "16",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "release only (minutes in debug): scripts/test.sh runs it with --release"
)]
fn interreflection_experiment_equals_the_committed_files() {
    check_experiment("interreflection", "interreflection", INTERREFLECTION);
}

/// The arguments of `experiments/hemispheres`: hemisphere rays migrating
/// through a distributed scene without an irradiance cache (`-ab 1 -aa 0
/// -as 0 -ad 64`) on the simulated cluster, 1 to 32 processors.
const HEMISPHERES: &[&str] = &[
    "--scene",
    "cornell",
    "--width",
    "64",
    "--height",
    "64",
    "--max-procs",
    "32",
    "-ab",
    "1",
    "-aa",
    "0",
    "-as",
    "0",
    "-ad",
    "64",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "release only (minutes in debug): scripts/test.sh runs it with --release"
)]
fn hemispheres_experiment_equals_the_committed_files() {
    check_experiment("hemispheres", "hemispheres", HEMISPHERES);
}

#[test]
#[ignore = "minutes in release: run with --release -- --ignored"]
fn studio_experiments_equal_the_committed_files() {
    check("studio", &["--scene", "studio"]);
}

#[test]
#[ignore = "half an hour in release: run with --release -- --ignored"]
fn paper_like_studio_experiments_equal_the_committed_files() {
    let args: Vec<&str> = ["--scene", "studio"].iter().chain(SOFT).copied().collect();
    check("studio-soft", &args);
}

#[test]
#[ignore = "minutes in release: run with --release -- --ignored"]
fn conference_experiments_equal_the_committed_files() {
    check(
        "conference",
        &[
            "--scene",
            "conference",
            "--width",
            "128",
            "--height",
            "128",
            "--cache-size",
            "64",
        ],
    );
}

/// `experiment calibrate` writes a model file the simulator accepts (every
/// fitted kind priced), recording the command and the scene, and says how
/// far the committed model is off. The costs themselves are measurements
/// and are not compared.
#[test]
fn calibrate_writes_a_model_file_the_simulator_accepts() {
    let out = tmpdir("calibrate");
    let o = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"))
        .args([
            "experiment",
            "calibrate",
            "--scene",
            "cornell",
            "--width",
            "16",
            "--height",
            "16",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("run hybrid-rt");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("the committed model"), "{stderr}");
    let text = std::fs::read_to_string(out.join("cost-model.json")).unwrap();
    let f = hybrid_rt::parallel::cost::ModelFile::parse(&text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(f.scene, "cornell");
    assert!(
        f.command.contains("experiment calibrate --scene cornell"),
        "{}",
        f.command
    );
    assert!(f.fit.steps > 0 && f.fit.threads_steps > 0);
    let committed = hybrid_rt::parallel::cost::committed();
    assert_eq!(f.assumed, committed.assumed, "assumptions are carried over");
    assert_eq!(f.model.master_step_ns, committed.model.master_step_ns);
    let _ = std::fs::remove_dir_all(&out);
}
