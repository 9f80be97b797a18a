//! The simulator's timeline: time per [`State`] per time bucket for every
//! actor, from which "processors clipping over time", "idle over time" and
//! similar figures are drawn.

use serde::{Deserialize, Serialize};

use crate::clock::Time;
use crate::protocol::Class;
use crate::stats::{State, StateTimes};

/// Most buckets a [`Timeline`] keeps (it coarsens beyond).
pub const MAX_BUCKETS: usize = 4096;

/// Time per [`State`] per bucket for every actor (workers, then the master).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// Bucket width in virtual nanoseconds.
    pub bucket_ns: u64,
    /// `actors[slot][bucket]`.
    pub actors: Vec<Vec<StateTimes>>,
    /// Traffic sent per actor and bucket, in bytes, per class index
    /// ([`Class::index`]).
    pub sent_bytes: Vec<Vec<[u64; 5]>>,
}

impl Timeline {
    pub(crate) fn new(actors: usize, bucket_ns: u64) -> Self {
        Timeline {
            bucket_ns: bucket_ns.max(1),
            actors: vec![Vec::new(); actors],
            sent_bytes: vec![Vec::new(); actors],
        }
    }

    /// Makes sure time `t` falls in one of at most [`MAX_BUCKETS`] buckets,
    /// doubling the bucket width (merging neighbours) as often as needed.
    pub(crate) fn fit(&mut self, t: Time) {
        while t / self.bucket_ns >= MAX_BUCKETS as u64 {
            self.bucket_ns *= 2;
            for row in &mut self.actors {
                *row = row
                    .chunks(2)
                    .map(|c| {
                        let mut m = c[0];
                        if let Some(b) = c.get(1) {
                            for s in State::ALL {
                                m.add(s, b.get(s));
                            }
                        }
                        m
                    })
                    .collect();
            }
            for row in &mut self.sent_bytes {
                *row = row
                    .chunks(2)
                    .map(|c| {
                        let mut m = c[0];
                        if let Some(b) = c.get(1) {
                            for (x, y) in m.iter_mut().zip(b) {
                                *x += y;
                            }
                        }
                        m
                    })
                    .collect();
            }
        }
    }

    pub(crate) fn add(&mut self, slot: usize, state: State, mut t0: Time, t1: Time) {
        if t1 <= t0 {
            return;
        }
        self.fit(t1 - 1);
        let b = self.bucket_ns;
        let row = &mut self.actors[slot];
        while t0 < t1 {
            let k = (t0 / b) as usize;
            let end = ((k as u64 + 1) * b).min(t1);
            if row.len() <= k {
                row.resize(k + 1, StateTimes::default());
            }
            row[k].add(state, end - t0);
            t0 = end;
        }
    }

    pub(crate) fn sent(&mut self, slot: usize, class: Class, at: Time, bytes: usize) {
        self.fit(at);
        let k = (at / self.bucket_ns) as usize;
        let row = &mut self.sent_bytes[slot];
        if row.len() <= k {
            row.resize(k + 1, [0; 5]);
        }
        row[k][class.index()] += bytes as u64;
    }

    /// Number of buckets covering the run.
    pub fn buckets(&self) -> usize {
        self.actors.iter().map(Vec::len).max().unwrap_or(0)
    }

    /// Time of `state` in bucket `k` of actor `slot`.
    pub fn get(&self, slot: usize, k: usize, state: State) -> u64 {
        self.actors[slot].get(k).map_or(0, |t| t.get(state))
    }
}
