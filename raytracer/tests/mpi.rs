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
    mpirun_wrapped(np, &[], args, env, dir, tag)
}

/// [`mpirun`] starting each rank as `wrapper... hybrid-rt args...`.
fn mpirun_wrapped(
    np: usize,
    wrapper: &[String],
    args: &[&str],
    env: &[(&str, &str)],
    dir: &Path,
    tag: &str,
) -> Run {
    let mut cmd = Command::new(std::env::var("MPIRUN").unwrap_or_else(|_| "mpirun".into()));
    cmd.args(["-np", &np.to_string(), "--oversubscribe"])
        .args(wrapper)
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

/// The sequential renderer's picture of the scene `base` renders, with
/// `extra` options, as written to a file in `d`.
fn sequential_picture(d: &Path, rad: &str, vf: &str, extra: &[&str]) -> Vec<u8> {
    let seq = d.join("seq.hdr");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"));
    cmd.args(base(rad, vf))
        .args(extra)
        .args(["-o", seq.to_str().unwrap()]);
    let r = run_limited(cmd, d, "seq");
    assert!(r.status.success(), "sequential: {}", r.stderr);
    std::fs::read(&seq).unwrap()
}

#[test]
fn mpirun_renders_the_sequential_picture() {
    let d = tmpdir("same");
    let (rad, vf) = cornell(&d);
    let want = sequential_picture(&d, &rad, &vf, &[]);

    for (k, (np, extra)) in [
        (1, &[][..]),
        (2, &["--procs", "2"][..]),
        (
            4,
            // Finished pixels sent to rank 0's master in batches of 5.
            &[
                "--cache",
                "10%",
                "--policy",
                "round-robin",
                "--tile",
                "8",
                "--pixel-batch",
                "5",
            ][..],
        ),
        // Every rank asks for the rest of the scene at its first fetch
        // (large data replies), and the paper's cache.
        (3, &["--complete-cache", "0", "--tile", "8"][..]),
        (2, &["--complete-cache", "off"][..]),
        // Data requests answered by the owner between its steps (the
        // others: on arrival, by the owner's MPI thread).
        (
            2,
            &["--complete-cache", "off", "--serve-data", "between-steps"][..],
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let out = d.join(format!("mpi{k}.hdr"));
        let json = d.join(format!("mpi{k}.json"));
        let mut args = base(&rad, &vf);
        args.extend(["--runtime", "mpi", "--time-limit", "200"]);
        args.extend(extra);
        args.extend([
            "--parallel-stats",
            json.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let r = mpirun(np, &args, &[], &d, &format!("np{np}-{k}"));
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
        let procs = stats["stats"]["procs"].as_array().unwrap();
        let sum = |k: &str| procs.iter().map(|p| p[k].as_u64().unwrap()).sum::<u64>();
        assert_eq!(
            sum("data_requests_served"),
            sum("data_requests_sent"),
            "-np {np} {extra:?}: every data request answered once"
        );
        for p in procs {
            let completed = p["cache_completed"].as_bool();
            if extra.contains(&"off") || extra.contains(&"10%") {
                assert_eq!(completed, Some(false), "-np {np} {extra:?}: {p}");
            } else if extra.contains(&"0") && p["data_items_requested"].as_u64() > Some(0) {
                assert_eq!(completed, Some(true), "-np {np} {extra:?}: {p}");
            }
        }
        let summaries = stats["procs"].as_array().unwrap();
        let count = |k: &str| {
            summaries
                .iter()
                .map(|p| p[k].as_u64().unwrap())
                .sum::<u64>()
        };
        assert!(
            count("pixels") >= count("pixels_sent"),
            "-np {np} {extra:?}"
        );
        assert_eq!(
            count("pixels_sent") > 0,
            extra.contains(&"--pixel-batch"),
            "-np {np} {extra:?}: pixels sent in batches"
        );
        let ranks = stats["ranks"].as_array().unwrap();
        assert_eq!(ranks.len(), np);
        for (i, t) in ranks.iter().enumerate() {
            assert_eq!(t["rank"].as_u64(), Some(i as u64));
            // The rank's fixed cost is measured once MPI has started and
            // lies below its peak (Linux says both).
            if cfg!(target_os = "linux") {
                let (start, peak) = (
                    t["started_resident_bytes"].as_u64().unwrap(),
                    t["peak_resident_bytes"].as_u64().unwrap(),
                );
                assert!(0 < start && start <= peak, "{t}");
            }
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
/// epoch each, the records broadcast to every rank between them, the
/// hemispheres' rays and leak tests migrating between ranks, each pixel's
/// owner deciding its lookups in the sequential order) under MPI: the
/// sequential picture, bit for bit. With
/// `-aw 2`, the constant ambient past the last bounce is the cache's
/// moving average, which every rank must compute alike.
#[test]
fn mpirun_renders_two_bounces_as_the_sequential_renderer() {
    let d = tmpdir("ab2");
    let (rad, vf) = cornell(&d);
    let ab = [
        "-ab", "2", "-aa", ".2", "-ad", "32", "-as", "8", "-ar", "16", "-aw", "2",
    ];
    let want = sequential_picture(&d, &rad, &vf, &ab);
    // And the scene compiled: each rank reads only its own cells, with a
    // cache of 10%.
    let hrtc = d.join("cornell.hrtc").to_string_lossy().into_owned();
    let r = hybrid_rt(&["compile", &rad, "-o", &hrtc], &d, "compile");
    assert!(r.status.success(), "{}", r.stderr);
    for (np, scene, cache) in [(1, &rad, "100%"), (3, &rad, "100%"), (3, &hrtc, "10%")] {
        let out = d.join(format!("mpi{np}-{cache}.hdr"));
        let mut args = base(scene, &vf);
        args.extend(ab);
        args.extend([
            "--runtime",
            "mpi",
            "--cache",
            cache,
            "--time-limit",
            "200",
            "-o",
            out.to_str().unwrap(),
        ]);
        let r = mpirun(
            np,
            &args,
            &[],
            &d,
            &format!("ab2np{np}{}", cache.trim_end_matches('%')),
        );
        assert!(r.status.success(), "-np {np} {scene}: {}", r.stderr);
        assert!(
            std::fs::read(&out).unwrap() == want,
            "-np {np} {scene}: the picture differs from the sequential one"
        );
        // Rank 0 reports, once; more than one wave ran.
        let e = &r.stderr;
        let line = e
            .lines()
            .find(|l| l.starts_with("parallel render:"))
            .unwrap_or_else(|| panic!("-np {np}: no report: {e}"));
        assert!(
            line.contains(&format!("{np} processors, mpi runtime")),
            "{line}"
        );
        assert_eq!(e.matches("irradiance cache:").count(), 1, "{e}");
        assert!(!e.contains("irradiance cache: 1 waves"), "{e}");
    }
}

/// Diffuse inter-reflection without an irradiance cache runs in the
/// hybrid workload, the hemispheres' sample rays migrating between ranks
/// to the cells they need: the sequential picture under `mpirun -np 3`,
/// with two bounces (with a cache and with one that holds almost
/// nothing), and with super-samples, which each pixel's owner makes when
/// the last of a hemisphere's first samples is merged there.
#[test]
fn mpirun_migrates_hemisphere_rays_to_the_sequential_picture() {
    let d = tmpdir("ab2-hybrid");
    let (rad, vf) = cornell(&d);
    let two = ["-ab", "2", "-aa", "0", "-ad", "16", "-as", "0"];
    let sup = ["-ab", "1", "-aa", "0", "-ad", "64", "-as", "16"];
    for (ab, cache) in [(two, "100%"), (two, "10%"), (sup, "10%")] {
        let want = sequential_picture(&d, &rad, &vf, &ab);
        let what = format!("{} --cache {cache}", ab.join(" "));
        let out = d.join(format!("mpi{}-{}.hdr", cache.trim_end_matches('%'), ab[1]));
        let mut args = base(&rad, &vf);
        args.extend(ab);
        args.extend([
            "--runtime",
            "mpi",
            "--cache",
            cache,
            "--time-limit",
            "200",
            "-o",
            out.to_str().unwrap(),
        ]);
        let r = mpirun(3, &args, &[], &d, &format!("ab{}hybrid{cache}", ab[1]));
        assert!(r.status.success(), "{what}: {}", r.stderr);
        assert!(
            std::fs::read(&out).unwrap() == want,
            "{what}: the picture differs from the sequential one"
        );
        // No cache, no waves.
        assert!(!r.stderr.contains("irradiance cache:"), "{}", r.stderr);
    }
}

/// A data request tagged for the owner's MPI thread that finds no data
/// server there (one that arrives before the rank's run has installed it;
/// `no-server:1` keeps rank 1's off for the whole run) is answered by the
/// processor loop between steps: the same picture, every request answered
/// once, rank 1's processor serving in its own steps.
#[test]
fn a_data_request_before_the_server_is_installed_is_answered_between_steps() {
    let d = tmpdir("noserver");
    let (rad, vf) = cornell(&d);
    let want = sequential_picture(&d, &rad, &vf, &[]);
    let (out, json) = (d.join("mpi.hdr"), d.join("mpi.json"));
    let mut args = base(&rad, &vf);
    args.extend(["--runtime", "mpi", "--time-limit", "200"]);
    args.extend(["--complete-cache", "off", "--serve-data", "on-arrival"]);
    args.extend(["--parallel-stats", json.to_str().unwrap()]);
    args.extend(["-o", out.to_str().unwrap()]);
    let r = mpirun(
        2,
        &args,
        &[("HYBRID_SCHED_MPI_FAULT", "no-server:1")],
        &d,
        "noserver",
    );
    assert!(r.status.success(), "{}", r.stderr);
    assert!(
        std::fs::read(&out).unwrap() == want,
        "the picture differs from the sequential one"
    );
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let procs = stats["stats"]["procs"].as_array().unwrap();
    let sum = |k: &str| procs.iter().map(|p| p[k].as_u64().unwrap()).sum::<u64>();
    assert_eq!(sum("data_requests_served"), sum("data_requests_sent"));
    let p1 = &procs[1];
    assert!(p1["data_requests_served"].as_u64().unwrap() > 0, "{p1}");
    assert!(p1["time_ns"]["serving_data"].as_u64().unwrap() > 0, "{p1}");
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

/// Memory limits set by the operating system: a memory cgroup this test
/// creates (Linux's memory controller, version 1 or 2), in which every
/// process started through [`MemoryCgroups::wrapper`] gets a cgroup of its
/// own with a hard limit (no swap): a process that needs more is killed.
/// `None` where this process may not create one (CI's container runs the
/// tests as root, where it can).
struct MemoryCgroups {
    dir: PathBuf,
    v1: bool,
}

impl MemoryCgroups {
    fn create(tag: &str) -> Option<MemoryCgroups> {
        let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
        let name = format!("hybrid-rt-test-{}-{tag}", std::process::id());
        for line in own.lines() {
            let mut fields = line.splitn(3, ':');
            let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
            let path = path.trim_start_matches('/');
            let v1 = controllers.split(',').any(|c| c == "memory");
            let base = match (v1, controllers.is_empty()) {
                (true, _) => Path::new("/sys/fs/cgroup/memory").join(path),
                // Version 2: the memory controller must be enabled for the
                // children (possible at the root of a container's namespace).
                (false, true) => {
                    let base = Path::new("/sys/fs/cgroup").join(path);
                    let _ = std::fs::write(base.join("cgroup.subtree_control"), "+memory");
                    base
                }
                (false, false) => continue,
            };
            let dir = base.join(&name);
            if std::fs::create_dir(&dir).is_err() {
                continue;
            }
            let cgroups = MemoryCgroups { dir, v1 };
            if !v1 {
                let _ = std::fs::write(cgroups.dir.join("cgroup.subtree_control"), "+memory");
            }
            // A child must have a limit to set.
            let probe = cgroups.dir.join("probe");
            let usable =
                std::fs::create_dir(&probe).is_ok() && probe.join(cgroups.limit_file()).exists();
            let _ = std::fs::remove_dir(&probe);
            if usable {
                return Some(cgroups);
            }
        }
        None
    }

    fn limit_file(&self) -> &'static str {
        if self.v1 {
            "memory.limit_in_bytes"
        } else {
            "memory.max"
        }
    }

    /// The command prefix that starts a process in a new cgroup `name`
    /// (`name` followed by the MPI rank under `mpirun`) limited to `bytes`.
    fn wrapper(&self, name: &str, bytes: u64) -> Vec<String> {
        let no_swap = if self.v1 {
            r#"{ echo "$2" > "$d/memory.memsw.limit_in_bytes"; } 2>/dev/null"#
        } else {
            r#"{ echo 0 > "$d/memory.swap.max"; } 2>/dev/null"#
        };
        let script = format!(
            r#"d="$0/$1${{OMPI_COMM_WORLD_RANK:-}}"; mkdir "$d" && echo "$2" > "$d/{}" && {{ {no_swap}; true; }} && echo $$ > "$d/cgroup.procs" && shift 2 && exec "$@""#,
            self.limit_file()
        );
        vec![
            "sh".into(),
            "-c".into(),
            script,
            self.dir.to_string_lossy().into_owned(),
            name.into(),
            bytes.to_string(),
        ]
    }

    /// The most memory cgroup `name` was charged, in bytes, where the
    /// kernel keeps it.
    fn peak(&self, name: &str) -> Option<u64> {
        let file = if self.v1 {
            "memory.max_usage_in_bytes"
        } else {
            "memory.peak"
        };
        let text = std::fs::read_to_string(self.dir.join(name).join(file)).ok()?;
        text.trim().parse().ok()
    }
}

impl Drop for MemoryCgroups {
    fn drop(&mut self) {
        if let Ok(children) = std::fs::read_dir(&self.dir) {
            for child in children.flatten() {
                if child.path().is_dir() {
                    let _ = std::fs::remove_dir(child.path());
                }
            }
        }
        let _ = std::fs::remove_dir(&self.dir);
    }
}

/// A generated city, compiled: under MPI every rank holds the replicated
/// part and reads only its own cells. Each rank runs under a memory limit
/// the operating system enforces, two thirds of the whole scene's render's
/// peak (the whole scene's render is killed under it), and the
/// picture is the sequential render's of the whole scene. Where no limit
/// can be set (no writable memory cgroup), every rank's peak as the
/// operating system measured it must stay below the whole scene's.
#[test]
fn ranks_of_a_compiled_scene_render_under_a_memory_limit_the_whole_scene_exceeds() {
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
    let seq_s = seq.to_str().unwrap();
    let mut whole_args = vec!["render", hrtc_s, "--peak-memory", "-o", seq_s];
    whole_args.extend(size);
    let r = hybrid_rt(&whole_args, &d, "whole");
    assert!(r.status.success(), "{}", r.stderr);
    let whole = peaks(&r.stderr);
    assert_eq!(whole.len(), 1, "{}", r.stderr);
    let whole = whole[0].1;
    let want = std::fs::read(&seq).unwrap();
    std::fs::remove_file(&seq).unwrap();

    let cgroups = MemoryCgroups::create("held");
    let limit = whole * 1024 / 3 * 2;
    let wrapper = match &cgroups {
        Some(cgroups) => {
            // The limit bites: the whole scene's render cannot run under it.
            let mut cmd = Command::new(&cgroups.wrapper("whole", limit)[0]);
            cmd.args(&cgroups.wrapper("whole", limit)[1..])
                .arg(env!("CARGO_BIN_EXE_hybrid-rt"))
                .args(&whole_args);
            let r = run_limited(cmd, &d, "whole-limited");
            assert!(
                !r.status.success() && !seq.exists(),
                "the whole scene's render ran under {limit} bytes: the limit tests nothing\n{}",
                r.stderr
            );
            eprintln!(
                "the whole scene's render, peak {whole} KiB, fails under a limit of {} KiB ({})",
                limit / 1024,
                r.status
            );
            cgroups.wrapper("rank", limit)
        }
        None => {
            eprintln!(
                "no memory cgroup can be created here: the ranks run without a limit, \
                 their measured peaks are checked"
            );
            Vec::new()
        }
    };

    // Four ranks: each holds the skeleton, a quarter of the objects and
    // its cache (two ranks each hold half the scene besides the skeleton,
    // about what the whole scene's renderer holds).
    let np = 4;
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
    let r = mpirun_wrapped(np, &wrapper, &args, &[], &d, &format!("held{np}"));
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
        let charged = cgroups
            .as_ref()
            .and_then(|c| c.peak(&format!("rank{rank}")))
            .map_or("no limit".into(), |b| {
                format!(
                    "{} KiB charged under the limit of {} KiB",
                    b / 1024,
                    limit / 1024
                )
            });
        eprintln!(
            "-np {np}: rank {rank} peaked at {kib} KiB resident ({charged}); the whole scene's render at {whole} KiB"
        );
        assert!(
            kib < whole,
            "-np {np}: rank {rank} peaked at {kib} KiB, not below the whole scene's {whole} KiB"
        );
    }
}
