//! The master: hands out root tasks, pools `ViaMaster` children, merges
//! results addressed to it, detects termination, and runs epochs.
//!
//! # Epochs
//! What termination detection finds is the end of an epoch. The master
//! then asks the workload for the next one ([`Workload::next_epoch`]); if
//! there is one, it sends its broadcast to every processor
//! ([`Msg::Broadcast`]) and holds its roots back until every processor has
//! answered [`Msg::BroadcastHeld`] (both basic messages; the master is not
//! passive meanwhile), then serves the parked work requests. Detection
//! starts afresh (no earlier wave confirms a later one). Otherwise it sends
//! [`Msg::Terminate`].
//!
//! The master is an extra actor, not a worker (the paper's master also
//! traced; keeping it apart keeps it responsive, which matters most for the
//! `ViaMaster` policy, and costs one mostly idle thread).
//!
//! # Termination detection
//! Counters with a confirmation wave (Mattern's four-counter method). Every
//! actor counts the *basic* messages (everything but credits, probes and
//! termination) it has sent and received. When the master holds no work (no
//! roots left, no pooled tasks, empty mailbox) and every worker has a work
//! request parked with it, it sends a probe wave. A worker answers only when
//! passive (no queued, ready, deferred or waiting task, empty send backlog)
//! with its two counters. When all answers are in, the master adds its own
//! counters, taken at that moment and only if it is itself passive, giving the
//! wave's totals (S, R). Termination is declared when a wave's S equals the
//! previous complete wave's R (then S = R, too).
//!
//! Why this is exact: let wave 1 end at t1 and wave 2 start after t1. Every
//! wave-1 report was taken at or before t1 and every wave-2 report after t1,
//! and counters only grow, so R1 <= R(t1) <= S(t1) <= S2. If R1 = S2 all are
//! equal: no basic message was in transit at t1, and no actor received one
//! between its wave-1 report and t1. Each was passive at its report and only
//! a basic message can give a passive actor work, so all were passive at t1
//! with nothing in transit: no work existed anywhere and none could appear.
//! Conversely, once the computation is over every worker is passive with a
//! parked request, so two more waves always end the run: no hang.

use std::collections::VecDeque;
use std::sync::Arc;

use tracing::{debug, info};

use crate::bundle::Outbox;
use crate::clock::Time;
use crate::config::Config;
use crate::error::RunError;
use crate::mailbox::Mailbox;
use crate::processor::Step;
use crate::protocol::message::{DdEnvelope, Incoming, Msg, Packet};
use crate::protocol::workload::{Epoch, Workload};
use crate::protocol::{Addr, Pool};
use crate::stats::{ProcStats, State};

struct Wave {
    id: u64,
    answered: Vec<bool>,
    count: usize,
    sent: u64,
    received: u64,
}

/// The master actor. See the module documentation.
pub(crate) struct Master<W: Workload> {
    procs: usize,
    workload: Arc<W>,
    roots: VecDeque<W::DdTask>,
    pool: VecDeque<(DdEnvelope<W>, Addr, usize)>,
    /// Workers with a work request parked, and whether it allows a root
    /// task (at most one entry per worker: a new request replaces it).
    parked: VecDeque<(usize, bool)>,
    mailbox: Mailbox<Incoming<W>>,
    outbox: Outbox<W>,
    acc: W::Accumulator,
    stats: ProcStats,
    basic_sent: u64,
    basic_received: u64,
    wave: Option<Wave>,
    previous: Option<(u64, u64)>,
    next_wave: u64,
    finished: bool,
    /// The epoch running (0 the first).
    epoch: usize,
    /// Processors yet to say they hold the epoch's broadcast; its roots
    /// are handed out only once this is 0.
    awaiting_held: usize,
}

impl<W: Workload> Master<W> {
    /// The master of a run with `config.procs` workers.
    pub(crate) fn new(workload: Arc<W>, config: &Config) -> Self {
        let procs = config.procs;
        let credits = config.credits_per_link as u32;
        Master {
            procs,
            roots: workload.root_tasks(procs).into(),
            pool: VecDeque::new(),
            parked: VecDeque::new(),
            mailbox: Mailbox::new(),
            outbox: Outbox::new(
                Addr::Master,
                procs,
                config.bundle.clone(),
                credits,
                config.link_window_bytes(),
            ),
            acc: W::Accumulator::default(),
            stats: ProcStats::new(Addr::Master),
            basic_sent: 0,
            basic_received: 0,
            wave: None,
            previous: None,
            next_wave: 0,
            finished: false,
            epoch: 0,
            awaiting_held: 0,
            workload,
        }
    }

    /// Adds `ns` to the time spent in `state`.
    pub(crate) fn account(&mut self, state: State, ns: Time) {
        self.stats.time_ns.add(state, ns);
    }

    /// A packet arrived.
    pub(crate) fn deliver(&mut self, packet: Packet<W>, _now: Time) {
        self.stats
            .received
            .record(packet.class, packet.items.len(), packet.bytes);
        let from = packet.from;
        for msg in packet.items {
            if msg.is_basic() {
                self.basic_received += 1;
            }
            let class = msg.class();
            let bytes = msg.byte_size();
            let credited = self.outbox.arrived(from, class, bytes);
            self.mailbox.push(
                class,
                Incoming {
                    from,
                    msg,
                    bytes,
                    credited,
                },
            );
        }
    }

    /// Handles one message, or, with none left, does the idle duties.
    pub(crate) fn step(&mut self, now: Time) -> Result<Step, RunError> {
        if self.finished {
            return Ok(Step::Finished);
        }
        let Some((_, inc)) = self.mailbox.pop() else {
            self.outbox.return_credits(true, now);
            self.maybe_start_wave(now);
            return Ok(Step::Idle);
        };
        let from = inc.from;
        let worker = match from {
            Addr::Proc(p) if p < self.procs => p,
            _ => {
                return Err(RunError::Workload {
                    at: Addr::Master,
                    message: format!("message {:?} from unexpected sender {from}", inc.msg),
                })
            }
        };
        match inc.msg {
            Msg::WorkRequest { roots } => {
                // A worker's new request replaces its parked one (a worker
                // back under its backlog budget allows a root again).
                self.parked.retain(|&(w, _)| w != worker);
                if let Some((env, sender, bytes)) = self.pool.pop_front() {
                    self.hand_out(worker, env, now);
                    self.consume(sender, Pool::Tasks, bytes, now);
                } else if let Some(task) = roots.then(|| self.next_root()).flatten() {
                    self.hand_out_root(worker, task, now);
                } else {
                    self.parked.push_back((worker, roots));
                }
            }
            Msg::BroadcastHeld(epoch) => {
                if epoch as usize != self.epoch || self.awaiting_held == 0 {
                    return Err(RunError::Workload {
                        at: Addr::Master,
                        message: format!(
                            "processor {worker} holds the broadcast of epoch {epoch}, not asked for (epoch {})",
                            self.epoch
                        ),
                    });
                }
                self.awaiting_held -= 1;
                if self.awaiting_held == 0 {
                    // Every processor holds the data: the epoch's roots go
                    // to the workers waiting for work.
                    let waiting: Vec<(usize, bool)> = self.parked.drain(..).collect();
                    for (w, roots) in waiting {
                        match roots.then(|| self.next_root()).flatten() {
                            Some(task) => self.hand_out_root(w, task, now),
                            None => self.parked.push_back((w, roots)),
                        }
                    }
                }
            }
            Msg::Dd(env) => {
                // A `ViaMaster` child: to the first processor asking for work.
                self.stats.tasks.pooled += 1;
                if let Some((w, _)) = self.parked.pop_front() {
                    self.hand_out(w, env, now);
                    self.consume(from, Pool::Tasks, inc.bytes, now);
                } else {
                    self.pool.push_back((env, from, inc.bytes));
                }
            }
            Msg::Result(r) => {
                self.workload.merge(&mut self.acc, r);
                self.stats.tasks.results_merged += 1;
                self.consume(from, Pool::Results, inc.bytes, now);
            }
            Msg::ProbeReply {
                wave,
                sent,
                received,
            } => self.on_probe_reply(worker, wave, sent, received, now),
            other => {
                return Err(RunError::Workload {
                    at: Addr::Master,
                    message: format!("unexpected message {other:?} from {from}"),
                })
            }
        }
        Ok(Step::Worked(State::Receiving))
    }

    /// The next root task, unless the epoch's broadcast is still on its way.
    fn next_root(&mut self) -> Option<W::DdTask> {
        if self.awaiting_held > 0 {
            return None;
        }
        self.roots.pop_front()
    }

    fn hand_out_root(&mut self, worker: usize, task: W::DdTask, now: Time) {
        self.stats.tasks.roots += 1;
        let env = DdEnvelope {
            task,
            origin: None,
            handout: true,
            root: true,
        };
        self.hand_out(worker, env, now);
    }

    fn hand_out(&mut self, worker: usize, mut env: DdEnvelope<W>, now: Time) {
        env.handout = true;
        self.send(Addr::Proc(worker), Msg::Dd(env), now);
    }

    /// A credit-limited message from `from` is consumed. Pooled tasks stay in
    /// the input buffer until handed out, so the pool is bounded by credits.
    fn consume(&mut self, from: Addr, pool: Pool, bytes: usize, now: Time) {
        self.outbox.consumed(from, pool, bytes, now);
    }

    fn send(&mut self, to: Addr, msg: Msg<W>, now: Time) {
        if msg.is_basic() {
            self.basic_sent += 1;
        }
        self.outbox.push(to, msg, now);
    }

    /// Holds no work: no roots, no pooled tasks, nothing unprocessed.
    fn is_passive(&self) -> bool {
        self.roots.is_empty()
            && self.pool.is_empty()
            && self.mailbox.is_empty()
            && self.awaiting_held == 0
    }

    fn maybe_start_wave(&mut self, now: Time) {
        if self.wave.is_some() || !self.is_passive() || self.parked.len() < self.procs {
            return;
        }
        let id = self.next_wave;
        self.next_wave += 1;
        self.stats.termination_waves += 1;
        debug!(wave = id, "termination probe wave");
        self.wave = Some(Wave {
            id,
            answered: vec![false; self.procs],
            count: 0,
            sent: 0,
            received: 0,
        });
        for p in 0..self.procs {
            self.send(Addr::Proc(p), Msg::Probe(id), now);
        }
    }

    fn on_probe_reply(&mut self, worker: usize, id: u64, sent: u64, received: u64, now: Time) {
        let Some(wave) = self.wave.as_mut() else {
            return;
        };
        if wave.id != id || wave.answered[worker] {
            return;
        }
        wave.answered[worker] = true;
        wave.count += 1;
        wave.sent += sent;
        wave.received += received;
        if wave.count < self.procs {
            return;
        }
        let wave = self.wave.take().expect("checked above");
        if !self.is_passive() {
            // The master's own report must be taken while passive; this wave
            // cannot serve as the first of a confirming pair.
            self.previous = None;
            return;
        }
        let s = wave.sent + self.basic_sent;
        let r = wave.received + self.basic_received;
        match self.previous {
            Some((_, r_prev)) if r_prev == s && s == r => {
                info!(
                    waves = self.stats.termination_waves,
                    messages = s,
                    epoch = self.epoch,
                    "epoch over"
                );
                self.previous = None;
                match self.workload.next_epoch(self.epoch, &mut self.acc) {
                    Some(next) => self.begin_epoch(next, now),
                    None => {
                        self.finished = true;
                        for p in 0..self.procs {
                            self.send(Addr::Proc(p), Msg::Terminate, now);
                        }
                    }
                }
            }
            _ => self.previous = Some((s, r)),
        }
    }

    /// Starts the next epoch: its broadcast goes to every processor, and
    /// its roots wait until all of them hold it. (The master is not
    /// passive until then, so no termination wave can end it early.)
    fn begin_epoch(&mut self, next: Epoch<W>, now: Time) {
        self.epoch += 1;
        self.stats.epochs += 1;
        debug!(
            epoch = self.epoch,
            roots = next.roots.len(),
            broadcast = next.broadcast.len(),
            "epoch begins"
        );
        self.roots.extend(next.roots);
        self.awaiting_held = self.procs;
        let epoch = u32::try_from(self.epoch).unwrap_or(u32::MAX);
        for p in 0..self.procs {
            // Each processor gets its own copy (one message each, as a
            // transport would send them).
            let items = next.broadcast.clone();
            self.send(Addr::Proc(p), Msg::Broadcast { epoch, items }, now);
        }
    }

    /// Packets to transmit now.
    pub(crate) fn take_packets(&mut self, now: Time) -> Vec<Packet<W>> {
        self.outbox.pump(now, false);
        let packets = self.outbox.take_ready();
        for p in &packets {
            self.stats.sent.record(p.class, p.items.len(), p.bytes);
        }
        packets
    }

    /// Ends the run: the master's accumulator and statistics.
    pub(crate) fn finish(mut self) -> (W::Accumulator, ProcStats) {
        (
            self.stats.memory.input_buffer_items,
            self.stats.memory.input_buffer_bytes,
        ) = self.outbox.input_high_water();
        self.stats.memory.mailbox_items = self.mailbox.high_water();
        self.stats.memory.send_backlog = self.outbox.backlog_high_water();
        self.stats.memory.send_backlog_bytes = self.outbox.backlog_bytes_high_water();
        self.stats.memory.in_flight_bytes = self.outbox.in_flight_high_water();
        (self.acc, self.stats)
    }
}
