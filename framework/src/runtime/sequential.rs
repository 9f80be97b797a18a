//! The sequential reference: every task runs on one processor with all data
//! resident, in a simple loop, with no messages, no cache and no policies.
//!
//! Hooks see the same processor count as the parallel run they are compared
//! with, so results are merged into the same per-destination accumulators and
//! a parallel report can be compared field by field.

use std::collections::VecDeque;

use crate::resident::Resident;
use std::sync::Arc;

use super::{RunReport, Runtime};
use crate::clock::{Clock, WallClock};
use crate::config::Config;
use crate::error::{ConfigError, RunError};
use crate::protocol::workload::{Ctx, DataView, Workload};
use crate::protocol::Addr;
use crate::protocol::DpOutcome;
use crate::stats::{ProcStats, RunStats, State};

/// The sequential reference runtime.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sequential;

#[async_trait::async_trait]
impl<W: Workload> Runtime<W> for Sequential {
    fn name(&self) -> &'static str {
        "sequential"
    }

    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        config.validate_for(&*workload)?;
        run_sequential(&*workload, config.procs)
    }
}

/// Runs every task of `workload` on one processor with all data local; results
/// go to the accumulators of a `procs`-processor run. The statistics hold one
/// processor (index 0) doing all the work.
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
/// use hybrid_sched::{run_sequential, run_sequential_observed};
///
/// let report = run_sequential(&Pairs, 2).unwrap();
/// assert_eq!(report.master, 35);
/// // One processor did all the work, without a message.
/// assert_eq!(report.stats.procs[0].tasks.demand_driven, 5);
/// assert_eq!(report.stats.packets_sent(), 0);
///
/// // The observed variant reports each step's charged work (for fitting a
/// // simulator's cost model): five data selections, one unit each.
/// let mut selected = 0;
/// run_sequential_observed(&Pairs, 2, &mut |charges, _ns| {
///     selected += charges.iter().filter(|(kind, _)| *kind == PairsWork::Select).map(|(_, n)| n).sum::<u64>();
/// })
/// .unwrap();
/// assert_eq!(selected, 5);
/// ```
pub fn run_sequential<W: Workload>(workload: &W, procs: usize) -> Result<RunReport<W>, RunError> {
    run_sequential_observed(workload, procs, &mut |_, _| {})
}

/// Called with each step's charged work and its wall-clock nanoseconds.
pub type StepObserver<'a, K> = dyn FnMut(&[(K, u64)], u64) + 'a;

/// [`run_sequential`], calling `observe(charges, ns)` after every task step
/// with the work it charged and the wall-clock nanoseconds it took: the
/// samples from which a simulator's cost model is fitted.
pub fn run_sequential_observed<W: Workload>(
    workload: &W,
    procs: usize,
    observe: &mut StepObserver<'_, W::Work>,
) -> Result<RunReport<W>, RunError> {
    if procs == 0 {
        return Err(ConfigError::NoProcessors.into());
    }
    crate::config::check_laid_out(workload, procs)?;
    let err = |message: String| RunError::Workload {
        at: Addr::Proc(0),
        message,
    };
    let clock = WallClock::new();
    let mut data = Resident::default();
    for p in 0..procs {
        data.extend(workload.load_partition(p, procs));
    }
    let mut stats = ProcStats::new(Addr::Proc(0));
    stats.memory.resident_bytes = data
        .values()
        .map(|i| crate::ByteSize::byte_size(i) as u64)
        .sum();
    let mut accs: Vec<W::Accumulator> = (0..procs).map(|_| Default::default()).collect();
    let mut master = W::Accumulator::default();
    let mut dd: VecDeque<W::DdTask> = workload.root_tasks(procs).into();
    stats.tasks.roots = dd.len() as u64;
    let mut dp: VecDeque<W::DpTask> = VecDeque::new();
    let placed: std::collections::HashSet<W::DataId> = data.keys().cloned().collect();
    let mut epoch = 0;
    loop {
        let t0 = clock.now();
        let mut ctx = Ctx::new(0, procs);
        let state = if let Some(task) = dp.pop_front() {
            let view = DataView::new(&data, None);
            stats.tasks.data_parallel_steps += 1;
            match workload.execute_dp(task, &view, &mut ctx) {
                DpOutcome::Finished => stats.tasks.data_parallel_finished += 1,
                DpOutcome::Migrate(task) => {
                    return Err(err(format!(
                    "data-parallel task {task:?} asked to migrate with all data local (needs {:?})",
                    workload.route_dp(&task)
                )))
                }
            }
            State::Executing
        } else if let Some(task) = dd.pop_front() {
            let ids = workload.select_data(&task, &mut ctx);
            stats.tasks.selections += 1;
            if let Some(missing) = ids.iter().find(|id| !data.contains_key(id)) {
                return Err(err(format!(
                    "data selection named unknown data {missing:?}"
                )));
            }
            let view = DataView::new(&data, None);
            workload.execute_dd(task, &view, &mut ctx);
            stats.tasks.demand_driven += 1;
            State::Executing
        } else if let Some(next) = workload.next_epoch(epoch, &mut master) {
            // The epoch is over: its broadcast data, then its roots.
            epoch += 1;
            for (id, item) in next.broadcast {
                if placed.contains(&id) {
                    return Err(err(format!(
                        "broadcast data {id:?} is placed data (broadcast ids must be new)"
                    )));
                }
                if data.insert(id.clone(), item).is_some() {
                    return Err(err(format!(
                        "broadcast data {id:?} is already held (broadcast data is written once)"
                    )));
                }
            }
            stats.tasks.roots += next.roots.len() as u64;
            dd.extend(next.roots);
            continue;
        } else {
            break;
        };
        let t1 = clock.now();
        observe(ctx.charges(), t1 - t0);
        stats.charge(ctx.charges());
        stats.tasks.children_spawned += ctx.dd.len() as u64;
        dd.extend(ctx.dd);
        dp.extend(ctx.dp);
        // Results in the order sent; what merging one at a processor
        // emits ([`Workload::merge_in`]) joins the queues and this list.
        let mut results: VecDeque<(Addr, W::Result)> = ctx.results.into();
        while let Some((dest, result)) = results.pop_front() {
            match dest {
                Addr::Master => workload.merge(&mut master, result),
                Addr::Proc(p) if p < procs => {
                    let mut merged = Ctx::new(p, procs);
                    let view = DataView::new(&data, None);
                    workload.merge_in(&mut accs[p], result, &view, &mut merged);
                    stats.charge(merged.charges());
                    stats.tasks.children_spawned += merged.dd.len() as u64;
                    dd.extend(merged.dd);
                    dp.extend(merged.dp);
                    results.extend(merged.results);
                }
                Addr::Proc(p) => {
                    return Err(err(format!(
                        "result sent to processor {p} but there are only {procs}"
                    )))
                }
            }
            stats.tasks.results_merged += 1;
        }
        stats.time_ns.add(state, clock.now() - t0);
    }
    let elapsed_ns = clock.now();
    Ok(RunReport {
        procs: accs,
        master,
        stats: RunStats {
            runtime: "sequential".to_string(),
            procs: vec![stats],
            master: ProcStats {
                epochs: epoch as u64,
                ..ProcStats::new(Addr::Master)
            },
            elapsed_ns,
        },
        extras: Default::default(),
    })
}
