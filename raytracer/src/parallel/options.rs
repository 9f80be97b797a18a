//! The parallel renderer's own options ([`WorkloadOptions`]), those that
//! are not the framework's.

use hybrid_sched::serde::{Deserialize, Serialize};

use super::distribution::Distribution;

/// Knobs of the parallel renderer that are not the framework's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct WorkloadOptions {
    /// Side of the square screen tiles (primary bundles), in pixels.
    pub tile: usize,
    /// Shadow bundles with fewer (estimated) rays than this go data-parallel.
    pub shadow_dp_below: usize,
    pub distribution: Distribution,
    /// Beyond the paper: clip once per (processor, cell, light) instead of
    /// once per shadow bundle, with the convex hull of the cell and the
    /// light (which holds every bundle shaded in the cell), and reuse the
    /// selection for every later bundle from that cell to that light.
    /// Selections hold every ray of the bundles they serve (not every cell
    /// their own pyramids reach: EXPERIMENTS.md); clipping drops by the bundles per cell.
    #[serde(default)]
    pub clip_cache: bool,
    /// Beyond the paper: shadow bundles start in the step that shaded their
    /// point instead of as tasks of their own: a data-parallel one (its
    /// first step would run on this processor anyway) and a demand-driven
    /// one whose every ray stays among the cells its processor holds
    /// resident (a selection step and an execution step saved for what
    /// is, in the studio, 1.7 rays); the rest, with data-parallel ones stopped by a cell held
    /// elsewhere, as one task per point. Pictures do not change; off, as the paper schedules.
    #[serde(default = "yes")]
    pub inline_local_shadows: bool,
    /// Beyond the paper: each processor builds a hierarchy over its
    /// resident objects and answers a fresh query through it when its
    /// objects decide the answer ([`crate::accel::LocalKernel`]), instead
    /// of walking the octree leaf by leaf. Pictures do not change; the
    /// queries answered so are charged as `trace.local`, not as leaves and
    /// objects, so the simulator (which prices the walk) runs without it.
    #[serde(default = "yes")]
    pub local_kernel: bool,
    /// Beyond the paper: the frame's last tiles handed out in quarters
    /// ([`super::tasks::screen_tiles`]). Off in runs recorded without it.
    #[serde(default)]
    pub tail_tiles: bool,
    /// Finished pixels a processor holds before it sends them to the
    /// master in one message; 0 holds them all to the end of the run. A
    /// processor's memory then grows with the picture by at most this many
    /// pixels (32 bytes each); the master holds the picture.
    #[serde(default = "pixel_batch")]
    pub pixel_batch: usize,
}

/// [`WorkloadOptions::pixel_batch`]'s default: 2 MiB of finished pixels.
pub const PIXEL_BATCH: usize = 1 << 16;

fn pixel_batch() -> usize {
    PIXEL_BATCH
}

fn yes() -> bool {
    true
}

impl Default for WorkloadOptions {
    fn default() -> Self {
        WorkloadOptions {
            tile: 16,
            shadow_dp_below: 2,
            distribution: Distribution::Octree,
            clip_cache: false,
            inline_local_shadows: true,
            local_kernel: true,
            tail_tiles: true,
            pixel_batch: PIXEL_BATCH,
        }
    }
}
