//! A deterministic discrete-event simulation of a cluster.
//!
//! The same `Node` state machines as every other runtime run in virtual
//! time. Nothing is measured: a step's duration comes from a [`CostModel`]
//! applied to the work the step charged (`Node::last_charges`), and a
//! packet's journey from a [`Network`] model:
//!
//! * the sender's CPU pays a software overhead per packet plus a cost per
//!   byte (marshalling, PVM/MPI buffers);
//! * the packet leaves when the sender's link is free and occupies it for
//!   `bytes / bandwidth`; it reaches the receiver `latency` later, after any
//!   packet already arriving on the receiver's link (both links are FIFO);
//! * the first packet between two actors also waits for the link's set-up
//!   (the Parsytec's "global message set-up");
//! * the receiver's CPU pays a per-packet and per-byte cost to take it in;
//! * with [`crate::DataService::OnArrival`], a data request is answered
//!   by its owner's data server when it arrives: the owner's CPU pays the
//!   request's receive cost and the reply's send cost then, and its
//!   current step (or wait) ends that much later.
//!
//! Events are ordered by (time, sequence number), so a run is a pure function
//! of the workload, the configuration and the model: the same inputs give the
//! same statistics, byte for byte. The optional latency jitter draws from a
//! seeded generator and keeps that property.
//!
//! Besides the usual results and statistics (with virtual times) the
//! report carries a [`Timeline`] ([`RunReport::timeline`]): for every
//! actor, the time spent in each [`State`] per time bucket, from which
//! "processors clipping over time", "idle over time" and similar figures
//! are drawn.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, HashSet};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::Timeline;
use super::{assemble, Extras, Node, RunReport, Runtime};
use crate::clock::Time;
use crate::config::{Config, DataService};
use crate::error::{ConfigError, RunError};
use crate::processor::Step;
use crate::protocol::message::Packet;
use crate::protocol::workload::{WorkKind, Workload};
use crate::protocol::{Addr, Class};
use crate::rng::SplitMix64;
use crate::server::DataServer;
use crate::stats::State;

/// Compute costs in nanoseconds of this machine's CPU; the network's
/// `cpu_scale` turns them into the simulated machine's. (Message overheads
/// are given in the simulated machine's time already, in [`Network`].)
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostModel {
    /// Cost of one charged unit of each work kind ([`crate::Ctx::charge`]),
    /// by [`WorkKind::name`]. A run rejects names its workload does not
    /// declare ([`CostModel::check`]).
    pub unit_ns: BTreeMap<String, f64>,
    /// Cost of a unit of a kind missing from `unit_ns`.
    pub default_unit_ns: f64,
    /// Fixed cost of every processor step (mailbox, bookkeeping).
    pub step_ns: f64,
    /// Cost of one master step (hand-out, probe, forwarding).
    pub master_step_ns: f64,
    /// Cost per byte of storing received data items in the cache.
    pub cache_byte_ns: f64,
}

impl Default for CostModel {
    fn default() -> Self {
        CostModel {
            unit_ns: BTreeMap::new(),
            default_unit_ns: 100.0,
            step_ns: 300.0,
            master_step_ns: 500.0,
            cache_byte_ns: 0.05,
        }
    }
}

impl CostModel {
    /// Sets the cost of one unit of `kind`.
    pub fn with_unit<K: WorkKind>(mut self, kind: K, ns: f64) -> Self {
        self.unit_ns.insert(kind.name().to_string(), ns);
        self
    }

    /// Checks that every kind named in `unit_ns` is one of `K`'s (a
    /// misspelt name would otherwise cost nothing, silently).
    pub fn check<K: WorkKind>(&self) -> Result<(), ConfigError> {
        match self.unit_ns.keys().find(|k| K::from_name(k).is_none()) {
            Some(k) => Err(ConfigError::UnknownWorkKind {
                name: k.clone(),
                known: K::ALL
                    .iter()
                    .map(|k| k.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            }),
            None => Ok(()),
        }
    }

    /// Nanoseconds of this machine for `charges`.
    pub fn cost<K: WorkKind>(&self, charges: &[(K, u64)]) -> f64 {
        charges
            .iter()
            .map(|&(kind, units)| {
                units as f64
                    * self
                        .unit_ns
                        .get(kind.name())
                        .copied()
                        .unwrap_or(self.default_unit_ns)
            })
            .sum()
    }
}

/// The simulated machine: processor speed and interconnect.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Network {
    /// Preset name (`parsytec-cc`, `10gbe`) or `custom`.
    pub name: String,
    /// How many times slower than this machine's core a node computes.
    pub cpu_scale: f64,
    /// Sender CPU time per packet (software set-up of a message), in the
    /// simulated machine's nanoseconds (not scaled by `cpu_scale`).
    pub send_overhead_ns: f64,
    /// Receiver CPU time per packet.
    pub recv_overhead_ns: f64,
    /// CPU time per byte, paid at each end (copies, marshalling).
    pub cpu_byte_ns: f64,
    /// Wire latency.
    pub latency_ns: f64,
    /// Link bandwidth in bytes per second (each actor has one link in and
    /// one out).
    pub bandwidth: f64,
    /// Extra delay of the first packet between two actors (route set-up).
    pub link_setup_ns: f64,
    /// Uniform latency jitter as a fraction of `latency_ns` (seeded).
    pub jitter: f64,
}

impl Network {
    /// The paper's machine: a 32-node Parsytec CC with 133 MHz PowerPC 604
    /// nodes under PVM. Links carry 27 MB/s; PVM's software overhead per
    /// message is of the order of 100 µs on such nodes. Compute runs 40
    /// times slower than one core of this machine (a 133 MHz PowerPC 604
    /// against a ~3 GHz out-of-order x86 core: clock ratio ~22, work per
    /// clock ~2).
    ///
    /// A route between two nodes is set up on first use, which the paper
    /// reports as "of the order of seconds" against runs of five hours
    /// (18072 s sequential): about 0.3% of a 32-processor run. Our renders
    /// are some 500 times shorter, so the preset keeps that share instead of
    /// the absolute figure: 5 ms per route. (At 1 s, set-up would be most of
    /// every simulated run and hide everything the experiments are about.)
    pub fn parsytec_cc() -> Self {
        Network {
            name: "parsytec-cc".into(),
            cpu_scale: 40.0,
            send_overhead_ns: 100_000.0,
            recv_overhead_ns: 50_000.0,
            cpu_byte_ns: 10.0,
            latency_ns: 50_000.0,
            bandwidth: 27.0e6,
            link_setup_ns: 5.0e6,
            jitter: 0.0,
        }
    }

    /// A modern cluster of machines like this one on 10 Gigabit Ethernet
    /// (MPI over TCP): 1.25 GB/s, 10 µs latency, a few µs of software
    /// overhead per message, no set-up cost.
    pub fn ten_gbe() -> Self {
        Network {
            name: "10gbe".into(),
            cpu_scale: 1.0,
            send_overhead_ns: 3_000.0,
            recv_overhead_ns: 2_000.0,
            cpu_byte_ns: 0.1,
            latency_ns: 10_000.0,
            bandwidth: 1.25e9,
            link_setup_ns: 0.0,
            jitter: 0.0,
        }
    }

    /// A preset by name: `parsytec-cc` (or `parsytec`), `10gbe`.
    pub fn preset(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "parsytec-cc" | "parsytec" | "parsytec_cc" => Some(Self::parsytec_cc()),
            "10gbe" | "10gbe-cluster" | "ten-gbe" => Some(Self::ten_gbe()),
            _ => None,
        }
    }

    /// Names accepted by [`Network::preset`].
    pub const PRESETS: [&'static str; 2] = ["parsytec-cc", "10gbe"];

    fn transfer_ns(&self, bytes: usize) -> f64 {
        bytes as f64 / self.bandwidth * 1e9
    }
}

/// The simulator: a cost model, a network and a seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sim {
    pub cost: CostModel,
    pub network: Network,
    /// Seed of the latency jitter.
    pub seed: u64,
    /// Initial timeline bucket width in virtual ns (`None`: 10 µs); the
    /// timeline doubles it whenever the run outgrows [`MAX_BUCKETS`](super::MAX_BUCKETS).
    pub bucket_ns: Option<u64>,
    /// Give up after this many events (a livelock guard).
    pub max_events: u64,
}

impl Sim {
    /// A simulator with `cost` on `network`, seed 0.
    pub fn new(cost: CostModel, network: Network) -> Self {
        Sim {
            cost,
            network,
            seed: 0,
            bucket_ns: None,
            max_events: 2_000_000_000,
        }
    }
}

#[async_trait::async_trait]
impl<W: Workload> Runtime<W> for Sim {
    fn name(&self) -> &'static str {
        "sim"
    }

    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        run_sim(workload, config, self)
    }
}

#[derive(Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Event {
    /// Actor `slot` may take its next step.
    Run(usize),
    /// Packet number `id` reaches its receiver.
    Arrive(u64),
}

/// The network's state: links, packets on their way, the event queue.
struct Wires<W: Workload> {
    queue: BinaryHeap<Reverse<(Time, u64, Event)>>,
    seq: u64,
    in_flight: BTreeMap<u64, Packet<W>>,
    /// When each actor's outgoing and incoming link is free.
    out_free: Vec<Time>,
    in_free: Vec<Time>,
    /// Routes set up so far.
    links: HashSet<(usize, usize)>,
    rng: SplitMix64,
}

impl<W: Workload> Wires<W> {
    fn push(&mut self, at: Time, event: Event) {
        self.queue.push(Reverse((at, self.seq, event)));
        self.seq += 1;
    }

    /// `packet` leaves actor `slot`'s CPU at `now`: it departs when the
    /// sender's link is free and arrives after the latency (and the
    /// route's set-up the first time), after any packet arriving before it.
    fn transmit(&mut self, net: &Network, slot: usize, packet: Packet<W>, now: Time, procs: usize) {
        let ns = |x: f64| -> Time { x.max(0.0).round() as Time };
        let dst = packet.to.slot(procs);
        let tx = ns(net.transfer_ns(packet.bytes));
        let depart = now.max(self.out_free[slot]);
        self.out_free[slot] = depart + tx;
        let mut lat = net.latency_ns;
        if net.jitter > 0.0 {
            lat *= 1.0 + net.jitter * self.rng.next_f64();
        }
        if self.links.insert((slot, dst)) {
            lat += net.link_setup_ns;
        }
        let arrive = (depart + ns(lat)).max(self.in_free[dst]) + tx;
        self.in_free[dst] = arrive;
        self.in_flight.insert(self.seq, packet);
        self.push(arrive, Event::Arrive(self.seq));
    }
}

/// Runs `workload` in the simulator; returns the report (virtual times)
/// and the timeline.
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
/// use hybrid_sched::{run_sim, Config, CostModel, Network, Sim};
///
/// let config = Config::new(2).with_cache_bytes(Some(16));
/// let fast = Sim::new(CostModel::default(), Network::preset("10gbe").unwrap());
/// let report = run_sim(Arc::new(Pairs), &config, &fast).unwrap();
/// assert_eq!(report.master, 35);
/// assert_eq!(report.stats.runtime, "sim");
/// assert!(report.timeline().unwrap().buckets() > 0);
///
/// // Virtual time: the same inputs give the same statistics, byte for byte.
/// let again = run_sim(Arc::new(Pairs), &config, &fast).unwrap();
/// assert_eq!(again.stats, report.stats);
///
/// // The paper's machine computes and communicates far more slowly.
/// let slow = Sim::new(CostModel::default(), Network::parsytec_cc());
/// let old = run_sim(Arc::new(Pairs), &config, &slow).unwrap();
/// assert_eq!(old.master, 35);
/// assert!(old.stats.elapsed_ns > report.stats.elapsed_ns);
/// ```
pub fn run_sim<W: Workload>(
    workload: Arc<W>,
    config: &Config,
    sim: &Sim,
) -> Result<RunReport<W>, RunError> {
    let net = &sim.network;
    if !(net.bandwidth > 0.0 && net.cpu_scale > 0.0) {
        return Err(RunError::Runtime(
            "simulated network needs a positive bandwidth and cpu scale".into(),
        ));
    }
    sim.cost.check::<W::Work>()?;
    let mut nodes: Vec<Option<Node<W>>> = Node::build_all(&workload, config)?
        .into_iter()
        .map(Some)
        .collect();
    let n = nodes.len();
    let procs = config.procs;
    let master = procs;
    let ns = |x: f64| -> Time { x.max(0.0).round() as Time };
    let scale = net.cpu_scale;

    let mut wires = Wires {
        queue: BinaryHeap::new(),
        seq: 0,
        in_flight: BTreeMap::new(),
        out_free: vec![0; n],
        in_free: vec![0; n],
        links: HashSet::new(),
        rng: SplitMix64::new(sim.seed ^ 0x5151_5EED),
    };
    let servers: Vec<_> = nodes
        .iter()
        .map(|node| node.as_ref().and_then(Node::server))
        .collect();
    let on_arrival = config.data_service == DataService::OnArrival;
    let mut free_at = vec![0 as Time; n];
    let mut scheduled = vec![false; n];
    let mut blocked_since: Vec<Option<(Time, State)>> = vec![None; n];
    let mut finished: Vec<_> = Vec::with_capacity(n);
    let mut done = vec![false; n];
    let mut timeline = Timeline::new(n, sim.bucket_ns.unwrap_or(10_000));
    let mut end = 0 as Time;

    for (slot, s) in scheduled.iter_mut().enumerate() {
        wires.push(0, Event::Run(slot));
        *s = true;
    }
    let mut events = 0u64;
    while let Some(Reverse((t, _, event))) = wires.queue.pop() {
        events += 1;
        if events > sim.max_events {
            return Err(RunError::Runtime(format!(
                "simulation gave up after {} events at virtual time {:.3} s",
                sim.max_events,
                t as f64 * 1e-9
            )));
        }
        if let Some(limit) = config.time_limit {
            if t > limit.as_nanos() as Time {
                return Err(RunError::TimedOut { limit });
            }
        }
        match event {
            Event::Arrive(id) => {
                let packet = wires.in_flight.remove(&id).expect("packet in flight");
                let slot = packet.to.slot(procs);
                if done[slot] {
                    return Err(RunError::Runtime(format!(
                        "{} sent a message to {}, which has already finished",
                        packet.from, packet.to
                    )));
                }
                if let Some(server) = servers[slot]
                    .as_ref()
                    .filter(|_| on_arrival && DataServer::is_request(&packet))
                {
                    // Answered now on the owner's CPU (module doc).
                    let cost_in = net.recv_overhead_ns + net.cpu_byte_ns * packet.bytes as f64;
                    let reply = server.serve(packet).map_err(|message| RunError::Workload {
                        at: Addr::from_slot(slot, procs),
                        message,
                    })?;
                    let cost_out = net.send_overhead_ns + net.cpu_byte_ns * reply.bytes as f64;
                    let d = ns(cost_in + cost_out);
                    let node = nodes[slot].as_mut().expect("live node");
                    node.account(State::ServingData, d);
                    timeline.sent(slot, reply.class, t + d, reply.bytes);
                    wires.transmit(net, slot, reply, t + d, procs);
                    match blocked_since[slot].as_mut() {
                        // Waiting: the wait resumes after the service.
                        Some((since, state)) => {
                            let from = (*since).max(free_at[slot]);
                            if t > from {
                                node.account(*state, t - from);
                                timeline.add(slot, *state, from, t);
                            }
                            timeline.add(slot, State::ServingData, t.max(from), t.max(from) + d);
                            *since = t.max(from) + d;
                            free_at[slot] = *since;
                        }
                        // Busy: its step ends that much later.
                        None => {
                            let busy_until = free_at[slot].max(t);
                            timeline.add(slot, State::ServingData, busy_until, busy_until + d);
                            free_at[slot] = busy_until + d;
                        }
                    }
                    end = end.max(free_at[slot]);
                    continue;
                }
                let node = nodes[slot].as_mut().expect("live node");
                // An actor waiting for input wakes up now; a busy one takes
                // the packet in after its current step.
                let start = if let Some((since, state)) = blocked_since[slot].take() {
                    let from = since.max(free_at[slot]);
                    if t > from {
                        node.account(state, t - from);
                        timeline.add(slot, state, from, t);
                    }
                    t.max(free_at[slot])
                } else {
                    t.max(free_at[slot])
                };
                let bytes = packet.bytes;
                let is_data = packet.class == Class::Data;
                node.deliver(packet, start);
                let mut cost = net.recv_overhead_ns + net.cpu_byte_ns * bytes as f64;
                if is_data {
                    cost += sim.cost.cache_byte_ns * bytes as f64 * scale;
                }
                let d = ns(cost);
                node.account(State::Receiving, d);
                timeline.add(slot, State::Receiving, start, start + d);
                free_at[slot] = start + d;
                if !scheduled[slot] {
                    scheduled[slot] = true;
                    wires.push(free_at[slot], Event::Run(slot));
                }
            }
            Event::Run(slot) => {
                scheduled[slot] = false;
                if done[slot] {
                    continue;
                }
                if t < free_at[slot] {
                    // A packet was taken in meanwhile: run when free.
                    scheduled[slot] = true;
                    wires.push(free_at[slot], Event::Run(slot));
                    continue;
                }
                let node = nodes[slot].as_mut().expect("live node");
                let step = node.step(t)?;
                let work = if slot == master {
                    sim.cost.master_step_ns
                } else {
                    sim.cost.step_ns + sim.cost.cost(node.last_charges())
                };
                let d = ns(work * scale);
                let mut now = t;
                match step {
                    Step::Worked(state) => {
                        node.account(state, d);
                        timeline.add(slot, state, now, now + d);
                        now += d;
                    }
                    Step::Idle | Step::Finished => {}
                }
                let packets = node.take_packets(now);
                for packet in packets {
                    let so = ns(net.send_overhead_ns + net.cpu_byte_ns * packet.bytes as f64);
                    node.account(State::Sending, so);
                    timeline.add(slot, State::Sending, now, now + so);
                    now += so;
                    timeline.sent(slot, packet.class, now, packet.bytes);
                    wires.transmit(net, slot, packet, now, procs);
                }
                free_at[slot] = now;
                end = end.max(now);
                match step {
                    Step::Finished => {
                        done[slot] = true;
                        let node = nodes[slot].take().expect("live node");
                        let addr = node.addr();
                        let (acc, st) = node.finish();
                        finished.push((addr, acc, st));
                    }
                    Step::Worked(_) => {
                        scheduled[slot] = true;
                        wires.push(now, Event::Run(slot));
                    }
                    Step::Idle => {
                        blocked_since[slot] = Some((now, node.blocked_state()));
                    }
                }
            }
        }
        if done.iter().all(|&d| d) {
            break;
        }
    }
    if let Some(slot) = done.iter().position(|d| !d) {
        return Err(RunError::Runtime(format!(
            "simulation stalled: {} waits for a message that never comes",
            Addr::from_slot(slot, procs)
        )));
    }
    // Actors that finished early are idle until the end of the run.
    for (addr, _, st) in &mut finished {
        let slot = addr.slot(procs);
        let total = st.time_ns.total();
        if total < end {
            st.time_ns.add(State::Idle, end - total);
            timeline.add(slot, State::Idle, total.min(end), end);
        }
    }
    let mut report = assemble("sim", procs, finished, end);
    report.extras = Extras::Timeline(timeline);
    Ok(report)
}
