//! Shared helpers for the integration tests.

use std::sync::mpsc;
use std::time::Duration;

use hybrid_examples::{combined, Blocks, BlocksAcc, BlocksParams};
use hybrid_sched::{run_sequential, RunReport};

/// Runs `f` on its own thread and fails the test if it does not return within
/// `limit` (a hang guard; the runtime's own time limit should fire first).
pub fn guarded<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(limit) {
        Ok(v) => v,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("run did not finish within {limit:?}: hang"),
        Err(mpsc::RecvTimeoutError::Disconnected) => match handle.join() {
            Err(p) => std::panic::resume_unwind(p),
            Ok(()) => unreachable!("the thread sends before it ends"),
        },
    }
}

/// A small blocks workload (fast in debug builds).
pub fn small(seed: u64) -> BlocksParams {
    BlocksParams {
        seed,
        blocks: 40,
        min_words: 8,
        max_words: 64,
        roots: 24,
        max_select: 5,
        max_children: 2,
        max_depth: 2,
        max_walks: 2,
        walk_len: 4,
        ..BlocksParams::default()
    }
}

/// Asserts that a parallel report equals the sequential run of the same
/// workload: identical accumulators at every processor and the master, and
/// every task's result merged exactly once.
pub fn assert_matches_sequential(w: &Blocks, report: &RunReport<Blocks>, what: &str) {
    let seq = run_sequential(w, report.procs.len()).expect("sequential run");
    let all = |r: &RunReport<Blocks>| -> BlocksAcc { combined(r.procs.iter().chain([&r.master])) };
    let (par_all, seq_all) = (all(report), all(&seq));
    if let Some((k, n)) = par_all.seen.iter().find(|(_, &n)| n != 1) {
        panic!("{what}: task {k:#x} merged {n} times");
    }
    assert_eq!(
        par_all.seen.keys().collect::<Vec<_>>(),
        seq_all.seen.keys().collect::<Vec<_>>(),
        "{what}: different sets of tasks ran"
    );
    assert_eq!(
        report.procs, seq.procs,
        "{what}: per-processor results differ"
    );
    assert_eq!(report.master, seq.master, "{what}: master results differ");
    assert!(seq_all.count > 0, "{what}: the workload did nothing");
}
