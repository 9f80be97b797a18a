//! The hybrid-scheduled parallel renderer: the paper's system as a
//! [`hybrid_sched::Workload`] (see [`workload`] for the mapping of tiles,
//! shadow bundles, migrating rays and cells onto the framework). By concept:
//! [`tasks`] holds everything that travels between processors, [`work`] the
//! kinds of work charged, [`distribution`] and [`partition`] who owns which
//! cell, `selection` and `execute` what a task needs and does, [`records`]
//! what travels to a pixel's owner and [`tree`] how pixels are assembled
//! exactly, [`caster`] restartable shadow bundles, `hemispheres` diffuse
//! inter-reflection's sample rays, `irradiance` and `cursor` the
//! irradiance cache (waves of pixels as epochs, and each pixel's lookups
//! decided in the sequential order), [`cost`] and [`predict`] the
//! simulator's cost model and the predicted distribution.
//!
//! [`render_parallel`] runs it on a chosen runtime and returns the image
//! with the framework's statistics; the image equals the sequential
//! renderer's bit for bit for any number of processors, policy, cache size
//! and distribution.

mod bundle_judge;
pub mod caster;
mod clip_memory;
mod completion;
pub mod cost;
mod cursor;
pub mod distribution;
mod execute;
mod held;
mod hemispheres;
mod irradiance;
mod kernel;
mod options;
pub mod owners;
pub mod partition;
mod picture;
pub mod predict;
pub mod records;
mod runtime;
mod samples;
mod selection;
mod sizes;
pub mod tasks;
pub mod tree;
mod walk;
mod wave_driver;
pub mod work;
pub mod workload;

#[cfg(test)]
mod partition_tests;

use std::sync::Arc;
use std::time::{Duration, Instant};

use hybrid_sched::{Config, DataService, Extras, Network, Policy, RankTraffic, RunStats, Timeline};
use serde::Serialize;

pub use completion::walks_worth_the_rest;
pub use distribution::Distribution;
pub use partition::Partition;
pub use picture::Picture;
#[cfg(feature = "mpi")]
pub use runtime::mpi_world;
pub use runtime::{check_hybrid, hemisphere_tile, hybrid_interreflection};
pub(crate) use runtime::{run_on, this_rank};
pub use sizes::{CacheSize, FetchLimit};
pub use tasks::{CellData, DdTask, DpTask, Item};
pub use wave_driver::WaveSummary;
pub use work::Work;
pub use workload::{RtWorkload, WorkloadOptions, PIXEL_BATCH};

use crate::accel::OctreeParams;
use crate::image::Film;
use crate::render::effects::EffectsReport;
use crate::render::{check_resolution, RenderOptions, Renderer};
use crate::scene::{Scene, View};
use crate::{Error, Result};

/// Which runtime drives the processors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum RuntimeKind {
    /// One tokio task per processor on a thread pool (the default).
    Threads,
    /// The framework's reference: every task on one processor, all data
    /// local, no messages.
    Sequential,
    /// The deterministic simulation of a cluster (virtual time; see
    /// [`ParallelOptions::network`] and [`cost`]).
    Sim,
    /// One processor per MPI rank (`mpirun -np N`; feature `mpi`).
    Mpi,
}

impl std::str::FromStr for RuntimeKind {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "threads" => Ok(RuntimeKind::Threads),
            "sequential" => Ok(RuntimeKind::Sequential),
            "sim" | "simulated" => Ok(RuntimeKind::Sim),
            #[cfg(feature = "mpi")]
            "mpi" => Ok(RuntimeKind::Mpi),
            #[cfg(not(feature = "mpi"))]
            "mpi" => Err(format!(
                "runtime {s:?} is not available in this build (build hybrid-rt with --features mpi)"
            )),
            _ => Err(format!(
                "unknown runtime {s:?}: expected threads, sequential or sim"
            )),
        }
    }
}

/// The renderer's budget of work in flight per processor
/// ([`ParallelOptions::flight_bytes`], `--flight-bytes`): 64 MiB. The
/// framework's default (1 MiB, [`hybrid_sched::config::DEFAULT_FLIGHT_BYTES`],
/// which the simulated experiments keep) narrows each link's byte window to
/// 1 MiB / 2 / processors and held back the conference room's large shadow
/// tasks: at 256x256 on 2 processors (threads) it took 5.0 s against 3.3 s
/// with 64 MiB or no bound, for the same picture.
pub const RENDER_FLIGHT_BYTES: usize = 64 << 20;

/// Everything a parallel render needs besides scene, options and view.
#[derive(Clone, Debug, Serialize)]
pub struct ParallelOptions {
    pub procs: usize,
    pub runtime: RuntimeKind,
    pub policy: Policy,
    pub cache: CacheSize,
    /// Most data one demand-driven task may have fetched; unlimited (the
    /// paper's scheduler) unless set: `render` uses [`FetchLimit::Auto`].
    pub fetch_limit: FetchLimit,
    /// Completing the cache after this percentage of the data held
    /// elsewhere is fetched ([`hybrid_sched::Config::complete_cache`]);
    /// `None` (the paper's cache) unless set: `render` sets 50.
    pub complete_cache: Option<u8>,
    /// When data requests are answered
    /// ([`hybrid_sched::Config::data_service`]); between steps (the
    /// paper's) unless set: `render` answers on arrival.
    pub data_service: DataService,
    pub workload: WorkloadOptions,
    /// Worker threads for the threads runtime (`None`: one per core).
    pub threads: Option<usize>,
    /// Give up (with an error) after this long.
    pub time_limit: Option<Duration>,
    /// The simulated machine (runtime `sim` only).
    pub network: Network,
    /// Seed of the simulation's latency jitter.
    pub sim_seed: u64,
    /// Flow control: credits per link (see [`hybrid_sched::Config`]).
    pub credits: usize,
    /// Flow control in bytes: work in flight per processor, input buffer
    /// plus send backlog (see [`hybrid_sched::Config::flight_bytes`]).
    pub flight_bytes: usize,
    /// Ask for the next tile when starting one (see
    /// [`hybrid_sched::Config::prefetch_work`]); `false`: the paper's
    /// ask-when-idle.
    pub prefetch_work: bool,
    /// With an irradiance cache, the records it starts from (an ambient
    /// file's, `-af`).
    #[serde(skip)]
    pub ambient_records: Arc<Vec<crate::render::ambient::AmbientRecord>>,
}

impl ParallelOptions {
    /// The workload's options as this runtime runs them: the simulator
    /// prices the octree walk leaf by leaf, so it runs without
    /// [`WorkloadOptions::local_kernel`].
    pub fn workload_options(&self) -> WorkloadOptions {
        let mut w = self.workload;
        if self.runtime == RuntimeKind::Sim {
            w.local_kernel = false;
        }
        w
    }

    pub fn new(procs: usize) -> Self {
        ParallelOptions {
            procs,
            runtime: RuntimeKind::Threads,
            policy: Policy::Local,
            cache: CacheSize::Unlimited,
            fetch_limit: FetchLimit::Size(CacheSize::Unlimited),
            complete_cache: None,
            data_service: DataService::BetweenSteps,
            workload: WorkloadOptions::default(),
            threads: None,
            time_limit: None,
            network: Network::ten_gbe(),
            sim_seed: 0,
            credits: Config::new(1).credits_per_link,
            flight_bytes: RENDER_FLIGHT_BYTES,
            prefetch_work: Config::new(1).prefetch_work,
            ambient_records: Arc::default(),
        }
    }
}

/// Per-processor figures of a parallel render.
#[derive(Clone, Debug, Serialize)]
pub struct ProcSummary {
    /// Bytes of objects resident (owned) on this processor.
    pub resident_bytes: u64,
    /// Objects resident.
    pub resident_objects: usize,
    /// Bytes of this processor's copies of its resident objects (one copy
    /// per object, however many of its leaves list it), measured from the
    /// copies' structures; 0 when replicated (processors share the scene).
    pub copy_bytes: u64,
    /// Bytes of the processor's own hierarchies at the end of the run: the
    /// one over its resident objects and the one grown over its cache (the
    /// copies they share with its leaves not counted); 0 where it uses the
    /// whole scene's or has none; `None` where another MPI rank built it.
    pub hierarchy_bytes: Option<u64>,
    /// Share of the octree's object references assigned here.
    pub cost: u64,
    /// Pixels assembled here.
    pub pixels: usize,
    /// Of those, the pixels sent to the master in batches during the run
    /// ([`WorkloadOptions::pixel_batch`]); the rest stayed here to the end.
    pub pixels_sent: usize,
    /// Most ray-tree nodes held at once while assembling pixels.
    pub peak_tree_nodes: usize,
    /// False for a processor of another MPI rank holding part of a
    /// distributed scene, whose objects this rank never saw:
    /// `resident_bytes` is then its cells' accounted bytes, and
    /// `copy_bytes` is not known here (0).
    pub measured: bool,
}

/// The outcome of [`render_parallel`].
#[derive(Debug, Serialize)]
pub struct ParallelRender {
    #[serde(skip)]
    pub film: Film,
    pub options: ParallelOptions,
    /// Cache budget in bytes per processor (`None`: unlimited).
    pub cache_bytes: Option<u64>,
    /// Most cell data one demand-driven task could have fetched for it,
    /// in bytes (`None`: no limit).
    pub fetch_limit_bytes: Option<u64>,
    /// Total cell data of the scene.
    pub data_bytes: u64,
    /// Heap bytes of the octree the run traced, as built
    /// ([`crate::accel::Octree::memory_bytes`]): replicated, every processor
    /// holds one.
    pub octree_bytes: u64,
    pub procs: Vec<ProcSummary>,
    /// The framework's statistics (times per state, traffic, tasks, cache,
    /// memory high-water marks, counted work).
    pub stats: RunStats,
    /// Wall-clock seconds of the run (after set-up).
    pub render_s: f64,
    /// Seconds to build the octree and the partition.
    pub setup_s: f64,
    /// Simulated seconds (runtime `sim`; the statistics' times are virtual
    /// too).
    pub simulated_s: Option<f64>,
    /// The effects the render simulated, and why.
    pub effects: EffectsReport,
    /// Per-state time line of every actor (runtime `sim`).
    #[serde(skip)]
    pub timeline: Option<Timeline>,
    /// Peak resident memory of this process as the operating system
    /// measured it after the run (`None` where it does not say): every
    /// processor of a run in one process together; under MPI, rank 0's
    /// (each rank's is in [`ParallelRender::ranks`]).
    pub peak_resident_bytes: Option<u64>,
    /// MPI runtime: what each rank put on and took off the wire (index =
    /// rank); empty for the other runtimes.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub ranks: Vec<RankTraffic>,
    /// With an irradiance cache, what it did (`irradiance.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ambient: Option<WaveSummary>,
}

impl ParallelRender {
    /// A counted work total over all processors (see [`Work`]).
    pub fn work(&self, kind: Work) -> u64 {
        self.stats
            .procs
            .iter()
            .map(|p| p.work.get(kind.name()).copied().unwrap_or(0))
            .sum()
    }
}

/// Renders `view` at `width` x `height` with the hybrid scheduler.
///
/// Under [`RuntimeKind::Mpi`] only rank 0 has the picture: there, use
/// [`render_parallel_ranked`].
pub fn render_parallel(
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
) -> Result<ParallelRender> {
    render_parallel_ranked(scene, options, view, width, height, popts)?.ok_or_else(|| {
        Error::Other("this MPI rank is not rank 0: only rank 0 has the picture".into())
    })
}

/// [`render_parallel`] for any runtime: `None` on MPI ranks other than 0
/// (each rank calls it with the same scene and options; rank 0 gets the
/// whole picture and every processor's statistics).
pub fn render_parallel_ranked(
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
) -> Result<Option<ParallelRender>> {
    render_parallel_with_progress(scene, options, view, width, height, popts, None)
}

/// [`render_parallel_ranked`] counting finished pixels into `progress`
/// while it runs (on this rank's processors; the picture is the same).
pub fn render_parallel_with_progress(
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
    progress: Option<Arc<std::sync::atomic::AtomicU64>>,
) -> Result<Option<ParallelRender>> {
    check_resolution(width, height)?;
    if popts.procs == 0 {
        return Err(Error::Usage("--procs must be at least 1".into()));
    }
    let t0 = Instant::now();
    let replicated = popts.workload.distribution == Distribution::Replicated;
    // Only the replicated distribution traces through the hierarchy.
    let renderer = if replicated {
        Renderer::shared(scene, options, &OctreeParams::default())?
    } else {
        Renderer::shared_lazy_bvh(scene, options, &OctreeParams::default())?
    };
    check_hybrid(&renderer)?;
    let wl = RtWorkload::new(
        renderer,
        view.clone(),
        width,
        height,
        popts.procs,
        popts.workload_options(),
    );
    run_workload(wl, popts, progress, t0)
}

/// [`render_parallel_with_progress`] for a distributed compiled scene: the
/// replicated part and the octree skeleton in `part`
/// ([`crate::compiled::CompiledScene::held_part`]), each processor reading
/// only its own cells (under MPI, this rank's processor; in one process,
/// every processor its own). The picture equals the sequential render of
/// the scene loaded whole. A processor that cannot read its part fails the
/// render before it starts, saying which part and why.
pub fn render_parallel_held(
    part: crate::compiled::HeldPart,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
    progress: Option<Arc<std::sync::atomic::AtomicU64>>,
) -> Result<Option<ParallelRender>> {
    check_resolution(width, height)?;
    if popts.procs == 0 {
        return Err(Error::Usage("--procs must be at least 1".into()));
    }
    let t0 = Instant::now();
    tracing::debug!(
        peak_kib = crate::report::peak_resident_bytes().map(|b| b / 1024),
        rss_kib = crate::report::resident_bytes().map(|b| b / 1024),
        "replicated part and skeleton read"
    );
    let predicted = (popts.workload.distribution == Distribution::Predicted)
        .then(|| part.predicted_costs(view))
        .transpose()?;
    let crate::compiled::HeldPart {
        scene,
        octree,
        source,
        predicted: stored,
    } = part;
    drop(stored);
    let renderer = Renderer::with_skeleton(Arc::new(scene), options, octree)?;
    check_hybrid(&renderer)?;
    let wl = RtWorkload::distributed(
        renderer,
        view.clone(),
        width,
        height,
        popts.procs,
        popts.workload_options(),
        source,
        predicted,
    )?;
    let wl = if popts.runtime == RuntimeKind::Mpi {
        wl.sharing_copies_in_process()
    } else {
        wl
    };
    match popts.runtime {
        RuntimeKind::Mpi => wl.read_part(this_rank()?)?,
        _ => wl.read_parts(popts.procs)?,
    }
    wl.parts_read();
    tracing::debug!(
        peak_kib = crate::report::peak_resident_bytes().map(|b| b / 1024),
        rss_kib = crate::report::resident_bytes().map(|b| b / 1024),
        octree_kib = wl.renderer().octree().memory_bytes() / 1024,
        cell_table_kib = wl.cells.memory_bytes() / 1024,
        partition_kib = wl.partition().memory_bytes() / 1024,
        "cells read"
    );
    run_workload(wl, popts, progress, t0)
}

/// Runs a workload and assembles the picture and the report.
fn run_workload(
    wl: RtWorkload,
    popts: &ParallelOptions,
    progress: Option<Arc<std::sync::atomic::AtomicU64>>,
    t0: Instant,
) -> Result<Option<ParallelRender>> {
    let (width, height) = (wl.width, wl.height);
    let replicated = popts.workload.distribution == Distribution::Replicated;
    let wl = match progress {
        Some(p) => wl.with_progress(p),
        None => wl,
    };
    let wl = match popts.ambient_records.is_empty() {
        true => wl,
        false => wl.with_ambient_records(&popts.ambient_records),
    };
    // One processor per process: the copies a rank receives share the
    // ones it holds.
    let wl = if popts.runtime == RuntimeKind::Mpi {
        wl.sharing_copies_in_process()
    } else {
        wl
    };
    let data_bytes = wl.data_bytes();
    let cache_bytes = popts.cache.resolve(data_bytes);
    let wl = Arc::new(wl);
    let setup_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let fetch_limit = popts.fetch_limit.resolve(data_bytes, cache_bytes);
    let mut report = run_on(wl.clone(), popts, cache_bytes, fetch_limit)?;
    let (timeline, ranks) = match std::mem::take(&mut report.extras) {
        Extras::None => (None, Vec::new()),
        Extras::Timeline(t) => (Some(t), Vec::new()),
        Extras::Ranks(ranks) => (None, ranks),
        // Another MPI rank: rank 0 has the picture.
        Extras::NotRoot { .. } => return Ok(None),
    };
    let simulated_s =
        (popts.runtime == RuntimeKind::Sim).then_some(report.stats.elapsed_ns as f64 * 1e-9);
    let render_s = t1.elapsed().as_secs_f64();
    let waves = wl.finish_waves(&mut report.master).transpose()?;

    // The batches processors sent (`WorkloadOptions::pixel_batch`), in
    // place at the master; the rest joins them here.
    if report.master.pending() != 0 {
        return Err(Error::Other(
            "parallel render sent ray-tree records to the master".into(),
        ));
    }
    let mut picture = report
        .master
        .picture
        .take()
        .unwrap_or_else(|| Picture::new(width * height));
    for &(pixel, c) in &report.master.pixels {
        picture.place(pixel, c);
    }
    let mut procs = Vec::with_capacity(popts.procs);
    for (p, acc) in report.procs.iter().enumerate() {
        if acc.pending() != 0 {
            return Err(Error::Other(format!(
                "parallel render lost results: processor {p} still waits for {} ray-tree nodes",
                acc.pending()
            )));
        }
        for &(pixel, c) in &acc.pixels {
            picture.place(pixel, c);
        }
        tracing::debug!(
            proc = p,
            pixels = acc.finished(),
            peak_tree_nodes = acc.peak_pending,
            "processor finished"
        );
        let part = wl.partition();
        let resident = part.resident_objects().get(p).copied().unwrap_or(0);
        if let Some((resident_bytes, copy_bytes)) = wl.held_figures(p) {
            procs.push(ProcSummary {
                resident_bytes,
                resident_objects: resident,
                copy_bytes,
                hierarchy_bytes: wl.hierarchy_bytes(p),
                cost: part.cost().get(p).copied().unwrap_or(0),
                pixels: acc.finished(),
                pixels_sent: acc.shipped,
                peak_tree_nodes: acc.peak_pending,
                measured: true,
            });
            continue;
        }
        let elsewhere = wl.held.is_some();
        procs.push(ProcSummary {
            // Replicated: every processor reads the whole scene.
            resident_bytes: if replicated {
                data_bytes
            } else if elsewhere {
                wl.accounted_share(p)
            } else {
                part.resident_bytes().get(p).copied().unwrap_or(0) as u64
            },
            resident_objects: if replicated {
                wl.renderer().scene().objects.len()
            } else {
                resident
            },
            // Another MPI rank's processor of a distributed scene: measured
            // there, not here.
            copy_bytes: if replicated || elsewhere || wl.reads_the_scene(report.procs.len()) {
                0
            } else {
                part.copy_bytes().get(p).copied().unwrap_or(0)
            },
            hierarchy_bytes: wl.hierarchy_bytes(p),
            cost: part.cost().get(p).copied().unwrap_or(0),
            pixels: acc.finished(),
            pixels_sent: acc.shipped,
            peak_tree_nodes: acc.peak_pending,
            measured: !elsewhere,
        });
    }
    if let Some(i) = picture.fault() {
        return Err(Error::Other(format!(
            "parallel render produced pixel {i} twice or out of range"
        )));
    }
    let (film, ambient) = match waves {
        // With a cache, the waves' picture (adaptive sampling included).
        Some((film, summary)) => (film, Some(summary)),
        None => {
            let Some(mut film) = picture.into_film(width, height) else {
                return Err(Error::Other(format!(
                    "parallel render's picture is not {width} x {height} pixels"
                )));
            };
            // -ps > 1: replicated tiles sample adaptively; the other
            // distributions traced every pixel (a tile's pixels finish out
            // of order), and keep the adaptive sampler's picture of them,
            // equal to the sequential one.
            let o = wl.renderer().options();
            if o.ps > 1 && !replicated {
                film = crate::render::adaptive::resample(&film, o.ps, o.pt);
            }
            (film, None)
        }
    };
    Ok(Some(ParallelRender {
        effects: wl.renderer().effects().clone(),
        film,
        options: popts.clone(),
        cache_bytes,
        fetch_limit_bytes: fetch_limit,
        data_bytes,
        octree_bytes: wl.renderer().octree().memory_bytes() as u64,
        procs,
        stats: report.stats,
        render_s,
        setup_s,
        simulated_s,
        timeline,
        peak_resident_bytes: hybrid_sched::stats::peak_resident_bytes(),
        ranks,
        ambient,
    }))
}
