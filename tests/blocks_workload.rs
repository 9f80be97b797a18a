//! The blocks workload on the framework: parallel equals sequential for every
//! processor count, policy and cache budget; flow control, bundling,
//! configuration errors and termination.

use std::sync::Arc;
use std::time::Duration;

use hybrid_examples::{Blocks, BlocksParams, Distribution};
use hybrid_sched::{
    run_lockstep, run_threads, BundleConfig, Config, ConfigError, DataService, Policy, RunError,
    RunReport,
};
use hybrid_tests::{assert_matches_sequential, guarded, small};
use proptest::prelude::*;

const LIMIT: Duration = Duration::from_secs(60);

/// Both ways of answering data requests.
const SERVICES: [DataService; 2] = [DataService::BetweenSteps, DataService::OnArrival];

fn threads(w: &Blocks, cfg: Config) -> RunReport<Blocks> {
    let w = Arc::new(w.clone());
    let cfg = cfg.with_time_limit(LIMIT);
    guarded(LIMIT + Duration::from_secs(10), move || {
        run_threads(w, &cfg).unwrap_or_else(|e| panic!("run failed: {e}"))
    })
}

#[test]
fn every_task_once_and_results_equal_sequential_for_all_procs_policies_caches() {
    let w = Blocks::new(small(3));
    // Smaller than any single block, so smaller than any task's data: every
    // task whose data is not resident must take the data-parallel fallback.
    let tiny = (w.smallest_block_bytes() / 2) as u64;
    let medium = 3 * w.largest_block_bytes() as u64;
    for (procs, service) in (1..=8).flat_map(|p| SERVICES.map(|s| (p, s))) {
        for policy in Policy::ALL {
            for cache in [Some(tiny), Some(medium), None] {
                let cfg = Config::new(procs)
                    .with_policy(policy)
                    .with_cache_bytes(cache)
                    .with_data_service(service)
                    .with_credits(4);
                let what = format!("{procs} procs, {policy}, cache {cache:?}, {service:?}");
                let r = threads(&w, cfg);
                assert_matches_sequential(&w, &r, &what);
                assert_eq!(
                    r.stats.sum(|p| p.data_requests_served),
                    r.stats.sum(|p| p.data_requests_sent),
                    "{what}: every request answered once"
                );
                if service == DataService::OnArrival {
                    // Answered by the owners' servers, never in a step.
                    let in_steps = r.stats.sum(|p| p.time_ns.serving_data);
                    assert_eq!(in_steps, 0, "{what}");
                }
                let fallbacks = r.stats.sum(|p| p.tasks.fallbacks);
                if cache == Some(tiny) && procs > 1 {
                    assert!(fallbacks > 0, "{what}: expected data-parallel fallbacks");
                    assert_eq!(
                        r.stats.sum(|p| p.cache.insertions),
                        0,
                        "{what}: nothing fits"
                    );
                }
                if cache.is_none() {
                    assert_eq!(fallbacks, 0, "{what}: unlimited cache needs no fallback");
                }
                for p in &r.stats.procs {
                    if let Some(budget) = cache {
                        assert!(p.memory.cached_bytes <= budget, "{what}: cache over budget");
                    }
                }
            }
        }
    }
}

/// `Config::fetch_limit`: a task with more to fetch than the limit takes
/// the data-parallel fallback, every task still runs once and the results
/// are the sequential ones; with a limit of zero nothing is ever fetched.
#[test]
fn the_fetch_limit_sends_larger_fetches_to_the_fallback_and_changes_no_result() {
    let w = Blocks::new(small(3));
    let one = w.largest_block_bytes() as u64;
    for procs in 1..=5 {
        for policy in Policy::ALL {
            for limit in [0, one] {
                let cfg = Config::new(procs)
                    .with_policy(policy)
                    .with_fetch_limit(Some(limit))
                    .with_credits(4);
                let what = format!("{procs} procs, {policy}, fetch limit {limit}");
                let r = threads(&w, cfg);
                assert_matches_sequential(&w, &r, &what);
                if limit == 0 {
                    assert_eq!(r.stats.sum(|p| p.data_items_requested), 0, "{what}");
                    if procs > 1 {
                        assert!(r.stats.sum(|p| p.tasks.fallbacks) > 0, "{what}");
                    }
                }
            }
        }
    }
}

/// `Config::complete_cache`: with a cache without budget, a processor that
/// has asked for the given share of the bytes placed elsewhere asks for the
/// rest. Each block is asked for once per processor, a processor that
/// completes ends up holding every block, and the results are the
/// sequential ones under every policy. With a budget or a fetch limit
/// nothing is completed.
#[test]
fn completing_the_cache_fetches_each_block_once_and_changes_no_result() {
    use hybrid_sched::{Addr, Workload};
    let w = Blocks::new(small(3));
    for procs in 2..=4 {
        let placement = w.placement(procs);
        for policy in Policy::ALL {
            for pct in [0u8, 30, 100] {
                let cfg = Config::new(procs)
                    .with_policy(policy)
                    .with_complete_cache(Some(pct))
                    .with_credits(4);
                let what = format!("{procs} procs, {policy}, completing at {pct}%");
                let r = threads(&w, cfg);
                assert_matches_sequential(&w, &r, &what);
                if pct == 0 {
                    assert!(r.stats.procs.iter().any(|p| p.cache_completed), "{what}");
                }
                for p in &r.stats.procs {
                    let Addr::Proc(id) = p.addr else { continue };
                    let elsewhere: Vec<u64> = placement
                        .iter()
                        .filter(|pl| pl.owner != id)
                        .map(|pl| pl.bytes)
                        .collect();
                    let asked = p.data_items_requested as usize;
                    assert!(asked <= elsewhere.len(), "{what}: p{id} asked twice");
                    assert_eq!(p.cache.insertions as usize, asked, "{what}: p{id}");
                    if p.cache_completed {
                        assert_eq!(asked, elsewhere.len(), "{what}: p{id} holds everything");
                    }
                    if pct == 0 && asked > 0 {
                        assert!(
                            p.cache_completed,
                            "{what}: p{id} completes at its first fetch"
                        );
                    }
                    if pct == 100 {
                        // Asked for everything before it could complete.
                        assert!(!p.cache_completed || asked == elsewhere.len(), "{what}");
                    }
                }
            }
        }
    }
    let budget = 3 * w.largest_block_bytes() as u64;
    for cfg in [
        Config::new(3).with_cache_bytes(Some(budget)),
        Config::new(3).with_fetch_limit(Some(budget)),
    ] {
        let r = threads(&w, cfg.clone().with_complete_cache(Some(0)));
        assert_matches_sequential(&w, &r, "a budget or a fetch limit");
        assert!(
            r.stats.procs.iter().all(|p| !p.cache_completed),
            "{cfg:?}: only a cache without budget completes"
        );
    }
    assert_eq!(
        Config::new(2).with_complete_cache(Some(101)).validate(),
        Err(ConfigError::CompletionPercent(101))
    );
}

#[test]
fn cache_counters_and_data_requests_are_consistent() {
    let w = Blocks::new(small(5));
    let r = threads(&w, Config::new(4).with_cache_bytes(Some(2000)));
    assert_matches_sequential(&w, &r, "4 procs, 2000-byte cache");
    let requested = r.stats.sum(|p| p.data_items_requested);
    let served = r.stats.sum(|p| p.data_items_served);
    assert_eq!(
        requested, served,
        "every requested item is served exactly once"
    );
    assert_eq!(
        r.stats.sum(|p| p.cache.insertions),
        requested,
        "every served item is cached once"
    );
    assert!(
        r.stats.sum(|p| p.cache.evictions) > 0,
        "a small cache must evict"
    );
    assert!(r.stats.sum(|p| p.cache.hits) > 0);
}

#[test]
fn hot_spot_input_buffers_stay_bounded_and_nothing_is_dropped() {
    // Every block lives on processor 0, caches are tiny: all data-parallel
    // work and every fallback converges on processor 0.
    let w = Blocks::new(BlocksParams {
        distribution: Distribution::Hotspot,
        roots: 64,
        walk_len: 6,
        ..small(11)
    });
    for policy in Policy::ALL {
        let cfg = Config::new(8)
            .with_policy(policy)
            .with_cache_bytes(Some(8))
            .with_credits(2);
        let bound = cfg.input_buffer_bound();
        let r = threads(&w, cfg);
        assert_matches_sequential(&w, &r, &format!("hot spot, {policy}"));
        for p in r.stats.procs.iter().chain([&r.stats.master]) {
            assert!(
                p.memory.input_buffer_items <= bound,
                "{policy}: {} buffered {} messages, bound {bound}",
                p.addr,
                p.memory.input_buffer_items
            );
            assert!(
                p.memory.waiting_tasks <= Config::new(8).max_waiting_tasks,
                "{policy}: {} had {} tasks waiting for data",
                p.addr,
                p.memory.waiting_tasks
            );
        }
        let hot = &r.stats.procs[0];
        assert!(
            hot.tasks.data_parallel_steps > 0,
            "{policy}: processor 0 is the hot spot"
        );
    }
}

#[test]
fn lockstep_hot_spot_bound_is_tight_and_deterministic() {
    let w = Blocks::new(BlocksParams {
        distribution: Distribution::Hotspot,
        ..small(2)
    });
    let cfg = Config::new(6)
        .with_policy(Policy::RoundRobin)
        .with_cache_bytes(Some(8))
        .with_credits(1);
    let a = run_lockstep(Arc::new(w.clone()), &cfg, 9, 1_000_000).expect("terminates");
    let b = run_lockstep(Arc::new(w.clone()), &cfg, 9, 1_000_000).expect("terminates");
    assert_matches_sequential(&w, &a, "lockstep hot spot");
    assert_eq!(a.stats, b.stats, "same seed, same run");
    for p in &a.stats.procs {
        assert!(p.memory.input_buffer_items <= cfg.input_buffer_bound());
    }
}

#[test]
fn bundling_cuts_message_count() {
    let w = Blocks::new(BlocksParams {
        roots: 48,
        ..small(4)
    });
    let run = |bundling: bool| {
        let cfg = Config::new(4)
            .with_policy(Policy::RoundRobin)
            .with_bundling(bundling);
        let r = run_lockstep(Arc::new(w.clone()), &cfg, 17, 1_000_000).expect("terminates");
        assert_matches_sequential(&w, &r, &format!("bundling {bundling}"));
        r.stats
    };
    let (on, off) = (run(true), run(false));
    let task_packets = |s: &hybrid_sched::RunStats| {
        s.sum(|p| {
            p.sent.result.packets + p.sent.data_parallel.packets + p.sent.demand_driven.packets
        })
    };
    let task_messages = |s: &hybrid_sched::RunStats| {
        s.sum(|p| {
            p.sent.result.messages + p.sent.data_parallel.messages + p.sent.demand_driven.messages
        })
    };
    assert_eq!(
        task_packets(&off),
        task_messages(&off),
        "unbundled: one message per packet"
    );
    assert!(on.sum(|p| p.bundles_sent) > 0);
    assert_eq!(off.sum(|p| p.bundles_sent), 0);
    assert!(
        task_packets(&on) * 10 < task_packets(&off) * 9,
        "bundled {} packets vs {} unbundled",
        task_packets(&on),
        task_packets(&off)
    );
    assert!(on.packets_sent() < off.packets_sent());
}

#[test]
fn bad_configurations_give_clear_errors() {
    let w = Arc::new(Blocks::new(small(1)));
    let err = |cfg: Config| match run_threads(w.clone(), &cfg) {
        Err(RunError::Config(e)) => e,
        other => panic!("expected a configuration error, got {other:?}"),
    };
    assert_eq!(err(Config::new(0)), ConfigError::NoProcessors);
    assert_eq!(
        err(Config::new(2).with_cache_bytes(Some(0))),
        ConfigError::ZeroCache
    );
    assert!(matches!(
        err(Config::new(2).with_cache_bytes(Some(u64::MAX))),
        ConfigError::CacheTooLarge { .. }
    ));
    let mut cfg = Config::new(2);
    cfg.bundle = BundleConfig {
        max_items: 0,
        ..BundleConfig::default()
    };
    let e = err(cfg);
    assert_eq!(e, ConfigError::ZeroBundleItems);
    assert!(
        e.to_string()
            .contains("bundle size limit must be at least 1"),
        "{e}"
    );
    assert_eq!(
        err(Config::new(2).with_credits(0)),
        ConfigError::ZeroCredits
    );
    let e = "sideways".parse::<Policy>().unwrap_err();
    assert!(
        e.to_string()
            .contains("unknown scheduling policy 'sideways'"),
        "{e}"
    );
    let e = RunError::from(ConfigError::NoProcessors);
    assert_eq!(
        e.to_string(),
        "invalid configuration: the number of processors must be at least 1 (got 0)"
    );
}

#[test]
fn statistics_cover_the_run_and_export_as_json() {
    let w = Blocks::new(small(8));
    let r = threads(&w, Config::new(3).with_policy(Policy::ViaMaster));
    assert_matches_sequential(&w, &r, "stats run");
    let json = r.stats.to_json();
    let back: hybrid_sched::RunStats = serde_json::from_str(&json).expect("valid JSON");
    assert_eq!(back, r.stats);
    for p in &r.stats.procs {
        assert!(p.time_ns.total() > 0, "{}: no time accounted", p.addr);
        assert!(p.work.get("select").copied().unwrap_or(0) > 0 || p.tasks.selections == 0);
    }
    let seq = hybrid_sched::run_sequential(&w, 3).expect("sequential");
    let total =
        |s: &hybrid_sched::RunStats, k: &str| s.sum(|p| p.work.get(k).copied().unwrap_or(0));
    assert_eq!(
        total(&r.stats, "select"),
        total(&seq.stats, "select"),
        "selection work"
    );
    // Fallbacks move checksum work into hops; the sum is the same.
    assert_eq!(
        total(&r.stats, "checksum") + total(&r.stats, "hop"),
        total(&seq.stats, "checksum") + total(&seq.stats, "hop"),
        "the same work is done in parallel as sequentially"
    );
    assert!(
        r.stats.master.tasks.pooled > 0,
        "via-master pools children at the master"
    );
    assert!(
        r.stats.master.termination_waves >= 2,
        "termination needs a confirming wave"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
    /// No premature termination: all results present (and each exactly once)
    /// for random workloads, processor counts, policies and caches.
    #[test]
    fn termination_is_never_premature(
        seed in any::<u64>(),
        procs in 1usize..=8,
        policy in 0usize..4,
        cache in prop_oneof![Just(None), (1u64..3000).prop_map(Some)],
        credits in 1usize..8,
        service in 0usize..2,
    ) {
        let w = Blocks::new(small(seed));
        let cfg = Config::new(procs)
            .with_policy(Policy::ALL[policy])
            .with_cache_bytes(cache)
            .with_data_service(SERVICES[service])
            .with_credits(credits);
        let r = threads(&w, cfg.clone());
        assert_matches_sequential(&w, &r, &format!("threads {cfg:?}"));
        let r = run_lockstep(Arc::new(w.clone()), &cfg, seed, 1_000_000).expect("terminates");
        assert_matches_sequential(&w, &r, &format!("lockstep {cfg:?}"));
    }
}
