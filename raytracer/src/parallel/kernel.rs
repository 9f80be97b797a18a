//! The processor's own hierarchy ([`LocalKernel`]): fresh queries whose
//! answer the processor's objects decide are answered through it instead
//! of the leaf-by-leaf octree walk that migrating rays need (see
//! [`crate::accel::LocalKernel`] for why the answers are the same); and
//! [`CellMemo`], the walk's memo of resident leaves.
//!
//! With a cache that never evicts, what a processor has fetched stays
//! local for the rest of the run, so its hierarchy *grows*: it is rebuilt
//! over its resident and cached leaves whenever the cache has grown by a
//! quarter since the last build ([`GrownKernel`]), or once the walks
//! through leaves cached since have cost about what a rebuild costs
//! ([`WALKED_PER_OBJECT`]). The rule of the answers is the same, with
//! "held by the hierarchy" for "resident": a query is answered by it only
//! if every non-empty leaf it enters is one the hierarchy was built over.
//! A leaf cached since is walked as before until the next build. The
//! rebuilds by growth cost at most about five builds of the final
//! hierarchy in all (each is at least a quarter larger than the one
//! before), those by walks at most what the walks they end had cost; they
//! spare the walk for every query that stays among the cells the processor
//! has come to hold.
//!
//! Where completion is configured (`render --complete-cache`), a processor
//! whose walks have cost, or at their rate would cost, what holding every
//! cell would asks for the rest of the scene (`completion.rs`,
//! [`super::walks_worth_the_rest`]); once its hierarchy covers
//! every cell, its tiles are traced whole, as the sequential renderer
//! traces them ([`RtWorkload::trace_tile_held`]).

use std::sync::Arc;

use hybrid_sched::{Ctx, DataView};

use super::bundle_judge::BundleJudge;
use super::caster::LocalQueries;
use super::distribution::EMPTY;
use super::tasks::{CellData, Tile};
use super::workload::RtWorkload;
use crate::accel::{
    GrownKernel, Hierarchy, HierarchyObjects, Hit, Judged, LeafObjects, LocalKernel, NodeId,
    ProcessorKernel as Kernel,
};
use crate::geometry::{Aabb, Ray, Segment};
use crate::render::{BvhCaster, RayCaster};
use crate::scene::ObjectId;

/// What one step's queries read to try the processor's hierarchy first.
pub struct LocalPath<'a> {
    source: Source<'a>,
    wl: &'a RtWorkload,
    proc: u32,
    /// The last object ignored by an any-hit query, and its index in the
    /// hierarchy (a point's shadow rays all ignore its surface).
    ignored: std::cell::Cell<Option<(ObjectId, Option<ObjectId>)>>,
    /// What the current shadow bundle's rays have found.
    bundle: BundleJudge,
}

enum Source<'a> {
    /// Over the resident objects (or the whole scene's).
    Resident(Hierarchy<'a>),
    /// Over the resident and cached objects.
    Grown(Arc<GrownKernel>),
}

impl LocalQueries for LocalPath<'_> {
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Judged<Option<Hit>> {
        LocalPath::intersect(self, ray, tmin, tmax)
    }

    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> Judged<bool> {
        LocalPath::occluded(self, ray, tmin, tmax, ignore)
    }

    fn holds(&self, leaf: NodeId) -> bool {
        LocalPath::holds(self, leaf)
    }

    fn begin_bundle(&self, region: Option<&Aabb>) {
        self.bundle.begin(region);
    }
}

impl LocalPath<'_> {
    /// Subtrees whose every non-empty leaf is resident here.
    #[inline]
    fn owned(&self, node: NodeId) -> bool {
        let o = self.wl.subtree_owner.get(node as usize);
        o == EMPTY || o == self.proc
    }

    #[inline]
    fn resident(&self, leaf: NodeId) -> bool {
        self.wl.partition.owner(leaf) == self.proc
    }

    /// Leaves whose every object the hierarchy holds.
    #[inline]
    pub fn holds(&self, leaf: NodeId) -> bool {
        match &self.source {
            Source::Resident(_) => self.resident(leaf),
            Source::Grown(g) => g.holds(leaf),
        }
    }

    /// The octree's nearest hit, if the objects here decide it; else
    /// the nearest of theirs ([`Hierarchy::intersect`]).
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Judged<Option<Hit>> {
        let octree = self.wl.renderer.octree();
        // The judgement of what the hierarchy was built over (subtrees
        // whose every non-empty leaf it holds, and the leaves it holds),
        // compiled for each source: it is asked at every node a judged
        // segment crosses.
        match &self.source {
            Source::Resident(h) => {
                let (owned, resident) = (|n| self.owned(n), |l| self.resident(l));
                let skip = |n| {
                    self.bundle
                        .vouches(octree, n, (ray, tmin, tmax), &owned, &resident)
                };
                h.intersect(octree, ray, tmin, tmax, &skip, &resident)
            }
            Source::Grown(g) => {
                let (covered, held) = (|n| g.covers(n), |l| g.holds(l));
                let skip = |n| {
                    self.bundle
                        .vouches(octree, n, (ray, tmin, tmax), &covered, &held)
                };
                g.hierarchy()
                    .intersect(octree, ray, tmin, tmax, &skip, &held)
            }
        }
    }

    /// The octree's any-hit answer, if the objects here decide it
    /// ([`Hierarchy::occluded`]).
    pub fn occluded(
        &self,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> Judged<bool> {
        let octree = self.wl.renderer.octree();
        let index = |h: &Hierarchy<'_>| {
            ignore.and_then(|id| match self.ignored.get() {
                Some((i, k)) if i == id => k,
                _ => {
                    let k = h.index_of(id);
                    self.ignored.set(Some((id, k)));
                    k
                }
            })
        };
        // A bundle whose judgements fail goes to the walk unjudged.
        if self.bundle.walks() {
            let h = match &self.source {
                Source::Resident(h) => *h,
                Source::Grown(g) => g.hierarchy(),
            };
            return match h.blocks(ray, tmin, tmax, index(&h)) {
                true => Judged::Decided(true),
                false => Judged::Partly(false),
            };
        }
        let r = match &self.source {
            Source::Resident(h) => {
                let (owned, resident) = (|n| self.owned(n), |l| self.resident(l));
                let skip = |n| {
                    self.bundle
                        .vouches(octree, n, (ray, tmin, tmax), &owned, &resident)
                };
                h.occluded_indexed(octree, ray, tmin, tmax, index(h), &skip, &resident)
            }
            Source::Grown(g) => {
                let h = g.hierarchy();
                let (covered, held) = (|n| g.covers(n), |l| g.holds(l));
                let skip = |n| {
                    self.bundle
                        .vouches(octree, n, (ray, tmin, tmax), &covered, &held)
                };
                h.occluded_indexed(octree, ray, tmin, tmax, index(&h), &skip, &held)
            }
        };
        self.bundle.judged(r);
        r
    }
}

/// Cached leaves before a processor's first grown hierarchy.
const FIRST_GROWTH: usize = 16;

/// Leaves walked (cached since the last build, so outside the grown
/// hierarchy) per object of that build that make a rebuild pay: a build
/// costs about 1.6 µs per object (6 ms for 3,800 objects) and a walked
/// leaf about 170 ns (the walk's share of a two-processor render of the
/// studio over the leaves it visited), so about ten walked leaves cost
/// what one object costs to build. Rebuilding once the walks have cost
/// as much as a build (the ski-rental rule) spends at most twice what the
/// best schedule of rebuilds would: a leaf fetched late near a light can
/// otherwise be walked by every shadow ray towards that light until the
/// cache has grown by a quarter again, which may be never.
const WALKED_PER_OBJECT: u64 = 10;

impl RtWorkload {
    /// Bytes of processor `proc`'s own hierarchies: the one over its
    /// resident cells and the latest grown over its cache
    /// ([`crate::accel::LocalKernel::memory_bytes`], the copies they share
    /// with the leaves not counted). `Some(0)` where it has none or uses
    /// the whole scene's; `None` where this process never built it (a
    /// processor of another MPI rank).
    pub fn hierarchy_bytes(&self, proc: usize) -> Option<u64> {
        let own = match self.kernels.get(proc)?.get() {
            None if self.opts.local_kernel && !self.replicated() => return None,
            Some(Kernel::Own(k)) => k.memory_bytes(),
            _ => 0,
        };
        let grown = self.grown.get(proc).map_or(0, |g| {
            g.slot
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .kernel
                .as_ref()
                .map_or(0, |k| k.memory_bytes())
        });
        Some((own + grown) as u64)
    }

    /// Builds processor `proc`'s hierarchy over `cells`, its resident
    /// leaves (option `local_kernel`; once: a later run of the workload
    /// has the same partition).
    pub(super) fn make_kernel(&self, proc: usize, cells: &[(NodeId, CellData)]) {
        if !self.opts.local_kernel || self.replicated() {
            return;
        }
        let Some(slot) = self.kernels.get(proc) else {
            return;
        };
        slot.get_or_init(|| {
            let t0 = std::time::Instant::now();
            let k = if cells.is_empty() {
                Kernel::Nothing
            } else if self.held.is_none() && cells.len() == self.cells.len() {
                self.renderer.bvh();
                Kernel::Whole
            } else {
                let shared = self.renderer.scene().table();
                Kernel::Own(Box::new(LocalKernel::build(
                    cells.iter().map(|c| &c.1.cell),
                    shared,
                )))
            };
            tracing::debug!(
                proc,
                objects = match &k {
                    Kernel::Own(k) => k.len(),
                    Kernel::Whole => self.renderer.scene().objects.len(),
                    Kernel::Nothing => 0,
                },
                bytes = match &k {
                    Kernel::Own(k) => k.memory_bytes(),
                    _ => 0,
                },
                seconds = t0.elapsed().as_secs_f64(),
                "processor's hierarchy built"
            );
            k
        });
    }

    /// Whether the processors read the scene itself instead of copies of
    /// their cells' objects: one processor, the scene loaded whole, its
    /// hierarchy the renderer's (so it neither walks the octree over its
    /// cells nor serves them to another processor).
    pub(super) fn reads_the_scene(&self, procs: usize) -> bool {
        procs == 1 && self.held.is_none() && self.opts.local_kernel && !self.replicated()
    }

    /// Every cell, listing its objects without copies (for a processor
    /// that [reads the scene](Self::reads_the_scene)).
    pub(super) fn listed_cells(&self) -> Vec<(NodeId, CellData)> {
        self.owner_table()
            .map(|(leaf, _, bytes)| {
                let cell = LeafObjects::listing(self.renderer.octree().leaf_objects(leaf));
                (leaf, CellData { leaf, bytes, cell })
            })
            .collect()
    }

    /// A caster over every object, counting its queries, where processor
    /// `proc` has one: the renderer's own where it holds every object of a
    /// scene loaded whole (its hierarchy is the renderer's), or its
    /// hierarchy grown over every cell once its cache holds them all
    /// ([`crate::accel::Grown::whole`]). Every answer is decided there, and
    /// a query needs no judgement, no walk and no record for a replay.
    #[inline]
    pub(super) fn whole_caster(&self, proc: usize) -> Option<CountingCaster<'_>> {
        let inner = match self.kernels.get(proc)?.get()? {
            Kernel::Whole => WholeSource::Scene(self.renderer.caster()),
            _ => WholeSource::Grown {
                octree: self.renderer.octree(),
                hierarchy: self.grown.get(proc)?.whole.get()?.hierarchy(),
                ignored: std::cell::Cell::new(None),
            },
        };
        Some(CountingCaster {
            inner,
            queries: std::cell::Cell::new(0),
        })
    }

    /// Traces tile `t` whole where the running processor holds every cell
    /// ([`Self::whole_caster`]) and bundles start where their point is
    /// shaded (`inline_local_shadows`): each primary ray's tree through
    /// the sequential renderer's own code with that caster, and only
    /// finished pixels emitted, as [`super::Distribution::Replicated`]
    /// traces a tile. The values are the same bit for bit; no child task,
    /// record or result of a node travels. Charged like the replicated
    /// path, and each ray and bundle as spawned, retired and (a bundle)
    /// run inline, with the queries as `trace.local`; no bundle goes
    /// data-parallel. `false` where it does not hold everything.
    pub(super) fn trace_tile_held(&self, t: &Tile, ctx: &mut Ctx<Self>) -> bool {
        let Some(caster) = self
            .whole_caster(ctx.proc_id())
            .filter(|_| self.opts.inline_local_shadows)
        else {
            return false;
        };
        let st = self.trace_primaries_whole(t, &caster, ctx);
        self.charge_held(&st, caster.queries.get(), ctx);
        true
    }

    /// Whether processor `proc` holds every non-empty cell: resident (one
    /// processor, or the `worst` distribution's), or resident and cached
    /// in a hierarchy grown over them all ([`crate::accel::Grown::whole`]).
    /// Then no bundle of it needs a selection, and no query a judgement.
    pub(super) fn holds_everything(&self, proc: usize) -> bool {
        self.subtree_owner
            .first()
            .is_some_and(|o| o == EMPTY || o as usize == proc)
            || self
                .grown
                .get(proc)
                .is_some_and(|g| g.whole.get().is_some())
    }

    /// Whether processor `proc` has a hierarchy of its own (option
    /// `local_kernel`): [`Self::local_path`] may answer.
    #[inline]
    pub(super) fn has_local_path(&self, proc: usize) -> bool {
        self.kernels.get(proc).is_some_and(|k| k.get().is_some())
    }

    /// Processor `proc`'s hierarchy, if it has one: the whole scene's
    /// where it holds everything, else its grown one where its cache keeps
    /// everything (built or rebuilt here when the cache has grown enough),
    /// else the one over its resident objects.
    #[inline]
    pub(super) fn local_path(
        &self,
        proc: usize,
        data: &DataView<'_, Self>,
    ) -> Option<LocalPath<'_>> {
        let base = self.kernels.get(proc)?.get()?;
        let source = match base {
            Kernel::Whole => Source::Resident(Hierarchy {
                bvh: self.renderer.bvh(),
                objects: HierarchyObjects::Scene(&self.renderer.scene().objects),
                ids: None,
            }),
            _ => match self.grown_kernel(proc, data) {
                Some(g) => Source::Grown(g),
                None => match base {
                    Kernel::Own(k) => Source::Resident(k.hierarchy()),
                    _ => return None,
                },
            },
        };
        Some(LocalPath {
            source,
            wl: self,
            proc: proc as u32,
            ignored: std::cell::Cell::new(None),
            bundle: BundleJudge::default(),
        })
    }

    /// Processor `proc`'s grown hierarchy, rebuilt first if its cache has
    /// grown by a quarter of what it holds since the last build, or if the
    /// walks over what it has cached since have cost as much as a rebuild
    /// ([`WALKED_PER_OBJECT`]); `None`
    /// while the cache can evict (copies in a hierarchy would outlive the
    /// budget) or before enough is cached.
    fn grown_kernel(&self, proc: usize, data: &DataView<'_, Self>) -> Option<Arc<GrownKernel>> {
        if !data.keeps_everything() {
            return None;
        }
        let grown = self.grown.get(proc)?;
        if let Some(g) = grown.whole.get() {
            return Some(Arc::clone(g));
        }
        let cached = data.cached_len();
        let mut slot = grown.slot.lock().unwrap_or_else(|e| e.into_inner());
        let total = grown.walked.load(std::sync::atomic::Ordering::Relaxed);
        // Walked since the last build.
        let walked = total - slot.walked_at_build;
        let paid = slot.kernel.as_ref().is_some_and(|k| {
            cached > slot.built_over && walked >= WALKED_PER_OBJECT * k.len().max(1) as u64
        });
        if cached >= slot.next_build.max(FIRST_GROWTH) || paid {
            let t0 = std::time::Instant::now();
            let g = GrownKernel::build(
                self.renderer.octree(),
                data.local_items()
                    .filter_map(|(&leaf, c)| Some((leaf, c.cell()?))),
                self.renderer.scene().table(),
            );
            tracing::debug!(
                proc,
                cached,
                walked,
                objects = g.len(),
                bytes = g.memory_bytes(),
                seconds = t0.elapsed().as_secs_f64(),
                "processor's hierarchy grown over its cache"
            );
            slot.next_build = cached + g.leaves().div_ceil(4).max(1);
            slot.built_over = cached;
            let g = Arc::new(g);
            if g.covers_all() {
                let _ = grown.whole.set(Arc::clone(&g));
            }
            slot.kernel = Some(g);
            slot.walked_at_build = total;
        }
        slot.kernel.clone()
    }
}

/// [`RtWorkload::cell`] with the last resident leaves found remembered: a
/// shadow bundle's rays cross the same few leaves again and again, and a
/// lookup in the processor's store is a hash lookup. Cached leaves are
/// looked up every time, so the cache sees every use (its recency order,
/// and so what it evicts, is what it would be without the memo).
pub(super) struct CellMemo<'a, 'v> {
    view: &'a DataView<'v, RtWorkload>,
    wl: &'a RtWorkload,
    proc: usize,
    slots: [std::cell::Cell<(NodeId, Option<&'v LeafObjects>)>; 8],
}

impl<'a, 'v> CellMemo<'a, 'v> {
    pub(super) fn new(view: &'a DataView<'v, RtWorkload>, wl: &'a RtWorkload, proc: usize) -> Self {
        CellMemo {
            view,
            wl,
            proc,
            slots: std::array::from_fn(|_| std::cell::Cell::new((NodeId::MAX, None))),
        }
    }

    #[inline]
    pub(super) fn get(&self, leaf: NodeId) -> Option<&'v LeafObjects> {
        let slot = &self.slots[leaf as usize & 7];
        match slot.get() {
            (l, Some(c)) if l == leaf => Some(c),
            _ => {
                let c = RtWorkload::cell(self.view, leaf);
                if c.is_some() && self.wl.owned(self.proc, leaf) {
                    slot.set((leaf, c));
                }
                c
            }
        }
    }
}

/// A caster that counts the queries it answers (charged as
/// [`super::work::Work::TraceLocal`], as the hierarchy's answers are).
pub(super) struct CountingCaster<'a> {
    inner: WholeSource<'a>,
    pub(super) queries: std::cell::Cell<u64>,
}

/// A hierarchy over every object of the scene.
enum WholeSource<'a> {
    /// The renderer's (the scene loaded whole).
    Scene(BvhCaster<'a>),
    /// A processor's grown over every non-empty leaf: every answer is
    /// the octree's, with nothing to judge.
    Grown {
        octree: &'a crate::accel::Octree,
        hierarchy: Hierarchy<'a>,
        /// The last object ignored and its index (as [`LocalPath`]'s).
        ignored: std::cell::Cell<Option<(ObjectId, Option<ObjectId>)>>,
    },
}

impl RayCaster for CountingCaster<'_> {
    #[inline]
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        self.queries.set(self.queries.get() + 1);
        match &self.inner {
            WholeSource::Scene(c) => c.intersect(ray, tmin, tmax),
            WholeSource::Grown {
                octree, hierarchy, ..
            } => match hierarchy.intersect(octree, ray, tmin, tmax, &|_| true, &|_| true) {
                Judged::Decided(h) | Judged::Partly(h) => h,
            },
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        self.queries.set(self.queries.get() + 1);
        match &self.inner {
            WholeSource::Scene(c) => c.occluded(ray, tmin, tmax, ignore),
            WholeSource::Grown {
                octree,
                hierarchy,
                ignored,
            } => {
                let index = ignore.and_then(|id| match ignored.get() {
                    Some((i, k)) if i == id => k,
                    _ => {
                        let k = hierarchy.index_of(id);
                        ignored.set(Some((id, k)));
                        k
                    }
                });
                match hierarchy
                    .occluded_indexed(octree, ray, tmin, tmax, index, &|_| true, &|_| true)
                {
                    Judged::Decided(b) | Judged::Partly(b) => b,
                }
            }
        }
    }

    /// Where the hierarchy is the renderer's, whose leaves hold blocks of
    /// triangles: a processor's hierarchy over its copies has none, and
    /// through it packets cost more than the rays one at a time (see the
    /// book's benchmarks chapter).
    fn traces_packets(&self) -> bool {
        matches!(self.inner, WholeSource::Scene(_))
    }

    fn occluded_packet(&self, rays: &[Segment], ignore: Option<ObjectId>, out: &mut [bool]) {
        match &self.inner {
            WholeSource::Scene(c) => {
                self.queries.set(self.queries.get() + rays.len() as u64);
                c.occluded_packet(rays, ignore, out)
            }
            WholeSource::Grown { .. } => {
                for (&(ray, tmin, tmax), o) in rays.iter().zip(out) {
                    *o = self.occluded(&ray, tmin, tmax, ignore);
                }
            }
        }
    }

    fn intersect_packet(&self, rays: &[Segment], out: &mut [Option<Hit>]) {
        match &self.inner {
            WholeSource::Scene(c) => {
                self.queries.set(self.queries.get() + rays.len() as u64);
                c.intersect_packet(rays, out)
            }
            WholeSource::Grown { .. } => {
                for (&(ray, tmin, tmax), o) in rays.iter().zip(out) {
                    *o = self.intersect(&ray, tmin, tmax);
                }
            }
        }
    }
}
