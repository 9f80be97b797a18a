//! `mpirun -np N hybrid-rt render ... --runtime mpi` (feature `mpi`; needs
//! Open MPI's `mpirun` on the PATH, or `MPIRUN`). Every run has a time
//! limit: a hang fails the test instead of the CI run.
#![cfg(feature = "mpi")]

use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

const CORNELL: &str = include_str!("data/radiance-cornell.rad");
const CORNELL_VF: &str = include_str!("data/radiance-cornell.vf");

/// Longest one `mpirun` may take before the test kills it and fails.
const LIMIT: Duration = Duration::from_secs(240);

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-mpi-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn cornell(dir: &Path) -> (String, String) {
    let rad = dir.join("cornell.rad");
    let vf = dir.join("cornell.vf");
    std::fs::write(&rad, CORNELL).unwrap();
    std::fs::write(&vf, CORNELL_VF).unwrap();
    (
        rad.to_string_lossy().into_owned(),
        vf.to_string_lossy().into_owned(),
    )
}

struct Run {
    status: ExitStatus,
    stderr: String,
}

/// Runs `cmd` with its output in files (no pipe can fill up), killing it
/// after [`LIMIT`].
fn run_limited(mut cmd: Command, dir: &Path, tag: &str) -> Run {
    let out = dir.join(format!("{tag}.stdout"));
    let err = dir.join(format!("{tag}.stderr"));
    cmd.stdin(Stdio::null())
        .stdout(File::create(&out).unwrap())
        .stderr(File::create(&err).unwrap());
    let mut child = cmd.spawn().expect("start mpirun (is Open MPI installed?)");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > LIMIT {
            // SIGTERM first: mpirun then ends its ranks too.
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            std::thread::sleep(Duration::from_secs(5));
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "{tag}: still running after {LIMIT:?} (hang?); stderr:\n{}",
                std::fs::read_to_string(&err).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    Run {
        status,
        stderr: std::fs::read_to_string(&err).unwrap_or_default(),
    }
}

fn mpirun(np: usize, args: &[&str], env: &[(&str, &str)], dir: &Path, tag: &str) -> Run {
    let mut cmd = Command::new(std::env::var("MPIRUN").unwrap_or_else(|_| "mpirun".into()));
    cmd.args(["-np", &np.to_string(), "--oversubscribe"])
        .arg(env!("CARGO_BIN_EXE_hybrid-rt"))
        .args(args)
        // CI runs as root in a container.
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_btl_vader_single_copy_mechanism", "none");
    for (k, v) in env {
        cmd.env(k, v);
    }
    run_limited(cmd, dir, tag)
}

fn base<'a>(rad: &'a str, vf: &'a str) -> Vec<&'a str> {
    vec![
        "render",
        rad,
        "--view-file",
        vf,
        "--width",
        "48",
        "--height",
        "40",
    ]
}

#[test]
fn mpirun_renders_the_sequential_picture() {
    let d = tmpdir("same");
    let (rad, vf) = cornell(&d);
    let seq = d.join("seq.hdr");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"));
    cmd.args(base(&rad, &vf))
        .args(["-o", seq.to_str().unwrap()]);
    let r = run_limited(cmd, &d, "seq");
    assert!(r.status.success(), "sequential: {}", r.stderr);
    let want = std::fs::read(&seq).unwrap();

    for (np, extra) in [
        (1, &[][..]),
        (2, &["--procs", "2"][..]),
        (
            4,
            &["--cache", "10%", "--policy", "round-robin", "--tile", "8"][..],
        ),
    ] {
        let out = d.join(format!("mpi{np}.hdr"));
        let json = d.join(format!("mpi{np}.json"));
        let mut args = base(&rad, &vf);
        args.extend(["--runtime", "mpi", "--time-limit", "200"]);
        args.extend(extra);
        args.extend([
            "--parallel-stats",
            json.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let r = mpirun(np, &args, &[], &d, &format!("np{np}"));
        assert!(r.status.success(), "-np {np}: {}", r.stderr);
        assert!(
            std::fs::read(&out).unwrap() == want,
            "-np {np}: the picture differs from the sequential one"
        );
        // Rank 0 reports, once.
        let e = &r.stderr;
        assert_eq!(
            e.matches(&format!("parallel render: {np} processors, mpi runtime"))
                .count(),
            1,
            "{e}"
        );
        assert!(e.contains("MPI wire traffic"), "{e}");
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(stats["stats"]["runtime"], "mpi");
        assert_eq!(stats["stats"]["procs"].as_array().unwrap().len(), np);
        let ranks = stats["ranks"].as_array().unwrap();
        assert_eq!(ranks.len(), np);
        for (i, t) in ranks.iter().enumerate() {
            assert_eq!(t["rank"].as_u64(), Some(i as u64));
            if np == 2 {
                // Geometry ships: with an unlimited cache every rank
                // fetches the other's cells over MPI. (With 10% at -np 4 a
                // rank may run everything data-parallel instead.)
                assert!(t["data_messages_received"].as_u64().unwrap() > 0, "{t}");
            }
            if np > 1 {
                assert!(t["bytes_received"].as_u64().unwrap() > 0, "{t}");
                assert!(t["messages_sent"].as_u64().unwrap() > 0, "{t}");
            } else {
                assert_eq!(t["messages_sent"].as_u64(), Some(0), "{t}");
            }
        }
    }
}

/// Diffuse inter-reflection (`-ab 2`, the irradiance cache in waves: one
/// epoch each, the records broadcast to every rank between them) under
/// MPI: the sequential picture, bit for bit, and the same cache.
#[test]
fn mpirun_renders_two_bounces_as_the_sequential_renderer() {
    let d = tmpdir("ab2");
    let (rad, vf) = cornell(&d);
    let ab = [
        "-ab", "2", "-aa", ".2", "-ad", "32", "-as", "8", "-ar", "16",
    ];
    let seq = d.join("seq.hdr");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"));
    cmd.args(base(&rad, &vf))
        .args(ab)
        .args(["-o", seq.to_str().unwrap()]);
    let r = run_limited(cmd, &d, "seq");
    assert!(r.status.success(), "sequential: {}", r.stderr);
    let want = std::fs::read(&seq).unwrap();
    for np in [1, 3] {
        let out = d.join(format!("mpi{np}.hdr"));
        let mut args = base(&rad, &vf);
        args.extend(ab);
        args.extend([
            "--runtime",
            "mpi",
            "--time-limit",
            "200",
            "-o",
            out.to_str().unwrap(),
        ]);
        let r = mpirun(np, &args, &[], &d, &format!("ab2np{np}"));
        assert!(r.status.success(), "-np {np}: {}", r.stderr);
        assert!(
            std::fs::read(&out).unwrap() == want,
            "-np {np}: the picture differs from the sequential one"
        );
        // Rank 0 reports, once; more than one wave ran.
        let e = &r.stderr;
        let line = e
            .lines()
            .find(|l| l.starts_with("parallel inter-reflection:"))
            .unwrap_or_else(|| panic!("-np {np}: no report: {e}"));
        assert!(line.contains(&format!("{np} processors (mpi)")), "{line}");
        assert_eq!(e.matches("parallel inter-reflection:").count(), 1, "{e}");
    }
}

#[test]
fn an_undecodable_message_is_a_clear_error_not_a_hang() {
    let d = tmpdir("garbage");
    let (rad, vf) = cornell(&d);
    let out = d.join("x.hdr");
    let mut args = base(&rad, &vf);
    args.extend(["--runtime", "mpi", "-o", out.to_str().unwrap()]);
    let r = mpirun(
        2,
        &args,
        &[("HYBRID_SCHED_MPI_FAULT", "garbage:1")],
        &d,
        "garbage",
    );
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("rank 0: cannot decode a 12-byte packet message from rank 1"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
}

#[test]
fn a_dying_rank_ends_the_job_with_an_error() {
    let d = tmpdir("exit");
    let (rad, vf) = cornell(&d);
    let out = d.join("x.hdr");
    let mut args = base(&rad, &vf);
    args.extend(["--runtime", "mpi", "-o", out.to_str().unwrap()]);
    let r = mpirun(
        3,
        &args,
        &[("HYBRID_SCHED_MPI_FAULT", "exit:1")],
        &d,
        "exit",
    );
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(r.stderr.contains("rank 1: fault injection"), "{}", r.stderr);
    assert!(!out.exists());
}

#[test]
fn procs_must_match_the_number_of_ranks() {
    let d = tmpdir("procs");
    let (rad, vf) = cornell(&d);
    let out = d.join("x.hdr");
    let mut args = base(&rad, &vf);
    args.extend([
        "--runtime",
        "mpi",
        "--procs",
        "3",
        "-o",
        out.to_str().unwrap(),
    ]);
    let r = mpirun(2, &args, &[], &d, "procs");
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(
        r.stderr.contains(
            "--procs 3 with --runtime mpi: there is one processor per MPI rank and this job has 2"
        ),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
}

/// Runs `hybrid-rt ARGS` alone (no mpirun), within the time limit.
fn hybrid_rt(args: &[&str], dir: &Path, tag: &str) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"));
    cmd.args(args);
    run_limited(cmd, dir, tag)
}

/// `--peak-memory`'s figures in `stderr`, in KiB: one per rank (by rank),
/// or the one of a process run alone (rank 0).
fn peaks(stderr: &str) -> Vec<(usize, u64)> {
    let mut out: Vec<(usize, u64)> = stderr
        .lines()
        .filter_map(|l| {
            let (who, rest) = l.split_once("peak resident memory: ")?;
            let kib = rest.strip_suffix(" KiB")?.parse().ok()?;
            let rank = who
                .strip_prefix("rank ")
                .and_then(|r| r.strip_suffix(": "))
                .map_or(Some(0), |r| r.parse().ok())?;
            Some((rank, kib))
        })
        .collect();
    out.sort();
    out
}

/// A generated city, compiled: under MPI every rank holds the replicated
/// part and reads only its own cells. The picture is the sequential
/// render's of the whole scene, and every rank's peak memory (as the
/// operating system measures it) stays below the whole scene's render's.
#[test]
fn ranks_of_a_compiled_scene_hold_their_part_not_the_whole_scene() {
    let d = tmpdir("held");
    let rad = d.join("city.rad");
    let hrtc = d.join("city.hrtc");
    let (rad_s, hrtc_s) = (rad.to_str().unwrap(), hrtc.to_str().unwrap());
    let vf = d.join("city.vf");
    let vf_s = vf.to_str().unwrap();
    let r = hybrid_rt(
        &["generate", "city", "--size", "200000", "-o", rad_s],
        &d,
        "generate",
    );
    assert!(r.status.success(), "{}", r.stderr);
    let r = hybrid_rt(&["compile", rad_s, "-o", hrtc_s], &d, "compile");
    assert!(r.status.success(), "{}", r.stderr);
    let size = ["--view-file", vf_s, "--width", "40", "--height", "30"];
    let seq = d.join("seq.hdr");
    let mut args = vec![
        "render",
        hrtc_s,
        "--peak-memory",
        "-o",
        seq.to_str().unwrap(),
    ];
    args.extend(size);
    let r = hybrid_rt(&args, &d, "whole");
    assert!(r.status.success(), "{}", r.stderr);
    let whole = peaks(&r.stderr);
    assert_eq!(whole.len(), 1, "{}", r.stderr);
    let whole = whole[0].1;
    let want = std::fs::read(&seq).unwrap();
    // Four ranks: each holds the skeleton, a quarter of the objects and
    // its cache (two ranks each hold half the scene besides the skeleton,
    // about what the whole scene's renderer holds).
    for np in [4] {
        let out = d.join(format!("held{np}.hdr"));
        let mut args = vec![
            "render",
            hrtc_s,
            "--runtime",
            "mpi",
            "--cache",
            "10%",
            "--peak-memory",
            "--time-limit",
            "200",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(size);
        let r = mpirun(np, &args, &[], &d, &format!("held{np}"));
        assert!(r.status.success(), "-np {np}: {}", r.stderr);
        assert!(
            std::fs::read(&out).unwrap() == want,
            "-np {np}: the picture differs from the sequential one"
        );
        let ranks = peaks(&r.stderr);
        assert_eq!(
            ranks.iter().map(|r| r.0).collect::<Vec<_>>(),
            (0..np).collect::<Vec<_>>(),
            "{}",
            r.stderr
        );
        for (rank, kib) in ranks {
            eprintln!("-np {np}: rank {rank} peaked at {kib} KiB; the whole scene's render at {whole} KiB");
            assert!(
                kib < whole,
                "-np {np}: rank {rank} peaked at {kib} KiB, not below the whole scene's {whole} KiB"
            );
        }
    }
}
