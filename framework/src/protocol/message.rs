//! Messages and envelopes: what travels between actors, carrying a
//! workload's tasks, data and results.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::protocol::workload::{ByteSize, Workload};
use crate::protocol::{Addr, Class};

/// A demand-driven task in transit.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct DdEnvelope<W: Workload> {
    /// The task.
    pub task: W::DdTask,
    /// The processor that ran the root task this one descends from (`None`
    /// for a root that has not run yet). Used by the `ToOrigin` policy.
    pub origin: Option<usize>,
    /// Whether the master sent it in answer to a work request.
    pub handout: bool,
    /// Whether it is a root task (from [`crate::Workload::root_tasks`]).
    #[serde(default)]
    pub root: bool,
}

/// A data-parallel task in transit.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct DpEnvelope<W: Workload> {
    /// The task.
    pub task: W::DpTask,
    /// Origin of the root task it descends from (see [`DdEnvelope::origin`]).
    pub origin: Option<usize>,
}

/// One logical message. Several of the same class may travel in one
/// [`Packet`] (a bundle).
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub enum Msg<W: Workload> {
    /// Please send these items (all owned by the receiver).
    DataRequest(Vec<W::DataId>),
    /// The requested items.
    DataReply(Vec<(W::DataId, W::DataItem)>),
    /// A result to merge at the receiver.
    Result(W::Result),
    /// A data-parallel task.
    Dp(DpEnvelope<W>),
    /// A demand-driven task.
    Dd(DdEnvelope<W>),
    /// A worker asks the master for a demand-driven task: a pooled child,
    /// or a root task too when `roots` (a worker over its backlog budget
    /// asks for pooled children only). A request from a worker whose
    /// earlier one is still parked replaces it.
    WorkRequest {
        /// Whether a root task may answer it.
        roots: bool,
    },
    /// Flow control: the receiver has consumed this many of the sender's
    /// credit-limited items, of this many bytes, in each pool (indexed by
    /// [`crate::Pool::index`]).
    Credit([(u32, u64); 2]),
    /// Termination detection: report your counters for wave `n` once passive.
    Probe(u64),
    /// Answer to [`Msg::Probe`]: basic messages sent and received so far.
    ProbeReply {
        /// The wave answered.
        wave: u64,
        /// Basic messages sent by this processor so far.
        sent: u64,
        /// Basic messages received by this processor so far.
        received: u64,
    },
    /// The computation is over.
    Terminate,
    /// From the master: epoch `epoch` begins; hold these write-once items
    /// ([`crate::Epoch::broadcast`]) and say so.
    Broadcast {
        /// The epoch beginning (1 the second).
        epoch: u32,
        /// The items, in the order the workload gave them.
        items: Vec<(W::DataId, W::DataItem)>,
    },
    /// To the master: the sender holds epoch `.0`'s broadcast items.
    BroadcastHeld(u32),
}

/// Bytes accounted for a control message or a packet header.
pub const HEADER_BYTES: usize = 32;

impl<W: Workload> Msg<W> {
    /// The priority class.
    pub fn class(&self) -> Class {
        match self {
            Msg::DataRequest(_) | Msg::DataReply(_) | Msg::Broadcast { .. } => Class::Data,
            Msg::Result(_) => Class::Result,
            Msg::Dp(_) => Class::DataParallel,
            Msg::Dd(_) => Class::DemandDriven,
            Msg::WorkRequest { .. }
            | Msg::Credit(..)
            | Msg::Probe(_)
            | Msg::ProbeReply { .. }
            | Msg::Terminate
            | Msg::BroadcastHeld(_) => Class::Control,
        }
    }

    /// Basic messages are those counted by termination detection: everything
    /// that carries or asks for work, data or results. Credits, probes and
    /// termination are not (they never create work).
    pub fn is_basic(&self) -> bool {
        !matches!(
            self,
            Msg::Credit(..) | Msg::Probe(_) | Msg::ProbeReply { .. } | Msg::Terminate
        )
    }

    /// Accounted size of a demand-driven task message.
    pub(crate) fn dd_bytes(task: &W::DdTask) -> usize {
        8 + task.byte_size()
    }

    /// Accounted size in bytes.
    pub fn byte_size(&self) -> usize {
        let id = std::mem::size_of::<W::DataId>();
        match self {
            Msg::DataRequest(ids) => 8 + ids.len() * id,
            Msg::DataReply(items) | Msg::Broadcast { items, .. } => {
                8 + items
                    .iter()
                    .map(|(_, item)| id + item.byte_size())
                    .sum::<usize>()
            }
            Msg::Result(r) => r.byte_size(),
            Msg::Dp(e) => 8 + e.task.byte_size(),
            Msg::Dd(e) => Self::dd_bytes(&e.task),
            _ => 16,
        }
    }
}

impl<W: Workload> fmt::Debug for Msg<W> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Msg::DataRequest(ids) => write!(f, "DataRequest({ids:?})"),
            Msg::DataReply(items) => write!(f, "DataReply({} items)", items.len()),
            Msg::Result(r) => write!(f, "Result({r:?})"),
            Msg::Dp(e) => write!(f, "Dp({:?})", e.task),
            Msg::Dd(e) => write!(f, "Dd({:?}, handout={})", e.task, e.handout),
            Msg::WorkRequest { roots } => write!(f, "WorkRequest {{ roots: {roots} }}"),
            Msg::Credit([tasks, results]) => {
                write!(f, "Credit(tasks {tasks:?}, results {results:?})")
            }
            Msg::Probe(w) => write!(f, "Probe({w})"),
            Msg::ProbeReply {
                wave,
                sent,
                received,
            } => write!(
                f,
                "ProbeReply(wave {wave}, sent {sent}, received {received})"
            ),
            Msg::Terminate => write!(f, "Terminate"),
            Msg::Broadcast { epoch, items } => {
                write!(f, "Broadcast(epoch {epoch}, {} items)", items.len())
            }
            Msg::BroadcastHeld(epoch) => write!(f, "BroadcastHeld({epoch})"),
        }
    }
}

/// What a transport carries: one or more messages of one class from one actor
/// to another. A packet with more than one item is a bundle.
#[derive(Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Packet<W: Workload> {
    /// Sender.
    pub from: Addr,
    /// Receiver.
    pub to: Addr,
    /// Class of every item.
    pub class: Class,
    /// The messages, in send order.
    pub items: Vec<Msg<W>>,
    /// Accounted size: header plus items.
    pub bytes: usize,
    /// The sender's load when it sent the packet (queued tasks; 0 from the
    /// master). Piggybacked for the `LoadAware` policy: load information
    /// travels for free with the traffic that exists anyway.
    #[serde(default)]
    pub load: u32,
}

impl<W: Workload> fmt::Debug for Packet<W> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Packet")
            .field("from", &self.from)
            .field("to", &self.to)
            .field("class", &self.class)
            .field("items", &self.items)
            .field("bytes", &self.bytes)
            .field("load", &self.load)
            .finish()
    }
}

impl<W: Workload> Packet<W> {
    /// Whether any item is a basic message (see [`Msg::is_basic`]).
    pub fn has_basic(&self) -> bool {
        self.items.iter().any(Msg::is_basic)
    }

    /// A packet holding a single message.
    pub fn single(from: Addr, to: Addr, msg: Msg<W>) -> Self {
        let bytes = HEADER_BYTES + msg.byte_size();
        Packet {
            from,
            to,
            class: msg.class(),
            items: vec![msg],
            bytes,
            load: 0,
        }
    }
}

/// Whether a message from `from` of class `class` is limited by credits.
/// Pushed task and result traffic from workers is; urgent traffic is not, and
/// neither are the master's hand-outs (each answers a work request, so at most
/// one per worker is ever in flight).
pub(crate) fn is_credit_limited(from: Addr, class: Class) -> bool {
    matches!(from, Addr::Proc(_)) && !class.is_urgent()
}

/// A message in a mailbox, with what the receiver needs to know about it.
pub(crate) struct Incoming<W: Workload> {
    pub from: Addr,
    pub msg: Msg<W>,
    pub bytes: usize,
    /// Whether consuming it returns a credit to `from` (and it counts in the
    /// bounded input buffer).
    pub credited: bool,
}
