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

/// A reply in parts ([`crate::server::DataServer::serve_parts`], the MPI
/// thread's): the request's items in order, each part within the bound
/// unless one item alone exceeds it, and every part counted as a basic
/// message sent with the request's receipt (termination detection's
/// totals stay apart until the last part arrives).
#[test]
fn a_reply_in_parts_keeps_the_order_the_bound_and_the_counts() {
    use super::Item;
    use crate::protocol::message::{Msg, Packet};
    use crate::server::DataServer;
    // Items of 24 + 8 n bytes: 3 -> 48, 7 -> 80, 1 -> 32, 20 -> 184.
    let words = [
        (10u32, 3usize),
        (11, 7),
        (12, 1),
        (13, 20),
        (14, 1),
        (15, 3),
    ];
    let items: crate::resident::Resident<u32, Item> = words
        .iter()
        .map(|&(id, n)| (id, Item(vec![u64::from(id); n])))
        .collect();
    let server = DataServer::<Mini>::new(1, Arc::new(items));
    let request =
        |ids: Vec<u32>| Packet::single(Addr::Proc(0), Addr::Proc(1), Msg::<Mini>::DataRequest(ids));
    let ids: Vec<u32> = words.iter().map(|w| w.0).collect();
    let parts = server.serve_parts(request(ids.clone()), 130).unwrap();
    let got: Vec<Vec<u32>> = parts
        .iter()
        .map(|p| match &p.items[..] {
            [Msg::DataReply(items)] => items.iter().map(|(id, _)| *id).collect(),
            other => panic!("not one data reply: {other:?}"),
        })
        .collect();
    // 48 + 80 = 128 <= 130; 32 alone (32 + 184 > 130); 184 alone (over the
    // bound by itself); 32 + 48 = 80.
    assert_eq!(got, vec![vec![10, 11], vec![12], vec![13], vec![14, 15]]);
    assert!(parts.iter().all(|p| p.to == Addr::Proc(0)));
    assert_eq!(
        server.basic(),
        (4, 1),
        "four parts sent, one request received"
    );
    // Unbounded: one reply with everything, as `serve` gives it.
    let whole = server.serve(request(ids)).unwrap();
    assert!(matches!(&whole.items[..], [Msg::DataReply(items)] if items.len() == 6));
    assert_eq!(server.basic(), (5, 2));
    // An empty request still gets its (empty) reply.
    let empty = server.serve_parts(request(Vec::new()), 130).unwrap();
    assert_eq!(empty.len(), 1);
    assert_eq!(server.basic(), (6, 3));
}

/// What a cache charges is the workload's ([`Workload::cache_charge`]):
/// charged eight times their bytes, items a budget holds four of by
/// placement do not fit it at all, so no task fetches (every one that
/// needs data from elsewhere runs as data-parallel work), while charged
/// their bytes the same budget caches; the results are the sequential ones
/// either way, and no cache is ever charged more than its budget.
#[test]
fn a_cache_charges_what_the_workload_says() {
    let budget = 4 * 56;
    for charge in [1u64, 8] {
        let w = Mini {
            items: 48,
            roots: 20,
            charge,
            ..Mini::default()
        };
        for policy in Policy::ALL {
            let cfg = Config::new(3)
                .with_policy(policy)
                .with_cache_bytes(Some(budget));
            let r = run_lockstep(Arc::new(w.clone()), &cfg, 5).expect("terminates");
            check_against_sequential(&w, &r);
            let what = format!("{policy}, charged {charge} times");
            let mut cached = 0;
            for p in &r.stats.procs {
                assert!(p.memory.cached_bytes <= budget, "{what}: {p:?}");
                cached += p.memory.cached_bytes;
            }
            assert_eq!(cached == 0, charge == 8, "{what}: {cached} bytes cached");
        }
    }
}
