//! Flow control: credits per link and input-buffer accounting.
//!
//! Every worker may have at most `credits_per_link` credit-limited messages
//! (results and tasks, see `is_credit_limited`) sent to one
//! receiver and not yet consumed there, and at most a byte window of them
//! (`Config::link_window_bytes`; a single message of any size when it has
//! none outstanding there). The receiver returns credits as it
//! consumes them (merges a result, starts a task, hands a pooled task out).
//! A sender never blocks: messages without credit wait in its outbox, and it
//! goes on with other work. Data requests and replies, and control messages,
//! never need credit, so a task waiting for data can always get it and the
//! receiver can always make progress; consumption returns credits, so no
//! cycle of full buffers can form (see SEMANTICS.md).

use serde::{Deserialize, Serialize};

/// Sender side: credits available towards each destination slot, and the
/// bytes outstanding there against the link's byte window.
#[derive(Clone, Debug)]
pub(crate) struct Credits {
    available: Vec<u32>,
    outstanding: Vec<usize>,
    window: usize,
}

impl Credits {
    /// `per_link` credits and a window of `window` bytes towards each of
    /// `slots` destinations.
    pub(crate) fn new(slots: usize, per_link: u32, window: usize) -> Self {
        Credits {
            available: vec![per_link; slots],
            outstanding: vec![0; slots],
            window,
        }
    }

    /// Credits available towards `slot`.
    pub(crate) fn available(&self, slot: usize) -> u32 {
        self.available[slot]
    }

    /// Whether a message of `bytes` may join a packet to `slot` that holds
    /// `packed` bytes already: it fits the byte window beside those and
    /// what is outstanding there, or it would travel alone with nothing
    /// outstanding (a message larger than the window is never stuck).
    pub(crate) fn fits(&self, slot: usize, packed: usize, bytes: usize) -> bool {
        let out = self.outstanding[slot].saturating_add(packed);
        out == 0 || out.saturating_add(bytes) <= self.window
    }

    /// Uses `n` credits and `bytes` of the window towards `slot`.
    pub(crate) fn consume(&mut self, slot: usize, n: u32, bytes: usize) {
        debug_assert!(self.available[slot] >= n, "credit underflow");
        self.available[slot] -= n;
        self.outstanding[slot] += bytes;
    }

    /// `n` credits and `bytes` of the window came back from `slot`.
    pub(crate) fn grant(&mut self, slot: usize, n: u32, bytes: usize) {
        self.available[slot] += n;
        self.outstanding[slot] = self.outstanding[slot].saturating_sub(bytes);
    }
}

/// Receiver side: consumed messages whose credit has not been returned yet.
/// Credits go back in batches (half a window at a time) to keep control
/// traffic small, and all at once when the receiver runs out of work.
///
/// (Example: the unit test `credit_round_trip`.)
#[derive(Clone, Debug)]
pub(crate) struct CreditLedger {
    owed: Vec<(u32, usize)>,
    batch: u32,
    batch_bytes: usize,
}

impl CreditLedger {
    /// Ledger for `slots` senders with `per_link` credits and a byte window
    /// of `window` each.
    pub(crate) fn new(slots: usize, per_link: u32, window: usize) -> Self {
        CreditLedger {
            owed: vec![(0, 0); slots],
            batch: per_link.div_ceil(2).max(1),
            batch_bytes: window.div_ceil(2).max(1),
        }
    }

    /// One message of `bytes` from `slot` was consumed.
    pub(crate) fn consumed(&mut self, slot: usize, bytes: usize) {
        let o = &mut self.owed[slot];
        o.0 += 1;
        o.1 += bytes;
    }

    /// Credits (messages, bytes) to return now: those that reached a batch
    /// (half the credits or half the byte window), or all when `flush`.
    pub(crate) fn take_due(&mut self, flush: bool) -> Vec<(usize, u32, usize)> {
        let mut due = Vec::new();
        for (slot, owed) in self.owed.iter_mut().enumerate() {
            let (n, bytes) = *owed;
            if n > 0 && (flush || n >= self.batch || bytes >= self.batch_bytes) {
                due.push((slot, n, bytes));
                *owed = (0, 0);
            }
        }
        due
    }

    /// Whether any credit is owed.
    #[cfg(test)]
    pub(crate) fn any_owed(&self) -> bool {
        self.owed.iter().any(|&(n, _)| n > 0)
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

    #[test]
    fn ledger_batches_and_flushes() {
        let mut l = CreditLedger::new(3, 4, 1000);
        l.consumed(1, 10);
        assert!(l.take_due(false).is_empty());
        l.consumed(1, 10);
        assert_eq!(l.take_due(false), vec![(1, 2, 20)]);
        l.consumed(2, 10);
        assert!(l.any_owed());
        assert_eq!(l.take_due(true), vec![(2, 1, 10)]);
        assert!(!l.any_owed());
        // Half the byte window is a batch too.
        l.consumed(0, 500);
        assert_eq!(l.take_due(false), vec![(0, 1, 500)]);
    }

    #[test]
    fn credits_round_trip() {
        let mut c = Credits::new(2, 3, 100);
        c.consume(0, 3, 30);
        assert_eq!(c.available(0), 0);
        c.grant(0, 2, 20);
        assert_eq!(c.available(0), 2);
        assert_eq!(c.available(1), 3);
    }

    #[test]
    fn byte_window_admits_what_fits_or_one_message_alone() {
        let mut c = Credits::new(1, 64, 100);
        // Nothing outstanding: even a message larger than the window goes.
        assert!(c.fits(0, 0, 250));
        // ... but only alone.
        assert!(!c.fits(0, 250, 1));
        assert!(c.fits(0, 60, 40));
        c.consume(0, 1, 60);
        assert!(c.fits(0, 0, 40));
        assert!(!c.fits(0, 0, 41));
        assert!(!c.fits(0, 20, 21));
        c.grant(0, 1, 60);
        assert!(c.fits(0, 0, 100));
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
        sender.consume(0, 4, 40); // four results sent: no credit left
        assert_eq!(sender.available(0), 0);

        // The receiver returns credits half a window (2) at a time ...
        receiver.consumed(0, 10);
        assert!(receiver.take_due(false).is_empty());
        receiver.consumed(0, 10);
        for (slot, n, bytes) in receiver.take_due(false) {
            sender.grant(slot, n, bytes);
        }
        assert_eq!(sender.available(0), 2);
        // ... and everything it owes when it runs out of work.
        receiver.consumed(0, 10);
        assert_eq!(receiver.take_due(true), [(0, 1, 10)]);
        assert!(!receiver.any_owed());
    }
}
