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
//! packets and receives encoded packets. On rank 0 the master and processor
//! 0 exchange packets directly, without MPI.
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
//! finalising MPI) after its first step.

use std::collections::VecDeque;
use std::sync::mpsc::{RecvTimeoutError, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::clock::{Clock, WallClock};
use crate::config::Config;
use crate::error::RunError;
use crate::master::Master;
use crate::processor::{Processor, Step};
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::{Addr, Class};
use crate::runtime::{assemble, Extras, Node, RunReport, Runtime};
use crate::stats::{ProcStats, RankTraffic, State};

pub use self::transport::{
    abort, decode_packet, encode_packet, init, last_world, world, World, TAG_FINAL, TAG_PACKET,
};
use self::transport::{decode, finish, phase, runtime_err, Cmd, Event, Phase, Session};

mod transport;

/// How long a rank waits at the final barrier for the others when the time
/// limit leaves less (or there is none).
pub const FINISH_GRACE: Duration = Duration::from_secs(60);

/// Longest a blocked processor loop waits before checking its time limit.
const MAX_BLOCK: Duration = Duration::from_millis(100);

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
    let mut rank_loop = RankLoop::new(session, workload, config, deadline, fault)?;
    rank_loop.run()?;
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

/// The rank hosting `addr`.
fn host(addr: Addr) -> usize {
    match addr {
        Addr::Master => 0,
        Addr::Proc(p) => p,
    }
}

/// A rank's part of the result, sent to rank 0 at the end.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
struct FinalReport<W: Workload> {
    rank: usize,
    nodes: Vec<(Addr, W::Accumulator, ProcStats)>,
    traffic: RankTraffic,
}

type Finished<W> = (Addr, <W as Workload>::Accumulator, ProcStats);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fault {
    Garbage,
    Exit,
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
    /// Slot 0: processor `rank`; slot 1 (rank 0 only): the master.
    nodes: Vec<Option<Node<W>>>,
    local: VecDeque<Packet<W>>,
    finished: Vec<Finished<W>>,
    /// Final reports by rank (rank 0 only).
    finals: Vec<Option<FinalReport<W>>>,
    traffic: RankTraffic,
    fault: Option<Fault>,
}

impl<'s, W: Workload> RankLoop<'s, W> {
    fn new(
        session: &'s Session,
        workload: Arc<W>,
        config: &Config,
        deadline: Option<(Instant, Duration)>,
        fault: Option<Fault>,
    ) -> Result<Self, RunError> {
        let World { rank, size } = session.world;
        // Only this rank's processor: it loads only its own partition.
        let mut nodes = vec![Some(Node::Worker(Box::new(Processor::new(
            rank,
            workload.clone(),
            config,
        )?)))];
        if rank == 0 {
            nodes.push(Some(Node::Master(Box::new(Master::new(workload, config)))));
        }
        Ok(RankLoop {
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
            fault,
        })
    }

    fn slot_of(&self, addr: Addr) -> Option<usize> {
        match addr {
            Addr::Proc(p) if p == self.rank => Some(0),
            Addr::Master if self.rank == 0 => Some(1),
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
            let wait = match self.deadline {
                Some((at, limit)) => {
                    let now = Instant::now();
                    if now >= at {
                        return Err(RunError::TimedOut { limit });
                    }
                    (at - now).min(MAX_BLOCK)
                }
                None => MAX_BLOCK,
            };
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
        match ev {
            Event::Received {
                from,
                tag: TAG_PACKET,
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
        if to == self.rank {
            self.traffic.local_packets += 1;
            self.local.push_back(packet);
            return Ok(());
        }
        let mut bytes =
            encode_packet(&packet).map_err(|e| runtime_err(format!("rank {}: {e}", self.rank)))?;
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
        self.send(to, TAG_PACKET, bytes)
    }

    fn send(&self, to: usize, tag: i32, bytes: Vec<u8>) -> Result<(), RunError> {
        self.session
            .cmds
            .send(Cmd::Send { to, tag, bytes })
            .map_err(|_| self.gone())
    }

    fn send_final(&mut self) -> Result<(), RunError> {
        let report = FinalReport::<W> {
            rank: self.rank,
            nodes: std::mem::take(&mut self.finished),
            traffic: RankTraffic {
                peak_resident_bytes: crate::stats::peak_resident_bytes().unwrap_or(0),
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
mod tests {
    use super::*;
    use crate::protocol::message::Msg;
    use crate::tests::Mini;

    fn packet() -> Packet<Mini> {
        Packet {
            from: Addr::Proc(1),
            to: Addr::Master,
            class: Class::Control,
            items: vec![Msg::WorkRequest { roots: true }, Msg::Credit(3, 120)],
            bytes: 48,
            load: 7,
        }
    }

    #[test]
    fn packets_round_trip() {
        let p = packet();
        let bytes = encode_packet(&p).unwrap();
        let q = decode_packet::<Mini>(&bytes, 1, 0).unwrap();
        assert_eq!(q.from, p.from);
        assert_eq!(q.to, p.to);
        assert_eq!(q.class, p.class);
        assert_eq!(q.bytes, p.bytes);
        assert_eq!(q.load, p.load);
        assert_eq!(format!("{:?}", q.items), format!("{:?}", p.items));
    }

    /// The epoch messages cross the wire whole: the broadcast's items, not
    /// only their count (which is all their `Debug` shows).
    #[test]
    fn epoch_messages_round_trip() {
        let p: Packet<Mini> = Packet {
            from: Addr::Master,
            to: Addr::Proc(2),
            class: Class::Data,
            items: vec![
                Msg::Broadcast {
                    epoch: 3,
                    items: vec![
                        (7, crate::tests::Item(vec![1, 2, 3])),
                        (9, crate::tests::Item(vec![])),
                    ],
                },
                Msg::BroadcastHeld(3),
            ],
            bytes: 96,
            load: 0,
        };
        let q = decode_packet::<Mini>(&encode_packet(&p).unwrap(), 0, 2).unwrap();
        match q.items.as_slice() {
            [Msg::Broadcast { epoch: 3, items }, Msg::BroadcastHeld(3)] => {
                assert_eq!(
                    format!("{items:?}"),
                    "[(7, Item([1, 2, 3])), (9, Item([]))]"
                );
            }
            other => panic!("decoded {other:?}"),
        }
    }

    /// The final report crosses the wire whole, whatever its statistics
    /// hold: postcard is not self-describing, so a field left out when it
    /// has its default value would shift every field after it.
    #[test]
    fn final_reports_round_trip() {
        for completed in [false, true] {
            let mut stats = ProcStats::new(Addr::Proc(1));
            stats.cache_completed = completed;
            stats.data_items_served = 17;
            stats.epochs = 2;
            let report: FinalReport<Mini> = FinalReport {
                rank: 1,
                nodes: vec![(Addr::Proc(1), Default::default(), stats)],
                traffic: RankTraffic::default(),
            };
            let bytes = postcard::to_stdvec(&report).unwrap();
            let back: FinalReport<Mini> = decode(&bytes, "final report", 1, 0).unwrap();
            let s = &back.nodes[0].2;
            assert_eq!(s.cache_completed, completed);
            assert_eq!((s.data_items_served, s.epochs), (17, 2));
        }
    }

    #[test]
    fn garbage_is_a_clear_error_naming_both_ranks() {
        let err =
            decode_packet::<Mini>(b"not a packet", 3, 2).expect_err("garbage must not decode");
        let text = err.to_string();
        assert!(text.contains("rank 2"), "{text}");
        assert!(text.contains("from rank 3"), "{text}");
        assert!(text.contains("cannot decode"), "{text}");
        assert!(text.contains("12-byte"), "{text}");
    }

    #[test]
    fn truncated_and_padded_messages_are_rejected() {
        let bytes = encode_packet(&packet()).unwrap();
        for cut in 0..bytes.len() {
            let err = decode_packet::<Mini>(&bytes[..cut], 1, 0).err();
            assert!(err.is_some(), "a packet cut to {cut} bytes decoded");
        }
        let mut padded = bytes.clone();
        padded.push(0);
        let text = decode_packet::<Mini>(&padded, 1, 0)
            .expect_err("trailing bytes must be rejected")
            .to_string();
        assert!(text.contains("left over"), "{text}");
    }

    #[test]
    fn faults_are_read_for_one_rank_only() {
        assert_eq!(Fault::parse("garbage:1", 1), Some(Fault::Garbage));
        assert_eq!(Fault::parse("garbage:1", 0), None);
        assert_eq!(Fault::parse("exit: 2", 2), Some(Fault::Exit));
        assert_eq!(Fault::parse("explode:0", 0), None);
        assert_eq!(Fault::parse("", 0), None);
    }
}
