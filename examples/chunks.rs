//! The book's running example on a runtime chosen on the command line,
//! checked against the sequential reference.
//!
//! `cargo run -p hybrid-examples --example chunks -- --runtime sim --procs 4`;
//! built with `--features mpi`, `mpirun -np 4 target/debug/examples/chunks
//! --runtime mpi` runs one processor per rank.

use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;
use hybrid_examples::Chunks;
use hybrid_sched::{
    run_sequential, Config, CostModel, Lockstep, Network, Policy, Runtime, Sequential, Sim, Threads,
};

#[derive(Parser, Debug)]
#[command(about = "Run the book's running example and check it against a sequential run")]
struct Args {
    /// Runtime: threads, sequential, lockstep, sim or mpi (mpi needs the
    /// `mpi` feature and `mpirun`).
    #[arg(long, default_value = "threads")]
    runtime: String,
    /// Worker processors (under mpi: the number of ranks).
    #[arg(long, default_value_t = 3)]
    procs: usize,
    /// Child-task policy: local, via-master, to-origin, round-robin, load-aware.
    #[arg(long, default_value = "local")]
    policy: Policy,
    /// Cache budget per processor in bytes (default: unlimited; below 312
    /// every query falls back to a walk).
    #[arg(long)]
    cache_bytes: Option<u64>,
    /// Root queries spawn child queries.
    #[arg(long)]
    child_queries: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let workload = Chunks {
        child_queries: args.child_queries,
    };
    let runtime: Box<dyn Runtime<Chunks>> = match args.runtime.as_str() {
        "threads" => Box::new(Threads),
        "sequential" => Box::new(Sequential),
        "lockstep" => Box::new(Lockstep::new(1)),
        "sim" => Box::new(Sim::new(CostModel::default(), Network::ten_gbe())),
        #[cfg(feature = "mpi")]
        "mpi" => {
            let world = match hybrid_sched::runtime::mpi::init() {
                Ok(w) => w,
                Err(e) => {
                    eprintln!("error: cannot start MPI: {e}");
                    return ExitCode::FAILURE;
                }
            };
            if args.procs != world.size {
                eprintln!(
                    "note: {} ranks, so {} processors (not {})",
                    world.size, world.size, args.procs
                );
            }
            Box::new(hybrid_sched::runtime::mpi::Mpi)
        }
        other => {
            eprintln!(
                "error: unknown runtime '{other}' (expected threads, sequential, lockstep, sim{})",
                if cfg!(feature = "mpi") {
                    " or mpi"
                } else {
                    "; mpi needs --features mpi"
                }
            );
            return ExitCode::FAILURE;
        }
    };
    #[cfg(feature = "mpi")]
    let procs = hybrid_sched::runtime::mpi::world().map_or(args.procs, |w| w.size);
    #[cfg(not(feature = "mpi"))]
    let procs = args.procs;
    let config = Config::new(procs)
        .with_policy(args.policy)
        .with_cache_bytes(args.cache_bytes);
    let report = match runtime.run_blocking(Arc::new(workload), &config) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            #[cfg(feature = "mpi")]
            if hybrid_sched::runtime::mpi::world().is_some() {
                hybrid_sched::runtime::mpi::abort(1);
            }
            return ExitCode::FAILURE;
        }
    };
    if !report.is_root() {
        // Another MPI rank: rank 0 holds the results.
        return ExitCode::SUCCESS;
    }
    let reference = match run_sequential(&workload, procs) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let agree = report.master == reference.master && report.procs == reference.procs;
    println!(
        "chunks on {} ({procs} procs, policy {}): master {:?}, {} fallbacks, {} migrations, {} items fetched",
        runtime.name(),
        args.policy,
        report.master,
        report.stats.sum(|p| p.tasks.fallbacks),
        report.stats.sum(|p| p.tasks.migrations),
        report.stats.sum(|p| p.data_items_requested),
    );
    if let Some(timeline) = report.timeline() {
        println!(
            "simulated: {:.1} µs of virtual time, {} actors on the timeline",
            report.stats.elapsed_ns as f64 / 1e3,
            timeline.actors.len()
        );
    }
    if let Some(ranks) = report.ranks() {
        println!("{} ranks reported their traffic", ranks.len());
    }
    println!(
        "{} the sequential reference",
        if agree { "equals" } else { "DIFFERS FROM" }
    );
    if agree {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
