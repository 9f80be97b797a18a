//! Whole runs: lockstep and threads against the sequential reference,
//! termination, flow control, bundling, contract violations.

use super::*;

#[test]
fn lockstep_matches_sequential_for_all_policies_and_caches() {
    let w = Mini::default();
    let item = (24 + 8 * w.words) as u64;
    for procs in 1..=4 {
        for policy in Policy::ALL {
            for cache in [Some(1), Some(2 * item), Some(5 * item), None] {
                let cfg = Config::new(procs)
                    .with_policy(policy)
                    .with_cache_bytes(cache)
                    .with_credits(2);
                let r = run_lockstep(Arc::new(w.clone()), &cfg, procs as u64 * 31 + 5)
                    .unwrap_or_else(|e| panic!("{procs} procs, {policy}, cache {cache:?}: {e}"));
                check_against_sequential(&w, &r);
                if cache == Some(1) && procs > 1 {
                    assert!(
                        r.stats.sum(|p| p.tasks.fallbacks) > 0,
                        "tiny cache must use the fallback"
                    );
                }
            }
        }
    }
}

/// Depth first ([`Workload::data_parallel_newest_first`]: the newest
/// data-parallel task first, children's demand-driven tasks before them,
/// the newest waiting tasks sent first) changes when tasks run, never what
/// they compute: every task once and the sequential results, under random
/// interleavings, with every policy and cache, and few credits so that
/// tasks wait to be sent.
#[test]
fn depth_first_runs_match_sequential_under_every_policy_and_cache() {
    let w = Mini {
        newest_first: true,
        depth: 3,
        roots: 16,
        ..Mini::default()
    };
    let item = (24 + 8 * w.words) as u64;
    for procs in 1..=4 {
        for policy in Policy::ALL {
            for cache in [Some(1), Some(2 * item), None] {
                for seed in 0..3 {
                    let cfg = Config::new(procs)
                        .with_policy(policy)
                        .with_cache_bytes(cache)
                        .with_credits(2);
                    let r = run_lockstep(Arc::new(w.clone()), &cfg, seed * 7 + procs as u64)
                        .unwrap_or_else(|e| panic!("{procs} procs, {policy}, {cache:?}: {e}"));
                    check_against_sequential(&w, &r);
                }
            }
        }
    }
}

/// A workload that locates its own data (its processors keep no
/// directory) runs exactly as one whose processors list the placement; one
/// whose answer disagrees with its placement is refused before the run,
/// naming the item.
#[test]
fn a_workload_that_locates_its_data_runs_as_one_listed() {
    let w = Mini {
        locating: Locating::Right,
        ..Mini::default()
    };
    let item = (24 + 8 * w.words) as u64;
    for procs in 1..=4 {
        for policy in Policy::ALL {
            for cache in [Some(1), Some(2 * item), None] {
                let cfg = Config::new(procs)
                    .with_policy(policy)
                    .with_cache_bytes(cache)
                    .with_complete_cache(Some(50))
                    .with_credits(2);
                let seed = procs as u64 * 17 + 3;
                let asked = run_lockstep(Arc::new(w.clone()), &cfg, seed).expect("runs");
                check_against_sequential(&w, &asked);
                let listed = run_lockstep(Arc::new(Mini::default()), &cfg, seed).expect("runs");
                let tasks = |r: &RunReport<Mini>| {
                    let t: Vec<_> = r.stats.procs.iter().map(|p| p.tasks).collect();
                    format!("{t:?}")
                };
                assert_eq!(tasks(&asked), tasks(&listed), "{procs} {policy} {cache:?}");
                assert_eq!(asked.procs, listed.procs);
            }
        }
    }
    let wrong = Mini {
        locating: Locating::Wrong,
        ..Mini::default()
    };
    let e = run_lockstep(Arc::new(wrong), &Config::new(2), 1).unwrap_err();
    assert!(
        e.to_string().contains("data 23 is placed on processor 1"),
        "{e}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    /// Termination is never premature (every result is present and merged
    /// exactly once) and never missed, across random interleavings.
    #[test]
    fn termination_is_exact_under_random_interleavings(
        seed in any::<u64>(),
        procs in 1usize..6,
        policy in 0usize..4,
        cache in prop_oneof![Just(None), (1u64..400).prop_map(Some)],
        credits in 1usize..4,
        bundling in any::<bool>(),
        prefetch in any::<bool>(),
    ) {
        let w = Mini { seed, ..Mini::default() };
        let mut cfg = Config::new(procs)
            .with_policy(Policy::ALL[policy])
            .with_cache_bytes(cache)
            .with_credits(credits)
            .with_bundling(bundling);
        // Asking for work ahead leaves a request at the master while the
        // processor is busy: termination must still be exact.
        cfg.prefetch_work = prefetch;
        let r = run_lockstep(Arc::new(w.clone()), &cfg, seed ^ 0xABCD).expect("terminates");
        check_against_sequential(&w, &r);
    }
}

#[test]
fn configs_written_before_prefetch_existed_still_load() {
    let mut v = serde_json::to_value(Config::new(2)).unwrap();
    v.as_object_mut().unwrap().remove("prefetch_work");
    let c: Config = serde_json::from_value(v).unwrap();
    assert!(c.prefetch_work, "the default asks for work ahead");
}

#[test]
fn hotspot_input_buffers_stay_within_credit_bound() {
    let w = Mini {
        hotspot: true,
        roots: 40,
        hops: 6,
        ..Mini::default()
    };
    for policy in Policy::ALL {
        let cfg = Config::new(4)
            .with_policy(policy)
            .with_cache_bytes(Some(1))
            .with_credits(2);
        let r = run_lockstep(Arc::new(w.clone()), &cfg, 3).expect("terminates");
        check_against_sequential(&w, &r);
        let bound = cfg.input_buffer_bound();
        for p in r.stats.procs.iter().chain([&r.stats.master]) {
            assert!(
                p.memory.input_buffer_items <= bound,
                "{policy}: {} held {} > {bound}",
                p.addr,
                p.memory.input_buffer_items
            );
        }
        assert!(r.stats.procs[0].memory.input_buffer_items > 0);
    }
}

#[test]
fn bundling_reduces_packets_in_lockstep() {
    let w = Mini {
        roots: 40,
        ..Mini::default()
    };
    let run = |bundling: bool| {
        let cfg = Config::new(4)
            .with_policy(Policy::RoundRobin)
            .with_bundling(bundling);
        let r = run_lockstep(Arc::new(w.clone()), &cfg, 11).expect("terminates");
        check_against_sequential(&w, &r);
        r.stats.packets_sent()
    };
    let (on, off) = (run(true), run(false));
    assert!(on < off, "bundled {on} packets, unbundled {off}");
}

#[test]
fn threads_runtime_matches_sequential() {
    let w = Mini::default();
    for policy in Policy::ALL {
        let cfg = Config::new(3)
            .with_policy(policy)
            .with_cache_bytes(Some(100))
            .with_time_limit(std::time::Duration::from_secs(60));
        let r = run_threads(Arc::new(w.clone()), &cfg).expect("runs");
        check_against_sequential(&w, &r);
    }
}

#[test]
fn workload_contract_violations_are_errors_not_hangs() {
    /// Claims to need data it already has.
    #[derive(Clone, Debug)]
    struct Liar(Mini);
    impl Workload for Liar {
        type DataId = u32;
        type DataItem = Item;
        type DdTask = Task;
        type DpTask = Walk;
        type Result = Res;
        type Accumulator = Acc;
        type Work = MiniWork;
        fn placement(&self, p: usize) -> Vec<Placement<u32>> {
            self.0.placement(p)
        }
        fn load_partition(&self, a: usize, b: usize) -> Vec<(u32, Item)> {
            self.0.load_partition(a, b)
        }
        fn root_tasks(&self, p: usize) -> Vec<Task> {
            self.0.root_tasks(p)
        }
        fn select_data(&self, t: &Task, c: &mut Ctx<Self>) -> Vec<u32> {
            c.charge(MiniWork::Select, 1);
            self.0.selection(t)
        }
        fn execute_dd(&self, _t: Task, _d: &DataView<'_, Self>, c: &mut Ctx<Self>) {
            c.spawn_dp(Walk {
                key: 1,
                path: vec![0],
                pos: 0,
                acc: 0,
                finish: None,
            });
        }
        fn to_data_parallel(&self, _t: Task, _c: &mut Ctx<Self>) {}
        fn route_dp(&self, w: &Walk) -> Option<u32> {
            w.path.first().copied()
        }
        fn execute_dp(
            &self,
            w: Walk,
            _d: &DataView<'_, Self>,
            _c: &mut Ctx<Self>,
        ) -> DpOutcome<Walk> {
            DpOutcome::Migrate(w)
        }
        fn merge(&self, _a: &mut Acc, _r: Res) {}
    }
    let cfg = Config::new(2).with_time_limit(std::time::Duration::from_secs(30));
    let err = run_threads(Arc::new(Liar(Mini::default())), &cfg).unwrap_err();
    assert!(err.to_string().contains("which is local"), "{err}");
    let err = run_sequential(&Liar(Mini::default()), 2).unwrap_err();
    assert!(err.to_string().contains("migrate"), "{err}");
}

#[test]
fn inconsistent_placement_is_a_config_error() {
    #[derive(Clone, Debug)]
    struct Bad(Mini);
    impl Workload for Bad {
        type DataId = u32;
        type DataItem = Item;
        type DdTask = Task;
        type DpTask = Walk;
        type Result = Res;
        type Accumulator = Acc;
        type Work = MiniWork;
        fn placement(&self, p: usize) -> Vec<Placement<u32>> {
            let mut v = self.0.placement(p);
            v[0].owner = p + 3; // out of range
            v
        }
        fn load_partition(&self, a: usize, b: usize) -> Vec<(u32, Item)> {
            self.0.load_partition(a, b)
        }
        fn root_tasks(&self, p: usize) -> Vec<Task> {
            self.0.root_tasks(p)
        }
        fn select_data(&self, t: &Task, c: &mut Ctx<Self>) -> Vec<u32> {
            self.0.select_data(t, &mut Ctx::new(c.proc_id(), c.procs()))
        }
        fn execute_dd(&self, _t: Task, _d: &DataView<'_, Self>, _c: &mut Ctx<Self>) {}
        fn to_data_parallel(&self, _t: Task, _c: &mut Ctx<Self>) {}
        fn route_dp(&self, _w: &Walk) -> Option<u32> {
            None
        }
        fn execute_dp(
            &self,
            _w: Walk,
            _d: &DataView<'_, Self>,
            _c: &mut Ctx<Self>,
        ) -> DpOutcome<Walk> {
            DpOutcome::Finished
        }
        fn merge(&self, _a: &mut Acc, _r: Res) {}
    }
    let err = run_threads(Arc::new(Bad(Mini::default())), &Config::new(2)).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("placement") && text.contains("only 2"),
        "{text}"
    );
}

/// The tests' workloads with many roots, deep families and long walks.
fn busy(hotspot: bool) -> Mini {
    Mini {
        hotspot,
        roots: 200,
        depth: 3,
        hops: 6,
        ..Mini::default()
    }
}

/// Peak work in flight (input buffer plus send backlog, at one moment) of
/// every actor stays within `Config::flight_bytes`, and the input buffer
/// within the five eighths its windows allow (a hard bound: every message
/// is smaller than a link's window here), under every policy and cache
/// size, with the sequential results. Credits alone do not bound it: the
/// same runs without the byte budget exceed it.
#[test]
fn work_in_flight_stays_within_the_byte_budget_under_every_policy() {
    let budget = 4096;
    let mut worst_unbounded = 0;
    for hotspot in [false, true] {
        let w = busy(hotspot);
        for policy in Policy::ALL {
            for cache in [Some(1), Some(200), None] {
                let base = Config::new(4).with_policy(policy).with_cache_bytes(cache);
                let cfg = base.clone().with_flight_bytes(budget);
                // The windows of four senders, results' reserves and the
                // backlog's budget share the budget out.
                assert_eq!(cfg.link_window_bytes(), 512);
                assert_eq!(Pool::reserve(512), 128);
                assert_eq!(4 * (512 + 128) + cfg.backlog_budget_bytes(), budget);
                let r = run_lockstep(Arc::new(w.clone()), &cfg, 3).expect("terminates");
                check_against_sequential(&w, &r);
                for p in r.stats.procs.iter().chain([&r.stats.master]) {
                    let m = &p.memory;
                    let case = format!("hot spot {hotspot}, {policy}, cache {cache:?}, {}", p.addr);
                    assert!(m.in_flight_bytes <= budget, "{case}: {m:?}");
                    assert!(m.input_buffer_bytes <= budget / 8 * 5, "{case}: {m:?}");
                    assert!(m.in_flight_bytes <= m.input_buffer_bytes + m.send_backlog_bytes);
                    assert!(m.in_flight_bytes >= m.input_buffer_bytes.max(m.send_backlog_bytes));
                }
                let free = base.with_flight_bytes(usize::MAX);
                let r = run_lockstep(Arc::new(w.clone()), &free, 3).expect("terminates");
                check_against_sequential(&w, &r);
                let peak = r
                    .stats
                    .procs
                    .iter()
                    .chain([&r.stats.master])
                    .map(|p| p.memory.in_flight_bytes)
                    .max()
                    .unwrap_or(0);
                worst_unbounded = worst_unbounded.max(peak);
            }
        }
    }
    assert!(
        worst_unbounded > budget,
        "credits alone held every run within {budget} bytes ({worst_unbounded}): the test shows nothing"
    );
}

/// Back-pressure never loses a task or hangs: with a budget of a few
/// messages every processor is over it most of the time (it keeps its
/// children and asks for pooled work only), and
/// every policy, cache size and interleaving still ends with the
/// sequential results. Depth first too, where a processor with too many
/// tasks waiting to leave runs nothing and parks what it receives.
#[test]
fn back_pressure_neither_loses_work_nor_deadlocks() {
    let mut kept = 0;
    let mut pooled_only = 0;
    let mut held = 0;
    let (mut held_for_tasks, mut parked) = (0, 0);
    for hotspot in [false, true] {
        for newest_first in [false, true] {
            let w = Mini {
                newest_first,
                ..busy(hotspot)
            };
            for policy in Policy::ALL {
                for cache in [Some(1), Some(200), None] {
                    for seed in [1, 2] {
                        let cfg = Config::new(4)
                            .with_policy(policy)
                            .with_cache_bytes(cache)
                            .with_credits(2)
                            .with_flight_bytes(8);
                        let r = run_lockstep(Arc::new(w.clone()), &cfg, seed).expect("terminates");
                        check_against_sequential(&w, &r);
                        kept += r.stats.sum(|p| p.tasks.kept_over_budget);
                        pooled_only += r.stats.sum(|p| p.tasks.pooled_only_requests);
                        held += r.stats.sum(|p| p.tasks.held_for_results);
                        held_for_tasks += r.stats.sum(|p| p.tasks.held_for_tasks);
                        parked += r.stats.sum(|p| p.tasks.parked);
                        if !newest_first {
                            assert_eq!(r.stats.sum(|p| p.tasks.held_for_tasks), 0);
                        }
                    }
                }
                // And on real threads.
                let cfg = Config::new(4)
                    .with_policy(policy)
                    .with_cache_bytes(Some(200))
                    .with_credits(2)
                    .with_flight_bytes(8)
                    .with_time_limit(std::time::Duration::from_secs(60));
                let r = run_threads(Arc::new(w.clone()), &cfg).expect("terminates");
                check_against_sequential(&w, &r);
            }
        }
    }
    assert!(
        kept > 0,
        "no child was ever kept: back-pressure never acted"
    );
    assert!(pooled_only > 0, "no request for pooled work only");
    assert!(
        held > 0,
        "no processor ever waited for its results to leave"
    );
    assert!(held_for_tasks > 0, "no processor ever held for its tasks");
    assert!(parked > 0, "no task was ever parked");
}
