//! One octree leaf's objects as a processor holds them: what a data item
//! of the parallel renderer carries, and what tracing over a leaf reads
//! when the scene is distributed.
//!
//! A [`LeafObjects`] lists the leaf's object ids in the octree's order and,
//! for each, either a copy of the object (a plain surface: polygon, sphere,
//! cone, ring) or nothing, for the objects every processor holds anyway
//! (instances, whose geometry is part of the replicated scene). A copy
//! ([`HeldObject`]) carries its intersection data, built with the same code
//! as the octree's ([`Prims`]), so a leaf traced from a [`LeafObjects`]
//! answers exactly as the whole scene's octree does.
//!
//! Objects that span several leaves: a processor's leaves share one copy
//! of each object ([`LeafObjects::copy_from`] takes the processor's
//! [`ObjectCopies`]); a leaf received in process shares the sender's
//! copies. A leaf on the wire carries every object it lists (a leaf is
//! self-contained, so it can be traced, cached and evicted alone); under
//! MPI (one processor per process) the receiving process reuses the copies
//! of objects it already holds, resident or brought by another leaf
//! ([`share_copies_in_process`]), so it keeps one copy per object too.
//! Copying every object into every leaf instead made the studio's one
//! processor hold 92 MB more than the whole scene (its walls and floor are
//! listed in thousands of leaves).
//!
//! On the wire (serde) a leaf is its ids and, for each plain surface, its
//! name (empty for a polygon, whose copy keeps none), material and
//! defining numbers (a polygon's vertices after the loader dropped
//! duplicates, a sphere's centre and radius, ...); reading it rebuilds
//! each shape with the loader's constructors, which derive the
//! rest (normal, triangulation) exactly as they did from the source, and
//! rejects data no source could have made.

use rustc_hash::FxHashMap;
use std::sync::{Arc, Mutex, Weak};

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::geometry::prims::{OnePrim, PolygonPairs, TriPair, TriRay};
use crate::geometry::{
    Aabb, MaterialId, Object, ObjectId, ObjectSet, PreparedRay, Shape, ShapeHit, Vec3,
};

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct LeafObjects {
    ids: Box<[ObjectId]>,
    /// Per id: its copy, `None` for an object every processor holds.
    held: Box<[Option<Arc<HeldObject>>]>,
}

/// A copy of one plain surface with its intersection data.
#[derive(Debug)]
pub struct HeldObject(Held);

/// How a copy is kept.
#[derive(Debug)]
enum Held {
    /// A polygon with triangles: tested through its pairs alone, so it
    /// keeps of its [`Object`] only what shading a hit and the wire read
    /// (its material and vertices), 80 bytes instead of the 184 of an
    /// object and its data (a processor holds copies by the hundred
    /// thousand; the MPI chapter, "Each rank's bound"). Not its name:
    /// nothing that traces or shades a polygon reads it (a name on a
    /// processor serves errors about the scene's sources, which are read
    /// before any copy is made). `prim` is always [`OnePrim::Pairs`].
    Flat {
        vertices: Vertices,
        prim: OnePrim,
        material: MaterialId,
    },
    /// Any other surface, whole, with its data.
    Whole(Box<(Object, OnePrim)>),
}

#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<HeldObject>() <= 80);

/// A polygon copy's vertices: where its pair of triangles holds them all
/// (a triangle or a quadrilateral, the usual polygon of a large scene),
/// which corner of the pair each is, 3 bits a vertex; else its own list.
#[derive(Debug)]
enum Vertices {
    InPair { n: u8, corners: u16 },
    Own(Box<[Vec3]>),
}

impl Vertices {
    /// `vertices` as the polygon's `pairs` hold them, when they do bit
    /// for bit, else kept.
    fn of(vertices: &[Vec3], pairs: &[TriPair]) -> Vertices {
        let same =
            |a: Vec3, b: Vec3| a.to_array().map(f64::to_bits) == b.to_array().map(f64::to_bits);
        let find = |v: Vec3| (0..6).find(|&c| same(pairs[0].vertex(c / 3, c % 3), v));
        if vertices.len() <= 4 && pairs.len() == 1 {
            let mut corners = 0u16;
            let all = vertices.iter().enumerate().all(|(i, &v)| match find(v) {
                Some(c) => {
                    corners |= (c as u16) << (3 * i);
                    true
                }
                None => false,
            });
            if all {
                return Vertices::InPair {
                    n: vertices.len() as u8,
                    corners,
                };
            }
        }
        Vertices::Own(vertices.into())
    }

    /// The vertices in their order (`pairs`: the polygon's).
    fn each<'a>(&'a self, pairs: &'a [TriPair]) -> impl Iterator<Item = Vec3> + 'a {
        let (n, own) = match self {
            Vertices::InPair { n, .. } => (usize::from(*n), &[][..]),
            Vertices::Own(v) => (v.len(), &v[..]),
        };
        (0..n).map(move |i| match self {
            Vertices::InPair { corners, .. } => {
                let c = usize::from(corners >> (3 * i) & 7);
                pairs[0].vertex(c / 3, c % 3)
            }
            Vertices::Own(_) => own[i],
        })
    }

    /// Heap bytes.
    fn heap_bytes(&self) -> usize {
        match self {
            Vertices::InPair { .. } => 0,
            Vertices::Own(v) => size_of_val(&**v),
        }
    }
}

impl HeldObject {
    pub(crate) fn new(object: Object) -> Arc<HeldObject> {
        let held = match Self::flat(&object) {
            Ok(flat) => flat,
            Err(prim) => Held::Whole(Box::new((object, prim))),
        };
        Arc::new(HeldObject(held))
    }

    /// [`HeldObject::new`] of a clone of `object`, without the clone
    /// where the copy is a polygon kept as its pairs: the object's name,
    /// triangulation and flattened triangles, which the copy drops, are
    /// not copied first (a processor makes its copies by the thousand
    /// before its first step; the studio's second processor of two took
    /// 4.5 ms to copy its 2,958 objects into 16,698 leaves).
    pub(crate) fn of(object: &Object) -> Arc<HeldObject> {
        let held = match Self::flat(object) {
            Ok(flat) => flat,
            Err(prim) => Held::Whole(Box::new((object.clone(), prim))),
        };
        Arc::new(HeldObject(held))
    }

    /// The copy of a polygon with triangles, whose intersection data is
    /// then always its pairs, or `Err` with the intersection data of any
    /// other object (kept whole with it). A copy is only traced and
    /// shaded: a polygon is tested through its intersection data alone,
    /// so its triangulation, flattened triangles, area table and normal
    /// are dropped; its vertices stay, they are what travels (as the
    /// corners of its pair where that holds them all).
    fn flat(object: &Object) -> Result<Held, OnePrim> {
        let prim = OnePrim::build(object);
        let vertices = match (&object.shape, &prim) {
            (Shape::Polygon(p), OnePrim::Pairs { pairs, .. }) if !p.tri_verts.is_empty() => {
                Vertices::of(&p.vertices, pairs)
            }
            _ => return Err(prim),
        };
        Ok(Held::Flat {
            vertices,
            prim,
            material: object.material,
        })
    }

    /// The copy's intersection data.
    #[inline]
    pub(crate) fn prim(&self) -> &OnePrim {
        match &self.0 {
            Held::Flat { prim, .. } => prim,
            Held::Whole(w) => &w.1,
        }
    }

    /// The copy's shape, where it keeps one (not a polygon kept as its
    /// pairs).
    #[inline]
    pub(crate) fn shape(&self) -> Option<&Shape> {
        match &self.0 {
            Held::Flat { .. } => None,
            Held::Whole(w) => Some(&w.0.shape),
        }
    }

    /// What shades a hit on the copy ([`Object::surface_at`]).
    #[inline]
    pub fn surface_at(&self, inner: Option<u32>) -> (MaterialId, bool) {
        match &self.0 {
            Held::Flat { material, .. } => (*material, true),
            Held::Whole(w) => w.0.surface_at(inner),
        }
    }

    /// The copy's name (the source's), `None` for a polygon's, which keeps
    /// none.
    pub fn name(&self) -> Option<&str> {
        match &self.0 {
            Held::Flat { .. } => None,
            Held::Whole(w) => Some(&w.0.name),
        }
    }

    /// The copy's material.
    pub fn material(&self) -> MaterialId {
        match &self.0 {
            Held::Flat { material, .. } => *material,
            Held::Whole(w) => w.0.material,
        }
    }

    /// A polygon's vertices (as the source gave them, duplicates dropped).
    pub fn vertices(&self) -> Option<Vec<Vec3>> {
        match &self.0 {
            Held::Flat { vertices, prim, .. } => Some(vertices.each(flat_pairs(prim)).collect()),
            Held::Whole(w) => match &w.0.shape {
                Shape::Polygon(p) => Some(p.vertices.to_vec()),
                _ => None,
            },
        }
    }

    /// The copy's bounds: its shape's.
    pub fn bounds(&self) -> Aabb {
        match &self.0 {
            Held::Flat { vertices, prim, .. } => Aabb::from_points(vertices.each(flat_pairs(prim))),
            Held::Whole(w) => w.0.shape.bounds(),
        }
    }

    /// Heap and inline bytes of the copy and its intersection data.
    pub fn bytes(&self) -> usize {
        let heap = match &self.0 {
            Held::Flat { vertices, .. } => vertices.heap_bytes(),
            Held::Whole(w) => {
                size_of::<(Object, OnePrim)>() + w.0.name.capacity() + w.0.shape.heap_bytes()
            }
        };
        size_of::<HeldObject>() + heap + self.prim().memory_bytes()
    }
}

/// A flat copy's pairs (its data is always pairs).
#[inline]
fn flat_pairs(prim: &OnePrim) -> &[TriPair] {
    match prim {
        OnePrim::Pairs { pairs, .. } => pairs,
        _ => &[],
    }
}

/// A processor's copies by index, as its hierarchy reads them.
impl ObjectSet for [Arc<HeldObject>] {
    #[inline]
    fn count(&self) -> usize {
        self.len()
    }

    #[inline]
    fn bounds(&self, k: usize) -> Aabb {
        self[k].bounds()
    }

    #[inline]
    fn surface_at(&self, k: usize, inner: Option<u32>) -> (MaterialId, bool) {
        self[k].surface_at(inner)
    }

    #[inline]
    fn intersect_shape(
        &self,
        k: usize,
        pre: &PreparedRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        let h = &self[k];
        h.prim()
            .intersect(h.shape(), pre, &TriRay::new(pre), tmin, tmax)
    }

    #[inline]
    fn occludes_shape(&self, k: usize, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool {
        let h = &self[k];
        h.prim()
            .occludes(h.shape(), pre, &TriRay::new(pre), tmin, tmax)
    }

    #[inline]
    fn polygon_normal(&self, k: usize) -> Vec3 {
        match self[k].prim() {
            OnePrim::Pairs { normal, .. } => *normal,
            _ => Vec3::ZERO,
        }
    }

    #[inline]
    fn polygon_pairs(&self, k: usize) -> PolygonPairs<'_> {
        PolygonPairs(flat_pairs(self[k].prim()))
    }
}

/// Bytes a processor's copy of `o` occupies (0 for an instance, which is
/// shared, not copied): measured from a copy's structures.
pub fn copy_bytes(o: &Object) -> usize {
    if is_plain(o) {
        HeldObject::of(o).bytes()
    } else {
        0
    }
}

/// Rough memory footprint of one object (its struct plus heap data).
pub fn object_bytes(o: &Object) -> usize {
    std::mem::size_of::<Object>() + o.name.len() + o.shape.heap_bytes()
}

/// One processor's copies by object id, shared by the leaves it builds.
pub type ObjectCopies = FxHashMap<ObjectId, Arc<HeldObject>>;

/// The copies alive in this process by object id, when
/// [`share_copies_in_process`] turned sharing on: the copies offered (a
/// processor's resident ones, alive for the whole run) in two sorted
/// lists, 12 bytes a copy (a hash map of them took 8.9 MB of a rank's
/// 281 MB on the 1.5M city), and the copies received since in a map whose
/// dead entries are swept when it doubles.
struct Shared {
    offered_ids: Box<[ObjectId]>,
    offered: Box<[Weak<HeldObject>]>,
    live: FxHashMap<ObjectId, Weak<HeldObject>>,
    sweep_at: usize,
}

impl Shared {
    fn get(&self, id: ObjectId) -> Option<Arc<HeldObject>> {
        let offered = self.offered_ids.binary_search(&id).ok();
        offered
            .and_then(|k| self.offered[k].upgrade())
            .or_else(|| self.live.get(&id).and_then(Weak::upgrade))
    }
}

static SHARED_COPIES: Mutex<Option<Shared>> = Mutex::new(None);

/// Shares copies process-wide from now on: leaves read from the wire reuse
/// the copies of objects this process holds, and `copies` (the resident
/// ones) are offered to them. For a process that runs one processor of
/// one scene (an MPI rank): object ids name the same object everywhere in
/// it.
pub fn share_copies_in_process(copies: &ObjectCopies) {
    let mut g = SHARED_COPIES.lock().unwrap_or_else(|e| e.into_inner());
    let t = g.get_or_insert_with(|| Shared {
        offered_ids: Box::default(),
        offered: Box::default(),
        live: FxHashMap::default(),
        sweep_at: 1024,
    });
    // Offered again (another processor in this process): the newer copy
    // of an id wins, as inserting into a map would.
    let mut all: Vec<(ObjectId, Weak<HeldObject>)> = copies
        .iter()
        .map(|(&id, c)| (id, Arc::downgrade(c)))
        .collect();
    all.extend(t.offered_ids.iter().copied().zip(t.offered.iter().cloned()));
    // Stable: for an id offered twice the newer entry comes first.
    all.sort_by_key(|e| e.0);
    all.dedup_by_key(|e| e.0);
    t.offered_ids = all.iter().map(|e| e.0).collect();
    t.offered = all.into_iter().map(|e| e.1).collect();
}

/// A copy of object `id` as received (`w`): the process-wide one when
/// sharing is on and one is alive, else built from `w`.
fn received_copy(id: ObjectId, w: WireObject) -> Result<Arc<HeldObject>, String> {
    let mut g = SHARED_COPIES.lock().unwrap_or_else(|e| e.into_inner());
    let Some(t) = g.as_mut() else {
        drop(g);
        return object_from_wire(w).map(HeldObject::new);
    };
    if let Some(c) = t.get(id) {
        return Ok(c);
    }
    let c = HeldObject::new(object_from_wire(w)?);
    t.live.insert(id, Arc::downgrade(&c));
    if t.live.len() >= t.sweep_at {
        t.live.retain(|_, w| w.strong_count() > 0);
        t.sweep_at = (2 * t.live.len()).max(1024);
    }
    Ok(c)
}

/// Whether a processor keeps its own copy of `o` in the leaves it holds
/// (plain surfaces) or uses the replicated one (instances).
fn is_plain(o: &Object) -> bool {
    !matches!(o.shape, Shape::Instance(_))
}

impl LeafObjects {
    /// A leaf listing `ids` without copies: each object is read through
    /// the scene's table, as the objects every processor holds are (for
    /// a processor that holds the scene itself, loaded whole).
    pub fn listing(ids: &[ObjectId]) -> LeafObjects {
        LeafObjects {
            ids: ids.into(),
            held: vec![None; ids.len()].into(),
        }
    }

    /// A leaf listing `ids` (its objects in the octree's order, ids into
    /// `objects`), sharing the copies in `copies` and adding the missing
    /// ones.
    pub fn copy_from(
        ids: &[ObjectId],
        objects: &[Object],
        copies: &mut ObjectCopies,
    ) -> LeafObjects {
        Self::copy_with(ids, |id| &objects[id as usize], copies)
    }

    /// [`LeafObjects::copy_from`] with each object found by `object`.
    pub fn copy_with<'o>(
        ids: &[ObjectId],
        object: impl Fn(ObjectId) -> &'o Object,
        copies: &mut ObjectCopies,
    ) -> LeafObjects {
        let held = ids
            .iter()
            .map(|&id| {
                let o = object(id);
                is_plain(o).then(|| {
                    copies
                        .entry(id)
                        .or_insert_with(|| HeldObject::of(o))
                        .clone()
                })
            })
            .collect();
        LeafObjects {
            ids: ids.into(),
            held,
        }
    }

    /// A leaf listing `ids` of a processor that made its copies as it read
    /// its part: the copies in `copies` are shared, a missing one is made
    /// from `shared` (the objects every processor holds; instances are not
    /// copied). An id found in neither is an error.
    pub fn copy_held(
        ids: &[ObjectId],
        shared: crate::geometry::ObjectTable<'_>,
        copies: &mut ObjectCopies,
    ) -> Result<LeafObjects, String> {
        let mut held = Vec::with_capacity(ids.len());
        for &id in ids {
            let copy = match copies.get(&id) {
                Some(c) => Some(c.clone()),
                None => {
                    let o = shared
                        .get(id)
                        .ok_or_else(|| format!("object {id} is neither read nor held"))?;
                    let c = is_plain(o).then(|| HeldObject::of(o));
                    if let Some(c) = &c {
                        copies.insert(id, c.clone());
                    }
                    c
                }
            };
            held.push(copy);
        }
        Ok(LeafObjects {
            ids: ids.into(),
            held: held.into(),
        })
    }

    /// The leaf's object ids, in the octree's order.
    pub fn ids(&self) -> &[ObjectId] {
        &self.ids
    }

    /// The copies held (plain surfaces; instances are not copied), in the
    /// leaf's order.
    pub fn copies(&self) -> impl Iterator<Item = &Arc<HeldObject>> + '_ {
        self.held.iter().flatten()
    }

    /// The copy of the leaf's `k`-th object, `None` for a shared one.
    #[inline]
    pub fn own(&self, k: usize) -> Option<&HeldObject> {
        self.own_shared(k).map(|h| &**h)
    }

    /// [`LeafObjects::own`] as the leaves hold it, to be held once more.
    #[inline]
    pub fn own_shared(&self, k: usize) -> Option<&Arc<HeldObject>> {
        self.held[k].as_ref()
    }

    /// Bytes of the leaf's own lists (ids, references to copies), not
    /// counting the copies, which leaves share.
    pub fn list_bytes(&self) -> usize {
        size_of_val(&*self.ids) + size_of_val(&*self.held)
    }
}

/// A plain surface on the wire.
#[derive(Serialize, Deserialize)]
struct WireObject {
    name: String,
    material: MaterialId,
    shape: WireShape,
}

#[derive(Serialize, Deserialize)]
enum WireShape {
    Polygon(Vec<[f64; 3]>),
    Sphere {
        center: [f64; 3],
        radius: f64,
        inward: bool,
    },
    Cone {
        p0: [f64; 3],
        p1: [f64; 3],
        r0: f64,
        r1: f64,
        inward: bool,
    },
    Ring {
        center: [f64; 3],
        normal: [f64; 3],
        r_inner: f64,
        r_outer: f64,
    },
}

#[derive(Serialize, Deserialize)]
struct Wire {
    ids: Vec<ObjectId>,
    /// Per id: the surface, or `None` for an object every processor holds.
    objects: Vec<Option<WireObject>>,
}

fn wire_object(h: &HeldObject) -> WireObject {
    let a = |v: Vec3| v.to_array();
    let o = match &h.0 {
        Held::Flat {
            vertices,
            prim,
            material,
        } => {
            return WireObject {
                name: String::new(),
                material: *material,
                shape: WireShape::Polygon(vertices.each(flat_pairs(prim)).map(a).collect()),
            }
        }
        Held::Whole(w) => &w.0,
    };
    let shape = match &o.shape {
        Shape::Polygon(p) => WireShape::Polygon(p.vertices.iter().map(|&v| a(v)).collect()),
        &Shape::Sphere {
            center,
            radius,
            inward,
        } => WireShape::Sphere {
            center: a(center),
            radius,
            inward,
        },
        &Shape::Cone {
            p0,
            p1,
            r0,
            r1,
            inward,
        } => WireShape::Cone {
            p0: a(p0),
            p1: a(p1),
            r0,
            r1,
            inward,
        },
        &Shape::Ring {
            center,
            normal,
            r_inner,
            r_outer,
        } => WireShape::Ring {
            center: a(center),
            normal: a(normal),
            r_inner,
            r_outer,
        },
        Shape::Instance(_) => unreachable!("instances are shared, never copied"),
    };
    WireObject {
        name: o.name.clone(),
        material: o.material,
        shape,
    }
}

fn object_from_wire(w: WireObject) -> Result<Object, String> {
    let v = Vec3::from_array;
    let shape = match w.shape {
        WireShape::Polygon(vs) => Shape::polygon(vs.into_iter().map(v).collect())?,
        WireShape::Sphere {
            center,
            radius,
            inward,
        } => Shape::sphere(v(center), radius, inward)?,
        WireShape::Cone {
            p0,
            p1,
            r0,
            r1,
            inward,
        } => Shape::cone(v(p0), v(p1), r0, r1, inward)?,
        WireShape::Ring {
            center,
            normal,
            r_inner,
            r_outer,
        } => {
            // Validated by the constructor; the stored (already unit)
            // normal is kept as it was, not normalised a second time.
            Shape::ring(v(center), v(normal), r_inner, r_outer)?;
            Shape::Ring {
                center: v(center),
                normal: v(normal),
                r_inner,
                r_outer,
            }
        }
    };
    Ok(Object {
        name: w.name,
        shape,
        material: w.material,
    })
}

impl Serialize for LeafObjects {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let objects = (0..self.ids.len())
            .map(|k| self.own(k).map(wire_object))
            .collect();
        Wire {
            ids: self.ids.to_vec(),
            objects,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for LeafObjects {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let w = Wire::deserialize(d)?;
        if w.objects.len() != w.ids.len() {
            return Err(D::Error::custom(format!(
                "a leaf lists {} objects but carries {}",
                w.ids.len(),
                w.objects.len()
            )));
        }
        let mut held = Vec::with_capacity(w.ids.len());
        for (id, o) in w.ids.iter().zip(w.objects) {
            held.push(match o {
                None => None,
                Some(o) => Some(
                    received_copy(*id, o)
                        .map_err(|e| D::Error::custom(format!("object {id}: {e}")))?,
                ),
            });
        }
        Ok(LeafObjects {
            ids: w.ids.into(),
            held: held.into(),
        })
    }
}
