//! Diffuse inter-reflection in parallel: hemisphere rays as data-parallel
//! tasks, and the irradiance cache's data dependency (paper, section 4).
//!
//! A cache answers a lookup only with records that are *finished*; in
//! parallel, a hemisphere may still be in flight when a nearby point asks.
//! The paper names two ways out, both implemented here and selected by
//! [`HemisphereMode`]:
//!
//! - [`HemisphereMode::OneAtATime`]: a processor samples at most one
//!   hemisphere at a time. A pixel that needs another one while its own is
//!   in flight waits for it (the processor meanwhile runs hemisphere rays
//!   of any processor, or idles), then looks again: usually the new record
//!   now answers it. Cost: idle time.
//! - [`HemisphereMode::Extra`]: hemispheres start freely. Cost: extra
//!   hemispheres, counted as *redundant* when, by the time one finishes, a
//!   record made after it started would have answered its lookup.
//!
//! The runtime: `procs` threads, screen tiles handed out demand-driven in
//! scanline order, and the rays of every first-level hemisphere queued as
//! data-parallel tasks that any processor runs in preference to starting
//! new pixels (the paper's priority rule). A pixel that misses the cache is
//! parked; when its hemisphere's record is stored it is traced again from
//! the start (its random streams are its own, so only cache lookups can
//! change). Deeper bounces (`-ab` > 1) are computed inside the hemisphere
//! ray that needs them, through the same shared cache. Records are visible
//! to every processor once stored (as if broadcast at once). The images
//! differ from the sequential renderer's only through which records
//! existed when a point was shaded: `tests/parallel_render.rs` checks they
//! agree within a tolerance. With `-aa 0` there is no cache to wait for:
//! hemispheres are sampled inline and the image equals the sequential one.
//!
//! This runs in process on threads; it is not (yet) part of the
//! hybrid-scheduled [`super::RtWorkload`], which refuses `-ab` (see
//! [`check_hybrid`]): there hemisphere rays would migrate cell by cell like
//! reflected rays.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, RwLock};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::accel::OctreeParams;
use crate::image::Film;
use crate::render::ambient::{AmbientCache, AmbientRecord, AmbientStore, Hemisphere};
use crate::render::{check_resolution, RayCounts, RayTask, RenderOptions, Renderer, TraceState};
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

/// How processors treat the cache's data dependency.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum HemisphereMode {
    /// At most one hemisphere in flight per processor; others wait.
    OneAtATime,
    /// Start hemispheres freely; accept (and count) the redundant ones.
    Extra,
}

impl std::str::FromStr for HemisphereMode {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "one" | "one-at-a-time" | "wait" => Ok(HemisphereMode::OneAtATime),
            "extra" | "accept-extra" | "free" => Ok(HemisphereMode::Extra),
            _ => Err(format!(
                "unknown hemisphere mode {s:?}: expected one-at-a-time or extra"
            )),
        }
    }
}

impl std::fmt::Display for HemisphereMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            HemisphereMode::OneAtATime => "one-at-a-time",
            HemisphereMode::Extra => "extra",
        })
    }
}

/// Options of [`render_ambient_parallel`].
#[derive(Clone, Debug, Serialize)]
pub struct AmbientParallelOptions {
    pub procs: usize,
    pub mode: HemisphereMode,
    /// Side of the square screen tiles, in pixels.
    pub tile: usize,
}

/// What a parallel inter-reflection render did.
#[derive(Debug, Serialize)]
pub struct AmbientParallelReport {
    #[serde(skip)]
    pub film: Film,
    pub options: AmbientParallelOptions,
    /// Wall-clock seconds of the pixel loop.
    pub render_s: f64,
    /// First-level hemispheres sampled as data-parallel tasks.
    pub hemispheres: u64,
    /// Of those, hemispheres a record stored meanwhile would have answered.
    pub redundant: u64,
    /// Hemisphere rays run as data-parallel tasks (first level only).
    pub hemisphere_tasks: u64,
    /// Pixels traced again after their hemisphere was cached.
    pub retraced_pixels: u64,
    /// Times a processor waited for its own hemisphere (one-at-a-time).
    pub waits: u64,
    /// Seconds processors spent idle (summed over processors).
    pub idle_s: f64,
    /// Records in the cache at the end.
    pub records: usize,
    /// The records this render added (after the `initial` ones).
    #[serde(skip)]
    pub new_records: Vec<AmbientRecord>,
    /// Rays by kind over all processors (retraced pixels included).
    pub rays: RayCounts,
    /// The effects the render simulated, and why.
    pub effects: crate::render::EffectsReport,
}

/// A first-level hemisphere in flight.
struct Slot {
    owner: usize,
    /// Cache size when it started: records from here on were made meanwhile.
    started_at: usize,
    state: Mutex<SlotState>,
    done: AtomicBool,
}

struct SlotState {
    hemisphere: Hemisphere,
    outstanding: usize,
    second_pass_done: bool,
}

struct DpTask {
    slot: Arc<Slot>,
    div: usize,
    task: RayTask,
}

struct Shared<'r, 's> {
    renderer: &'r Renderer<'s>,
    view: &'r View,
    width: usize,
    height: usize,
    tile: usize,
    tiles_x: usize,
    tiles: usize,
    next_tile: AtomicUsize,
    cache: Arc<RwLock<AmbientCache>>,
    queue: Mutex<VecDeque<DpTask>>,
    wake: Condvar,
    in_flight: AtomicUsize,
    hemispheres: AtomicU64,
    redundant: AtomicU64,
    tasks: AtomicU64,
    /// Finished pixels, for a progress display.
    progress: Option<Arc<AtomicU64>>,
}

impl Shared<'_, '_> {
    fn push_tasks(&self, slot: &Arc<Slot>, tasks: Vec<(usize, RayTask)>) {
        let mut q = self.queue.lock().unwrap_or_else(|e| e.into_inner());
        for (div, task) in tasks {
            q.push_back(DpTask {
                slot: slot.clone(),
                div,
                task,
            });
        }
        drop(q);
        self.wake.notify_all();
    }

    fn pop_task(&self) -> Option<DpTask> {
        self.queue
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .pop_front()
    }

    /// Runs one hemisphere ray; the last ray of a hemisphere stores its
    /// record (or queues the super-samples first).
    fn run_task(&self, t: DpTask, st: &mut TraceState) {
        let (c, d) = self.renderer.trace(&t.task, st);
        self.tasks.fetch_add(1, Ordering::Relaxed);
        let s = self.renderer.ambient_settings();
        let mut state = t.slot.state.lock().unwrap_or_else(|e| e.into_inner());
        state.hemisphere.add(t.div, c, d);
        state.outstanding -= 1;
        if state.outstanding > 0 {
            return;
        }
        if !state.second_pass_done {
            state.second_pass_done = true;
            let more = state.hemisphere.second_pass(s.super_samples);
            if !more.is_empty() {
                state.outstanding = more.len();
                drop(state);
                self.push_tasks(&t.slot, more);
                return;
            }
        }
        // With a cache (the only case that defers hemispheres) there is
        // always a record.
        let (_, rec) = state.hemisphere.finish(s);
        drop(state);
        if let Some(rec) = rec {
            let mut cache = self.cache.write().unwrap_or_else(|e| e.into_inner());
            if cache.covered_since(
                s,
                rec.point,
                rec.normal,
                rec.level,
                rec.weight,
                t.slot.started_at,
            ) {
                self.redundant.fetch_add(1, Ordering::Relaxed);
            }
            cache.insert(s, rec);
        }
        t.slot.done.store(true, Ordering::Release);
        self.in_flight.fetch_sub(1, Ordering::AcqRel);
        self.wake.notify_all();
    }

    fn cache_len(&self) -> usize {
        self.cache.read().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Starts a first-level hemisphere for processor `p`.
    fn start(&self, p: usize, h: Hemisphere) -> Arc<Slot> {
        let tasks = h.first_pass();
        let slot = Arc::new(Slot {
            owner: p,
            started_at: self.cache_len(),
            state: Mutex::new(SlotState {
                hemisphere: h,
                outstanding: tasks.len(),
                second_pass_done: false,
            }),
            done: AtomicBool::new(false),
        });
        self.hemispheres.fetch_add(1, Ordering::Relaxed);
        self.in_flight.fetch_add(1, Ordering::AcqRel);
        self.push_tasks(&slot, tasks);
        slot
    }
}

/// Per-processor state.
struct Proc {
    id: usize,
    st: TraceState,
    pixels: Vec<(usize, Color)>,
    /// Pixels waiting for a hemisphere, with it.
    parked: Vec<(usize, Arc<Slot>)>,
    /// Pixels of the current tile not yet traced.
    todo: VecDeque<usize>,
    retraced: u64,
    waits: u64,
    idle: Duration,
}

impl Proc {
    /// Traces pixel `i`: `Some(hemisphere)` if it needs one not cached.
    fn trace(&mut self, sh: &Shared, i: usize) -> Option<Hemisphere> {
        let (x, y) = (i % sh.width, i / sh.width);
        self.st.deferred = None;
        let c = sh
            .renderer
            .pixel(sh.view, sh.width, sh.height, x, y, &mut self.st);
        match self.st.deferred.take() {
            Some(h) => Some(*h),
            None => {
                self.pixels.push((i, c));
                if let Some(p) = &sh.progress {
                    p.fetch_add(1, Ordering::Relaxed);
                }
                None
            }
        }
    }

    /// Runs a queued hemisphere ray if there is one, else idles briefly.
    fn help_or_idle(&mut self, sh: &Shared) {
        if let Some(t) = sh.pop_task() {
            sh.run_task(t, &mut self.st);
            return;
        }
        let t0 = Instant::now();
        let q = sh.queue.lock().unwrap_or_else(|e| e.into_inner());
        if q.is_empty() {
            let _ = sh.wake.wait_timeout(q, Duration::from_micros(500));
        }
        self.idle += t0.elapsed();
    }

    fn own_in_flight(&self) -> Option<Arc<Slot>> {
        self.parked
            .iter()
            .map(|(_, s)| s)
            .find(|s| s.owner == self.id && !s.done.load(Ordering::Acquire))
            .cloned()
    }

    /// Handles a miss of pixel `i` that needs `h`.
    fn miss(&mut self, sh: &Shared, mode: HemisphereMode, i: usize, mut h: Hemisphere) {
        loop {
            if mode == HemisphereMode::OneAtATime {
                if let Some(busy) = self.own_in_flight() {
                    // Wait for the hemisphere in flight, then look again.
                    self.waits += 1;
                    while !busy.done.load(Ordering::Acquire) {
                        self.help_or_idle(sh);
                    }
                    self.resume_finished(sh, mode);
                    self.retraced += 1;
                    match self.trace(sh, i) {
                        None => return,
                        Some(again) => {
                            h = again;
                            continue;
                        }
                    }
                }
            }
            let slot = sh.start(self.id, h);
            self.parked.push((i, slot));
            return;
        }
    }

    /// Traces again the parked pixels whose hemisphere is done.
    fn resume_finished(&mut self, sh: &Shared, mode: HemisphereMode) {
        loop {
            let Some(k) = self
                .parked
                .iter()
                .position(|(_, s)| s.done.load(Ordering::Acquire))
            else {
                return;
            };
            let (i, _) = self.parked.swap_remove(k);
            self.retraced += 1;
            if let Some(h) = self.trace(sh, i) {
                self.miss(sh, mode, i, h);
            }
        }
    }

    fn next_pixel(&mut self, sh: &Shared) -> Option<usize> {
        if let Some(i) = self.todo.pop_front() {
            return Some(i);
        }
        let t = sh.next_tile.fetch_add(1, Ordering::Relaxed);
        if t >= sh.tiles {
            return None;
        }
        let (tx, ty) = (t % sh.tiles_x, t / sh.tiles_x);
        for y in ty * sh.tile..((ty + 1) * sh.tile).min(sh.height) {
            for x in tx * sh.tile..((tx + 1) * sh.tile).min(sh.width) {
                self.todo.push_back(y * sh.width + x);
            }
        }
        self.todo.pop_front()
    }

    fn run(&mut self, sh: &Shared, mode: HemisphereMode) {
        loop {
            // Data-parallel work first.
            if let Some(t) = sh.pop_task() {
                sh.run_task(t, &mut self.st);
                continue;
            }
            self.resume_finished(sh, mode);
            if let Some(i) = self.next_pixel(sh) {
                if let Some(h) = self.trace(sh, i) {
                    self.miss(sh, mode, i, h);
                }
                continue;
            }
            // No new pixels: wait for parked ones, help the others.
            if self.parked.is_empty() && sh.in_flight.load(Ordering::Acquire) == 0 {
                return;
            }
            self.help_or_idle(sh);
        }
    }
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
    if opts.tile == 0 {
        return Err(Error::Usage("--tile must be at least 1".into()));
    }
    let renderer = Renderer::with_octree(scene, options, &OctreeParams::default())?;
    let tiles_x = width.div_ceil(opts.tile);
    let tiles_y = height.div_ceil(opts.tile);
    let mut start = AmbientCache::default();
    for r in initial {
        start.insert(renderer.ambient_settings(), *r);
    }
    let loaded = start.len();
    let cache = Arc::new(RwLock::new(start));
    let sh = Shared {
        renderer: &renderer,
        view,
        width,
        height,
        tile: opts.tile,
        tiles_x,
        tiles: tiles_x * tiles_y,
        next_tile: AtomicUsize::new(0),
        cache: cache.clone(),
        queue: Mutex::new(VecDeque::new()),
        wake: Condvar::new(),
        in_flight: AtomicUsize::new(0),
        hemispheres: AtomicU64::new(0),
        redundant: AtomicU64::new(0),
        tasks: AtomicU64::new(0),
        progress,
    };
    let caching = renderer.ambient_settings().accuracy > 0.0;
    let t0 = Instant::now();
    let procs: Vec<Proc> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..opts.procs)
            .map(|id| {
                let sh = &sh;
                let cache = cache.clone();
                let mode = opts.mode;
                scope.spawn(move || {
                    let mut st = TraceState::with_store(AmbientStore::Shared(cache));
                    // Without a cache (-aa 0) a parked pixel would never
                    // find its record: hemispheres are then sampled inline.
                    st.defer_hemispheres = caching;
                    let mut p = Proc {
                        id,
                        st,
                        pixels: Vec::new(),
                        parked: Vec::new(),
                        todo: VecDeque::new(),
                        retraced: 0,
                        waits: 0,
                        idle: Duration::ZERO,
                    };
                    p.run(sh, mode);
                    p
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join())
            .collect::<std::result::Result<Vec<_>, _>>()
    })
    .map_err(|_| Error::Other("a render thread panicked".into()))?;
    let render_s = t0.elapsed().as_secs_f64();
    let mut film = Film::new(width, height);
    let mut seen = vec![false; width * height];
    let mut rays = RayCounts::default();
    let (mut retraced, mut waits, mut idle) = (0, 0, Duration::ZERO);
    for p in &procs {
        for &(i, c) in &p.pixels {
            if std::mem::replace(&mut seen[i], true) {
                return Err(Error::Other(format!("pixel {i} rendered twice")));
            }
            film.set(i % width, i / width, c);
        }
        rays.add(&p.st.counts);
        retraced += p.retraced;
        waits += p.waits;
        idle += p.idle;
    }
    if let Some(i) = seen.iter().position(|s| !s) {
        return Err(Error::Other(format!("pixel {i} was never rendered")));
    }
    // -ps > 1: every pixel was traced; keep the adaptive sampler's picture.
    let o = renderer.options();
    if o.ps > 1 {
        film = crate::render::adaptive::resample(&film, o.ps, o.pt);
    }
    let (records, new_records) = {
        let c = cache.read().unwrap_or_else(|e| e.into_inner());
        (c.len(), c.records()[loaded.min(c.len())..].to_vec())
    };
    Ok(AmbientParallelReport {
        film,
        options: opts.clone(),
        render_s,
        hemispheres: sh.hemispheres.load(Ordering::Relaxed),
        redundant: sh.redundant.load(Ordering::Relaxed),
        hemisphere_tasks: sh.tasks.load(Ordering::Relaxed),
        retraced_pixels: retraced,
        waits,
        idle_s: idle.as_secs_f64(),
        records,
        new_records,
        rays,
        effects: renderer.effects().clone(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_parse() {
        assert_eq!(
            "one-at-a-time".parse::<HemisphereMode>(),
            Ok(HemisphereMode::OneAtATime)
        );
        assert_eq!("extra".parse::<HemisphereMode>(), Ok(HemisphereMode::Extra));
        assert!("both".parse::<HemisphereMode>().is_err());
        assert_eq!(HemisphereMode::Extra.to_string(), "extra");
    }
}
