//! The MPI runtime (feature `mpi`): one worker processor per MPI rank, the
//! master on rank 0 next to processor 0, so `mpirun -np N` runs N
//! processors.
//!
//! # Threads
//! Every MPI call (initialisation, sends, receives, the final barrier,
//! finalisation, abort) happens on one dedicated thread per rank, the *MPI
//! thread*; MPI is initialised with [`mpi::Threading::Funneled`], which is
//! all that needs. The *processor loop* on the calling thread drives the
//! rank's actors with exactly the `Node` calls the threads runtime makes
//! (`deliver`, `step`, `take_packets`, `account`, `blocked_state`, `finish`)
//! and talks to the MPI thread through std channels: it hands over encoded
//! packets and receives encoded packets. On rank 0 the master runs on a
//! thread of its own, the *master thread*, with the same calls: the MPI
//! thread hands it the packets tagged [`TAG_MASTER`] directly, so a
//! processor's request for work is answered while processor 0 is in the
//! middle of a step (sharing the processor loop, the master waited for
//! that step to end, and on the studio scene at `-np 2` rank 1 was idle
//! 35% of the time). The master and processor 0 exchange encoded packets
//! through the same channels, without MPI.
//!
//! Where the run answers data requests on arrival
//! ([`crate::DataService::OnArrival`]), a processor sends its requests
//! with tag [`TAG_DATA`], and the owner's MPI thread answers them itself
//! with the rank's data server (decoding the request and encoding the
//! reply there), while the processor loop computes. A request that
//! arrives before the owner's run has given its MPI thread the server
//! goes to the processor loop, which answers it between steps. The
//! server's traffic joins the rank's [`RankTraffic`].
//!
//! # Wire format
//! One MPI message (tag [`TAG_PACKET`]) is the postcard encoding of one
//! [`Packet`]. At the end every rank other than 0 sends one message (tag
//! [`TAG_FINAL`]) to rank 0 with the postcard encoding of its actors'
//! accumulators and statistics and its [`RankTraffic`]; rank 0 assembles the
//! [`RunReport`]. (This gather is point-to-point on purpose: it travels
//! through the same non-blocking loop as everything else, so a rank still
//! completing a late send never blocks a collective.)
//!
//! The MPI thread never blocks in MPI: it polls with `MPI_Improbe`, sends
//! with `MPI_Isend` and tests outstanding sends, so two ranks sending large
//! messages to each other cannot deadlock. When idle it waits on its command
//! channel with a short, growing timeout (20 µs to 100 µs), so an
//! oversubscribed rank does not burn a core polling.
//!
//! # Errors
//! Nothing here hangs on a failure it can see:
//! * a message that cannot be decoded is a [`RunError::Runtime`] naming the
//!   receiving and the sending rank and the reason;
//! * [`Config::time_limit`] bounds the processor loop, and the final
//!   barrier waits at most [`FINISH_GRACE`] (or the rest of the time limit,
//!   if longer);
//! * after an error the caller prints it and calls [`abort`], which calls
//!   `MPI_Abort` so that `mpirun` ends every rank with a non-zero status;
//! * a rank that dies (a crash, a kill, an exit without `MPI_Finalize`) makes
//!   `mpirun` terminate the job and exit non-zero.
//!
//! # Fault injection (tests)
//! The environment variable `HYBRID_SCHED_MPI_FAULT` makes one rank
//! misbehave: `garbage:R` makes rank R send an undecodable message instead
//! of its first packet, `exit:R` makes rank R exit (status 3, without
//! finalising MPI) after its first step, `no-server:R` keeps rank R's
//! data server off its MPI thread, so every data request to R takes the
//! path of one that arrives before a rank has installed it (answered by
//! the processor loop, between steps).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::mpsc::{RecvTimeoutError, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::clock::{Clock, WallClock};
use crate::config::{Config, DataService};
use crate::error::RunError;
use crate::master::Master;
use crate::processor::{Processor, Step};
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::{Addr, Class};
use crate::runtime::{assemble, Extras, Node, RunReport, Runtime};
use crate::server::DataServer;
use crate::stats::{ProcStats, RankTraffic, State};

use self::master::{master_loop, Finished, LOOP_DONE, LOOP_FAILED, LOOP_RUNNING};
pub use self::transport::{
    abort, decode_packet, encode_packet, init, last_world, started_peak_bytes, world, World,
    TAG_DATA, TAG_FINAL, TAG_MASTER, TAG_PACKET,
};
use self::transport::{
    decode, finish, host, idle_wait, phase, runtime_err, Cmd, Event, MasterChannels, Phase, Session,
};

mod master;
mod serve;
mod transport;
mod wire;

/// How long a rank waits at the final barrier for the others when the time
/// limit leaves less (or there is none).
pub const FINISH_GRACE: Duration = Duration::from_secs(60);

/// The MPI runtime: one processor per rank, the master on rank 0. MPI must
/// be running ([`init`]); a process runs one MPI job.
#[derive(Clone, Copy, Debug, Default)]
pub struct Mpi;

#[async_trait::async_trait]
impl<W: Workload> Runtime<W> for Mpi {
    fn name(&self) -> &'static str {
        "mpi"
    }

    async fn run(&self, workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
        run_mpi(workload, config)
    }
}

/// Runs `workload` with this rank's actors: processor `rank`, and on rank 0
/// the master too. `config.procs` must equal the number of ranks.
///
/// Returns the assembled report on rank 0, with the traffic per rank in
/// [`Extras::Ranks`]; every other rank returns an empty report marked
/// [`Extras::NotRoot`].
/// On success MPI is finalised (an MPI job runs once per process); on error
/// it keeps running so that the caller can print the error and [`abort`].
pub fn run_mpi<W: Workload>(workload: Arc<W>, config: &Config) -> Result<RunReport<W>, RunError> {
    config.validate_for(&*workload)?;
    let mut guard = phase();
    let Phase::Running(session) = &mut *guard else {
        return Err(runtime_err(
            "MPI is not running in this process (initialise it with runtime::mpi::init first)",
        ));
    };
    let world = session.world;
    if config.procs != world.size {
        return Err(runtime_err(format!(
            "rank {}: the run is configured for {} processors but the MPI job has {} ranks (one processor per rank)",
            world.rank, config.procs, world.size
        )));
    }
    let started = Instant::now();
    let deadline = config.time_limit.map(|limit| (started + limit, limit));
    let fault = Fault::from_env(world.rank);
    // Only rank 0 has a master; elsewhere its channels go now.
    let channels = session.master.take().filter(|_| world.rank == 0);
    let master = channels.map(|ch| {
        let node = Node::Master(Box::new(Master::new(workload.clone(), config)));
        (node, ch)
    });
    let to_master = master.as_ref().map(|(_, ch)| ch.to_master.clone());
    let mut rank_loop = RankLoop::new(session, workload, config, deadline, fault, to_master)?;
    let answering = rank_loop.install_data_handler();
    let ran = run_rank(&mut rank_loop, master, deadline, world.size);
    if answering {
        *session.data.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
    ran?;
    rank_loop.merge_served();
    let RankLoop {
        clock,
        finished,
        finals,
        traffic,
        ..
    } = rank_loop;
    let elapsed = clock.now();
    let finish_by = deadline
        .map_or(started, |(d, _)| d)
        .max(Instant::now() + FINISH_GRACE);
    finish(session, finish_by)?;
    *guard = Phase::Finalized(world);
    if world.rank != 0 {
        let mut report = assemble("mpi", world.size, Vec::new(), elapsed);
        report.extras = Extras::NotRoot { rank: world.rank };
        return Ok(report);
    }
    let mut all = finished;
    let mut ranks = vec![RankTraffic {
        peak_resident_bytes: crate::stats::peak_resident_bytes().unwrap_or(0),
        peak_wire_bytes: wire::WIRE.peak(),
        started_resident_bytes: started_peak_bytes(),
        ..traffic
    }];
    for f in finals.into_iter().skip(1).flatten() {
        all.extend(f.nodes);
        ranks.push(f.traffic);
    }
    let mut report = assemble("mpi", world.size, all, elapsed);
    report.extras = Extras::Ranks(ranks);
    Ok(report)
}

/// Runs this rank's processor loop, and on rank 0 the master's thread
/// beside it; the master's statistics and traffic join the loop's.
fn run_rank<W: Workload>(
    rank_loop: &mut RankLoop<'_, W>,
    master: Option<(Node<W>, MasterChannels)>,
    deadline: Option<(Instant, Duration)>,
    size: usize,
) -> Result<(), RunError> {
    match master {
        None => rank_loop.run()?,
        Some((node, ch)) => {
            let cmds = rank_loop.session.cmds.clone();
            let loop_state = AtomicU8::new(LOOP_RUNNING);
            let (looped, mastered) = std::thread::scope(|s| {
                let master = std::thread::Builder::new()
                    .name("master".into())
                    .spawn_scoped(s, || {
                        master_loop(node, ch, cmds, size, deadline, &loop_state, FINISH_GRACE)
                    });
                let Ok(master) = master else {
                    return (
                        Err(runtime_err("rank 0: cannot start the master's thread")),
                        None,
                    );
                };
                let looped = rank_loop.run();
                let state = if looped.is_ok() {
                    LOOP_DONE
                } else {
                    LOOP_FAILED
                };
                loop_state.store(state, Ordering::Relaxed);
                let mastered = master
                    .join()
                    .unwrap_or_else(|_| Err(runtime_err("rank 0: the master's thread panicked")));
                (looped, Some(mastered))
            });
            // The master's own error first: the loop only heard of it.
            let ((addr, acc, stats), traffic) = match (mastered, looped) {
                (Some(Err(e)), _) | (_, Err(e)) => return Err(e),
                (Some(Ok(Some(m))), Ok(())) => m,
                (_, Ok(())) => return Err(runtime_err("rank 0: the master did not finish")),
            };
            rank_loop.finished.push((addr, acc, stats));
            rank_loop.traffic.add_counts(&traffic);
        }
    }
    Ok(())
}

/// A rank's part of the result, sent to rank 0 at the end.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
struct FinalReport<W: Workload> {
    rank: usize,
    nodes: Vec<(Addr, W::Accumulator, ProcStats)>,
    traffic: RankTraffic,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    Garbage,
    Exit,
    NoServer,
}

impl Fault {
    fn from_env(rank: usize) -> Option<Fault> {
        Fault::parse(&std::env::var("HYBRID_SCHED_MPI_FAULT").ok()?, rank)
    }

    fn parse(spec: &str, rank: usize) -> Option<Fault> {
        let (kind, at) = spec.split_once(':')?;
        if at.trim().parse::<usize>().ok()? != rank {
            return None;
        }
        match kind.trim() {
            "garbage" => Some(Fault::Garbage),
            "exit" => Some(Fault::Exit),
            "no-server" => Some(Fault::NoServer),
            _ => None,
        }
    }
}

/// The processor loop of one rank.
struct RankLoop<'s, W: Workload> {
    session: &'s Session,
    rank: usize,
    size: usize,
    clock: WallClock,
    deadline: Option<(Instant, Duration)>,
    /// Processor `rank` (one slot: the master has its own thread).
    nodes: Vec<Option<Node<W>>>,
    /// Rank 0: the master's inbox (its packets are encoded as they would
    /// be for MPI and travel in-process).
    to_master: Option<std::sync::mpsc::Sender<Event>>,
    local: VecDeque<Packet<W>>,
    finished: Vec<Finished<W>>,
    /// Final reports by rank (rank 0 only).
    finals: Vec<Option<FinalReport<W>>>,
    traffic: RankTraffic,
    /// Data requests go tagged [`TAG_DATA`], answered by their owner's
    /// MPI thread ([`DataService::OnArrival`]).
    on_arrival: bool,
    /// What this rank's MPI thread answered for it.
    served: Arc<std::sync::Mutex<RankTraffic>>,
    fault: Option<Fault>,
}

impl<'s, W: Workload> RankLoop<'s, W> {
    fn new(
        session: &'s Session,
        workload: Arc<W>,
        config: &Config,
        deadline: Option<(Instant, Duration)>,
        fault: Option<Fault>,
        to_master: Option<std::sync::mpsc::Sender<Event>>,
    ) -> Result<Self, RunError> {
        let World { rank, size } = session.world;
        // Only this rank's processor: it loads only its own partition.
        let nodes = vec![Some(Node::Worker(Box::new(Processor::new(
            rank, workload, config,
        )?)))];
        Ok(RankLoop {
            to_master,
            session,
            rank,
            size,
            clock: WallClock::new(),
            deadline,
            nodes,
            local: VecDeque::new(),
            finished: Vec::new(),
            finals: (0..size).map(|_| None).collect(),
            traffic: RankTraffic {
                rank,
                ..RankTraffic::default()
            },
            on_arrival: config.data_service == DataService::OnArrival,
            served: Arc::default(),
            fault,
        })
    }

    fn slot_of(&self, addr: Addr) -> Option<usize> {
        match addr {
            Addr::Proc(p) if p == self.rank => Some(0),
            _ => None,
        }
    }

    fn gone(&self) -> RunError {
        runtime_err(format!(
            "rank {}: the MPI thread stopped unexpectedly",
            self.rank
        ))
    }

    fn run(&mut self) -> Result<(), RunError> {
        loop {
            // Everything that arrived.
            loop {
                match self.session.events.try_recv() {
                    Ok(ev) => self.on_event(ev)?,
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return Err(self.gone()),
                }
            }
            while let Some(packet) = self.local.pop_front() {
                self.deliver(packet);
            }
            // One step of every live actor.
            let mut worked = false;
            for slot in 0..self.nodes.len() {
                let Some(node) = self.nodes[slot].as_mut() else {
                    continue;
                };
                let t1 = self.clock.now();
                let step = node.step(t1)?;
                let t2 = self.clock.now();
                match step {
                    Step::Worked(state) => node.account(state, t2 - t1),
                    _ => node.account(State::Sending, t2 - t1),
                }
                let packets = node.take_packets(t2);
                if !packets.is_empty() {
                    for packet in packets {
                        self.route(packet)?;
                    }
                    let t3 = self.clock.now();
                    if let Some(node) = self.nodes[slot].as_mut() {
                        node.account(State::Sending, t3 - t2);
                    }
                }
                if self.fault == Some(Fault::Exit) {
                    eprintln!("rank {}: fault injection: exiting", self.rank);
                    std::process::exit(3);
                }
                match step {
                    Step::Finished => {
                        if let Some(node) = self.nodes[slot].take() {
                            let addr = node.addr();
                            let (acc, stats) = node.finish();
                            self.finished.push((addr, acc, stats));
                        }
                        worked = true;
                    }
                    Step::Worked(_) => worked = true,
                    Step::Idle => {}
                }
            }
            if self.nodes.iter().all(Option::is_none) && self.local.is_empty() {
                if self.rank != 0 {
                    return self.send_final();
                }
                if self.finals.iter().skip(1).all(Option::is_some) {
                    return Ok(());
                }
            }
            let wait = idle_wait(self.deadline)?;
            if !worked && self.local.is_empty() {
                let t = self.clock.now();
                let got = self.session.events.recv_timeout(wait);
                let t4 = self.clock.now();
                for node in self.nodes.iter_mut().flatten() {
                    let state = node.blocked_state();
                    node.account(state, t4 - t);
                }
                match got {
                    Ok(ev) => self.on_event(ev)?,
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => return Err(self.gone()),
                }
            }
        }
    }

    fn on_event(&mut self, ev: Event) -> Result<(), RunError> {
        if let Event::Received { from, bytes, .. } = &ev {
            if *from != self.rank {
                wire::WIRE.release(bytes.len());
            }
        }
        match ev {
            // A data request the MPI thread had no handler for yet is
            // answered between steps.
            Event::Received {
                from,
                tag: TAG_PACKET | TAG_DATA,
                bytes,
            } => {
                self.traffic.messages_received += 1;
                self.traffic.bytes_received += bytes.len() as u64;
                let packet = decode_packet::<W>(&bytes, from, self.rank)?;
                if host(packet.from) != from {
                    return Err(runtime_err(format!(
                        "rank {}: rank {from} sent a packet claiming to come from {}",
                        self.rank, packet.from
                    )));
                }
                if packet.class == Class::Data {
                    self.traffic.data_messages_received += 1;
                    self.traffic.data_bytes_received += bytes.len() as u64;
                }
                self.deliver(packet);
                Ok(())
            }
            Event::Received {
                from,
                tag: TAG_FINAL,
                bytes,
            } if self.rank == 0 && from < self.size => {
                let report: FinalReport<W> = decode(&bytes, "final report", from, self.rank)?;
                if report.rank != from {
                    return Err(runtime_err(format!(
                        "rank 0: rank {from} sent the final report of rank {}",
                        report.rank
                    )));
                }
                self.finals[from] = Some(report);
                Ok(())
            }
            Event::Received { from, tag, bytes } => Err(runtime_err(format!(
                "rank {}: unexpected {}-byte message with tag {tag} from rank {from}",
                self.rank,
                bytes.len()
            ))),
            Event::Failed(msg) => Err(runtime_err(format!("rank {}: {msg}", self.rank))),
            Event::Done => Err(runtime_err(format!(
                "rank {}: the MPI thread finished before the run did",
                self.rank
            ))),
        }
    }

    /// Hands a packet to its actor on this rank.
    fn deliver(&mut self, packet: Packet<W>) {
        let Some(slot) = self.slot_of(packet.to) else {
            // Cannot happen: `route` sends every packet to its host rank,
            // and `on_event` checked the sender. Count it rather than fail.
            self.traffic.late_packets += 1;
            return;
        };
        let t = self.clock.now();
        match self.nodes[slot].as_mut() {
            Some(node) => {
                node.deliver(packet, t);
                node.account(State::Receiving, self.clock.now() - t);
            }
            None => self.traffic.late_packets += 1,
        }
    }

    /// Sends a packet to its actor: locally or over MPI.
    fn route(&mut self, packet: Packet<W>) -> Result<(), RunError> {
        let to = host(packet.to);
        if to >= self.size {
            return Err(runtime_err(format!(
                "rank {}: {} sent a packet to {}, but the job has only {} ranks",
                self.rank, packet.from, packet.to, self.size
            )));
        }
        let for_master = packet.to == Addr::Master;
        if to == self.rank && !for_master {
            self.traffic.local_packets += 1;
            self.local.push_back(packet);
            return Ok(());
        }
        let mut bytes =
            encode_packet(&packet).map_err(|e| runtime_err(format!("rank {}: {e}", self.rank)))?;
        if for_master && to == self.rank {
            self.traffic.local_packets += 1;
            let ev = Event::Received {
                from: self.rank,
                tag: TAG_MASTER,
                bytes,
            };
            return match &self.to_master {
                Some(m) if m.send(ev).is_ok() => Ok(()),
                _ => Err(runtime_err(format!(
                    "rank {}: the master's thread is gone",
                    self.rank
                ))),
            };
        }
        if self.fault == Some(Fault::Garbage) {
            self.fault = None;
            eprintln!(
                "rank {}: fault injection: sending garbage to rank {to}",
                self.rank
            );
            bytes = b"not a packet".to_vec();
        }
        self.traffic.messages_sent += 1;
        self.traffic.bytes_sent += bytes.len() as u64;
        let tag = if for_master {
            TAG_MASTER
        } else if self.on_arrival && DataServer::is_request(&packet) {
            TAG_DATA
        } else {
            TAG_PACKET
        };
        self.send(to, tag, bytes)
    }

    fn send(&self, to: usize, tag: i32, bytes: Vec<u8>) -> Result<(), RunError> {
        wire::WIRE.hold(bytes.len());
        self.session
            .cmds
            .send(Cmd::Send { to, tag, bytes })
            .map_err(|_| self.gone())
    }

    fn send_final(&mut self) -> Result<(), RunError> {
        self.merge_served();
        let report = FinalReport::<W> {
            rank: self.rank,
            nodes: std::mem::take(&mut self.finished),
            traffic: RankTraffic {
                peak_resident_bytes: crate::stats::peak_resident_bytes().unwrap_or(0),
                peak_wire_bytes: wire::WIRE.peak(),
                started_resident_bytes: started_peak_bytes(),
                ..self.traffic
            },
        };
        let bytes = postcard::to_stdvec(&report).map_err(|e| {
            runtime_err(format!(
                "rank {}: cannot encode the final report: {e}",
                self.rank
            ))
        })?;
        self.send(0, TAG_FINAL, bytes)
    }
}

#[cfg(test)]
mod tests;
