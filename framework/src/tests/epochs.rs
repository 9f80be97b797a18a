//! Epochs and write-once broadcast data ([`Workload::next_epoch`],
//! SEMANTICS.md section 10): a workload in rounds, each reading what every
//! round before it made, gives the sequential reference's results on every
//! runtime, processor count, policy and cache size, and every task of a
//! round, and every merge at a processor of a result of one
//! ([`Workload::merge_in`]), sees all of the earlier rounds' broadcasts.

use super::*;
use crate::runtime::sim::{run_sim, CostModel, Network, Sim};
use crate::Epoch;

/// Rounds of `tasks` tasks each. Task `(round, i)` reads data item
/// `i % items` (placed) and the broadcast of every earlier round (ids
/// `BASE + r`), and sends the master a value mixing them. When a round
/// ends, the master broadcasts the sum of its values (in task order) and
/// starts the next. Children of a task (to `depth`) do the same, so a
/// round's work spreads over processors by the policy.
#[derive(Clone, Debug)]
struct Rounds {
    items: u32,
    tasks: u32,
    rounds: u32,
    depth: u8,
}

const BASE: u32 = 1_000_000;

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Val(u64);

impl ByteSize for Val {
    fn byte_size(&self) -> usize {
        8
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct RoundTask {
    round: u32,
    i: u32,
    depth: u8,
}

impl ByteSize for RoundTask {
    fn byte_size(&self) -> usize {
        9
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
struct Got {
    round: u32,
    key: u64,
    value: u64,
    /// Earlier rounds' broadcasts the task did not find.
    missing: u32,
}

impl ByteSize for Got {
    fn byte_size(&self) -> usize {
        24
    }
}

/// Per round, the values by task key; and the broadcasts made.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
struct RoundsAcc {
    got: BTreeMap<(u32, u64), u64>,
    missing: u32,
    duplicates: u32,
    sums: Vec<u64>,
}

crate::work_kinds! {
    enum RoundsWork { Work = "work" }
}

impl Rounds {
    fn run(&self, t: &RoundTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        ctx.charge(RoundsWork::Work, 1);
        let mut v = mix(u64::from(t.round) << 40 | u64::from(t.i) << 8 | u64::from(t.depth));
        v = v.wrapping_add(data.get(&(t.i % self.items)).map_or(0, |x| x.0));
        let mut missing = 0;
        for r in 0..t.round {
            match data.get(&(BASE + r)) {
                Some(x) => v = mix(v ^ x.0),
                None => missing += 1,
            }
        }
        let key = u64::from(t.i) << 8 | u64::from(t.depth);
        let got = Got {
            round: t.round,
            key,
            value: v,
            missing,
        };
        // And to the processor that ran the task's root, whose merge reads
        // the broadcasts too.
        ctx.emit_result(Addr::Proc(ctx.origin()), got.clone());
        ctx.emit_result(Addr::Master, got);
        if t.depth > 0 {
            for c in 0..2 {
                ctx.spawn_dd(RoundTask {
                    round: t.round,
                    i: t.i * 2 + c + self.tasks,
                    depth: t.depth - 1,
                });
            }
        }
    }

    fn roots(&self, round: u32) -> Vec<RoundTask> {
        (0..self.tasks)
            .map(|i| RoundTask {
                round,
                i,
                depth: self.depth,
            })
            .collect()
    }
}

impl Workload for Rounds {
    type DataId = u32;
    type DataItem = Val;
    type DdTask = RoundTask;
    type DpTask = RoundTask;
    type Result = Got;
    type Accumulator = RoundsAcc;
    type Work = RoundsWork;

    fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
        (0..self.items)
            .map(|id| Placement {
                id,
                owner: id as usize % procs,
                bytes: 8,
            })
            .collect()
    }

    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Val)> {
        (0..self.items)
            .filter(|&id| id as usize % procs == proc)
            .map(|id| (id, Val(mix(u64::from(id)))))
            .collect()
    }

    fn root_tasks(&self, _procs: usize) -> Vec<RoundTask> {
        self.roots(0)
    }

    fn select_data(&self, t: &RoundTask, _ctx: &mut Ctx<Self>) -> Vec<u32> {
        // The placed item, and the broadcasts (held everywhere: never
        // fetched).
        let mut ids = vec![t.i % self.items];
        ids.extend((0..t.round).map(|r| BASE + r));
        ids
    }

    fn execute_dd(&self, t: RoundTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        self.run(&t, data, ctx);
    }

    fn to_data_parallel(&self, t: RoundTask, ctx: &mut Ctx<Self>) {
        ctx.spawn_dp(t);
    }

    fn route_dp(&self, t: &RoundTask) -> Option<u32> {
        Some(t.i % self.items)
    }

    fn execute_dp(
        &self,
        t: RoundTask,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<RoundTask> {
        if !data.is_local(&(t.i % self.items)) {
            return DpOutcome::Migrate(t);
        }
        self.run(&t, data, ctx);
        DpOutcome::Finished
    }

    fn merge(&self, acc: &mut RoundsAcc, r: Got) {
        acc.missing += r.missing;
        if acc.got.insert((r.round, r.key), r.value).is_some() {
            acc.duplicates += 1;
        }
    }

    /// A processor's merge: the earlier rounds' broadcasts it does not
    /// find count as missing.
    fn merge_in(&self, acc: &mut RoundsAcc, r: Got, data: &DataView<'_, Self>, _: &mut Ctx<Self>) {
        acc.missing += (0..r.round)
            .filter(|rr| data.get(&(BASE + rr)).is_none())
            .count() as u32;
        self.merge(acc, r);
    }

    fn next_epoch(&self, ended: usize, acc: &mut RoundsAcc) -> Option<Epoch<Self>> {
        let round = ended as u32;
        // In key order: the same sum whatever order the results came in.
        let sum = acc
            .got
            .range((round, 0)..(round + 1, 0))
            .fold(0u64, |s, (_, &v)| mix(s ^ v));
        acc.sums.push(sum);
        (round + 1 < self.rounds).then(|| Epoch {
            roots: self.roots(round + 1),
            broadcast: vec![(BASE + round, Val(sum))],
        })
    }
}

fn rounds() -> Rounds {
    Rounds {
        items: 9,
        tasks: 6,
        rounds: 5,
        depth: 2,
    }
}

/// Every task of every round ran once, saw every earlier broadcast, and
/// the results are the sequential reference's; every result merged at a
/// processor (`procs`' accumulators) was merged once, and its merge saw
/// every broadcast its task did.
fn check(w: &Rounds, r: &RunReport<Rounds>, want: &RoundsAcc, what: &str) {
    let got = &r.master;
    let per_round = w.tasks * ((1 << (w.depth + 1)) - 1);
    let at_procs: usize = r.procs.iter().map(|a| a.got.len()).sum();
    assert_eq!(at_procs as u32, w.rounds * per_round, "{what}");
    for a in &r.procs {
        assert_eq!(a.missing, 0, "{what}: a merge missed an earlier broadcast");
        assert_eq!(a.duplicates, 0, "{what}");
    }
    assert_eq!(got.got.len() as u32, w.rounds * per_round, "{what}");
    assert_eq!(got.missing, 0, "{what}: a task missed an earlier broadcast");
    assert_eq!(got.duplicates, 0, "{what}");
    assert_eq!(got.sums.len() as u32, w.rounds, "{what}");
    assert_eq!(got, want, "{what}");
}

#[test]
fn rounds_equal_the_sequential_reference_on_every_runtime() {
    let w = rounds();
    let seq = run_sequential(&w, 1).unwrap();
    assert_eq!(seq.stats.master.epochs, u64::from(w.rounds - 1));
    let want = seq.master.clone();
    check(&w, &seq, &want, "sequential");
    let item = 8 + 4;
    for procs in [1, 2, 3, 5] {
        for policy in Policy::ALL {
            for cache in [Some(item), None] {
                let mut cfg = Config::new(procs);
                cfg.policy = policy;
                cfg.cache_bytes = cache;
                let what = format!("{procs} procs, {policy:?}, cache {cache:?}");
                let r = run_lockstep(Arc::new(w.clone()), &cfg, procs as u64 * 7 + 1)
                    .unwrap_or_else(|e| panic!("lockstep, {what}: {e}"));
                check(&w, &r, &want, &format!("lockstep, {what}"));
                assert_eq!(r.stats.master.epochs, u64::from(w.rounds - 1));
                let r = run_threads(Arc::new(w.clone()), &cfg)
                    .unwrap_or_else(|e| panic!("threads, {what}: {e}"));
                check(&w, &r, &want, &format!("threads, {what}"));
                let sim = Sim::new(
                    CostModel::default().with_unit(RoundsWork::Work, 20_000.0),
                    Network::parsytec_cc(),
                );
                let r = run_sim(Arc::new(w.clone()), &cfg, &sim)
                    .unwrap_or_else(|e| panic!("sim, {what}: {e}"));
                check(&w, &r, &want, &format!("sim, {what}"));
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]
    /// Across random interleavings (random delivery order and delays), no
    /// task of a round runs before every processor holds the earlier
    /// rounds' broadcasts, and no round ends before all of its work.
    #[test]
    fn no_round_starts_early_in_any_interleaving(seed in any::<u64>(), procs in 1usize..6) {
        let w = Rounds { items: 7, tasks: 4, rounds: 4, depth: 1 };
        let want = run_sequential(&w, procs).unwrap().master;
        let mut cfg = Config::new(procs);
        cfg.policy = Policy::ALL[(seed % Policy::ALL.len() as u64) as usize];
        let r = run_lockstep(Arc::new(w.clone()), &cfg, seed).expect("terminates");
        check(&w, &r, &want, "lockstep");
    }
}

/// Broadcast data is written once: an id that is placed, or one broadcast
/// before, fails the run with an error naming it (not a panic or a hang).
#[test]
fn a_broadcast_id_written_twice_or_placed_is_an_error() {
    #[derive(Clone, Debug)]
    struct Again(Rounds, u32);
    // The same workload, broadcasting `id` every round.
    impl Workload for Again {
        type DataId = u32;
        type DataItem = Val;
        type DdTask = RoundTask;
        type DpTask = RoundTask;
        type Result = Got;
        type Accumulator = RoundsAcc;
        type Work = RoundsWork;
        fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
            self.0.placement(procs)
        }
        fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Val)> {
            self.0.load_partition(proc, procs)
        }
        fn root_tasks(&self, _procs: usize) -> Vec<RoundTask> {
            self.0.roots(0)
        }
        fn select_data(&self, t: &RoundTask, _ctx: &mut Ctx<Self>) -> Vec<u32> {
            vec![t.i % self.0.items]
        }
        fn execute_dd(&self, t: RoundTask, _data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
            ctx.emit_result(
                Addr::Master,
                Got {
                    round: t.round,
                    key: u64::from(t.i),
                    value: 1,
                    missing: 0,
                },
            );
        }
        fn to_data_parallel(&self, _t: RoundTask, _ctx: &mut Ctx<Self>) {}
        fn route_dp(&self, _t: &RoundTask) -> Option<u32> {
            None
        }
        fn execute_dp(
            &self,
            _t: RoundTask,
            _data: &DataView<'_, Self>,
            _ctx: &mut Ctx<Self>,
        ) -> DpOutcome<RoundTask> {
            DpOutcome::Finished
        }
        fn merge(&self, acc: &mut RoundsAcc, r: Got) {
            acc.got.insert((r.round, r.key), r.value);
        }
        fn next_epoch(&self, ended: usize, _acc: &mut RoundsAcc) -> Option<Epoch<Self>> {
            (ended < 3).then(|| Epoch {
                roots: self.0.roots(ended as u32 + 1),
                broadcast: vec![(self.1, Val(0))],
            })
        }
    }
    let base = Rounds {
        items: 4,
        tasks: 3,
        rounds: 4,
        depth: 0,
    };
    for (id, says) in [(BASE, "already held"), (2, "placed data")] {
        let w = Again(base.clone(), id);
        let e = run_sequential(&w, 2).unwrap_err().to_string();
        assert!(e.contains(says), "sequential: {e}");
        for procs in [1, 3] {
            let cfg = Config::new(procs);
            let e = run_lockstep(Arc::new(w.clone()), &cfg, 5)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "lockstep: {e}");
            let e = run_threads(Arc::new(w.clone()), &cfg)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "threads: {e}");
        }
    }
}
