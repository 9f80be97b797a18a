//! Merges that start work ([`Workload::merge_in`], `SEMANTICS.md` section
//! 11): what a merge emits runs like any step's emissions, on every
//! runtime, and the accumulators equal the sequential run's.

use super::*;
use crate::runtime::sim::{run_sim, CostModel, Network, Sim};

fn spawning() -> Mini {
    Mini {
        merge_spawns: true,
        roots: 16,
        ..Mini::default()
    }
}

/// Follow-ups merged: the keys of results of work that merges started.
fn follow_ups(r: &RunReport<Mini>) -> usize {
    all_keys(r).keys().filter(|k| *k & FOLLOW_UP != 0).count()
}

/// Under random interleavings, with every policy, caches from one byte to
/// none and few credits, depth first or not: every task once, the
/// sequential results, and follow-ups among them.
#[test]
fn merges_that_start_work_match_sequential_under_random_interleavings() {
    let w = spawning();
    let seq = run_sequential(&w, 3).expect("sequential run");
    let started = seq
        .procs
        .iter()
        .flatten()
        .filter(|(k, _)| *k & FOLLOW_UP != 0);
    assert!(started.count() > 0, "the sequential run starts follow-ups");
    let item = (24 + 8 * w.words) as u64;
    for newest_first in [false, true] {
        let w = Mini {
            newest_first,
            ..w.clone()
        };
        for procs in 1..=4 {
            for policy in Policy::ALL {
                for cache in [Some(1), Some(3 * item), None] {
                    let cfg = Config::new(procs)
                        .with_policy(policy)
                        .with_cache_bytes(cache)
                        .with_credits(2);
                    let what = format!("{procs} procs, {policy}, cache {cache:?}");
                    for seed in 0..3 {
                        let r = run_lockstep(Arc::new(w.clone()), &cfg, seed * 7 + procs as u64)
                            .unwrap_or_else(|e| panic!("{what}: {e}"));
                        check_against_sequential(&w, &r);
                        assert!(follow_ups(&r) > 0, "{what}: no follow-up");
                    }
                }
            }
        }
    }
}

/// On threads and the simulated cluster as well.
#[test]
fn merges_that_start_work_match_sequential_on_threads_and_the_simulator() {
    let w = spawning();
    for procs in [1, 2, 4] {
        let cfg = Config::new(procs)
            .with_cache_bytes(Some(200))
            .with_credits(2);
        let r = run_threads(Arc::new(w.clone()), &cfg).expect("threads run");
        check_against_sequential(&w, &r);
        assert!(follow_ups(&r) > 0);
        let mut cost = CostModel::default();
        cost.unit_ns.insert("work".into(), 50_000.0);
        let sim = Sim::new(cost, Network::parsytec_cc());
        let r = run_sim(Arc::new(w.clone()), &cfg, &sim).expect("simulated run");
        check_against_sequential(&w, &r);
        assert!(follow_ups(&r) > 0);
    }
}
