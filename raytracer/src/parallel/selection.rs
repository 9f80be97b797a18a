//! Data selection: the cells a demand-driven task needs that its processor
//! does not hold. A tile selects the pyramid from the eye through its
//! corners (or the leaves along its primary rays), a shadow bundle the
//! pyramid around its light ([`crate::render::light::PreparedLight`]'s
//! pyramids), clipped against the octree; with option `clip_cache` a
//! selection per (processor, cell, light) is reused, and, where the cache
//! never evicts, clipping skips the subtrees a processor already holds
//! whole.

use hybrid_sched::{Ctx, DataView};

use super::clip_memory::{hold_whole, ClipEntry};
use super::distribution::EMPTY;
use super::tasks::Tile;
use super::work::Work;
use super::workload::RtWorkload;
use crate::accel::{NodeId, Pyramid};
use crate::geometry::{Aabb, Vec3};
use crate::render::light::LightExtent;
use crate::render::{RayTask, ShadowBundle};
use crate::scene::ViewType;

impl RtWorkload {
    /// Data selection for a tile: the pyramid from the eye through the
    /// tile's corners (perspective views), else the leaves along every
    /// primary ray (which are kept for the tile's execution).
    pub(super) fn select_tile(
        &self,
        t: &Tile,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        if self.replicated() || self.all_resident(None, ctx.proc_id()) {
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
                return self.clip(&Pyramid::from_rays(self.view.vp, &dirs), local, ctx);
            }
        }
        let mut leaves = Vec::new();
        let mut visits = 0u64;
        let rays = self.compute_tile_rays(t);
        for task in rays.iter().flatten() {
            octree.for_each_leaf_along_ray(&task.ray, task.tmin, task.tmax, |leaf, _, _| {
                visits += 1;
                leaves.push(leaf);
                false
            });
        }
        // Execution (or the data-parallel fallback) on this processor takes
        // them: each primary ray is computed once.
        self.tile_rays[ctx.proc_id() % self.tile_rays.len()]
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert((t.x0, t.y0), rays);
        ctx.charge(Work::ClipNodes, visits);
        self.nonempty(leaves)
    }

    /// Notes tile `t` as taken on processor `proc` and takes the primary
    /// rays (one a pixel) its selection left, if it left them.
    pub(super) fn take_tile(&self, t: &Tile, proc: usize) -> Option<Vec<Option<RayTask>>> {
        self.note_tile(proc, t);
        let shard = &self.tile_rays[proc % self.tile_rays.len()];
        let mut left = shard.lock().unwrap_or_else(|e| e.into_inner());
        left.remove(&(t.x0, t.y0))
    }

    /// Data selection for a shadow bundle: the pyramid from the shaded
    /// point around the whole source.
    pub(super) fn select_shadow(
        &self,
        b: &ShadowBundle,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        if self.replicated() || self.shadow_all_resident(b, ctx.proc_id()) {
            return Vec::new();
        }
        if self.opts.clip_cache {
            if let Some(sel) = self.select_shadow_cached(b, local, ctx) {
                return sel;
            }
        }
        match self.shadow_pyramid(b) {
            Some(pyramid) => self.clip(&pyramid, local, ctx),
            None => Vec::new(),
        }
    }

    /// Whether a new shadow bundle should run data-parallel: too few rays to
    /// be worth clipping, or a pyramid that would not bound it (the point
    /// inside the source's box, a very wide distant source).
    pub(super) fn shadow_goes_dp(&self, b: &ShadowBundle) -> bool {
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

    /// True if every leaf a bundle confined to `bounds` (`None`: anywhere)
    /// can touch is resident on processor `proc`: its data selection would
    /// fetch nothing, so clipping is skipped.
    pub(super) fn all_resident(&self, bounds: Option<Aabb>, proc: usize) -> bool {
        if self.subtree_owner.is_empty() {
            return false;
        }
        if self.holds_everything(proc) {
            return true;
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
        let o = self.subtree_owner.get(node as usize);
        o == EMPTY || o as usize == proc
    }

    /// Whether every cell a shadow ray of `b` can enter is resident on
    /// processor `proc`: the box holding the bundle's rays (padded for the
    /// origin offsets; the whole scene for a distant source) lies in
    /// subtrees `proc` owns.
    pub(super) fn shadow_all_resident(&self, b: &ShadowBundle, proc: usize) -> bool {
        if self.holds_everything(proc) {
            return true;
        }
        let bounds = self
            .renderer
            .lights()
            .get(b.light as usize)
            .and_then(|l| l.shadow_bounds(b.point, b.offset_scale));
        self.all_resident(bounds, proc)
    }

    /// [`WorkloadOptions::clip_cache`]: the selection for every bundle from
    /// the shaded point's cell to its (finite) light. `None` to clip the
    /// bundle's own pyramid instead.
    ///
    /// With `local` (what the processor holds) and an unlimited cache, a
    /// selection found entirely local is remembered, and later bundles from
    /// the cell to the light select (and pin) nothing.
    pub(super) fn select_shadow_cached(
        &self,
        b: &ShadowBundle,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Option<Vec<NodeId>> {
        let octree = self.renderer.octree();
        let leaf = octree.find_leaf(b.point)?;
        let proc = ctx.proc_id();
        let key = (proc as u32, leaf, b.light);
        let shard = &self.clip_cache[proc % self.clip_cache.len()];
        if let Some(e) = shard.lock().ok()?.entries.get_mut(&key) {
            ctx.charge(Work::ClipReused, 1);
            // Only where nothing is ever evicted: a selection left empty
            // pins nothing, so with a budget a cell could leave before the
            // bundle runs.
            if let Some(local) = local.filter(|l| l.keeps_everything()) {
                if e.all_local || e.leaves.iter().all(|&l| self.held(local, proc, l)) {
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
        let sel = self.clip(&hull, local, ctx);
        if let Ok(mut cache) = shard.lock() {
            cache.entries.insert(
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
    /// hold, front to back: subtrees it owns entirely are not visited, nor,
    /// with option `clip_cache` and a `local` view that never evicts, the
    /// subtrees whose every non-empty leaf it holds (see
    /// [`ClipCache`](super::clip_memory::ClipCache)).
    pub(super) fn clip(
        &self,
        pyramid: &Pyramid,
        local: Option<&DataView<'_, Self>>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<NodeId> {
        let octree = self.renderer.octree();
        let me = ctx.proc_id();
        let owned = |id: NodeId| {
            let o = self.subtree_owner.get(id as usize);
            o == me as u32 || o == EMPTY
        };
        let view = local.filter(|l| self.opts.clip_cache && l.keeps_everything());
        let mut guard = view.and_then(|_| self.clip_cache[me % self.clip_cache.len()].lock().ok());
        let mut whole = guard.as_mut().map(|g| g.whole_of(me, octree.node_count()));
        let mut leaves = Vec::new();
        let wanted = |id: NodeId| {
            if owned(id) {
                return false;
            }
            if let (Some(whole), Some(view)) = (whole.as_deref_mut(), view) {
                if whole.has(id) {
                    return false;
                }
                if octree.is_leaf(id) && view.is_local(&id) {
                    hold_whole(whole, octree, id, owned);
                    return false;
                }
            }
            true
        };
        let visits = octree.clip_leaves_where(pyramid, wanted, |l| {
            if !octree.leaf_objects(l).is_empty() {
                leaves.push(l);
            }
        });
        ctx.charge(Work::ClipNodes, visits);
        leaves
    }

    pub(super) fn shadow_pyramid(&self, b: &ShadowBundle) -> Option<Pyramid> {
        self.renderer
            .lights()
            .get(b.light as usize)?
            .shadow_pyramid(b.point)
    }
}
