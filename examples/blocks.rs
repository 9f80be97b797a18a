//! The blocks workload on the threads runtime, checked against the sequential
//! reference.
//!
//! `cargo run --example blocks -- --procs 8 [--policy P] [--cache-bytes N]`

use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use clap::Parser;
use hybrid_examples::{breakdown_table, Blocks, BlocksParams, Distribution};
use hybrid_sched::{run_sequential, run_threads, Config, Policy};

#[derive(Parser, Debug)]
#[command(about = "Run the blocks workload in parallel and check it against a sequential run")]
struct Args {
    /// Worker processors.
    #[arg(long, default_value_t = 8)]
    procs: usize,
    /// Child-task policy: local, via-master, to-origin, round-robin.
    #[arg(long, default_value = "local")]
    policy: Policy,
    /// Cache budget per processor in bytes (default: unlimited).
    #[arg(long)]
    cache_bytes: Option<u64>,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Number of data blocks.
    #[arg(long, default_value_t = 256)]
    blocks: u32,
    /// Number of root tasks.
    #[arg(long, default_value_t = 512)]
    roots: u32,
    /// Data placement: round-robin, ranges or hotspot.
    #[arg(long, default_value = "round-robin")]
    distribution: String,
    /// Computation per block read (folds of the block).
    #[arg(long, default_value_t = 16)]
    rounds: u32,
    /// Send every message on its own.
    #[arg(long)]
    no_bundling: bool,
    /// Credits per link (flow control).
    #[arg(long, default_value_t = 64)]
    credits: usize,
    /// Write the statistics as JSON to this file.
    #[arg(long)]
    stats_json: Option<std::path::PathBuf>,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let distribution = match args.distribution.as_str() {
        "round-robin" => Distribution::RoundRobin,
        "ranges" => Distribution::Ranges,
        "hotspot" => Distribution::Hotspot,
        other => {
            eprintln!(
                "error: unknown distribution '{other}' (expected round-robin, ranges or hotspot)"
            );
            return ExitCode::FAILURE;
        }
    };
    let workload = Blocks::new(BlocksParams {
        seed: args.seed,
        blocks: args.blocks,
        roots: args.roots,
        distribution,
        rounds: args.rounds,
        ..BlocksParams::default()
    });
    let mut config = Config::new(args.procs)
        .with_policy(args.policy)
        .with_cache_bytes(args.cache_bytes)
        .with_bundling(!args.no_bundling)
        .with_credits(args.credits)
        .with_time_limit(Duration::from_secs(300));
    config.threads = None;
    let sequential = match run_sequential(&workload, args.procs) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let parallel = match run_threads(Arc::new(workload.clone()), &config) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let agree = parallel.procs == sequential.procs && parallel.master == sequential.master;
    let tasks: u64 = parallel.procs.iter().map(|a| a.count).sum::<u64>() + parallel.master.count;
    println!(
        "blocks: {} procs, policy {}, cache {}, {} blocks ({} bytes, largest {}), {} roots",
        args.procs,
        args.policy,
        args.cache_bytes
            .map_or("unlimited".to_string(), |b| format!("{b} bytes")),
        args.blocks,
        workload.total_bytes(),
        workload.largest_block_bytes(),
        args.roots
    );
    println!(
        "parallel {} sequential: {} results, checksum {:016x} (sequential {:016x})",
        if agree { "==" } else { "!=" },
        tasks,
        hybrid_examples::combined(parallel.procs.iter().chain([&parallel.master])).sum,
        hybrid_examples::combined(sequential.procs.iter().chain([&sequential.master])).sum,
    );
    println!(
        "elapsed {:.1} ms (threads), {:.1} ms (sequential); {} packets sent",
        parallel.stats.elapsed_ns as f64 / 1e6,
        sequential.stats.elapsed_ns as f64 / 1e6,
        parallel.stats.packets_sent()
    );
    print!("{}", breakdown_table(&parallel.stats));
    if let Some(path) = args.stats_json {
        if let Err(e) = std::fs::write(&path, parallel.stats.to_json()) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    if agree {
        ExitCode::SUCCESS
    } else {
        eprintln!("error: the parallel results differ from the sequential run");
        ExitCode::FAILURE
    }
}
