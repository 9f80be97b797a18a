//! Primitive shapes. Data layout is the contract between the scene loaders
//! (which build shapes) and the intersection code (which tests them).
//!
//! All constructors validate their input (finite coordinates, positive
//! radii, non-degenerate polygons) and return a reason string on failure; the
//! loaders attach file and line.

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::tripair::PolygonPairs;
use super::{Aabb, PreparedRay, Ray, Vec3};

/// Index into [`Scene::materials`](crate::scene::Scene::materials).
pub type MaterialId = u32;
/// Index into [`Scene::objects`](crate::scene::Scene::objects).
pub type ObjectId = u32;

/// Objects by id: a scene's every object, or the ones a processor of a
/// distributed scene holds (see `crate::compiled`), with their ids.
#[derive(Debug, Clone, Copy)]
pub struct ObjectTable<'a> {
    objects: &'a [Object],
    /// `objects[k]` is object `ids[k]` (ascending); `None`: object `k`.
    ids: Option<&'a [ObjectId]>,
}

impl<'a> ObjectTable<'a> {
    /// Every object: object `k` is `objects[k]`.
    pub fn dense(objects: &'a [Object]) -> Self {
        ObjectTable { objects, ids: None }
    }

    /// Some objects: `objects[k]` is object `ids[k]`, ids ascending.
    pub fn sparse(objects: &'a [Object], ids: &'a [ObjectId]) -> Self {
        debug_assert_eq!(objects.len(), ids.len());
        ObjectTable {
            objects,
            ids: Some(ids),
        }
    }

    /// Object `id`, if held.
    #[inline]
    pub fn get(&self, id: ObjectId) -> Option<&'a Object> {
        match self.ids {
            None => self.objects.get(id as usize),
            Some(ids) => ids
                .binary_search(&id)
                .ok()
                .and_then(|k| self.objects.get(k)),
        }
    }

    /// The objects held, with their ids, in id order.
    pub fn iter(&self) -> impl Iterator<Item = (ObjectId, &'a Object)> + 'a {
        let ids = self.ids;
        self.objects
            .iter()
            .enumerate()
            .map(move |(k, o)| (ids.map_or(k as ObjectId, |ids| ids[k]), o))
    }
}

/// A named surface: one Radiance primitive (or one OBJ face group).
#[derive(Debug, Clone)]
pub struct Object {
    pub name: String,
    pub shape: Shape,
    pub material: MaterialId,
}

// A scene of millions of surfaces holds this struct once per surface (a
// processor's copies of polygons are smaller still: `accel::HeldObject`):
// the instance's matrices are boxed and the polygon's arrays are boxed
// slices so that it stays at 136 bytes (312 before; the MPI chapter,
// "Each rank's bound").
#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<Object>() <= 136);

/// Objects by index: what a hierarchy was built over (a slice of the
/// scene's objects, or a processor's copies, which its leaves share).
/// What a hierarchy reads of an object: its bounds, what shades a hit on
/// it, and its shape's own ray test (for objects without compact data).
pub trait ObjectSet {
    /// How many.
    fn count(&self) -> usize;
    /// The bounds of object `k < count()`: its shape's.
    fn bounds(&self, k: usize) -> Aabb;
    /// What shades a hit on object `k` ([`Object::surface_at`]).
    fn surface_at(&self, k: usize, inner: Option<u32>) -> (MaterialId, bool);
    /// Nearest hit of object `k` with `tmin < t < tmax`: its shape's
    /// [`Shape::intersect_prepared`].
    fn intersect_shape(
        &self,
        k: usize,
        pre: &PreparedRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit>;
    /// Whether object `k` is hit with `tmin < t < tmax`: its shape's
    /// [`Shape::occludes_prepared`].
    fn occludes_shape(&self, k: usize, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool;
    /// The normal a hit on polygon `k` reports (zero for other shapes).
    fn polygon_normal(&self, k: usize) -> Vec3;
    /// Polygon `k`'s triangle pairs where the set keeps them (a
    /// processor's copies do, and the hierarchy built over them reads them
    /// here instead of keeping a reference of its own); none otherwise.
    fn polygon_pairs(&self, _k: usize) -> PolygonPairs<'_> {
        PolygonPairs::default()
    }
}

impl ObjectSet for [Object] {
    #[inline]
    fn count(&self) -> usize {
        self.len()
    }

    #[inline]
    fn bounds(&self, k: usize) -> Aabb {
        self[k].shape.bounds()
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
        self[k].shape.intersect_prepared(pre, tmin, tmax)
    }

    #[inline]
    fn occludes_shape(&self, k: usize, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool {
        self[k].shape.occludes_prepared(pre, tmin, tmax)
    }

    #[inline]
    fn polygon_normal(&self, k: usize) -> Vec3 {
        match &self[k].shape {
            Shape::Polygon(p) => p.normal,
            _ => Vec3::ZERO,
        }
    }
}

/// The slice's (so that a `&Vec<Object>` can be passed as it is).
impl ObjectSet for Vec<Object> {
    #[inline]
    fn count(&self) -> usize {
        self.as_slice().count()
    }

    #[inline]
    fn bounds(&self, k: usize) -> Aabb {
        self.as_slice().bounds(k)
    }

    #[inline]
    fn surface_at(&self, k: usize, inner: Option<u32>) -> (MaterialId, bool) {
        self.as_slice().surface_at(k, inner)
    }

    #[inline]
    fn intersect_shape(
        &self,
        k: usize,
        pre: &PreparedRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        self.as_slice().intersect_shape(k, pre, tmin, tmax)
    }

    #[inline]
    fn occludes_shape(&self, k: usize, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool {
        self.as_slice().occludes_shape(k, pre, tmin, tmax)
    }

    #[inline]
    fn polygon_normal(&self, k: usize) -> Vec3 {
        self.as_slice().polygon_normal(k)
    }
}

/// A primitive surface.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A planar polygon, convex or concave, stored with its triangulation.
    Polygon(Polygon),
    /// Sphere; `inward` flips the normal (Radiance `bubble`).
    Sphere {
        center: Vec3,
        radius: f64,
        inward: bool,
    },
    /// Truncated cone from `p0` (radius `r0`) to `p1` (radius `r1`); a
    /// cylinder when `r0 == r1`. `inward` flips the normal (Radiance `cup`, `tube`).
    /// Open ended: no caps, as in Radiance.
    Cone {
        p0: Vec3,
        p1: Vec3,
        r0: f64,
        r1: f64,
        inward: bool,
    },
    /// Disk with a hole: points at distance in `[r_inner, r_outer]` from
    /// `center` in the plane through `center` with unit `normal`.
    Ring {
        center: Vec3,
        normal: Vec3,
        r_inner: f64,
        r_outer: f64,
    },
    /// A transformed reference to shared geometry. Boxed: its two
    /// matrices would make every object of a scene 152 bytes larger
    /// (instances are few, polygons many).
    Instance(Box<Instance>),
}

/// A planar polygon with at least three vertices. Its arrays are boxed
/// slices, not vectors: a polygon never grows once made, and a scene holds
/// many (32 bytes less each).
#[derive(Debug, Clone)]
pub struct Polygon {
    /// Vertices in the order given in the input (defines orientation).
    pub vertices: Box<[Vec3]>,
    /// Unit normal from the vertex order (Newell's method).
    pub normal: Vec3,
    /// Triangulation as indices into `vertices`, each triangle wound like the polygon.
    pub triangles: Box<[[u32; 3]]>,
    /// The triangles' vertices, flattened (what intersection reads: one
    /// contiguous array, no index indirection).
    pub tri_verts: Box<[[Vec3; 3]]>,
    /// Total area (sum of the triangles' areas).
    pub area: f64,
    /// Cumulative triangle areas divided by `area` (last entry 1): picks a
    /// triangle proportionally to its area when sampling.
    pub cdf: Box<[f64]>,
}

/// A similarity transform (rotation, uniform scale, mirror, translation), as
/// Radiance's `xform` allows. Distances scale by `scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// object -> world
    pub to_world: glam::DMat4,
    /// world -> object
    pub to_object: glam::DMat4,
    /// Uniform scale factor of `to_world` (always positive).
    pub scale: f64,
}

/// Geometry shared by many instances (a Radiance `instance` of an octree, or
/// a generator's repeated chair). Built once, referenced through `Arc`.
#[derive(Debug)]
pub struct InstanceGeometry {
    /// A name for statistics and messages (the source file or generator name).
    pub name: String,
    pub objects: Vec<Object>,
    /// Acceleration structure over `objects`, in object space (a
    /// hierarchy, the [`Bvh`](super::Bvh): an instance's objects are always
    /// kept together).
    pub accel: Box<dyn ObjectIndex>,
    pub bounds: Aabb,
    /// Vertex normals and (u, v) of a Radiance mesh (`.rtm`): its
    /// triangles shade smoothly and patterns see `Lu`, `Lv`.
    pub shading: Option<Arc<MeshShading>>,
    /// Indices (ascending) of the objects that are instances with a
    /// modifier of their own (not `void`): a hit inside one is shaded with
    /// that modifier, as Radiance's `o_instance` does; a hit inside any
    /// other nested instance with the material of the object hit there.
    pub modified_instances: Vec<u32>,
}

/// Per-vertex data of a triangle mesh, for shading (Radiance's `o_mesh`).
#[derive(Debug, Clone, Default)]
pub struct MeshShading {
    /// Per object of the geometry: the vertex indices of its triangle.
    pub triangles: Vec<[u32; 3]>,
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (all vertices or none).
    pub normals: Option<Vec<Vec3>>,
    /// Vertex (u, v) (all vertices or none).
    pub uv: Option<Vec<[f64; 2]>>,
}

#[derive(Debug, Clone)]
pub struct Instance {
    pub geometry: Arc<InstanceGeometry>,
    pub transform: Transform,
}

/// Nearest intersection found by a hierarchy (the octree's or a [`Bvh`](super::Bvh)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f64,
    /// `ray.at(t)`.
    pub point: Vec3,
    /// Unit geometric normal, oriented by the shape (not towards the ray).
    pub normal: Vec3,
    /// The top-level object hit.
    pub object: ObjectId,
    /// For instances: index of the hit object in the instance's geometry (its
    /// material shades the hit, or, where it is an instance itself, that of
    /// the object hit inside it: [`Hit::surface`]).
    pub inner: Option<u32>,
    /// What shading needs of the object hit: its material (an instance's:
    /// its inner object's) and whether the surface is flat (a polygon or a
    /// ring), in one word ([`Hit::material`], [`Hit::flat`]) so a hit keeps
    /// the size it had without them: every migrating ray and replayed
    /// shadow answer carries one. With it a hit is shaded by a processor
    /// that holds no copy of the object (a migrated ray's nearest hit so
    /// far, a shadow bundle's replayed answer).
    pub surface: u32,
}

/// The flat bit of [`Hit::surface`]; the material id is the rest.
const FLAT_BIT: u32 = 1 << 31;

impl Hit {
    /// The hit at distance `t` along `ray` on object `id` (`obj`), with the
    /// shape's normal, instance index and (for instances) innermost surface.
    #[inline]
    pub fn on(obj: &Object, id: ObjectId, ray: &Ray, t: f64, h: &ShapeHit) -> Hit {
        Hit::on_surface(|inner| obj.surface_at(inner), id, ray, t, h)
    }

    /// [`Hit::on`] with the object's [`Object::surface_at`] given as
    /// `surface_at` (for objects held in another form than an [`Object`]).
    #[inline]
    pub fn on_surface(
        surface_at: impl FnOnce(Option<u32>) -> (MaterialId, bool),
        id: ObjectId,
        ray: &Ray,
        t: f64,
        h: &ShapeHit,
    ) -> Hit {
        let surface = h.surface.unwrap_or_else(|| {
            let (material, flat) = surface_at(h.inner);
            Hit::surface_word(material, flat)
        });
        Hit {
            t,
            point: ray.at(t),
            normal: h.normal,
            object: id,
            inner: h.inner,
            surface,
        }
    }

    /// [`Hit::surface`] for `material` and `flat` (material ids stay below
    /// 2^31: the loaders make at most one per scene record).
    #[inline]
    pub fn surface_word(material: MaterialId, flat: bool) -> u32 {
        debug_assert!(material < FLAT_BIT);
        (material & !FLAT_BIT) | if flat { FLAT_BIT } else { 0 }
    }

    /// The material shading the hit.
    #[inline]
    pub fn material(&self) -> MaterialId {
        self.surface & !FLAT_BIT
    }

    /// Whether the surface hit is flat (a polygon or a ring).
    #[inline]
    pub fn flat(&self) -> bool {
        self.surface & FLAT_BIT != 0
    }
}

impl Object {
    /// The material shading a hit on this object and whether the surface
    /// hit is flat; `inner` is the hit's index into an instance's geometry.
    #[inline]
    pub fn surface_at(&self, inner: Option<u32>) -> (MaterialId, bool) {
        let o = match (&self.shape, inner) {
            (Shape::Instance(inst), Some(i)) => {
                inst.geometry.objects.get(i as usize).unwrap_or(self)
            }
            _ => self,
        };
        (
            o.material,
            matches!(o.shape, Shape::Polygon(_) | Shape::Ring { .. }),
        )
    }
}

/// A search structure over the objects of an instance's geometry: what
/// intersecting an instance asks of it. The [`Bvh`](super::Bvh) implements
/// it; a trait, so that shapes sit below the hierarchy that holds them (an
/// instance is a shape holding a hierarchy of shapes).
pub trait ObjectIndex: std::fmt::Debug + Send + Sync {
    /// Nearest hit with `tmin < t < tmax` among `objects` (the slice the
    /// structure was built over).
    fn intersect(&self, objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit>;
    /// True if any object other than `ignore` is hit with `tmin < t < tmax`.
    fn occluded(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool;
    /// Heap bytes the structure owns.
    fn memory_bytes(&self) -> usize;
}

/// Result of intersecting one shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeHit {
    /// Distance along the (world-space) ray.
    pub t: f64,
    /// Unit geometric normal in world space, oriented by the shape (not towards the ray).
    pub normal: Vec3,
    /// For instances: index of the hit object inside `InstanceGeometry::objects`.
    pub inner: Option<u32>,
    /// For instances: the [`Hit::surface`] of the innermost object hit,
    /// resolved through instances nested in the instance's geometry (an
    /// instance's own material is not what shades it).
    pub surface: Option<u32>,
}

// Intersection, bounds, area and sampling are implemented in `shape_impl.rs`
// alongside the constructors; see the methods on `Shape`.
#[allow(dead_code)]
fn _assert_send_sync() {
    fn f<T: Send + Sync>() {}
    f::<Shape>();
    f::<Ray>();
}
