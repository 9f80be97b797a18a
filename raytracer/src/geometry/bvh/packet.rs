//! Coherent rays through the hierarchy as packets: a screen tile's primary
//! rays, a shaded point's shadow rays towards one light.
//!
//! The nodes are visited once for the whole packet. At each node an
//! interval test ([`Frustum`]) rejects the children no ray of the packet can
//! enter, with one slab test for all of them; of the rest, a child is
//! entered with the first ray (in packet order) whose own slab test enters
//! it, and rays before that one are never tested below it (they did not
//! enter, and their segment only shrinks). At a node whose children are
//! leaves every ray still in play is tested on its own, so below the upper
//! levels a packet costs what its rays would cost alone; above them, where
//! a tile's rays go the same way, it costs one ray.
//!
//! **Same answers as one ray at a time.** The interval test is
//! conservative for the rounded arithmetic of the per-ray test: the entry
//! distance of a ray, `(plane - origin) * inverse`, rounded twice, is
//! monotone in the origin and in the inverse direction (rounding to nearest
//! is monotone), so its least and greatest values over the packet lie at
//! the corners of the packet's ranges; an axis whose inverse directions
//! change sign within the packet (or are infinite) is left out of the test,
//! which only weakens it. The objects a ray meets are tested with the same
//! code ([`Tester`]), and the answer (the nearest hit, the smaller id of
//! equal ones; any hit) does not depend on the order objects are tested in.

#[cfg(target_arch = "x86_64")]
use super::Avx2;
use super::{leaf, Bvh, Enter, Portable, Slab, Tester, Wide, SHALLOW, STACK};
use crate::geometry::robust::next_up;
use crate::geometry::shape::{Hit, Object, ObjectId, ObjectSet, ShapeHit};
use crate::geometry::{PreparedRay, Ray};
use smallvec::SmallVec;

/// Most rays in one packet (an 8 x 8 tile).
pub const PACKET: usize = 64;

/// Per-ray state of a packet, on the stack. Packets are traced by the
/// thousand, and heap buffers made and freed for each one made the
/// allocator hand their pages back to the system and fault them in again
/// (the program's mimalloc purges freed memory at once, for its peak
/// resident set): 5,209 `madvise` calls in one round of `hybrid-rt bench
/// --embree` on the studio, 1,703 with these buffers, and primary rays as
/// 8 x 8 packets 1.47 times as fast.
type PerRay<T> = SmallVec<[T; PACKET]>;

/// Pending nodes of a packet's traversal: on the stack for trees up to
/// [`SHALLOW`] levels deep (each wide level leaves at most three pending).
type Pending<T> = SmallVec<[T; 128]>;
const _: () = assert!(3 * SHALLOW < 128);

/// A ray of a packet: the ray and its segment `(tmin, tmax)`.
pub type Segment = (Ray, f64, f64);

/// The packet's ranges, for the interval test.
struct Frustum {
    /// Axes in the test: the packet's inverse directions on them are
    /// finite and of one sign.
    axes: [bool; 3],
    o_lo: [f64; 3],
    o_hi: [f64; 3],
    inv_lo: [f64; 3],
    inv_hi: [f64; 3],
    /// Index (0 lower, 1 upper) of the plane the packet enters by.
    near: [usize; 3],
    /// The least `tmin` of the packet.
    tmin: f64,
}

impl Frustum {
    fn new(pre: &[PreparedRay], tmin: &[f64]) -> Self {
        let mut f = Frustum {
            axes: [true; 3],
            o_lo: [f64::INFINITY; 3],
            o_hi: [f64::NEG_INFINITY; 3],
            inv_lo: [f64::INFINITY; 3],
            inv_hi: [f64::NEG_INFINITY; 3],
            near: [0; 3],
            tmin: f64::INFINITY,
        };
        for &t in tmin {
            if t < f.tmin {
                f.tmin = t;
            }
        }
        // One pass over the rays, all three axes (a NaN origin or an
        // infinite inverse takes its axis out of the test).
        let mut neg = [0usize; 3];
        for p in pre {
            let (o, inv) = (p.ray.origin.to_array(), p.inv_dir.to_array());
            for a in 0..3 {
                if o[a] < f.o_lo[a] {
                    f.o_lo[a] = o[a];
                }
                if o[a] > f.o_hi[a] {
                    f.o_hi[a] = o[a];
                }
                if inv[a] < f.inv_lo[a] {
                    f.inv_lo[a] = inv[a];
                }
                if inv[a] > f.inv_hi[a] {
                    f.inv_hi[a] = inv[a];
                }
                neg[a] += inv[a].is_sign_negative() as usize;
                f.axes[a] &= inv[a].is_finite() & o[a].is_finite();
            }
        }
        for (a, &neg) in neg.iter().enumerate() {
            if neg != 0 && neg != pre.len() {
                f.axes[a] = false;
            }
            f.near[a] = (neg != 0) as usize;
        }
        f
    }

    /// The lanes of `n` some ray of the packet may enter before `cut` (a
    /// bound on every ray's segment end): bit `i` for child `i`.
    #[inline(always)]
    fn test4(&self, n: &Wide, cut: f64) -> u32 {
        let mut t0 = [self.tmin; 4];
        let mut t1 = [cut; 4];
        for a in 0..3 {
            if !self.axes[a] {
                continue;
            }
            let lo = n.b[a][self.near[a]].map(f64::from);
            let hi = n.b[a][1 - self.near[a]].map(f64::from);
            for l in 0..4 {
                // The least entry and the greatest exit over the packet.
                let (e0, e1) = (lo[l] - self.o_hi[a], lo[l] - self.o_lo[a]);
                let e = (e0 * self.inv_lo[a])
                    .min(e0 * self.inv_hi[a])
                    .min(e1 * self.inv_lo[a])
                    .min(e1 * self.inv_hi[a]);
                let (x0, x1) = (hi[l] - self.o_hi[a], hi[l] - self.o_lo[a]);
                let x = (x0 * self.inv_lo[a])
                    .max(x0 * self.inv_hi[a])
                    .max(x1 * self.inv_lo[a])
                    .max(x1 * self.inv_hi[a]);
                t0[l] = if e > t0[l] { e } else { t0[l] };
                t1[l] = if x < t1[l] { x } else { t1[l] };
            }
        }
        let mut mask = 0;
        for l in 0..4 {
            // A NaN (an empty lane's infinite planes) rejects nothing.
            if t0[l].partial_cmp(&t1[l]) != Some(std::cmp::Ordering::Greater) {
                mask |= 1 << l;
            }
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
    best: &mut Option<(f64, ObjectId, ShapeHit)>,
) {
    let bound = if best.is_some() { next_up(*cut) } else { *cut };
    if let Some(h) = test.intersect(id, tmin, bound) {
        if best.is_none_or(|(bt, bid, _)| h.t < bt || (h.t == bt && id < bid)) {
            *best = Some((h.t, id, h));
            *cut = h.t;
        }
    }
}

impl Bvh {
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
        let pre: PerRay<PreparedRay> = rays.iter().map(|(r, ..)| PreparedRay::new(r)).collect();
        let pre = &pre[..];
        let test: PerRay<Tester> = pre
            .iter()
            .map(|p| Tester::new(&self.prims, objects, p))
            .collect();
        let test = &test[..];
        let compact: PerRay<_> = test
            .iter()
            .map(|t| t.compact().filter(|_| !self.blocks.is_empty()))
            .collect();
        let compact = &compact[..];
        let tmin: PerRay<f64> = rays.iter().map(|r| r.1).collect();
        let tmin = &tmin[..];
        let mut cut: PerRay<f64> = rays.iter().map(|r| r.2).collect();
        let cut = &mut cut[..];
        let mut best: PerRay<Option<(f64, ObjectId, ShapeHit)>> = SmallVec::from_elem(None, n);
        let best = &mut best[..];
        // Objects without finite bounds: tested by every ray.
        for &id in &self.unbounded {
            for r in 0..n {
                consider(&test[r], tmin[r], id, &mut cut[r], &mut best[r]);
            }
        }
        if !self.nodes.is_empty() && n > 0 {
            let slabs: PerRay<Slab> = pre.iter().map(|p| Slab::new(&p.ray, p.inv_dir)).collect();
            let slabs = &slabs[..];
            let frustum = Frustum::new(pre, tmin);
            let cap = 3 * if self.depth as usize <= SHALLOW {
                SHALLOW
            } else {
                STACK
            } + 1;
            // Pending nodes, nearest on top: (node, first ray, entry of
            // that ray).
            let mut stack: Pending<(u32, u32, f64)> = SmallVec::with_capacity(cap);
            stack.push((0, 0, 0.0));
            while let Some((node, first, _)) = stack.pop() {
                let first = first as usize;
                let n_ = &self.nodes[node as usize];
                let hi = cut[first..n]
                    .iter()
                    .copied()
                    .fold(f64::NEG_INFINITY, f64::max);
                let mask = frustum.test4(n_, hi);
                if mask == 0 {
                    continue;
                }
                let (leaves, inner) = split(n_, mask);
                // Each inner child's first ray and its entry.
                let mut enter = [(u32::MAX, 0.0f64); 4];
                let mut open = inner;
                for r in first..n {
                    if open == 0 && leaves == 0 {
                        break;
                    }
                    let (m, t0) = E::enter4(&slabs[r], n_, tmin[r], cut[r]);
                    let mut newly = m & open;
                    open &= !m;
                    while newly != 0 {
                        let l = newly.trailing_zeros() as usize;
                        newly &= newly - 1;
                        enter[l] = (r as u32, t0[l]);
                    }
                    let mut lm = m & leaves;
                    if lm == 0 {
                        continue;
                    }
                    // This ray's leaves, nearest first, each while still
                    // in front of the ray's cut.
                    let mut order = [(0usize, 0.0f64); 4];
                    let mut k = 0;
                    while lm != 0 {
                        let l = lm.trailing_zeros() as usize;
                        lm &= lm - 1;
                        let mut j = k;
                        while j > 0 && order[j - 1].1 > t0[l] {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = (l, t0[l]);
                        k += 1;
                    }
                    for &(l, t) in &order[..k] {
                        if t > cut[r] {
                            break;
                        }
                        let (s, count) = (n_.link[l] as usize, n_.count[l] as usize);
                        let mut ids = &self.ids[s..s + count];
                        if let Some((prims, tr)) = compact[r] {
                            let (tris, polys) = self.blocks.leaf(s);
                            leaf::nearest::<E>(tris, prims, tr, tmin[r], &mut cut[r], &mut best[r]);
                            ids = &ids[polys..];
                        }
                        for &id in ids {
                            consider(&test[r], tmin[r], id, &mut cut[r], &mut best[r]);
                        }
                    }
                }
                // Inner children entered, farthest pushed first (ties by
                // lane: deterministic).
                let base = stack.len();
                for (l, &(r, t)) in enter.iter().enumerate() {
                    if r == u32::MAX {
                        continue;
                    }
                    let e = (n_.link[l], r, t);
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
        for (r, o) in out[..n].iter_mut().enumerate() {
            *o = best[r].map(|(t, id, h)| Hit::on(&objects[id as usize], id, &rays[r].0, t, &h));
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
        let pre: PerRay<PreparedRay> = rays.iter().map(|(r, ..)| PreparedRay::new(r)).collect();
        let pre = &pre[..];
        let test: PerRay<Tester> = pre
            .iter()
            .map(|p| Tester::new(&self.prims, objects, p))
            .collect();
        let test = &test[..];
        let occludes = |r: usize, id: ObjectId| {
            Some(id) != ignore && test[r].occludes(id, rays[r].1, rays[r].2)
        };
        let tri_rays: PerRay<_> = test
            .iter()
            .map(|t| {
                t.compact()
                    .filter(|_| !self.blocks.is_empty())
                    .map(|(_, tr)| tr)
            })
            .collect();
        let tri_rays = &tri_rays[..];
        let mut open = n;
        for (r, o) in out.iter_mut().enumerate() {
            if self.unbounded.iter().any(|&id| occludes(r, id)) {
                *o = true;
                open -= 1;
            }
        }
        if self.nodes.is_empty() || open == 0 {
            return;
        }
        let slabs: PerRay<Slab> = pre.iter().map(|p| Slab::new(&p.ray, p.inv_dir)).collect();
        let slabs = &slabs[..];
        let tmin: PerRay<f64> = rays.iter().map(|r| r.1).collect();
        let tmin = &tmin[..];
        let frustum = Frustum::new(pre, tmin);
        let hi = rays.iter().map(|r| r.2).fold(f64::NEG_INFINITY, f64::max);
        // Pending nodes: (node, first ray).
        let mut stack: Pending<(u32, u32)> = SmallVec::new();
        stack.push((0, 0));
        while let Some((node, first)) = stack.pop() {
            let n_ = &self.nodes[node as usize];
            let mask = frustum.test4(n_, hi);
            if mask == 0 {
                continue;
            }
            let (leaves, inner) = split(n_, mask);
            let mut enter = [u32::MAX; 4];
            let mut todo = inner;
            for r in first as usize..n {
                if todo == 0 && leaves == 0 {
                    break;
                }
                if out[r] {
                    continue;
                }
                let (m, _) = E::enter4(&slabs[r], n_, rays[r].1, rays[r].2);
                let mut newly = m & todo;
                todo &= !m;
                while newly != 0 {
                    let l = newly.trailing_zeros() as usize;
                    newly &= newly - 1;
                    enter[l] = r as u32;
                }
                let mut lm = m & leaves;
                while lm != 0 {
                    let l = lm.trailing_zeros() as usize;
                    lm &= lm - 1;
                    let (s, count) = (n_.link[l] as usize, n_.count[l] as usize);
                    let mut ids = &self.ids[s..s + count];
                    let mut hit = false;
                    if let Some(tr) = tri_rays[r] {
                        let (tris, polys) = self.blocks.leaf(s);
                        hit = leaf::any::<E>(tris, tr, rays[r].1, rays[r].2, ignore);
                        ids = &ids[polys..];
                    }
                    if hit || ids.iter().any(|&id| occludes(r, id)) {
                        out[r] = true;
                        open -= 1;
                        break;
                    }
                }
            }
            if open == 0 {
                return;
            }
            for (l, &r) in enter.iter().enumerate() {
                if r != u32::MAX {
                    stack.push((n_.link[l], r));
                }
            }
        }
    }
}
