//! A processor's data server: answers data requests for the items the
//! processor owns without waiting for the processor's step to end
//! ([`crate::DataService::OnArrival`]).
//!
//! The items a processor owns (its partition, [`crate::Workload::load_partition`])
//! never change during a run, so they can be read while the processor
//! computes: the server and the processor's store share them (one copy).
//! Each runtime serves where its model of a machine puts a communication
//! agent (SEMANTICS.md, section 6):
//! * the simulator at the request's arrival, the time it takes delaying
//!   the owner's current step (an interrupt handler on the owner's CPU);
//! * the threads runtime in the requesting processor's step, as a
//!   one-sided read (a remote get): the reply is a copy of the owner's
//!   items, as a message would carry;
//! * the MPI runtime on the owner's MPI thread, between its sends and
//!   receives.
//!
//! A request and its reply are basic messages of the owner for
//! termination detection: the server counts them, and the owner's answer
//! to a probe includes its server's counts ([`DataServer::basic`]). Both
//! counts only grow, and a request's receipt is counted before its reply
//! is sent, so the counting argument of SEMANTICS.md section 7 holds (the
//! requester counts the request sent and the reply received as well, so
//! an exchange in progress keeps the totals apart either way).

use std::sync::{Arc, Mutex};

use crate::protocol::message::{Msg, Packet};
use crate::protocol::workload::{ByteSize, Workload};
use crate::protocol::{Addr, Class};
use crate::resident::Resident;
use crate::stats::{ProcStats, Traffic};
use crate::store::Items;

/// What a server did, merged into its processor's statistics at the end.
#[derive(Debug, Default)]
struct Tally {
    requests: u64,
    /// Reply packets made: one per request, or its parts
    /// ([`DataServer::serve_parts`]).
    replies: u64,
    items: u64,
    /// Data class traffic: the replies sent, the requests received.
    sent: Traffic,
    received: Traffic,
}

fn record(t: &mut Traffic, bytes: usize) {
    t.packets += 1;
    t.messages += 1;
    t.bytes += bytes as u64;
}

fn add(to: &mut Traffic, t: &Traffic) {
    to.packets += t.packets;
    to.messages += t.messages;
    to.bytes += t.bytes;
}

/// Processor `me`'s data server (see the module documentation).
pub(crate) struct DataServer<W: Workload> {
    me: usize,
    items: Arc<Resident<W::DataId, W::DataItem>>,
    tally: Mutex<Tally>,
    /// The owner's load as its last packet carried it (for the
    /// load-aware policy, which reads it from every packet).
    load: std::sync::atomic::AtomicU32,
}

impl<W: Workload> DataServer<W> {
    /// The server of processor `me`, whose store holds `items`.
    pub(crate) fn new(me: usize, items: Arc<Resident<W::DataId, W::DataItem>>) -> Self {
        DataServer {
            me,
            items,
            tally: Mutex::new(Tally::default()),
            load: std::sync::atomic::AtomicU32::new(0),
        }
    }

    /// Whether `packet` is a data request (data requests travel alone: their
    /// class is urgent, never bundled).
    pub(crate) fn is_request(packet: &Packet<W>) -> bool {
        packet.class == Class::Data
            && packet.items.len() == 1
            && matches!(packet.items[0], Msg::DataRequest(_))
    }

    /// Copies of the items `ids`, or which one this processor does not own.
    pub(crate) fn copies(&self, ids: &[W::DataId]) -> Result<Items<W>, String> {
        ids.iter()
            .map(|id| match self.items.get(id) {
                Some(item) => Ok((id.clone(), item.clone())),
                None => Err(format!(
                    "processor {} was asked for data {id:?} that it does not own",
                    self.me
                )),
            })
            .collect()
    }

    /// Answers a data request packet ([`DataServer::is_request`]) addressed
    /// to this processor: the reply packet, counted as the owner's.
    pub(crate) fn serve(&self, request: Packet<W>) -> Result<Packet<W>, String> {
        let mut parts = self.serve_parts(request, usize::MAX)?;
        // Without a limit, the whole reply is one part.
        debug_assert_eq!(parts.len(), 1);
        parts
            .pop()
            .ok_or_else(|| format!("processor {}'s data server made no reply", self.me))
    }

    /// [`DataServer::serve`] in parts: reply packets whose items take at
    /// most `part_bytes` each (their [`ByteSize`]; an item larger than
    /// that travels alone), in the request's order; at least one. Every
    /// part is counted as sent now, with the request's receipt, so that an
    /// exchange in progress keeps termination detection's totals apart
    /// until the last part has arrived, whenever the parts leave.
    pub(crate) fn serve_parts(
        &self,
        request: Packet<W>,
        part_bytes: usize,
    ) -> Result<Vec<Packet<W>>, String> {
        let (from, bytes) = (request.from, request.bytes);
        let Some(Msg::DataRequest(ids)) = request.items.into_iter().next() else {
            return Err(format!(
                "processor {}'s data server got a packet that is not a data request",
                self.me
            ));
        };
        let items = self.copies(&ids)?;
        let n = items.len() as u64;
        let mut parts = vec![Vec::new()];
        let mut size = 0usize;
        for (id, item) in items {
            let b = item.byte_size();
            let last = parts
                .last_mut()
                .filter(|p| p.is_empty() || size.saturating_add(b) <= part_bytes);
            match last {
                Some(p) => {
                    size = size.saturating_add(b);
                    p.push((id, item));
                }
                None => {
                    size = b;
                    parts.push(vec![(id, item)]);
                }
            }
        }
        let load = self.load.load(std::sync::atomic::Ordering::Relaxed);
        let replies: Vec<Packet<W>> = parts
            .into_iter()
            .map(|items| {
                let mut reply = Packet::single(Addr::Proc(self.me), from, Msg::DataReply(items));
                reply.load = load;
                reply
            })
            .collect();
        let mut t = self.tally.lock().unwrap_or_else(|e| e.into_inner());
        record(&mut t.received, bytes);
        t.requests += 1;
        t.items += n;
        for reply in &replies {
            t.replies += 1;
            record(&mut t.sent, reply.bytes);
        }
        Ok(replies)
    }

    /// Notes the owner's load, for the replies to carry.
    pub(crate) fn note_load(&self, load: u32) {
        self.load.store(load, std::sync::atomic::Ordering::Relaxed);
    }

    /// Basic messages (sent, received) the server handled for its owner:
    /// the replies (or their parts) sent and the requests received, both
    /// counted before a reply leaves.
    pub(crate) fn basic(&self) -> (u64, u64) {
        let t = self.tally.lock().unwrap_or_else(|e| e.into_inner());
        (t.replies, t.requests)
    }

    /// Adds what the server did to its owner's statistics.
    pub(crate) fn merge_into(&self, stats: &mut ProcStats) {
        let t = self.tally.lock().unwrap_or_else(|e| e.into_inner());
        stats.data_requests_served += t.requests;
        stats.data_items_served += t.items;
        add(&mut stats.sent.data, &t.sent);
        add(&mut stats.received.data, &t.received);
    }
}
