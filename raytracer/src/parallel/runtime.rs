//! Running a workload on the runtime [`ParallelOptions`] names: threads,
//! the framework's sequential reference, the simulator (priced by the
//! committed cost model) or MPI.

use std::sync::Arc;

use hybrid_sched::{Config, Runtime, Sequential, Sim, Threads};

use super::{cost, ParallelOptions, RuntimeKind};
use crate::render::{RenderOptions, Renderer};
use crate::{Error, Result};

/// Runs `wl` on the runtime, processors and flow control of `popts`,
/// with a cache of `cache_bytes` per processor and at most `fetch_limit`
/// bytes fetched for one demand-driven task.
pub(crate) fn run_on<W: hybrid_sched::Workload>(
    wl: Arc<W>,
    popts: &ParallelOptions,
    cache_bytes: Option<u64>,
    fetch_limit: Option<u64>,
) -> Result<hybrid_sched::RunReport<W>> {
    let mut config = Config::new(popts.procs)
        .with_policy(popts.policy)
        .with_cache_bytes(cache_bytes)
        .with_fetch_limit(fetch_limit)
        .with_complete_cache(popts.complete_cache)
        .with_data_service(popts.data_service);
    config.threads = popts.threads;
    config.time_limit = popts.time_limit;
    config.credits_per_link = popts.credits;
    config.flight_bytes = popts.flight_bytes;
    config.prefetch_work = popts.prefetch_work;
    config
        .validate()
        .map_err(|e| Error::Usage(format!("parallel configuration: {e}")))?;
    let runtime: Box<dyn Runtime<W>> = match popts.runtime {
        RuntimeKind::Threads => Box::new(Threads),
        RuntimeKind::Sequential => Box::new(Sequential),
        RuntimeKind::Sim => {
            let mut sim = Sim::new(cost::model(), popts.network.clone());
            sim.seed = popts.sim_seed;
            // Virtual time has no wall-clock limit.
            config.time_limit = None;
            Box::new(sim)
        }
        RuntimeKind::Mpi => mpi_runtime()?,
    };
    runtime
        .run_blocking(wl, &config)
        .map_err(|e| Error::Other(format!("parallel render failed: {e}")))
}

/// Starts MPI (once per process) and returns `(rank, ranks)`.
#[cfg(feature = "mpi")]
pub fn mpi_world() -> Result<(usize, usize)> {
    let w = hybrid_sched::runtime::mpi::init()
        .map_err(|e| Error::Other(format!("cannot start MPI: {e}")))?;
    Ok((w.rank, w.size))
}

/// The MPI runtime (one processor per rank).
#[cfg(feature = "mpi")]
fn mpi_runtime<W: hybrid_sched::Workload>() -> Result<Box<dyn Runtime<W>>> {
    Ok(Box::new(hybrid_sched::runtime::mpi::Mpi))
}

#[cfg(not(feature = "mpi"))]
fn mpi_runtime<W: hybrid_sched::Workload>() -> Result<Box<dyn Runtime<W>>> {
    Err(Error::Usage(
        "runtime \"mpi\" is not available in this build (build hybrid-rt with --features mpi)"
            .into(),
    ))
}

/// This process's MPI rank.
#[cfg(feature = "mpi")]
pub(crate) fn this_rank() -> Result<usize> {
    mpi_world().map(|(rank, _)| rank)
}

#[cfg(not(feature = "mpi"))]
pub(crate) fn this_rank() -> Result<usize> {
    mpi_runtime::<super::RtWorkload>().map(|_| 0)
}

/// Most samples of a hemisphere the hybrid-scheduled workload takes,
/// strata and super-samples (a sample is named by a 16-bit step of its
/// node's path).
const MOST_STRATA: u32 = 60_000;

/// Whether the hybrid-scheduled workload computes the diffuse
/// inter-reflection `o` asks for: without an irradiance cache (`-aa 0`),
/// a hemisphere's sample rays are data-parallel tasks like any other
/// ray's, and the pixel's owner evaluates it once their values are in;
/// its super-samples (`-as`), which depend on the first samples' values,
/// are made there when the last of those is merged
/// ([`hybrid_sched::Workload::merge_in`]) and traced the same way. With a
/// cache, pixels are shaded in waves and each pixel's owner decides its
/// lookups in the sequential renderer's order (`irradiance.rs`,
/// `cursor.rs`), its hemispheres' rays traced the same way. Hemispheres of
/// more samples than a ray-tree path can name (`-ad` plus `-as` above
/// 60,000) are not.
pub fn hybrid_interreflection(o: &RenderOptions) -> bool {
    u64::from(o.ad) + u64::from(o.as_) <= u64::from(MOST_STRATA)
}

/// Most hemisphere samples the primary rays of one tile start at once, for
/// [`hemisphere_tile`].
const TILE_SAMPLES: u64 = 16_384;

/// The tile side for a render with diffuse inter-reflection in the hybrid
/// workload ([`hybrid_interreflection`]) where none was asked for: the
/// largest power of two up to `side` whose tile starts at most
/// 16,384 hemisphere samples (`-ad` plus `-as` per primary ray,
/// `-pn` of them per pixel). Each of
/// a tile's pixels starts a hemisphere of its own when the tile runs, and
/// its samples wait as tasks, so what a processor holds grows with the
/// tile's area: the Cornell box at 96 x 96, `-ab 1 -aa 0` (`-ad 512 -as
/// 128`), two processors, peaked at 12, 32, 128 and 528 MB with tiles of 4,
/// 8, 16 and 32 pixels. Without `-ab` (or with a cache, which shades
/// pixels in waves, not tiles) it is `side`.
pub fn hemisphere_tile(o: &RenderOptions, side: usize) -> usize {
    if o.ab == 0 || o.aa > 0.0 || !hybrid_interreflection(o) {
        return side;
    }
    let per_pixel = (u64::from(o.pn.max(1)) * (u64::from(o.ad) + u64::from(o.as_))).max(1);
    let mut t = 1;
    while t * 2 <= side && ((t * 2) as u64).pow(2) * per_pixel <= TILE_SAMPLES {
        t *= 2;
    }
    t
}

/// The hybrid-scheduled workload names a hemisphere's samples by 16-bit
/// steps of their ray-tree paths: it refuses hemispheres of more samples
/// than that instead of losing some.
pub fn check_hybrid(renderer: &Renderer<'_>) -> Result<()> {
    let o = renderer.options();
    if renderer.effects().diffuse_interreflection.enabled && !hybrid_interreflection(o) {
        return Err(Error::Usage(format!(
            "-ab {} -as {} -ad {}: the hybrid-scheduled workload samples hemispheres of at most {MOST_STRATA} rays (-ad plus -as)",
            o.ab, o.as_, o.ad
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tile for hemispheres: rpict's settings give 4, fewer samples a
    /// larger tile up to the side asked for, a cache (or no `-ab`) the side.
    #[test]
    fn hemisphere_tiles_keep_a_tiles_samples_bounded() {
        let o = |ab, aa, ad, as_| RenderOptions {
            ab,
            aa,
            ad,
            as_,
            ..RenderOptions::default()
        };
        assert_eq!(hemisphere_tile(&o(1, 0.0, 512, 128), 16), 4);
        assert_eq!(hemisphere_tile(&o(2, 0.0, 64, 0), 16), 16);
        assert_eq!(hemisphere_tile(&o(1, 0.0, 128, 0), 16), 8);
        assert_eq!(hemisphere_tile(&o(1, 0.0, 4096, 512), 16), 1);
        assert_eq!(hemisphere_tile(&o(1, 0.0, 16, 0), 8), 8);
        let four = RenderOptions {
            pn: 4,
            ..o(1, 0.0, 128, 0)
        };
        assert_eq!(hemisphere_tile(&four, 16), 4);
        assert_eq!(hemisphere_tile(&o(1, 0.2, 512, 128), 16), 16);
        assert_eq!(hemisphere_tile(&o(0, 0.0, 512, 128), 16), 16);
        for ad in [1, 7, 64, 100, 640, 5000] {
            let t = hemisphere_tile(&o(1, 0.0, ad, 0), 32) as u64;
            assert!(t.is_power_of_two() && t <= 32);
            assert!(
                t == 1 || t * t * u64::from(ad) <= TILE_SAMPLES,
                "-ad {ad}: {t}"
            );
            assert!(
                t == 32 || 4 * t * t * u64::from(ad) > TILE_SAMPLES,
                "-ad {ad}: {t}"
            );
        }
    }
}
