//! The simulator: agreement with the sequential reference, determinism,
//! network and cost models.

use super::*;
use crate::runtime::sim::{run_sim, CostModel, Network, Sim};

fn sim(net: Network) -> Sim {
    let mut cost = CostModel::default();
    cost.unit_ns.insert("work".into(), 50_000.0);
    Sim::new(cost, net)
}

/// Runs `check` on every policy, a cache of one byte, of three items and
/// without budget, and both network presets, for each processor count.
fn each_config(w: &Mini, procs: &[usize], mut check: impl FnMut(Config, Network, String)) {
    let item = (24 + 8 * w.words) as u64;
    for &procs in procs {
        for policy in Policy::ALL {
            for cache in [Some(1), Some(3 * item), None] {
                for net in [Network::parsytec_cc(), Network::ten_gbe()] {
                    let cfg = Config::new(procs)
                        .with_policy(policy)
                        .with_cache_bytes(cache)
                        .with_credits(2);
                    let what = format!("{procs} procs, {policy}, cache {cache:?}, {}", net.name);
                    check(cfg, net, what);
                }
            }
        }
    }
}

#[test]
fn simulated_runs_match_sequential_for_all_policies_and_caches() {
    let w = Mini::default();
    each_config(&w, &[1, 2, 3, 5], |cfg, net, what| {
        let r =
            run_sim(Arc::new(w.clone()), &cfg, &sim(net)).unwrap_or_else(|e| panic!("{what}: {e}"));
        check_against_sequential(&w, &r);
        // Every actor's states cover the whole run exactly.
        for p in r.stats.procs.iter().chain([&r.stats.master]) {
            assert_eq!(p.time_ns.total(), r.stats.elapsed_ns, "{what}: {}", p.addr);
        }
        let tl = r.timeline().unwrap();
        let tl_total: u64 = tl.actors[0].iter().map(|s| s.total()).sum();
        assert_eq!(tl_total, r.stats.elapsed_ns, "{what}");
    });
}

#[test]
fn same_inputs_same_figures_byte_for_byte() {
    let w = Mini::default();
    let cfg = Config::new(4)
        .with_policy(Policy::RoundRobin)
        .with_cache_bytes(Some(200));
    let mut s = sim(Network::ten_gbe());
    s.network.jitter = 0.5;
    s.seed = 7;
    let run = |s: &Sim| {
        let r = run_sim(Arc::new(w.clone()), &cfg, s).unwrap();
        let tl = r.timeline().unwrap();
        (
            serde_json::to_string(&r.stats).unwrap(),
            serde_json::to_string(&tl).unwrap(),
        )
    };
    assert_eq!(run(&s), run(&s));
    s.seed = 8;
    let other = run(&s);
    s.seed = 7;
    assert_ne!(
        run(&s).0,
        other.0,
        "the seed must matter when there is jitter"
    );
}

#[test]
fn a_slower_network_takes_longer_and_compute_scales() {
    let w = Mini::default();
    let cfg = Config::new(4).with_cache_bytes(Some(200));
    let elapsed = |net: Network| {
        run_sim(Arc::new(w.clone()), &cfg, &sim(net))
            .unwrap()
            .stats
            .elapsed_ns
    };
    let fast = Network::ten_gbe();
    let slow = Network {
        bandwidth: fast.bandwidth / 1000.0,
        latency_ns: fast.latency_ns * 100.0,
        ..fast.clone()
    };
    assert!(elapsed(slow) > elapsed(fast.clone()));
    let slow_cpu = Network {
        cpu_scale: 10.0,
        ..fast.clone()
    };
    let (a, b) = (elapsed(fast), elapsed(slow_cpu));
    assert!(b > 5 * a, "10x slower cpu: {a} -> {b}");
    // One processor on a network with free messages: the run costs what
    // the cost model says, step for step.
    let net = Network {
        send_overhead_ns: 0.0,
        recv_overhead_ns: 0.0,
        cpu_byte_ns: 0.0,
        latency_ns: 0.0,
        link_setup_ns: 0.0,
        ..Network::ten_gbe()
    };
    let r = run_sim(Arc::new(w.clone()), &Config::new(1), &sim(net)).unwrap();
    let p = &r.stats.procs[0];
    let folds = p.work.get("work").copied().unwrap_or(0) as f64;
    assert!(folds > 0.0);
    let busy = (p.time_ns.executing + p.time_ns.selecting) as f64;
    assert!(busy >= folds * 50_000.0, "busy {busy} for {folds} units");
}

#[test]
fn presets_by_name() {
    for name in Network::PRESETS {
        assert_eq!(Network::preset(name).unwrap().name, name);
    }
    assert!(Network::preset("token-ring").is_none());
}

#[test]
fn serving_on_arrival_changes_no_result_and_covers_the_run() {
    let w = Mini::default();
    let (mut waited, mut waited_on_arrival) = (0u64, 0u64);
    each_config(&w, &[2, 3, 5], |cfg, net, what| {
        let run = |service| {
            let cfg = cfg.clone().with_data_service(service);
            run_sim(Arc::new(w.clone()), &cfg, &sim(net.clone()))
                .unwrap_or_else(|e| panic!("{what}: {e}"))
        };
        let before = run(DataService::BetweenSteps);
        let r = run(DataService::OnArrival);
        check_against_sequential(&w, &r);
        for p in r.stats.procs.iter().chain([&r.stats.master]) {
            assert_eq!(p.time_ns.total(), r.stats.elapsed_ns, "{what}: {}", p.addr);
        }
        let tl = r.timeline().unwrap();
        for (k, actor) in tl.actors.iter().enumerate() {
            let total: u64 = actor.iter().map(|s| s.total()).sum();
            assert_eq!(total, r.stats.elapsed_ns, "{what}: actor {k}'s timeline");
        }
        // Every request answered once, by its owner's server.
        let sent = r.stats.sum(|p| p.data_requests_sent);
        assert_eq!(r.stats.sum(|p| p.data_requests_served), sent, "{what}");
        assert_eq!(
            r.stats.sum(|p| p.data_items_served),
            r.stats.sum(|p| p.data_items_requested),
            "{what}"
        );
        if sent > 0 {
            assert!(r.stats.sum(|p| p.time_ns.serving_data) > 0, "{what}");
        }
        waited += before.stats.sum(|p| p.time_ns.waiting_data);
        waited_on_arrival += r.stats.sum(|p| p.time_ns.waiting_data);
    });
    assert!(
        waited_on_arrival < waited,
        "waiting for data: {waited_on_arrival} ns served on arrival, {waited} ns between steps"
    );
}
