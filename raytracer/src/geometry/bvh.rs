//! A bounding volume hierarchy over a set of objects.
//!
//! The octree stays what the paper made it: the division of the scene into
//! cells, and the structure a resumable query's progress is counted in. For
//! rays whose whole path is in one set of objects (the sequential renderer,
//! a whole scene, the shared geometry of instances), this hierarchy answers the same queries with fewer steps:
//! four-wide nodes (Embree's layout) built with the binned surface area
//! heuristic ([`Builder`]), each holding its four children's boxes (in
//! single precision, rounded outwards) so that all are tested at once,
//! four lanes side by side: in single precision for nearest hits
//! ([`single`], conservative), in double precision for any hits; the
//! nearest child entered is visited first. Measured (`hybrid-rt bench
//! --embree`, the studio as 48,684 triangles, one core): the wide nodes
//! trace primary rays about twice as fast as binary ones, shadow rays about
//! 1.3 times; the build takes a little under twice Embree's time (0.53 to
//! 0.57 of its speed, 2026-12-04, five rounds; the book's benchmark
//! chapter).
//!
//! A leaf's polygons are tested four triangles at a time ([`leaf`]'s
//! blocks, Embree's leaf layout), each lane with the pair test's
//! operations; its other objects through [`Tester`].
//!
//! **Same answers as the octree.** A node is only a filter: the objects it
//! lets through are tested with the same operations ([`Tester`], or a
//! block's lanes), and the answer
//! (the nearest hit, the smaller id of equal ones; any hit) does not depend
//! on the order objects are tested in. Every box is enlarged by the
//! octree's margin (`1e-9` of the scene's size), far beyond the rounding of
//! the slab test, then rounded outwards to single precision, so no object a ray hits is ever filtered out: rays on box
//! faces, grazing rays and rays along an axis included (a zero direction
//! component gives an infinite inverse; the `0 * inf` NaN of a ray exactly
//! on a box plane leaves that axis unconstrained).

mod binning;
mod leaf;
mod packet;
mod single;

pub(crate) use packet::PerRay;
pub use packet::{Segment, PACKET};

use std::mem::MaybeUninit;

use super::prims::{Prims, Tester, TriRay};
use super::shape::{Hit, InstanceGeometry, Object, ObjectId, ObjectIndex, ObjectSet};
use super::{Aabb, PreparedRay, Ray, Vec3};

/// Largest number of objects in a leaf.
const MAX_LEAF: usize = 8;
/// Bins per axis of the binned surface area heuristic (a power of two:
/// bin positions are masked with `BINS - 1`).
const BINS: usize = 16;
const _: () = assert!(BINS.is_power_of_two());
/// Cost of visiting a node (two box tests) relative to testing one
/// object. Measured (`hybrid-rt bench`, studio and Cornell box, 512x512):
/// 1.0 gave 1.38x and 0.88x the octree's rate, 0.5 1.64x and 1.08x, 0.25
/// no better than 0.5.
const NODE_COST: f64 = 0.5;
/// Depth below which the build splits by count (halving, so at most 32
/// levels more).
const SAH_DEPTH: u32 = 48;
/// Size of the traversal stack: at least the tree's depth.
const STACK: usize = 96;
/// Trees at most this deep are traversed with a smaller stack (a
/// traversal's stack is zeroed for every ray: 4.6 kB for [`STACK`], 1.9 kB
/// for this). Each wide level leaves at most three children pending.
const SHALLOW: usize = 40;

/// Asks the processor to fetch the cache line at `p` (a hint: any
/// address may be given).
#[inline(always)]
fn prefetch(p: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a hint, which reads nothing and faults on no address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Four children, the traversal's node: [`Node`]'s layout four lanes wide
/// (`b[axis][0]` the lower corners, `b[axis][1]` the upper, each
/// `[child 0, .., child 3]`). Built by collapsing the binary tree: each
/// wide node takes a binary node's children and opens the largest internal
/// one until it has four (Embree's "wide nodes": half the levels, the four
/// box tests side by side). Unused children have empty boxes.
///
/// The boxes are single precision, each rounded outwards from the exact
/// double-precision union (lower corners down, upper corners up), so a
/// node is only ever larger than what it holds and filters out no object
/// a ray could hit; the any-hit traversal's slab test widens them to
/// double precision, the nearest-hit traversal's runs in single precision
/// with conservative per-ray constants ([`single`]). A node is 128 bytes instead of 224 (Embree's nodes are
/// single precision too): a processor's hierarchy over 150,000 resident
/// objects took 16.8 MB of nodes in double precision.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Wide {
    b: [[[f32; 4]; 2]; 3],
    link: [u32; 4],
    count: [u32; 4],
}

impl Wide {
    const UNUSED: Wide = Wide {
        b: [[[f32::INFINITY; 4], [f32::NEG_INFINITY; 4]]; 3],
        link: [0; 4],
        count: [0; 4],
    };

    /// Byte offset in a node of axis `a`'s planes `k` (0 lower, 1 upper):
    /// a ray's entry and exit planes are located once, not at every node
    /// (an index there cost a shift per plane; measured under callgrind,
    /// 3.4% of primary rays' instructions).
    const fn plane_at(a: usize, k: usize) -> usize {
        std::mem::offset_of!(Wide, b) + (2 * a + k) * std::mem::size_of::<[f32; 4]>()
    }

    /// The four children's planes at byte offset `at`.
    ///
    /// # Safety
    /// `at` must be one [`Wide::plane_at`] made.
    #[inline(always)]
    unsafe fn planes_at(&self, at: usize) -> *const f32 {
        // SAFETY: the caller's; the planes are 16-byte aligned in the node.
        unsafe { (self as *const Wide).cast::<u8>().add(at).cast() }
    }
}

/// Per-ray constants of the slab test.
#[derive(Clone, Copy)]
struct Slab {
    o: [f64; 3],
    inv: [f64; 3],
    /// Index (0 lower, 1 upper) of the plane the ray enters by on each axis.
    near: [usize; 3],
}

impl Slab {
    #[inline(always)]
    fn new(ray: &Ray, inv: Vec3) -> Self {
        let inv = inv.to_array();
        Slab {
            o: ray.origin.to_array(),
            inv,
            near: inv.map(|x| x.is_sign_negative() as usize),
        }
    }

    /// Entry and exit distances of a wide node's four children's boxes
    /// within `[tmin, tmax]` (the ray enters child `i` if `t0[i] <= t1[i]`).
    #[inline(always)]
    fn test4(&self, n: &Wide, tmin: f64, tmax: f64) -> ([f64; 4], [f64; 4]) {
        self.test4_at(&planes(n, &self.near), tmin, tmax)
    }

    /// [`Slab::test4`] on a node's planes made by [`planes`] with this
    /// ray's `near`.
    #[inline(always)]
    fn test4_at(&self, p: &Planes, tmin: f64, tmax: f64) -> ([f64; 4], [f64; 4]) {
        let mut t0 = [tmin; 4];
        let mut t1 = [tmax; 4];
        for (a, [lo, hi]) in p.iter().enumerate() {
            let (o, inv) = (self.o[a], self.inv[a]);
            for l in 0..4 {
                let e = (lo[l] - o) * inv;
                let x = (hi[l] - o) * inv;
                // Written so a NaN (0 * inf) keeps the bound: `maxpd`/`minpd`.
                t0[l] = if e > t0[l] { e } else { t0[l] };
                t1[l] = if x < t1[l] { x } else { t1[l] };
            }
        }
        (t0, t1)
    }
}

/// A node's four children's planes in double precision (widening is
/// exact), per axis the planes rays with `near` enter by, then those they
/// leave by.
type Planes = [[[f64; 4]; 2]; 3];

/// [`Planes`] of `n` for rays entering by the planes `near` names.
#[inline(always)]
fn planes(n: &Wide, near: &[usize; 3]) -> Planes {
    std::array::from_fn(|a| {
        [
            n.b[a][near[a]].map(f64::from),
            n.b[a][1 - near[a]].map(f64::from),
        ]
    })
}

/// The slab test of one ray against a node's four children: the mask of
/// children entered (bit `i` for child `i`) and their entry distances.
/// Every implementation does [`Slab::test4_at`]'s IEEE operations in its
/// order, so all give the same answers.
trait Enter {
    /// # Safety
    /// The implementation's instructions must be available.
    #[inline(always)]
    unsafe fn enter4(s: &Slab, n: &Wide, tmin: f64, tmax: f64) -> (u32, [f64; 4]) {
        Self::enter4_at(s, &Self::planes(n, &s.near), tmin, tmax)
    }

    /// A node's planes for rays entering by the planes `near` names (see
    /// [`planes`]): a packet whose rays all enter by the same planes widens
    /// them once per node, not once per ray.
    type Planes;

    /// # Safety
    /// The implementation's instructions must be available.
    unsafe fn planes(n: &Wide, near: &[usize; 3]) -> Self::Planes;

    /// [`Enter::enter4`] on planes made with the ray's own `near`.
    ///
    /// # Safety
    /// The implementation's instructions must be available.
    unsafe fn enter4_at(s: &Slab, p: &Self::Planes, tmin: f64, tmax: f64) -> (u32, [f64; 4]);

    /// [`Enter::enter4`] in single precision ([`single`]).
    ///
    /// # Safety
    /// The implementation's instructions must be available.
    unsafe fn enter4_32(s: &single::Slab32, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]);

    /// The distances of a leaf block's four triangles ([`leaf::Tri4`]),
    /// NaN where the ray misses; every implementation gives the same.
    ///
    /// # Safety
    /// The implementation's instructions must be available.
    unsafe fn tri4(tr: &TriRay, b: &leaf::Tri4) -> [f64; 4];

    /// The lanes of `t` with `lo < t < hi`: bit `i` for lane `i`.
    ///
    /// # Safety
    /// The implementation's instructions must be available.
    unsafe fn within(t: &[f64; 4], lo: f64, hi: f64) -> u32;
}

/// Portable code.
struct Portable;

impl Enter for Portable {
    type Planes = Planes;

    #[inline(always)]
    unsafe fn planes(n: &Wide, near: &[usize; 3]) -> Planes {
        planes(n, near)
    }

    #[inline(always)]
    unsafe fn enter4_at(s: &Slab, p: &Planes, tmin: f64, tmax: f64) -> (u32, [f64; 4]) {
        let (t0, t1) = s.test4_at(p, tmin, tmax);
        let mut m = 0;
        for l in 0..4 {
            m |= ((t0[l] <= t1[l]) as u32) << l;
        }
        (m, t0)
    }

    #[inline(always)]
    unsafe fn enter4_32(s: &single::Slab32, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
        single::enter4(s, n, tmin, tmax)
    }

    #[inline(always)]
    unsafe fn tri4(tr: &TriRay, b: &leaf::Tri4) -> [f64; 4] {
        leaf::lanes(tr, b)
    }

    #[inline(always)]
    unsafe fn within(t: &[f64; 4], lo: f64, hi: f64) -> u32 {
        let mut m = 0;
        for (l, &t) in t.iter().enumerate() {
            m |= ((t > lo && t < hi) as u32) << l;
        }
        m
    }
}

/// AVX2: the four children in one register per quantity. `maxpd(e, t0)`
/// is `if e > t0 { e } else { t0 }` and `minpd(x, t1)` is `if x < t1 { x }
/// else { t1 }`, the scalar test's choices, NaN included.
#[cfg(target_arch = "x86_64")]
struct Avx2;

#[cfg(target_arch = "x86_64")]
impl Enter for Avx2 {
    type Planes = [[std::arch::x86_64::__m256d; 2]; 3];

    #[inline(always)]
    unsafe fn planes(n: &Wide, near: &[usize; 3]) -> Self::Planes {
        use std::arch::x86_64::*;
        // `Wide` is aligned to 32 bytes, each `[f32; 4]` of it to 16;
        // widening to double precision is exact. Spelled out, without
        // closures or `array::from_fn`: code outside this AVX2 function
        // (a generic of the standard library) may be left uninlined, and
        // then calls each intrinsic as a function.
        let b = &n.b;
        let (x, y, z) = (near[0], near[1], near[2]);
        [
            [
                _mm256_cvtps_pd(_mm_load_ps(b[0][x].as_ptr())),
                _mm256_cvtps_pd(_mm_load_ps(b[0][1 - x].as_ptr())),
            ],
            [
                _mm256_cvtps_pd(_mm_load_ps(b[1][y].as_ptr())),
                _mm256_cvtps_pd(_mm_load_ps(b[1][1 - y].as_ptr())),
            ],
            [
                _mm256_cvtps_pd(_mm_load_ps(b[2][z].as_ptr())),
                _mm256_cvtps_pd(_mm_load_ps(b[2][1 - z].as_ptr())),
            ],
        ]
    }

    #[inline(always)]
    unsafe fn enter4_at(s: &Slab, p: &Self::Planes, tmin: f64, tmax: f64) -> (u32, [f64; 4]) {
        use std::arch::x86_64::*;
        let mut t0 = _mm256_set1_pd(tmin);
        let mut t1 = _mm256_set1_pd(tmax);
        for (a, &[lo, hi]) in p.iter().enumerate() {
            let o = _mm256_set1_pd(s.o[a]);
            let inv = _mm256_set1_pd(s.inv[a]);
            let e = _mm256_mul_pd(_mm256_sub_pd(lo, o), inv);
            let x = _mm256_mul_pd(_mm256_sub_pd(hi, o), inv);
            t0 = _mm256_max_pd(e, t0);
            t1 = _mm256_min_pd(x, t1);
        }
        let m = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(t0, t1)) as u32;
        let mut out = [0.0; 4];
        _mm256_storeu_pd(out.as_mut_ptr(), t0);
        (m, out)
    }

    #[inline(always)]
    unsafe fn enter4_32(s: &single::Slab32, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
        single::enter4_avx2(s, n, tmin, tmax)
    }

    #[inline(always)]
    unsafe fn tri4(tr: &TriRay, b: &leaf::Tri4) -> [f64; 4] {
        leaf::lanes_avx2(tr, b)
    }

    #[inline(always)]
    unsafe fn within(t: &[f64; 4], lo: f64, hi: f64) -> u32 {
        use std::arch::x86_64::*;
        let t = _mm256_loadu_pd(t.as_ptr());
        let above = _mm256_cmp_pd::<_CMP_GT_OQ>(t, _mm256_set1_pd(lo));
        let below = _mm256_cmp_pd::<_CMP_LT_OQ>(t, _mm256_set1_pd(hi));
        _mm256_movemask_pd(_mm256_and_pd(above, below)) as u32
    }
}

/// A ray's slab test at the nodes: in double precision ([`Slab`], any
/// ray) or single ([`single::Slab32`], rays within its range). Either is only a
/// filter that lets through every child the ray enters, so the traversals'
/// answers do not depend on which one ran.
trait NodeTest: Copy {
    /// Distances along the ray (widening to double precision is exact).
    type T: Copy + PartialOrd + Into<f64>;

    /// A segment's start, rounded down.
    fn lower(t: f64) -> Self::T;

    /// A segment's end, rounded up.
    fn upper(t: f64) -> Self::T;

    /// The mask of `n`'s children entered within `[tmin, tmax]` and their
    /// entry distances.
    ///
    /// # Safety
    /// `E`'s instructions must be available.
    unsafe fn enter<E: Enter>(&self, n: &Wide, tmin: Self::T, tmax: Self::T)
        -> (u32, [Self::T; 4]);
}

impl NodeTest for Slab {
    type T = f64;

    #[inline(always)]
    fn lower(t: f64) -> f64 {
        t
    }

    #[inline(always)]
    fn upper(t: f64) -> f64 {
        t
    }

    #[inline(always)]
    unsafe fn enter<E: Enter>(&self, n: &Wide, tmin: f64, tmax: f64) -> (u32, [f64; 4]) {
        E::enter4(self, n, tmin, tmax)
    }
}

impl NodeTest for single::Slab32 {
    type T = f32;

    #[inline(always)]
    fn lower(t: f64) -> f32 {
        single::down(t)
    }

    #[inline(always)]
    fn upper(t: f64) -> f32 {
        single::up(t)
    }

    #[inline(always)]
    unsafe fn enter<E: Enter>(&self, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
        E::enter4_32(self, n, tmin, tmax)
    }
}

/// The hierarchy. `Default` is the empty one (every query misses).
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    /// Node 0 holds the root's children.
    nodes: Vec<Wide>,
    /// Object ids in leaf order.
    ids: Vec<ObjectId>,
    /// Objects without finite bounds: tested by every ray.
    unbounded: Vec<ObjectId>,
    prims: Prims,
    /// The leaves' polygons as blocks of four triangles (empty where the
    /// polygons' data is shared with copies: see [`Bvh::build_with`]).
    blocks: leaf::Blocks,
    /// Deepest leaf (the root's children have depth 1).
    depth: u32,
    /// Whether the nodes' planes are within the single-precision slab
    /// test's range ([`single::fits`]).
    single: bool,
}

/// Statistics of a built hierarchy.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BvhStats {
    pub nodes: usize,
    pub leaves: usize,
    pub depth: u32,
    pub objects: usize,
}

/// An object's box, enlarged by the build's margin, in single precision
/// (each coordinate rounded to the nearest, for the heuristic): lanes 0 to
/// 2 the coordinates, lane 3 of `lo` the object's id (its bits), lane 3 of
/// `hi` the directions its coordinates were rounded in (see [`Ref::new`]),
/// from which a leaf takes the exact box rounded outwards without asking
/// the object again. 32 bytes, two SIMD registers.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Ref {
    lo: [f32; 4],
    hi: [f32; 4],
}

/// Lane 3 of a ref's `hi`: a normal number (arithmetic on subnormal
/// ones is slow on some processors), its low six bits the rounding flags.
const FLAGS: u32 = 0x3f80_0000;

impl Ref {
    /// Object `id`'s box `lo`..`hi` (double precision, finite). The
    /// heuristic's box rounds to the nearest, as it always has (the same
    /// tree as before the flags). Flag `k`
    /// says that `lo[k]` was rounded up, flag `3 + k` that `hi[k]` was
    /// rounded down, so that [`Ref::outward`] finds the box rounded
    /// outwards: one step further where a flag is set.
    #[inline(always)]
    fn new(id: ObjectId, lo: [f64; 3], hi: [f64; 3]) -> Ref {
        // Loops rather than `map`s, which were not inlined.
        let mut r = Ref {
            lo: [0.0; 4],
            hi: [0.0; 4],
        };
        let mut flags = FLAGS;
        for k in 0..3 {
            let (l, h) = (to_f32(lo[k]), to_f32(hi[k]));
            flags |= ((f64::from(l) > lo[k]) as u32) << k;
            flags |= ((f64::from(h) < hi[k]) as u32) << (3 + k);
            r.lo[k] = l;
            r.hi[k] = h;
        }
        r.lo[3] = f32::from_bits(id);
        r.hi[3] = f32::from_bits(flags);
        r
    }

    /// The box rounded outwards to single precision: each coordinate
    /// [`round_down`] (`lo`) or [`round_up`] (`hi`) of the double-precision
    /// one.
    #[inline(always)]
    fn outward(&self) -> ([f32; 3], [f32; 3]) {
        let flags = self.hi[3].to_bits();
        let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
        for k in 0..3 {
            lo[k] = if (flags >> k) & 1 != 0 {
                step_down(self.lo[k])
            } else {
                self.lo[k]
            };
            hi[k] = if (flags >> (3 + k)) & 1 != 0 {
                step_up(self.hi[k])
            } else {
                self.hi[k]
            };
        }
        (lo, hi)
    }

    /// The object's id.
    #[inline(always)]
    fn id(&self) -> ObjectId {
        self.lo[3].to_bits()
    }

    /// Twice the box's centre, lane 3 zero. (Not the sum of lane 3 too:
    /// an id's bits are a subnormal number, and arithmetic on subnormals
    /// is slow on some processors.)
    #[inline(always)]
    fn centre(&self) -> [f32; 4] {
        let (lo, hi) = (&self.lo, &self.hi);
        [lo[0] + hi[0], lo[1] + hi[1], lo[2] + hi[2], 0.0]
    }
}

/// A box in single precision (lane 3 meaningless).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Box4 {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl Box4 {
    const EMPTY: Box4 = Box4 {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
    };

    #[inline(always)]
    fn add(&mut self, lo: &[f32; 4], hi: &[f32; 4]) {
        for k in 0..4 {
            self.lo[k] = fmin(self.lo[k], lo[k]);
            self.hi[k] = fmax(self.hi[k], hi[k]);
        }
    }

    #[inline(always)]
    fn grow(&mut self, p: &[f32; 4]) {
        self.add(p, p);
    }

    /// Half the surface area (0 for an empty box).
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let e = [0, 1, 2].map(|k| fmax(self.hi[k] - self.lo[k], 0.0));
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }

    fn extent(&self) -> [f32; 3] {
        [0, 1, 2].map(|k| self.hi[k] - self.lo[k])
    }
}

/// A run `refs[start..end]` of the build: its box and the box of its
/// centres (single precision), and its depth in binary splits (the root's
/// children have depth 1).
#[derive(Debug, Clone, Copy)]
struct Part {
    start: usize,
    end: usize,
    bounds: Box4,
    centres: Box4,
    depth: u32,
}

/// What the build decided for a child of a wide node.
#[derive(Debug, Clone, Copy)]
enum Kid {
    /// Not yet looked at.
    Open(Part),
    Leaf(Part),
    /// Split in two (its box's half area, the sides); becomes a wide node
    /// of its own unless opened.
    Split(f32, Part, Part),
}

impl Kid {
    fn half_area(&self) -> f32 {
        match self {
            Kid::Open(p) | Kid::Leaf(p) => p.bounds.half_area(),
            Kid::Split(a, _, _) => *a,
        }
    }
}

/// `a.min(b)` and `a.max(b)` without the NaN cases: one `minps`/`maxps`
/// (`minpd`/`maxpd`) lane.
#[inline(always)]
fn fmin<T: PartialOrd>(a: T, b: T) -> T {
    if a < b {
        a
    } else {
        b
    }
}

#[inline(always)]
fn fmax<T: PartialOrd>(a: T, b: T) -> T {
    if a > b {
        a
    } else {
        b
    }
}

/// The build, Embree's way: the binned surface area heuristic on
/// single-precision boxes ([`Ref`], all three axes binned in one pass),
/// partitions in place in one array (no allocation per node), four-wide
/// nodes built directly (the binary split of the largest child repeated
/// until there are four). Deterministic: every step is a function of the
/// refs' order, which only the steps themselves change; no threads.
struct Builder {
    refs: Vec<Ref>,
    nodes: Vec<Wide>,
    /// Object ids of the leaves built so far, in leaf order.
    ids: Vec<ObjectId>,
    /// Deepest leaf in wide levels (the root's children have depth 1).
    depth: u32,
    /// The heuristic's bins, one set per axis (reused: each split clears
    /// the ones it uses).
    bins: [Bins; 3],
}

/// The part over `refs[start..end]` (boxes and centres gathered).
fn part_of(refs: &[Ref], start: usize, end: usize, depth: u32) -> Part {
    let (mut bounds, mut centres) = (Box4::EMPTY, Box4::EMPTY);
    for r in &refs[start..end] {
        bounds.add(&r.lo, &r.hi);
        centres.grow(&r.centre());
    }
    Part {
        start,
        end,
        bounds,
        centres,
        depth,
    }
}

/// Per-axis bins of the heuristic: each bin's box and object count.
#[derive(Clone, Copy)]
struct Bins {
    b: [Box4; BINS],
    n: [u32; BINS],
}

impl Bins {
    const EMPTY: Bins = Bins {
        b: [Box4::EMPTY; BINS],
        n: [0; BINS],
    };

    /// Sweeps the first `nb` bins' boundaries: the cheapest `(cost,
    /// boundary, left box, right box)`.
    fn sweep(&self, nb: usize, parent_area: f32) -> Option<(f32, usize, Box4, Box4)> {
        let mut right_area = [0.0f32; BINS];
        let mut right_n = [0u32; BINS];
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for b in (1..nb).rev() {
            acc.add(&self.b[b].lo, &self.b[b].hi);
            cnt += self.n[b];
            right_area[b] = acc.half_area();
            right_n[b] = cnt;
        }
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        let mut best: Option<(f32, usize, Box4)> = None;
        let scale = 1.0 / parent_area.max(f32::MIN_POSITIVE);
        for b in 1..nb {
            acc.add(&self.b[b - 1].lo, &self.b[b - 1].hi);
            cnt += self.n[b - 1];
            if cnt == 0 || right_n[b] == 0 {
                continue;
            }
            let cost = NODE_COST as f32
                + (acc.half_area() * cnt as f32 + right_area[b] * right_n[b] as f32) * scale;
            if best.is_none_or(|(c, ..)| cost < c) {
                best = Some((cost, b, acc));
            }
        }
        let (cost, b, left) = best?;
        let mut right = Box4::EMPTY;
        for bin in &self.b[b..nb] {
            right.add(&bin.lo, &bin.hi);
        }
        Some((cost, b, left, right))
    }
}

impl Builder {
    /// How to split `p`: the binned surface area heuristic over the three
    /// axes (objects binned by box centre, the three axes in one pass); a
    /// split by count where centres coincide or the tree would grow too
    /// deep for the traversal stack; `None` for a leaf. Reorders
    /// `refs[p.start..p.end]` so that each side is a run.
    fn split(&mut self, p: &Part) -> Option<(Part, Part)> {
        let n = p.end - p.start;
        if n <= 1 {
            return None;
        }
        let ext = p.centres.extent();
        let widest = ext[0].max(ext[1]).max(ext[2]);
        if p.depth >= SAH_DEPTH || !(widest.is_finite() && widest > 0.0) {
            return self.by_count(p);
        }
        // Fewer bins for fewer objects, as Embree's binner counts them.
        let nb = (4 + n / 20).min(n).min(BINS);
        let mut cmin = p.centres.lo;
        cmin[3] = 0.0;
        let mut scale = [0.0f32; 4];
        for k in 0..3 {
            scale[k] = if ext[k] > 0.0 {
                nb as f32 / ext[k]
            } else {
                0.0
            };
        }
        // A centre is in `[cmin, cmin + ext]`: bins `0..nb` (clamped: a
        // centre on the top edge, rounding; a NaN from an infinite scale is
        // bin 0).
        let grid = binning::Grid {
            cmin,
            scale,
            top: (nb - 1) as f32,
        };
        let bins = &mut self.bins;
        for bins in bins.iter_mut() {
            bins.b[..nb].fill(Box4::EMPTY);
            bins.n[..nb].fill(0);
        }
        binning::bin_all(&self.refs[p.start..p.end], &grid, bins);
        let parent_area = p.bounds.half_area();
        let mut best: Option<(f32, usize, usize, Box4, Box4)> = None;
        for (axis, bins) in bins.iter().enumerate() {
            if ext[axis].is_nan() || ext[axis] <= 0.0 {
                continue;
            }
            if let Some((cost, b, l, r)) = bins.sweep(nb, parent_area) {
                if best.is_none_or(|(c, ..)| cost < c) {
                    best = Some((cost, axis, b, l, r));
                }
            }
        }
        let Some((cost, axis, b, left, right)) = best else {
            return self.by_count(p);
        };
        if n <= MAX_LEAF && cost >= n as f32 {
            return None;
        }
        // In place (Hoare's partition), gathering each side's centres.
        let refs = &mut self.refs[p.start..p.end];
        let (mut i, mut j) = (0, refs.len());
        let (mut lc, mut rc) = (Box4::EMPTY, Box4::EMPTY);
        let side = move |r: &Ref| grid.bin(r.lo[axis] + r.hi[axis], axis) < b;
        loop {
            while i < j && side(&refs[i]) {
                lc.grow(&refs[i].centre());
                i += 1;
            }
            while i < j && !side(&refs[j - 1]) {
                rc.grow(&refs[j - 1].centre());
                j -= 1;
            }
            if i >= j {
                break;
            }
            refs.swap(i, j - 1);
        }
        let mid = p.start + i;
        let depth = p.depth + 1;
        Some((
            Part {
                start: p.start,
                end: mid,
                bounds: left,
                centres: lc,
                depth,
            },
            Part {
                start: mid,
                end: p.end,
                bounds: right,
                centres: rc,
                depth,
            },
        ))
    }

    /// Halves `p` at the median centre on its centres' widest axis (ties
    /// by index: by object id); `None` for a leaf when it holds at most
    /// [`MAX_LEAF`] objects.
    fn by_count(&mut self, p: &Part) -> Option<(Part, Part)> {
        let n = p.end - p.start;
        if n <= MAX_LEAF {
            return None;
        }
        let ext = p.centres.extent();
        let mut widest = 0;
        for k in 1..3 {
            if ext[k] > ext[widest] {
                widest = k;
            }
        }
        self.refs[p.start..p.end].select_nth_unstable_by(n / 2, |a, b| {
            (a.lo[widest] + a.hi[widest])
                .total_cmp(&(b.lo[widest] + b.hi[widest]))
                .then(a.id().cmp(&b.id()))
        });
        let mid = p.start + n / 2;
        Some((
            part_of(&self.refs, p.start, mid, p.depth + 1),
            part_of(&self.refs, mid, p.end, p.depth + 1),
        ))
    }

    /// The wide node over a part split into `first`; returns its index and
    /// exact box. Its children: the two sides, the largest side that
    /// splits split again until there are four (the first of equal areas).
    fn wide(&mut self, first: (Part, Part), depth: u32) -> (u32, Aabb) {
        let mut kids = [
            Kid::Open(first.0),
            Kid::Open(first.1),
            Kid::Open(first.1),
            Kid::Open(first.1),
        ];
        let mut n = 2;
        while n < 4 {
            let mut open: Option<(usize, f32)> = None;
            for (i, k) in kids[..n].iter().enumerate() {
                if matches!(k, Kid::Leaf(_)) {
                    continue;
                }
                let a = k.half_area();
                if open.is_none_or(|(_, b)| a > b) {
                    open = Some((i, a));
                }
            }
            let Some((i, _)) = open else { break };
            kids[i] = match kids[i] {
                Kid::Split(_, l, r) => {
                    kids[n] = Kid::Open(r);
                    n += 1;
                    Kid::Open(l)
                }
                Kid::Open(p) | Kid::Leaf(p) => self.decide(&p),
            }
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(Wide::UNUSED);
        let mut all = Aabb::EMPTY;
        for (j, kid) in kids[..n].iter().enumerate() {
            let kid = match *kid {
                Kid::Open(p) => self.decide(&p),
                k => k,
            };
            let (link, count, b) = match kid {
                Kid::Split(_, l, r) => {
                    let (link, b) = self.wide((l, r), depth + 1);
                    (link, 0, b)
                }
                Kid::Leaf(p) | Kid::Open(p) => {
                    let (link, b) = self.leaf(&p, depth);
                    (link, (p.end - p.start) as u32, b)
                }
            };
            all = all.union(b);
            let w = &mut self.nodes[id as usize];
            for a in 0..3 {
                w.b[a][0][j] = round_down(b.min[a]);
                w.b[a][1][j] = round_up(b.max[a]);
            }
            w.link[j] = link;
            w.count[j] = count;
        }
        (id, all)
    }

    /// `p` as a leaf or split.
    fn decide(&mut self, p: &Part) -> Kid {
        match self.split(p) {
            Some((l, r)) => Kid::Split(p.bounds.half_area(), l, r),
            None => Kid::Leaf(*p),
        }
    }

    /// Appends `p`'s objects to the leaf order; returns where they start
    /// and their exact box, rounded outwards ([`Ref::outward`]: without
    /// asking the objects for their boxes again; their vertices lie
    /// scattered through memory, and the three reads of each object's box
    /// took about a sixth of the studio's build, `perf`).
    fn leaf(&mut self, p: &Part, depth: u32) -> (u32, Aabb) {
        self.depth = self.depth.max(depth);
        let start = self.ids.len() as u32;
        // The union taken in single precision (exact: the corners are
        // single-precision numbers).
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for r in &self.refs[p.start..p.end] {
            let (l, h) = r.outward();
            for k in 0..3 {
                lo[k] = fmin(lo[k], l[k]);
                hi[k] = fmax(hi[k], h[k]);
            }
            self.ids.push(r.id());
        }
        let v = |x: [f32; 3]| Vec3::new(x[0].into(), x[1].into(), x[2].into());
        let all = Aabb::new(v(lo), v(hi));
        (start, all)
    }
}

/// `x` rounded to the nearest single-precision number, within the finite
/// range.
fn to_f32(x: f64) -> f32 {
    (x as f32).clamp(f32::MIN, f32::MAX)
}

/// The greatest single-precision number below `f` (`f32::next_down`,
/// which the supported Rust, 1.85, lacks); minus infinity stays. `f` is
/// not NaN.
#[inline(always)]
fn step_down(f: f32) -> f32 {
    match f {
        0.0 => -f32::from_bits(1),
        f32::NEG_INFINITY => f,
        f if f > 0.0 => f32::from_bits(f.to_bits() - 1),
        f => f32::from_bits(f.to_bits() + 1),
    }
}

/// The least single-precision number above `f` (`f32::next_up`); infinity
/// stays. `f` is not NaN.
#[inline(always)]
fn step_up(f: f32) -> f32 {
    -step_down(-f)
}

/// The greatest single-precision number not above `x` (a node's lower
/// corner; below `f32::MIN`, minus infinity).
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        // `f` is above a finite `x`: neither NaN nor minus infinity.
        step_down(f)
    } else {
        f
    }
}

/// The least single-precision number not below `x` (a node's upper
/// corner; above `f32::MAX`, infinity).
fn round_up(x: f64) -> f32 {
    -round_down(-x)
}

impl Bvh {
    /// Builds the hierarchy over `objects` (ids are indices into
    /// `objects`). Objects with empty bounds are left out, like the
    /// octree's. Deterministic: the same objects give the same tree.
    pub fn build(objects: &[Object]) -> Bvh {
        let mut bvh = Self::build_with(objects, Prims::build_without_polygons(objects));
        bvh.blocks = leaf::Blocks::build(&bvh.nodes, &mut bvh.ids, objects);
        bvh
    }

    /// [`Bvh::build`] with the objects' intersection data given (built for
    /// `objects`, in order: [`Prims::from_ones`] of copies' data), without
    /// the leaves' blocks: the polygons are tested through that data (a
    /// processor's copies share their triangle pairs with it).
    pub(crate) fn build_with<O: ObjectSet + ?Sized>(objects: &O, prims: Prims) -> Bvh {
        debug_assert!(prims.matches(objects));
        let mut unbounded = Vec::new();
        let mut scene = Aabb::EMPTY;
        let mut n = 0usize;
        // An object is bounded if its box is neither empty nor infinite
        // (the same test in both passes: `bounds` is a function).
        let bounded = |b: &Aabb| !b.is_empty() && b.min.is_finite() && b.max.is_finite();
        for i in 0..objects.count() {
            let b = objects.bounds(i);
            if b.is_empty() {
                continue;
            }
            if !bounded(&b) {
                unbounded.push(i as ObjectId);
                continue;
            }
            scene = scene.union(b);
            n += 1;
        }
        let mut bvh = Bvh {
            unbounded,
            prims,
            ..Default::default()
        };
        if n == 0 {
            return bvh;
        }
        // The octree's margin: far beyond the slab test's rounding.
        let margin = 1e-9 * (scene.extent().max_element() + scene.magnitude());
        let pad = Vec3::splat(margin);
        let mut refs = Vec::with_capacity(n);
        for i in 0..objects.count() {
            let b = objects.bounds(i);
            if !bounded(&b) {
                continue;
            }
            let b = Aabb::new(b.min - pad, b.max + pad);
            refs.push(Ref::new(i as ObjectId, b.min.to_array(), b.max.to_array()));
        }
        debug_assert_eq!(refs.len(), n);
        let mut b = Builder {
            refs,
            nodes: Vec::with_capacity(n / 2 + 1),
            ids: Vec::with_capacity(n),
            depth: 0,
            bins: [Bins::EMPTY; 3],
        };
        let root = part_of(&b.refs, 0, n, 0);
        match b.split(&root) {
            None => {
                let (link, all) = b.leaf(&root, 1);
                let mut w = Wide::UNUSED;
                for a in 0..3 {
                    w.b[a][0][0] = round_down(all.min[a]);
                    w.b[a][1][0] = round_up(all.max[a]);
                }
                w.link[0] = link;
                w.count[0] = n as u32;
                b.nodes.push(w);
            }
            Some(sides) => {
                b.wide(sides, 1);
            }
        }
        bvh.nodes = b.nodes;
        bvh.ids = b.ids;
        bvh.depth = b.depth;
        // Every node's planes lie within the root children's (each box is
        // rounded outwards from a union of the boxes below it).
        let root = &bvh.nodes[0];
        bvh.single = (0..4).all(|l| {
            (0..3).all(|a| {
                let (lo, hi) = (root.b[a][0][l], root.b[a][1][l]);
                lo > hi || single::fits(lo, hi)
            })
        });
        bvh
    }

    pub fn stats(&self) -> BvhStats {
        BvhStats {
            nodes: self.nodes.len(),
            leaves: self
                .nodes
                .iter()
                .flat_map(|n| n.count)
                .filter(|&c| c > 0)
                .count(),
            depth: self.depth,
            objects: self.ids.len() + self.unbounded.len(),
        }
    }

    /// Heap bytes (nodes, ids and the compact object data).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Wide>()
            + (self.ids.capacity() + self.unbounded.capacity()) * std::mem::size_of::<ObjectId>()
            + self.prims.memory_bytes()
            + self.blocks.memory_bytes()
    }

    /// Nearest hit with `tmin < t < tmax` among `objects` (the slice the
    /// hierarchy was built over). Equal distances resolve to the smaller
    /// object id, like [`crate::accel::intersect_brute_force`] and
    /// [`crate::accel::Octree::intersect`].
    pub fn intersect<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.intersect_avx2(objects, ray, tmin, tmax) };
        }
        // SAFETY: portable code.
        unsafe {
            if self.depth as usize <= SHALLOW {
                self.intersect_with::<{ 3 * SHALLOW + 1 }, Portable, O>(objects, ray, tmin, tmax)
            } else {
                self.intersect_with::<{ 3 * STACK + 1 }, Portable, O>(objects, ray, tmin, tmax)
            }
        }
    }

    /// [`Bvh::intersect`] compiled for AVX2 (the four lanes of a slab test
    /// in one instruction). The same IEEE operations in the same order (no
    /// fused multiply-add): the same answers, bit for bit. Measured
    /// (`hybrid-rt bench --embree`, three runs side by side): about 6%
    /// faster, primary and shadow rays.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_avx2<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        if self.depth as usize <= SHALLOW {
            self.intersect_with::<{ 3 * SHALLOW + 1 }, Avx2, O>(objects, ray, tmin, tmax)
        } else {
            self.intersect_with::<{ 3 * STACK + 1 }, Avx2, O>(objects, ray, tmin, tmax)
        }
    }

    /// The single-precision slab test for rays within its range, the
    /// double-precision one for the others.
    ///
    /// # Safety
    /// `E`'s instructions must be available.
    #[inline(always)]
    unsafe fn intersect_with<const N: usize, E: Enter, O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        let pre = PreparedRay::new(ray);
        match single::Slab32::new(ray, pre.inv_dir, tmin).filter(|_| self.single) {
            Some(s) => self.intersect_impl::<N, E, _, O>(objects, &pre, s, tmin, tmax),
            None => {
                let s = Slab::new(ray, pre.inv_dir);
                self.intersect_impl::<N, E, _, O>(objects, &pre, s, tmin, tmax)
            }
        }
    }

    /// # Safety
    /// `E`'s instructions must be available.
    #[inline(always)]
    unsafe fn intersect_impl<const N: usize, E: Enter, S: NodeTest, O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        pre: &PreparedRay,
        slab: S,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        let ray = &pre.ray;
        let test = Tester::new(&self.prims, objects, pre);
        let blocks = test.compact().filter(|_| !self.blocks.is_empty());
        let mut best: leaf::Best = None;
        let mut cut = tmax;
        for &id in &self.unbounded {
            packet::consider(&test, tmin, id, &mut cut, &mut best);
        }
        if !self.nodes.is_empty() {
            let t_min = S::lower(tmin);
            // The cut for the slab test: rounded up whenever it moves.
            let mut t_cut = S::upper(cut);
            // Pending children, nearest on top: (link, count, entry
            // distance). Not zeroed (it is as large as the deepest tree
            // needs): entries below `sp` are the ones written.
            let mut stack = [const { MaybeUninit::<(u32, u32, S::T)>::uninit() }; N];
            let mut sp = 0usize;
            let (mut link, mut count) = (0u32, 0u32);
            loop {
                if count > 0 {
                    let (s, count) = (link as usize, count as usize);
                    let mut ids = &self.ids[s..s + count];
                    if let Some((_, tr)) = blocks {
                        let (tris, polys) = self.blocks.leaf(s);
                        leaf::nearest::<E>(tris, tr, tmin, &mut cut, &mut best);
                        ids = &ids[polys..];
                    }
                    for &id in ids {
                        packet::consider(&test, tmin, id, &mut cut, &mut best);
                    }
                    t_cut = S::upper(cut);
                } else {
                    let n = &self.nodes[link as usize];
                    let (m, t0) = slab.enter::<E>(n, t_min, t_cut);
                    if m != 0 {
                        // On to the nearest child entered (the first of
                        // equal ones); the others pending, farthest pushed
                        // first (ties by lane: deterministic). A branch on
                        // which child is nearer: computed without one
                        // (vector minimum), the next node waited for it,
                        // and primary rays ran 0.85 times as fast.
                        let mut near = m.trailing_zeros() as usize;
                        let mut rest = m & (m - 1);
                        if rest != 0 {
                            let mut r = rest;
                            while r != 0 {
                                let lane = r.trailing_zeros() as usize;
                                r &= r - 1;
                                if t0[lane] < t0[near] {
                                    near = lane;
                                }
                            }
                            rest = m & !(1 << near);
                        }
                        let base = sp;
                        while rest != 0 {
                            let lane = rest.trailing_zeros() as usize;
                            rest &= rest - 1;
                            let e = (n.link[lane], n.count[lane], t0[lane]);
                            let mut j = sp;
                            // SAFETY: `j - 1 < sp`: written.
                            while j > base && unsafe { stack[j - 1].assume_init() }.2 < e.2 {
                                stack[j] = stack[j - 1];
                                j -= 1;
                            }
                            stack[j] = MaybeUninit::new(e);
                            sp += 1;
                        }
                        (link, count) = (n.link[near], n.count[near]);
                        continue;
                    }
                }
                // The nearest pending child still in front of the cut.
                let mut next = None;
                while sp > 0 {
                    sp -= 1;
                    // SAFETY: below the old `sp`: written.
                    let (l, c, t) = unsafe { stack[sp].assume_init() };
                    if t <= t_cut {
                        next = Some((l, c));
                        break;
                    }
                }
                match next {
                    Some(lc) => (link, count) = lc,
                    None => break,
                }
            }
        }
        best.map(|(t, id, h)| {
            let h = leaf::reported(h, blocks.map(|(prims, _)| prims), id, t);
            Hit::on_surface(
                |inner| objects.surface_at(id as usize, inner),
                id,
                ray,
                t,
                &h,
            )
        })
    }

    /// True if any object other than `ignore` is hit with `tmin < t < tmax`.
    pub fn occluded<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.occluded_avx2(objects, ray, tmin, tmax, ignore) };
        }
        // SAFETY: portable code.
        unsafe {
            if self.depth as usize <= SHALLOW {
                self.occluded_impl::<{ 3 * SHALLOW }, Portable, O>(objects, ray, tmin, tmax, ignore)
            } else {
                self.occluded_impl::<{ 3 * STACK }, Portable, O>(objects, ray, tmin, tmax, ignore)
            }
        }
    }

    /// [`Bvh::occluded`] compiled for AVX2 (see [`Bvh::intersect_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn occluded_avx2<O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        if self.depth as usize <= SHALLOW {
            self.occluded_impl::<{ 3 * SHALLOW }, Avx2, O>(objects, ray, tmin, tmax, ignore)
        } else {
            self.occluded_impl::<{ 3 * STACK }, Avx2, O>(objects, ray, tmin, tmax, ignore)
        }
    }

    /// # Safety
    /// `E`'s instructions must be available.
    #[inline(always)]
    unsafe fn occluded_impl<const N: usize, E: Enter, O: ObjectSet + ?Sized>(
        &self,
        objects: &O,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        let pre = PreparedRay::new(ray);
        let test = Tester::new(&self.prims, objects, &pre);
        let occludes = |id: ObjectId| Some(id) != ignore && test.occludes(id, tmin, tmax);
        if self.unbounded.iter().any(|&id| occludes(id)) {
            return true;
        }
        let tr = test
            .compact()
            .filter(|_| !self.blocks.is_empty())
            .map(|(_, tr)| tr);
        if self.nodes.is_empty() {
            return false;
        }
        let slab = Slab::new(ray, pre.inv_dir);
        let mut stack = [0u32; N];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (t0, t1) = slab.test4(n, tmin, tmax);
            let mut next = u32::MAX;
            for lane in 0..4 {
                if t0[lane] > t1[lane] {
                    continue;
                }
                let count = n.count[lane] as usize;
                if count > 0 {
                    let s = n.link[lane] as usize;
                    let mut ids = &self.ids[s..s + count];
                    if let Some(tr) = tr {
                        let (tris, polys) = self.blocks.leaf(s);
                        if leaf::any::<E>(tris, tr, tmin, tmax, ignore) {
                            return true;
                        }
                        ids = &ids[polys..];
                    }
                    if ids.iter().any(|&id| occludes(id)) {
                        return true;
                    }
                } else if next == u32::MAX {
                    next = n.link[lane];
                } else {
                    stack[sp] = n.link[lane];
                    sp += 1;
                }
            }
            if next != u32::MAX {
                node = next;
            } else if sp > 0 {
                sp -= 1;
                node = stack[sp];
            } else {
                return false;
            }
        }
    }
}

impl InstanceGeometry {
    /// Shared geometry with its own hierarchy ([`Bvh`]) in object space.
    pub fn new(name: impl Into<String>, objects: Vec<Object>) -> Self {
        let bounds = objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.shape.bounds()));
        let accel = Box::new(Bvh::build(&objects));
        Self {
            name: name.into(),
            objects,
            accel,
            bounds,
            shading: None,
            modified_instances: Vec::new(),
        }
    }
}

impl ObjectIndex for Bvh {
    fn intersect(&self, objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        Bvh::intersect(self, objects, ray, tmin, tmax)
    }

    fn occluded(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        Bvh::occluded(self, objects, ray, tmin, tmax, ignore)
    }

    fn memory_bytes(&self) -> usize {
        Bvh::memory_bytes(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rng::Rng;
    use crate::geometry::Shape;

    /// A node's corners in single precision never cut into what they
    /// bound: each is the nearest single-precision number on the outer
    /// side, across zero, at the ends of the range and beyond it.
    #[test]
    fn node_corners_round_outwards_to_the_nearest_single() {
        let mut rng = Rng::new(7);
        let mut xs = vec![
            0.0,
            -0.0,
            1e-50,
            -1e-50,
            1e-40,
            -1e-40,
            1.0,
            -1.0,
            0.1,
            -0.1,
            1e5 + 1e-9,
            -1e5 - 1e-9,
            f64::from(f32::MAX),
            -f64::from(f32::MAX),
            1e39,
            -1e39,
            1e300,
            -1e300,
        ];
        for _ in 0..2000 {
            let e = rng.next_f64() * 80.0 - 40.0;
            let sign = if rng.next_f64() < 0.5 { -1.0 } else { 1.0 };
            xs.push(sign * rng.next_f64() * 10f64.powf(e));
        }
        for x in xs {
            let (d, u) = (round_down(x), round_up(x));
            assert!(f64::from(d) <= x && x <= f64::from(u), "{x}: {d} {u}");
            // A ref's rounding flags give the same corners.
            let r = Ref::new(9, [x, -x, x], [x, -x, x]);
            let (lo, hi) = r.outward();
            assert_eq!(lo.map(f32::to_bits), [d, -u, d].map(f32::to_bits), "{x}");
            assert_eq!(hi.map(f32::to_bits), [u, -d, u].map(f32::to_bits), "{x}");
            assert_eq!((r.id(), r.centre()[3]), (9, 0.0));
            if f64::from(d) == x {
                assert_eq!(f64::from(u), x, "{x}");
            } else {
                // Adjacent: nothing single-precision lies between them.
                let above_d = if d == 0.0 {
                    f32::from_bits(1)
                } else if d > 0.0 {
                    f32::from_bits(d.to_bits() + 1)
                } else {
                    f32::from_bits(d.to_bits() - 1)
                };
                assert_eq!(above_d, u, "{x}: {d} {u}");
            }
        }
        assert_eq!(round_up(1e300), f32::INFINITY);
        assert_eq!(round_down(1e300), f32::MAX);
        assert_eq!(round_down(-1e300), f32::NEG_INFINITY);
        assert_eq!(round_up(-1e300), -f32::MAX);
        assert_eq!(step_down(f32::MIN), f32::NEG_INFINITY);
        assert_eq!(step_up(f32::MAX), f32::INFINITY);
        assert_eq!(step_down(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(step_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(step_up(-0.0), f32::from_bits(1));
        assert_eq!(step_down(0.0), -f32::from_bits(1));
    }

    fn scene(seed: u64, n: usize) -> Vec<Object> {
        scene_at(seed, n, 1.0)
    }

    /// [`scene`] with every length times `scale`.
    fn scene_at(seed: u64, n: usize, scale: f64) -> Vec<Object> {
        let mut rng = Rng::new(seed);
        let mut v = || Vec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * scale;
        let mut out = Vec::new();
        while out.len() < n {
            let c = v() * 10.0;
            let (a, b) = (c + v() * 0.5, c + v() * 0.5);
            let shape = if out.len() % 7 == 0 {
                Shape::sphere(c, 0.1 * scale, false)
            } else {
                Shape::polygon(vec![c, a, b])
            };
            if let Ok(shape) = shape {
                out.push(Object {
                    name: String::new(),
                    shape,
                    material: 0,
                });
            }
        }
        // Coincident copies: centres that do not spread.
        for _ in 0..40 {
            out.push(out[1].clone());
        }
        out
    }

    /// Lane `l` of `n` in double precision.
    fn lane_box(n: &Wide, l: usize) -> Aabb {
        let c = |k: usize| {
            Vec3::new(
                n.b[0][k][l].into(),
                n.b[1][k][l].into(),
                n.b[2][k][l].into(),
            )
        };
        Aabb::new(c(0), c(1))
    }

    /// `b` rounded outwards to single precision.
    fn rounded(b: Aabb) -> Aabb {
        let (lo, hi) = (b.min.to_array(), b.max.to_array());
        Aabb::new(
            Vec3::from_array(lo.map(|x| f64::from(round_down(x)))),
            Vec3::from_array(hi.map(|x| f64::from(round_up(x)))),
        )
    }

    /// Every child box is the union of what it holds, rounded outwards
    /// to single precision: its objects' boxes enlarged by the margin, or
    /// its node's children's boxes (already rounded).
    fn check_boxes(bvh: &Bvh, objects: &[Object], node: u32, margin: f64) -> usize {
        let n = &bvh.nodes[node as usize];
        let mut held = 0;
        for l in 0..4 {
            let lane = lane_box(n, l);
            if lane.is_empty() {
                continue;
            }
            let want = if n.count[l] > 0 {
                let s = n.link[l] as usize;
                held += n.count[l] as usize;
                rounded(
                    bvh.ids[s..s + n.count[l] as usize]
                        .iter()
                        .fold(Aabb::EMPTY, |b, &id| {
                            let o = objects[id as usize].shape.bounds();
                            b.union(Aabb::new(o.min - margin, o.max + margin))
                        }),
                )
            } else {
                held += check_boxes(bvh, objects, n.link[l], margin);
                let c = &bvh.nodes[n.link[l] as usize];
                (0..4).fold(Aabb::EMPTY, |b, k| b.union(lane_box(c, k)))
            };
            assert_eq!(
                (lane.min, lane.max),
                (want.min, want.max),
                "node {node} lane {l}"
            );
        }
        held
    }

    #[test]
    fn bvh_build_is_deterministic_and_boxes_exact() {
        for (seed, n) in [(1, 3), (2, 9), (3, 300), (4, 5000)] {
            let objects = scene(seed, n);
            let a = Bvh::build(&objects);
            let b = Bvh::build(&objects);
            assert_eq!(a.ids, b.ids);
            assert_eq!(a.depth, b.depth);
            assert_eq!(a.nodes.len(), b.nodes.len());
            for (x, y) in a.nodes.iter().zip(&b.nodes) {
                assert_eq!((x.link, x.count), (y.link, y.count));
                assert_eq!(format!("{:?}", x.b), format!("{:?}", y.b));
            }
            let scene_box = objects
                .iter()
                .fold(Aabb::EMPTY, |b, o| b.union(o.shape.bounds()));
            let margin = 1e-9 * (scene_box.extent().max_element() + scene_box.magnitude());
            assert_eq!(check_boxes(&a, &objects, 0, margin), objects.len());
            let mut ids = a.ids.clone();
            ids.sort_unstable();
            assert!(ids.iter().copied().eq(0..objects.len() as ObjectId));
            assert!(a.stats().leaves * MAX_LEAF >= objects.len());
        }
    }

    /// A slab test's mask and entry distances (widened to double
    /// precision, which is exact), portable and (where the processor has
    /// it) AVX2.
    pub(super) fn enter_on_every_set<S: NodeTest>(
        s: &S,
        n: &Wide,
        tmin: S::T,
        tmax: S::T,
    ) -> Vec<(u32, [u64; 4])> {
        let bits = |(m, t0): (u32, [S::T; 4])| (m, t0.map(|t| t.into().to_bits()));
        // SAFETY: portable code.
        let mut out = vec![bits(unsafe { s.enter::<Portable>(n, tmin, tmax) })];
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            #[target_feature(enable = "avx2")]
            unsafe fn avx2<S: NodeTest>(
                s: &S,
                n: &Wide,
                tmin: S::T,
                tmax: S::T,
            ) -> (u32, [S::T; 4]) {
                s.enter::<Avx2>(n, tmin, tmax)
            }
            // SAFETY: the processor has AVX2.
            out.push(bits(unsafe { avx2(s, n, tmin, tmax) }));
        }
        out
    }

    /// A node's planes found by byte offset are the ones its index names.
    #[test]
    fn plane_offsets_name_the_planes() {
        let mut n = Wide::UNUSED;
        for a in 0..3 {
            for k in 0..2 {
                n.b[a][k] = std::array::from_fn(|l| (10 * a + 4 * k + l) as f32);
            }
        }
        for a in 0..3 {
            for k in 0..2 {
                // SAFETY: an offset `plane_at` made; four floats there.
                let p = unsafe { std::slice::from_raw_parts(n.planes_at(Wide::plane_at(a, k)), 4) };
                assert_eq!(p, n.b[a][k], "axis {a}, plane {k}");
            }
        }
    }

    /// The portable slab test and the AVX2 one give the same masks and
    /// entry distances, bit for bit, at every node, and the traversals
    /// compiled for each the same nearest and any hits: rays from inside
    /// and outside the scene, along the axes (infinite inverses), in a box
    /// plane (the `0 * inf` NaN, which must keep the bound), at scales 1e-5
    /// to 1e5.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn instruction_sets_agree_at_every_node() {
        let mut rng = Rng::new(17);
        for scale in [1e-5, 1.0, 1e5] {
            let objects = scene_at(6, 1500, scale);
            let bvh = Bvh::build(&objects);
            let mut hits = 0;
            for i in 0..300 {
                let mut v = || Vec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
                let mut o = (v() * 14.0 - Vec3::splat(2.0)) * scale;
                // Half the rays towards the objects' region.
                let mut d = if i % 2 == 0 {
                    v() * 10.0 * scale - o
                } else {
                    v() - Vec3::splat(0.5)
                };
                match i % 6 {
                    0 => d.x = 0.0,
                    1 => (d.y, d.z) = (0.0, 0.0),
                    // In the lower plane of a root child's box.
                    2 => (o.x, d.x) = (f64::from(bvh.nodes[0].b[0][0][0]), 0.0),
                    _ => {}
                }
                if d.length() == 0.0 {
                    continue;
                }
                let ray = Ray::new(o, d.normalize());
                let pre = PreparedRay::new(&ray);
                let slab = Slab::new(&ray, pre.inv_dir);
                let tmin = 1e-9 * scale;
                let tmax = if i % 4 < 2 {
                    f64::INFINITY
                } else {
                    8.0 * scale
                };
                let slab32 =
                    single::Slab32::new(&ray, pre.inv_dir, tmin).expect("within the range");
                let (t0, t1) = (single::down(tmin), single::up(tmax));
                for n in &bvh.nodes {
                    let all = enter_on_every_set(&slab, n, tmin, tmax);
                    assert!(all.iter().all(|x| *x == all[0]), "ray {i}: {all:?}");
                    // The single-precision test: the same on every set, and
                    // a superset of the double-precision test's children
                    // (its slack, 2^-20 of each distance, is far wider than
                    // double precision's rounding).
                    let all32 = enter_on_every_set(&slab32, n, t0, t1);
                    assert!(all32.iter().all(|x| *x == all32[0]), "ray {i}: {all32:?}");
                    assert_eq!(all32[0].0 & all[0].0, all[0].0, "ray {i}");
                }
                // SAFETY: portable code.
                let portable = unsafe {
                    bvh.intersect_with::<{ 3 * STACK + 1 }, Portable, _>(
                        &objects[..],
                        &ray,
                        tmin,
                        tmax,
                    )
                };
                hits += portable.is_some() as usize;
                if !std::arch::is_x86_feature_detected!("avx2") {
                    continue;
                }
                let key = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.object));
                // SAFETY: the processor has AVX2.
                let avx2 = unsafe { bvh.intersect_avx2(&objects[..], &ray, tmin, tmax) };
                assert_eq!(key(avx2), key(portable), "ray {i}");
                // And the any-hit traversals, to the hit and short of it.
                let end = portable.map_or(tmax, |h| 0.5 * (tmin + h.t));
                for t in [end, tmax] {
                    // SAFETY: portable code, and the processor has AVX2.
                    let (p, a) = unsafe {
                        (
                            bvh.occluded_impl::<{ 3 * STACK }, Portable, _>(
                                &objects[..],
                                &ray,
                                tmin,
                                t,
                                None,
                            ),
                            bvh.occluded_avx2(&objects[..], &ray, tmin, t, None),
                        )
                    };
                    assert_eq!(a, p, "ray {i}");
                }
            }
            assert!(hits > 30, "{hits} rays hit at scale {scale}");
        }
    }
}
