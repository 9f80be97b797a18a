//! Runtimes move packets between actors and call their state machines.
//!
//! * [`threads`]: one tokio task per actor on a multi-thread runtime.
//! * [`sequential`]: the reference: every task on one processor, all data
//!   local, no messages.
//! * [`lockstep`]: deterministic, single-threaded, seeded interleavings of
//!   all actors (for tests and debugging).
//! * `mpi` (feature `mpi`): one processor per MPI rank, the master on
//!   rank 0.
//!
//! A runtime needs only the `Node` interface: `deliver`, `step`,
//! `take_packets`, `account`, `blocked_state`. A discrete-event simulator
//! drives exactly the same calls with virtual time (charging the work reported
//! by `Node::last_charges` through a cost model), and an MPI runtime with
//! one node per rank.

pub mod lockstep;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod sequential;
pub mod sim;
pub mod threads;

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::clock::Time;
use crate::config::Config;
use crate::error::RunError;
use crate::master::Master;
use crate::processor::{Processor, Step};
use crate::protocol::{Addr, Packet};
use crate::stats::{ProcStats, RunStats, State};
use crate::workload::Workload;

/// What a run produced: merged results per actor, and statistics.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct RunReport<W: Workload> {
    /// Accumulator of each worker processor (results addressed to it).
    pub procs: Vec<W::Accumulator>,
    /// Accumulator of the master (results addressed to [`Addr::Master`]).
    pub master: W::Accumulator,
    /// Statistics.
    pub stats: RunStats,
}

impl<W: Workload> RunReport<W> {
    /// The accumulator of `addr`.
    pub fn accumulator(&self, addr: Addr) -> &W::Accumulator {
        match addr {
            Addr::Master => &self.master,
            Addr::Proc(p) => &self.procs[p],
        }
    }
}

impl<W: Workload> std::fmt::Debug for RunReport<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunReport")
            .field("procs", &self.procs)
            .field("master", &self.master)
            .field("stats", &self.stats)
            .finish()
    }
}

/// Something that can run a workload.
pub trait Runtime {
    /// A short name for reports ("threads", "sequential", ...).
    fn name(&self) -> &'static str;

    /// Runs `workload` under `config` to completion.
    fn run<W: Workload>(&self, workload: Arc<W>, config: &Config)
        -> Result<RunReport<W>, RunError>;
}

/// Any actor: the master or a worker. Runtimes hold a `Vec<Node<W>>` indexed
/// by [`Addr::slot`].
pub(crate) enum Node<W: Workload> {
    /// The master.
    Master(Box<Master<W>>),
    /// A worker.
    Worker(Box<Processor<W>>),
}

impl<W: Workload> Node<W> {
    /// Builds every actor of a run: workers `0..procs`, then the master.
    pub(crate) fn build_all(workload: &Arc<W>, config: &Config) -> Result<Vec<Node<W>>, RunError> {
        config.validate()?;
        let mut nodes = Vec::with_capacity(config.procs + 1);
        for p in 0..config.procs {
            nodes.push(Node::Worker(Box::new(Processor::new(
                p,
                workload.clone(),
                config,
            )?)));
        }
        nodes.push(Node::Master(Box::new(Master::new(
            workload.clone(),
            config,
        ))));
        Ok(nodes)
    }

    /// The actor's address.
    pub(crate) fn addr(&self) -> Addr {
        match self {
            Node::Master(_) => Addr::Master,
            Node::Worker(p) => p.addr(),
        }
    }

    /// A packet arrived.
    pub(crate) fn deliver(&mut self, packet: Packet<W>, now: Time) {
        match self {
            Node::Master(m) => m.deliver(packet, now),
            Node::Worker(p) => p.deliver(packet, now),
        }
    }

    /// One unit of work.
    pub(crate) fn step(&mut self, now: Time) -> Result<Step, RunError> {
        match self {
            Node::Master(m) => m.step(now),
            Node::Worker(p) => p.step(now),
        }
    }

    /// Packets to transmit.
    pub(crate) fn take_packets(&mut self, now: Time) -> Vec<Packet<W>> {
        match self {
            Node::Master(m) => m.take_packets(now),
            Node::Worker(p) => p.take_packets(now),
        }
    }

    /// Adds time to a state.
    pub(crate) fn account(&mut self, state: State, ns: Time) {
        match self {
            Node::Master(m) => m.account(state, ns),
            Node::Worker(p) => p.account(state, ns),
        }
    }

    /// State to account blocked time to.
    pub(crate) fn blocked_state(&self) -> State {
        match self {
            Node::Master(_) => State::Idle,
            Node::Worker(p) => p.blocked_state(),
        }
    }

    /// Work charged in the last step (empty for the master).
    pub(crate) fn last_charges(&self) -> &[(W::Work, u64)] {
        match self {
            Node::Master(_) => &[],
            Node::Worker(p) => p.last_charges(),
        }
    }

    /// Accumulator and statistics at the end of the run.
    pub(crate) fn finish(self) -> (W::Accumulator, ProcStats) {
        match self {
            Node::Master(m) => (*m).finish(),
            Node::Worker(p) => (*p).finish(),
        }
    }
}

/// Assembles a report from finished nodes (any order).
pub(crate) fn assemble<W: Workload>(
    runtime: &str,
    procs: usize,
    finished: Vec<(Addr, W::Accumulator, ProcStats)>,
    elapsed_ns: u64,
) -> RunReport<W> {
    let mut accs: Vec<Option<W::Accumulator>> = (0..procs).map(|_| None).collect();
    let mut stats: Vec<Option<ProcStats>> = vec![None; procs];
    let mut master = None;
    for (addr, acc, st) in finished {
        match addr {
            Addr::Master => master = Some((acc, st)),
            Addr::Proc(p) => {
                accs[p] = Some(acc);
                stats[p] = Some(st);
            }
        }
    }
    let (master_acc, master_stats) =
        master.unwrap_or_else(|| (W::Accumulator::default(), ProcStats::new(Addr::Master)));
    RunReport {
        procs: accs.into_iter().map(Option::unwrap_or_default).collect(),
        master: master_acc,
        stats: RunStats {
            runtime: runtime.to_string(),
            procs: stats
                .into_iter()
                .enumerate()
                .map(|(i, s)| s.unwrap_or_else(|| ProcStats::new(Addr::Proc(i))))
                .collect(),
            master: master_stats,
            elapsed_ns,
        },
    }
}
