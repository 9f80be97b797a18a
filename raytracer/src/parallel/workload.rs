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

use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};

use hybrid_sched::serde::{Deserialize, Serialize};
use hybrid_sched::{Addr, Ctx, DataView, DpOutcome, Placement, Workload};

use super::caster::{PartialCaster, Replay};
use super::distribution::Distribution;
use super::partition::{object_bytes, Partition};
use super::tasks::{CellData, DdTask, DpTask, RayJob, ShadowDp, ShadowJob, Tile};
use super::tree::{Child, NodeKey, PixelTrees, Record, RtResult};
use super::work::Work;
use crate::accel::{Hit, NodeId, Partial, Pyramid, TraceCursor};
use crate::geometry::{Aabb, Vec3};
use crate::render::direct::{run_shadow_bundle, ShadowCounts};
use crate::render::light::LightExtent;
use crate::render::material::shade;
use crate::render::{RayKind, RayTask, Renderer, Request, ShadowBundle};
use crate::scene::{View, ViewType};

thread_local! {
    /// The patch list of [`run_shadow_bundle`], reused by every bundle a
    /// thread runs (a fresh one per bundle grew on the hot path).
    static SCRATCH: std::cell::RefCell<Vec<crate::render::direct::Contribution>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

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
    /// Selections are supersets of the per-bundle ones (a little more data
    /// may be fetched); clipping work drops by the bundles per cell.
    #[serde(default)]
    pub clip_cache: bool,
}

impl Default for WorkloadOptions {
    fn default() -> Self {
        WorkloadOptions {
            tile: 16,
            shadow_dp_below: 2,
            distribution: Distribution::Octree,
            clip_cache: false,
        }
    }
}

/// The parallel ray tracer (see the module documentation).
#[derive(Debug)]
pub struct RtWorkload {
    renderer: Renderer<'static>,
    view: View,
    width: usize,
    height: usize,
    opts: WorkloadOptions,
    /// Non-empty leaves with their data size.
    cells: Vec<(NodeId, u32, u64)>,
    partition: Partition,
    /// Per node: the one processor owning every non-empty leaf below it,
    /// [`EMPTY`] if there is none, [`MIXED`] if several own some.
    subtree_owner: Vec<u32>,
    /// Predicted subtree costs ([`Distribution::Predicted`] only).
    predicted: Vec<u64>,
    /// Shadow selections per (processor, cell, light) (option
    /// `clip_cache`), one map per processor so they do not contend.
    clip_cache: Vec<Mutex<ClipCache>>,
    /// Finished pixels, counted for a progress display (see
    /// [`RtWorkload::with_progress`]).
    progress: Option<Arc<std::sync::atomic::AtomicU64>>,
}

/// Shadow selections per (processor, cell, light).
type ClipCache = HashMap<(u32, NodeId, u32), ClipEntry>;

/// One cached shadow selection.
#[derive(Debug)]
struct ClipEntry {
    leaves: Arc<[NodeId]>,
    /// Every leaf of the selection was found local, under a cache that
    /// never evicts: bundles from this cell to this light need no
    /// selection at all.
    all_local: bool,
}

const EMPTY: u32 = u32::MAX - 1;
const MIXED: u32 = u32::MAX;

impl RtWorkload {
    /// Counts finished pixels into `counter` as processors assemble them
    /// (what is computed does not change).
    pub fn with_progress(mut self, counter: Arc<std::sync::atomic::AtomicU64>) -> Self {
        self.progress = Some(counter);
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
        let cells = octree
            .leaves()
            .filter_map(|leaf| {
                let ids = octree.leaf_objects(leaf);
                (!ids.is_empty()).then(|| {
                    let bytes: usize = ids
                        .iter()
                        .map(|&o| {
                            let n = listed[o as usize].max(1) as usize;
                            object_bytes(&objects[o as usize]).div_ceil(n) + 4
                        })
                        .sum();
                    (leaf, ids.len() as u32, bytes as u64)
                })
            })
            .collect();
        let predicted = if opts.distribution == Distribution::Predicted {
            super::predict::subtree_costs(&renderer, &view, width, height)
        } else {
            Vec::new()
        };
        let partition = Self::partition_for(&renderer, opts.distribution, procs, &predicted);
        let subtree_owner = Self::subtree_owners(&renderer, &partition);
        RtWorkload {
            subtree_owner,
            predicted,
            clip_cache: (0..procs.max(1))
                .map(|_| Mutex::new(HashMap::new()))
                .collect(),
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
        }
    }

    fn partition_for(
        renderer: &Renderer<'static>,
        d: Distribution,
        procs: usize,
        predicted: &[u64],
    ) -> Partition {
        let (octree, objects) = (renderer.octree(), &renderer.scene().objects);
        let procs = u32::try_from(procs.max(1)).unwrap_or(u32::MAX);
        match d {
            // Replicated: the memory cut, for the per-processor report only.
            Distribution::Octree | Distribution::Replicated => {
                Partition::new(octree, objects, procs)
            }
            Distribution::Worst => Partition::worst_case(octree, objects, procs),
            Distribution::Predicted => Partition::by_cost(octree, objects, procs, predicted),
        }
    }

    fn subtree_owners(renderer: &Renderer<'static>, part: &Partition) -> Vec<u32> {
        let octree = renderer.octree();
        let n = octree.node_count();
        let mut out = vec![EMPTY; n];
        // Children always have larger ids than their parent.
        for id in (0..n as NodeId).rev() {
            out[id as usize] = match octree.children(id) {
                None if octree.leaf_objects(id).is_empty() => EMPTY,
                None => part.owner(id),
                Some(ch) => ch
                    .iter()
                    .fold(EMPTY, |acc, &c| match (acc, out[c as usize]) {
                        (a, EMPTY) => a,
                        (EMPTY, b) => b,
                        (a, b) if a == b => a,
                        _ => MIXED,
                    }),
            };
        }
        out
    }

    /// True if every leaf a bundle confined to `bounds` (`None`: anywhere)
    /// can touch is resident on processor `proc`: its data selection would
    /// fetch nothing, so clipping is skipped.
    fn all_resident(&self, bounds: Option<Aabb>, proc: usize, procs: usize) -> bool {
        if self.partition.procs() as usize != procs || self.subtree_owner.is_empty() {
            return false;
        }
        let octree = self.renderer.octree();
        let mut node: NodeId = 0;
        if let Some(b) = bounds {
            'descend: while let Some(children) = octree.children(node) {
                for c in children {
                    let cb = octree.node_bounds(c);
                    if (cb.min.cmple(b.min) & cb.max.cmpge(b.max)).all() {
                        node = c;
                        continue 'descend;
                    }
                }
                break;
            }
        }
        let o = self.subtree_owner[node as usize];
        o == EMPTY || o as usize == proc
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
        self.cells.iter().map(|c| c.2).sum()
    }

    /// The largest data set one task can need: every cell (used to size a
    /// cache that is "smaller than one task's data").
    pub fn largest_cell_bytes(&self) -> u64 {
        self.cells.iter().map(|c| c.2).max().unwrap_or(0)
    }

    /// [`Distribution::Replicated`]: every leaf is local everywhere.
    #[inline]
    fn replicated(&self) -> bool {
        self.opts.distribution == Distribution::Replicated
    }

    /// Leaves as data items: (leaf, owner, bytes); none when replicated.
    fn owner_table(&self, procs: usize) -> Vec<(NodeId, usize, u64)> {
        if self.replicated() {
            return Vec::new();
        }
        let fresh;
        let part = if self.partition.procs() as usize == procs.max(1) {
            &self.partition
        } else {
            fresh = Self::partition_for(
                &self.renderer,
                self.opts.distribution,
                procs,
                &self.predicted,
            );
            &fresh
        };
        self.cells
            .iter()
            .map(|&(leaf, _, bytes)| (leaf, part.owner(leaf) as usize, bytes))
            .collect()
    }

    /// Whether `leaf`'s objects are available on processor `proc` (of
    /// `procs`): resident by the partition (an array lookup) or in the view
    /// (cached, or resident under a runtime that holds everything locally).
    #[inline]
    fn is_local(&self, view: &DataView<'_, Self>, proc: usize, procs: usize, leaf: NodeId) -> bool {
        self.owned(proc, procs, leaf) || view.get(&leaf).is_some()
    }

    /// [`Self::is_local`] without touching the leaf's cache recency.
    fn held(&self, view: &DataView<'_, Self>, proc: usize, procs: usize, leaf: NodeId) -> bool {
        self.owned(proc, procs, leaf) || view.is_local(&leaf)
    }

    /// Whether `leaf` is resident on processor `proc` (of `procs`) without
    /// asking a view: everything is when replicated, else the partition's
    /// owner (an array lookup).
    #[inline]
    fn owned(&self, proc: usize, procs: usize, leaf: NodeId) -> bool {
        self.replicated()
            || (self.partition.procs() as usize == procs
                && self.partition.owner(leaf) as usize == proc)
    }

    /// The non-empty leaves among `leaves`, each once, in order.
    fn nonempty(&self, leaves: impl IntoIterator<Item = NodeId>) -> Vec<NodeId> {
        let octree = self.renderer.octree();
        let mut seen = HashSet::new();
        leaves
            .into_iter()
            .filter(|&l| !octree.leaf_objects(l).is_empty() && seen.insert(l))
            .collect()
    }

    /// Data selection for a tile: the pyramid from the eye through the
    /// tile's corners (perspective views), else the leaves along every
    /// primary ray.
    fn select_tile(&self, t: &Tile, ctx: &mut Ctx<Self>) -> Vec<NodeId> {
        if self.replicated() || self.all_resident(None, ctx.proc_id(), ctx.procs()) {
            return Vec::new();
        }
        let octree = self.renderer.octree();
        let (w, h) = (self.width as f64, self.height as f64);
        if self.view.vtype == ViewType::Perspective {
            // Pixel edges widened by the largest jitter offset, so every
            // jittered ray of the tile is inside.
            let m = (self.renderer.options().pj * 0.5).max(0.5);
            let xs = [(t.x0 as f64 - m) / w, (t.x1 as f64 + m) / w];
            let ys = [1.0 - (t.y0 as f64 - m) / h, 1.0 - (t.y1 as f64 + m) / h];
            let dirs: Vec<Vec3> = xs
                .iter()
                .flat_map(|&x| ys.iter().map(move |&y| (x, y)))
                .filter_map(|(x, y)| self.view.ray(x, y).map(|(r, _, _)| r.dir))
                .collect();
            if dirs.len() == 4 {
                return self.clip(&Pyramid::from_rays(self.view.vp, &dirs), ctx);
            }
        }
        let mut leaves = Vec::new();
        let mut visits = 0u64;
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                let Some(task) = self.primary(x, y) else {
                    continue;
                };
                octree.for_each_leaf_along_ray(&task.ray, task.tmin, task.tmax, |leaf, _, _| {
                    visits += 1;
                    leaves.push(leaf);
                    false
                });
            }
        }
        ctx.charge(Work::ClipNodes, visits);
        self.nonempty(leaves)
    }

    /// Data selection for a shadow bundle: the pyramid from the shaded
    /// point around the whole source.
    fn select_shadow(
        &self,
        b: &ShadowBundle,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        if self.replicated() {
            return Vec::new();
        }
        // The box holding every shadow ray of the bundle (padded for the
        // origin offsets), if the source is finite.
        let bounds = self
            .renderer
            .lights()
            .get(b.light as usize)
            .and_then(|l| l.shadow_bounds(b.point, b.offset_scale));
        if self.all_resident(bounds, ctx.proc_id(), ctx.procs()) {
            return Vec::new();
        }
        if self.opts.clip_cache {
            if let Some(sel) = self.select_shadow_cached(b, local, ctx) {
                return sel;
            }
        }
        match self.shadow_pyramid(b) {
            Some(pyramid) => self.clip(&pyramid, ctx),
            None => Vec::new(),
        }
    }

    /// [`WorkloadOptions::clip_cache`]: the selection for every bundle from
    /// the shaded point's cell to its (finite) light. `None` to clip the
    /// bundle's own pyramid instead.
    ///
    /// With `local` (what the processor holds) and an unlimited cache, a
    /// selection found entirely local is remembered, and later bundles from
    /// the cell to the light select (and pin) nothing.
    fn select_shadow_cached(
        &self,
        b: &ShadowBundle,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Option<Vec<NodeId>> {
        let octree = self.renderer.octree();
        let leaf = octree.find_leaf(b.point)?;
        let (proc, procs) = (ctx.proc_id(), ctx.procs());
        let key = (proc as u32, leaf, b.light);
        let shard = &self.clip_cache[proc % self.clip_cache.len()];
        if let Some(e) = shard.lock().ok()?.get_mut(&key) {
            ctx.charge(Work::ClipReused, 1);
            // Only where nothing is ever evicted: a selection left empty
            // pins nothing, so with a budget a cell could leave before the
            // bundle runs.
            if let Some(local) = local.filter(|l| l.keeps_everything()) {
                if e.all_local || e.leaves.iter().all(|&l| self.held(local, proc, procs, l)) {
                    e.all_local = true;
                    ctx.charge(Work::ClipAllLocal, 1);
                    return Some(Vec::new());
                }
            }
            return Some(e.leaves.to_vec());
        }
        // Entries exist only for finite sources (checked here, on a miss).
        let light = self.renderer.lights().get(b.light as usize)?;
        let points = light.shadow_hull_points(octree.node_bounds(leaf), b.point, b.offset_scale)?;
        let hull = Pyramid::hull(&points, b.point)?;
        let sel = self.clip(&hull, ctx);
        if let Ok(mut cache) = shard.lock() {
            cache.insert(
                key,
                ClipEntry {
                    leaves: sel.clone().into(),
                    all_local: false,
                },
            );
        }
        Some(sel)
    }

    /// The non-empty leaves meeting `pyramid` that this processor does not
    /// hold, front to back (subtrees it holds entirely are not visited).
    fn clip(&self, pyramid: &Pyramid, ctx: &mut Ctx<Self>) -> Vec<NodeId> {
        let octree = self.renderer.octree();
        let mut leaves = Vec::new();
        let me = ctx.proc_id() as u32;
        let known = self.partition.procs() as usize == ctx.procs();
        let wanted = |id: NodeId| {
            let o = self.subtree_owner[id as usize];
            !(known && (o == me || o == EMPTY))
        };
        let visits = octree.clip_leaves_where(pyramid, wanted, |l| {
            if !octree.leaf_objects(l).is_empty() {
                leaves.push(l);
            }
        });
        ctx.charge(Work::ClipNodes, visits);
        leaves
    }

    fn shadow_pyramid(&self, b: &ShadowBundle) -> Option<Pyramid> {
        self.renderer
            .lights()
            .get(b.light as usize)?
            .shadow_pyramid(b.point)
    }

    /// Whether a new shadow bundle should run data-parallel: too few rays to
    /// be worth clipping, or a pyramid that would not bound it (the point
    /// inside the source's box, a very wide distant source).
    fn shadow_goes_dp(&self, b: &ShadowBundle) -> bool {
        let Some(light) = self.renderer.lights().get(b.light as usize) else {
            return true;
        };
        match light.extent() {
            None => true,
            Some(LightExtent::Distant { cos_half, .. }) => {
                cos_half < 0.5 || self.opts.shadow_dp_below > 1
            }
            Some(LightExtent::Finite(_)) => {
                light.box_holds(b.point)
                    || light.patch_estimate(b.point, self.renderer.options().ds)
                        < self.opts.shadow_dp_below
            }
        }
    }

    fn primary(&self, x: u32, y: u32) -> Option<RayTask> {
        self.renderer
            .primary_task(&self.view, self.width, self.height, x as usize, y as usize)
    }

    /// [`Distribution::Replicated`]: with the whole scene at hand there is
    /// nothing to migrate or fetch, so a tile's pixels are traced whole by
    /// the sequential renderer (the very code the other distributions must
    /// equal) and only finished pixels are emitted. Its ray and shadow
    /// counts are charged; traversal units (`trace.*`) are not, since the
    /// sequential kernel does not count them, so a simulated replicated run
    /// prices tracing from the ray counts alone.
    fn trace_tile_whole(&self, t: &Tile, ctx: &mut Ctx<Self>) {
        let origin = Addr::Proc(ctx.origin());
        let mut st = crate::render::TraceState::default();
        if self.renderer.options().ps > 1 {
            // Adaptive sampling: the tile with its grid cells as apron, so
            // its pixels equal the sequential picture's.
            let grid = self.renderer.grid(self.width, self.height);
            let width = self.width as u32;
            grid.fill_region(
                t.x0 as usize..t.x1 as usize,
                t.y0 as usize..t.y1 as usize,
                &mut None,
                &mut |x, y| {
                    self.renderer
                        .pixel(&self.view, self.width, self.height, x, y, &mut st)
                },
                &mut |x, y, value| {
                    ctx.emit_result(
                        origin,
                        RtResult {
                            key: NodeKey::root(y as u32 * width + x as u32),
                            record: Record::Value(value),
                        },
                    )
                },
            );
            self.charge_counts(&st, ctx);
            return;
        }
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                let Some(task) = self.primary(x, y) else {
                    continue;
                };
                let value = self.renderer.radiance(&task, &mut st);
                ctx.emit_result(
                    origin,
                    RtResult {
                        key: NodeKey::root(y * self.width as u32 + x),
                        record: Record::Value(value),
                    },
                );
            }
        }
        self.charge_counts(&st, ctx);
    }

    /// Charges the rays and shadow work tallied in `st`.
    fn charge_counts(&self, st: &crate::render::TraceState, ctx: &mut Ctx<Self>) {
        let c = &st.counts;
        for (kind, n) in [
            (Work::RaysPrimary, c.primary),
            (Work::RaysReflection, c.reflection),
            (Work::RaysRefraction, c.refraction),
            (Work::RaysPassThrough, c.pass_through),
        ] {
            ctx.charge(kind, n);
        }
        ctx.charge(Work::ShadowBundles, c.shadow.bundles);
        ctx.charge(Work::ShadowPatches, c.shadow.patches);
        ctx.charge(Work::ShadowTested, c.shadow.tested);
        ctx.charge(Work::ShadowEstimated, c.shadow.estimated);
        ctx.charge(Work::ShadowUnoccluded, c.shadow.unoccluded);
        ctx.charge(Work::ShadowSegments, c.shadow.transparent_segments);
    }

    /// A traced ray is complete: shade its hit here (or take the sky), send
    /// the node's record to the pixel's owner, spawn its requests.
    fn finish_ray(&self, key: NodeKey, task: &RayTask, hit: Option<Hit>, ctx: &mut Ctx<Self>) {
        ctx.charge(
            match task.kind {
                RayKind::Primary => Work::RaysPrimary,
                RayKind::Reflection => Work::RaysReflection,
                RayKind::Refraction => Work::RaysRefraction,
                RayKind::PassThrough => Work::RaysPassThrough,
                RayKind::Ambient => Work::RaysAmbient,
            },
            1,
        );
        ctx.charge(Work::RaysRetired, 1);
        let dest = Addr::Proc(ctx.origin());
        let Some(hit) = hit else {
            let sky = self.renderer.sky_seen(task);
            ctx.emit_result(
                dest,
                RtResult {
                    key,
                    record: Record::Value(sky),
                },
            );
            return;
        };
        ctx.charge(Work::Shade, 1);
        let sctx = self.renderer.context();
        let mut requests = Vec::new();
        let shaded = shade(&sctx, task, &hit, &mut requests);
        let mut children = Vec::with_capacity(requests.len());
        for (i, r) in requests.into_iter().enumerate() {
            match r {
                Request::Trace { task: child, coef } => {
                    children.push(Child::Trace(coef));
                    ctx.charge(Work::RaysSpawned, 1);
                    ctx.spawn_dp(DpTask::Ray(RayJob {
                        key: key.child(i),
                        task: child,
                        cursor: TraceCursor::default(),
                        next: None,
                    }));
                }
                Request::Shadow(bundle) | Request::Scatter(bundle) => {
                    children.push(if matches!(r, Request::Scatter(_)) {
                        Child::Scatter
                    } else {
                        Child::Shadow
                    });
                    ctx.charge(Work::ShadowSpawned, 1);
                    let key = key.child(i);
                    if self.shadow_goes_dp(&bundle) {
                        ctx.charge(Work::ShadowBundlesDp, 1);
                        ctx.spawn_dp(DpTask::Shadow(ShadowDp {
                            key,
                            bundle,
                            replay: Replay::default(),
                            next: None,
                        }));
                    } else {
                        ctx.spawn_dd(DdTask::Shadow(ShadowJob { key, bundle }));
                    }
                }
            }
        }
        let attenuation = crate::render::medium::participate(
            self.renderer.options(),
            shaded.extinction,
            &shaded.medium,
            hit.t,
        );
        ctx.emit_result(
            dest,
            RtResult {
                key,
                record: Record::Shaded {
                    base: shaded.base,
                    children,
                    attenuation,
                },
            },
        );
    }

    /// Traces a ray as far as the local cells allow: finished, or the job
    /// to migrate.
    fn advance_ray(
        &self,
        mut job: RayJob,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<RayJob> {
        let octree = self.renderer.octree();
        let objects = &self.renderer.scene().objects;
        let t = &job.task;
        let (proc, procs) = (ctx.proc_id(), ctx.procs());
        let (mut leaves, mut tests) = (0u64, 0u64);
        let partial =
            octree.intersect_partial(objects, &t.ray, t.tmin, t.tmax, &mut job.cursor, |l| {
                leaves += 1;
                tests += octree.leaf_objects(l).len() as u64;
                self.is_local(data, proc, procs, l)
            });
        ctx.charge(Work::TraceLeaves, leaves);
        ctx.charge(Work::TraceObjects, tests);
        match partial {
            Partial::Blocked(leaf) => {
                job.next = Some(leaf);
                Some(job)
            }
            Partial::Done(hit) => {
                let task = job.task;
                self.finish_ray(job.key, &task, hit, ctx);
                None
            }
        }
    }

    /// Runs a shadow bundle as far as the local cells allow: finished, or
    /// the bundle to migrate with its recorded answers.
    fn advance_shadow(
        &self,
        mut job: ShadowDp,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<ShadowDp> {
        let octree = self.renderer.octree();
        let objects = &self.renderer.scene().objects;
        if !job.replay.answers.is_empty() || job.replay.cursor != TraceCursor::default() {
            ctx.charge(Work::ShadowRestarts, 1);
        }
        let replay = std::mem::take(&mut job.replay);
        let (proc, procs) = (ctx.proc_id(), ctx.procs());
        let visits = std::cell::Cell::new((0u64, 0u64));
        let caster = PartialCaster::new(
            octree,
            objects,
            |l| {
                let (a, b) = visits.get();
                visits.set((a + 1, b + octree.leaf_objects(l).len() as u64));
                self.is_local(data, proc, procs, l)
            },
            replay,
        );
        let mut counts = ShadowCounts::default();
        let value = SCRATCH.with_borrow_mut(|scratch| {
            run_shadow_bundle(
                &self.renderer.context(),
                &caster,
                &job.bundle,
                scratch,
                &mut counts,
            )
        });
        let (leaves, tests) = visits.get();
        ctx.charge(Work::TraceLeaves, leaves);
        ctx.charge(Work::TraceObjects, tests);
        if let Some(leaf) = caster.blocked() {
            job.replay = caster.into_replay();
            job.next = Some(leaf);
            return Some(job);
        }
        charge_shadow(ctx, &counts);
        ctx.emit_result(
            Addr::Proc(ctx.origin()),
            RtResult {
                key: job.key,
                record: Record::Value(value),
            },
        );
        None
    }
}

fn charge_shadow(ctx: &mut Ctx<RtWorkload>, c: &ShadowCounts) {
    ctx.charge(Work::ShadowRetired, 1);
    ctx.charge(Work::ShadowBundles, c.bundles);
    ctx.charge(Work::ShadowPatches, c.patches);
    ctx.charge(Work::ShadowTested, c.tested);
    ctx.charge(Work::ShadowEstimated, c.estimated);
    ctx.charge(Work::ShadowUnoccluded, c.unoccluded);
    ctx.charge(Work::ShadowSegments, c.transparent_segments);
}

impl Workload for RtWorkload {
    type DataId = NodeId;
    type DataItem = CellData;
    type DdTask = DdTask;
    type DpTask = DpTask;
    type Result = RtResult;
    type Accumulator = PixelTrees;
    type Work = Work;

    fn placement(&self, procs: usize) -> Vec<Placement<NodeId>> {
        self.owner_table(procs)
            .into_iter()
            .map(|(id, owner, bytes)| Placement { id, owner, bytes })
            .collect()
    }

    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(NodeId, CellData)> {
        tracing::debug!(proc, procs, "processor starting: loading its partition");
        let objects: std::collections::HashMap<NodeId, u32> =
            self.cells.iter().map(|&(l, n, _)| (l, n)).collect();
        self.owner_table(procs)
            .into_iter()
            .filter(|&(_, owner, _)| owner == proc)
            .map(|(leaf, _, bytes)| {
                (
                    leaf,
                    CellData {
                        leaf,
                        objects: objects[&leaf],
                        bytes,
                    },
                )
            })
            .collect()
    }

    fn root_tasks(&self, _procs: usize) -> Vec<DdTask> {
        let mut t = self.opts.tile;
        let ps = self.renderer.options().ps as usize;
        if ps > 1 && self.replicated() {
            // Tiles aligned to the adaptive sampling grid: a tile then
            // shares only its border grid rows and columns with others.
            t = t.div_ceil(ps) * ps;
        }
        let mut out = Vec::new();
        for y0 in (0..self.height).step_by(t) {
            for x0 in (0..self.width).step_by(t) {
                out.push(DdTask::Tile(Tile {
                    x0: x0 as u32,
                    y0: y0 as u32,
                    x1: (x0 + t).min(self.width) as u32,
                    y1: (y0 + t).min(self.height) as u32,
                }));
            }
        }
        out
    }

    fn select_data(&self, task: &DdTask, ctx: &mut Ctx<Self>) -> Vec<NodeId> {
        match task {
            DdTask::Tile(t) => self.select_tile(t, ctx),
            DdTask::Shadow(j) => self.select_shadow(&j.bundle, None, ctx),
        }
    }

    fn select_data_in(
        &self,
        task: &DdTask,
        local: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        match task {
            DdTask::Tile(t) => self.select_tile(t, ctx),
            DdTask::Shadow(j) => self.select_shadow(&j.bundle, Some(local), ctx),
        }
    }

    fn execute_dd(&self, task: DdTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        match task {
            DdTask::Tile(t) if self.replicated() => self.trace_tile_whole(&t, ctx),
            DdTask::Tile(t) => {
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        let Some(task) = self.primary(x, y) else {
                            continue;
                        };
                        ctx.charge(Work::RaysSpawned, 1);
                        let job = RayJob {
                            key: NodeKey::root(y * self.width as u32 + x),
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
            }
            DdTask::Shadow(j) => {
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

    fn to_data_parallel(&self, task: DdTask, ctx: &mut Ctx<Self>) {
        match task {
            DdTask::Tile(t) => {
                for y in t.y0..t.y1 {
                    for x in t.x0..t.x1 {
                        if let Some(task) = self.primary(x, y) {
                            ctx.charge(Work::RaysSpawned, 1);
                            ctx.spawn_dp(DpTask::Ray(RayJob {
                                key: NodeKey::root(y * self.width as u32 + x),
                                task,
                                cursor: TraceCursor::default(),
                                next: None,
                            }));
                        }
                    }
                }
            }
            DdTask::Shadow(j) => {
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

    fn route_dp(&self, task: &DpTask) -> Option<NodeId> {
        match task {
            DpTask::Ray(j) => j.next,
            DpTask::Shadow(s) => s.next,
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
        };
        match next {
            Some(t) => DpOutcome::Migrate(t),
            None => DpOutcome::Finished,
        }
    }

    fn merge(&self, acc: &mut PixelTrees, result: RtResult) {
        let before = acc.pixels.len();
        acc.merge(result);
        if let Some(p) = &self.progress {
            let done = acc.pixels.len().saturating_sub(before) as u64;
            if done > 0 {
                p.fetch_add(done, std::sync::atomic::Ordering::Relaxed);
            }
        }
    }
}
