//! The threads runtime: one tokio task per actor on a multi-thread runtime,
//! unbounded channels between them.
//!
//! Channels are unbounded on purpose: a send must never block (a blocked
//! sender could not consume its own input, which is how distributed deadlocks
//! start). Memory is bounded by the credit-based flow control inside the
//! actors instead (see `flow.rs`). Each actor yields to the scheduler after
//! every step, so many actors share few threads fairly, and awaits its channel
//! only when it has nothing to do. This is the only module that names tokio.
//!
//! With [`crate::DataService::OnArrival`] a data request never waits in
//! its owner's channel: the requesting actor has the owner's data server
//! answer it at once (a one-sided read of the owner's items, which no step
//! changes) and takes the reply in before its next step.

use std::collections::HashMap;
use std::sync::Arc;

use tokio::sync::mpsc::{unbounded_channel, UnboundedReceiver, UnboundedSender};
use tokio::task::JoinSet;
use tracing::Instrument;

use super::{assemble, Node, RunReport, Runtime};
use crate::clock::{Clock, WallClock};
use crate::config::{Config, DataService};
use crate::error::RunError;
use crate::processor::Step;
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;
use crate::server::DataServer;
use crate::stats::{ProcStats, State};

/// The threads runtime (see the module documentation).
#[derive(Clone, Copy, Debug, Default)]
pub struct Threads;

#[async_trait::async_trait]
impl<W: Workload> Runtime<W> for Threads {
    fn name(&self) -> &'static str {
        "threads"
    }

    /// Runs on a tokio runtime of its own, on a thread of its own, and
    /// awaits the end: the caller's executor (tokio's, of either flavour,
    /// or any other) is never blocked, and the run gets its configured
    /// threads whatever the caller's runtime has.
    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        let config = config.clone();
        let (tx, rx) = tokio::sync::oneshot::channel();
        std::thread::Builder::new()
            .name("hybrid-sched".into())
            .spawn(move || {
                let _ = tx.send(run_threads(workload, &config));
            })
            .map_err(|e| RunError::Runtime(format!("cannot start the run's thread: {e}")))?;
        rx.await
            .map_err(|_| RunError::Runtime("the run's thread panicked".into()))?
    }

    fn run_blocking(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        run_threads(workload, config)
    }
}

/// Runs `workload` on a fresh tokio multi-thread runtime with one actor per
/// processor plus the master. Blocks until termination is detected, an actor
/// fails, or the configured time limit passes. Called inside a tokio
/// runtime, it runs on a thread of its own (tokio cannot start a runtime
/// inside a runtime) and blocks the calling thread until the end; an async
/// caller awaits [`Threads`]' [`Runtime::run`] instead.
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
/// use std::time::Duration;
/// use hybrid_sched::{run_sequential, run_threads, Config, Policy, RunError};
///
/// let config = Config::new(3)
///     .with_policy(Policy::RoundRobin)
///     .with_cache_bytes(Some(16))
///     .with_time_limit(Duration::from_secs(60));
/// let report = run_threads(Arc::new(Pairs), &config)?;
/// assert_eq!(report.master, 35);
/// assert_eq!(report.master, run_sequential(&Pairs, 3)?.master);
/// assert_eq!(report.stats.runtime, "threads");
/// assert_eq!(report.stats.procs.len(), 3);
/// assert_eq!(report.stats.sum(|p| p.tasks.demand_driven), 5);
///
/// // A bad configuration is an error, not a panic.
/// let err = run_threads(Arc::new(Pairs), &Config::new(0)).unwrap_err();
/// assert!(matches!(err, RunError::Config(_)));
/// # Ok::<(), RunError>(())
/// ```
pub fn run_threads<W: Workload>(
    workload: Arc<W>,
    config: &Config,
) -> Result<RunReport<W>, RunError> {
    if tokio::runtime::Handle::try_current().is_ok() {
        return std::thread::scope(|s| {
            std::thread::Builder::new()
                .name("hybrid-sched".into())
                .spawn_scoped(s, || run_threads(workload, config))
                .map_err(|e| RunError::Runtime(format!("cannot start the run's thread: {e}")))?
                .join()
                .map_err(|_| RunError::Runtime("the run's thread panicked".into()))?
        });
    }
    let nodes = Node::build_all(&workload, config)?;
    // By default one thread per core. (An extra thread for the mostly
    // sleeping master was measured slower on 2 cores: the master then waits
    // for the OS to preempt a busy processor before it can hand out work,
    // while on a shared worker it runs at the processors' next yield.)
    let threads = config
        .threads
        .unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(2)
        })
        .clamp(1, nodes.len());
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(threads)
        .enable_time()
        .build()
        .map_err(|e| RunError::Runtime(format!("cannot start tokio: {e}")))?;
    let share = threads < nodes.len();
    let report = rt.block_on(run_actors(nodes, config, share));
    // Every actor has finished (or been aborted with the run's error):
    // the workers are told to stop, and the run returns without waiting
    // for their threads to exit (each hands its allocator's memory back on
    // the way out: 1.3 to 2.3 ms of a two-processor render of the studio
    // at 512x512 waited for it).
    rt.shutdown_background();
    report
}

type Finished<W> = (Addr, <W as Workload>::Accumulator, ProcStats);

async fn run_actors<W: Workload>(
    nodes: Vec<Node<W>>,
    config: &Config,
    share: bool,
) -> Result<RunReport<W>, RunError> {
    let clock = Arc::new(WallClock::new());
    let procs = nodes.len() - 1;
    let mut txs = Vec::with_capacity(nodes.len());
    let mut rxs = Vec::with_capacity(nodes.len());
    for _ in 0..nodes.len() {
        let (tx, rx) = unbounded_channel();
        txs.push(tx);
        rxs.push(rx);
    }
    let txs = Arc::new(txs);
    // Data requests answered on arrival: by the owner's server, in the
    // requesting actor's step (a one-sided read of the owner's items).
    let servers: Arc<Vec<_>> = Arc::new(if config.data_service == DataService::OnArrival {
        nodes.iter().map(Node::server).collect()
    } else {
        Vec::new()
    });
    let mut set = JoinSet::new();
    let mut addrs = HashMap::new();
    for (node, rx) in nodes.into_iter().zip(rxs) {
        let addr = node.addr();
        let span = tracing::debug_span!("actor", %addr);
        let links = Links {
            txs: txs.clone(),
            servers: servers.clone(),
        };
        let handle =
            set.spawn(actor(node, rx, links, clock.clone(), procs, share).instrument(span));
        addrs.insert(handle.id(), addr);
    }
    drop(txs);
    let collect = async {
        let mut done: Vec<Finished<W>> = Vec::new();
        while let Some(joined) = set.join_next_with_id().await {
            match joined {
                Ok((_, Ok(finished))) => done.push(finished),
                Ok((_, Err(e))) => return Err(e),
                Err(e) => {
                    let at = addrs.get(&e.id()).copied().unwrap_or(Addr::Master);
                    let message = if e.is_panic() {
                        let payload = e.into_panic();
                        payload
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| payload.downcast_ref::<String>().cloned())
                            .unwrap_or_else(|| "non-string panic".to_string())
                    } else {
                        "cancelled".to_string()
                    };
                    return Err(RunError::Panicked { at, message });
                }
            }
        }
        Ok(done)
    };
    // On any error the JoinSet is dropped on return, which aborts all actors.
    let finished = match config.time_limit {
        Some(limit) => tokio::time::timeout(limit, collect)
            .await
            .map_err(|_| RunError::TimedOut { limit })??,
        None => collect.await?,
    };
    Ok(assemble("threads", procs, finished, clock.now()))
}

/// Where an actor's packets go: every actor's channel, and the data
/// servers that answer requests on arrival (empty: none do).
struct Links<W: Workload> {
    txs: Arc<Vec<UnboundedSender<Packet<W>>>>,
    servers: Arc<Vec<Option<Arc<DataServer<W>>>>>,
}

/// Longest stretch of work an actor does before yielding its thread.
const YIELD_EVERY_NS: u64 = 200_000;

async fn actor<W: Workload>(
    mut node: Node<W>,
    mut rx: UnboundedReceiver<Packet<W>>,
    links: Links<W>,
    clock: Arc<WallClock>,
    procs: usize,
    share: bool,
) -> Result<Finished<W>, RunError> {
    let addr = node.addr();
    // One clock reading per step: each reading ends one accounted interval
    // and starts the next (a million tiny steps made 3 readings per step
    // a tenth of the run).
    let mut now = clock.now();
    let mut last_yield = now;
    loop {
        let t0 = now;
        let mut received = false;
        while let Ok(packet) = rx.try_recv() {
            node.deliver(packet, t0);
            received = true;
        }
        let t1 = if received {
            let t = clock.now();
            node.account(State::Receiving, t - t0);
            t
        } else {
            t0
        };
        let step = node.step(t1)?;
        let t2 = clock.now();
        match step {
            Step::Worked(state) => node.account(state, t2 - t1),
            _ => node.account(State::Sending, t2 - t1),
        }
        now = t2;
        let packets = node.take_packets(t2);
        let mut answered = false;
        let mut to_master = false;
        if !packets.is_empty() {
            let mut replies = Vec::new();
            for packet in packets {
                let to = packet.to;
                to_master |= to == Addr::Master;
                let server = links.servers.get(to.slot(procs)).and_then(Option::as_ref);
                if let Some(server) = server.filter(|_| DataServer::is_request(&packet)) {
                    let reply = server
                        .serve(packet)
                        .map_err(|message| RunError::Workload { at: to, message })?;
                    replies.push(reply);
                    continue;
                }
                links.txs[to.slot(procs)].send(packet).map_err(|_| {
                    RunError::Runtime(format!(
                        "{addr} sent a message to {to}, which has already finished"
                    ))
                })?;
            }
            now = clock.now();
            node.account(State::Sending, now - t2);
            if !replies.is_empty() {
                answered = true;
                for reply in replies {
                    node.deliver(reply, now);
                }
                let t3 = clock.now();
                node.account(State::Receiving, t3 - now);
                now = t3;
            }
        }
        match step {
            Step::Finished => break,
            // Share the thread with other actors (when there are more actors
            // than threads), but not after every step: a yield costs a trip
            // through the scheduler (and often a futex wake-up), more than a
            // small task's work. Except after a step that sent the master
            // something (a request for work, above all): the master, woken
            // by this thread, waits in its next-to-run slot, which the other
            // threads do not take from, until this actor yields; without the
            // yield it waited for the next step too (a tile, up to a
            // millisecond), and the processor asking for work ran out of it.
            // Two processors on two threads, the studio at 512x512: idle
            // 15.2 ms of a render in all before, 0.3 ms after (medians of
            // eight, `--parallel-stats`).
            Step::Worked(_) if share => {
                if to_master || now.saturating_sub(last_yield) >= YIELD_EVERY_NS {
                    tokio::task::yield_now().await;
                    now = clock.now();
                    last_yield = now;
                }
            }
            Step::Worked(_) => {}
            // The replies it just took in are work.
            Step::Idle if answered => {}
            Step::Idle => {
                let blocked = node.blocked_state();
                let packet = rx
                    .recv()
                    .await
                    .ok_or_else(|| RunError::Runtime(format!("{addr}: every sender is gone")))?;
                let t4 = clock.now();
                node.account(blocked, t4 - now);
                node.deliver(packet, t4);
                now = t4;
            }
        }
    }
    let (acc, stats) = node.finish();
    Ok((addr, acc, stats))
}
