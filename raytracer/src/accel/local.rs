//! A processor's own hierarchy over the objects it holds resident: the
//! fast kernel ([`Bvh`]) for the rays that stay among its cells.
//!
//! A migrating ray walks the octree leaf by leaf so that it can stop at the
//! first leaf held elsewhere and resume there. Most rays never leave their
//! processor's cells (on one processor, none does), and for them the walk
//! is pure overhead: the octree visits every leaf along the ray and tests
//! each leaf's objects, where the hierarchy of the sequential renderer
//! tests a handful. So a fresh query is first answered from the hierarchy
//! of the processor's resident objects, and the answer is kept only if the
//! octree would have given the same one:
//!
//! * nearest hit: the octree's answer is the nearest hit among all objects
//!   (equal distances: the smaller id), since the leaf holding the nearest
//!   hit point lists its object. If every non-empty leaf the ray enters up
//!   to the local answer's distance is resident here, every object that
//!   could be hit before it is local, and the local answer is the octree's.
//! * any hit: a local object blocking the segment blocks it for the
//!   octree too (the leaf holding the blocking point lists it), wherever
//!   the segment goes. An unblocked answer needs every non-empty leaf
//!   along the whole segment resident here; where the segment leaves the
//!   processor's cells, the walk that follows passes the resident leaves
//!   without testing their objects again
//!   ([`Octree::occluded_partial_past`]).
//!
//! Which leaves the ray enters is decided by the octree's own traversal
//! ([`Octree::leaves_along_all`]), skipping subtrees the processor owns
//! whole. Otherwise the query falls back to the leaf-by-leaf walk, which
//! reads cached leaves and migrates. Pictures do not change.

use std::sync::Arc;

use super::cells::{HeldObject, LeafObjects};
use super::octree::{NodeId, NodeTest, Octree};
use super::rank::RankedSet;
use crate::geometry::prims::Prims;
use crate::geometry::{Bvh, Hit, Object, ObjectTable, Ray};
use crate::scene::ObjectId;

/// See the module documentation.
#[derive(Debug, Default)]
pub struct LocalKernel {
    /// The resident objects, ascending by id (so the hierarchy's tie rule,
    /// the smaller index, is the octree's, the smaller id): the copies the
    /// processor's leaves hold (shared with them, not copied again), and
    /// copies of the instances they list.
    objects: Vec<Arc<HeldObject>>,
    /// `ids[k]`: the scene's id of `objects[k]`.
    ids: Vec<ObjectId>,
    /// The same ids, for an id's place among them in one lookup (every
    /// shadow bundle asks for the surface its rays leave).
    places: RankedSet,
    bvh: Bvh,
}

impl LocalKernel {
    /// The kernel over the objects of `cells` (a processor's resident
    /// leaves): their copies, and the objects every processor holds that
    /// they list (instances) from `shared`.
    pub fn build<'a>(
        cells: impl IntoIterator<Item = &'a LeafObjects>,
        shared: ObjectTable<'_>,
    ) -> LocalKernel {
        // An object is listed by every leaf it overlaps (the studio's 4,602
        // objects, 73,856 times): its first listing's copy is taken, found
        // with a bit per id, and the copies sorted by id once each.
        let cells: Vec<&LeafObjects> = cells.into_iter().collect();
        let ids_listed = cells.iter().flat_map(|c| c.ids().iter().copied());
        let mut copied = NodeSet::new(ids_listed.max().map_or(0, |m| m as usize + 1));
        let mut copies: Vec<(ObjectId, &Arc<HeldObject>)> = Vec::new();
        let mut instances: Vec<ObjectId> = Vec::new();
        for c in &cells {
            for (j, &id) in c.ids().iter().enumerate() {
                match c.own_shared(j) {
                    Some(h) if !copied.has(id) => {
                        copied.set(id);
                        copies.push((id, h));
                    }
                    Some(_) => {}
                    None => instances.push(id),
                }
            }
        }
        // An instance listed in many leaves is copied once.
        instances.sort_unstable();
        instances.dedup();
        instances.retain(|&id| !copied.has(id));
        let mut found: Vec<(ObjectId, Arc<HeldObject>)> =
            Vec::with_capacity(copies.len() + instances.len());
        found.extend(copies.into_iter().map(|(id, h)| (id, Arc::clone(h))));
        found.extend(
            instances
                .into_iter()
                .filter_map(|id| Some((id, HeldObject::of(shared.get(id)?)))),
        );
        // Every id once: an unstable sort is deterministic.
        found.sort_unstable_by_key(|f| f.0);
        let (ids, objects): (Vec<ObjectId>, Vec<Arc<HeldObject>>) = found.into_iter().unzip();
        let prims = Prims::from_ones(objects.iter().map(|h| h.prim()));
        let bvh = Bvh::build_with(&objects[..], prims);
        let places = RankedSet::new(ids.iter().copied());
        LocalKernel {
            objects,
            ids,
            places,
            bvh,
        }
    }

    /// Objects in the kernel.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Heap bytes of the kernel: its lists and the hierarchy with its
    /// intersection data; the copies it shares with the leaves are
    /// counted with them (instances' copies are not counted).
    pub fn memory_bytes(&self) -> usize {
        self.objects.capacity() * std::mem::size_of::<Arc<HeldObject>>()
            + self.ids.capacity() * std::mem::size_of::<ObjectId>()
            + self.places.memory_bytes()
            + self.bvh.memory_bytes()
    }

    /// The kernel as queries read it.
    pub fn hierarchy(&self) -> Hierarchy<'_> {
        Hierarchy {
            bvh: &self.bvh,
            objects: HierarchyObjects::Copies(&self.objects),
            ids: Some(LocalIds {
                ids: &self.ids,
                places: &self.places,
            }),
        }
    }
}

/// What a [`Hierarchy`] was built over.
#[derive(Clone, Copy, Debug)]
pub enum HierarchyObjects<'a> {
    /// The scene's objects (the whole scene's hierarchy).
    Scene(&'a [Object]),
    /// A processor's copies (its [`LocalKernel`]).
    Copies(&'a [Arc<HeldObject>]),
}

/// A hierarchy over the objects a processor holds resident, as queries
/// read it: a [`LocalKernel`], or the whole scene's hierarchy where the
/// processor holds every object.
#[derive(Clone, Copy, Debug)]
pub struct Hierarchy<'a> {
    pub bvh: &'a Bvh,
    /// What the hierarchy was built over.
    pub objects: HierarchyObjects<'a>,
    /// The scene's ids of the objects; `None`: an object's index is its
    /// id.
    pub ids: Option<LocalIds<'a>>,
}

/// The scene's ids of a [`LocalKernel`]'s objects.
#[derive(Clone, Copy, Debug)]
pub struct LocalIds<'a> {
    /// `ids[k]`: the scene's id of object `k` (ascending).
    pub ids: &'a [ObjectId],
    /// The same ids: `places.rank(id)` is `id`'s index in `ids`.
    pub places: &'a RankedSet,
}

impl Hierarchy<'_> {
    /// The octree's nearest hit with `tmin < t < tmax` (see
    /// [`Octree::intersect_partial`]), decided if this processor's objects
    /// decide it: `owned(subtree)` vouches for subtrees whose every
    /// non-empty leaf is resident here, `resident(leaf)` for a leaf.
    /// Undecided, the nearest hit among its objects (for the walk to
    /// start from, passing the resident leaves,
    /// [`Octree::intersect_partial_past`]).
    pub fn intersect<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        octree: &Octree,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        owned: &S,
        resident: &K,
    ) -> Judged<Option<Hit>> {
        let hit = match self.objects {
            HierarchyObjects::Scene(o) => self.bvh.intersect(o, ray, tmin, tmax),
            HierarchyObjects::Copies(o) => self.bvh.intersect(o, ray, tmin, tmax),
        };
        let hit = hit.map(|mut h| {
            if let Some(l) = self.ids {
                h.object = l.ids[h.object as usize];
            }
            h
        });
        let cut = hit.map_or(tmax, |h| h.t);
        if octree.leaves_along_all(ray, tmin, tmax, cut, owned, resident) {
            Judged::Decided(hit)
        } else {
            Judged::Partly(hit)
        }
    }

    /// The octree's any-hit answer (see [`Octree::occluded_partial`]),
    /// decided if this processor's objects decide it (see
    /// [`Hierarchy::intersect`]): where they block the segment, or where
    /// they do not and every leaf along it is theirs. Undecided, `false`:
    /// no object here blocks it.
    #[allow(clippy::too_many_arguments)]
    pub fn occluded<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        octree: &Octree,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
        owned: &S,
        resident: &K,
    ) -> Judged<bool> {
        let ignore = ignore.and_then(|id| self.index_of(id));
        self.occluded_indexed(octree, ray, tmin, tmax, ignore, owned, resident)
    }

    /// The index in this hierarchy of the scene's object `id`, if it
    /// holds it.
    pub fn index_of(&self, id: ObjectId) -> Option<ObjectId> {
        match self.ids {
            None => Some(id),
            Some(l) => l.places.rank(id).map(|k| k as ObjectId),
        }
    }

    /// Whether an object of the hierarchy other than the one of index
    /// `ignore` ([`Hierarchy::index_of`]) blocks the segment, without the
    /// judgement of the leaves along it.
    pub fn blocks(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        match self.objects {
            HierarchyObjects::Scene(o) => self.bvh.occluded(o, ray, tmin, tmax, ignore),
            HierarchyObjects::Copies(o) => self.bvh.occluded(o, ray, tmin, tmax, ignore),
        }
    }

    /// [`Hierarchy::occluded`] with the object to ignore given by its
    /// index here ([`Hierarchy::index_of`]: the many shadow rays from one
    /// point look it up once).
    #[allow(clippy::too_many_arguments)]
    pub fn occluded_indexed<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        octree: &Octree,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
        owned: &S,
        resident: &K,
    ) -> Judged<bool> {
        // A blocker here blocks the segment for the octree too, wherever
        // the segment goes: the leaf holding the blocking point lists it.
        // Only "unblocked" needs every leaf along the segment judged.
        let blocked = self.blocks(ray, tmin, tmax, ignore);
        if blocked || octree.leaves_along_all(ray, tmin, tmax, tmax, owned, resident) {
            Judged::Decided(blocked)
        } else {
            Judged::Partly(false)
        }
    }
}

/// A [`Hierarchy`]'s answer to a query: the octree's, or, where objects it
/// does not hold may change it, what its own objects answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Judged<T> {
    /// The octree's answer.
    Decided(T),
    /// Undecided: the answer over the hierarchy's objects alone.
    Partly(T),
}

/// A processor's hierarchy, as the parallel renderer keeps one per
/// processor.
#[derive(Debug)]
pub enum ProcessorKernel {
    /// It holds no object.
    Nothing,
    /// It holds every object of a scene loaded whole: the renderer's own
    /// hierarchy serves (the same objects; no second copy).
    Whole,
    /// Its own, over its resident copies.
    Own(Box<LocalKernel>),
}

/// A set of octree nodes (or of other dense ids, such as objects'), a bit
/// each.
#[derive(Debug)]
pub struct NodeSet(Vec<u64>);

impl NodeSet {
    /// The empty set over `nodes` nodes.
    pub fn new(nodes: usize) -> Self {
        NodeSet(vec![0; nodes.div_ceil(64)])
    }

    /// Whether `n` is in the set.
    #[inline]
    pub fn has(&self, n: NodeId) -> bool {
        self.0
            .get(n as usize / 64)
            .is_some_and(|w| w >> (n % 64) & 1 == 1)
    }

    /// Puts `n` in the set (a node past the end is ignored).
    pub fn set(&mut self, n: NodeId) {
        if let Some(w) = self.0.get_mut(n as usize / 64) {
            *w |= 1 << (n % 64);
        }
    }
}

/// A processor's hierarchy over the leaves it holds, resident and cached
/// (the parallel renderer grows one over its cache where the cache never
/// evicts): the kernel, and which leaves and subtrees it was built over,
/// for the judgement of [`Hierarchy::intersect`] and
/// [`Hierarchy::occluded`].
#[derive(Debug)]
pub struct GrownKernel {
    kernel: LocalKernel,
    /// The leaves it was built over.
    held: NodeSet,
    /// Nodes whose every non-empty leaf it was built over.
    covered: NodeSet,
    /// How many leaves it was built over.
    leaves: usize,
}

impl GrownKernel {
    /// The kernel over `cells` (leaf, its objects) of `octree`, with the
    /// objects every processor holds from `shared` (see
    /// [`LocalKernel::build`]).
    pub fn build<'a>(
        octree: &Octree,
        cells: impl IntoIterator<Item = (NodeId, &'a LeafObjects)>,
        shared: ObjectTable<'_>,
    ) -> GrownKernel {
        let n = octree.node_count();
        let mut held = NodeSet::new(n);
        let mut objects: Vec<&LeafObjects> = Vec::new();
        for (leaf, c) in cells {
            held.set(leaf);
            objects.push(c);
        }
        let kernel = LocalKernel::build(objects.iter().copied(), shared);
        // Children always have larger ids than their parent.
        let mut covered = NodeSet::new(n);
        for id in (0..n as NodeId).rev() {
            let all = match octree.children(id) {
                None => octree.leaf_objects(id).is_empty() || held.has(id),
                Some(ch) => ch.iter().all(|&c| covered.has(c)),
            };
            if all {
                covered.set(id);
            }
        }
        GrownKernel {
            leaves: objects.len(),
            kernel,
            held,
            covered,
        }
    }

    /// Whether it was built over `leaf`.
    #[inline]
    pub fn holds(&self, leaf: NodeId) -> bool {
        self.held.has(leaf)
    }

    /// Whether it was built over every non-empty leaf below `node`.
    #[inline]
    pub fn covers(&self, node: NodeId) -> bool {
        self.covered.has(node)
    }

    /// Whether it was built over every non-empty leaf of the octree.
    pub fn covers_all(&self) -> bool {
        self.covered.has(0)
    }

    /// Leaves it was built over.
    pub fn leaves(&self) -> usize {
        self.leaves
    }

    /// Objects in it.
    pub fn len(&self) -> usize {
        self.kernel.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kernel.is_empty()
    }

    /// Heap bytes (see [`LocalKernel::memory_bytes`]) and its node sets.
    pub fn memory_bytes(&self) -> usize {
        self.kernel.memory_bytes() + (self.held.0.capacity() + self.covered.0.capacity()) * 8
    }

    /// The kernel as queries read it.
    pub fn hierarchy(&self) -> Hierarchy<'_> {
        self.kernel.hierarchy()
    }
}

/// Per processor, where the parallel renderer keeps its grown hierarchy:
/// the latest build, the number of cached items it was built over, the
/// number at which the next one is due, and [`Grown::walked`] when it was
/// built.
#[derive(Debug, Default)]
pub struct GrownSlot {
    pub kernel: Option<std::sync::Arc<GrownKernel>>,
    pub built_over: usize,
    pub next_build: usize,
    pub walked_at_build: u64,
}

/// A processor's [`GrownSlot`] behind a lock, and the leaves its queries
/// have walked since the start of the run because it does not hold them
/// (counted without the lock: every shadow bundle adds to it).
#[derive(Debug, Default)]
pub struct Grown {
    pub slot: std::sync::Mutex<GrownSlot>,
    pub walked: std::sync::atomic::AtomicU64,
    /// The build over every non-empty leaf, once there is one: with a
    /// cache that never evicts it is never rebuilt, and its queries need
    /// no judgement (read without the lock).
    pub whole: std::sync::OnceLock<std::sync::Arc<GrownKernel>>,
    /// Pixels of the tiles the processor has traced (counted as each
    /// tile's primary rays are made): the sample its walks per pixel are
    /// projected from.
    pub pixels: std::sync::atomic::AtomicU64,
    /// Whether it has asked for the rest of the scene.
    pub asked: std::sync::atomic::AtomicBool,
}
