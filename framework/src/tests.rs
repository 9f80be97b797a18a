//! State-machine tests driven by a deterministic, seeded lockstep scheduler
//! (no tokio): packets are delivered in random order (FIFO per link, like
//! channels and MPI) with random delays, which explores interleavings that a
//! thread pool rarely produces. This is also a small proof that the processor
//! logic is runtime independent.

use std::collections::BTreeMap;
use std::sync::Arc;

use proptest::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bundle::Outbox;
use crate::protocol::{Addr, Class, DdEnvelope, Msg, Packet};
use crate::runtime::RunReport;
use crate::{
    run_sequential, run_threads, BundleConfig, ByteSize, Config, Ctx, DataView, DpOutcome,
    Placement, Policy, RunError, Workload,
};

fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A miniature workload: `items` data items of `words` u64 each, root tasks
/// reading `sel` items, children to `depth`, walks of `hops` items.
#[derive(Clone, Debug)]
pub(crate) struct Mini {
    pub items: u32,
    pub words: usize,
    pub roots: u32,
    pub sel: u32,
    pub depth: u8,
    pub hops: usize,
    pub hotspot: bool,
    pub seed: u64,
}

impl Default for Mini {
    fn default() -> Self {
        Mini {
            items: 24,
            words: 4,
            roots: 12,
            sel: 4,
            depth: 2,
            hops: 3,
            hotspot: false,
            seed: 7,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Item(Vec<u64>);
impl ByteSize for Item {
    fn byte_size(&self) -> usize {
        24 + 8 * self.0.len()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Task {
    key: u64,
    depth: u8,
}
impl ByteSize for Task {
    fn byte_size(&self) -> usize {
        16
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Walk {
    key: u64,
    path: Vec<u32>,
    pos: usize,
    acc: u64,
    /// Set for the data-parallel fallback of a demand-driven task.
    finish: Option<Task>,
}
impl ByteSize for Walk {
    fn byte_size(&self) -> usize {
        40 + 4 * self.path.len()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Res {
    pub(crate) key: u64,
    pub(crate) value: u64,
}
impl ByteSize for Res {
    fn byte_size(&self) -> usize {
        16
    }
}

/// key -> (times merged, value)
pub(crate) type Acc = BTreeMap<u64, (u32, u64)>;

impl Mini {
    fn ids(&self, key: u64, salt: u64, n: u64) -> Vec<u32> {
        (0..n)
            .map(|i| (mix(key ^ mix(self.seed ^ salt ^ (i << 40))) % u64::from(self.items)) as u32)
            .collect()
    }
    fn selection(&self, t: &Task) -> Vec<u32> {
        let mut v = self.ids(t.key, 1, u64::from(self.sel));
        v.sort_unstable();
        v.dedup();
        v
    }
    fn fold(acc: u64, id: u32, item: &Item) -> u64 {
        item.0
            .iter()
            .fold(acc.rotate_left(5) ^ u64::from(id), |a, &w| mix(a ^ w))
    }
    fn dest(&self, key: u64, procs: usize) -> Addr {
        let h = mix(key ^ 99);
        if h % 4 == 0 {
            Addr::Master
        } else {
            Addr::Proc((h / 4) as usize % procs)
        }
    }
    fn finish_dd(&self, t: &Task, acc: u64, ctx: &mut Ctx<Self>) {
        ctx.emit_result(
            self.dest(t.key, ctx.procs()),
            Res {
                key: t.key,
                value: acc,
            },
        );
        if t.depth < self.depth {
            for i in 0..(mix(t.key ^ 5) % 3) {
                ctx.spawn_dd(Task {
                    key: (t.key << 2) | (i + 1),
                    depth: t.depth + 1,
                });
            }
        }
        if self.hops > 0 && mix(t.key ^ 6) % 2 == 0 {
            ctx.spawn_dp(Walk {
                key: t.key | (1 << 63),
                path: self.ids(t.key, 2, self.hops as u64),
                pos: 0,
                acc,
                finish: None,
            });
        }
    }
}

crate::work_kinds! {
    /// What the test workloads count.
    pub(crate) enum MiniWork {
        Select = "select",
        Work = "work",
    }
}

impl Workload for Mini {
    type DataId = u32;
    type DataItem = Item;
    type DdTask = Task;
    type DpTask = Walk;
    type Result = Res;
    type Accumulator = Acc;
    type Work = MiniWork;

    fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
        (0..self.items)
            .map(|i| Placement {
                id: i,
                owner: if self.hotspot { 0 } else { i as usize % procs },
                bytes: (24 + 8 * self.words) as u64,
            })
            .collect()
    }
    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Item)> {
        self.placement(procs)
            .into_iter()
            .filter(|p| p.owner == proc)
            .map(|p| {
                let v = (0..self.words as u64)
                    .map(|w| mix(u64::from(p.id) * 1000 + w))
                    .collect();
                (p.id, Item(v))
            })
            .collect()
    }
    fn root_tasks(&self, _procs: usize) -> Vec<Task> {
        (0..self.roots)
            .map(|r| Task {
                key: u64::from(r + 1) << 20,
                depth: 0,
            })
            .collect()
    }
    fn select_data(&self, t: &Task, ctx: &mut Ctx<Self>) -> Vec<u32> {
        ctx.charge(MiniWork::Select, 1);
        self.selection(t)
    }
    fn execute_dd(&self, t: Task, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let mut acc = t.key;
        for id in self.selection(&t) {
            acc = Self::fold(acc, id, data.get(&id).expect("selected data is present"));
        }
        ctx.charge(MiniWork::Work, 1);
        self.finish_dd(&t, acc, ctx);
    }
    fn to_data_parallel(&self, t: Task, ctx: &mut Ctx<Self>) {
        ctx.spawn_dp(Walk {
            key: t.key,
            path: self.selection(&t),
            pos: 0,
            acc: t.key,
            finish: Some(t),
        });
    }
    fn route_dp(&self, w: &Walk) -> Option<u32> {
        w.path.get(w.pos).copied()
    }
    fn execute_dp(
        &self,
        mut w: Walk,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<Walk> {
        while let Some(&id) = w.path.get(w.pos) {
            match data.get(&id) {
                Some(item) => {
                    w.acc = Self::fold(w.acc, id, item);
                    w.pos += 1;
                }
                None => return DpOutcome::Migrate(w),
            }
        }
        match w.finish {
            Some(t) => self.finish_dd(&t, w.acc, ctx),
            None => ctx.emit_result(
                self.dest(w.key, ctx.procs()),
                Res {
                    key: w.key,
                    value: w.acc,
                },
            ),
        }
        DpOutcome::Finished
    }
    fn merge(&self, acc: &mut Acc, r: Res) {
        let e = acc.entry(r.key).or_insert((0, r.value));
        e.0 += 1;
    }
}

fn run_lockstep<W: Workload>(w: Arc<W>, cfg: &Config, seed: u64) -> Result<RunReport<W>, RunError> {
    crate::runtime::lockstep::run_lockstep(w, cfg, seed, 200_000)
}

fn all_keys(r: &RunReport<Mini>) -> BTreeMap<u64, (u32, u64)> {
    let mut out = BTreeMap::new();
    for acc in r.procs.iter().chain([&r.master]) {
        for (k, v) in acc {
            assert!(out.insert(*k, *v).is_none(), "key {k} merged at two places");
        }
    }
    out
}

fn check_against_sequential(w: &Mini, r: &RunReport<Mini>) {
    let seq = run_sequential(w, r.procs.len()).expect("sequential run");
    assert_eq!(r.procs, seq.procs, "per-processor results differ");
    assert_eq!(r.master, seq.master, "master results differ");
    for (k, (n, _)) in all_keys(r) {
        assert_eq!(n, 1, "task {k:#x} reported {n} times");
    }
    let dd: u64 = r.stats.sum(|p| p.tasks.demand_driven + p.tasks.fallbacks);
    assert_eq!(
        dd, seq.stats.procs[0].tasks.demand_driven,
        "demand-driven task count"
    );
}

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

#[test]
fn packets_round_trip_through_serde() {
    let packet: Packet<Mini> = Packet {
        from: Addr::Proc(1),
        to: Addr::Master,
        class: Class::DemandDriven,
        items: vec![
            Msg::Dd(DdEnvelope {
                task: Task { key: 5, depth: 1 },
                origin: Some(1),
                handout: false,
            }),
            Msg::DataReply(vec![(3, Item(vec![1, 2]))]),
            Msg::ProbeReply {
                wave: 2,
                sent: 10,
                received: 9,
            },
        ],
        bytes: 100,
        load: 0,
    };
    let json = serde_json::to_string(&packet).expect("serialise");
    let back: Packet<Mini> = serde_json::from_str(&json).expect("deserialise");
    assert_eq!(format!("{back:?}"), format!("{packet:?}"));
}

fn dd(key: u64) -> Msg<Mini> {
    Msg::Dd(DdEnvelope {
        task: Task { key, depth: 0 },
        origin: None,
        handout: false,
    })
}

#[test]
fn outbox_bundles_by_count_and_flush_and_sends_urgent_at_once() {
    let bundle = BundleConfig {
        enabled: true,
        max_items: 3,
        max_bytes: 1 << 20,
        max_age: std::time::Duration::from_secs(1),
    };
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, bundle, 100);
    out.push(Addr::Proc(1), dd(1), 0);
    out.push(Addr::Proc(1), dd(2), 0);
    assert!(!out.has_ready(), "not yet a full bundle");
    out.push(Addr::Proc(1), Msg::DataRequest(vec![4]), 0);
    let urgent = out.take_ready();
    assert_eq!(urgent.len(), 1);
    assert_eq!(urgent[0].class, Class::Data);
    out.push(Addr::Proc(1), dd(3), 0);
    let full = out.take_ready();
    assert_eq!(full.len(), 1);
    assert_eq!(full[0].items.len(), 3, "one bundle of three");
    out.push(Addr::Proc(1), dd(4), 10);
    out.pump(10 + 999_999_999, false);
    assert!(!out.has_ready(), "younger than max_age");
    out.pump(10 + 1_000_000_000, false);
    assert_eq!(out.take_ready().len(), 1, "sent by age");
    out.push(Addr::Master, dd(5), 0);
    out.pump(0, true);
    assert_eq!(out.take_ready().len(), 1, "flushed");
    assert!(out.is_empty());
}

#[test]
fn outbox_holds_messages_without_credit_and_never_drops() {
    let mut out: Outbox<Mini> = Outbox::new(Addr::Proc(0), 2, BundleConfig::default(), 2);
    for k in 0..5 {
        out.push(Addr::Proc(1), dd(k), 0);
    }
    out.pump(0, true);
    let first = out.take_ready();
    assert_eq!(first.iter().map(|p| p.items.len()).sum::<usize>(), 2);
    assert_eq!(out.backlog(), 3);
    assert_eq!(out.credits_towards(Addr::Proc(1)), 0);
    out.pump(0, true);
    assert!(!out.has_ready(), "no credit, nothing sent");
    out.grant(Addr::Proc(1), 2, 0);
    out.pump(0, true);
    assert_eq!(
        out.take_ready()
            .iter()
            .map(|p| p.items.len())
            .sum::<usize>(),
        2
    );
    out.grant(Addr::Proc(1), 5, 0);
    out.pump(0, true);
    let last = out.take_ready();
    assert_eq!(last.iter().map(|p| p.items.len()).sum::<usize>(), 1);
    assert!(out.is_empty());
    assert_eq!(out.backlog_high_water(), 5);
    // Data traffic is never credit-limited.
    for _ in 0..10 {
        out.push(Addr::Proc(1), Msg::DataRequest(vec![1]), 0);
    }
    assert_eq!(out.take_ready().len(), 10);
}

mod sim {
    use super::*;
    use crate::runtime::sim::{run_sim, CostModel, Network, Sim};

    fn sim(net: Network) -> Sim {
        let mut cost = CostModel::default();
        cost.unit_ns.insert("work".into(), 50_000.0);
        Sim::new(cost, net)
    }

    #[test]
    fn simulated_runs_match_sequential_for_all_policies_and_caches() {
        let w = Mini::default();
        let item = (24 + 8 * w.words) as u64;
        for procs in [1, 2, 3, 5] {
            for policy in Policy::ALL {
                for cache in [Some(1), Some(3 * item), None] {
                    for net in [Network::parsytec_cc(), Network::ten_gbe()] {
                        let cfg = Config::new(procs)
                            .with_policy(policy)
                            .with_cache_bytes(cache)
                            .with_credits(2);
                        let r = run_sim(Arc::new(w.clone()), &cfg, &sim(net))
                            .unwrap_or_else(|e| panic!("{procs} procs, {policy}: {e}"));
                        check_against_sequential(&w, &r);
                        // Every actor's states cover the whole run exactly.
                        for p in r.stats.procs.iter().chain([&r.stats.master]) {
                            assert_eq!(p.time_ns.total(), r.stats.elapsed_ns, "{}", p.addr);
                        }
                        let tl = r.timeline().unwrap();
                        let tl_total: u64 = tl.actors[0].iter().map(|s| s.total()).sum();
                        assert_eq!(tl_total, r.stats.elapsed_ns);
                    }
                }
            }
        }
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
}
