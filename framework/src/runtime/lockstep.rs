//! A deterministic single-threaded runtime for tests and debugging.
//!
//! Actors run in rounds. In each round every packet in flight is delivered
//! with probability 1/2 (FIFO per link is kept, as channels and MPI keep it),
//! and every actor takes a pseudo-random number of steps. The same seed gives
//! the same run, while different seeds explore very different interleavings
//! (delayed probes, late credits, data replies overtaken by tasks), which is
//! how the termination and flow-control arguments are tested. Time is a
//! virtual counter; no cost model is applied (that is the simulator's job).

use std::collections::{HashSet, VecDeque};
use std::sync::Arc;

use super::{assemble, Node, RunReport, Runtime};
use crate::config::Config;
use crate::error::RunError;
use crate::processor::Step;
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;
use crate::rng::SplitMix64;

/// The lockstep runtime with its interleaving seed.
#[derive(Clone, Copy, Debug)]
pub struct Lockstep {
    /// Seed of the interleaving.
    pub seed: u64,
    /// Give up (with [`RunError::Runtime`]) after this many rounds.
    pub max_rounds: u64,
}

impl Lockstep {
    /// Lockstep runtime with `seed` and a generous round limit.
    pub fn new(seed: u64) -> Self {
        Lockstep {
            seed,
            max_rounds: 10_000_000,
        }
    }
}

#[async_trait::async_trait]
impl<W: Workload> Runtime<W> for Lockstep {
    fn name(&self) -> &'static str {
        "lockstep"
    }

    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        run_lockstep(workload, config, self.seed, self.max_rounds)
    }
}

/// Runs `workload` deterministically (see the module documentation).
///
/// # Example
///
/// The workload is the crate-level example's (the sum of five pairs, 35).
///
/// ```rust
/// # use std::sync::Arc;
/// # use hybrid_sched::serde::{Deserialize, Serialize};
/// # use hybrid_sched::{Addr, ByteSize, Ctx, DataView, DpOutcome, Placement, Workload};
/// # // The crate-level example's workload: six numbers 1..=6 over the processors;
/// # // demand-driven task `Pair(i)` adds items i and i + 1, data-parallel `Walk`
/// # // adds items `next..end` by migrating to their owners.
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Num(u64);
/// # impl ByteSize for Num { fn byte_size(&self) -> usize { 8 } }
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Pair(u32);
/// # impl ByteSize for Pair { fn byte_size(&self) -> usize { 4 } }
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Walk { next: u32, end: u32, acc: u64 }
/// # impl ByteSize for Walk { fn byte_size(&self) -> usize { 16 } }
/// # hybrid_sched::work_kinds! { enum PairsWork { Select = "select" } }
/// # struct Pairs;
/// # impl Workload for Pairs {
/// #     type DataId = u32;
/// #     type DataItem = Num;
/// #     type DdTask = Pair;
/// #     type DpTask = Walk;
/// #     type Result = Num;
/// #     type Accumulator = u64;
/// #     type Work = PairsWork;
/// #     fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
/// #         (0..6).map(|id| Placement { id, owner: id as usize % procs, bytes: 8 }).collect()
/// #     }
/// #     fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Num)> {
/// #         (0..6u32).filter(|&i| i as usize % procs == proc).map(|i| (i, Num(u64::from(i) + 1))).collect()
/// #     }
/// #     fn root_tasks(&self, _procs: usize) -> Vec<Pair> { (0..5).map(Pair).collect() }
/// #     fn select_data(&self, t: &Pair, ctx: &mut Ctx<Self>) -> Vec<u32> {
/// #         ctx.charge(PairsWork::Select, 1);
/// #         vec![t.0, t.0 + 1]
/// #     }
/// #     fn execute_dd(&self, t: Pair, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
/// #         let sum = data.get(&t.0).unwrap().0 + data.get(&(t.0 + 1)).unwrap().0;
/// #         ctx.emit_result(Addr::Master, Num(sum));
/// #     }
/// #     fn to_data_parallel(&self, t: Pair, ctx: &mut Ctx<Self>) {
/// #         ctx.spawn_dp(Walk { next: t.0, end: t.0 + 2, acc: 0 });
/// #     }
/// #     fn route_dp(&self, w: &Walk) -> Option<u32> { (w.next < w.end).then_some(w.next) }
/// #     fn execute_dp(&self, mut w: Walk, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) -> DpOutcome<Walk> {
/// #         while w.next < w.end {
/// #             let Some(item) = data.get(&w.next) else { return DpOutcome::Migrate(w) };
/// #             w.acc += item.0;
/// #             w.next += 1;
/// #         }
/// #         ctx.emit_result(Addr::Master, Num(w.acc));
/// #         DpOutcome::Finished
/// #     }
/// #     fn merge(&self, acc: &mut u64, r: Num) { *acc += r.0; }
/// # }
/// use hybrid_sched::{run_lockstep, Config};
///
/// let config = Config::new(3).with_cache_bytes(Some(16)).with_credits(1);
/// let a = run_lockstep(Arc::new(Pairs), &config, 7, 100_000).unwrap();
/// assert_eq!(a.master, 35);
/// // The seed fixes the interleaving: the same seed, the same run.
/// let b = run_lockstep(Arc::new(Pairs), &config, 7, 100_000).unwrap();
/// assert_eq!(a.stats, b.stats);
/// ```
pub fn run_lockstep<W: Workload>(
    workload: Arc<W>,
    config: &Config,
    seed: u64,
    max_rounds: u64,
) -> Result<RunReport<W>, RunError> {
    let mut nodes = Node::build_all(&workload, config)?;
    let procs = config.procs;
    let mut rng = SplitMix64::new(seed);
    let mut net: VecDeque<Packet<W>> = VecDeque::new();
    let mut done = vec![false; nodes.len()];
    let mut now = 0u64;
    for _ in 0..max_rounds {
        now += 1 + rng.next_u64() % 500_000;
        let mut held: HashSet<(Addr, Addr)> = HashSet::new();
        let mut keep = VecDeque::with_capacity(net.len());
        while let Some(p) = net.pop_front() {
            let link = (p.from, p.to);
            if held.contains(&link) || rng.next_u64() % 2 == 0 {
                held.insert(link);
                keep.push_back(p);
                continue;
            }
            let slot = p.to.slot(procs);
            if done[slot] {
                // Only control traffic (a late credit) may reach a finished
                // actor; a basic message would be work lost.
                if p.has_basic() {
                    return Err(RunError::Runtime(format!(
                        "{} sent {:?} to {}, which has already finished",
                        p.from, p.items, p.to
                    )));
                }
                continue;
            }
            nodes[slot].deliver(p, now);
        }
        net = keep;
        for (slot, node) in nodes.iter_mut().enumerate() {
            if done[slot] {
                continue;
            }
            for _ in 0..=rng.next_u64() % 3 {
                let step = node.step(now)?;
                net.extend(node.take_packets(now));
                match step {
                    Step::Finished => {
                        done[slot] = true;
                        break;
                    }
                    Step::Idle => break,
                    Step::Worked(_) => {}
                }
            }
        }
        if done.iter().all(|&d| d) {
            if let Some(p) = net.iter().find(|p| p.has_basic()) {
                return Err(RunError::Runtime(format!(
                    "{:?} still in flight after termination",
                    p
                )));
            }
            let finished = nodes
                .into_iter()
                .map(|n| {
                    let addr = n.addr();
                    let (acc, stats) = n.finish();
                    (addr, acc, stats)
                })
                .collect();
            return Ok(assemble("lockstep", procs, finished, now));
        }
    }
    Err(RunError::Runtime(format!(
        "lockstep run did not terminate within {max_rounds} rounds"
    )))
}
