//! Per-processor instrumentation, exported as JSON.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::cache::CacheCounters;
use crate::clock::Time;
use crate::protocol::workload::WorkKind;
use crate::protocol::{Addr, Class};

/// What a processor is doing; time is accounted per state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum State {
    /// Running task code (tracing rays, checksumming blocks).
    Executing,
    /// Data selection (pyramid clipping).
    Selecting,
    /// Nothing runnable, but tasks are waiting for data.
    WaitingData,
    /// Nothing to do at all.
    Idle,
    /// Handing packets to the transport.
    Sending,
    /// Taking packets from the transport, merging results, filling the cache.
    Receiving,
    /// Answering data requests.
    ServingData,
}

impl State {
    /// Every state, in report order.
    pub const ALL: [State; 7] = [
        State::Executing,
        State::Selecting,
        State::WaitingData,
        State::Idle,
        State::Sending,
        State::Receiving,
        State::ServingData,
    ];
}

/// Nanoseconds spent per [`State`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateTimes {
    /// See [`State::Executing`].
    pub executing: u64,
    /// See [`State::Selecting`].
    pub selecting: u64,
    /// See [`State::WaitingData`].
    pub waiting_data: u64,
    /// See [`State::Idle`].
    pub idle: u64,
    /// See [`State::Sending`].
    pub sending: u64,
    /// See [`State::Receiving`].
    pub receiving: u64,
    /// See [`State::ServingData`].
    pub serving_data: u64,
}

impl StateTimes {
    /// Adds `ns` to `state`.
    pub fn add(&mut self, state: State, ns: Time) {
        let slot = self.get_mut(state);
        *slot = slot.saturating_add(ns);
    }

    /// Time in `state`.
    pub fn get(&self, state: State) -> u64 {
        match state {
            State::Executing => self.executing,
            State::Selecting => self.selecting,
            State::WaitingData => self.waiting_data,
            State::Idle => self.idle,
            State::Sending => self.sending,
            State::Receiving => self.receiving,
            State::ServingData => self.serving_data,
        }
    }

    fn get_mut(&mut self, state: State) -> &mut u64 {
        match state {
            State::Executing => &mut self.executing,
            State::Selecting => &mut self.selecting,
            State::WaitingData => &mut self.waiting_data,
            State::Idle => &mut self.idle,
            State::Sending => &mut self.sending,
            State::Receiving => &mut self.receiving,
            State::ServingData => &mut self.serving_data,
        }
    }

    /// Sum over all states.
    pub fn total(&self) -> u64 {
        State::ALL.iter().map(|&s| self.get(s)).sum()
    }
}

/// Packets, messages and bytes of one class in one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Traffic {
    /// Transport packets (a bundle counts once).
    pub packets: u64,
    /// Logical messages.
    pub messages: u64,
    /// Accounted bytes.
    pub bytes: u64,
}

/// [`Traffic`] per [`Class`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassTraffic {
    /// Control.
    pub control: Traffic,
    /// Data requests and replies.
    pub data: Traffic,
    /// Results.
    pub result: Traffic,
    /// Data-parallel tasks.
    pub data_parallel: Traffic,
    /// Demand-driven tasks.
    pub demand_driven: Traffic,
}

impl ClassTraffic {
    /// The counters of `class`.
    pub fn get(&self, class: Class) -> &Traffic {
        match class {
            Class::Control => &self.control,
            Class::Data => &self.data,
            Class::Result => &self.result,
            Class::DataParallel => &self.data_parallel,
            Class::DemandDriven => &self.demand_driven,
        }
    }

    /// Mutable counters of `class`.
    pub fn get_mut(&mut self, class: Class) -> &mut Traffic {
        match class {
            Class::Control => &mut self.control,
            Class::Data => &mut self.data,
            Class::Result => &mut self.result,
            Class::DataParallel => &mut self.data_parallel,
            Class::DemandDriven => &mut self.demand_driven,
        }
    }

    /// Records one packet.
    pub fn record(&mut self, class: Class, messages: usize, bytes: usize) {
        let t = self.get_mut(class);
        t.packets += 1;
        t.messages += messages as u64;
        t.bytes += bytes as u64;
    }

    /// Sum over classes.
    pub fn total(&self) -> Traffic {
        let mut sum = Traffic::default();
        for c in Class::ALL {
            let t = self.get(c);
            sum.packets += t.packets;
            sum.messages += t.messages;
            sum.bytes += t.bytes;
        }
        sum
    }
}

/// Task counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TaskCounters {
    /// Root tasks handed out (master) or received by hand-out (worker).
    pub roots: u64,
    /// Data selections run.
    pub selections: u64,
    /// Demand-driven tasks executed.
    pub demand_driven: u64,
    /// Data-parallel execution steps (a migrating task counts once per
    /// processor it runs on).
    pub data_parallel_steps: u64,
    /// Data-parallel tasks finished.
    pub data_parallel_finished: u64,
    /// Data-parallel tasks sent on to another processor.
    pub migrations: u64,
    /// Demand-driven tasks converted to data-parallel work because their data
    /// could never fit the cache.
    pub fallbacks: u64,
    /// Demand-driven tasks that had to wait for cache space (pins).
    pub deferred: u64,
    /// Child demand-driven tasks spawned.
    pub children_spawned: u64,
    /// Child tasks pooled at the master (master only).
    pub pooled: u64,
    /// Back-pressure: children kept on this processor, which its policy
    /// would have sent away, because its send backlog was over budget
    /// ([`crate::Config::flight_bytes`]).
    #[serde(default)]
    pub kept_over_budget: u64,
    /// Back-pressure: work requests for pooled children only (no root task)
    /// sent while over budget.
    #[serde(default)]
    pub pooled_only_requests: u64,
    /// Back-pressure: steps in which this processor left its work
    /// unconsumed, over budget with results waiting for credit.
    #[serde(default)]
    pub held_for_results: u64,
    /// Back-pressure, depth first only: steps in which this processor ran
    /// nothing, its send backlog of tasks over budget.
    #[serde(default)]
    pub held_for_tasks: u64,
    /// Tasks received while so held, whose credit went back at once.
    #[serde(default)]
    pub parked: u64,
    /// Results merged here.
    pub results_merged: u64,
}

/// Memory high-water marks by category.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MemoryHighWater {
    /// Resident (owned) data bytes.
    pub resident_bytes: u64,
    /// Cached data bytes.
    pub cached_bytes: u64,
    /// Tasks waiting for data (count).
    pub waiting_tasks: usize,
    /// Bytes of tasks waiting for data.
    pub waiting_task_bytes: usize,
    /// Credit-limited messages received and not consumed (the bounded part of
    /// the input buffer; the master counts its pooled tasks here too).
    pub input_buffer_items: usize,
    /// Bytes of the above.
    pub input_buffer_bytes: usize,
    /// Everything in the mailbox, including local work and urgent traffic.
    pub mailbox_items: usize,
    /// Tasks queued for execution here (local and remote).
    pub queued_tasks: usize,
    /// Messages held in the outbox for a bundle or for credit.
    pub send_backlog: usize,
    /// Bytes of the above.
    #[serde(default)]
    pub send_backlog_bytes: usize,
    /// Work in flight: input buffer bytes plus send backlog bytes, the most
    /// ever held at one moment (at most the sum of the two high-water marks).
    #[serde(default)]
    pub in_flight_bytes: usize,
    /// Bytes of root tasks (the ray tracer's primary-ray tiles) held here
    /// from hand-out to execution.
    #[serde(default)]
    pub root_task_bytes: usize,
    /// Bytes of the largest data selection (data ids) one selection step
    /// returned (the ray tracer's pyramid clipping).
    #[serde(default)]
    pub selection_bytes: usize,
}

/// Everything measured at one actor.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ProcStats {
    /// Which actor.
    pub addr: Addr,
    /// Time per state (nanoseconds, wall or virtual).
    pub time_ns: StateTimes,
    /// Counted work units per kind (see [`crate::Ctx::charge`]).
    pub work: BTreeMap<String, u64>,
    /// Traffic sent.
    pub sent: ClassTraffic,
    /// Traffic received.
    pub received: ClassTraffic,
    /// Packets sent holding more than one message.
    pub bundles_sent: u64,
    /// Task counters.
    pub tasks: TaskCounters,
    /// Cache counters.
    pub cache: CacheCounters,
    /// Data request messages sent.
    pub data_requests_sent: u64,
    /// Data items requested.
    pub data_items_requested: u64,
    /// Data requests answered.
    pub data_requests_served: u64,
    /// Data items sent in replies.
    pub data_items_served: u64,
    /// Whether it completed its cache ([`crate::Config::complete_cache`]):
    /// asked for every item placed elsewhere that it had not asked for
    /// yet (maybe none).
    #[serde(default)]
    pub cache_completed: bool,
    /// Memory high-water marks.
    pub memory: MemoryHighWater,
    /// Termination-detection waves (master only).
    pub termination_waves: u64,
    /// Epochs begun after the first ([`crate::Workload::next_epoch`];
    /// master only).
    #[serde(default)]
    pub epochs: u64,
}

impl ProcStats {
    /// Empty statistics for `addr`.
    pub fn new(addr: Addr) -> Self {
        ProcStats {
            addr,
            time_ns: StateTimes::default(),
            work: BTreeMap::new(),
            sent: ClassTraffic::default(),
            received: ClassTraffic::default(),
            bundles_sent: 0,
            tasks: TaskCounters::default(),
            cache: CacheCounters::default(),
            data_requests_sent: 0,
            data_items_requested: 0,
            data_requests_served: 0,
            data_items_served: 0,
            cache_completed: false,
            memory: MemoryHighWater::default(),
            termination_waves: 0,
            epochs: 0,
        }
    }

    /// Adds counted work.
    pub fn charge<K: WorkKind>(&mut self, charges: &[(K, u64)]) {
        for &(kind, units) in charges {
            let kind = kind.name();
            // Look up before inserting: no allocation on the hot path.
            match self.work.get_mut(kind) {
                Some(e) => *e = e.saturating_add(units),
                None => {
                    self.work.insert(kind.to_string(), units);
                }
            }
        }
    }

    /// Cache hit rate in `[0, 1]` (`None` without lookups).
    pub fn cache_hit_rate(&self) -> Option<f64> {
        let n = self.cache.hits + self.cache.misses;
        (n > 0).then(|| self.cache.hits as f64 / n as f64)
    }
}

/// Statistics of a whole run.
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
/// use hybrid_sched::{run_threads, Config, State};
///
/// let config = Config::new(2).with_cache_bytes(Some(16));
/// let stats = run_threads(Arc::new(Pairs), &config).unwrap().stats;
/// // The master handed out the five root tasks, the workers ran them, and the
/// // master merged their five results.
/// assert_eq!(stats.master.tasks.roots, 5);
/// assert_eq!(stats.sum(|p| p.tasks.demand_driven), 5);
/// assert_eq!(stats.master.tasks.results_merged, 5);
/// // Every item fetched was served by its owner.
/// let requested = stats.sum(|p| p.data_items_requested);
/// assert!(requested > 0);
/// assert_eq!(stats.sum(|p| p.data_items_served), requested);
/// assert_eq!(stats.sum(|p| p.cache.insertions), requested);
/// // Time is accounted per state; the whole of it goes to JSON.
/// for p in &stats.procs {
///     assert!(p.time_ns.get(State::Executing) <= p.time_ns.total());
/// }
/// assert!(stats.to_json().contains("\"data_items_served\""));
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RunStats {
    /// Which runtime produced them.
    pub runtime: String,
    /// Worker statistics, by processor index.
    pub procs: Vec<ProcStats>,
    /// Master statistics.
    pub master: ProcStats,
    /// Run time in nanoseconds (wall or virtual).
    pub elapsed_ns: u64,
}

impl RunStats {
    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("statistics are plain data")
    }

    /// Sum of a counter over all workers.
    pub fn sum<F: Fn(&ProcStats) -> u64>(&self, f: F) -> u64 {
        self.procs.iter().map(f).sum()
    }

    /// Total packets sent by every actor (master included).
    pub fn packets_sent(&self) -> u64 {
        self.sum(|p| p.sent.total().packets) + self.master.sent.total().packets
    }
}

/// What one rank of a distributed run (the MPI runtime) put on and took off
/// the wire: encoded bytes as transmitted, unlike the accounted bytes of
/// [`ProcStats::sent`] and [`ProcStats::received`], which model the
/// workload's data sizes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RankTraffic {
    /// The rank.
    pub rank: usize,
    /// Packets sent to other ranks.
    pub messages_sent: u64,
    /// Encoded bytes sent to other ranks.
    pub bytes_sent: u64,
    /// Packets received from other ranks.
    pub messages_received: u64,
    /// Encoded bytes received from other ranks.
    pub bytes_received: u64,
    /// Of the packets received: data requests and replies.
    pub data_messages_received: u64,
    /// Encoded bytes of those.
    pub data_bytes_received: u64,
    /// Packets between two actors on this rank (the master and processor 0
    /// on rank 0), delivered without MPI.
    pub local_packets: u64,
    /// Packets that arrived for an actor that had already finished (dropped).
    pub late_packets: u64,
    /// Peak resident memory of the rank's process as the operating system
    /// measured it at the end of its run ([`peak_resident_bytes`]; 0 where
    /// the system does not say).
    #[serde(default)]
    pub peak_resident_bytes: u64,
    /// The most encoded bytes the rank's process held for the wire at
    /// once: packets encoded for another rank and not yet delivered by MPI,
    /// and packets received and not yet decoded (its message buffers).
    #[serde(default)]
    pub peak_wire_bytes: u64,
    /// The rank's peak resident memory once MPI had started, before the
    /// workload's data was read (its fixed cost: the program, Open MPI and
    /// their threads); 0 where the system does not say.
    #[serde(default)]
    pub started_resident_bytes: u64,
}

impl RankTraffic {
    /// Adds `other`'s message and byte counts (another thread of the same
    /// rank: the master's, or the MPI thread's data server); the rank and
    /// the peak memory stay.
    pub fn add_counts(&mut self, other: &RankTraffic) {
        self.messages_sent += other.messages_sent;
        self.bytes_sent += other.bytes_sent;
        self.messages_received += other.messages_received;
        self.bytes_received += other.bytes_received;
        self.data_messages_received += other.data_messages_received;
        self.data_bytes_received += other.data_bytes_received;
        self.local_packets += other.local_packets;
        self.late_packets += other.late_packets;
    }
}

/// This process's peak resident memory as the operating system measured
/// it (Linux: `VmHWM` in `/proc/self/status`), in bytes; `None` elsewhere.
pub fn peak_resident_bytes() -> Option<u64> {
    proc_status_kib("VmHWM:").map(|k| k * 1024)
}

/// This process's resident memory now (Linux: `VmRSS`), in bytes.
pub fn resident_bytes() -> Option<u64> {
    proc_status_kib("VmRSS:").map(|k| k * 1024)
}

fn proc_status_kib(key: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}
