//! The sending side of a processor: per-destination bundling gated by credits.
//!
//! Urgent messages (control, data requests and replies) become packets at
//! once. Credit-limited messages (results and tasks) wait in a *lane* per
//! destination and class until the lane is due (enough messages or bytes for a
//! bundle, its oldest message old enough, or the processor ran out of work)
//! and credits allow; then they leave as one packet. Nothing is ever dropped:
//! a lane without credit simply keeps its messages (the send backlog).

use std::collections::VecDeque;

use crate::clock::Time;
use crate::config::BundleConfig;
use crate::flow::{CreditLedger, Credits, InputBuffer};
use crate::protocol::message::{is_credit_limited, Msg, Packet, HEADER_BYTES};
use crate::protocol::workload::Workload;
use crate::protocol::{Addr, Class, Pool};

struct Lane<W: Workload> {
    items: VecDeque<(Msg<W>, usize, Time)>,
    bytes: usize,
}

impl<W: Workload> Default for Lane<W> {
    fn default() -> Self {
        Lane {
            items: VecDeque::new(),
            bytes: 0,
        }
    }
}

/// Outgoing message buffer of one actor.
///
/// # Example
///
/// The workload is the crate-level example's (`Num` is its result type).
///
/// (Example: the unit test `outbox_bundles_and_credits`.)
pub(crate) struct Outbox<W: Workload> {
    me: Addr,
    procs: usize,
    bundle: BundleConfig,
    max_age: Time,
    /// `lanes[dest_slot][class]`; only credit-limited classes are used.
    lanes: Vec<[Lane<W>; 5]>,
    credits: Credits,
    /// Credits owed to senders for consumed messages (the receiving side
    /// of flow control), and the input buffer they bound.
    ledger: CreditLedger,
    inbuf: InputBuffer,
    ready: Vec<Packet<W>>,
    backlog: usize,
    backlog_high_water: usize,
    /// Bytes of the messages waiting in lanes, and their high-water mark.
    backlog_bytes: usize,
    backlog_bytes_high_water: usize,
    /// Bytes of the results among them.
    result_backlog_bytes: usize,
    /// High-water mark of the work in flight here: input buffer bytes plus
    /// send backlog bytes, at the same moment.
    in_flight_high_water: usize,
    /// Data-parallel tasks leave newest first
    /// ([`crate::Workload::data_parallel_newest_first`]).
    dp_newest_first: bool,
}

impl<W: Workload> Outbox<W> {
    /// Outbox of `me` in a run with `procs` workers, `credits_per_link`
    /// credits and a byte window of `window` towards each destination
    /// (and results' reserve beyond them).
    pub(crate) fn new(
        me: Addr,
        procs: usize,
        bundle: BundleConfig,
        credits_per_link: u32,
        window: usize,
    ) -> Self {
        let slots = procs + 1;
        let max_age = u64::try_from(bundle.max_age.as_nanos()).unwrap_or(u64::MAX);
        Outbox {
            me,
            procs,
            bundle,
            max_age,
            lanes: (0..slots).map(|_| Default::default()).collect(),
            credits: Credits::new(slots, credits_per_link, window),
            ledger: CreditLedger::new(slots, credits_per_link, window),
            inbuf: InputBuffer::default(),
            ready: Vec::new(),
            backlog: 0,
            backlog_high_water: 0,
            backlog_bytes: 0,
            backlog_bytes_high_water: 0,
            result_backlog_bytes: 0,
            in_flight_high_water: 0,
            dp_newest_first: false,
        }
    }

    /// Sends data-parallel tasks newest first.
    pub(crate) fn send_dp_newest_first(&mut self, yes: bool) {
        self.dp_newest_first = yes;
    }

    /// A message of `class` from `from` arrived: whether it is
    /// credit-limited (it then counts in the input buffer until
    /// [`Outbox::consumed`]).
    pub(crate) fn arrived(&mut self, from: Addr, class: Class, bytes: usize) -> bool {
        let credited = is_credit_limited(from, class);
        if credited {
            self.inbuf.add(bytes);
            self.note_in_flight();
        }
        credited
    }

    /// A credit-limited message of `bytes` from `from` was consumed: its
    /// credit goes back with the next batch that is due.
    pub(crate) fn consumed(&mut self, from: Addr, pool: Pool, bytes: usize, now: Time) {
        self.inbuf.remove(bytes);
        self.ledger.consumed(from.slot(self.procs), pool, bytes);
        self.return_credits(false, now);
    }

    /// Sends the credits that are due; with `flush`, every owed one (the
    /// actor ran out of work).
    pub(crate) fn return_credits(&mut self, flush: bool, now: Time) {
        for (slot, owed) in self.ledger.take_due(flush) {
            self.push(
                Addr::from_slot(slot, self.procs),
                Msg::Credit(owed.map(|(n, bytes)| (n, bytes as u64))),
                now,
            );
        }
    }

    /// Most credit-limited messages and bytes ever held in the input
    /// buffer.
    pub(crate) fn input_high_water(&self) -> (usize, usize) {
        (self.inbuf.high_water_items, self.inbuf.high_water_bytes)
    }

    /// Queues `msg` for `to`. Urgent messages become packets immediately.
    pub(crate) fn push(&mut self, to: Addr, msg: Msg<W>, now: Time) {
        let class = msg.class();
        if !is_credit_limited(self.me, class) {
            self.ready.push(Packet::single(self.me, to, msg));
            return;
        }
        let slot = to.slot(self.procs);
        let bytes = msg.byte_size();
        let lane = &mut self.lanes[slot][class.index()];
        lane.items.push_back((msg, bytes, now));
        lane.bytes += bytes;
        self.backlog += 1;
        self.backlog_high_water = self.backlog_high_water.max(self.backlog);
        self.backlog_bytes += bytes;
        self.backlog_bytes_high_water = self.backlog_bytes_high_water.max(self.backlog_bytes);
        if class == Class::Result {
            self.result_backlog_bytes += bytes;
        }
        self.note_in_flight();
        self.pump_lane(slot, class, now, false);
    }

    /// Credits (and window bytes) came back from `from`; lanes towards it
    /// may move again.
    pub(crate) fn grant(&mut self, from: Addr, returned: [(u32, u64); 2], now: Time) {
        let slot = from.slot(self.procs);
        for pool in Pool::ALL {
            let (credits, bytes) = returned[pool.index()];
            let bytes = usize::try_from(bytes).unwrap_or(usize::MAX);
            self.credits.grant(slot, pool, credits, bytes);
        }
        for class in Class::ALL {
            self.pump_lane(slot, class, now, false);
        }
    }

    /// Sends every lane that is due; with `flush`, every lane that has credit.
    pub(crate) fn pump(&mut self, now: Time, flush: bool) {
        if self.backlog == 0 {
            return;
        }
        for slot in 0..self.lanes.len() {
            for class in Class::ALL {
                self.pump_lane(slot, class, now, flush);
            }
        }
    }

    fn pump_lane(&mut self, slot: usize, class: Class, now: Time, flush: bool) {
        let to = Addr::from_slot(slot, self.procs);
        loop {
            let lane = &mut self.lanes[slot][class.index()];
            let Some(&(_, _, oldest)) = lane.items.front() else {
                return;
            };
            let due = flush
                || !self.bundle.enabled
                || lane.items.len() >= self.bundle.max_items
                || lane.bytes >= self.bundle.max_bytes
                || now.saturating_sub(oldest) >= self.max_age;
            let pool = class.pool();
            let credit = self.credits.available(slot, pool) as usize;
            if !due || credit == 0 {
                return;
            }
            let cap = if self.bundle.enabled {
                self.bundle.max_items.min(credit)
            } else {
                1
            };
            let mut items = Vec::new();
            let mut bytes = HEADER_BYTES;
            let newest = self.dp_newest_first && class == Class::DataParallel;
            while items.len() < cap && bytes - HEADER_BYTES < self.bundle.max_bytes {
                let next = if newest {
                    lane.items.back()
                } else {
                    lane.items.front()
                };
                let Some(&(_, b, _)) = next else {
                    break;
                };
                // The byte window: a message that does not fit waits for
                // credit, unless it is the first with nothing outstanding.
                if !self.credits.fits(slot, pool, bytes - HEADER_BYTES, b) {
                    break;
                }
                let taken = if newest {
                    lane.items.pop_back()
                } else {
                    lane.items.pop_front()
                };
                let (msg, b, _) = taken.expect("peeked");
                lane.bytes -= b;
                bytes += b;
                items.push(msg);
            }
            if items.is_empty() {
                return;
            }
            if newest {
                // In the order they were made: the receiver, newest first
                // too, takes the newest of them first.
                items.reverse();
            }
            let payload = bytes - HEADER_BYTES;
            self.backlog -= items.len();
            self.backlog_bytes -= payload;
            if class == Class::Result {
                self.result_backlog_bytes -= payload;
            }
            self.credits
                .consume(slot, pool, items.len() as u32, payload);
            self.ready.push(Packet {
                from: self.me,
                to,
                class,
                items,
                bytes,
                load: 0,
            });
        }
    }

    /// Packets ready to transmit, in the order they became ready.
    pub(crate) fn take_ready(&mut self) -> Vec<Packet<W>> {
        std::mem::take(&mut self.ready)
    }

    /// Whether packets are ready to transmit.
    #[cfg(test)]
    pub(crate) fn has_ready(&self) -> bool {
        !self.ready.is_empty()
    }

    /// Messages waiting in lanes (for a bundle or for credit).
    pub(crate) fn backlog(&self) -> usize {
        self.backlog
    }

    /// Most messages ever waiting in lanes.
    pub(crate) fn backlog_high_water(&self) -> usize {
        self.backlog_high_water
    }

    /// Bytes of the messages waiting in lanes now.
    pub(crate) fn backlog_bytes(&self) -> usize {
        self.backlog_bytes
    }

    /// Bytes of the results waiting in lanes now.
    pub(crate) fn result_backlog_bytes(&self) -> usize {
        self.result_backlog_bytes
    }

    /// Most bytes ever waiting in lanes.
    pub(crate) fn backlog_bytes_high_water(&self) -> usize {
        self.backlog_bytes_high_water
    }

    /// Work in flight here now: credit-limited bytes received and not
    /// consumed plus bytes waiting in lanes.
    pub(crate) fn in_flight_bytes(&self) -> usize {
        self.inbuf.bytes + self.backlog_bytes
    }

    /// Most work ever in flight here ([`Outbox::in_flight_bytes`]).
    pub(crate) fn in_flight_high_water(&self) -> usize {
        self.in_flight_high_water
    }

    fn note_in_flight(&mut self) {
        self.in_flight_high_water = self.in_flight_high_water.max(self.in_flight_bytes());
    }

    /// Whether nothing at all is waiting to go out.
    #[cfg(test)]
    pub(crate) fn is_empty(&self) -> bool {
        self.backlog == 0 && self.ready.is_empty()
    }

    /// Credits available towards `to` (for tests and diagnostics).
    #[cfg(test)]
    pub(crate) fn credits_towards(&self, to: Addr, pool: Pool) -> u32 {
        self.credits.available(to.slot(self.procs), pool)
    }
}

#[cfg(test)]
mod example {
    use super::*;
    use crate::tests::{Mini, Res};

    /// Formerly the type's documentation example.
    #[test]
    fn outbox_bundles_and_credits() {
        // Processor 0 of 2: bundles of up to 3 messages, 4 credits per
        // receiver (and one more that only results may use).
        let bundle = BundleConfig {
            max_items: 3,
            ..BundleConfig::default()
        };
        let mut out = Outbox::<Mini>::new(Addr::Proc(0), 2, bundle, 4, 1 << 20);
        let to = Addr::Proc(1);

        // A data request leaves at once, alone; results wait for a bundle of three.
        out.push(to, Msg::DataRequest(vec![1]), 0);
        for v in 0..3 {
            out.push(to, Msg::Result(Res { key: v, value: v }), 0);
        }
        let packets = out.take_ready();
        assert_eq!(packets.len(), 2);
        assert_eq!((packets[0].class, packets[0].items.len()), (Class::Data, 1));
        assert_eq!(
            (packets[1].class, packets[1].items.len()),
            (Class::Result, 3)
        );

        // Each result used a credit: one shared is left towards processor
        // 1, and results' reserve, so of the next bundle two messages
        // leave; the third waits (nothing blocks, nothing is dropped).
        assert_eq!(out.credits_towards(to, Pool::Tasks), 1);
        assert_eq!(out.credits_towards(to, Pool::Results), 2);
        for v in 3..6 {
            out.push(to, Msg::Result(Res { key: v, value: v }), 0);
        }
        assert_eq!(out.take_ready()[0].items.len(), 2);
        assert_eq!(out.backlog(), 1);

        // The receiver consumed three and gave their credits back; a flush
        // (the sender ran out of work) sends the rest without waiting for
        // a full bundle.
        out.grant(to, [(0, 0), (3, 3 * 16)], 0);
        out.pump(0, true);
        assert_eq!(out.take_ready()[0].items.len(), 1);
        assert!(out.is_empty());
    }
}
