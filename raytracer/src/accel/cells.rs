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
//! name, material and defining numbers (a polygon's vertices after the
//! loader dropped duplicates, a sphere's centre and radius, ...); reading
//! it rebuilds each shape with the loader's constructors, which derive the
//! rest (normal, triangulation) exactly as they did from the source, and
//! rejects data no source could have made.

use rustc_hash::FxHashMap;
use std::sync::{Arc, Mutex, Weak};

use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::geometry::prims::OnePrim;
use crate::geometry::{MaterialId, Object, ObjectId, ObjectSet, Shape, Vec3};

/// See the module documentation.
#[derive(Debug, Clone)]
pub struct LeafObjects {
    ids: Box<[ObjectId]>,
    /// Per id: its copy, `None` for an object every processor holds.
    held: Box<[Option<Arc<HeldObject>>]>,
}

/// A copy of one plain surface with its intersection data.
#[derive(Debug)]
pub struct HeldObject {
    object: Object,
    prim: OnePrim,
}

impl HeldObject {
    pub(crate) fn new(mut object: Object) -> Arc<HeldObject> {
        let prim = OnePrim::build(&object);
        // A copy is only traced and shaded: a polygon is tested through its
        // intersection data alone (built from its triangles whenever it has
        // any), so its triangulation, flattened triangles and area table
        // are dropped; its vertices stay, they are what travels.
        if let Shape::Polygon(p) = &mut object.shape {
            if !p.tri_verts.is_empty() {
                p.triangles = Box::default();
                p.tri_verts = Box::default();
                p.cdf = Box::default();
            }
        }
        Arc::new(HeldObject { object, prim })
    }

    /// The copy's intersection data.
    #[inline]
    pub(crate) fn prim(&self) -> &OnePrim {
        &self.prim
    }

    /// The copy.
    pub fn object(&self) -> &Object {
        &self.object
    }

    /// Heap and inline bytes of the copy and its intersection data.
    pub fn bytes(&self) -> usize {
        let o = &self.object;
        let heap = o.name.capacity() + o.shape.heap_bytes();
        size_of::<HeldObject>() + heap + self.prim.memory_bytes()
    }
}

/// A processor's copies by index, as its hierarchy reads them.
impl ObjectSet for [Arc<HeldObject>] {
    #[inline]
    fn count(&self) -> usize {
        self.len()
    }

    #[inline]
    fn object(&self, k: usize) -> &Object {
        &self[k].object
    }
}

/// Bytes a processor's copy of `o` occupies (0 for an instance, which is
/// shared, not copied): measured from a copy's structures.
pub fn copy_bytes(o: &Object) -> usize {
    if is_plain(o) {
        HeldObject::new(o.clone()).bytes()
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
/// [`share_copies_in_process`] turned sharing on; dead entries are swept
/// when the table doubles.
struct Shared {
    live: FxHashMap<ObjectId, Weak<HeldObject>>,
    sweep_at: usize,
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
        live: FxHashMap::default(),
        sweep_at: 1024,
    });
    for (&id, c) in copies {
        t.live.insert(id, Arc::downgrade(c));
    }
}

/// A copy of object `id` as received (`w`): the process-wide one when
/// sharing is on and one is alive, else built from `w`.
fn received_copy(id: ObjectId, w: WireObject) -> Result<Arc<HeldObject>, String> {
    let mut g = SHARED_COPIES.lock().unwrap_or_else(|e| e.into_inner());
    let Some(t) = g.as_mut() else {
        drop(g);
        return object_from_wire(w).map(HeldObject::new);
    };
    if let Some(c) = t.live.get(&id).and_then(Weak::upgrade) {
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
                        .or_insert_with(|| HeldObject::new(o.clone()))
                        .clone()
                })
            })
            .collect();
        LeafObjects {
            ids: ids.into(),
            held,
        }
    }

    /// A leaf listing `ids` whose objects are not all held yet: the copies
    /// in `copies` are shared, a missing copy is made from what `make`
    /// gives for its id (an object read for this processor, moved into
    /// its copy), else from `shared` (the objects every processor holds;
    /// instances are not copied). An id found nowhere is an error.
    pub fn copy_made<E>(
        ids: &[ObjectId],
        mut make: impl FnMut(ObjectId) -> Option<Result<Object, E>>,
        shared: crate::geometry::ObjectTable<'_>,
        copies: &mut ObjectCopies,
    ) -> Result<LeafObjects, E>
    where
        E: From<String>,
    {
        let mut held = Vec::with_capacity(ids.len());
        for &id in ids {
            let copy = match copies.get(&id) {
                Some(c) => Some(c.clone()),
                None => match make(id) {
                    Some(o) => Some(HeldObject::new(o?)),
                    None => {
                        let o = shared.get(id).ok_or_else(|| {
                            E::from(format!("object {id} is neither read nor held"))
                        })?;
                        is_plain(o).then(|| HeldObject::new(o.clone()))
                    }
                },
            };
            if let Some(c) = &copy {
                copies.entry(id).or_insert_with(|| c.clone());
            }
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

fn wire_object(o: &Object) -> WireObject {
    let a = |v: Vec3| v.to_array();
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
            .map(|k| self.own(k).map(|h| wire_object(h.object())))
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
