//! The master's thread on rank 0 (see the module documentation of
//! [`super`]).

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::mpsc::{RecvTimeoutError, Sender, TryRecvError};
use std::time::{Duration, Instant};

use super::transport::{
    decode_packet, encode_packet, host, idle_wait, runtime_err, Cmd, Event, MasterChannels,
    TAG_MASTER, TAG_PACKET,
};
use super::wire::WIRE;
use crate::clock::{Clock, WallClock};
use crate::error::RunError;
use crate::processor::Step;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;
use crate::runtime::Node;
use crate::stats::{ProcStats, RankTraffic, State};

/// What an actor of a rank leaves at the end: its address, accumulator and
/// statistics.
pub(crate) type Finished<W> = (Addr, <W as Workload>::Accumulator, ProcStats);

/// The processor loop of rank 0 runs ([`master_loop`]'s `loop_state`).
pub(super) const LOOP_RUNNING: u8 = 0;
/// The processor loop of rank 0 has ended: its processor has finished.
pub(super) const LOOP_DONE: u8 = 1;
/// The processor loop of rank 0 has ended on an error.
pub(super) const LOOP_FAILED: u8 = 2;

/// The master's thread on rank 0: the processor loop's calls for the
/// master alone, its inbox fed by the MPI thread (packets tagged
/// [`TAG_MASTER`]) and by the processor loop. It ends when the master
/// finishes, on an error (told to the processor loop as
/// [`Event::Failed`]), or, with `Ok(None)`, once the processor loop has
/// failed (`loop_state`). After the processor loop has ended well (its
/// processor got the master's termination) the master has `grace` to
/// finish.
pub(super) fn master_loop<W: Workload>(
    mut node: Node<W>,
    ch: MasterChannels,
    cmds: Sender<Cmd>,
    size: usize,
    deadline: Option<(Instant, Duration)>,
    loop_state: &AtomicU8,
    grace: Duration,
) -> Result<Option<(Finished<W>, RankTraffic)>, RunError> {
    let clock = WallClock::new();
    let mut traffic = RankTraffic::default();
    let mut finish_by: Option<Instant> = None;
    let result = (|| loop {
        match loop_state.load(Ordering::Relaxed) {
            LOOP_FAILED => return Ok(None),
            LOOP_DONE => {
                let by = *finish_by.get_or_insert_with(|| Instant::now() + grace);
                if Instant::now() >= by {
                    return Err(runtime_err(
                        "rank 0: the master did not finish after its processors had",
                    ));
                }
            }
            _ => {}
        }
        loop {
            match ch.inbox.try_recv() {
                Ok(ev) => master_receives(&mut node, ev, &clock, &mut traffic)?,
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    return Err(runtime_err("rank 0: the master's inbox closed"))
                }
            }
        }
        let t1 = clock.now();
        let step = node.step(t1)?;
        let t2 = clock.now();
        match step {
            Step::Worked(state) => node.account(state, t2 - t1),
            _ => node.account(State::Sending, t2 - t1),
        }
        for packet in node.take_packets(t2) {
            let to = host(packet.to);
            if to >= size {
                return Err(runtime_err(format!(
                    "rank 0: the master sent a packet to {}, but the job has only {size} ranks",
                    packet.to
                )));
            }
            let bytes = encode_packet(&packet).map_err(|e| runtime_err(format!("rank 0: {e}")))?;
            let sent = if to == 0 {
                traffic.local_packets += 1;
                ch.to_loop
                    .send(Event::Received {
                        from: 0,
                        tag: TAG_PACKET,
                        bytes,
                    })
                    .is_ok()
            } else {
                traffic.messages_sent += 1;
                traffic.bytes_sent += bytes.len() as u64;
                WIRE.hold(bytes.len());
                cmds.send(Cmd::Send {
                    to,
                    tag: TAG_PACKET,
                    bytes,
                })
                .is_ok()
            };
            if !sent {
                return Err(runtime_err("rank 0: the MPI thread stopped unexpectedly"));
            }
        }
        node.account(State::Sending, clock.now() - t2);
        match step {
            Step::Finished => {
                let addr = node.addr();
                let (acc, stats) = node.finish();
                return Ok(Some(((addr, acc, stats), traffic)));
            }
            Step::Worked(_) => {}
            Step::Idle => {
                let wait = idle_wait(deadline)?;
                let t = clock.now();
                let got = ch.inbox.recv_timeout(wait);
                let state = node.blocked_state();
                node.account(state, clock.now() - t);
                match got {
                    Ok(ev) => master_receives(&mut node, ev, &clock, &mut traffic)?,
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => {
                        return Err(runtime_err("rank 0: the master's inbox closed"))
                    }
                }
            }
        }
    })();
    if let Err(e) = &result {
        // The processor loop stops on it (and the caller reports this one).
        let _ = ch
            .to_loop
            .send(Event::Failed(format!("the master failed: {e}")));
    }
    result
}

/// Hands a packet from the master's inbox to the master.
fn master_receives<W: Workload>(
    node: &mut Node<W>,
    ev: Event,
    clock: &WallClock,
    traffic: &mut RankTraffic,
) -> Result<(), RunError> {
    let Event::Received { from, tag, bytes } = ev else {
        return Err(runtime_err(
            "rank 0: the master's inbox got a control event",
        ));
    };
    if tag != TAG_MASTER {
        return Err(runtime_err(format!(
            "rank 0: the master got a message with tag {tag} from rank {from}"
        )));
    }
    if from != 0 {
        traffic.messages_received += 1;
        traffic.bytes_received += bytes.len() as u64;
        WIRE.release(bytes.len());
    }
    let packet = decode_packet::<W>(&bytes, from, 0)?;
    if host(packet.from) != from || packet.to != Addr::Master {
        return Err(runtime_err(format!(
            "rank 0: rank {from} sent the master a packet from {} to {}",
            packet.from, packet.to
        )));
    }
    let t = clock.now();
    node.deliver(packet, t);
    node.account(State::Receiving, clock.now() - t);
    Ok(())
}
