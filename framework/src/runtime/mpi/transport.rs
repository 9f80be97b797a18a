//! The MPI transport: the dedicated MPI thread, the session the processor
//! loop talks to it through, and the wire format of packets.

use std::collections::VecDeque;
use std::os::raw::{c_int, c_void};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::{Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mpi::collective::CommunicatorCollectives;
use mpi::ffi;
use mpi::point_to_point::{MatchedReceiveVec, Source};
use mpi::raw::AsRaw;
use mpi::topology::{Communicator, SimpleCommunicator};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::wire::WIRE;
use crate::error::RunError;
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;

/// MPI tag of a packet.
pub const TAG_PACKET: i32 = 1;
/// MPI tag of a rank's final report (to rank 0).
pub const TAG_FINAL: i32 = 2;
/// MPI tag of a packet for the master (on rank 0): the MPI thread hands it
/// to the master's thread, not to the processor loop.
pub const TAG_MASTER: i32 = 3;
/// MPI tag of a data request where the run answers them on arrival
/// ([`crate::DataService::OnArrival`]): the owner's MPI thread answers it
/// with the rank's data server, or, before the rank's run has installed one,
/// hands it to the processor loop as a packet.
pub const TAG_DATA: i32 = 4;

/// A data request's reply on the MPI thread: its parts, each encoded when
/// it is sent, with the rank it goes to.
pub(crate) type Reply = Box<dyn Iterator<Item = Result<(usize, Vec<u8>), RunError>> + Send>;

/// Answers a data request on the MPI thread: the sending rank and the
/// encoded request in, the reply out.
pub(crate) type DataHandler = Box<dyn FnMut(usize, &[u8]) -> Result<Reply, RunError> + Send>;

/// While the rank's sends in flight hold this many encoded bytes, its MPI
/// thread starts no part of a data reply: the replies wait, as their
/// requests, not encoded. A rank's outgoing buffers are then at most this
/// plus one part and what its processor and master send (on a
/// 1.5-million-triangle city under `mpirun -np 4` they reached 20-28 MiB a
/// rank without it).
pub(crate) const SENDING_BYTES: usize = 4 << 20;

/// The rank's [`DataHandler`] while a run that answers on arrival is on.
pub(crate) type DataSlot = std::sync::Arc<Mutex<Option<DataHandler>>>;

/// Longest a blocked processor loop (or the master's thread) waits before
/// checking its time limit.
const MAX_BLOCK: Duration = Duration::from_millis(100);

/// How long a blocked loop may wait for its next event: at most
/// [`MAX_BLOCK`], and not past the run's deadline (an error once it has
/// passed).
pub(crate) fn idle_wait(deadline: Option<(Instant, Duration)>) -> Result<Duration, RunError> {
    match deadline {
        Some((at, limit)) => {
            let now = Instant::now();
            if now >= at {
                return Err(RunError::TimedOut { limit });
            }
            Ok((at - now).min(MAX_BLOCK))
        }
        None => Ok(MAX_BLOCK),
    }
}

/// The rank hosting `addr`.
pub(crate) fn host(addr: Addr) -> usize {
    match addr {
        Addr::Master => 0,
        Addr::Proc(p) => p,
    }
}

/// Shortest and longest idle wait of the MPI thread between polls. The
/// longest bounds the latency an idle rank adds to every message (a data
/// request and its reply each pay it): on the studio scene at -np 2 a 1 ms
/// cap made the run about 20% slower than this one.
const MIN_BACKOFF: Duration = Duration::from_micros(20);
const MAX_BACKOFF: Duration = Duration::from_micros(100);
/// The cap with a single rank: nothing arrives from elsewhere, commands wake
/// the thread anyway.
const MAX_BACKOFF_ALONE: Duration = Duration::from_millis(10);
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

/// Processor loop -> MPI thread.
pub(crate) enum Cmd {
    Send { to: usize, tag: i32, bytes: Vec<u8> },
    Finish { deadline: Instant },
    Abort(i32),
}

/// MPI thread -> processor loop.
pub(crate) enum Event {
    Received {
        from: usize,
        tag: i32,
        bytes: Vec<u8>,
    },
    /// Every send completed and every rank reached the final barrier.
    Done,
    Failed(String),
}

pub(crate) struct Session {
    pub(crate) world: World,
    pub(crate) cmds: Sender<Cmd>,
    pub(crate) events: Receiver<Event>,
    /// The master's channels, taken by the run (a process runs one): into
    /// `events`, for the master's packets to processor 0 on rank 0; and
    /// the packets tagged [`TAG_MASTER`], from the MPI thread or from the
    /// processor loop. Held only while the run is (an `events` whose every
    /// sender is gone tells that the MPI thread stopped).
    pub(crate) master: Option<MasterChannels>,
    /// The data handler the MPI thread answers [`TAG_DATA`] with.
    pub(crate) data: DataSlot,
    pub(crate) thread: Option<JoinHandle<()>>,
}

/// See [`Session::master`].
pub(crate) struct MasterChannels {
    pub(crate) to_loop: Sender<Event>,
    pub(crate) to_master: Sender<Event>,
    pub(crate) inbox: Receiver<Event>,
}

pub(crate) enum Phase {
    NotStarted,
    Running(Session),
    /// MPI ended; the world it ran in.
    Finalized(World),
}

static PHASE: Mutex<Phase> = Mutex::new(Phase::NotStarted);

/// The process's peak resident memory when MPI had started (0 before, or
/// where the system does not say).
static STARTED_PEAK: AtomicU64 = AtomicU64::new(0);

/// This process's peak resident memory, in bytes, once [`init`] had
/// started MPI: the program, Open MPI and their threads, before a caller
/// that initialises first reads its data (its fixed cost). 0 before
/// [`init`] or where the system does not say.
pub fn started_peak_bytes() -> u64 {
    STARTED_PEAK.load(Ordering::Relaxed)
}

pub(crate) fn phase() -> MutexGuard<'static, Phase> {
    PHASE.lock().unwrap_or_else(|e| e.into_inner())
}

pub(crate) fn runtime_err(msg: impl Into<String>) -> RunError {
    RunError::Runtime(msg.into())
}

/// Starts MPI on its dedicated thread (once per process; later calls return
/// the same [`World`]).
pub fn init() -> Result<World, RunError> {
    let mut guard = phase();
    match &*guard {
        Phase::Running(s) => return Ok(s.world),
        Phase::Finalized(_) => {
            return Err(runtime_err(
                "MPI has already been finalised in this process: it runs once per process",
            ))
        }
        Phase::NotStarted => {}
    }
    let (ready_tx, ready_rx) = mpsc::channel();
    let (cmd_tx, cmd_rx) = mpsc::channel();
    let (ev_tx, ev_rx) = mpsc::channel();
    let (master_tx, master_rx) = mpsc::channel();
    let (events_tx, to_master) = (ev_tx.clone(), master_tx.clone());
    let data = DataSlot::default();
    let handler = data.clone();
    let thread = std::thread::Builder::new()
        .name("mpi".into())
        .spawn(move || mpi_thread(ready_tx, cmd_rx, ev_tx, to_master, handler))
        .map_err(|e| runtime_err(format!("cannot start the MPI thread: {e}")))?;
    let world = match ready_rx.recv() {
        Ok(Ok(world)) => world,
        Ok(Err(msg)) => return Err(runtime_err(msg)),
        Err(_) => return Err(runtime_err("the MPI thread stopped while initialising MPI")),
    };
    STARTED_PEAK.store(
        crate::stats::peak_resident_bytes().unwrap_or(0),
        Ordering::Relaxed,
    );
    *guard = Phase::Running(Session {
        world,
        cmds: cmd_tx,
        events: ev_rx,
        master: Some(MasterChannels {
            to_loop: events_tx,
            to_master: master_tx,
            inbox: master_rx,
        }),
        data,
        thread: Some(thread),
    });
    Ok(world)
}

/// The [`World`] while MPI runs in this process (after [`init`], before the
/// end of a successful [`super::run_mpi`]).
pub fn world() -> Option<World> {
    match &*PHASE.try_lock().ok()? {
        Phase::Running(s) => Some(s.world),
        _ => None,
    }
}

/// This process's [`World`] once MPI has started in it, also after it
/// ended (`None` before [`init`]): for what a rank reports after its run.
pub fn last_world() -> Option<World> {
    match &*PHASE.try_lock().ok()? {
        Phase::Running(s) => Some(s.world),
        Phase::Finalized(w) => Some(*w),
        Phase::NotStarted => None,
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

/// Ends the run: completes every send, meets every rank at a barrier,
/// finalises MPI and joins the MPI thread.
pub(crate) fn finish(session: &mut Session, deadline: Instant) -> Result<(), RunError> {
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

/// Encodes a packet for the wire, into a buffer of exactly its size: the
/// size is measured first (a second pass over the packet), because a
/// growing buffer would take up to twice a data reply's bytes, and three
/// times while it is copied to a larger one (a data reply of cells is
/// megabytes; on a 300,000-triangle city under `mpirun -np 2`, valgrind's
/// massif found 14 MB of growing buffers in a rank's peak heap of 152 MB).
pub fn encode_packet<W: Workload>(packet: &Packet<W>) -> Result<Vec<u8>, RunError> {
    let fail = |e: postcard::Error| {
        runtime_err(format!(
            "cannot encode a packet from {} to {}: {e}",
            packet.from, packet.to
        ))
    };
    let size = postcard::experimental::serialized_size(packet).map_err(fail)?;
    let mut bytes = vec![0u8; size];
    let used = postcard::to_slice(packet, &mut bytes).map_err(fail)?.len();
    debug_assert_eq!(used, size);
    bytes.truncate(used);
    Ok(bytes)
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

pub(crate) fn decode<T: DeserializeOwned>(
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
pub(crate) fn mpi_thread(
    ready: Sender<Result<World, String>>,
    cmds: Receiver<Cmd>,
    events: Sender<Event>,
    master: Sender<Event>,
    data: DataSlot,
) {
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
    // Data replies not yet (wholly) sent: their parts leave while the
    // sends in flight hold less than `SENDING_BYTES`.
    let mut replies: VecDeque<Reply> = VecDeque::new();
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
                    // (The sender's hold on a failed send's bytes is not
                    // let go: the run fails.)
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
            WIRE.hold(bytes.len());
            busy = true;
            let ev = Event::Received {
                from: status.source_rank() as usize,
                tag: status.tag(),
                bytes,
            };
            // The master's packets go straight to its thread: it answers
            // while processor 0 is in the middle of a step.
            let _ = match ev {
                Event::Received { from, tag, bytes } if tag == TAG_DATA => {
                    let mut handler = data.lock().unwrap_or_else(|e| e.into_inner());
                    let answered = handler.as_mut().map(|answer| answer(from, &bytes));
                    if answered.is_some() {
                        WIRE.release(bytes.len());
                    }
                    match answered {
                        Some(Ok(reply)) => {
                            replies.push_back(reply);
                            Ok(())
                        }
                        Some(Err(e)) if !failed => {
                            failed = true;
                            fail(e.to_string());
                            Ok(())
                        }
                        Some(Err(_)) => Ok(()),
                        // No run answers here yet: the processor loop will.
                        None => events.send(Event::Received { from, tag, bytes }),
                    }
                }
                ev if status.tag() == TAG_MASTER => master.send(ev),
                ev => events.send(ev),
            };
        }
        let before = pending.len();
        pending.retain_mut(|p| {
            let done = p.test();
            if done {
                WIRE.release(p.buf.len());
            }
            !done
        });
        busy |= pending.len() != before;
        let mut sending: usize = pending.iter().map(|p| p.buf.len()).sum();
        while sending < SENDING_BYTES {
            let Some(reply) = replies.front_mut() else {
                break;
            };
            busy = true;
            match reply.next() {
                Some(Ok((to, part))) => {
                    sending += part.len();
                    WIRE.hold(part.len());
                    match PendingSend::start(&world, to, TAG_PACKET, part) {
                        Ok(p) => pending.push(p),
                        Err(msg) if !failed => {
                            failed = true;
                            fail(msg);
                        }
                        Err(_) => {}
                    }
                }
                Some(Err(e)) => {
                    replies.pop_front();
                    if !failed {
                        failed = true;
                        fail(e.to_string());
                    }
                }
                None => {
                    replies.pop_front();
                }
            }
        }
        if let Some(deadline) = finish_by {
            if barrier.is_none() && pending.is_empty() && replies.is_empty() {
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
