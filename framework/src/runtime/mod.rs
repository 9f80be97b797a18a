//! Runtimes move packets between actors and call their state machines.
//! Every runtime implements the one [`Runtime`] interface and returns a
//! [`RunReport`], whose [`Extras`] carry what only it produces.
//!
//! * [`threads`]: one tokio task per actor on a multi-thread runtime.
//! * [`sequential`]: the reference: every task on one processor, all data
//!   local, no messages.
//! * [`lockstep`]: deterministic, single-threaded, seeded interleavings of
//!   all actors (for tests and debugging).
//! * [`sim`]: a deterministic discrete-event simulation of a cluster in
//!   virtual time (its report carries a [`Timeline`]).
//! * `mpi` (feature `mpi`): one processor per MPI rank, the master on
//!   rank 0 (its report carries the traffic per rank).
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
mod timeline;

use std::future::Future;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use serde::{Deserialize, Serialize};

use crate::clock::Time;
use crate::config::Config;
use crate::error::RunError;
use crate::master::Master;
use crate::processor::{Processor, Step};
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;
use crate::server::DataServer;
use crate::stats::{ProcStats, RankTraffic, RunStats, State};

pub use self::timeline::{Timeline, MAX_BUCKETS};

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
    /// What only this runtime produces (not serialised).
    #[serde(skip)]
    pub extras: Extras,
}

/// What a runtime reports besides results and statistics.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Extras {
    /// Nothing more (threads, sequential, lockstep).
    #[default]
    None,
    /// The simulator's time per state and bucket ([`sim::Sim`]).
    Timeline(Timeline),
    /// MPI, rank 0: wire traffic per rank (index = rank).
    Ranks(Vec<RankTraffic>),
    /// MPI, any other rank: this rank's actors finished; results and
    /// statistics are in rank 0's report (this one holds none).
    NotRoot {
        /// This rank.
        rank: usize,
    },
}

impl<W: Workload> RunReport<W> {
    /// The accumulator of `addr`.
    pub fn accumulator(&self, addr: Addr) -> &W::Accumulator {
        match addr {
            Addr::Master => &self.master,
            Addr::Proc(p) => &self.procs[p],
        }
    }

    /// The simulator's timeline ([`Extras::Timeline`]).
    pub fn timeline(&self) -> Option<&Timeline> {
        match &self.extras {
            Extras::Timeline(t) => Some(t),
            _ => None,
        }
    }

    /// MPI's traffic per rank, on rank 0 ([`Extras::Ranks`]).
    pub fn ranks(&self) -> Option<&[RankTraffic]> {
        match &self.extras {
            Extras::Ranks(r) => Some(r),
            _ => None,
        }
    }

    /// Whether this report holds the run's results: false only on MPI
    /// ranks other than 0 ([`Extras::NotRoot`]).
    pub fn is_root(&self) -> bool {
        !matches!(self.extras, Extras::NotRoot { .. })
    }
}

impl<W: Workload> std::fmt::Debug for RunReport<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunReport")
            .field("procs", &self.procs)
            .field("master", &self.master)
            .field("stats", &self.stats)
            .field("extras", &self.extras)
            .finish()
    }
}

/// Something that can run a workload: the one interface of every runtime.
///
/// Object safe (`Box<dyn Runtime<W>>`) and async: a tokio application
/// awaits [`Runtime::run`]; other callers use [`Runtime::run_blocking`],
/// which works inside or outside a tokio runtime.
///
/// ```rust
/// # use std::sync::Arc;
/// # use hybrid_sched::serde::{Deserialize, Serialize};
/// # use hybrid_sched::{Addr, ByteSize, Ctx, DataView, DpOutcome, NoWork, Placement, Workload};
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Num(u64);
/// # impl ByteSize for Num { fn byte_size(&self) -> usize { 8 } }
/// # /// Each root task sends its number to the master; no data.
/// # struct Count;
/// # impl Workload for Count {
/// #     type DataId = u32;
/// #     type DataItem = Num;
/// #     type DdTask = Num;
/// #     type DpTask = Num;
/// #     type Result = Num;
/// #     type Accumulator = u64;
/// #     type Work = NoWork;
/// #     fn placement(&self, _procs: usize) -> Vec<Placement<u32>> { Vec::new() }
/// #     fn load_partition(&self, _proc: usize, _procs: usize) -> Vec<(u32, Num)> { Vec::new() }
/// #     fn root_tasks(&self, _procs: usize) -> Vec<Num> { (1..=4).map(Num).collect() }
/// #     fn select_data(&self, _t: &Num, _ctx: &mut Ctx<Self>) -> Vec<u32> { Vec::new() }
/// #     fn execute_dd(&self, t: Num, _d: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
/// #         ctx.emit_result(Addr::Master, t);
/// #     }
/// #     fn to_data_parallel(&self, _t: Num, _ctx: &mut Ctx<Self>) {}
/// #     fn route_dp(&self, _w: &Num) -> Option<u32> { None }
/// #     fn execute_dp(&self, _w: Num, _d: &DataView<'_, Self>, _c: &mut Ctx<Self>) -> DpOutcome<Num> {
/// #         DpOutcome::Finished
/// #     }
/// #     fn merge(&self, acc: &mut u64, r: Num) { *acc += r.0; }
/// # }
/// use hybrid_sched::{Config, CostModel, Lockstep, Network, Runtime, Sequential, Sim, Threads};
///
/// let runtimes: Vec<Box<dyn Runtime<Count>>> = vec![
///     Box::new(Threads),
///     Box::new(Sequential),
///     Box::new(Lockstep::new(7)),
///     Box::new(Sim::new(CostModel::default(), Network::ten_gbe())),
/// ];
/// for rt in &runtimes {
///     let report = rt.run_blocking(Arc::new(Count), &Config::new(2)).unwrap();
///     assert_eq!(report.master, 10, "{}", rt.name());
///     assert_eq!(report.timeline().is_some(), rt.name() == "sim");
/// }
/// ```
#[async_trait::async_trait]
pub trait Runtime<W: Workload>: Send + Sync {
    /// A short name for reports ("threads", "sequential", ...).
    fn name(&self) -> &'static str;

    /// Runs `workload` under `config` to completion.
    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError>;

    /// [`Runtime::run`] for callers that are not async; it may be called
    /// inside a tokio runtime as well (it blocks the calling thread).
    fn run_blocking(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        block_on(self.run(workload, config))
    }
}

/// Polls `future` to completion on the calling thread, parking between
/// polls. Needs no tokio context: the runtimes' futures either complete at
/// once or wait for a runtime-independent channel.
pub(crate) fn block_on<F: Future>(future: F) -> F::Output {
    struct Unpark(std::thread::Thread);
    impl Wake for Unpark {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = Waker::from(Arc::new(Unpark(std::thread::current())));
    let mut cx = Context::from_waker(&waker);
    let mut future = std::pin::pin!(future);
    loop {
        if let Poll::Ready(out) = future.as_mut().poll(&mut cx) {
            return out;
        }
        std::thread::park();
    }
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
    ///
    /// The directory is built and checked once, and shared. The processors
    /// load their partitions at the same time, on up to one thread per
    /// core ([`crate::par::map_indices`]; each loads only its own, so the
    /// order does not matter): four processors of the ray tracer's
    /// 1.5M-triangle city took 0.58-0.61 s on two cores instead of
    /// 1.09-1.18. An error is the lowest-numbered processor's.
    pub(crate) fn build_all(workload: &Arc<W>, config: &Config) -> Result<Vec<Node<W>>, RunError> {
        config.validate_for(&**workload)?;
        let dir = crate::store::Directory::shared(workload, config.procs)?;
        let built = crate::par::map_indices(config.procs, |p| {
            Processor::with_directory(p, workload.clone(), config, dir.clone())
        });
        let mut nodes = Vec::with_capacity(config.procs + 1);
        for p in built {
            nodes.push(Node::Worker(Box::new(p?)));
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
    /// A worker's data server (`None`: the master).
    pub(crate) fn server(&self) -> Option<Arc<DataServer<W>>> {
        match self {
            Node::Worker(p) => Some(Arc::clone(p.server())),
            Node::Master(_) => None,
        }
    }

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
        extras: Extras::None,
    }
}
