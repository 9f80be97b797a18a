//! Flow control: credits per link and input-buffer accounting.
//!
//! Every worker may have at most `credits_per_link` credit-limited messages
//! (results and tasks, see `is_credit_limited`) sent to one
//! receiver and not yet consumed there, and at most a byte window of them
//! (`Config::link_window_bytes`; a single message of any size when it has
//! none outstanding there). Results have a pool of their own: as many
//! credits again and a window a quarter as large (`Config::link_windows`). Every
//! receiver merges results whatever its state, so a sender's results
//! always get credit in the end, however many of its tasks the receiver
//! holds (a processor over its budget waits for that). The receiver
//! returns credits as it
//! consumes them (merges a result, starts a task, hands a pooled task out).
//! A sender never blocks: messages without credit wait in its outbox, and it
//! goes on with other work. Data requests and replies, and control messages,
//! never need credit, so a task waiting for data can always get it and the
//! receiver can always make progress; consumption returns credits, so no
//! cycle of full buffers can form (see SEMANTICS.md).

use serde::{Deserialize, Serialize};

use crate::protocol::Pool;

/// Sender side: credits available towards each destination slot in each
/// pool, and the bytes outstanding there against the pool's byte window.
#[derive(Clone, Debug)]
pub(crate) struct Credits {
    available: Vec<[u32; 2]>,
    outstanding: Vec<[usize; 2]>,
    window: [usize; 2],
}

impl Credits {
    /// `per_link` credits in each pool and byte windows of `windows` (per
    /// pool) towards each of `slots` destinations.
    pub(crate) fn new(slots: usize, per_link: u32, windows: [usize; 2]) -> Self {
        Credits {
            available: vec![[per_link; 2]; slots],
            outstanding: vec![[0; 2]; slots],
            window: windows,
        }
    }

    /// Credits available towards `slot` in `pool`.
    pub(crate) fn available(&self, slot: usize, pool: Pool) -> u32 {
        self.available[slot][pool.index()]
    }

    /// Whether a message of `bytes` may join a packet to `slot` that holds
    /// `packed` bytes already: it fits the pool's byte window beside those
    /// and what is outstanding there, or it would travel alone with nothing
    /// outstanding (a message larger than the window is never stuck).
    pub(crate) fn fits(&self, slot: usize, pool: Pool, packed: usize, bytes: usize) -> bool {
        let out = self.outstanding[slot][pool.index()].saturating_add(packed);
        out == 0 || out.saturating_add(bytes) <= self.window[pool.index()]
    }

    /// Uses `n` credits and `bytes` of the window towards `slot`.
    pub(crate) fn consume(&mut self, slot: usize, pool: Pool, n: u32, bytes: usize) {
        let i = pool.index();
        debug_assert!(self.available[slot][i] >= n, "credit underflow");
        self.available[slot][i] -= n;
        self.outstanding[slot][i] += bytes;
    }

    /// `n` credits and `bytes` of the pool's window came back from `slot`.
    pub(crate) fn grant(&mut self, slot: usize, pool: Pool, n: u32, bytes: usize) {
        let i = pool.index();
        self.available[slot][i] += n;
        self.outstanding[slot][i] = self.outstanding[slot][i].saturating_sub(bytes);
    }
}

/// Receiver side: consumed messages whose credit has not been returned yet.
/// Credits go back in batches (half a pool's credits or window at a time)
/// to keep control traffic small, and all at once when the receiver runs
/// out of work.
///
/// (Example: the unit test `credit_round_trip`.)
#[derive(Clone, Debug)]
pub(crate) struct CreditLedger {
    owed: Vec<[(u32, usize); 2]>,
    batch: [u32; 2],
    batch_bytes: [usize; 2],
}

impl CreditLedger {
    /// Ledger for `slots` senders with `per_link` credits in each pool and
    /// byte windows of `windows` (per pool).
    pub(crate) fn new(slots: usize, per_link: u32, windows: [usize; 2]) -> Self {
        let window = windows;
        CreditLedger {
            owed: vec![[(0, 0); 2]; slots],
            batch: [per_link.div_ceil(2).max(1); 2],
            batch_bytes: window.map(|w| w.div_ceil(2).max(1)),
        }
    }

    /// One message of `bytes` of `pool` from `slot` was consumed.
    pub(crate) fn consumed(&mut self, slot: usize, pool: Pool, bytes: usize) {
        let o = &mut self.owed[slot][pool.index()];
        o.0 += 1;
        o.1 += bytes;
    }

    /// Credits to return now, per slot: (messages, bytes) in each pool,
    /// for every slot where a pool reached a batch (half its credits or
    /// byte window; the other pool's go with them), or every slot owed
    /// anything when `flush`.
    pub(crate) fn take_due(&mut self, flush: bool) -> Vec<(usize, [(u32, usize); 2])> {
        let mut due = Vec::new();
        for (slot, owed) in self.owed.iter_mut().enumerate() {
            let reached = |i: usize| {
                let (n, bytes) = owed[i];
                n > 0 && (flush || n >= self.batch[i] || bytes >= self.batch_bytes[i])
            };
            if reached(0) || reached(1) {
                due.push((slot, *owed));
                *owed = [(0, 0); 2];
            }
        }
        due
    }

    /// Whether any credit is owed.
    #[cfg(test)]
    pub(crate) fn any_owed(&self) -> bool {
        self.owed.iter().flatten().any(|&(n, _)| n > 0)
    }
}

/// Current size and high-water mark of the credit-limited part of an input
/// buffer (messages received, not yet consumed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct InputBuffer {
    /// Messages held now.
    pub items: usize,
    /// Bytes held now.
    pub bytes: usize,
    /// Most messages ever held.
    pub high_water_items: usize,
    /// Most bytes ever held.
    pub high_water_bytes: usize,
}

impl InputBuffer {
    /// A message arrived.
    pub(crate) fn add(&mut self, bytes: usize) {
        self.items += 1;
        self.bytes += bytes;
        self.high_water_items = self.high_water_items.max(self.items);
        self.high_water_bytes = self.high_water_bytes.max(self.bytes);
    }

    /// A message was consumed.
    pub(crate) fn remove(&mut self, bytes: usize) {
        self.items -= 1;
        self.bytes -= bytes;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Pool::{Results, Tasks};

    #[test]
    fn ledger_batches_and_flushes() {
        // 4 credits per pool (batches of 2); windows of 750 bytes for tasks
        // and 250 for results (batches of 375 and 125 bytes).
        let mut l = CreditLedger::new(3, 4, [750, 250]);
        l.consumed(1, Tasks, 10);
        assert!(l.take_due(false).is_empty());
        l.consumed(1, Tasks, 10);
        assert_eq!(l.take_due(false), vec![(1, [(2, 20), (0, 0)])]);
        l.consumed(2, Tasks, 10);
        assert!(l.any_owed());
        assert_eq!(l.take_due(true), vec![(2, [(1, 10), (0, 0)])]);
        assert!(!l.any_owed());
        // Half the pool's byte window is a batch too.
        l.consumed(0, Tasks, 375);
        assert_eq!(l.take_due(false), vec![(0, [(1, 375), (0, 0)])]);
        l.consumed(0, Results, 125);
        assert_eq!(l.take_due(false), vec![(0, [(0, 0), (1, 125)])]);
        // Results are owed apart from tasks; a batch of either returns both.
        l.consumed(0, Tasks, 10);
        assert!(l.take_due(false).is_empty());
        l.consumed(0, Results, 10);
        l.consumed(0, Results, 10);
        assert_eq!(l.take_due(false), vec![(0, [(1, 10), (2, 20)])]);
        assert!(!l.any_owed());
    }

    #[test]
    fn credits_round_trip() {
        let mut c = Credits::new(2, 3, [100, 25]);
        c.consume(0, Tasks, 3, 30);
        assert_eq!(c.available(0, Tasks), 0);
        // Tasks without credit leave the results' pool untouched.
        assert_eq!(c.available(0, Results), 3);
        c.grant(0, Tasks, 2, 20);
        assert_eq!(c.available(0, Tasks), 2);
        assert_eq!(c.available(1, Tasks), 3);
    }

    #[test]
    fn byte_window_admits_what_fits_or_one_message_alone() {
        // Windows of 100 bytes for tasks, 33 for results.
        let mut c = Credits::new(1, 64, [100, 33]);
        // Nothing outstanding: even a message larger than the window goes.
        assert!(c.fits(0, Tasks, 0, 250));
        // ... but only alone.
        assert!(!c.fits(0, Tasks, 250, 1));
        assert!(c.fits(0, Tasks, 60, 40));
        c.consume(0, Tasks, 1, 60);
        assert!(c.fits(0, Tasks, 0, 40));
        assert!(!c.fits(0, Tasks, 0, 41));
        assert!(!c.fits(0, Tasks, 20, 21));
        // The results' window is apart: a full task window leaves it open.
        c.consume(0, Tasks, 1, 40);
        assert!(c.fits(0, Results, 0, 33));
        assert!(!c.fits(0, Results, 1, 33));
        c.grant(0, Tasks, 2, 100);
        assert!(c.fits(0, Tasks, 0, 100));
    }

    #[test]
    fn input_buffer_high_water() {
        let mut b = InputBuffer::default();
        b.add(10);
        b.add(5);
        b.remove(10);
        b.add(1);
        assert_eq!((b.items, b.bytes), (2, 6));
        assert_eq!((b.high_water_items, b.high_water_bytes), (2, 15));
    }
}

#[cfg(test)]
mod example {
    use super::*;

    /// Formerly the type's documentation example.
    #[test]
    fn credit_round_trip() {
        // One sender with 4 credits for results (and 4 for tasks) towards
        // one receiver (slot 0 on both sides).
        let mut sender = Credits::new(1, 4, [1 << 20; 2]);
        let mut receiver = CreditLedger::new(1, 4, [1 << 20; 2]);
        sender.consume(0, Pool::Results, 4, 40); // four results sent: no credit left
        assert_eq!(sender.available(0, Pool::Results), 0);

        // The receiver returns credits half a pool's (2) at a time ...
        receiver.consumed(0, Pool::Results, 10);
        assert!(receiver.take_due(false).is_empty());
        receiver.consumed(0, Pool::Results, 10);
        for (slot, owed) in receiver.take_due(false) {
            for pool in Pool::ALL {
                let (n, bytes) = owed[pool.index()];
                sender.grant(slot, pool, n, bytes);
            }
        }
        assert_eq!(sender.available(0, Pool::Results), 2);
        // ... and everything it owes when it runs out of work.
        receiver.consumed(0, Pool::Results, 10);
        assert_eq!(receiver.take_due(true), [(0, [(0, 0), (1, 10)])]);
        assert!(!receiver.any_owed());
    }
}
