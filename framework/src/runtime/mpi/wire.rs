//! The rank's message buffers, measured: how many encoded bytes the
//! process holds for the wire at once ([`WIRE`]).

use std::sync::atomic::{AtomicU64, Ordering};

/// Encoded bytes this process holds for the wire: packets encoded for
/// another rank and not yet delivered by MPI (queued for the MPI thread or
/// in a non-blocking send), and packets received from another rank and not
/// yet decoded. Its peak is the rank's message buffers
/// ([`crate::stats::RankTraffic::peak_wire_bytes`]); MPI runs once per
/// process, so one gauge serves it.
pub(crate) struct WireGauge {
    held: AtomicU64,
    peak: AtomicU64,
}

pub(crate) static WIRE: WireGauge = WireGauge {
    held: AtomicU64::new(0),
    peak: AtomicU64::new(0),
};

impl WireGauge {
    /// `bytes` more are held.
    pub(crate) fn hold(&self, bytes: usize) {
        let now = self.held.fetch_add(bytes as u64, Ordering::Relaxed) + bytes as u64;
        self.peak.fetch_max(now, Ordering::Relaxed);
    }

    /// `bytes` held before are let go.
    pub(crate) fn release(&self, bytes: usize) {
        self.held.fetch_sub(bytes as u64, Ordering::Relaxed);
    }

    /// The most bytes held at once so far.
    pub(crate) fn peak(&self) -> u64 {
        self.peak.load(Ordering::Relaxed)
    }
}
