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
//! * any hit: if every non-empty leaf along the whole segment is resident
//!   here, every object that could block it is local. (A local object
//!   blocking the ray would block it for the octree too, but a segment
//!   that leaves the processor's cells is walked without asking.)
//!
//! Which leaves the ray enters is decided by the octree's own traversal
//! ([`Octree::leaves_along_all`]), skipping subtrees the processor owns
//! whole. Otherwise the query falls back to the leaf-by-leaf walk, which
//! reads cached leaves and migrates. Pictures do not change.

use super::cells::{HeldObject, LeafObjects};
use super::octree::{NodeId, Octree};
use crate::geometry::prims::Prims;
use crate::geometry::{Bvh, Hit, Object, ObjectTable, Ray};
use crate::scene::ObjectId;

/// See the module documentation.
#[derive(Debug, Default)]
pub struct LocalKernel {
    /// Copies of the resident objects, ascending by id (so the hierarchy's
    /// tie rule, the smaller index, is the octree's, the smaller id).
    objects: Vec<Object>,
    /// `ids[k]`: the scene's id of `objects[k]`.
    ids: Vec<ObjectId>,
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
        enum Src<'a> {
            Copy(&'a HeldObject),
            Shared(&'a Object),
        }
        let mut found: Vec<(ObjectId, Src<'_>)> = Vec::new();
        for c in cells {
            for (j, &id) in c.ids().iter().enumerate() {
                match c.own(j) {
                    Some(h) => found.push((id, Src::Copy(h))),
                    None => {
                        if let Some(o) = shared.get(id) {
                            found.push((id, Src::Shared(o)));
                        }
                    }
                }
            }
        }
        found.sort_by_key(|f| f.0);
        found.dedup_by_key(|f| f.0);
        // Shared objects (instances) have no compact data: one built for
        // each says so.
        let own: Vec<Prims> = found
            .iter()
            .filter_map(|(_, s)| match s {
                Src::Shared(o) => Some(Prims::build(std::slice::from_ref(*o))),
                Src::Copy(_) => None,
            })
            .collect();
        let mut own_iter = own.iter();
        let mut parts: Vec<&Prims> = Vec::with_capacity(found.len());
        let mut objects = Vec::with_capacity(found.len());
        let mut ids = Vec::with_capacity(found.len());
        for (id, s) in &found {
            match s {
                Src::Copy(h) => {
                    let (p, one) = h.parts();
                    parts.push(p);
                    objects.push(one[0].clone());
                }
                Src::Shared(o) => {
                    parts.push(own_iter.next().expect("one per shared object"));
                    objects.push((*o).clone());
                }
            }
            ids.push(*id);
        }
        let prims = Prims::concat(parts);
        let bvh = Bvh::build_with(&objects, prims);
        LocalKernel { objects, ids, bvh }
    }

    /// Objects in the kernel.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Heap bytes of the kernel (its copies' structs and intersection data
    /// and the hierarchy; the polygons' vertices are counted by their
    /// capacity).
    pub fn memory_bytes(&self) -> usize {
        self.objects.capacity() * std::mem::size_of::<Object>()
            + self
                .objects
                .iter()
                .map(|o| match &o.shape {
                    crate::geometry::Shape::Polygon(p) => {
                        p.vertices.capacity() * std::mem::size_of::<crate::geometry::Vec3>()
                    }
                    _ => 0,
                })
                .sum::<usize>()
            + self.ids.capacity() * std::mem::size_of::<ObjectId>()
            + self.bvh.memory_bytes()
    }

    /// The kernel as queries read it.
    pub fn hierarchy(&self) -> Hierarchy<'_> {
        Hierarchy {
            bvh: &self.bvh,
            objects: &self.objects,
            ids: Some(&self.ids),
        }
    }
}

/// A hierarchy over the objects a processor holds resident, as queries
/// read it: a [`LocalKernel`], or the whole scene's hierarchy where the
/// processor holds every object.
#[derive(Clone, Copy, Debug)]
pub struct Hierarchy<'a> {
    pub bvh: &'a Bvh,
    /// What the hierarchy was built over.
    pub objects: &'a [Object],
    /// `ids[k]`: the scene's id of `objects[k]` (ascending); `None`: `k`.
    pub ids: Option<&'a [ObjectId]>,
}

impl Hierarchy<'_> {
    /// The octree's nearest hit with `tmin < t < tmax` (see
    /// [`Octree::intersect_partial`]) if this processor's objects decide
    /// it: `owned(subtree)` vouches for subtrees whose every non-empty leaf
    /// is resident here, `resident(leaf)` for a leaf. `None`: undecided.
    pub fn intersect(
        &self,
        octree: &Octree,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        owned: &dyn Fn(NodeId) -> bool,
        resident: &dyn Fn(NodeId) -> bool,
    ) -> Option<Option<Hit>> {
        let hit = self.bvh.intersect(self.objects, ray, tmin, tmax);
        let cut = hit.map_or(tmax, |h| h.t);
        if !octree.leaves_along_all(ray, tmin, tmax, cut, owned, resident) {
            return None;
        }
        Some(hit.map(|mut h| {
            if let Some(ids) = self.ids {
                h.object = ids[h.object as usize];
            }
            h
        }))
    }

    /// The octree's any-hit answer (see [`Octree::occluded_partial`]) if
    /// this processor's objects decide it (see [`Hierarchy::intersect`]).
    #[allow(clippy::too_many_arguments)]
    pub fn occluded(
        &self,
        octree: &Octree,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
        owned: &dyn Fn(NodeId) -> bool,
        resident: &dyn Fn(NodeId) -> bool,
    ) -> Option<bool> {
        let ignore = match self.ids {
            None => ignore,
            Some(ids) => ignore.and_then(|id| ids.binary_search(&id).ok().map(|k| k as ObjectId)),
        };
        // Judged first: where the segment leaves the processor's cells the
        // walk answers, and tracing here too would be work thrown away.
        octree
            .leaves_along_all(ray, tmin, tmax, tmax, owned, resident)
            .then(|| self.bvh.occluded(self.objects, ray, tmin, tmax, ignore))
    }
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
