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
use std::os::raw::{c_int, c_void};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mpi::collective::CommunicatorCollectives;
use mpi::ffi;
use mpi::point_to_point::{MatchedReceiveVec, Source};
use mpi::raw::AsRaw;
use mpi::topology::{Communicator, SimpleCommunicator};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::{assemble, Extras, Node, RunReport, Runtime};
use crate::clock::{Clock, WallClock};
use crate::config::Config;
use crate::error::RunError;
use crate::master::Master;
use crate::processor::{Processor, Step};
use crate::protocol::{Addr, Class, Packet};
use crate::stats::{ProcStats, RankTraffic, State};
use crate::workload::Workload;

/// MPI tag of a packet.
pub const TAG_PACKET: i32 = 1;
/// MPI tag of a rank's final report (to rank 0).
pub const TAG_FINAL: i32 = 2;
/// How long a rank waits at the final barrier for the others when the time
/// limit leaves less (or there is none).
pub const FINISH_GRACE: Duration = Duration::from_secs(60);

/// Shortest and longest idle wait of the MPI thread between polls. The
/// longest bounds the latency an idle rank adds to every message (a data
/// request and its reply each pay it): on the studio scene at -np 2 a 1 ms
/// cap made the run about 20% slower than this one.
const MIN_BACKOFF: Duration = Duration::from_micros(20);
const MAX_BACKOFF: Duration = Duration::from_micros(100);
/// The cap with a single rank: nothing arrives from elsewhere, commands wake
/// the thread anyway.
const MAX_BACKOFF_ALONE: Duration = Duration::from_millis(10);
/// Longest a blocked processor loop waits before checking its time limit.
const MAX_BLOCK: Duration = Duration::from_millis(100);
/// Messages received per turn of the MPI thread before it looks at its sends.
const RECEIVES_PER_TURN: usize = 64;

/// This process's place in the MPI job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct World {
    /// This rank.
    pub rank: usize,
    /// Number of ranks (= worker processors).
    pub size: usize,
}

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

/// Processor loop -> MPI thread.
enum Cmd {
    Send { to: usize, tag: i32, bytes: Vec<u8> },
    Finish { deadline: Instant },
    Abort(i32),
}

/// MPI thread -> processor loop.
enum Event {
    Received {
        from: usize,
        tag: i32,
        bytes: Vec<u8>,
    },
    /// Every send completed and every rank reached the final barrier.
    Done,
    Failed(String),
}

struct Session {
    world: World,
    cmds: Sender<Cmd>,
    events: Receiver<Event>,
    thread: Option<JoinHandle<()>>,
}

enum Phase {
    NotStarted,
    Running(Session),
    Finalized,
}

static PHASE: Mutex<Phase> = Mutex::new(Phase::NotStarted);

fn phase() -> MutexGuard<'static, Phase> {
    PHASE.lock().unwrap_or_else(|e| e.into_inner())
}

fn runtime_err(msg: impl Into<String>) -> RunError {
    RunError::Runtime(msg.into())
}

/// Starts MPI on its dedicated thread (once per process; later calls return
/// the same [`World`]).
pub fn init() -> Result<World, RunError> {
    let mut guard = phase();
    match &*guard {
        Phase::Running(s) => return Ok(s.world),
        Phase::Finalized => {
            return Err(runtime_err(
                "MPI has already been finalised in this process: it runs once per process",
            ))
        }
        Phase::NotStarted => {}
    }
    let (ready_tx, ready_rx) = mpsc::channel();
    let (cmd_tx, cmd_rx) = mpsc::channel();
    let (ev_tx, ev_rx) = mpsc::channel();
    let thread = std::thread::Builder::new()
        .name("mpi".into())
        .spawn(move || mpi_thread(ready_tx, cmd_rx, ev_tx))
        .map_err(|e| runtime_err(format!("cannot start the MPI thread: {e}")))?;
    let world = match ready_rx.recv() {
        Ok(Ok(world)) => world,
        Ok(Err(msg)) => return Err(runtime_err(msg)),
        Err(_) => return Err(runtime_err("the MPI thread stopped while initialising MPI")),
    };
    *guard = Phase::Running(Session {
        world,
        cmds: cmd_tx,
        events: ev_rx,
        thread: Some(thread),
    });
    Ok(world)
}

/// The [`World`] while MPI runs in this process (after [`init`], before the
/// end of a successful [`run_mpi`]).
pub fn world() -> Option<World> {
    match &*PHASE.try_lock().ok()? {
        Phase::Running(s) => Some(s.world),
        _ => None,
    }
}

/// Ends the whole job after an error: `MPI_Abort` with `code` (every rank
/// stops, `mpirun` exits non-zero) while MPI runs, else a plain exit.
/// Print the error first.
pub fn abort(code: i32) -> ! {
    let code = if code == 0 { 1 } else { code };
    if let Ok(guard) = PHASE.try_lock() {
        if let Phase::Running(s) = &*guard {
            if s.cmds.send(Cmd::Abort(code)).is_ok() {
                // MPI_Abort ends this process from the MPI thread.
                std::thread::sleep(Duration::from_secs(30));
            }
        }
    }
    std::process::exit(code)
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
    config.validate()?;
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
    *guard = Phase::Finalized;
    if world.rank != 0 {
        let mut report = assemble("mpi", world.size, Vec::new(), elapsed);
        report.extras = Extras::NotRoot { rank: world.rank };
        return Ok(report);
    }
    let mut all = finished;
    let mut ranks = vec![traffic];
    for f in finals.into_iter().skip(1).flatten() {
        all.extend(f.nodes);
        ranks.push(f.traffic);
    }
    let mut report = assemble("mpi", world.size, all, elapsed);
    report.extras = Extras::Ranks(ranks);
    Ok(report)
}

/// Ends the run: completes every send, meets every rank at a barrier,
/// finalises MPI and joins the MPI thread.
fn finish(session: &mut Session, deadline: Instant) -> Result<(), RunError> {
    let rank = session.world.rank;
    let gone = || runtime_err(format!("rank {rank}: the MPI thread stopped unexpectedly"));
    session
        .cmds
        .send(Cmd::Finish { deadline })
        .map_err(|_| gone())?;
    loop {
        match session.events.recv() {
            Ok(Event::Done) => break,
            Ok(Event::Failed(msg)) => return Err(runtime_err(format!("rank {rank}: {msg}"))),
            // Stray control traffic after termination: nobody needs it.
            Ok(Event::Received { .. }) => {}
            Err(_) => return Err(gone()),
        }
    }
    if let Some(t) = session.thread.take() {
        t.join()
            .map_err(|_| runtime_err(format!("rank {rank}: the MPI thread panicked")))?;
    }
    Ok(())
}

/// Encodes a packet for the wire.
pub fn encode_packet<W: Workload>(packet: &Packet<W>) -> Result<Vec<u8>, RunError> {
    postcard::to_stdvec(packet).map_err(|e| {
        runtime_err(format!(
            "cannot encode a packet from {} to {}: {e}",
            packet.from, packet.to
        ))
    })
}

/// Decodes a packet that rank `rank` received from rank `from`; the error
/// names both ranks and the reason.
pub fn decode_packet<W: Workload>(
    bytes: &[u8],
    from: usize,
    rank: usize,
) -> Result<Packet<W>, RunError> {
    decode(bytes, "packet", from, rank)
}

fn decode<T: DeserializeOwned>(
    bytes: &[u8],
    what: &str,
    from: usize,
    rank: usize,
) -> Result<T, RunError> {
    let fail = |why: String| {
        let head: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
        runtime_err(format!(
            "rank {rank}: cannot decode a {}-byte {what} message from rank {from} (starting {}): {why}",
            bytes.len(),
            head.join(" ")
        ))
    };
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((value, [])) => Ok(value),
        Ok((_, rest)) => Err(fail(format!("{} bytes left over", rest.len()))),
        Err(e) => Err(fail(e.to_string())),
    }
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
            traffic: self.traffic,
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

/// A non-blocking send in flight. Owns its buffer until MPI is done with it.
struct PendingSend {
    buf: Vec<u8>,
    request: ffi::MPI_Request,
    done: bool,
}

impl PendingSend {
    fn start(
        comm: &SimpleCommunicator,
        to: usize,
        tag: i32,
        buf: Vec<u8>,
    ) -> Result<PendingSend, String> {
        let count = c_int::try_from(buf.len())
            .map_err(|_| format!("a {}-byte message is too large for MPI", buf.len()))?;
        let dest = c_int::try_from(to).map_err(|_| format!("rank {to} is out of range"))?;
        // SAFETY: MPI reads `count` bytes from the buffer until the request
        // completes. The buffer's heap storage does not move when the Vec
        // moves, and it is owned by the returned value, which is tested until
        // completion before it is dropped (and leaks the buffer if dropped
        // early, see `Drop`).
        let mut request = unsafe { ffi::RSMPI_REQUEST_NULL };
        let rc = unsafe {
            ffi::MPI_Isend(
                buf.as_ptr() as *const c_void as *mut c_void,
                count,
                ffi::RSMPI_UINT8_T,
                dest,
                tag,
                comm.as_raw(),
                &mut request,
            )
        };
        if rc != ffi::MPI_SUCCESS as c_int {
            return Err(format!("MPI_Isend to rank {to} failed with code {rc}"));
        }
        Ok(PendingSend {
            buf,
            request,
            done: false,
        })
    }

    /// Whether the send has completed.
    fn test(&mut self) -> bool {
        if !self.done {
            let mut flag: c_int = 0;
            // SAFETY: a valid request from MPI_Isend, not yet completed.
            unsafe {
                ffi::MPI_Test(&mut self.request, &mut flag, ffi::RSMPI_STATUS_IGNORE);
            }
            self.done = flag != 0;
        }
        self.done
    }
}

impl Drop for PendingSend {
    fn drop(&mut self) {
        if !self.done {
            // MPI may still read the buffer: never free it.
            std::mem::forget(std::mem::take(&mut self.buf));
        }
    }
}

/// The MPI thread: initialises MPI, moves bytes, finalises MPI.
fn mpi_thread(ready: Sender<Result<World, String>>, cmds: Receiver<Cmd>, events: Sender<Event>) {
    let Some((universe, threading)) = mpi::initialize_with_threading(mpi::Threading::Funneled)
    else {
        let _ = ready.send(Err("MPI is already initialised in this process".into()));
        return;
    };
    let world = universe.world();
    let me = World {
        rank: world.rank() as usize,
        size: world.size() as usize,
    };
    tracing::debug!(
        rank = me.rank,
        size = me.size,
        ?threading,
        "MPI initialised"
    );
    if ready.send(Ok(me)).is_err() {
        return;
    }
    let fail = |msg: String| {
        // The processor loop reports it; the caller then aborts the job.
        let _ = events.send(Event::Failed(msg));
    };
    let mut pending: Vec<PendingSend> = Vec::new();
    let mut queued: VecDeque<Cmd> = VecDeque::new();
    let mut finish_by: Option<Instant> = None;
    let mut barrier = None;
    let mut failed = false;
    let mut backoff = Duration::ZERO;
    let max_backoff = if me.size == 1 {
        MAX_BACKOFF_ALONE
    } else {
        MAX_BACKOFF
    };
    loop {
        let mut busy = false;
        loop {
            let cmd = match queued.pop_front() {
                Some(c) => c,
                None => match cmds.try_recv() {
                    Ok(c) => c,
                    Err(TryRecvError::Empty) => break,
                    // The session is gone without finishing: the process is
                    // ending abnormally. Make sure the job ends with it.
                    Err(TryRecvError::Disconnected) => world.abort(1),
                },
            };
            busy = true;
            match cmd {
                Cmd::Send { to, tag, bytes } => match PendingSend::start(&world, to, tag, bytes) {
                    Ok(p) => pending.push(p),
                    Err(msg) if !failed => {
                        failed = true;
                        fail(msg);
                    }
                    Err(_) => {}
                },
                Cmd::Finish { deadline } => finish_by = Some(deadline),
                Cmd::Abort(code) => world.abort(code),
            }
        }
        for _ in 0..RECEIVES_PER_TURN {
            let Some(probed) = world.any_process().immediate_matched_probe() else {
                break;
            };
            let (bytes, status) = probed.matched_receive_vec::<u8>();
            busy = true;
            let _ = events.send(Event::Received {
                from: status.source_rank() as usize,
                tag: status.tag(),
                bytes,
            });
        }
        let before = pending.len();
        pending.retain_mut(|p| !p.test());
        busy |= pending.len() != before;
        if let Some(deadline) = finish_by {
            if barrier.is_none() && pending.is_empty() {
                barrier = Some(world.immediate_barrier());
            }
            if let Some(b) = barrier.take() {
                match b.test() {
                    Ok(_) => break,
                    Err(b) => barrier = Some(b),
                }
            }
            if !failed && Instant::now() >= deadline {
                failed = true;
                fail(format!(
                    "waited until the deadline for the other ranks to finish ({} sends outstanding here)",
                    pending.len()
                ));
            }
        }
        if busy {
            backoff = Duration::ZERO;
        } else {
            backoff = (backoff * 2).clamp(MIN_BACKOFF, max_backoff);
            match cmds.recv_timeout(backoff) {
                Ok(c) => queued.push_back(c),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => world.abort(1),
            }
        }
    }
    // Every rank passed the barrier, so every send was received; anything
    // left is stray control traffic, received so that nothing is pending.
    while let Some(probed) = world.any_process().immediate_matched_probe() {
        let _ = probed.matched_receive_vec::<u8>();
    }
    let _ = events.send(Event::Done);
    drop(world);
    // Dropping the universe calls MPI_Finalize.
    drop(universe);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::Msg;
    use crate::tests::Mini;

    fn packet() -> Packet<Mini> {
        Packet {
            from: Addr::Proc(1),
            to: Addr::Master,
            class: Class::Control,
            items: vec![Msg::WorkRequest, Msg::Credit(3)],
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
