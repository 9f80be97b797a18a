//! Diffuse inter-reflection on the framework: the same picture as the
//! sequential renderer, bit for bit, for any runtime (threads, the
//! simulator, MPI), number of processors and policy.
//!
//! The irradiance cache makes a pixel depend on the records that exist
//! when its points are shaded (paper, section 4: the cache is a data
//! dependency between tasks). Both renderers therefore shade pixels in the
//! waves of [`crate::render::waves`]: within a wave every pixel reads the
//! cache as it was when the wave began plus the records its own trace
//! makes; between waves the wave's records join the cache in pixel order.
//! Here a wave is one of the framework's *epochs*
//! ([`hybrid_sched::Workload::next_epoch`]): its pixels are root tasks in
//! chunks (at most 16 pixels, about four chunks per processor), handed out
//! demand-driven; each chunk's values and records go to
//! the master; when the wave is over the master feeds them to the waves'
//! state machine ([`Waves`]), which names the next wave, and the wave's
//! records travel to every processor as write-once broadcast data (item
//! `w` holds wave `w`'s records) before any pixel of the next wave is
//! shaded. A processor's cache for wave `w` is the starting records
//! (`-af`) plus the broadcasts `0..w`, in order: the sequential renderer's
//! cache at that wave. Which processor shades a pixel, and when, changes
//! nothing in its value. Without a cache (`-aa 0`) every pixel is
//! independent: one epoch, and the adaptive sampler's picture taken from
//! the full one ([`crate::render::adaptive::resample`], equal to sampling
//! adaptively).
//!
//! The scene is replicated: every processor traces whole ray trees,
//! hemispheres included. Hemisphere rays migrating to the processors that
//! own the cells (a distributed scene) are not done.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use hybrid_sched::serde::{Deserialize, Serialize};
use hybrid_sched::{ByteSize, Ctx, DataView, DpOutcome, Epoch, Placement, Workload};

use super::{run_on, ParallelOptions, RuntimeKind, Work};
use crate::accel::OctreeParams;
use crate::image::Film;
use crate::render::ambient::{AmbientCache, AmbientRecord, AmbientSettings};
use crate::render::waves::Waves;
use crate::render::{check_resolution, RayCounts, RenderOptions, Renderer, TraceState};
use crate::scene::{Color, Scene, View};
use crate::{Error, Result};

/// Most pixels shaded as one task: many enough that handing them out
/// costs little.
const CHUNK: usize = 16;

/// Pixels per task for a wave of `len` pixels on `procs` processors: at
/// most [`CHUNK`], and few enough that every processor gets about four
/// tasks (a wave is a barrier: a coarse wave of 64 pixels in chunks of 16
/// would keep all but four processors waiting).
fn chunk_len(len: usize, procs: usize) -> usize {
    len.div_ceil(4 * procs.max(1)).clamp(1, CHUNK)
}

/// A task: pixels (row-major indices) of one wave.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Pixels {
    pub wave: u32,
    pub pixels: Vec<u32>,
}

impl ByteSize for Pixels {
    fn byte_size(&self) -> usize {
        8 + 4 * self.pixels.len()
    }
}

/// Broadcast data: the records one wave made, in pixel order.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct WaveRecords(pub Vec<AmbientRecord>);

impl ByteSize for WaveRecords {
    fn byte_size(&self) -> usize {
        8 + self.0.len() * std::mem::size_of::<AmbientRecord>()
    }
}

/// A task's result, for the master: each pixel's value and the records
/// its trace made, and the rays it took.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Shaded {
    pub pixels: Vec<(u32, Color, Vec<AmbientRecord>)>,
    pub rays: RayCounts,
}

impl ByteSize for Shaded {
    fn byte_size(&self) -> usize {
        std::mem::size_of::<RayCounts>()
            + self
                .pixels
                .iter()
                .map(|p| 32 + p.2.len() * std::mem::size_of::<AmbientRecord>())
                .sum::<usize>()
    }
}

/// The master's accumulator: the values of the wave running (taken when
/// it ends), and the rays of the whole render.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct WaveAcc {
    pub shaded: std::collections::BTreeMap<u32, (Color, Vec<AmbientRecord>)>,
    /// Pixels shaded twice (none, unless the framework ran a task twice).
    pub duplicates: u64,
    pub rays: RayCounts,
}

/// The waves' bookkeeping, on the master.
struct Driver {
    /// The waves (`None` without a cache).
    waves: Option<Waves>,
    /// The pixels of the wave running.
    current: Vec<u32>,
    /// What went wrong between epochs (a lost pixel), reported after the
    /// run.
    error: Option<String>,
}

/// The workload (see the module documentation).
pub struct AmbientWaves {
    renderer: Renderer<'static>,
    view: View,
    width: usize,
    height: usize,
    settings: AmbientSettings,
    caching: bool,
    /// The cache a wave finds: `.1` holds the starting records and the
    /// broadcasts `0..(.0)`. Shared by a process's processors (a wave's
    /// tasks start only when the previous wave is over, so it only moves
    /// forward).
    frozen: Mutex<(u32, Arc<AmbientCache>)>,
    driver: Mutex<Driver>,
    progress: Option<Arc<AtomicU64>>,
    /// Processors in the run (tasks are sized for them).
    procs: usize,
}

impl AmbientWaves {
    fn new(
        renderer: Renderer<'static>,
        view: View,
        width: usize,
        height: usize,
        initial: Arc<AmbientCache>,
        progress: Option<Arc<AtomicU64>>,
        procs: usize,
    ) -> Self {
        let settings = *renderer.ambient_settings();
        let caching = renderer.caches_ambient();
        let (ps, pt) = (renderer.options().ps, renderer.options().pt);
        let (waves, current) = if caching {
            let mut w = Waves::new(width, height, (ps, pt), settings, initial.clone());
            let first = w.next_wave().unwrap_or_default();
            (Some(w), first)
        } else {
            (None, (0..(width * height) as u32).collect())
        };
        AmbientWaves {
            renderer,
            view,
            width,
            height,
            settings,
            caching,
            frozen: Mutex::new((0, initial)),
            driver: Mutex::new(Driver {
                waves,
                current,
                error: None,
            }),
            progress,
            procs,
        }
    }

    fn chunks(&self, wave: u32, pixels: &[u32]) -> Vec<Pixels> {
        pixels
            .chunks(chunk_len(pixels.len(), self.procs))
            .map(|c| Pixels {
                wave,
                pixels: c.to_vec(),
            })
            .collect()
    }

    /// The cache as wave `wave` found it, from the broadcasts this
    /// processor holds.
    fn cache_for(&self, wave: u32, data: &DataView<'_, Self>) -> Arc<AmbientCache> {
        let mut slot = self.frozen.lock().unwrap_or_else(|e| e.into_inner());
        while slot.0 < wave {
            // Every task of wave `w` runs after the broadcasts 0..w are
            // held (the framework's guarantee, SEMANTICS.md section 10):
            // a missing one is a broken guarantee, not an empty wave, and
            // ends the run rather than shade against the wrong cache.
            let records = data
                .get(&slot.0)
                .unwrap_or_else(|| {
                    panic!(
                        "wave {wave}: the records of wave {} were not broadcast to this processor",
                        slot.0
                    )
                })
                .0
                .clone();
            // Taken out of the slot, so that it is extended in place when
            // no task of an earlier wave still holds it.
            let before = std::mem::take(&mut slot.1);
            slot.1 = AmbientCache::extended(before, &self.settings, records);
            slot.0 += 1;
        }
        slot.1.clone()
    }

    fn shade(&self, t: &Pixels, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let cache = self.caching.then(|| self.cache_for(t.wave, data));
        let mut st = TraceState::default();
        let mut pixels = Vec::with_capacity(t.pixels.len());
        for &i in &t.pixels {
            let i_ = i as usize;
            if let Some(cache) = &cache {
                st.ambient = Renderer::frozen_state(cache);
            }
            let c = self.renderer.pixel(
                &self.view,
                self.width,
                self.height,
                i_ % self.width,
                i_ / self.width,
                &mut st,
            );
            let own = if cache.is_some() {
                st.ambient.take_own()
            } else {
                Vec::new()
            };
            pixels.push((i, c, own));
        }
        // Priced by the simulator's cost model (fitted on the hybrid
        // workload): a shaded point per ray traced, a spawned ray per ray
        // after the primary one, and the shadow bundles. Tracing through
        // the hierarchy charges nothing of its own (the fitted model puts
        // it in the octree walk's leaves and objects, which a replicated
        // scene's hierarchy does not count); at the hybrid workload's
        // prices for the rest, the total comes out about twice the
        // sequential renderer's measured time (EXPERIMENTS.md).
        let r = &st.counts;
        let spawned = r.reflection + r.refraction + r.pass_through + r.ambient;
        for (kind, n) in [
            (Work::Shade, r.primary + spawned),
            (Work::RaysPrimary, r.primary),
            (Work::RaysSpawned, spawned),
            (Work::RaysAmbient, r.ambient),
            (Work::ShadowBundles, r.shadow.bundles),
            (Work::ShadowTested, r.shadow.tested),
        ] {
            if n > 0 {
                ctx.charge(kind, n);
            }
        }
        if let Some(p) = &self.progress {
            p.fetch_add(t.pixels.len() as u64, Ordering::Relaxed);
        }
        ctx.emit_result(
            hybrid_sched::Addr::Master,
            Shaded {
                pixels,
                rays: st.counts,
            },
        );
    }
}

impl Workload for AmbientWaves {
    type DataId = u32;
    type DataItem = WaveRecords;
    type DdTask = Pixels;
    type DpTask = Pixels;
    type Result = Shaded;
    type Accumulator = WaveAcc;
    type Work = Work;

    /// No placed data: the scene is every processor's, and the records
    /// arrive as broadcasts.
    fn placement(&self, _procs: usize) -> Vec<Placement<u32>> {
        Vec::new()
    }

    fn load_partition(&self, _proc: usize, _procs: usize) -> Vec<(u32, WaveRecords)> {
        Vec::new()
    }

    fn root_tasks(&self, _procs: usize) -> Vec<Pixels> {
        let d = self.driver.lock().unwrap_or_else(|e| e.into_inner());
        self.chunks(0, &d.current)
    }

    /// Nothing to fetch: the cache's records are held everywhere.
    fn select_data(&self, _t: &Pixels, _ctx: &mut Ctx<Self>) -> Vec<u32> {
        Vec::new()
    }

    fn execute_dd(&self, t: Pixels, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        self.shade(&t, data, ctx);
    }

    fn to_data_parallel(&self, t: Pixels, ctx: &mut Ctx<Self>) {
        ctx.spawn_dp(t);
    }

    fn route_dp(&self, _t: &Pixels) -> Option<u32> {
        None
    }

    fn execute_dp(
        &self,
        t: Pixels,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<Pixels> {
        self.shade(&t, data, ctx);
        DpOutcome::Finished
    }

    fn merge(&self, acc: &mut WaveAcc, r: Shaded) {
        acc.rays.add(&r.rays);
        for (i, c, own) in r.pixels {
            if acc.shaded.insert(i, (c, own)).is_some() {
                acc.duplicates += 1;
            }
        }
    }

    /// A wave is over: its values and records go to the waves' state
    /// machine; the next wave's pixels are the roots, this wave's records
    /// the broadcast.
    fn next_epoch(&self, ended: usize, acc: &mut WaveAcc) -> Option<Epoch<Self>> {
        let mut d = self.driver.lock().unwrap_or_else(|e| e.into_inner());
        let d = &mut *d;
        let waves = d.waves.as_mut()?;
        let mut results = Vec::with_capacity(d.current.len());
        for i in &d.current {
            let Some(r) = acc.shaded.remove(i) else {
                d.error = Some(format!("wave {ended}: pixel {i} has no value"));
                return None;
            };
            results.push(r);
        }
        // The broadcast is what the wave added to the master's cache, in
        // its order (a processor's insertion keeps and drops the same).
        let before = waves.cache().len();
        waves.wave_done(&d.current, results);
        let made = waves.cache().records()[before..].to_vec();
        let next = waves.next_wave()?;
        d.current = next;
        let wave = u32::try_from(ended + 1).ok()?;
        Some(Epoch {
            roots: self.chunks(wave, &d.current),
            broadcast: vec![(wave - 1, WaveRecords(made))],
        })
    }
}

/// What a parallel inter-reflection render did.
#[derive(Debug, Serialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct AmbientParallelReport {
    #[serde(skip)]
    pub film: Film,
    pub options: ParallelOptions,
    /// Wall-clock seconds of the run.
    pub render_s: f64,
    /// Simulated seconds (runtime `sim` only).
    pub simulated_s: Option<f64>,
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
    /// The framework's statistics (processors, messages, broadcasts).
    pub stats: hybrid_sched::RunStats,
}

/// Renders with diffuse inter-reflection on the runtime and processors of
/// `popts` (see the module documentation), the cache starting from
/// `initial` (records of an earlier render, Radiance's `-af`), counting
/// finished pixels into `progress` while it runs (the picture is the
/// same). `None` on MPI ranks other than 0 (each rank calls it with the
/// same scene and options; rank 0 gets the picture).
#[allow(clippy::too_many_arguments)]
pub fn render_ambient_parallel(
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
    initial: &[AmbientRecord],
    progress: Option<Arc<AtomicU64>>,
) -> Result<Option<AmbientParallelReport>> {
    check_resolution(width, height)?;
    if popts.procs == 0 {
        return Err(Error::Usage("--procs must be at least 1".into()));
    }
    let renderer = Renderer::shared(scene, options, &OctreeParams::default())?;
    let s = *renderer.ambient_settings();
    let (ps, pt) = (renderer.options().ps, renderer.options().pt);
    let mut base = AmbientCache::default();
    for r in initial {
        base.insert(&s, *r);
    }
    let loaded = base.len();
    let wl = Arc::new(AmbientWaves::new(
        renderer,
        view.clone(),
        width,
        height,
        Arc::new(base),
        progress,
        popts.procs,
    ));
    let t0 = Instant::now();
    let mut report = run_on(wl.clone(), popts, None, None)?;
    let render_s = t0.elapsed().as_secs_f64();
    if matches!(report.extras, hybrid_sched::Extras::NotRoot { .. }) {
        return Ok(None);
    }
    let simulated_s =
        (popts.runtime == RuntimeKind::Sim).then_some(report.stats.elapsed_ns as f64 * 1e-9);
    let acc = std::mem::take(&mut report.master);
    let mut d = wl.driver.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(e) = d.error.take() {
        return Err(Error::Other(format!("parallel render lost a result: {e}")));
    }
    if acc.duplicates > 0 {
        return Err(Error::Other(format!(
            "parallel render shaded {} pixels twice",
            acc.duplicates
        )));
    }
    let (film, cache, waves) = match d.waves.take() {
        Some(w) => {
            if !acc.shaded.is_empty() {
                return Err(Error::Other(format!(
                    "parallel render left {} pixels outside its waves",
                    acc.shaded.len()
                )));
            }
            let out = w.finish();
            (out.film, out.cache, out.waves)
        }
        None => {
            let mut full = Film::new(width, height);
            if acc.shaded.len() != width * height {
                return Err(Error::Other(format!(
                    "parallel render shaded {} of {} pixels",
                    acc.shaded.len(),
                    width * height
                )));
            }
            for (&i, (c, _)) in &acc.shaded {
                full.set(i as usize % width, i as usize / width, *c);
            }
            let film = if ps > 1 {
                crate::render::adaptive::resample(&full, ps, pt)
            } else {
                full
            };
            let cache = wl
                .frozen
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .1
                .clone();
            (film, cache, 0)
        }
    };
    let records = cache.len();
    let new_records = cache.records()[loaded.min(records)..].to_vec();
    Ok(Some(AmbientParallelReport {
        film,
        options: popts.clone(),
        render_s,
        simulated_s,
        waves,
        hemispheres: acc.rays.ambient_cache.hemispheres,
        records,
        new_records,
        rays: acc.rays,
        effects: wl.renderer.effects().clone(),
        stats: report.stats,
    }))
}
