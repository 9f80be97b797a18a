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
