//! Tests named by `SEMANTICS.md` for what its sections say exactly: §3
//! (priority order inside a processor) and §6 (progress).

use super::*;
use crate::processor::{Processor, Step};
use crate::protocol::message::DpEnvelope;
use crate::stats::State;

/// §3: control, data and results first; then a demand-driven task whose
/// data has arrived (it holds cache pins), before a data-parallel task
/// that was already waiting; fresh demand-driven work last.
#[test]
fn ready_demand_driven_tasks_run_before_waiting_data_parallel_tasks() {
    let w = Arc::new(Mini::default());
    let cfg = Config::new(2);
    let mut p = Processor::new(0, w.clone(), &cfg).unwrap();
    // A root task whose selection needs an item of processor 1.
    let task = (1..)
        .map(|k| Task {
            key: k << 20,
            depth: 0,
        })
        .find(|t| w.selection(t).iter().any(|id| id % 2 == 1))
        .unwrap();
    let env = DdEnvelope {
        task,
        origin: None,
        handout: true,
        root: false,
    };
    p.deliver(Packet::single(Addr::Master, Addr::Proc(0), Msg::Dd(env)), 0);
    assert_eq!(p.step(1).unwrap(), Step::Worked(State::Selecting));
    let request = p
        .take_packets(1)
        .into_iter()
        .flat_map(|pk| pk.items)
        .find_map(|m| match m {
            Msg::DataRequest(ids) => Some(ids),
            _ => None,
        })
        .expect("the task waits for processor 1's data");
    // A data-parallel walk over local data arrives first, then the reply.
    let walk = Walk {
        key: 5,
        path: vec![0, 2],
        pos: 0,
        acc: 0,
        finish: None,
    };
    let dp = Msg::Dp(DpEnvelope {
        task: walk,
        origin: Some(1),
    });
    p.deliver(Packet::single(Addr::Proc(1), Addr::Proc(0), dp), 2);
    let remote: BTreeMap<u32, Item> = w.load_partition(1, 2).into_iter().collect();
    let items = request.iter().map(|id| (*id, remote[id].clone())).collect();
    let reply = Msg::DataReply(items);
    p.deliver(Packet::single(Addr::Proc(1), Addr::Proc(0), reply), 3);
    // The reply (data class) is handled before the walk that came first.
    assert!(matches!(p.step(4).unwrap(), Step::Worked(_)));
    assert!(p.last_charges().is_empty(), "no hook ran for the reply");
    // Then the demand-driven task its data woke: execute_dd charges "work".
    assert_eq!(p.step(5).unwrap(), Step::Worked(State::Executing));
    assert_eq!(p.last_charges(), [(MiniWork::Work, 1)]);
    // Only then the walk (execute_dp charges nothing).
    assert!(matches!(p.step(6).unwrap(), Step::Worked(_)));
    assert!(p.last_charges().is_empty());
}

/// §6: no deadlock, no hang, with everything that could cause one at
/// once: a hot spot (all data on processor 0), one credit per link (send
/// backlogs), a cache that holds one task's data at a time (deferral) or
/// none (fallback), all policies, many interleavings. Every run ends
/// within the lockstep round limit with the sequential results.
#[test]
fn progress_under_hot_spot_single_credit_and_tight_caches() {
    let w = Mini {
        hotspot: true,
        ..Mini::default()
    };
    let item = (24 + 8 * w.words) as u64;
    for policy in Policy::ALL {
        for cache in [Some(1), Some(u64::from(w.sel) * item)] {
            for seed in 0..6 {
                let cfg = Config::new(3)
                    .with_policy(policy)
                    .with_cache_bytes(cache)
                    .with_credits(1);
                let r = run_lockstep(Arc::new(w.clone()), &cfg, seed)
                    .unwrap_or_else(|e| panic!("{policy}, cache {cache:?}, seed {seed}: {e}"));
                check_against_sequential(&w, &r);
                if cache == Some(1) {
                    assert!(r.stats.sum(|p| p.tasks.fallbacks) > 0);
                }
            }
        }
    }
}

/// A view's `get` of a cached item is a use (the processor refreshes its
/// recency and counts a hit after the hook); `peek` reads the same item
/// without one, so a hook may read again what it has read.
#[test]
fn peeking_reads_without_a_use() {
    use crate::cache::ByteLru;
    use crate::resident::Resident;
    let mut resident = Resident::default();
    resident.insert(1u32, Item(vec![1]));
    let mut cache = ByteLru::new(None);
    cache.insert(2u32, Item(vec![2]), 32);
    let view = crate::DataView::<Mini>::new(&resident, Some(&cache));
    assert_eq!(view.peek(&1), Some(&Item(vec![1])));
    assert_eq!(view.peek(&2), Some(&Item(vec![2])));
    assert_eq!(view.peek(&3), None);
    assert!(view.into_touched().is_empty(), "peeks are not uses");
    let view = crate::DataView::<Mini>::new(&resident, Some(&cache));
    assert_eq!(view.get(&2), view.peek(&2));
    assert_eq!(view.into_touched(), vec![2], "a get is");
}
