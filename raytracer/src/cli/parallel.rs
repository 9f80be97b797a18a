//! `hybrid-rt render --procs N ...`: options and the per-processor report.

use std::fmt::Write as _;
use std::time::Duration;

use hybrid_sched::{Class, Network, Policy, State};

use super::args::ParallelArgs;
use super::common::usage;
use crate::parallel::Work;
use crate::parallel::{ParallelOptions, ParallelRender, RuntimeKind, WorkloadOptions};
use crate::Result;

/// The parallel options when the render is parallel: `--procs` is given,
/// or `--runtime mpi` (then `--procs` defaults to the number of ranks and
/// must equal it if given). Starts MPI for `--runtime mpi`.
pub(super) fn resolve(a: &ParallelArgs) -> Result<Option<ParallelOptions>> {
    // Without --procs the render is sequential unless --runtime says mpi.
    let runtime = RuntimeKind::from(a.runtime);
    if runtime != RuntimeKind::Mpi {
        return a.procs.map(|n| options(a, n)).transpose();
    }
    let (_, ranks) = mpi_world()?;
    match a.procs {
        Some(n) if n != ranks => Err(usage(format!(
            "--procs {n} with --runtime mpi: there is one processor per MPI rank and this job has {ranks}; leave --procs out or run mpirun -np {n}"
        ))),
        _ => options(a, ranks).map(Some),
    }
}

#[cfg(feature = "mpi")]
fn mpi_world() -> Result<(usize, usize)> {
    crate::parallel::mpi_world()
}

#[cfg(not(feature = "mpi"))]
fn mpi_world() -> Result<(usize, usize)> {
    Err(usage(
        "--runtime mpi is not available in this build (build hybrid-rt with --features mpi)",
    ))
}

/// Parses the parallel flags for `procs` processors.
pub(super) fn options(a: &ParallelArgs, procs: usize) -> Result<ParallelOptions> {
    if procs == 0 {
        return Err(usage("--procs 0: at least one processor is needed"));
    }
    if a.tile == Some(0) {
        return Err(usage("--tile 0: tiles must be at least one pixel wide"));
    }
    if a.threads == Some(0) {
        return Err(usage("--threads 0: at least one thread is needed"));
    }
    let time_limit = match a.time_limit {
        None => None,
        Some(s) if s.is_finite() && s > 0.0 && s < 1e9 => Some(Duration::from_secs_f64(s)),
        Some(s) => {
            return Err(usage(format!(
                "--time-limit {s}: expected a positive number of seconds"
            )))
        }
    };
    let policy = Policy::from(a.policy);
    let network = Network::from(a.network);
    if a.credits == 0 {
        return Err(usage("--credits 0: at least one credit per link is needed"));
    }
    Ok(ParallelOptions {
        procs,
        runtime: a.runtime.into(),
        policy,
        cache: a
            .cache
            .parse()
            .map_err(|e| usage(format!("--cache: {e}")))?,
        fetch_limit: a
            .fetch_limit
            .parse()
            .map_err(|e| usage(format!("--fetch-limit: {e}")))?,
        complete_cache: a.complete_cache.0,
        data_service: a.serve_data.into(),
        workload: WorkloadOptions {
            tile: a.tile.unwrap_or(WorkloadOptions::default().tile),
            shadow_dp_below: a.shadow_dp_below,
            distribution: a.distribution.into(),
            clip_cache: a.clip_cache,
            inline_local_shadows: a.inline_shadows,
            local_kernel: a.local_kernel,
            tail_tiles: a.tail_tiles,
            pixel_batch: a.pixel_batch,
        },
        threads: a.threads,
        time_limit,
        network,
        sim_seed: 0,
        credits: a.credits,
        flight_bytes: a.flight_bytes,
        prefetch_work: !a.no_prefetch,
        ambient_records: Default::default(),
    })
}

fn pct(part: u64, whole: u64) -> f64 {
    if whole == 0 {
        0.0
    } else {
        100.0 * part as f64 / whole as f64
    }
}

/// A per-processor table of the run: where the time went, what ran where,
/// the cache, the traffic.
pub fn summary(r: &ParallelRender) -> String {
    let mut s = String::new();
    let cache = match r.cache_bytes {
        Some(b) => format!(
            "{:.1} KiB per processor ({:.1}% of {:.1} KiB of cell data)",
            b as f64 / 1024.0,
            pct(b, r.data_bytes),
            r.data_bytes as f64 / 1024.0
        ),
        None => format!(
            "unlimited ({:.1} KiB of cell data)",
            r.data_bytes as f64 / 1024.0
        ),
    };
    let cache = match r.fetch_limit_bytes {
        Some(b) => format!("{cache}, fetch limit {:.1} KiB a task", b as f64 / 1024.0),
        None => cache,
    };
    let _ = writeln!(
        s,
        "parallel render: {} processors, {} runtime, policy {}, distribution {}, tiles {}px, cache {}",
        r.options.procs,
        r.stats.runtime,
        r.options.policy,
        r.options.workload.distribution,
        r.options.workload.tile,
        cache
    );
    let _ = writeln!(
        s,
        "{:>4} {:>10} {:>9} {:>9} {:>6} {:>6} {:>6} {:>6} {:>6} {:>7} {:>8} {:>7} {:>9} {:>9} {:>6} {:>8} {:>9}",
        "proc",
        "resid KiB",
        "copy KiB",
        "hier KiB",
        "exec%",
        "clip%",
        "wait%",
        "idle%",
        "comm%",
        "tiles",
        "dd tasks",
        "dp migr",
        "rays",
        "shadow",
        "hit%",
        "msgs",
        "KiB sent"
    );
    for (i, p) in r.stats.procs.iter().enumerate() {
        let t = &p.time_ns;
        let total = t.total();
        let comm = t.get(State::Sending) + t.get(State::Receiving) + t.get(State::ServingData);
        let w = |k: Work| p.work.get(k.name()).copied().unwrap_or(0);
        let rays = w(Work::RaysPrimary)
            + w(Work::RaysReflection)
            + w(Work::RaysRefraction)
            + w(Work::RaysPassThrough);
        let sent = p.sent.total();
        let _ = writeln!(
            s,
            "{:>4} {:>10.1} {:>9} {:>9} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>7} {:>8} {:>7} {:>9} {:>9} {:>6} {:>8} {:>9.1}",
            i,
            r.procs.get(i).map_or(0, |x| x.resident_bytes) as f64 / 1024.0,
            // Unknown here for another rank's part of a distributed scene.
            match r.procs.get(i) {
                Some(x) if !x.measured => "-".to_string(),
                x => format!("{:.1}", x.map_or(0, |x| x.copy_bytes) as f64 / 1024.0),
            },
            match r.procs.get(i).and_then(|x| x.hierarchy_bytes) {
                Some(b) => format!("{:.1}", b as f64 / 1024.0),
                None => "-".to_string(),
            },
            pct(t.get(State::Executing), total),
            pct(t.get(State::Selecting), total),
            pct(t.get(State::WaitingData), total),
            pct(t.get(State::Idle), total),
            pct(comm, total),
            p.tasks.roots,
            p.tasks.demand_driven,
            p.tasks.migrations,
            rays,
            w(Work::ShadowTested),
            p.cache_hit_rate()
                .map_or("-".to_string(), |h| format!("{:.1}", 100.0 * h)),
            sent.messages,
            sent.bytes as f64 / 1024.0,
        );
    }
    let st = &r.stats;
    let data_msgs = st.sum(|p| p.sent.get(Class::Data).messages);
    let _ = writeln!(
        s,
        "total: {:.3} s; {} packets ({} messages, {} data messages); {} data items fetched; {} migrations; {} shadow bundles data-parallel; {} clip misses",
        r.render_s,
        st.packets_sent(),
        st.sum(|p| p.sent.total().messages) + st.master.sent.total().messages,
        data_msgs,
        st.sum(|p| p.data_items_requested),
        st.sum(|p| p.tasks.migrations),
        r.work(Work::ShadowBundlesDp),
        r.work(Work::ClipMisses),
    );
    if let (Some(b), true) = (r.peak_resident_bytes, r.ranks.is_empty()) {
        let _ = writeln!(
            s,
            "peak resident memory of this process (every processor of the run together, as the OS measured it): {:.1} MiB",
            b as f64 / (1024.0 * 1024.0)
        );
    }
    if let Some(v) = r.simulated_s {
        let _ = writeln!(
            s,
            "simulated on {}: {:.4} s of virtual time (times above are virtual; the simulation took {:.3} s)",
            r.options.network.name, v, r.render_s
        );
    }
    if !r.ranks.is_empty() {
        let _ = writeln!(
            s,
            "MPI wire traffic (encoded bytes; the master runs on rank 0), the most encoded bytes each rank held for the wire at once (its message buffers: sends not yet delivered, receipts not yet decoded) and its peak memory (as the OS measured it; bound: 1.3 x (its resident share + the cache budget) + the octree skeleton, issue 19's target without its few MiB; start: the peak once MPI had started, before the scene was read, the process's fixed cost):\n{:>4} {:>9} {:>10} {:>9} {:>10} {:>9} {:>10} {:>13} {:>8} {:>9} {:>9} {:>9} {:>9}",
            "rank",
            "msgs sent",
            "KiB sent",
            "msgs recv",
            "KiB recv",
            "data recv",
            "data KiB",
            "data KiB acct",
            "local",
            "wire MiB",
            "start MiB",
            "peak MiB",
            "bound MiB"
        );
        for t in &r.ranks {
            // What the processor on this rank accounted for the data it
            // received (the cells' object bytes).
            let accounted = r
                .stats
                .procs
                .get(t.rank)
                .map_or(0, |p| p.received.get(Class::Data).bytes);
            let share = r
                .stats
                .procs
                .get(t.rank)
                .map_or(0, |p| p.memory.resident_bytes);
            // No bound with an unlimited cache.
            let bound = r.cache_bytes.map_or("-".to_string(), |c| {
                let b = 1.3 * (share + c) as f64 + r.octree_bytes as f64;
                format!("{:.1}", b / (1024.0 * 1024.0))
            });
            let _ = writeln!(
                s,
                "{:>4} {:>9} {:>10.1} {:>9} {:>10.1} {:>9} {:>10.1} {:>13.1} {:>8} {:>9.1} {:>9.1} {:>9.1} {:>9}",
                t.rank,
                t.messages_sent,
                t.bytes_sent as f64 / 1024.0,
                t.messages_received,
                t.bytes_received as f64 / 1024.0,
                t.data_messages_received,
                t.data_bytes_received as f64 / 1024.0,
                accounted as f64 / 1024.0,
                t.local_packets,
                t.peak_wire_bytes as f64 / (1024.0 * 1024.0),
                t.started_resident_bytes as f64 / (1024.0 * 1024.0),
                t.peak_resident_bytes as f64 / (1024.0 * 1024.0),
                bound
            );
        }
    }
    if let Some(a) = &r.ambient {
        let c = &a.counts;
        let _ = writeln!(
            s,
            "irradiance cache: {} waves, {} lookups ({} interpolated, {} fell back to -av), {} hemispheres, {} leak tests ({} lookups sent theirs away), {} records",
            a.waves,
            c.lookups,
            c.hits,
            c.fallbacks,
            c.hemispheres,
            r.work(Work::LeakTests),
            r.work(Work::LeakJobs),
            a.records
        );
    }
    s
}
