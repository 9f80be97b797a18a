//! Flow control: credits per link and input-buffer accounting.
//!
//! Every worker may have at most `credits_per_link` credit-limited messages
//! (results and tasks, see `is_credit_limited`) sent to one receiver and not
//! yet consumed there, and at most a byte window of them
//! (`Config::link_window_bytes`; a single message of any size when it has
//! none outstanding there). Results may go beyond both into a reserve of
//! their own, a quarter as large again ([`Pool::reserve`]), and a result
//! goes alone when none is outstanding: every receiver merges results
//! whatever its state, so a sender's results always get credit in the end,
//! however many of its tasks the receiver holds (a processor past its
//! budget waits for that). The receiver returns credits as it consumes
//! them (merges a result, starts a task, hands a pooled task out). A sender
//! never blocks: messages without credit wait in its outbox, and it goes on
//! with other work. Data requests and replies, and control messages, never
//! need credit, so a task waiting for data can always get it and the
//! receiver can always make progress; consumption returns credits, so no
//! cycle of full buffers can form (see SEMANTICS.md).

use serde::{Deserialize, Serialize};

use crate::protocol::Pool;

/// Sender side: the credit-limited messages and bytes outstanding towards
/// each destination slot, per pool, against the credits and byte window
/// both pools share and the reserve only results may use beyond them.
#[derive(Clone, Debug)]
pub(crate) struct Credits {
    out_n: Vec<[u32; 2]>,
    out_bytes: Vec<[usize; 2]>,
    per_link: u32,
    window: usize,
    reserve: u32,
    reserve_bytes: usize,
}

impl Credits {
    /// `per_link` credits and a window of `window` bytes shared by both
    /// pools towards each of `slots` destinations, and results' reserve
    /// beyond them ([`Pool::reserve`] of each).
    pub(crate) fn new(slots: usize, per_link: u32, window: usize) -> Self {
        Credits {
            out_n: vec![[0; 2]; slots],
            out_bytes: vec![[0; 2]; slots],
            per_link,
            window,
            reserve: Pool::reserve(per_link as usize) as u32,
            reserve_bytes: Pool::reserve(window),
        }
    }

    /// Credits available towards `slot` for a message of `pool`: tasks
    /// have what both pools together have not used of the shared ones;
    /// results the reserve too, and always one when none of theirs is
    /// outstanding.
    pub(crate) fn available(&self, slot: usize, pool: Pool) -> u32 {
        let [tasks, results] = self.out_n[slot];
        let total = tasks.saturating_add(results);
        match pool {
            Pool::Tasks => self.per_link.saturating_sub(total),
            Pool::Results => {
                let left = self
                    .per_link
                    .saturating_add(self.reserve)
                    .saturating_sub(total);
                if results == 0 {
                    left.max(1)
                } else {
                    left
                }
            }
        }
    }

    /// Whether a message of `pool` and `bytes` may join a packet to `slot`
    /// that holds `packed` bytes already: beside those and what is
    /// outstanding there it fits the shared window (results: the shared
    /// window and the reserve), or it would travel alone with nothing
    /// outstanding (results: none of theirs), so a message larger than
    /// the window is never stuck, and a result never waits for a task.
    pub(crate) fn fits(&self, slot: usize, pool: Pool, packed: usize, bytes: usize) -> bool {
        let [tasks, results] = self.out_bytes[slot];
        let out = tasks.saturating_add(results).saturating_add(packed);
        match pool {
            Pool::Tasks => out == 0 || out.saturating_add(bytes) <= self.window,
            Pool::Results => {
                results.saturating_add(packed) == 0
                    || out.saturating_add(bytes) <= self.window.saturating_add(self.reserve_bytes)
            }
        }
    }

    /// Uses `n` credits and `bytes` of the window towards `slot`.
    pub(crate) fn consume(&mut self, slot: usize, pool: Pool, n: u32, bytes: usize) {
        let i = pool.index();
        debug_assert!(self.available(slot, pool) >= n, "credit underflow");
        self.out_n[slot][i] += n;
        self.out_bytes[slot][i] += bytes;
    }

    /// `n` credits and `bytes` of `pool`'s came back from `slot`.
    pub(crate) fn grant(&mut self, slot: usize, pool: Pool, n: u32, bytes: usize) {
        let i = pool.index();
        self.out_n[slot][i] = self.out_n[slot][i].saturating_sub(n);
        self.out_bytes[slot][i] = self.out_bytes[slot][i].saturating_sub(bytes);
    }
}

/// Receiver side: consumed messages whose credit has not been returned yet,
/// per pool. Credits go back in batches (half the shared credits or window
/// at a time, both pools together) to keep control traffic small, and all
/// at once when the receiver runs out of work.
///
/// (Example: the unit test `credit_round_trip`.)
#[derive(Clone, Debug)]
pub(crate) struct CreditLedger {
    owed: Vec<[(u32, usize); 2]>,
    batch: u32,
    batch_bytes: usize,
}

impl CreditLedger {
    /// Ledger for `slots` senders with `per_link` credits and a byte window
    /// of `window` each (shared by the pools).
    pub(crate) fn new(slots: usize, per_link: u32, window: usize) -> Self {
        CreditLedger {
            owed: vec![[(0, 0); 2]; slots],
            batch: per_link.div_ceil(2).max(1),
            batch_bytes: window.div_ceil(2).max(1),
        }
    }

    /// One message of `bytes` of `pool` from `slot` was consumed.
    pub(crate) fn consumed(&mut self, slot: usize, pool: Pool, bytes: usize) {
        let o = &mut self.owed[slot][pool.index()];
        o.0 += 1;
        o.1 += bytes;
    }

    /// Credits to return now, per slot: (messages, bytes) in each pool,
    /// for every slot owed a batch (half the credits or byte window, both
    /// pools together), or every slot owed anything when `flush`.
    pub(crate) fn take_due(&mut self, flush: bool) -> Vec<(usize, [(u32, usize); 2])> {
        let mut due = Vec::new();
        for (slot, owed) in self.owed.iter_mut().enumerate() {
            let n = owed[0].0 + owed[1].0;
            let bytes = owed[0].1 + owed[1].1;
            if n > 0 && (flush || n >= self.batch || bytes >= self.batch_bytes) {
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
    fn results_reserve_a_quarter_at_least_one() {
        assert_eq!(Pool::reserve(64), 16);
        assert_eq!(Pool::reserve(3), 1);
        assert_eq!(Pool::reserve(0), 1);
    }

    #[test]
    fn ledger_batches_and_flushes() {
        // 4 credits (batches of 2) and a window of 1000 bytes (batches of
        // 500), both pools together.
        let mut l = CreditLedger::new(3, 4, 1000);
        l.consumed(1, Tasks, 10);
        assert!(l.take_due(false).is_empty());
        l.consumed(1, Results, 10);
        assert_eq!(l.take_due(false), vec![(1, [(1, 10), (1, 10)])]);
        l.consumed(2, Tasks, 10);
        assert!(l.any_owed());
        assert_eq!(l.take_due(true), vec![(2, [(1, 10), (0, 0)])]);
        assert!(!l.any_owed());
        // Half the byte window is a batch too.
        l.consumed(0, Results, 500);
        assert_eq!(l.take_due(false), vec![(0, [(0, 0), (1, 500)])]);
    }

    #[test]
    fn results_have_a_reserve_tasks_cannot_use() {
        // 4 credits shared, 1 more for results; a window of 100 bytes
        // shared, 25 more for results.
        let mut c = Credits::new(2, 4, 100);
        c.consume(0, Tasks, 4, 100);
        assert_eq!(c.available(0, Tasks), 0);
        assert!(!c.fits(0, Tasks, 0, 1));
        // Tasks used everything shared: results still go, in the reserve.
        assert_eq!(c.available(0, Results), 1);
        assert!(c.fits(0, Results, 0, 25));
        c.consume(0, Results, 1, 20);
        assert_eq!(c.available(0, Results), 0);
        assert!(!c.fits(0, Results, 0, 6));
        // Results come back: tasks still have to wait for theirs.
        c.grant(0, Results, 1, 20);
        assert_eq!(c.available(0, Tasks), 0);
        c.grant(0, Tasks, 2, 50);
        assert_eq!(c.available(0, Tasks), 2);
        assert_eq!(c.available(1, Tasks), 4);
        assert_eq!(c.available(1, Results), 5);
    }

    #[test]
    fn a_result_goes_alone_when_none_of_its_pool_is_outstanding() {
        // However much of the link tasks hold, beyond the reserve too
        // (one large task went alone), a result with none of its pool
        // outstanding has a credit and fits.
        let mut c = Credits::new(1, 1, 10);
        c.consume(0, Tasks, 1, 500);
        assert_eq!(c.available(0, Results), 1);
        assert!(c.fits(0, Results, 0, 300));
        assert!(!c.fits(0, Results, 300, 1), "but only alone");
        c.consume(0, Results, 1, 300);
        assert_eq!(c.available(0, Results), 0);
    }

    #[test]
    fn byte_window_admits_what_fits_or_one_message_alone() {
        let mut c = Credits::new(1, 64, 100);
        // Nothing outstanding: even a message larger than the window goes.
        assert!(c.fits(0, Tasks, 0, 250));
        // ... but only alone.
        assert!(!c.fits(0, Tasks, 250, 1));
        assert!(c.fits(0, Tasks, 60, 40));
        c.consume(0, Tasks, 1, 60);
        assert!(c.fits(0, Tasks, 0, 40));
        assert!(!c.fits(0, Tasks, 0, 41));
        assert!(!c.fits(0, Tasks, 20, 21));
        c.grant(0, Tasks, 1, 60);
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
        // One sender with 4 credits towards one receiver (slot 0 on both sides).
        let mut sender = Credits::new(1, 4, 1 << 20);
        let mut receiver = CreditLedger::new(1, 4, 1 << 20);
        sender.consume(0, Pool::Tasks, 4, 40); // four tasks sent: no credit left
        assert_eq!(sender.available(0, Pool::Tasks), 0);

        // The receiver returns credits half a window (2) at a time ...
        receiver.consumed(0, Pool::Tasks, 10);
        assert!(receiver.take_due(false).is_empty());
        receiver.consumed(0, Pool::Tasks, 10);
        for (slot, owed) in receiver.take_due(false) {
            for pool in Pool::ALL {
                let (n, bytes) = owed[pool.index()];
                sender.grant(slot, pool, n, bytes);
            }
        }
        assert_eq!(sender.available(0, Pool::Tasks), 2);
        // ... and everything it owes when it runs out of work.
        receiver.consumed(0, Pool::Tasks, 10);
        assert_eq!(receiver.take_due(true), [(0, [(1, 10), (0, 0)])]);
        assert!(!receiver.any_owed());
    }
}
