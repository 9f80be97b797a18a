//! The data store's completion ([`crate::Config::complete_cache`]), driven
//! directly, and asked for by a workload ([`crate::Ctx::complete_cache`]).

use std::sync::Arc;

use super::{check_against_sequential, run_lockstep, Mini};
use crate::protocol::{Addr, Placement};
use crate::store::{DataStore, Directory};
use crate::{Config, Policy, Workload};

const MIB: u64 = 1 << 20;

fn directory() -> Arc<Directory<Mini>> {
    // Processor 0 holds nothing; 1 and 2 hold items of these accounted
    // sizes, one of them larger than a completion request's bound.
    let items = [(1, 1, 5), (2, 1, 5), (3, 1, 1), (4, 2, 20), (5, 2, 1)];
    let placement = items
        .iter()
        .map(|&(id, owner, mib)| Placement {
            id,
            owner,
            bytes: mib * MIB,
        })
        .collect();
    Arc::new(Directory::build(placement, 3).unwrap())
}

/// Every item held elsewhere is asked for once, from its owner, in
/// requests of at most 8 MiB each (an item larger than that alone), and
/// only once.
#[test]
fn completion_asks_for_everything_held_elsewhere_in_bounded_requests() {
    let mut s = DataStore::<Mini>::new(0, Vec::new(), directory(), None, None, Some(0)).unwrap();
    let requests = s.complete().expect("at 0 a store completes at once");
    assert_eq!(
        requests,
        vec![(1, vec![1]), (1, vec![2, 3]), (2, vec![4]), (2, vec![5])]
    );
    assert!(s.complete().is_none(), "a store completes once");
}

/// A cache with a budget, a fetch limit or no percentage: never.
#[test]
fn completion_needs_a_cache_without_budget_and_no_fetch_limit() {
    for (cache, limit, percent) in [
        (Some(64 * MIB), None, Some(0)),
        (None, Some(MIB), Some(0)),
        (None, None, None),
    ] {
        let mut s =
            DataStore::<Mini>::new(0, Vec::new(), directory(), cache, limit, percent).unwrap();
        assert!(s.complete().is_none(), "{cache:?} {limit:?} {percent:?}");
    }
}

/// A workload that asks for completion (here: a walk that must migrate)
/// gets it where completion is configured, whatever the percentage, and
/// nowhere else; each item is asked for once, and the results are the
/// sequential ones.
#[test]
fn a_workload_asks_for_completion_where_it_is_configured() {
    // Many items, so no processor asks for all of them on its own.
    let w = Mini {
        items: 400,
        roots: 30,
        hops: 6,
        complete_on_migrate: true,
        ..Mini::default()
    };
    let procs = 3;
    let placement = w.placement(procs);
    for policy in Policy::ALL {
        for (cache, limit, percent, completes) in [
            (None, None, Some(100), true),
            (None, None, None, false),
            (Some(1 << 20), None, Some(100), false),
            (None, Some(1 << 20), Some(100), false),
        ] {
            let cfg = Config::new(procs)
                .with_policy(policy)
                .with_cache_bytes(cache)
                .with_fetch_limit(limit)
                .with_complete_cache(percent);
            let what = format!("{policy}, cache {cache:?}, limit {limit:?}, at {percent:?}");
            let r = run_lockstep(Arc::new(w.clone()), &cfg, 5).expect("terminates");
            check_against_sequential(&w, &r);
            let mut migrated_from = 0;
            for p in &r.stats.procs {
                let Addr::Proc(id) = p.addr else { continue };
                let elsewhere = placement.iter().filter(|pl| pl.owner != id).count();
                let asked = p.data_items_requested as usize;
                assert!(asked <= elsewhere, "{what}: p{id} asked twice");
                if p.tasks.migrations > 0 {
                    migrated_from += 1;
                    assert_eq!(p.cache_completed, completes, "{what}: p{id}");
                }
                if p.cache_completed {
                    assert_eq!(asked, elsewhere, "{what}: p{id} holds everything");
                }
                assert!(completes || !p.cache_completed, "{what}: p{id}");
            }
            assert!(migrated_from > 0, "{what}: no walk migrated");
        }
    }
}
