//! The ray tracer as a [`Workload`] of the hybrid scheduling framework.
//!
//! * **Data**: one item per non-empty octree leaf (its objects). Every
//!   processor holds the whole octree skeleton (cells and object lists);
//!   the objects of a leaf may be read only where the leaf is resident or
//!   cached. The [`Partition`] says who owns which leaf.
//! * **Demand-driven tasks**: screen tiles (root tasks, handed out by the
//!   master) and shadow bundles (one shaded point and one light source).
//!   Data selection clips a pyramid around the bundle against the octree;
//!   the leaves it selects are fetched (one request per owner) into the
//!   cache, and the task runs where it was scheduled.
//! * **Data-parallel tasks**: reflected, refracted and passed-through rays,
//!   and shadow bundles too small to be worth clipping. They run as far as
//!   the local cells allow, then migrate to the owner of the next cell the
//!   ray needs, carrying their traversal state; shading happens where the
//!   intersection is found.
//! * **Results**: each node of a pixel's ray tree is sent to the processor
//!   that rendered the pixel's tile, which assembles the pixel exactly as
//!   the sequential renderer computes it (see [`super::tree`]).
//!
//! A task whose data selection turns out to have missed a cell (it cannot
//! happen if clipping is conservative, which is tested, but floating point
//! is floating point) does not fail or read what it must not: the ray or
//! bundle continues data-parallel from where it stopped, and the event is
//! counted as `clip.misses`.

use rustc_hash::FxHashSet;
use std::sync::{Arc, Mutex};

use hybrid_sched::{Addr, Ctx, DataView, DpOutcome, Epoch, Placement, Workload};

use super::caster::Replay;
use super::distribution::{partition_for, subtree_owners, Distribution};
use super::partition::{object_bytes, Partition};
use super::tasks::{CellData, DdTask, DpTask, Item, RayJob, ShadowDp};
use super::tree::{PixelTrees, Record, RtResult};
use super::work::Work;
use crate::accel::{CellTable, LeafObjects, NodeId, ObjectCopies, TraceCursor};
use crate::render::Renderer;
use crate::scene::View;

pub use super::options::{WorkloadOptions, PIXEL_BATCH};

/// The parallel ray tracer (see the module documentation).
#[derive(Debug)]
pub struct RtWorkload {
    pub(super) renderer: Renderer<'static>,
    pub(super) view: View,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) opts: WorkloadOptions,
    /// Non-empty leaves with their data size ([`Workload::locate`]).
    pub(super) cells: Arc<CellTable>,
    pub(super) partition: Partition,
    /// Per node: the one processor owning every non-empty leaf below it,
    /// see [`super::distribution::subtree_owners`].
    pub(super) subtree_owner: super::owners::NodeOwners,
    /// Per processor (so they do not contend), its shadow selections and
    /// the subtrees it holds whole (option `clip_cache`).
    pub(super) clip_cache: Vec<Mutex<super::clip_memory::ClipCache>>,
    /// Primary rays a tile's selection computed (views whose tiles have no
    /// bounding pyramid), per processor, for its execution to take: each
    /// primary ray is computed once.
    pub(super) tile_rays: Vec<Mutex<TileRays>>,
    /// Finished pixels, counted for a progress display (see
    /// [`RtWorkload::with_progress`]).
    pub(super) progress: Option<Arc<std::sync::atomic::AtomicU64>>,
    /// See [`RtWorkload::sharing_copies_in_process`].
    pub(super) share_in_process: bool,
    /// Per processor, its hierarchy (option `local_kernel`).
    pub(super) kernels: Vec<std::sync::OnceLock<crate::accel::ProcessorKernel>>,
    /// Per processor, its hierarchy grown over its cache (see [`super::kernel`]).
    pub(super) grown: Vec<crate::accel::Grown>,
    /// [`super::walks_worth_the_rest`] for this scene (worked out once).
    pub(super) rest_worth: std::sync::OnceLock<u64>,
    /// A distributed compiled scene: the renderer holds its replicated
    /// part, each processor reads its cells ([`RtWorkload::distributed`]).
    pub(super) held: Option<Held>,
    /// With an irradiance cache, its waves (`irradiance.rs`).
    pub(super) irradiance: Option<super::wave_driver::Irradiance>,
}

/// A processor's cells as it loads them.
type Part = Vec<(NodeId, CellData)>;

/// Where the processors of a distributed compiled scene read their cells,
/// and what they read.
#[derive(Debug)]
pub(super) struct Held {
    /// Where the cells are read from, until every processor of this
    /// process has read its part ([`RtWorkload::parts_read`]); processors
    /// read their parts at the same time.
    pub(super) source: std::sync::RwLock<Option<crate::compiled::CellSource>>,
    /// Per processor, its cells as read before the run
    /// ([`RtWorkload::read_part`]), until its processor starts.
    pub(super) parts: Vec<Mutex<Option<Part>>>,
    /// Per processor: its resident objects' bytes ([`super::Partition`]'s
    /// count for a scene loaded whole), its copies' bytes and count.
    pub(super) figures: Vec<Mutex<Option<(u64, u64, u64)>>>,
    /// The average bytes of a copy read here ([`RtWorkload::held_charge`]).
    pub(super) per_copy: std::sync::OnceLock<u64>,
}

/// A tile's primary rays by its top-left pixel, row by row (`None`: the
/// view has no ray through that pixel).
pub(super) type TileRays = hybrid_sched::IdMap<(u32, u32), Vec<Option<crate::render::RayTask>>>;

impl RtWorkload {
    /// Makes every processor offer its resident copies to the leaves this
    /// process receives ([`crate::accel::share_copies_in_process`]): for
    /// runtimes with one processor per process (MPI).
    pub fn sharing_copies_in_process(mut self) -> Self {
        self.share_in_process = true;
        self
    }

    /// Counts finished pixels into `counter` as processors assemble them
    /// (what is computed does not change).
    pub fn with_progress(mut self, counter: Arc<std::sync::atomic::AtomicU64>) -> Self {
        self.progress = Some(counter);
        self
    }

    /// With an irradiance cache, the render starts from `records` (an
    /// ambient file's, Radiance's `-af`) instead of none.
    pub fn with_ambient_records(
        mut self,
        records: &[crate::render::ambient::AmbientRecord],
    ) -> Self {
        let procs = self.partition.procs() as usize;
        self.irradiance = super::wave_driver::Irradiance::new(
            &self.renderer,
            self.width,
            self.height,
            procs,
            records,
        );
        self
    }

    /// A workload rendering `view` at `width` x `height` on `procs`
    /// processors.
    pub fn new(
        renderer: Renderer<'static>,
        view: View,
        width: usize,
        height: usize,
        procs: usize,
        opts: WorkloadOptions,
    ) -> Self {
        let cells = Self::cells_of(&renderer);
        Self::assemble(
            renderer, view, width, height, procs, opts, cells, None, None,
        )
    }

    /// Non-empty leaves with their accounted bytes.
    fn cells_of(renderer: &Renderer<'static>) -> Arc<CellTable> {
        let octree = renderer.octree();
        let objects = &renderer.scene().objects;
        // An object listed in n leaves is stored once where they are held
        // together: each of its leaves accounts for 1/n of its bytes, so the
        // cells sum to the scene's size and cache budgets mean what they say.
        let mut listed = vec![0u32; objects.len()];
        for leaf in octree.leaves() {
            for &o in octree.leaf_objects(leaf) {
                listed[o as usize] += 1;
            }
        }
        let cells = octree.leaves().filter_map(|leaf| {
            let ids = octree.leaf_objects(leaf);
            (!ids.is_empty()).then(|| {
                let bytes: usize = ids
                    .iter()
                    .map(|&o| {
                        let n = listed[o as usize].max(1) as usize;
                        object_bytes(&objects[o as usize]).div_ceil(n) + 4
                    })
                    .sum();
                (leaf, bytes as u64)
            })
        });
        Arc::new(CellTable::new(cells))
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn assemble(
        renderer: Renderer<'static>,
        view: View,
        width: usize,
        height: usize,
        procs: usize,
        opts: WorkloadOptions,
        cells: Arc<CellTable>,
        held: Option<Held>,
        predicted: Option<Vec<u64>>,
    ) -> Self {
        let predicted = match predicted {
            Some(p) => p,
            None if opts.distribution == Distribution::Predicted => {
                super::predict::subtree_costs(&renderer, &view, width, height)
            }
            None => Vec::new(),
        };
        let partition = partition_for(&renderer, opts.distribution, procs, &predicted);
        let subtree_owner = super::owners::NodeOwners::new(subtree_owners(&renderer, &partition));
        let irradiance = super::wave_driver::Irradiance::new(&renderer, width, height, procs, &[]);
        RtWorkload {
            irradiance,
            subtree_owner,
            clip_cache: (0..procs.max(1))
                .map(|_| Mutex::new(Default::default()))
                .collect(),
            tile_rays: (0..procs.max(1))
                .map(|_| Mutex::new(Default::default()))
                .collect(),
            kernels: (0..procs.max(1)).map(|_| Default::default()).collect(),
            grown: (0..procs.max(1)).map(|_| Default::default()).collect(),
            rest_worth: Default::default(),
            renderer,
            view,
            width,
            height,
            opts: WorkloadOptions {
                tile: opts.tile.max(1),
                ..opts
            },
            cells,
            partition,
            progress: None,
            share_in_process: false,
            held,
        }
    }

    pub fn renderer(&self) -> &Renderer<'static> {
        &self.renderer
    }

    /// The data distribution for the configured processor count.
    pub fn partition(&self) -> &Partition {
        &self.partition
    }

    /// Total bytes of all cell data (about the scene's object bytes plus
    /// the leaves' object lists).
    pub fn data_bytes(&self) -> u64 {
        self.cells.total_bytes()
    }

    /// The largest data set one task can need: every cell (used to size a
    /// cache that is "smaller than one task's data").
    pub fn largest_cell_bytes(&self) -> u64 {
        self.cells.largest_bytes()
    }

    /// [`Distribution::Replicated`]: every leaf is local everywhere.
    #[inline]
    pub(super) fn replicated(&self) -> bool {
        self.opts.distribution == Distribution::Replicated
    }

    /// Leaves as data items: (leaf, owner, bytes); none when replicated.
    /// An iterator, not a list: it has an entry per leaf of the whole scene
    /// (24 bytes each), and its callers keep a processor's part of it or
    /// turn it into the directory.
    pub(super) fn owner_table(&self) -> impl Iterator<Item = (NodeId, usize, u64)> + '_ {
        let part = &self.partition;
        let n = if self.replicated() {
            0
        } else {
            self.cells.len()
        };
        self.cells
            .iter()
            .take(n)
            .map(move |(leaf, bytes)| (leaf, part.owner(leaf) as usize, bytes))
    }

    /// `leaf`'s objects as this processor holds them (resident or cached),
    /// what tracing reads; `None` if they are held elsewhere. (Under the
    /// replicated distribution tiles are traced whole from the shared
    /// scene and never come here.)
    #[inline]
    pub(super) fn cell<'v>(view: &DataView<'v, Self>, leaf: NodeId) -> Option<&'v LeafObjects> {
        view.get(&leaf).and_then(Item::cell)
    }

    /// Whether `leaf`'s objects are held on processor `proc`: resident by
    /// the partition (an array lookup) or in the view (cached, or resident
    /// under a runtime that holds everything locally), without touching
    /// the leaf's cache recency.
    pub(super) fn held(&self, view: &DataView<'_, Self>, proc: usize, leaf: NodeId) -> bool {
        self.owned(proc, leaf) || view.is_local(&leaf)
    }

    /// Whether `leaf` is resident on processor `proc` without
    /// asking a view: everything is when replicated, else the partition's
    /// owner (an array lookup).
    #[inline]
    pub(super) fn owned(&self, proc: usize, leaf: NodeId) -> bool {
        self.replicated() || self.partition.owner(leaf) as usize == proc
    }

    /// The non-empty leaves among `leaves`, each once, in order.
    pub(super) fn nonempty(&self, leaves: impl IntoIterator<Item = NodeId>) -> Vec<NodeId> {
        let octree = self.renderer.octree();
        let mut seen = FxHashSet::default();
        leaves
            .into_iter()
            .filter(|&l| !octree.leaf_objects(l).is_empty() && seen.insert(l))
            .collect()
    }
}
impl Workload for RtWorkload {
    type DataId = NodeId;
    type DataItem = Item;
    type DdTask = DdTask;
    type DpTask = DpTask;
    type Result = RtResult;
    type Accumulator = PixelTrees;
    type Work = Work;

    /// The partition is balanced for the count the workload is built for
    /// ([`RtWorkload::new`]'s `procs`); the framework refuses a run with
    /// another count before any hook runs, so the start-up hooks below
    /// need not look at theirs.
    fn laid_out_for(&self) -> Option<usize> {
        Some(self.partition.procs() as usize)
    }

    /// With diffuse inter-reflection: hemispheres, depth first (`hemispheres.rs`).
    fn data_parallel_newest_first(&self) -> bool {
        self.renderer.effects().diffuse_interreflection.enabled
    }

    fn placement(&self, _procs: usize) -> Vec<Placement<NodeId>> {
        self.owner_table()
            .map(|(id, owner, bytes)| Placement { id, owner, bytes })
            .collect()
    }

    /// The cell table and the partition are the directory: no processor
    /// keeps one of its own.
    fn locates(&self) -> bool {
        true
    }

    #[inline]
    fn locate(&self, leaf: &NodeId, _procs: usize) -> Option<(usize, u64)> {
        if self.replicated() {
            return None;
        }
        let bytes = self.cells.bytes_of(*leaf)?;
        Some((self.partition.owner(*leaf) as usize, bytes))
    }

    fn cache_charge(&self, leaf: &NodeId, bytes: u64) -> u64 {
        self.held_charge(*leaf, bytes)
    }

    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(NodeId, Item)> {
        let cells = self.load_cells(proc, procs);
        cells.into_iter().map(|(l, c)| (l, Item::Cell(c))).collect()
    }

    fn root_tasks(&self, procs: usize) -> Vec<DdTask> {
        if let Some(irr) = &self.irradiance {
            return irr.roots();
        }
        let ps = self.renderer.options().ps as usize;
        // Tiles aligned to the adaptive sampling grid where replicated: a
        // tile then shares only its border grid rows and columns with others.
        let align = if ps > 1 && self.replicated() { ps } else { 1 };
        let side = self.opts.tile.div_ceil(align) * align;
        let tail = self.opts.tail_tiles;
        super::tasks::screen_tiles(self.width, self.height, side, align, procs, tail)
            .into_iter()
            .map(DdTask::Tile)
            .collect()
    }

    fn next_epoch(&self, ended: usize, acc: &mut PixelTrees) -> Option<Epoch<Self>> {
        self.next_wave(ended, acc)
    }
    fn select_data(&self, task: &DdTask, ctx: &mut Ctx<Self>) -> Vec<NodeId> {
        match task {
            DdTask::Tile(t) => self.select_tile(t, None, ctx),
            DdTask::Shadows(jobs) => jobs
                .iter()
                .flat_map(|j| self.select_shadow(&j.bundle, None, ctx))
                .collect(),
            // A wave's pixels are scattered: their rays go to their cells.
            DdTask::Wave(_) => Vec::new(),
        }
    }

    fn select_data_in(
        &self,
        task: &DdTask,
        local: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        match task {
            DdTask::Tile(t) => self.select_tile(t, Some(local), ctx),
            DdTask::Shadows(jobs) => jobs
                .iter()
                .flat_map(|j| self.select_shadow(&j.bundle, Some(local), ctx))
                .collect(),
            DdTask::Wave(_) => Vec::new(),
        }
    }

    fn execute_dd(&self, task: DdTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        match task {
            DdTask::Wave(w) => self.run_wave(&w, Some(data), ctx),
            DdTask::Tile(t) if self.replicated() => self.trace_tile_whole(&t, ctx),
            DdTask::Tile(t) if self.trace_tile_held(&t, ctx) => {}
            DdTask::Tile(t) => {
                for (key, task) in self.tile_jobs(&t, ctx) {
                    ctx.charge(Work::RaysSpawned, 1);
                    let job = RayJob {
                        key,
                        task,
                        cursor: TraceCursor::default(),
                        next: None,
                    };
                    if let Some(job) = self.advance_ray(job, data, ctx) {
                        ctx.charge(Work::ClipMisses, 1);
                        ctx.spawn_dp(DpTask::Ray(job));
                    }
                }
            }
            DdTask::Shadows(jobs) => {
                for j in jobs {
                    let job = ShadowDp {
                        key: j.key,
                        bundle: j.bundle,
                        replay: Replay::default(),
                        next: None,
                    };
                    if let Some(job) = self.advance_shadow(job, data, ctx) {
                        ctx.charge(Work::ClipMisses, 1);
                        ctx.spawn_dp(DpTask::Shadow(job));
                    }
                }
            }
        }
    }

    fn to_data_parallel(&self, task: DdTask, ctx: &mut Ctx<Self>) {
        match task {
            DdTask::Wave(w) => self.run_wave(&w, None, ctx),
            DdTask::Tile(t) => {
                for (key, task) in self.tile_jobs(&t, ctx) {
                    ctx.charge(Work::RaysSpawned, 1);
                    ctx.spawn_dp(DpTask::Ray(RayJob {
                        key,
                        task,
                        cursor: TraceCursor::default(),
                        next: None,
                    }));
                }
            }
            DdTask::Shadows(jobs) => {
                for j in jobs {
                    ctx.charge(Work::ShadowBundlesDp, 1);
                    ctx.spawn_dp(DpTask::Shadow(ShadowDp {
                        key: j.key,
                        bundle: j.bundle,
                        replay: Replay::default(),
                        next: None,
                    }));
                }
            }
        }
    }

    fn route_dp(&self, task: &DpTask) -> Option<NodeId> {
        match task {
            DpTask::Ray(j) => j.next,
            DpTask::Shadow(s) => s.next,
            DpTask::Leak(l) => l.next,
        }
    }

    fn execute_dp(
        &self,
        task: DpTask,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<DpTask> {
        let next = match task {
            DpTask::Ray(j) => self.advance_ray(j, data, ctx).map(DpTask::Ray),
            DpTask::Shadow(s) => self.advance_shadow(s, data, ctx).map(DpTask::Shadow),
            DpTask::Leak(l) => self.advance_leaks(l, data, ctx).map(DpTask::Leak),
        };
        match next {
            Some(t) => DpOutcome::Migrate(t),
            None => DpOutcome::Finished,
        }
    }

    fn merge(&self, acc: &mut PixelTrees, result: RtResult) {
        // The master: batches of finished pixels, placed in the picture.
        if let Record::Pixels(pixels) = result.record {
            acc.place_batch(self.width * self.height, pixels);
            return;
        }
        let before = acc.pixels.len();
        acc.merge(result);
        // Only a processor's merge makes super-samples (no ray-tree record
        // goes to the master).
        debug_assert!(acc.wanted.is_empty(), "super-samples left unmade");
        self.count_progress(acc, before);
    }

    /// A hemisphere's super-samples are made where its first samples'
    /// values meet: at the pixel's owner, when the last of them is merged.
    fn merge_in(
        &self,
        acc: &mut PixelTrees,
        result: RtResult,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) {
        if self.irradiance.is_some() {
            return self.merge_wave(acc, result, data, ctx);
        }
        let before = acc.pixels.len();
        acc.merge(result);
        self.super_sample(acc, ctx);
        // The master holds the picture; a processor a batch at most.
        self.count_progress(acc, before);
        let batch = self.opts.pixel_batch;
        if batch > 0 && acc.pixels.len() >= batch {
            ctx.emit_result(Addr::Master, acc.ship_pixels());
        }
    }
}

impl RtWorkload {
    /// Processor `proc`'s cells, read or copied (see `load_partition`).
    fn load_cells(&self, proc: usize, procs: usize) -> Vec<(NodeId, CellData)> {
        tracing::debug!(proc, procs, "processor starting: loading its partition");
        if let Some(h) = &self.held {
            let read = h
                .parts
                .get(proc)
                .and_then(|s| s.lock().unwrap_or_else(|e| e.into_inner()).take());
            // Read before the run (render_parallel_held does, reports what
            // it cannot read, then lets the cell index go: a workload runs
            // once there); a workload whose parts were not read before the
            // run reads them here.
            let cells = match read {
                Some(cells) => cells,
                None => self.read_cells(h, proc).unwrap_or_else(|e| panic!("{e}")),
            };
            self.make_kernel(proc, &cells);
            return cells;
        }
        if self.reads_the_scene(procs) {
            let cells = self.listed_cells();
            self.make_kernel(proc, &cells);
            return cells;
        }
        // One copy of each object for all of this processor's leaves.
        let mut copies = ObjectCopies::default();
        let cells = self
            .owner_table()
            .filter(|&(_, owner, _)| owner == proc)
            .map(|(leaf, _, bytes)| {
                let cell = LeafObjects::copy_from(
                    self.renderer.octree().leaf_objects(leaf),
                    &self.renderer.scene().objects,
                    &mut copies,
                );
                (leaf, CellData { leaf, bytes, cell })
            })
            .collect::<Vec<_>>();
        if self.share_in_process {
            crate::accel::share_copies_in_process(&copies);
        }
        self.make_kernel(proc, &cells);
        cells
    }

    /// Counts the pixels finished since there were `before`.
    fn count_progress(&self, acc: &PixelTrees, before: usize) {
        if let Some(p) = &self.progress {
            let done = acc.pixels.len().saturating_sub(before) as u64;
            if done > 0 {
                p.fetch_add(done, std::sync::atomic::Ordering::Relaxed);
            }
        }
    }
}
