//! A leaf's triangles four at a time.
//!
//! The compact data ([`Prims`]) keeps a polygon's triangles in pairs, one
//! polygon at a time, so a leaf of single triangles (a mesh) runs the
//! two-lane test once per triangle with its second lane repeating the
//! first. Here, at the build, each leaf's polygons are gathered into
//! blocks of four triangles from any of its objects (`v[vertex][axis]
//! [lane]`, each lane with its object's id), tested with the same
//! watertight test four lanes wide (AVX2), or lane by lane. Embree's
//! leaves hold triangles four to a block for the same reason. A leaf
//! starts in the block the leaf before it left open where its triangles
//! fit there without taking more blocks than they fill (a mesh's leaves of
//! one or two triangles share blocks: the benchmark's 48,684 triangles in
//! 12,778 blocks rather than 27,259); unused lanes at the end of a block
//! repeat its last triangle.
//!
//! **Same answers.** Each lane does the pair test's operations
//! ([`crate::geometry::intersect_triangle`]'s, in its order, with its exact
//! recomputation of a zero edge function), so each triangle's distance is
//! bit for bit the pair test's; a hit is taken with the traversal's rule
//! (the nearest, the smaller id of equal ones), which does not depend on
//! the order triangles are tested in, nor on testing more triangles than
//! the leaf's own (a neighbour's, in a shared block: objects of the scene
//! on the ray, whose hits are real). Objects that are not polygons are
//! tested by id as before: a leaf's ids hold its polygons first.

use super::{Enter, Wide};
use crate::geometry::prims::{Prims, TriRay};
use crate::geometry::robust::{diff_of_products, next_up};
use crate::geometry::shape::{Object, ObjectId, Shape, ShapeHit};

/// Four triangles side by side: `v[vertex][axis][lane]`, and each lane's
/// object.
#[derive(Debug, Clone, Copy)]
pub(super) struct Tri4 {
    v: [[[f64; 4]; 3]; 3],
    id: [ObjectId; 4],
}

/// Every leaf's blocks, in leaf order. Neighbouring leaves share a block
/// where the later one fits in the lanes the earlier one left (without
/// needing more blocks than its own triangles fill): a leaf tests its
/// blocks whole, its neighbours' triangles too. That changes no answer
/// (they are objects of the scene on the ray: the nearest hit, the
/// smaller id of equal ones, or any hit, is the same over more objects
/// as long as it is over every object the traversal must test) and it
/// halves the blocks of a mesh whose leaves hold one or two triangles.
#[derive(Debug, Clone, Default)]
pub(super) struct Blocks {
    /// At a leaf's first position in the hierarchy's ids: its first block,
    /// how many blocks it tests, and how many of its ids (the first ones)
    /// are polygons tested through the blocks. Other positions are unused.
    at: Vec<(u32, u32, u32)>,
    tris: Vec<Tri4>,
}

impl Blocks {
    /// The blocks of the leaves of `nodes` (links into `ids`), putting
    /// each leaf's polygons first in `ids`. Empty when no leaf holds a
    /// polygon.
    pub(super) fn build(nodes: &[Wide], ids: &mut [ObjectId], objects: &[Object]) -> Blocks {
        let triangles = |id: ObjectId| match &objects[id as usize].shape {
            Shape::Polygon(p) => &p.tri_verts[..],
            _ => &[],
        };
        let mut leaves: Vec<(u32, u32)> = nodes
            .iter()
            .flat_map(|n| (0..4).map(move |l| (n.link[l], n.count[l])))
            .filter(|&(_, count)| count > 0)
            .collect();
        leaves.sort_unstable();
        // First each leaf's polygons put first and its triangles counted
        // (from a compact table, read in id order), and where its blocks
        // start; then the blocks, in an array of exactly their number
        // (reserving a bound and shrinking copied them: 2.3 ms of a 33 ms
        // build of a 48,684-triangle mesh).
        let tris_of: Vec<u32> = objects
            .iter()
            .map(|o| match &o.shape {
                Shape::Polygon(p) => p.tri_verts.len() as u32,
                _ => 0,
            })
            .collect();
        let mut at = vec![(0, 0, 0); ids.len()];
        let mut open = 0; // lanes filled in the open block
        let mut count = 0u32; // blocks closed
        for &(s, n_ids) in &leaves {
            let leaf = &mut ids[s as usize..(s + n_ids) as usize];
            let none = |id: &ObjectId| tris_of[*id as usize] == 0;
            let mut polys = leaf.iter().take_while(|id| !none(id)).count();
            if polys < leaf.len() {
                // Stable: polygons first, each side in its order.
                leaf.sort_by_key(none);
                polys = leaf.iter().take_while(|id| !none(id)).count();
            }
            let n: usize = leaf[..polys]
                .iter()
                .map(|&id| tris_of[id as usize] as usize)
                .sum();
            if n == 0 {
                at[s as usize] = (count, 0, 0);
                continue;
            }
            // Into the open block where that costs the leaf no block more
            // than its own triangles fill.
            if open > 0 && open + n > 4 * n.div_ceil(4) {
                count += 1;
                open = 0;
            }
            at[s as usize] = (count, (open + n).div_ceil(4) as u32, polys as u32);
            count += ((open + n) / 4) as u32;
            open = (open + n) % 4;
        }
        let total = count as usize + (open > 0) as usize;
        if total == 0 {
            return Blocks::default();
        }
        let mut b = Blocks {
            at,
            tris: Vec::with_capacity(total),
        };
        let mut blk = Tri4 {
            v: [[[0.0; 4]; 3]; 3],
            id: [0; 4],
        };
        // Lanes of `blk` filled (it is pushed when full or closed).
        let mut k = 0;
        let ids: &[ObjectId] = ids;
        for &(s, _) in &leaves {
            let (first, _, polys) = b.at[s as usize];
            if k > 0 && first as usize == b.tris.len() + 1 {
                close(&mut blk, k);
                b.tris.push(blk);
                k = 0;
            }
            for (j, &id) in ids[s as usize..][..polys as usize].iter().enumerate() {
                ahead(objects, ids, s as usize + j, &triangles);
                for t in triangles(id) {
                    for (vert, out) in blk.v.iter_mut().enumerate() {
                        let p = t[vert].to_array();
                        for axis in 0..3 {
                            out[axis][k] = p[axis];
                        }
                    }
                    blk.id[k] = id;
                    k += 1;
                    if k == 4 {
                        b.tris.push(blk);
                        k = 0;
                    }
                }
            }
        }
        if k > 0 {
            close(&mut blk, k);
            b.tris.push(blk);
        }
        debug_assert_eq!(b.tris.len(), total);
        b
    }

    pub(super) fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The blocks of the leaf at `start`, and how many of its ids they
    /// stand for.
    #[inline(always)]
    pub(super) fn leaf(&self, start: usize) -> (&[Tri4], usize) {
        let (first, blocks, polys) = self.at[start];
        (
            &self.tris[first as usize..(first + blocks) as usize],
            polys as usize,
        )
    }

    /// Asks the processor to fetch the first block of the leaf at
    /// `start` (a hint: any leaf may be named).
    #[inline(always)]
    pub(super) fn prefetch(&self, start: usize) {
        let (first, blocks, _) = self.at[start];
        if blocks > 0 {
            let p: *const u8 = (&self.tris[first as usize] as *const Tri4).cast();
            for line in 0..size_of::<Tri4>().div_ceil(64) {
                super::prefetch(p.wrapping_add(64 * line));
            }
        }
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.at.capacity() * size_of::<(u32, u32, u32)>() + self.tris.capacity() * size_of::<Tri4>()
    }
}

/// Asks the processor to fetch what the blocks' build reads a few objects
/// after `ids[j]`: objects in leaf order lie scattered through memory, and
/// each costs two dependent reads (the object, then its triangles). The
/// object 16 ahead, the triangles of the object 8 ahead (whose object was
/// asked for 8 objects ago).
#[inline(always)]
fn ahead<'a>(
    objects: &'a [Object],
    ids: &[ObjectId],
    j: usize,
    triangles: &impl Fn(ObjectId) -> &'a [[crate::geometry::Vec3; 3]],
) {
    if let Some(&id) = ids.get(j + 16) {
        super::prefetch((&objects[id as usize] as *const Object).cast());
    }
    if let Some(&id) = ids.get(j + 8) {
        super::prefetch(triangles(id).as_ptr().cast());
    }
}

/// The last filled lane again in `blk`'s lanes from `k` on (a repeated
/// triangle changes no answer).
fn close(blk: &mut Tri4, k: usize) {
    for lane in k..4 {
        for out in blk.v.iter_mut() {
            for axis in out.iter_mut() {
                axis[lane] = axis[k - 1];
            }
        }
        blk.id[lane] = blk.id[k - 1];
    }
}

/// The nearest hit so far: distance, object, and what the object
/// reported, `None` for a triangle of a block (its normal and surface word
/// are the compact data's, [`reported`], looked up once the nearest is
/// known rather than at every nearer hit: a read at a random place in a
/// table as long as the objects, where the packets' clock samples showed
/// 3.7% of their time).
pub(super) type Best = Option<(f64, ObjectId, Option<ShapeHit>)>;

/// What the nearest hit's object reported: `h` where it was tested by id,
/// or for a triangle of a block (`h` is `None`) the hit at `t` with the
/// normal and surface word of polygon `id` in `prims`, the compact data
/// the blocks were tested with (so the hit reads no `Object`).
#[inline(always)]
pub(super) fn reported(
    h: Option<ShapeHit>,
    prims: Option<&Prims>,
    id: ObjectId,
    t: f64,
) -> ShapeHit {
    match (h, prims) {
        (Some(h), _) => h,
        (None, Some(prims)) => {
            let p = prims.polygon_hit(id);
            ShapeHit {
                t,
                normal: p.normal,
                inner: None,
                surface: Some(p.surface),
            }
        }
        (None, None) => unreachable!("a block's hit without blocks"),
    }
}

/// The triangles of `blocks` for one ray, with the traversal's rule (see
/// `consider` in the traversals): a hit with `tmin < t` no farther than
/// `cut` (strictly nearer while nothing is hit), the smaller id of equal
/// distances.
///
/// # Safety
/// `E`'s instructions must be available.
#[inline(always)]
pub(super) unsafe fn nearest<E: Enter>(
    blocks: &[Tri4],
    tr: &TriRay,
    tmin: f64,
    cut: &mut f64,
    best: &mut Best,
) {
    for b in blocks {
        let t = E::tri4(tr, b);
        // The lanes in range. Of those, a lane is taken where it is nearer
        // than the nearest so far (the smaller id of equal distances): the
        // bound a later lane would be held to once one is taken (its
        // distance, or the next number after it) is that comparison's.
        let bound = if best.is_some() { next_up(*cut) } else { *cut };
        let mut m = E::within(&t, tmin, bound);
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            let (t, id) = (t[l], b.id[l]);
            if best.is_none_or(|(bt, bid, _)| t < bt || (t == bt && id < bid)) {
                *best = Some((t, id, None));
                *cut = t;
            }
        }
    }
}

/// Whether a triangle of `blocks` other than `ignore`'s is hit with
/// `tmin < t < tmax`.
///
/// # Safety
/// `E`'s instructions must be available.
#[inline(always)]
pub(super) unsafe fn any<E: Enter>(
    blocks: &[Tri4],
    tr: &TriRay,
    tmin: f64,
    tmax: f64,
    ignore: Option<ObjectId>,
) -> bool {
    // Loops, not closures: a closure would not inherit the caller's
    // target features, and the intrinsics would not be inlined.
    for b in blocks {
        let t = E::tri4(tr, b);
        let mut m = E::within(&t, tmin, tmax);
        if m != 0 && ignore.is_none() {
            return true;
        }
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            if Some(b.id[l]) != ignore {
                return true;
            }
        }
    }
    false
}

/// Lane `l`'s distance, or NaN where the ray misses: the pair test's
/// operations on one lane (see `pair_hits_lanes` in [`Prims`]' module),
/// which are [`crate::geometry::intersect_triangle`]'s. Written out rather
/// than shared with it: one core function for both changed how the
/// traversals compiled (71.1 against 68.2 million instructions for the
/// benchmark's primary rays, callgrind), although on those rays the
/// traversals call neither.
#[inline(always)]
fn lane(tr: &TriRay, b: &Tri4, l: usize) -> f64 {
    let [kx, ky, kz] = tr.k;
    let [a, bv, c] = &b.v;
    let (ox, oy, oz) = (tr.o[0], tr.o[1], tr.o[2]);
    let (a_x, a_y, a_z) = (a[kx][l] - ox, a[ky][l] - oy, a[kz][l] - oz);
    let (b_x, b_y, b_z) = (bv[kx][l] - ox, bv[ky][l] - oy, bv[kz][l] - oz);
    let (c_x, c_y, c_z) = (c[kx][l] - ox, c[ky][l] - oy, c[kz][l] - oz);
    let ax = a_x - tr.sx * a_z;
    let ay = a_y - tr.sy * a_z;
    let bx = b_x - tr.sx * b_z;
    let by = b_y - tr.sy * b_z;
    let cx = c_x - tr.sx * c_z;
    let cy = c_y - tr.sy * c_z;
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_of_products(cx, by, cy, bx);
        v = diff_of_products(ax, cy, ay, cx);
        w = diff_of_products(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return f64::NAN;
    }
    let det = u + v + w;
    if det == 0.0 {
        return f64::NAN;
    }
    let az = tr.sz * a_z;
    let bz = tr.sz * b_z;
    let cz = tr.sz * c_z;
    (u * az + v * bz + w * cz) / det
}

/// The four lanes one by one.
#[inline(always)]
pub(super) fn lanes(tr: &TriRay, b: &Tri4) -> [f64; 4] {
    std::array::from_fn(|l| lane(tr, b, l))
}

/// The four lanes at once (the pair test's SSE2 code, twice as wide);
/// any zero edge function sends the block to [`lanes`]. A block whose
/// four lanes all miss still goes on to its distances (NaN in every lane):
/// a branch on that spared such blocks the division, but goes either way
/// with the data; without it the 8 x 8 primary packets were no slower
/// (0.480 of Embree's streams against 0.474, medians of four rounds).
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn lanes_avx2(tr: &TriRay, b: &Tri4) -> [f64; 4] {
    use std::arch::x86_64::*;
    let [kx, ky, kz] = tr.k;
    let [a, bv, c] = &b.v;
    let ld = |x: &[f64; 4]| _mm256_loadu_pd(x.as_ptr());
    let (ox, oy, oz) = (
        _mm256_set1_pd(tr.o[0]),
        _mm256_set1_pd(tr.o[1]),
        _mm256_set1_pd(tr.o[2]),
    );
    let (sx, sy) = (_mm256_set1_pd(tr.sx), _mm256_set1_pd(tr.sy));
    let a_z = _mm256_sub_pd(ld(&a[kz]), oz);
    let b_z = _mm256_sub_pd(ld(&bv[kz]), oz);
    let c_z = _mm256_sub_pd(ld(&c[kz]), oz);
    let ax = _mm256_sub_pd(_mm256_sub_pd(ld(&a[kx]), ox), _mm256_mul_pd(sx, a_z));
    let ay = _mm256_sub_pd(_mm256_sub_pd(ld(&a[ky]), oy), _mm256_mul_pd(sy, a_z));
    let bx = _mm256_sub_pd(_mm256_sub_pd(ld(&bv[kx]), ox), _mm256_mul_pd(sx, b_z));
    let by = _mm256_sub_pd(_mm256_sub_pd(ld(&bv[ky]), oy), _mm256_mul_pd(sy, b_z));
    let cx = _mm256_sub_pd(_mm256_sub_pd(ld(&c[kx]), ox), _mm256_mul_pd(sx, c_z));
    let cy = _mm256_sub_pd(_mm256_sub_pd(ld(&c[ky]), oy), _mm256_mul_pd(sy, c_z));
    let u = _mm256_sub_pd(_mm256_mul_pd(cx, by), _mm256_mul_pd(cy, bx));
    let v = _mm256_sub_pd(_mm256_mul_pd(ax, cy), _mm256_mul_pd(ay, cx));
    let w = _mm256_sub_pd(_mm256_mul_pd(bx, ay), _mm256_mul_pd(by, ax));
    let z = _mm256_setzero_pd();
    let zero = _mm256_or_pd(
        _mm256_or_pd(
            _mm256_cmp_pd::<_CMP_EQ_OQ>(u, z),
            _mm256_cmp_pd::<_CMP_EQ_OQ>(v, z),
        ),
        _mm256_cmp_pd::<_CMP_EQ_OQ>(w, z),
    );
    if _mm256_movemask_pd(zero) != 0 {
        return lanes(tr, b);
    }
    let neg = _mm256_or_pd(
        _mm256_or_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(u, z),
            _mm256_cmp_pd::<_CMP_LT_OQ>(v, z),
        ),
        _mm256_cmp_pd::<_CMP_LT_OQ>(w, z),
    );
    let pos = _mm256_or_pd(
        _mm256_or_pd(
            _mm256_cmp_pd::<_CMP_GT_OQ>(u, z),
            _mm256_cmp_pd::<_CMP_GT_OQ>(v, z),
        ),
        _mm256_cmp_pd::<_CMP_GT_OQ>(w, z),
    );
    // As in the pair test: a NaN edge function is no miss here and goes
    // on to a NaN distance.
    let mut miss = _mm256_and_pd(neg, pos);
    let det = _mm256_add_pd(_mm256_add_pd(u, v), w);
    miss = _mm256_or_pd(miss, _mm256_cmp_pd::<_CMP_EQ_OQ>(det, z));
    let sz = _mm256_set1_pd(tr.sz);
    let (az, bz, cz) = (
        _mm256_mul_pd(sz, a_z),
        _mm256_mul_pd(sz, b_z),
        _mm256_mul_pd(sz, c_z),
    );
    let num = _mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(u, az), _mm256_mul_pd(v, bz)),
        _mm256_mul_pd(w, cz),
    );
    let t = _mm256_div_pd(num, det);
    let t = _mm256_or_pd(
        _mm256_andnot_pd(miss, t),
        _mm256_and_pd(miss, _mm256_set1_pd(f64::NAN)),
    );
    let mut out = [0.0; 4];
    _mm256_storeu_pd(out.as_mut_ptr(), t);
    out
}

#[cfg(test)]
mod tests {
    use crate::accel::{intersect_brute_force, occluded_brute_force};
    use crate::geometry::{Bvh, Object, Ray, Segment, Shape, Vec3, PACKET};

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> Object {
        Object {
            name: String::new(),
            shape: Shape::polygon(vec![a, b, c]).unwrap(),
            material: 0,
        }
    }

    /// A height field of single triangles sharing edges and vertices (so
    /// rays through them make edge functions zero), a copy of one triangle
    /// (equal distances, told apart by id), a hexagon (a polygon of four
    /// triangles, split across blocks) and a sphere (tested by id) at
    /// `scale`.
    fn mesh(scale: f64) -> Vec<Object> {
        let p = |x: f64, y: f64| {
            let z = ((x * 1.3).sin() + (y * 0.7).cos()) * 0.25;
            Vec3::new(x, y, z) * scale
        };
        let mut objects = Vec::new();
        for i in 0..12 {
            for j in 0..12 {
                let (x, y) = (i as f64, j as f64);
                objects.push(tri(p(x, y), p(x + 1.0, y), p(x + 1.0, y + 1.0)));
                objects.push(tri(p(x, y), p(x + 1.0, y + 1.0), p(x, y + 1.0)));
            }
        }
        objects.push(objects[40].clone());
        let hexagon = (0..6)
            .map(|k| {
                let a = k as f64 * std::f64::consts::PI / 3.0;
                Vec3::new(6.0 + 2.0 * a.cos(), 6.0 + 2.0 * a.sin(), 1.5) * scale
            })
            .collect();
        objects.push(Object {
            name: String::new(),
            shape: Shape::polygon(hexagon).unwrap(),
            material: 0,
        });
        objects.push(Object {
            name: String::new(),
            shape: Shape::Sphere {
                center: Vec3::new(3.0, 9.0, 1.0) * scale,
                radius: 0.7 * scale,
                inward: false,
            },
            material: 0,
        });
        objects
    }

    #[test]
    fn blocks_answer_as_brute_force_through_vertices_and_edges() {
        for scale in [1e-5, 1.0, 1e5] {
            let objects = mesh(scale);
            let bvh = Bvh::build(&objects);
            assert!(!bvh.blocks.is_empty());
            // Some leaves share a block (the tests below cover it).
            let starts: Vec<u32> = bvh
                .nodes
                .iter()
                .flat_map(|n| (0..4).filter(|&l| n.count[l] > 0).map(|l| n.link[l]))
                .filter_map(|s| {
                    let (first, blocks, _) = bvh.blocks.at[s as usize];
                    (blocks > 0).then_some(first)
                })
                .collect();
            let mut distinct = starts.clone();
            distinct.sort_unstable();
            distinct.dedup();
            assert!(distinct.len() < starts.len(), "no block shared");
            let eye = Vec3::new(5.5, 4.5, 9.0) * scale;
            let mut rays: Vec<Segment> = Vec::new();
            for o in &objects {
                let Shape::Polygon(p) = &o.shape else {
                    continue;
                };
                for t in &p.tri_verts {
                    // Each vertex, each edge's midpoint, the centre.
                    let aims = [
                        t[0],
                        t[1],
                        t[2],
                        (t[0] + t[1]) * 0.5,
                        (t[1] + t[2]) * 0.5,
                        (t[2] + t[0]) * 0.5,
                        (t[0] + t[1] + t[2]) / 3.0,
                    ];
                    for aim in aims {
                        rays.push((Ray::new(eye, aim - eye), 0.0, f64::INFINITY));
                    }
                }
            }
            let mut hits = 0;
            for (ray, tmin, tmax) in &rays {
                let want = intersect_brute_force(&objects, ray, *tmin, *tmax);
                assert_eq!(bvh.intersect(&objects, ray, *tmin, *tmax), want);
                let Some(h) = want else { continue };
                hits += 1;
                // Shadow segments ending just short of the hit, and past it
                // ignoring the object hit.
                let short = h.t * (1.0 - 1e-9);
                assert_eq!(
                    bvh.occluded(&objects, ray, *tmin, short, None),
                    occluded_brute_force(&objects, ray, *tmin, short, None)
                );
                assert_eq!(
                    bvh.occluded(&objects, ray, *tmin, *tmax, Some(h.object)),
                    occluded_brute_force(&objects, ray, *tmin, *tmax, Some(h.object))
                );
            }
            assert!(hits > rays.len() / 2, "{hits} of {}", rays.len());
            // The same rays as packets.
            let mut out = [None; PACKET];
            for packet in rays.chunks(PACKET) {
                bvh.intersect_packet(&objects, packet, &mut out);
                for ((ray, tmin, tmax), got) in packet.iter().zip(&out) {
                    assert_eq!(*got, intersect_brute_force(&objects, ray, *tmin, *tmax));
                }
            }
        }
    }
}
