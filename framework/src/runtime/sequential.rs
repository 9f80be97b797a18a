//! The sequential reference: every task runs on one processor with all data
//! resident, in a simple loop, with no messages, no cache and no policies.
//!
//! Hooks see the same processor count as the parallel run they are compared
//! with, so results are merged into the same per-destination accumulators and
//! a parallel report can be compared field by field.

use std::collections::VecDeque;

use crate::store::IdMap;
use std::sync::Arc;

use super::{RunReport, Runtime};
use crate::clock::{Clock, WallClock};
use crate::config::Config;
use crate::error::{ConfigError, RunError};
use crate::message::Addr;
use crate::stats::{ProcStats, RunStats, State};
use crate::workload::{Ctx, DataView, DpOutcome, Workload};

/// The sequential reference runtime.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sequential;

impl Runtime for Sequential {
    fn name(&self) -> &'static str {
        "sequential"
    }

    fn run<W: Workload>(
        &self,
        workload: Arc<W>,
        config: &Config,
    ) -> Result<RunReport<W>, RunError> {
        config.validate()?;
        run_sequential(&*workload, config.procs)
    }
}

/// Runs every task of `workload` on one processor with all data local; results
/// go to the accumulators of a `procs`-processor run. The statistics hold one
/// processor (index 0) doing all the work.
pub fn run_sequential<W: Workload>(workload: &W, procs: usize) -> Result<RunReport<W>, RunError> {
    run_sequential_observed(workload, procs, &mut |_, _| {})
}

/// Called with each step's charged work and its wall-clock nanoseconds.
pub type StepObserver<'a> = dyn FnMut(&[(&'static str, u64)], u64) + 'a;

/// [`run_sequential`], calling `observe(charges, ns)` after every task step
/// with the work it charged and the wall-clock nanoseconds it took: the
/// samples from which a simulator's cost model is fitted.
pub fn run_sequential_observed<W: Workload>(
    workload: &W,
    procs: usize,
    observe: &mut StepObserver<'_>,
) -> Result<RunReport<W>, RunError> {
    if procs == 0 {
        return Err(ConfigError::NoProcessors.into());
    }
    let err = |message: String| RunError::Workload {
        at: Addr::Proc(0),
        message,
    };
    let clock = WallClock::new();
    let mut data = IdMap::default();
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
        } else {
            break;
        };
        let t1 = clock.now();
        observe(ctx.charges(), t1 - t0);
        stats.charge(ctx.charges());
        stats.tasks.children_spawned += ctx.dd.len() as u64;
        dd.extend(ctx.dd);
        dp.extend(ctx.dp);
        for (dest, result) in ctx.results {
            let acc = match dest {
                Addr::Master => &mut master,
                Addr::Proc(p) if p < procs => &mut accs[p],
                Addr::Proc(p) => {
                    return Err(err(format!(
                        "result sent to processor {p} but there are only {procs}"
                    )))
                }
            };
            workload.merge(acc, result);
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
            master: ProcStats::new(Addr::Master),
            elapsed_ns,
        },
    })
}
