//! The octree's compact copy of the scene's polygons, laid out for the
//! intersection loop.
//!
//! A polygon's triangles are stored in pairs, structure of arrays
//! (`v[vertex][axis][lane]`), so the watertight test runs on two triangles at
//! once with packed double-precision arithmetic, and the ray's axis
//! permutation is an address offset rather than a shuffle. A polygon with an
//! odd number of triangles repeats its last triangle in the unused lane
//! (testing a triangle twice changes neither the nearest distance nor the
//! any-hit answer). Every operation of the scalar test
//! ([`crate::geometry::intersect_triangle`]) is done in the same order on the
//! same values, so each lane's result is bit for bit the scalar result.
//! Spheres and cones keep their constants next to each other (a cone's axis
//! length, direction and slope computed once, with the expressions the
//! test would use); other shapes are tested through [`Shape`] as before.

use super::robust::diff_of_products;
use super::shape::{Object, ObjectId, ObjectSet};
pub(crate) use super::tripair::{PolygonPairs, TriPair};
use crate::geometry::{
    intersect_cone_consts, intersect_sphere, sphere_normal, ConeConsts, PreparedRay, Shape,
    ShapeHit, Vec3,
};

/// Where an object's data lives: `pairs` pairs from `start` (a polygon),
/// quadric number `start` (`pairs == 0`), or nowhere (`start == NONE`:
/// test the [`Shape`]).
#[derive(Debug, Clone, Copy)]
struct PrimRef {
    start: u32,
    pairs: u32,
}

const NONE: u32 = u32::MAX;

impl Default for PrimRef {
    fn default() -> Self {
        Self {
            start: NONE,
            pairs: 0,
        }
    }
}

#[derive(Debug, Clone, Copy)]
pub(crate) enum Quadric {
    Sphere {
        center: Vec3,
        radius: f64,
        inward: bool,
    },
    Cone {
        c: ConeConsts,
        inward: bool,
    },
}

impl Quadric {
    /// Nearest hit with `tmin < t < tmax`: the shape's own test.
    #[inline]
    fn intersect(&self, pre: &PreparedRay, tmin: f64, tmax: f64) -> Option<ShapeHit> {
        match *self {
            Quadric::Sphere {
                center,
                radius,
                inward,
            } => {
                let t = intersect_sphere(&pre.ray, center, radius, tmin, tmax)?;
                Some(ShapeHit {
                    t,
                    normal: sphere_normal(pre.ray.at(t), center, inward),
                    inner: None,
                    surface: None,
                })
            }
            Quadric::Cone { ref c, inward } => {
                let (t, n) = intersect_cone_consts(&pre.ray, c, tmin, tmax)?;
                Some(ShapeHit {
                    t,
                    normal: if inward { -n } else { n },
                    inner: None,
                    surface: None,
                })
            }
        }
    }

    /// Whether it is hit with `tmin < t < tmax`.
    #[inline]
    fn occludes(&self, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool {
        match *self {
            Quadric::Sphere { center, radius, .. } => {
                intersect_sphere(&pre.ray, center, radius, tmin, tmax).is_some()
            }
            Quadric::Cone { ref c, .. } => intersect_cone_consts(&pre.ray, c, tmin, tmax).is_some(),
        }
    }
}

/// The nearest `t` with `tmin < t < tmax` among the triangles of `pairs`
/// (the first of equal ones: the smallest `t` in range).
#[inline(always)]
fn nearest_pair_hit(tr: &TriRay, pairs: &[TriPair], tmin: f64, tmax: f64) -> Option<f64> {
    let mut best = tmax;
    let mut hit = false;
    for p in pairs {
        for t in pair_hits(tr, p) {
            if t > tmin && t < best {
                best = t;
                hit = true;
            }
        }
    }
    hit.then_some(best)
}

/// Whether a triangle of `pairs` is hit with `tmin < t < tmax`.
#[inline(always)]
fn any_pair_hit(tr: &TriRay, pairs: &[TriPair], tmin: f64, tmax: f64) -> bool {
    pairs.iter().any(|p| {
        let [t0, t1] = pair_hits(tr, p);
        (t0 > tmin && t0 < tmax) || (t1 > tmin && t1 < tmax)
    })
}

/// One object's intersection data as a processor's copy keeps it: what
/// [`Prims::build`] makes for the object, without the per-object tables
/// (a polygon's triangle pairs in one allocation, its normal beside them).
#[derive(Debug, Clone)]
pub(crate) enum OnePrim {
    Pairs {
        /// Read where they are by the processor's hierarchy
        /// ([`Prims::from_ones`], [`ObjectSet::polygon_pairs`]), which keeps
        /// no reference of its own.
        pairs: Box<[TriPair]>,
        normal: Vec3,
    },
    Quadric(Box<Quadric>),
    /// Tested through its [`Shape`].
    Other,
}

impl OnePrim {
    /// The data of `o`, exactly as [`Prims::build`] makes it.
    pub(crate) fn build(o: &Object) -> OnePrim {
        // A polygon's pairs straight into their one allocation (copies are
        // made by the hundred thousand when a processor reads its cells;
        // the tables of a one-object `Prims` cost three allocations more).
        if let Shape::Polygon(poly) = &o.shape {
            if !poly.tri_verts.is_empty() {
                return OnePrim::Pairs {
                    pairs: poly.tri_verts.chunks(2).map(TriPair::of).collect(),
                    normal: poly.normal,
                };
            }
        }
        let p = Prims::build(std::slice::from_ref(o));
        match p.refs[0] {
            r if r.start == NONE => OnePrim::Other,
            PrimRef { start, pairs: 0 } => OnePrim::Quadric(Box::new(p.quadrics[start as usize])),
            _ => OnePrim::Pairs {
                pairs: p.pairs.into(),
                normal: p.normals[0],
            },
        }
    }

    /// Nearest hit of a processor's copy of an object (this data, its
    /// `shape` where it keeps one) with `tmin < t < tmax`, for a ray
    /// prepared as `pre` and `tr`: what [`Prims::intersect`] answers for
    /// it. A copy without its shape is a polygon kept as its pairs, which
    /// are all its test reads.
    #[inline]
    pub(crate) fn intersect(
        &self,
        shape: Option<&Shape>,
        pre: &PreparedRay,
        tr: &TriRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        match self {
            OnePrim::Pairs { pairs, normal } => {
                nearest_pair_hit(tr, pairs, tmin, tmax).map(|t| ShapeHit {
                    t,
                    normal: *normal,
                    inner: None,
                    surface: None,
                })
            }
            OnePrim::Quadric(q) => q.intersect(pre, tmin, tmax),
            OnePrim::Other => {
                debug_assert!(shape.is_some(), "a copy without data keeps its shape");
                shape.and_then(|s| s.intersect_prepared(pre, tmin, tmax))
            }
        }
    }

    /// Whether a processor's copy of an object is hit with
    /// `tmin < t < tmax` (see [`OnePrim::intersect`]).
    #[inline]
    pub(crate) fn occludes(
        &self,
        shape: Option<&Shape>,
        pre: &PreparedRay,
        tr: &TriRay,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        match self {
            OnePrim::Pairs { pairs, .. } => any_pair_hit(tr, pairs, tmin, tmax),
            OnePrim::Quadric(q) => q.occludes(pre, tmin, tmax),
            OnePrim::Other => {
                debug_assert!(shape.is_some(), "a copy without data keeps its shape");
                shape.is_some_and(|s| s.occludes_prepared(pre, tmin, tmax))
            }
        }
    }

    /// Heap bytes (a polygon's pairs).
    pub(crate) fn memory_bytes(&self) -> usize {
        match self {
            OnePrim::Pairs { pairs, .. } => size_of_val(&**pairs),
            OnePrim::Quadric(_) => std::mem::size_of::<Quadric>(),
            OnePrim::Other => 0,
        }
    }
}

/// Per-object intersection data, indexed by object id.
#[derive(Debug, Clone, Default)]
pub(crate) struct Prims {
    refs: Vec<PrimRef>,
    pairs: Vec<TriPair>,
    /// Made from copies ([`Prims::from_ones`]): polygon `id`'s pairs are
    /// the copy's own, read through [`ObjectSet::polygon_pairs`] (`pairs`
    /// is empty; 16 bytes an object a processor's hierarchy does not hold).
    copies: bool,
    quadrics: Vec<Quadric>,
    /// Polygon normals (what a hit reports), zero for other shapes, where
    /// the polygons are tested through this data ([`Prims::build`], the
    /// octree's); empty otherwise, and when made from copies, whose own
    /// normals a hit reports ([`ObjectSet::polygon_normal`]: 24 bytes an
    /// object a processor's hierarchy does not hold twice).
    normals: Vec<Vec3>,
    /// What a hit on a polygon reports of it (normal and surface word),
    /// zero for other shapes, for a hierarchy that tests the polygons in
    /// its leaves' blocks ([`Prims::build_without_polygons`]); empty
    /// otherwise. 8 bytes an object more than a normal alone: the octree,
    /// whose hits come through [`Prims::intersect`], keeps `normals`.
    polygon_hits: Vec<PolygonHit>,
}

/// What a hit on a polygon reports of it besides its distance: its normal
/// and its surface word ([`crate::geometry::Hit::surface`]). One 32-byte
/// entry, read once a traversal knows a ray's nearest hit: with the
/// surface word here, a hit on a triangle of a leaf's blocks reads no
/// `Object` (136 bytes, scattered through memory). The words in a table
/// of their own beside the normals cost a second cache miss per hit: the
/// primary packets ran at 0.552 of Embree's streams that way against
/// 0.567 this way (medians of four rounds alternating).
#[derive(Debug, Clone, Copy, Default)]
#[repr(align(32))]
pub(crate) struct PolygonHit {
    pub(crate) normal: Vec3,
    pub(crate) surface: u32,
}

impl PolygonHit {
    fn of(o: &Object, normal: Vec3) -> PolygonHit {
        let (material, flat) = o.surface_at(None);
        PolygonHit {
            normal,
            surface: crate::geometry::Hit::surface_word(material, flat),
        }
    }
}

/// The per-ray constants of the watertight test, with the origin permuted
/// like the axes (`o[0]` is the origin's `kx` coordinate, and so on).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriRay {
    pub(crate) k: [usize; 3],
    pub(crate) o: [f64; 3],
    pub(crate) sx: f64,
    pub(crate) sy: f64,
    pub(crate) sz: f64,
}

impl TriRay {
    #[inline]
    pub(crate) fn new(pre: &PreparedRay) -> Self {
        let o = pre.ray.origin.to_array();
        Self {
            k: [pre.kx, pre.ky, pre.kz],
            o: [o[pre.kx], o[pre.ky], o[pre.kz]],
            sx: pre.sx,
            sy: pre.sy,
            sz: pre.sz,
        }
    }
}

impl Prims {
    /// The data for `objects` (in id order).
    pub(crate) fn build(objects: &[Object]) -> Prims {
        Self::build_inner(objects, true)
    }

    /// [`Prims::build`] for a hierarchy that keeps its polygons' triangles
    /// itself (in its leaves' blocks): polygons are tested through their
    /// shapes (the same answers) where asked for by id, and keep what a
    /// hit reports of them ([`PolygonHit`]).
    pub(crate) fn build_without_polygons(objects: &[Object]) -> Prims {
        Self::build_inner(objects, false)
    }

    fn build_inner(objects: &[Object], polygons: bool) -> Prims {
        // Reserved exactly: growing the pair array from empty cost a
        // hierarchy build about 15% of its time.
        let pairs = if polygons {
            objects
                .iter()
                .map(|o| match &o.shape {
                    Shape::Polygon(poly) => poly.tri_verts.len().div_ceil(2),
                    _ => 0,
                })
                .sum()
        } else {
            0
        };
        let mut p = Prims {
            refs: Vec::with_capacity(objects.len()),
            pairs: Vec::with_capacity(pairs),
            quadrics: Vec::new(),
            normals: Vec::with_capacity(if polygons { objects.len() } else { 0 }),
            polygon_hits: Vec::with_capacity(if polygons { 0 } else { objects.len() }),
            copies: false,
        };
        for o in objects {
            let quadric = match &o.shape {
                Shape::Polygon(poly) if !polygons => {
                    p.refs.push(PrimRef::default());
                    p.polygon_hits.push(PolygonHit::of(o, poly.normal));
                    continue;
                }
                Shape::Polygon(poly) if !poly.tri_verts.is_empty() => {
                    let start = p.pairs.len() as u32;
                    p.pairs.extend(poly.tri_verts.chunks(2).map(TriPair::of));
                    p.refs.push(PrimRef {
                        start,
                        pairs: p.pairs.len() as u32 - start,
                    });
                    p.normals.push(poly.normal);
                    continue;
                }
                &Shape::Sphere {
                    center,
                    radius,
                    inward,
                } => Some(Quadric::Sphere {
                    center,
                    radius,
                    inward,
                }),
                &Shape::Cone {
                    p0,
                    p1,
                    r0,
                    r1,
                    inward,
                } => Some(Quadric::Cone {
                    c: ConeConsts::new(p0, p1, r0, r1),
                    inward,
                }),
                _ => None,
            };
            // Quadrics and the shapes tested through `Shape` report no
            // stored normal.
            p.refs.push(match quadric {
                Some(q) => {
                    p.quadrics.push(q);
                    PrimRef {
                        start: p.quadrics.len() as u32 - 1,
                        pairs: 0,
                    }
                }
                None => PrimRef::default(),
            });
            if polygons {
                p.normals.push(Vec3::ZERO);
            } else {
                p.polygon_hits.push(PolygonHit::default());
            }
        }
        p
    }

    /// The data of several copies laid end to end, in order (object `i`
    /// of the result is the `i`-th copy): what [`Prims::build`] makes for
    /// their objects, answering bit for bit as it does. A polygon's pairs
    /// are not copied: the result shares each copy's own (a processor's
    /// hierarchy over its resident copies would otherwise hold a second
    /// copy of every triangle, 144 bytes per quadrilateral).
    pub(crate) fn from_ones<'a, I>(parts: I) -> Prims
    where
        I: IntoIterator<Item = &'a OnePrim>,
        I::IntoIter: ExactSizeIterator,
    {
        let parts = parts.into_iter();
        let n = parts.len();
        // Allocated once, to the size: a processor's kernel holds it for
        // the whole run.
        let mut p = Prims {
            refs: Vec::with_capacity(n),
            pairs: Vec::new(),
            quadrics: Vec::new(),
            normals: Vec::new(),
            polygon_hits: Vec::new(),
            copies: true,
        };
        for q in parts {
            match q {
                OnePrim::Pairs { pairs, .. } => {
                    p.refs.push(PrimRef {
                        start: 0,
                        pairs: pairs.len() as u32,
                    });
                }
                OnePrim::Quadric(q) => {
                    p.refs.push(PrimRef {
                        start: p.quadrics.len() as u32,
                        pairs: 0,
                    });
                    p.quadrics.push(**q);
                }
                OnePrim::Other => {
                    p.refs.push(PrimRef::default());
                }
            }
        }
        p.quadrics.shrink_to_fit();
        p
    }

    /// Polygon `id`'s pairs (`r` is its reference): this data's, or where
    /// it was made from copies, the copy's.
    #[inline(always)]
    fn pairs_of<'a, O: ObjectSet + ?Sized>(
        &'a self,
        objects: &'a O,
        id: ObjectId,
        r: PrimRef,
    ) -> &'a [TriPair] {
        if self.copies {
            let pairs = objects.polygon_pairs(id as usize).0;
            debug_assert_eq!(
                pairs.len(),
                r.pairs as usize,
                "a hierarchy made from copies is queried with those copies"
            );
            pairs
        } else {
            &self.pairs[r.start as usize..(r.start + r.pairs) as usize]
        }
    }

    /// What a hit on polygon `id` reports of it (data built by
    /// [`Prims::build_without_polygons`]).
    #[inline(always)]
    pub(crate) fn polygon_hit(&self, id: ObjectId) -> PolygonHit {
        self.polygon_hits[id as usize]
    }

    /// Where [`Prims::polygon_hit`] reads (for a prefetch; any id may be
    /// given).
    #[inline(always)]
    pub(crate) fn polygon_hit_ptr(&self, id: ObjectId) -> *const u8 {
        self.polygon_hits.as_ptr().wrapping_add(id as usize).cast()
    }

    /// The normal a hit on polygon `id` of `objects` reports: this data's,
    /// or where it was made from copies, the copy's.
    #[inline(always)]
    fn normal_in<O: ObjectSet + ?Sized>(&self, objects: &O, id: ObjectId) -> Vec3 {
        if self.copies {
            objects.polygon_normal(id as usize)
        } else {
            self.normals[id as usize]
        }
    }

    /// True if this data was built for `objects` (callers fall back to the
    /// shapes otherwise).
    #[inline]
    pub(crate) fn matches<O: ObjectSet + ?Sized>(&self, objects: &O) -> bool {
        self.refs.len() == objects.count()
    }

    /// Heap bytes (pairs read from copies are counted with the copies).
    pub(crate) fn memory_bytes(&self) -> usize {
        self.refs.capacity() * size_of::<PrimRef>()
            + self.pairs.capacity() * size_of::<TriPair>()
            + self.quadrics.capacity() * size_of::<Quadric>()
            + self.normals.capacity() * size_of::<Vec3>()
            + self.polygon_hits.capacity() * size_of::<PolygonHit>()
    }

    /// Nearest hit of object `id` with `tmin < t < tmax`: exactly
    /// `objects[id].shape.intersect_prepared(pre, tmin, tmax)`.
    #[inline(always)]
    pub(crate) fn intersect<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        id: ObjectId,
        pre: &PreparedRay,
        tr: &TriRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        let r = self.refs[id as usize];
        if r.pairs == 0 {
            return self.intersect_other(objects, id, r, pre, tmin, tmax);
        }
        let pairs = self.pairs_of(objects, id, r);
        nearest_pair_hit(tr, pairs, tmin, tmax).map(|t| ShapeHit {
            t,
            normal: self.normal_in(objects, id),
            inner: None,
            surface: None,
        })
    }

    /// [`Prims::intersect`] of a quadric or another shape (out of line: the
    /// polygons' test is the one inlined into the traversals).
    #[inline(never)]
    fn intersect_other<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        id: ObjectId,
        r: PrimRef,
        pre: &PreparedRay,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        match self.quadrics.get(r.start as usize) {
            Some(q) => q.intersect(pre, tmin, tmax),
            None => objects.intersect_shape(id as usize, pre, tmin, tmax),
        }
    }

    /// True if object `id` has a hit with `tmin < t < tmax`: exactly
    /// `objects[id].shape.occludes_prepared(pre, tmin, tmax)`.
    #[inline]
    pub(crate) fn occludes<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        id: ObjectId,
        pre: &PreparedRay,
        tr: &TriRay,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        let r = self.refs[id as usize];
        if r.pairs == 0 {
            return self.occludes_other(objects, id, r, pre, tmin, tmax);
        }
        any_pair_hit(tr, self.pairs_of(objects, id, r), tmin, tmax)
    }

    /// [`Prims::occludes`] of a quadric or another shape (out of line).
    #[inline(never)]
    fn occludes_other<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        id: ObjectId,
        r: PrimRef,
        pre: &PreparedRay,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        match self.quadrics.get(r.start as usize) {
            Some(q) => q.occludes(pre, tmin, tmax),
            None => objects.occludes_shape(id as usize, pre, tmin, tmax),
        }
    }
}

/// Object tests for one ray: through the compact data where it was built
/// for `objects`, else through the shapes.
pub(crate) struct Tester<'a, O: ObjectSet + ?Sized = [Object]> {
    prims: Option<&'a Prims>,
    objects: &'a O,
    pre: &'a PreparedRay,
    tr: TriRay,
}

impl<'a, O: ObjectSet + ?Sized> Tester<'a, O> {
    #[inline]
    pub(crate) fn new(prims: &'a Prims, objects: &'a O, pre: &'a PreparedRay) -> Self {
        Tester {
            prims: prims.matches(objects).then_some(prims),
            objects,
            pre,
            tr: TriRay::new(pre),
        }
    }

    /// The compact data and this ray's constants for the triangle test,
    /// where the data was built for the objects.
    #[inline(always)]
    pub(crate) fn compact(&self) -> Option<(&'a Prims, &TriRay)> {
        self.prims.map(|p| (p, &self.tr))
    }

    /// [`OnePrim::intersect`] for this ray.
    #[inline]
    pub(crate) fn intersect_one(
        &self,
        prim: &OnePrim,
        shape: Option<&Shape>,
        tmin: f64,
        tmax: f64,
    ) -> Option<ShapeHit> {
        prim.intersect(shape, self.pre, &self.tr, tmin, tmax)
    }

    /// [`OnePrim::occludes`] for this ray.
    #[inline]
    pub(crate) fn occludes_one(
        &self,
        prim: &OnePrim,
        shape: Option<&Shape>,
        tmin: f64,
        tmax: f64,
    ) -> bool {
        prim.occludes(shape, self.pre, &self.tr, tmin, tmax)
    }

    /// Nearest hit of object `id` with `tmin < t < tmax`.
    #[inline(always)]
    pub(crate) fn intersect(&self, id: ObjectId, tmin: f64, tmax: f64) -> Option<ShapeHit> {
        match self.prims {
            Some(p) => p.intersect(self.objects, id, self.pre, &self.tr, tmin, tmax),
            None => self
                .objects
                .intersect_shape(id as usize, self.pre, tmin, tmax),
        }
    }

    /// True if object `id` has a hit with `tmin < t < tmax`.
    #[inline]
    pub(crate) fn occludes(&self, id: ObjectId, tmin: f64, tmax: f64) -> bool {
        match self.prims {
            Some(p) => p.occludes(self.objects, id, self.pre, &self.tr, tmin, tmax),
            None => self
                .objects
                .occludes_shape(id as usize, self.pre, tmin, tmax),
        }
    }
}

/// Two lanes of doubles; the operators work lane by lane (compiled to
/// packed SSE2 arithmetic, each lane rounded exactly like the scalar code).
#[derive(Debug, Clone, Copy)]
struct F2([f64; 2]);

impl F2 {
    #[inline(always)]
    fn splat(x: f64) -> F2 {
        F2([x, x])
    }
}

impl std::ops::Sub for F2 {
    type Output = F2;
    #[inline(always)]
    fn sub(self, o: F2) -> F2 {
        F2([self.0[0] - o.0[0], self.0[1] - o.0[1]])
    }
}

impl std::ops::Add for F2 {
    type Output = F2;
    #[inline(always)]
    fn add(self, o: F2) -> F2 {
        F2([self.0[0] + o.0[0], self.0[1] + o.0[1]])
    }
}

impl std::ops::Mul for F2 {
    type Output = F2;
    #[inline(always)]
    fn mul(self, o: F2) -> F2 {
        F2([self.0[0] * o.0[0], self.0[1] * o.0[1]])
    }
}

impl std::ops::Div for F2 {
    type Output = F2;
    #[inline(always)]
    fn div(self, o: F2) -> F2 {
        F2([self.0[0] / o.0[0], self.0[1] / o.0[1]])
    }
}

/// The watertight test ([`crate::geometry::intersect_triangle`]) on both
/// triangles of a pair without the range test: each lane's `t`, or NaN where
/// the ray misses the triangle.
#[inline(always)]
fn pair_hits(tr: &TriRay, p: &TriPair) -> [f64; 2] {
    #[cfg(target_arch = "x86_64")]
    if let Some(t) = sse2::pair_hits(tr, p) {
        return t;
    }
    pair_hits_lanes(tr, p)
}

/// [`pair_hits`] lane by lane in portable code (out of line on x86_64,
/// where it only takes the rare pairs with an edge function of zero).
#[cfg_attr(target_arch = "x86_64", inline(never))]
#[cfg_attr(not(target_arch = "x86_64"), inline(always))]
fn pair_hits_lanes(tr: &TriRay, p: &TriPair) -> [f64; 2] {
    let [kx, ky, kz] = tr.k;
    let [a, b, c] = &p.v;
    let (ox, oy, oz) = (F2::splat(tr.o[0]), F2::splat(tr.o[1]), F2::splat(tr.o[2]));
    let (sx, sy) = (F2::splat(tr.sx), F2::splat(tr.sy));
    let (a_x, a_y, a_z) = (F2(a[kx]) - ox, F2(a[ky]) - oy, F2(a[kz]) - oz);
    let (b_x, b_y, b_z) = (F2(b[kx]) - ox, F2(b[ky]) - oy, F2(b[kz]) - oz);
    let (c_x, c_y, c_z) = (F2(c[kx]) - ox, F2(c[ky]) - oy, F2(c[kz]) - oz);
    let ax = a_x - sx * a_z;
    let ay = a_y - sy * a_z;
    let bx = b_x - sx * b_z;
    let by = b_y - sy * b_z;
    let cx = c_x - sx * c_z;
    let cy = c_y - sy * c_z;
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let mut out = [f64::NAN; 2];
    for (l, out) in out.iter_mut().enumerate() {
        let (mut u, mut v, mut w) = (u.0[l], v.0[l], w.0[l]);
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Recompute the lane's edge functions with exact signs, as the
            // scalar test does.
            let (ax, ay, bx, by, cx, cy) = (ax.0[l], ay.0[l], bx.0[l], by.0[l], cx.0[l], cy.0[l]);
            u = diff_of_products(cx, by, cy, bx);
            v = diff_of_products(ax, cy, ay, cx);
            w = diff_of_products(bx, ay, by, ax);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            continue;
        }
        let det = u + v + w;
        if det == 0.0 {
            continue;
        }
        let az = tr.sz * a_z.0[l];
        let bz = tr.sz * b_z.0[l];
        let cz = tr.sz * c_z.0[l];
        *out = (u * az + v * bz + w * cz) / det;
    }
    out
}

/// The common case of the pair test with explicit SSE2 (part of every
/// x86_64 target): the three edge functions of both triangles, computed
/// with the scalar test's operations in its order; where none of them is
/// zero (the scalar test recomputes those with exact signs), the scalar
/// test's answer for both lanes: a miss where a lane's signs are mixed or
/// its determinant is zero, else its distance, with the same operations
/// in the same order. Anything else goes through the full test.
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use std::arch::x86_64::*;

    use super::{TriPair, TriRay};

    #[inline(always)]
    pub(super) fn pair_hits(tr: &TriRay, p: &TriPair) -> Option<[f64; 2]> {
        let [kx, ky, kz] = tr.k;
        let [a, b, c] = &p.v;
        // SAFETY: SSE2 is enabled on every x86_64 target (the intrinsics
        // need no runtime check); each load reads one `[f64; 2]`.
        unsafe {
            let ld = |x: &[f64; 2]| _mm_loadu_pd(x.as_ptr());
            let (ox, oy, oz) = (
                _mm_set1_pd(tr.o[0]),
                _mm_set1_pd(tr.o[1]),
                _mm_set1_pd(tr.o[2]),
            );
            let (sx, sy) = (_mm_set1_pd(tr.sx), _mm_set1_pd(tr.sy));
            let a_z = _mm_sub_pd(ld(&a[kz]), oz);
            let b_z = _mm_sub_pd(ld(&b[kz]), oz);
            let c_z = _mm_sub_pd(ld(&c[kz]), oz);
            let ax = _mm_sub_pd(_mm_sub_pd(ld(&a[kx]), ox), _mm_mul_pd(sx, a_z));
            let ay = _mm_sub_pd(_mm_sub_pd(ld(&a[ky]), oy), _mm_mul_pd(sy, a_z));
            let bx = _mm_sub_pd(_mm_sub_pd(ld(&b[kx]), ox), _mm_mul_pd(sx, b_z));
            let by = _mm_sub_pd(_mm_sub_pd(ld(&b[ky]), oy), _mm_mul_pd(sy, b_z));
            let cx = _mm_sub_pd(_mm_sub_pd(ld(&c[kx]), ox), _mm_mul_pd(sx, c_z));
            let cy = _mm_sub_pd(_mm_sub_pd(ld(&c[ky]), oy), _mm_mul_pd(sy, c_z));
            let u = _mm_sub_pd(_mm_mul_pd(cx, by), _mm_mul_pd(cy, bx));
            let v = _mm_sub_pd(_mm_mul_pd(ax, cy), _mm_mul_pd(ay, cx));
            let w = _mm_sub_pd(_mm_mul_pd(bx, ay), _mm_mul_pd(by, ax));
            let z = _mm_setzero_pd();
            let zero = _mm_or_pd(
                _mm_or_pd(_mm_cmpeq_pd(u, z), _mm_cmpeq_pd(v, z)),
                _mm_cmpeq_pd(w, z),
            );
            if _mm_movemask_pd(zero) != 0 {
                return None;
            }
            let neg = _mm_or_pd(
                _mm_or_pd(_mm_cmplt_pd(u, z), _mm_cmplt_pd(v, z)),
                _mm_cmplt_pd(w, z),
            );
            let pos = _mm_or_pd(
                _mm_or_pd(_mm_cmpgt_pd(u, z), _mm_cmpgt_pd(v, z)),
                _mm_cmpgt_pd(w, z),
            );
            // No edge function is zero (nor NaN: a NaN compares unequal
            // and neither below nor above zero, so it is no miss here and
            // goes on to a NaN distance, as in the scalar test).
            let mut miss = _mm_and_pd(neg, pos);
            if _mm_movemask_pd(miss) == 3 {
                return Some([f64::NAN; 2]);
            }
            let det = _mm_add_pd(_mm_add_pd(u, v), w);
            miss = _mm_or_pd(miss, _mm_cmpeq_pd(det, z));
            let sz = _mm_set1_pd(tr.sz);
            let (az, bz, cz) = (
                _mm_mul_pd(sz, a_z),
                _mm_mul_pd(sz, b_z),
                _mm_mul_pd(sz, c_z),
            );
            let num = _mm_add_pd(
                _mm_add_pd(_mm_mul_pd(u, az), _mm_mul_pd(v, bz)),
                _mm_mul_pd(w, cz),
            );
            let t = _mm_div_pd(num, det);
            let t = _mm_or_pd(
                _mm_andnot_pd(miss, t),
                _mm_and_pd(miss, _mm_set1_pd(f64::NAN)),
            );
            let mut out = [0.0; 2];
            _mm_storeu_pd(out.as_mut_ptr(), t);
            Some(out)
        }
    }
}
