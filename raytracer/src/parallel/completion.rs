//! When a processor asks for the rest of the scene
//! ([`hybrid_sched::Ctx::complete_cache`]): the walks past its own cells
//! are the rent, holding every cell the price (the ski-rental rule, with
//! the run's length known).

use hybrid_sched::Ctx;

use super::tasks::Tile;
use super::workload::RtWorkload;

/// What a leaf walked past a processor's hierarchy costs a parallel render
/// in all, not only the walk: judging the queries that leave the
/// hierarchy, walking them, migrating or scheduling what stops at a cell
/// held elsewhere. Measured on the studio at 512x512, two processors, the
/// render holding its partial hierarchies until half the data it lacks
/// was asked for against the same render holding every cell from its
/// first fetch: 1.05, 1.11 and 1.14 us more time executing and selecting
/// (both processors) per leaf walked (the first render's `trace.leaves`)
/// in three runs.
const WALK_OVERHEAD_NS: f64 = 1100.0;

/// A hierarchy's build per object (measured as for the grown hierarchy's
/// rebuilds, `kernel.rs`).
const BUILD_NS_PER_OBJECT: f64 = 1600.0;

/// Copying a byte of cell data into the cache (or receiving it), generous
/// for a memory copy and about a 10 Gbit/s link's time.
const COPY_NS_PER_BYTE: f64 = 1.0;

/// Leaves walked after which a processor of a scene of `objects` objects
/// and `data_bytes` of cell data asks for the rest of it
/// ([`hybrid_sched::Ctx::complete_cache`]): the ski-rental rule again, as
/// for rebuilds. Renting is walking: each leaf a query walks past the
/// processor's hierarchy costs about 1.1 µs in all (`WALK_OVERHEAD_NS`,
/// measured). Buying is holding every cell: a hierarchy over every object
/// (about 1.6 µs each, `BUILD_NS_PER_OBJECT`) and a copy of the cell data
/// (about 1 ns a byte, `COPY_NS_PER_BYTE`). Buying once the rent has reached the price
/// costs at most twice the better of never buying and buying at once.
/// Whether a processor may buy is the framework's (a cache without
/// budget, completion configured: `render --complete-cache`); the picture
/// is the same either way. The studio (4,602 objects, 3.0 MB): about
/// 9,400 leaves.
pub fn walks_worth_the_rest(objects: usize, data_bytes: u64) -> u64 {
    let price = objects as f64 * BUILD_NS_PER_OBJECT + data_bytes as f64 * COPY_NS_PER_BYTE;
    (price / WALK_OVERHEAD_NS).ceil().max(1.0) as u64
}

/// The leaves a processor would walk over `share` pixels at the rate of
/// its first `pixels` (`walked` so far): 0 before it has traced
/// [`PROJECT_FROM`] of its share (a few tiles are a poor sample).
fn projected_walks(walked: u64, pixels: u64, share: u64) -> u64 {
    if pixels == 0 || pixels.saturating_mul(PROJECT_FROM) < share {
        return 0;
    }
    let p = u128::from(walked) * u128::from(share.max(pixels)) / u128::from(pixels);
    u64::try_from(p).unwrap_or(u64::MAX)
}

/// [`projected_walks`] projects once a processor has traced 1/64 of its
/// share of the frame's pixels (the studio at 512x512 on two processors:
/// about 6 of its 384 tiles).
const PROJECT_FROM: u64 = 64;

impl RtWorkload {
    /// Counts `leaves` walked by the running processor's queries outside
    /// its grown hierarchy (`kernel.rs`), and asks for the
    /// rest of the scene ([`Ctx::complete_cache`]) once the walks are worth
    /// it ([`walks_worth_the_rest`]): when they have cost what the rest
    /// costs (the ski-rental rule), or sooner, when the walks per pixel of
    /// its tiles so far, over its share of the frame's pixels, come to
    /// that cost (the rule with the run's length known: renting for the
    /// whole run costs more than buying now). Once: the count only grows.
    #[inline]
    pub(super) fn note_walked(&self, ctx: &mut Ctx<Self>, leaves: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        if leaves == 0 {
            return;
        }
        let proc = ctx.proc_id();
        let Some(g) = self.grown.get(proc) else {
            return;
        };
        let walked = g.walked.fetch_add(leaves, Relaxed) + leaves;
        if g.asked.load(Relaxed) {
            return;
        }
        let worth = *self.rest_worth.get_or_init(|| {
            walks_worth_the_rest(self.renderer.scene().object_count(), self.data_bytes())
        });
        let pixels = g.pixels.load(Relaxed);
        let share = (self.width * self.height).div_ceil(ctx.procs().max(1)) as u64;
        let projected = projected_walks(walked, pixels, share);
        // Only a processor with a hierarchy of its own gains by holding
        // everything: it then traces through it alone.
        if (walked >= worth || projected >= worth)
            && self.has_local_path(proc)
            && !g.asked.swap(true, Relaxed)
        {
            tracing::debug!(
                proc,
                walked,
                pixels,
                projected,
                worth,
                "the walks pay for the rest of the scene"
            );
            ctx.complete_cache();
        }
    }

    /// Counts the pixels of tile `t` as traced by processor `proc` (for
    /// [`Self::note_walked`]'s projection).
    #[inline]
    pub(super) fn note_tile(&self, proc: usize, t: &Tile) {
        if let Some(g) = self.grown.get(proc) {
            let px = u64::from(t.x1 - t.x0) * u64::from(t.y1 - t.y0);
            g.pixels.fetch_add(px, std::sync::atomic::Ordering::Relaxed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{projected_walks, PROJECT_FROM};

    /// Nothing is projected from less than 1/64 of the share; from there
    /// on, the walks at the rate so far over the whole share (never fewer
    /// than walked, and without overflow).
    #[test]
    fn walks_are_projected_over_the_share_from_a_sample() {
        let share: u64 = 97_536;
        let sample = share.div_ceil(PROJECT_FROM);
        assert_eq!(projected_walks(5_000, sample - 1, share), 0);
        assert_eq!(projected_walks(5_000, 0, share), 0);
        assert_eq!(projected_walks(3_000, 1_536, share), 3_000 * share / 1_536);
        assert_eq!(projected_walks(3_000, share, share), 3_000);
        // More pixels than the share (tiles taken from a slower processor).
        assert_eq!(projected_walks(3_000, 2 * share, share), 3_000);
        assert_eq!(projected_walks(u64::MAX, sample, share), u64::MAX);
    }
}
