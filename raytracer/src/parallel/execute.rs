//! Execution: tracing a tile's primary rays (or, replicated, the whole
//! tile), shading a hit and spawning its rays and shadow bundles, advancing
//! a migrating ray or a restartable shadow bundle as far as the local cells
//! allow, and sending every ray-tree record to the pixel's origin.

use hybrid_sched::{Addr, Ctx, DataView};

use super::caster::Replay;
use super::caster::{LocalQueries, PartialCaster, Recording};
use super::kernel::{CellMemo, LocalPath};
use super::tasks::{DdTask, DpTask, RayJob, ShadowDp, ShadowJob, Tile};
use super::tree::{evaluate, Child, NodeKey, Record, RtResult};
use super::work::Work;
use super::workload::RtWorkload;
use crate::accel::{Hit, Judged, NodeId, Partial, TraceCursor};
use crate::render::direct::{run_shadow_bundle, ShadowCounts};
use crate::render::material::shade;
use crate::render::RayCaster;
use crate::render::{RayKind, RayTask, Request, ShadowBundle};
use crate::scene::Color;

thread_local! {
    /// The patch list of [`run_shadow_bundle`], reused by every bundle a
    /// thread runs (a fresh one per bundle grew on the hot path).
    static SCRATCH: std::cell::RefCell<crate::render::direct::Patches> =
        std::cell::RefCell::new(crate::render::direct::Patches::default());
    /// A shaded point's requests, reused by every point a thread shades: a
    /// request is large, and a point lit by hundreds of sources grew a
    /// fresh vector through several copies (a sixth of the conference
    /// room's instructions on one processor).
    static REQUESTS: std::cell::RefCell<Vec<Request>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

impl RtWorkload {
    pub(super) fn primary(&self, x: u32, y: u32) -> Option<RayTask> {
        self.renderer
            .primary_task(&self.view, self.width, self.height, x as usize, y as usize)
    }

    /// A tile's primary rays, row by row (`None` where the view has no
    /// ray), computed once: [`RtWorkload::select_tile`] computes them
    /// when it walks them and leaves them here.
    pub(super) fn compute_tile_rays(&self, t: &Tile) -> Vec<Option<RayTask>> {
        (t.y0..t.y1)
            .flat_map(|y| (t.x0..t.x1).map(move |x| (x, y)))
            .map(|(x, y)| self.primary(x, y))
            .collect()
    }

    /// The primary rays of tile `t` on processor `proc` with their ray-tree
    /// keys, row by row: the ones its selection left, else computed now.
    pub(super) fn tile_primaries(
        &self,
        t: &Tile,
        proc: usize,
    ) -> impl Iterator<Item = (NodeKey, RayTask)> + '_ {
        let rays = self
            .take_tile(t, proc)
            .unwrap_or_else(|| self.compute_tile_rays(t));
        let (x0, y0, w) = (t.x0, t.y0, (t.x1 - t.x0).max(1));
        let width = self.width as u32;
        rays.into_iter().enumerate().filter_map(move |(i, task)| {
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            task.map(|task| (NodeKey::root(y * width + x), task))
        })
    }

    /// [`Distribution::Replicated`]: with the whole scene at hand there is
    /// nothing to migrate or fetch, so a tile's pixels are traced whole by
    /// the sequential renderer (the very code the other distributions must
    /// equal) and only finished pixels are emitted. Its ray and shadow
    /// counts are charged; traversal units (`trace.*`) are not, since the
    /// sequential kernel does not count them, so a simulated replicated run
    /// prices tracing from the ray counts alone.
    pub(super) fn trace_tile_whole(&self, t: &Tile, ctx: &mut Ctx<Self>) {
        if self.renderer.options().ps <= 1 {
            let st = self.trace_primaries_whole(t, &self.renderer.caster(), ctx);
            self.charge_counts(&st, ctx);
            return;
        }
        // Adaptive sampling: the tile with its grid cells as apron, so its
        // pixels equal the sequential picture's.
        let origin = Addr::Proc(ctx.origin());
        let mut st = crate::render::TraceState::default();
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
    }

    /// Each primary ray of tile `t` traced whole through `caster` by the
    /// sequential renderer's code ([`crate::render::Renderer::trace_tasks`]:
    /// as packets where `caster` traces them), its pixel's value sent to the tile's origin; returns the tally of
    /// what was traced.
    pub(super) fn trace_primaries_whole<C: RayCaster>(
        &self,
        t: &Tile,
        caster: &C,
        ctx: &mut Ctx<Self>,
    ) -> crate::render::TraceState {
        if self.renderer.options().pn > 1 {
            return self.trace_samples_whole(t, caster, ctx);
        }
        let origin = Addr::Proc(ctx.origin());
        let mut st = crate::render::TraceState::default();
        let (keys, tasks): (Vec<NodeKey>, Vec<RayTask>) =
            self.tile_primaries(t, ctx.proc_id()).unzip();
        let mut keys = keys.into_iter();
        self.renderer
            .trace_tasks(caster, &tasks, &mut st, &mut |value| {
                if let Some(key) = keys.next() {
                    let record = Record::Value(value);
                    ctx.emit_result(origin, RtResult { key, record });
                }
            });
        st
    }

    /// Charges the rays and shadow work tallied in `st`.
    pub(super) fn charge_counts(&self, st: &crate::render::TraceState, ctx: &mut Ctx<Self>) {
        let c = &st.counts;
        for (kind, n) in [
            (Work::RaysPrimary, c.primary),
            (Work::RaysReflection, c.reflection),
            (Work::RaysRefraction, c.refraction),
            (Work::RaysPassThrough, c.pass_through),
            (Work::RaysAmbient, c.ambient),
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
    pub(super) fn finish_ray(
        &self,
        key: NodeKey,
        task: &RayTask,
        hit: Option<Hit>,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) {
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
            let record = self.sky_record(self.renderer.sky_seen(task));
            ctx.emit_result(dest, RtResult { key, record });
            return;
        };
        ctx.charge(Work::Shade, 1);
        let sctx = self.renderer.context();
        let mut requests = REQUESTS.take();
        requests.clear();
        let shaded = shade(&sctx, task, &hit, &mut requests);
        let mut children = Vec::with_capacity(requests.len());
        // Bundles that need cells held elsewhere: one task for them all.
        let mut scheduled = Vec::new();
        // A processor holding the scene runs every bundle here, through
        // the renderer's hierarchy, and charges their work once.
        let whole = self
            .whole_caster(ctx.proc_id())
            .filter(|_| self.opts.inline_local_shadows);
        let mut tally = WholeTally::default();
        // Elsewhere, the processor's hierarchy, looked up once for all the
        // point's bundles.
        let (pid, local) = (ctx.proc_id(), std::cell::OnceCell::new());
        let path = || local.get_or_init(|| self.local_path(pid, data)).as_ref();
        for (i, r) in requests.iter().enumerate() {
            match r {
                Request::Trace { task: child, coef } => {
                    children.push(Child::Trace(*coef));
                    ctx.charge(Work::RaysSpawned, 1);
                    ctx.spawn_dp(DpTask::Ray(RayJob {
                        key: key.child(i),
                        task: *child,
                        cursor: TraceCursor::default(),
                        next: None,
                    }));
                }
                Request::Shadow(bundle) | Request::Scatter(bundle) if whole.is_some() => {
                    let caster = whole.as_ref().expect("matched");
                    tally.spawned += 1;
                    let v = self.run_bundle(caster, bundle, &mut tally.counts);
                    children.push(match r {
                        Request::Scatter(_) => Child::KnownScatter(v),
                        _ => Child::Known(v),
                    });
                }
                Request::Shadow(bundle) | Request::Scatter(bundle) => {
                    let scatter = matches!(r, Request::Scatter(_));
                    ctx.charge(Work::ShadowSpawned, 1);
                    // A bundle run here is run by reference and its value
                    // goes into the point's record (`Child::Known`): no key,
                    // task or result of its own. One that must travel is
                    // copied into a task, keyed by its request index.
                    let fresh = |bundle: &ShadowBundle, replay, next| ShadowDp {
                        key: key.child(i),
                        bundle: *bundle,
                        replay,
                        next,
                    };
                    let job = |bundle: &ShadowBundle| ShadowJob {
                        key: key.child(i),
                        bundle: *bundle,
                    };
                    let inline = self.opts.inline_local_shadows;
                    let run = if self.shadow_goes_dp(bundle) {
                        ctx.charge(Work::ShadowBundlesDp, 1);
                        if inline {
                            // Its first step would run here (it names no
                            // cell yet): run it now. Stopped by a cell held
                            // elsewhere, it joins the point's task (fetched
                            // cells serve later bundles) instead of migrating.
                            ctx.charge(Work::ShadowBundlesInline, 1);
                            match self.try_shadow(bundle, Replay::default(), path(), data, ctx) {
                                ShadowRun::Done(v) => Some(v),
                                ShadowRun::Blocked(..) => {
                                    ctx.charge(Work::ShadowJoined, 1);
                                    scheduled.push(job(bundle));
                                    None
                                }
                            }
                        } else {
                            ctx.spawn_dp(DpTask::Shadow(fresh(bundle, Replay::default(), None)));
                            None
                        }
                    } else if inline && self.shadow_all_resident(bundle, ctx.proc_id()) {
                        // Nothing to select or fetch: run it now (should a
                        // ray still leave the resident cells, the bundle
                        // migrates as a data-parallel one).
                        ctx.charge(Work::ShadowBundlesInline, 1);
                        match self.try_shadow(bundle, Replay::default(), path(), data, ctx) {
                            ShadowRun::Done(v) => Some(v),
                            ShadowRun::Blocked(replay, leaf) => {
                                ctx.charge(Work::ClipMisses, 1);
                                ctx.spawn_dp(DpTask::Shadow(fresh(bundle, replay, Some(leaf))));
                                None
                            }
                        }
                    } else {
                        // With its own hierarchy (option `local_kernel`), the
                        // processor tries the bundle on what it holds and has
                        // cached before paying for a selection; should it
                        // need a cell from elsewhere, it is scheduled as if
                        // it had not been tried.
                        let tried = (inline && self.has_local_path(ctx.proc_id()))
                            .then(|| self.try_shadow(bundle, Replay::default(), path(), data, ctx));
                        match tried {
                            Some(ShadowRun::Done(v)) => {
                                ctx.charge(Work::ShadowBundlesInline, 1);
                                Some(v)
                            }
                            tried => {
                                if tried.is_some() {
                                    ctx.charge(Work::ShadowTriedElsewhere, 1);
                                }
                                scheduled.push(job(bundle));
                                None
                            }
                        }
                    };
                    children.push(match (run, scatter) {
                        (Some(v), false) => Child::Known(v),
                        (Some(v), true) => Child::KnownScatter(v),
                        (None, false) => Child::Shadow,
                        (None, true) => Child::Scatter,
                    });
                }
            }
        }
        // With a cache, the pixel's owner decides the ambient terms.
        let deferred = (self.irradiance.is_some())
            .then(|| self.defer_ambient(task, &shaded, &requests, &mut children));
        if deferred.is_none() {
            let n = requests.len();
            self.spawn_hemispheres(&key, task, &shaded.ambient, n, &mut children, ctx);
        }
        requests.clear();
        REQUESTS.set(requests);
        if let Some(caster) = &whole {
            tally.charge(caster.queries.get(), ctx);
        }
        if !scheduled.is_empty() {
            ctx.spawn_dd(DdTask::Shadows(scheduled));
        }
        let attenuation = crate::render::medium::participate(
            self.renderer.options(),
            shaded.extinction,
            &shaded.medium,
            hit.t,
        );
        // Where every child's value is known here (a processor holding the
        // scene ran its bundles and no ray was spawned), the node's value
        // goes as the merge would compute it.
        let base = self.ambient_base(&shaded);
        let record = if let Some(d) = deferred {
            d.record(shaded.base, children, attenuation, hit.t)
        } else if whole.is_some() && children.iter().all(|c| !c.awaited()) {
            Record::Value(evaluate(base, &children, &[], attenuation))
        } else {
            Record::Shaded {
                base,
                children,
                attenuation,
            }
        };
        ctx.emit_result(dest, RtResult { key, record });
    }

    /// Traces a ray as far as the local cells allow: finished, or the job
    /// to migrate.
    pub(super) fn advance_ray(
        &self,
        mut job: RayJob,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<RayJob> {
        // Where the processor's hierarchy leaves the answer undecided, the
        // walk starts from its nearest hit and passes the leaves it holds.
        let mut local = None;
        if job.cursor == TraceCursor::default() {
            if let Some(c) = self.whole_caster(ctx.proc_id()) {
                let t = &job.task;
                let hit = c.intersect(&t.ray, t.tmin, t.tmax);
                ctx.charge(Work::TraceLocal, 1);
                let task = job.task;
                self.finish_ray(job.key, &task, hit, data, ctx);
                return None;
            }
            if let Some(l) = self.local_path(ctx.proc_id(), data) {
                let t = &job.task;
                match l.intersect(&t.ray, t.tmin, t.tmax) {
                    Judged::Decided(hit) => {
                        ctx.charge(Work::TraceLocal, 1);
                        let task = job.task;
                        self.finish_ray(job.key, &task, hit, data, ctx);
                        return None;
                    }
                    Judged::Partly(hit) => job.cursor.best = hit,
                }
                local = Some(l);
            }
        }
        let tested = |leaf| local.as_ref().is_some_and(|l| l.holds(leaf));
        let octree = self.renderer.octree();
        let shared = self.renderer.scene().table();
        let t = &job.task;
        let (mut leaves, mut tests) = (0u64, 0u64);
        let partial = octree.intersect_partial_past(
            shared,
            &t.ray,
            t.tmin,
            t.tmax,
            &mut job.cursor,
            |l| {
                leaves += 1;
                tests += octree.leaf_objects(l).len() as u64;
                Self::cell(data, l)
            },
            &tested,
        );
        ctx.charge(Work::TraceLeaves, leaves);
        ctx.charge(Work::TraceObjects, tests);
        self.note_walked(ctx, leaves);
        match partial {
            Partial::Blocked(leaf) => {
                job.next = Some(leaf);
                Some(job)
            }
            Partial::Done(hit) => {
                let task = job.task;
                self.finish_ray(job.key, &task, hit, data, ctx);
                None
            }
        }
    }

    /// `bundle`'s value through `caster`, with this thread's scratch
    /// space, its counts added to `counts`.
    #[inline]
    fn run_bundle<C: RayCaster>(
        &self,
        caster: &C,
        bundle: &ShadowBundle,
        counts: &mut ShadowCounts,
    ) -> Color {
        SCRATCH.with_borrow_mut(|scratch| {
            run_shadow_bundle(&self.renderer.context(), caster, bundle, scratch, counts)
        })
    }

    /// Runs a shadow bundle as far as the local cells allow: finished, or
    /// the bundle to migrate with its recorded answers. Fresh queries try
    /// the processor's hierarchy first: it decides many, and where it does
    /// not, the walk passes the leaves it holds (a bundle whose data was
    /// selected because it leaves the processor's cells too: the leaves it
    /// crosses before it leaves them).
    pub(super) fn advance_shadow(
        &self,
        mut job: ShadowDp,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<ShadowDp> {
        let replay = std::mem::take(&mut job.replay);
        let local = self.local_path(ctx.proc_id(), data);
        match self.try_shadow(&job.bundle, replay, local.as_ref(), data, ctx) {
            ShadowRun::Done(value) => {
                ctx.emit_result(
                    Addr::Proc(ctx.origin()),
                    RtResult {
                        key: job.key,
                        record: Record::Value(value),
                    },
                );
                None
            }
            ShadowRun::Blocked(replay, leaf) => {
                job.replay = replay;
                job.next = Some(leaf);
                Some(job)
            }
        }
    }

    /// [`Self::advance_shadow`] on a bundle by reference, emitting nothing:
    /// its value, or where it stopped. `local`: the processor's hierarchy
    /// ([`Self::local_path`]).
    pub(super) fn try_shadow(
        &self,
        bundle: &ShadowBundle,
        replay: Replay,
        local: Option<&LocalPath<'_>>,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> ShadowRun {
        let octree = self.renderer.octree();
        let shared = self.renderer.scene().table();
        if !replay.answers.is_empty() || replay.cursor != TraceCursor::default() {
            ctx.charge(Work::ShadowRestarts, 1);
        }
        let fresh = replay.answers.is_empty() && replay.cursor == TraceCursor::default();
        if let Some(caster) = self.whole_caster(ctx.proc_id()).filter(|_| fresh) {
            // Everything is here: the sequential renderer's path.
            let mut counts = ShadowCounts::default();
            let value = self.run_bundle(&caster, bundle, &mut counts);
            ctx.charge(Work::TraceLeaves, 0);
            ctx.charge(Work::TraceObjects, 0);
            ctx.charge(Work::TraceLocal, caster.queries.get());
            charge_shadow(ctx, &counts);
            return ShadowRun::Done(value);
        }
        let visits = std::cell::Cell::new((0u64, 0u64));
        let memo = CellMemo::new(data, self, ctx.proc_id());
        let recording = if self.holds_everything(ctx.proc_id()) {
            Recording::Off
        } else if fresh {
            Recording::Deferred
        } else {
            Recording::On
        };
        let local = local.map(|l| l as &dyn LocalQueries);
        let caster = PartialCaster::new(
            octree,
            shared,
            |l| {
                let (a, b) = visits.get();
                visits.set((a + 1, b + octree.leaf_objects(l).len() as u64));
                memo.get(l)
            },
            replay,
            local,
        )
        .recording(recording);
        let mut counts = ShadowCounts::default();
        let value = self.run_bundle(&caster, bundle, &mut counts);
        let (leaves, tests) = visits.get();
        ctx.charge(Work::TraceLeaves, leaves);
        ctx.charge(Work::TraceObjects, tests);
        self.note_walked(ctx, leaves);
        ctx.charge(Work::TraceLocal, caster.local_answers.get());
        if let Some(leaf) = caster.blocked() {
            if caster.replayable() {
                return ShadowRun::Blocked(caster.into_replay(), leaf);
            }
            // Run again from the start, recording the answers up to the
            // same block (the same queries, the same answers); its work
            // and its uses of the cache are counted once, above.
            let again = PartialCaster::new(
                octree,
                shared,
                |l| data.peek(&l).and_then(super::tasks::Item::cell),
                Replay::default(),
                local,
            );
            self.run_bundle(&again, bundle, &mut ShadowCounts::default());
            debug_assert_eq!(again.blocked(), Some(leaf));
            return ShadowRun::Blocked(again.into_replay(), leaf);
        }
        charge_shadow(ctx, &counts);
        ShadowRun::Done(value)
    }
}

/// What running a shadow bundle here came to.
pub(super) enum ShadowRun {
    /// Finished: its (weighted) value.
    Done(Color),
    /// It needs a leaf held elsewhere: the answers recorded so far, and
    /// the leaf.
    Blocked(Replay, NodeId),
}

/// The work of the shadow bundles one step ran through the renderer's
/// hierarchy ([`RtWorkload::whole_caster`]), charged once: what each
/// bundle's own charges add up to.
#[derive(Default)]
struct WholeTally {
    spawned: u64,
    counts: ShadowCounts,
}

impl WholeTally {
    /// Charges the bundles (`queries`: the shadow rays they cast).
    fn charge(&self, queries: u64, ctx: &mut Ctx<RtWorkload>) {
        if self.spawned == 0 {
            return;
        }
        let c = &self.counts;
        for (kind, units) in [
            (Work::ShadowSpawned, self.spawned),
            (Work::ShadowBundlesInline, self.spawned),
            (Work::TraceLeaves, 0),
            (Work::TraceObjects, 0),
            (Work::TraceLocal, queries),
            (Work::ShadowRetired, self.spawned),
            (Work::ShadowBundles, c.bundles),
            (Work::ShadowPatches, c.patches),
            (Work::ShadowTested, c.tested),
            (Work::ShadowEstimated, c.estimated),
            (Work::ShadowUnoccluded, c.unoccluded),
            (Work::ShadowSegments, c.transparent_segments),
        ] {
            ctx.charge(kind, units);
        }
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
