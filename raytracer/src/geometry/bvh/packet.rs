//! Coherent rays through the hierarchy as packets: a screen tile's primary
//! rays, a shaded point's shadow rays towards one light.
//!
//! The nodes are visited once for the whole packet. At each node an
//! interval test ([`Frustum`]) rejects the children no ray of the packet can
//! enter, with one slab test for all of them; of the rest, each ray that
//! may enter the node is tested on its own, in packet order, and a child is
//! entered with the rays whose test entered it (a mask of 64 bits on the
//! pending stack). At a node with no leaf among its children the tests stop
//! once every child has a ray, and the rays not tested go down with every
//! child: above, where a tile's rays go the same way, a node costs about
//! one ray. Below, a child is visited only by the rays that enter it, so a
//! tile whose rays part (a far, thin building's edges) costs about what its
//! rays would cost alone, not the union of their paths.
//!
//! A leaf child is tested once every ray's test of the node is done, leaf
//! by leaf, with all the rays that entered it (a nearest-hit packet takes
//! its leaves in the order the first ray to enter each entered them, and a
//! ray skips a leaf that starts beyond its nearest hit so far). Testing
//! each ray's leaves as its node test found them, nearest first, took the
//! 8 x 8 primary packets 0.500 of Embree's streams against 0.547 this way
//! (medians of three rounds alternating), shadow packets 1.36 of
//! `rtcOccluded1` against 1.49: one leaf's rays in a tight loop rather than
//! a branch on every ray's lanes, the leaf's blocks kept in the cache.
//!
//! **Same answers as one ray at a time.** The interval test is
//! conservative for the rounded arithmetic of the per-ray test: the entry
//! distance of a ray, `(plane - origin) * inverse`, rounded twice, is
//! monotone in the origin and in the inverse direction (rounding to nearest
//! is monotone), so its least and greatest values over the packet lie at
//! the corners of the packet's ranges; an axis whose inverse directions
//! change sign within the packet (or are infinite) is left out of the test,
//! which only weakens it. A ray left out of a child's mask failed its own
//! test of that child, and its segment only shrinks. The objects a ray
//! meets are tested with the same code ([`Tester`]), and the answer (the
//! nearest hit, the smaller id of equal ones; any hit) does not depend on
//! the order objects are tested in.

#[cfg(target_arch = "x86_64")]
use super::Avx2;
use super::{fmax, fmin, leaf, Bvh, Enter, Portable, Slab, Tester, Wide, STACK};
use crate::geometry::prims::TriRay;
use crate::geometry::robust::next_up;
use crate::geometry::shape::{Hit, Object, ObjectId, ObjectSet};
use crate::geometry::{PreparedRay, Ray};
use std::cmp::Ordering;
use std::mem::MaybeUninit;

/// Most rays in one packet (an 8 x 8 tile).
pub const PACKET: usize = 64;

/// For each set of four children (bit `i` for child `i`), all ones in the
/// lanes of the children in it.
const LANE_MASKS: [[u64; 4]; 16] = {
    let mut t = [[0u64; 4]; 16];
    let mut m = 0;
    while m < 16 {
        let mut l = 0;
        while l < 4 {
            t[m][l] = if (m >> l) & 1 != 0 { u64::MAX } else { 0 };
            l += 1;
        }
        m += 1;
    }
    t
};

/// Adds ray `r` to the masks of the children (`lanes`, one bit a child)
/// its own test entered: without a branch per child (four vector
/// operations).
#[inline(always)]
fn mark_entered(entered: &mut [u64; 4], lanes: u32, r: usize) {
    let (bit, masks) = (1u64 << r, &LANE_MASKS[lanes as usize & 15]);
    for (e, m) in entered.iter_mut().zip(masks) {
        *e |= m & bit;
    }
}

/// Values on the stack, at most `N` of them: a packet's per-ray state
/// ([`PerRay`]) and its pending nodes ([`Pending`]). Packets are traced by
/// the thousand, and heap buffers made and freed for each one made the
/// allocator hand their pages back to the system and fault them in again
/// (the program's mimalloc purges freed memory at once, for its peak
/// resident set): 5,209 `madvise` calls in one round of `hybrid-rt bench
/// --embree` on the studio, 1,703 with these buffers, and primary rays as
/// 8 x 8 packets 1.47 times as fast. A fixed array rather than a
/// `SmallVec`, whose every push asks whether it has spilled to the heap
/// (the shadow packets' set-up took 48M instructions in `SmallVec`'s
/// code), and which `SmallVec::with_capacity`, left out of line, returned
/// by a copy of its 3 KiB (a `memcpy` for every primary packet). Nothing
/// is written until pushed.
pub(crate) struct Fixed<T: Copy, const N: usize> {
    len: usize,
    v: [MaybeUninit<T>; N],
}

/// Per-ray state of a packet (and a packet's rays, as callers gather
/// them).
pub(crate) type PerRay<T> = Fixed<T, PACKET>;

/// Pending nodes of a packet's traversal: each wide level of the tree
/// leaves at most three (four children entered, one of them taken off
/// next), and the hierarchy is at most [`STACK`] levels deep.
type Pending<T> = Fixed<T, { 3 * STACK + 1 }>;

impl<T: Copy, const N: usize> Fixed<T, N> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Fixed {
            len: 0,
            v: [const { MaybeUninit::uninit() }; N],
        }
    }

    /// # Panics
    /// If it holds `N` values already.
    #[inline(always)]
    pub(crate) fn push(&mut self, x: T) {
        self.v[self.len].write(x);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: values below the old `len` were written by `push`.
        Some(unsafe { self.v[self.len].assume_init() })
    }

    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [T] {
        // SAFETY: the first `len` values were written by `push`, and `T`
        // is `Copy` (no drop to run).
        unsafe { std::slice::from_raw_parts_mut(self.v.as_mut_ptr().cast(), self.len) }
    }
}

impl<T: Copy, const N: usize> std::ops::Deref for Fixed<T, N> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: as in `as_mut_slice`.
        unsafe { std::slice::from_raw_parts(self.v.as_ptr().cast(), self.len) }
    }
}

impl<T: Copy, const N: usize> std::ops::DerefMut for Fixed<T, N> {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        self.as_mut_slice()
    }
}

/// A ray of a packet: the ray and its segment `(tmin, tmax)`.
pub type Segment = (Ray, f64, f64);

/// The packet's ranges, for the interval test.
struct Frustum {
    /// Axes in the test: the packet's origins on them are finite, and its
    /// inverse directions finite, nonzero and of one sign.
    axes: [bool; 3],
    o_lo: [f64; 3],
    o_hi: [f64; 3],
    inv_lo: [f64; 3],
    inv_hi: [f64; 3],
    /// Index (0 lower, 1 upper) of the plane the packet enters by.
    near: [usize; 3],
    /// Whether every ray enters by the planes `near` names (on every axis
    /// its inverse directions have one sign).
    uniform: bool,
    /// The least `tmin` of the packet.
    tmin: f64,
}

impl Frustum {
    #[inline(always)]
    fn new(slabs: &[Slab], tmin: &[f64]) -> Self {
        let mut f = Frustum {
            axes: [true; 3],
            o_lo: [f64::INFINITY; 3],
            o_hi: [f64::NEG_INFINITY; 3],
            inv_lo: [f64::INFINITY; 3],
            inv_hi: [f64::NEG_INFINITY; 3],
            near: [0; 3],
            uniform: true,
            tmin: tmin.iter().fold(f64::INFINITY, |m, &t| fmin(t, m)),
        };
        // One pass over the rays, all three axes, without branches. `x *
        // 0` is a zero for a finite `x` and NaN otherwise, so `nonfinite`
        // stays 0 (its sign bits cleared) while every origin and inverse
        // is finite: an OR, not a sum, whose chain of dependent additions
        // was 4.5% of a primary packet's time.
        let mut neg = [0usize; 3];
        let mut nonfinite = [0u64; 3];
        for s in slabs {
            for a in 0..3 {
                let (o, inv) = (s.o[a], s.inv[a]);
                f.o_lo[a] = fmin(o, f.o_lo[a]);
                f.o_hi[a] = fmax(o, f.o_hi[a]);
                f.inv_lo[a] = fmin(inv, f.inv_lo[a]);
                f.inv_hi[a] = fmax(inv, f.inv_hi[a]);
                nonfinite[a] |= (o * 0.0 + inv * 0.0).to_bits() & !(1 << 63);
                neg[a] += s.near[a];
            }
        }
        let finite = nonfinite.map(|x| x == 0);
        for a in 0..3 {
            let mixed = neg[a] != 0 && neg[a] != slabs.len();
            // Of one sign and no zero among them.
            let nonzero = f.inv_lo[a] > 0.0 || f.inv_hi[a] < 0.0;
            f.axes[a] = !mixed && nonzero && finite[a];
            f.uniform &= !mixed;
            f.near[a] = (neg[a] != 0) as usize;
        }
        f
    }

    /// The lanes of `n` some ray of the packet may enter before `cut` (a
    /// bound on every ray's segment end): bit `i` for child `i`.
    ///
    /// Written with selects (`if a < b { a } else { b }`, what `minpd`
    /// does) so it compiles to a few vector instructions: no product here
    /// is NaN (the axes in the test have finite origins and finite,
    /// nonzero inverses, and planes are finite or infinite), so the
    /// selects are the least and greatest values.
    #[inline(always)]
    fn test4(&self, n: &Wide, cut: f64) -> u32 {
        let (min, max) = (fmin::<f64>, fmax::<f64>);
        let mut t0 = [self.tmin; 4];
        let mut t1 = [cut; 4];
        for a in 0..3 {
            if !self.axes[a] {
                continue;
            }
            let lo = n.b[a][self.near[a]].map(f64::from);
            let hi = n.b[a][1 - self.near[a]].map(f64::from);
            let (olo, ohi, ilo, ihi) = (self.o_lo[a], self.o_hi[a], self.inv_lo[a], self.inv_hi[a]);
            for l in 0..4 {
                // The least entry and the greatest exit over the packet.
                let (e0, e1) = (lo[l] - ohi, lo[l] - olo);
                let e = min(min(e0 * ilo, e0 * ihi), min(e1 * ilo, e1 * ihi));
                let (x0, x1) = (hi[l] - ohi, hi[l] - olo);
                let x = max(max(x0 * ilo, x0 * ihi), max(x1 * ilo, x1 * ihi));
                t0[l] = max(e, t0[l]);
                t1[l] = min(x, t1[l]);
            }
        }
        let mut mask = 0;
        for l in 0..4 {
            // A NaN bound (`tmin` or `cut`) rejects nothing.
            mask |= ((t0[l].partial_cmp(&t1[l]) != Some(Ordering::Greater)) as u32) << l;
        }
        mask
    }
}

/// The children of `n` in `mask` that are leaves, and those that are
/// inner nodes.
#[inline(always)]
fn split(n: &Wide, mask: u32) -> (u32, u32) {
    let mut leaves = 0u32;
    for (l, &count) in n.count.iter().enumerate() {
        leaves |= ((count > 0) as u32) << l;
    }
    (mask & leaves, mask & !leaves)
}

/// Object `id` for one ray of a packet: the single-ray traversal's test
/// (the nearest hit, the smaller id of equal ones).
#[inline(always)]
pub(super) fn consider<O: ObjectSet + ?Sized>(
    test: &Tester<O>,
    tmin: f64,
    id: ObjectId,
    cut: &mut f64,
    best: &mut leaf::Best,
) {
    let bound = if best.is_some() { next_up(*cut) } else { *cut };
    if let Some(h) = test.intersect(id, tmin, bound) {
        if best.is_none_or(|(bt, bid, _)| h.t < bt || (h.t == bt && id < bid)) {
            *best = Some((h.t, id, Some(h)));
            *cut = h.t;
        }
    }
}

/// The greatest of `t` (NaNs skipped; `-inf` for none), in four
/// independent lanes rather than one chain of dependent selects.
#[inline(always)]
fn greatest(t: &[f64]) -> f64 {
    let mut m = [f64::NEG_INFINITY; 4];
    let mut chunks = t.chunks_exact(4);
    for c in &mut chunks {
        for l in 0..4 {
            m[l] = fmax(c[l], m[l]);
        }
    }
    for &x in chunks.remainder() {
        m[0] = fmax(x, m[0]);
    }
    m.into_iter().fold(f64::NEG_INFINITY, |a, b| fmax(b, a))
}

/// The mask of a packet's `n` rays (bit `r` for ray `r`).
#[inline(always)]
fn all_rays(n: usize) -> u64 {
    if n >= 64 {
        u64::MAX
    } else {
        (1u64 << n) - 1
    }
}

/// The packet's segment ends, and its rays' constants for the leaves'
/// triangle tests and for the slab tests. The prepared rays themselves are
/// not kept (136 bytes a ray): object tests by id, which need them, are
/// rare (objects without bounds, and leaves' objects beside their blocks'
/// triangles), and prepare their ray again (the same values).
#[inline(always)]
fn prepare(
    rays: &[Segment],
    tmin: &mut PerRay<f64>,
    tmax: &mut PerRay<f64>,
    tri: &mut PerRay<TriRay>,
    slabs: &mut PerRay<Slab>,
) {
    for (ray, t0, t1) in rays {
        let p = PreparedRay::new(ray);
        tmin.push(*t0);
        tmax.push(*t1);
        tri.push(TriRay::new(&p));
        slabs.push(Slab::new(&p.ray, p.inv_dir));
    }
}

impl Bvh {
    /// Leaf child `l` of `n`: its blocks' triangles (where the blocks are
    /// tested) and the ids left to test by id.
    #[inline(always)]
    fn leaf_parts(&self, n: &Wide, l: usize, blocks: bool) -> (&[leaf::Tri4], &[ObjectId]) {
        let (s, count) = (n.link[l] as usize, n.count[l] as usize);
        let (tris, polys) = if blocks {
            self.blocks.leaf(s)
        } else {
            (&[][..], 0)
        };
        (tris, &self.ids[s + polys..s + count])
    }

    /// Nearest hits of a packet of at most [`PACKET`] rays, each with its
    /// segment: `out[i]` is what [`Bvh::intersect`] answers for `rays[i]`,
    /// bit for bit. The rays should be coherent (one tile's primary rays):
    /// any rays give the right answers, coherent ones give them faster.
    ///
    /// # Panics
    /// If there are more than [`PACKET`] rays or `out` is shorter.
    pub fn intersect_packet(&self, objects: &[Object], rays: &[Segment], out: &mut [Option<Hit>]) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.intersect_packet_avx2(objects, rays, out) };
        }
        // SAFETY: portable code.
        unsafe { self.intersect_packet_impl::<Portable>(objects, rays, out) }
    }

    /// [`Bvh::intersect_packet`] compiled for AVX2 (the same IEEE
    /// operations in the same order: the same answers).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_packet_avx2(
        &self,
        objects: &[Object],
        rays: &[Segment],
        out: &mut [Option<Hit>],
    ) {
        self.intersect_packet_impl::<Avx2>(objects, rays, out)
    }

    /// # Safety
    /// `E`'s instructions must be available.
    #[inline(always)]
    unsafe fn intersect_packet_impl<E: Enter>(
        &self,
        objects: &[Object],
        rays: &[Segment],
        out: &mut [Option<Hit>],
    ) {
        let n = rays.len();
        let (mut tmin, mut cut) = (PerRay::new(), PerRay::new());
        let (mut tri, mut slabs) = (PerRay::new(), PerRay::new());
        prepare(rays, &mut tmin, &mut cut, &mut tri, &mut slabs);
        let (tmin, cut) = (&tmin[..], cut.as_mut_slice());
        let (tri, slabs) = (&tri[..], &slabs[..]);
        // Objects `ids` for ray `r`, tested by id.
        let by_id = |r: usize, ids: &[ObjectId], cut: &mut f64, best: &mut leaf::Best| {
            let p = PreparedRay::new(&rays[r].0);
            let test = Tester::new(&self.prims, objects, &p);
            for &id in ids {
                consider(&test, tmin[r], id, cut, best);
            }
        };
        // The leaves' blocks, where the compact data was built for
        // `objects`.
        let blocks =
            (!self.blocks.is_empty() && self.prims.matches(objects)).then_some(&self.prims);
        let mut best = PerRay::<leaf::Best>::new();
        for _ in 0..n {
            best.push(None);
        }
        let best = best.as_mut_slice();
        // Objects without finite bounds: tested by every ray.
        if !self.unbounded.is_empty() {
            for r in 0..n {
                by_id(r, &self.unbounded, &mut cut[r], &mut best[r]);
            }
        }
        if !self.nodes.is_empty() && n > 0 {
            let frustum = Frustum::new(slabs, tmin);
            // Pending nodes, nearest on top: (node, the rays that may enter
            // it, the entry of the first ray that did).
            let mut stack = Pending::<(u32, u64, f64)>::new();
            stack.push((0, all_rays(n), 0.0));
            // Each ray's entries into the current node's children (read
            // only for the rays that entered a leaf there).
            let mut entries = [[0.0f64; 4]; PACKET];
            // The greatest segment end of the packet, found again only
            // after a leaf may have shortened one (segments only shrink:
            // a bound found before is still a bound).
            let mut hi = greatest(cut);
            let mut shortened = false;
            while let Some((node, rays_in, _)) = stack.pop() {
                let n_ = &self.nodes[node as usize];
                if shortened {
                    hi = greatest(cut);
                    shortened = false;
                }
                let mask = frustum.test4(n_, hi);
                if mask == 0 {
                    continue;
                }
                let (leaves, inner) = split(n_, mask);
                // The leaves' blocks fetched while the rays' tests run.
                if blocks.is_some() {
                    let mut lm = leaves;
                    while lm != 0 {
                        let l = lm.trailing_zeros() as usize;
                        lm &= lm - 1;
                        self.blocks.prefetch(n_.link[l] as usize);
                    }
                }
                // The node's planes widened once for the packet where every
                // ray enters by the same ones.
                let planes = frustum.uniform.then(|| E::planes(n_, &frustum.near));
                // Each inner child's first ray's entry, and the rays tested
                // that entered it; the rays that entered each leaf.
                let mut enter = [0.0f64; 4];
                let mut entered = [0u64; 4];
                let mut in_leaf = [0u64; 4];
                let mut open = inner;
                let mut untested = rays_in;
                while untested != 0 {
                    if open == 0 && leaves == 0 {
                        break;
                    }
                    let r = untested.trailing_zeros() as usize;
                    untested &= untested - 1;
                    let (m, t0) = match &planes {
                        Some(p) => E::enter4_at(&slabs[r], p, tmin[r], cut[r]),
                        None => E::enter4(&slabs[r], n_, tmin[r], cut[r]),
                    };
                    let mut newly = m & open;
                    open &= !m;
                    while newly != 0 {
                        let l = newly.trailing_zeros() as usize;
                        newly &= newly - 1;
                        enter[l] = t0[l];
                    }
                    mark_entered(&mut entered, m & inner, r);
                    mark_entered(&mut in_leaf, m & leaves, r);
                    entries[r] = t0;
                }
                // The leaves entered, each with all its rays at once (in
                // the order the first ray to enter each entered them),
                // each ray while the leaf is still in front of its cut.
                if leaves != 0 {
                    let mut order = [(0usize, 0.0f64); 4];
                    let mut k = 0;
                    let mut lm = leaves;
                    while lm != 0 {
                        let l = lm.trailing_zeros() as usize;
                        lm &= lm - 1;
                        if in_leaf[l] == 0 {
                            continue;
                        }
                        let t = entries[in_leaf[l].trailing_zeros() as usize][l];
                        let mut j = k;
                        while j > 0 && order[j - 1].1 > t {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = (l, t);
                        k += 1;
                    }
                    for &(l, _) in &order[..k] {
                        shortened = true;
                        let (tris, ids) = self.leaf_parts(n_, l, blocks.is_some());
                        let mut rm = in_leaf[l];
                        while rm != 0 {
                            let r = rm.trailing_zeros() as usize;
                            rm &= rm - 1;
                            if entries[r][l] > cut[r] {
                                continue;
                            }
                            leaf::nearest::<E>(tris, &tri[r], tmin[r], &mut cut[r], &mut best[r]);
                            if !ids.is_empty() {
                                by_id(r, ids, &mut cut[r], &mut best[r]);
                            }
                        }
                    }
                }
                // Inner children entered, farthest pushed first (ties by
                // lane: deterministic). A child's rays: those tested that
                // entered it and those not tested (the loop stopped once
                // every inner child had a ray, and no child is a leaf).
                let base = stack.len();
                for (l, (&t, &m)) in enter.iter().zip(&entered).enumerate() {
                    if (inner >> l) & 1 == 0 || m == 0 {
                        continue;
                    }
                    let e = (n_.link[l], m | untested, t);
                    stack.push(e);
                    let mut j = stack.len() - 1;
                    while j > base && stack[j - 1].2 < e.2 {
                        stack[j] = stack[j - 1];
                        j -= 1;
                    }
                    stack[j] = e;
                }
            }
        }
        // What the hits read, scattered through memory (a block's
        // triangle's normal and surface word, another object's own data):
        // all asked for first, then read.
        for b in best.iter().flatten() {
            match (b.2, blocks) {
                (None, Some(prims)) => super::prefetch(prims.polygon_hit_ptr(b.1)),
                _ => super::prefetch((&objects[b.1 as usize] as *const Object).cast()),
            }
        }
        for (r, o) in out[..n].iter_mut().enumerate() {
            *o = best[r].map(|(t, id, h)| {
                let h = leaf::reported(h, blocks, id, t);
                Hit::on(&objects[id as usize], id, &rays[r].0, t, &h)
            });
        }
    }
    /// Shadow rays as a packet of at most [`PACKET`] rays: `out[i]` is what
    /// [`Bvh::occluded`] answers for `rays[i]` with `ignore`. The rays
    /// should be coherent (from neighbouring points towards one light, or
    /// from one point towards one area light).
    ///
    /// # Panics
    /// If there are more than [`PACKET`] rays or `out` is shorter.
    pub fn occluded_packet(
        &self,
        objects: &[Object],
        rays: &[Segment],
        ignore: Option<ObjectId>,
        out: &mut [bool],
    ) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.occluded_packet_avx2(objects, rays, ignore, out) };
        }
        // SAFETY: portable code.
        unsafe { self.occluded_packet_impl::<Portable>(objects, rays, ignore, out) }
    }

    /// [`Bvh::occluded_packet`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn occluded_packet_avx2(
        &self,
        objects: &[Object],
        rays: &[Segment],
        ignore: Option<ObjectId>,
        out: &mut [bool],
    ) {
        self.occluded_packet_impl::<Avx2>(objects, rays, ignore, out)
    }

    /// # Safety
    /// `E`'s instructions must be available.
    #[inline(always)]
    unsafe fn occluded_packet_impl<E: Enter>(
        &self,
        objects: &[Object],
        rays: &[Segment],
        ignore: Option<ObjectId>,
        out: &mut [bool],
    ) {
        let n = rays.len();
        let out = &mut out[..n];
        out.fill(false);
        let (mut tmin, mut tmax) = (PerRay::new(), PerRay::new());
        let (mut tri, mut slabs) = (PerRay::new(), PerRay::new());
        prepare(rays, &mut tmin, &mut tmax, &mut tri, &mut slabs);
        let (tmin, tmax) = (&tmin[..], &tmax[..]);
        let (tri, slabs) = (&tri[..], &slabs[..]);
        // Whether one of `ids` other than `ignore` blocks ray `r`.
        // (Called where `ids` is not empty: rarely.)
        let occludes = |r: usize, ids: &[ObjectId]| {
            let p = PreparedRay::new(&rays[r].0);
            let test = Tester::new(&self.prims, objects, &p);
            ids.iter()
                .any(|&id| Some(id) != ignore && test.occludes(id, tmin[r], tmax[r]))
        };
        // The leaves' blocks, where the compact data was built for
        // `objects`.
        let blocks = !self.blocks.is_empty() && self.prims.matches(objects);
        // Rays not yet found blocked.
        let mut live = all_rays(n);
        if !self.unbounded.is_empty() {
            for (r, o) in out.iter_mut().enumerate() {
                if occludes(r, &self.unbounded) {
                    *o = true;
                    live &= !(1u64 << r);
                }
            }
        }
        if self.nodes.is_empty() || live == 0 {
            return;
        }
        let frustum = Frustum::new(slabs, tmin);
        let hi = greatest(tmax);
        // Pending nodes: (node, the rays that may enter it).
        let mut stack = Pending::<(u32, u64)>::new();
        stack.push((0, live));
        while let Some((node, rays_in)) = stack.pop() {
            let rays_in = rays_in & live;
            if rays_in == 0 {
                continue;
            }
            let n_ = &self.nodes[node as usize];
            let mask = frustum.test4(n_, hi);
            if mask == 0 {
                continue;
            }
            let (leaves, inner) = split(n_, mask);
            let planes = frustum.uniform.then(|| E::planes(n_, &frustum.near));
            let mut entered = [0u64; 4];
            let mut in_leaf = [0u64; 4];
            let mut todo = inner;
            let mut untested = rays_in;
            while untested != 0 {
                if todo == 0 && leaves == 0 {
                    break;
                }
                let r = untested.trailing_zeros() as usize;
                untested &= untested - 1;
                let (m, _) = match &planes {
                    Some(p) => E::enter4_at(&slabs[r], p, tmin[r], tmax[r]),
                    None => E::enter4(&slabs[r], n_, tmin[r], tmax[r]),
                };
                todo &= !m;
                mark_entered(&mut entered, m & inner, r);
                mark_entered(&mut in_leaf, m & leaves, r);
            }
            // The leaves entered, each with all its rays still live.
            let mut lm = leaves;
            while lm != 0 {
                let l = lm.trailing_zeros() as usize;
                lm &= lm - 1;
                let (tris, ids) = self.leaf_parts(n_, l, blocks);
                let mut rm = in_leaf[l] & live;
                while rm != 0 {
                    let r = rm.trailing_zeros() as usize;
                    rm &= rm - 1;
                    if leaf::any::<E>(tris, &tri[r], tmin[r], tmax[r], ignore)
                        || (!ids.is_empty() && occludes(r, ids))
                    {
                        out[r] = true;
                        live &= !(1u64 << r);
                    }
                }
            }
            if live == 0 {
                return;
            }
            // A child's rays: those tested that entered it and those not
            // tested (the loop stopped once every inner child had a ray,
            // and no child is a leaf).
            for (l, &m) in entered.iter().enumerate() {
                if (inner >> l) & 1 != 0 && m != 0 {
                    stack.push((n_.link[l], (m | untested) & live));
                }
            }
        }
    }
}
