//! Diffuse inter-reflection on threads: the same picture as the sequential
//! renderer, bit for bit, for any number of processors.
//!
//! The irradiance cache makes a pixel depend on the records that exist
//! when its points are shaded (paper, section 4: the cache is a data
//! dependency between tasks). Both renderers therefore shade pixels in the
//! waves of [`crate::render::waves`]: within a wave every pixel reads the
//! cache as it was when the wave began (shared read-only by all
//! processors) plus the records its own trace makes; between waves the
//! wave's records join the cache in pixel order, as a broadcast of
//! write-once data would deliver them. Here the pixels of a wave are
//! handed out demand-driven, in chunks, to `procs` threads; which thread
//! shades a pixel and when changes nothing in its value. With adaptive
//! pixel sampling (`-ps` > 1) the pixels the sampler asks for are waves
//! too (see [`crate::render::waves`]). Without a cache (`-aa 0`) every
//! pixel is independent: all are shaded at once and the adaptive
//! sampler's picture taken from the full one
//! ([`crate::render::adaptive::resample`], equal to sampling adaptively).
//!
//! This runs in process on threads; it is not (yet) part of the
//! hybrid-scheduled [`super::RtWorkload`], which refuses `-ab` (see
//! [`check_hybrid`]): there a hemisphere's rays would migrate cell by cell
//! like reflected rays, within the same waves.

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::accel::OctreeParams;
use crate::image::Film;
use crate::render::ambient::{AmbientCache, AmbientRecord};
use crate::render::waves::render_in_waves;
use crate::render::{check_resolution, RayCounts, RenderOptions, Renderer, TraceState};
use crate::scene::{Color, Scene, View};
use crate::{Error, Result};

/// The hybrid-scheduled workload assembles pixels from ray-tree records
/// and has no irradiance cache: it refuses renders that need one (or more
/// than one primary ray per pixel) instead of silently dropping the term.
pub fn check_hybrid(renderer: &Renderer<'_>) -> Result<()> {
    let o = renderer.options();
    if renderer.effects().diffuse_interreflection.enabled {
        return Err(Error::Usage(format!(
            "-ab {}: the hybrid-scheduled workload does not compute diffuse inter-reflection; with --procs, -ab renders use the threaded irradiance-cache renderer (parallel::ambient)",
            o.ab
        )));
    }
    if o.pn > 1 {
        return Err(Error::Usage(format!(
            "-pn {}: the hybrid-scheduled workload traces one primary ray per pixel",
            o.pn
        )));
    }
    Ok(())
}

/// Options of [`render_ambient_parallel`].
#[derive(Clone, Debug, Serialize)]
pub struct AmbientParallelOptions {
    pub procs: usize,
}

/// What a parallel inter-reflection render did.
#[derive(Debug, Serialize)]
pub struct AmbientParallelReport {
    #[serde(skip)]
    pub film: Film,
    pub options: AmbientParallelOptions,
    /// Wall-clock seconds of the pixel loop.
    pub render_s: f64,
    /// Waves of pixels shaded (0 without a cache).
    pub waves: usize,
    /// Hemispheres sampled, over all processors.
    pub hemispheres: u64,
    /// Records in the cache at the end.
    pub records: usize,
    /// The records this render added (after the `initial` ones), in the
    /// order they joined the cache.
    #[serde(skip)]
    pub new_records: Vec<AmbientRecord>,
    /// Rays by kind over all processors.
    pub rays: RayCounts,
    /// The effects the render simulated, and why.
    pub effects: crate::render::EffectsReport,
}

/// Renders with diffuse inter-reflection on `opts.procs` threads (see the
/// module documentation).
pub fn render_ambient_parallel(
    scene: &Scene,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    opts: &AmbientParallelOptions,
) -> Result<AmbientParallelReport> {
    render_ambient_parallel_with_progress(scene, options, view, width, height, opts, &[], None)
}

/// Pixels shaded together: few enough to balance, many enough that
/// handing them out costs nothing.
const CHUNK: usize = 16;

/// Shades the pixels `items` (row-major indices) on `procs` threads: each
/// pixel's value and the records its trace made, in the order of `items`.
fn shade_all<F>(
    procs: usize,
    items: &[u32],
    shade: F,
    rays: &mut RayCounts,
    progress: Option<&AtomicU64>,
) -> Result<Vec<(Color, Vec<AmbientRecord>)>>
where
    F: Fn(usize, &mut TraceState) -> (Color, Vec<AmbientRecord>) + Sync,
{
    let next = AtomicUsize::new(0);
    let threads = procs.min(items.len().div_ceil(CHUNK)).max(1);
    type Part = (Vec<(usize, (Color, Vec<AmbientRecord>))>, RayCounts);
    let parts: Vec<std::thread::Result<Part>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut st = TraceState::default();
                    let mut done = Vec::new();
                    loop {
                        let k = next.fetch_add(CHUNK, Ordering::Relaxed);
                        if k >= items.len() {
                            break;
                        }
                        let end = (k + CHUNK).min(items.len());
                        for (j, &i) in items.iter().enumerate().take(end).skip(k) {
                            done.push((j, shade(i as usize, &mut st)));
                        }
                        if let Some(p) = progress {
                            p.fetch_add((end - k) as u64, Ordering::Relaxed);
                        }
                    }
                    (done, st.counts)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join()).collect()
    });
    let mut out = vec![(Color::ZERO, Vec::new()); items.len()];
    for part in parts {
        let (done, counts) =
            part.map_err(|_| Error::Other("a rendering thread panicked".into()))?;
        rays.add(&counts);
        for (j, r) in done {
            out[j] = r;
        }
    }
    Ok(out)
}

/// [`render_ambient_parallel`] with the cache starting from `initial`
/// (records of an earlier render, Radiance's `-af`), counting finished
/// pixels into `progress` while it runs (the picture is the same).
#[allow(clippy::too_many_arguments)]
pub fn render_ambient_parallel_with_progress(
    scene: &Scene,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    opts: &AmbientParallelOptions,
    initial: &[AmbientRecord],
    progress: Option<Arc<AtomicU64>>,
) -> Result<AmbientParallelReport> {
    check_resolution(width, height)?;
    if opts.procs == 0 {
        return Err(Error::Usage("--procs must be at least 1".into()));
    }
    let renderer = Renderer::with_octree(scene, options, &OctreeParams::default())?;
    let s = *renderer.ambient_settings();
    let (ps, pt) = (renderer.options().ps, renderer.options().pt);
    let caching = renderer.caches_ambient();
    let mut base = AmbientCache::default();
    for r in initial {
        base.insert(&s, *r);
    }
    let loaded = base.len();
    let progress = progress.as_deref();
    let t0 = Instant::now();
    let mut rays = RayCounts::default();
    let (film, cache, waves) = if caching {
        let out = render_in_waves(
            width,
            height,
            (ps, pt),
            &s,
            Arc::new(base),
            &mut |wave, cache| {
                shade_all(
                    opts.procs,
                    wave,
                    |i, st| {
                        st.ambient = Renderer::frozen_state(cache);
                        let c = renderer.pixel(view, width, height, i % width, i / width, st);
                        (c, st.ambient.take_own())
                    },
                    &mut rays,
                    progress,
                )
            },
            &mut |_| {},
        )?;
        (out.film, out.cache, out.waves)
    } else {
        // No cache: every pixel on its own, then (-ps > 1) the adaptive
        // sampler's picture from the full one.
        let all: Vec<u32> = (0..(width * height) as u32).collect();
        let shaded = shade_all(
            opts.procs,
            &all,
            |i, st| {
                let c = renderer.pixel(view, width, height, i % width, i / width, st);
                (c, Vec::new())
            },
            &mut rays,
            progress,
        )?;
        let mut full = Film::new(width, height);
        for (i, (c, _)) in shaded.into_iter().enumerate() {
            full.set(i % width, i / width, c);
        }
        let film = if ps > 1 {
            crate::render::adaptive::resample(&full, ps, pt)
        } else {
            full
        };
        (film, Arc::new(base), 0)
    };
    let render_s = t0.elapsed().as_secs_f64();
    let records = cache.len();
    let new_records = cache.records()[loaded.min(records)..].to_vec();
    Ok(AmbientParallelReport {
        film,
        options: opts.clone(),
        render_s,
        waves,
        hemispheres: rays.ambient_cache.hemispheres,
        records,
        new_records,
        rays,
        effects: renderer.effects().clone(),
    })
}
