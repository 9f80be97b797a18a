//! The slab test in single precision, Embree's arithmetic, kept
//! conservative: a child a ray enters in exact arithmetic is always
//! entered.
//!
//! The nodes' planes are single precision already (rounded outwards). A
//! ray's constants are rounded so that every computed entry distance is no
//! later than the exact one, and every exit no earlier:
//!
//! - **Origins.** Lower planes are measured from a single no smaller than
//!   the origin, upper planes from one no greater ([`up`], [`down`]): `lo -
//!   o'` is at most `lo - o` and `hi - o'` at least `hi - o`, which moves
//!   each entry earlier and each exit later whatever the direction's sign.
//! - **Inverse directions.** Entries are multiplied by the inverse shrunk
//!   by [`SLACK`], exits by the inverse grown by it, each then rounded to
//!   nearest (2^-24 of its value; an entry's inverse beyond the single
//!   range becomes the largest single). With the subtraction's and the
//!   product's roundings, 2^-24 each, `|(lo - o') * inv'|` before its last
//!   rounding is still below `|lo - o'| / |dir|`, and the exit's above.
//! - **The last rounding** is to nearest, which is monotone: a real entry
//!   no later than a real exit rounds to a float no later than the exit's,
//!   underflow and overflow included. A bound `tmin` is rounded down, a
//!   bound `tmax` up.
//!
//! Entries behind the origin may come out later than exact (a negative
//! value shrinks towards zero), which matters only if `tmin` is negative:
//! such rays, and rays whose origin or direction is beyond [`RANGE`] (where
//! `lo - o'` could overflow) or not finite, take the double-precision test
//! ([`super::Slab`]). A zero direction component gives an entry inverse
//! of the largest single (an entry at `0 * f32::MAX = 0` where the ray runs
//! in a plane: no later than exact) and an infinite exit inverse, whose
//! `0 * inf` is NaN and keeps the bound (`maxps`/`minps` return their
//! second operand), as in double precision. The nodes' planes
//! are within the range where the hierarchy uses this test ([`fits`]),
//! unused children's are infinite: `inf - o'` is infinite and never NaN.
//!
//! Every implementation does [`enter4`]'s IEEE operations in its order (no
//! fused multiply-add), so all give the same masks and distances.
//!
//! **Where it runs.** The nearest-hit traversal ([`super::Bvh::intersect`])
//! only. Measured (`hybrid-rt bench --embree`, the studio, one core, six
//! rounds alternating with the double-precision build): primary rays 0.437
//! to 0.479 of Embree's `rtcIntersect1` against 0.414 to 0.461, and the
//! studio's render (512 x 512) no slower. In the any-hit traversal it made
//! the render about 1.06 times as long (shadow rays are short, and the
//! per-ray constants cost more than the nodes save), so that one stays in
//! double precision.

use super::Wide;
use crate::geometry::{Ray, Vec3};

/// Largest magnitude of an origin or direction component, and of a node's
/// finite plane, for the single-precision test: differences of two such
/// values stay far from `f32::MAX`.
pub(super) const RANGE: f64 = 1e30;

/// Relative shrinking and growing of the inverse directions and of the
/// values rounded to single precision: more than the roundings it covers
/// (to single precision, 2^-24 each; the subtraction and the product).
const SLACK: f64 = 1.0 / (1u64 << 20) as f64;

/// Absolute slack of [`up`] and [`down`]: more than half the smallest
/// subnormal single (2^-150), where a relative one falls short.
const TINY: f64 = 1.0 / (1u128 << 120) as f64;

/// A single no smaller than `x` (`|x| <= RANGE`, or plus infinity; minus
/// infinity and NaN give NaN, which as a bound lets no child through, as
/// the empty segments they make should): nudged up before rounding to
/// nearest, without the branches of an exact rounding up (a ray's
/// constants are made once a ray, and branches on its bits are
/// mispredicted).
#[inline(always)]
pub(super) fn up(x: f64) -> f32 {
    (x + (x.abs() * SLACK + TINY)) as f32
}

/// A single no greater than `x` (see [`up`]; minus infinity stays, plus
/// infinity and NaN give NaN).
#[inline(always)]
pub(super) fn down(x: f64) -> f32 {
    (x - (x.abs() * SLACK + TINY)) as f32
}

/// Whether a hierarchy whose root box is `lo`..`hi` (single precision,
/// finite or infinite) can use the single-precision test.
pub(super) fn fits(lo: f32, hi: f32) -> bool {
    f64::from(lo).abs() <= RANGE && f64::from(hi).abs() <= RANGE
}

/// Per-ray constants of the single-precision slab test.
#[derive(Clone, Copy, Debug)]
pub(super) struct Slab32 {
    /// The origin each axis's entry planes are measured from.
    o_near: [f32; 3],
    /// The origin each axis's exit planes are measured from.
    o_far: [f32; 3],
    /// The inverse direction for entries (shrunk) and exits (grown).
    inv_near: [f32; 3],
    inv_far: [f32; 3],
    /// Index (0 lower, 1 upper) of the plane the ray enters by on each axis.
    near: [usize; 3],
    /// Offsets ([`Wide::plane_at`]) of each axis's entry and exit planes.
    at: [[usize; 2]; 3],
}

impl Slab32 {
    /// The constants of `ray` (whose inverse direction is `inv`) for
    /// segments starting at `tmin`, or `None` where the single-precision
    /// test cannot bound it (see the module's documentation).
    #[inline(always)]
    pub(super) fn new(ray: &Ray, inv: Vec3, tmin: f64) -> Option<Self> {
        if tmin.is_nan() || tmin < 0.0 {
            return None;
        }
        let (o, d, inv) = (ray.origin.to_array(), ray.dir.to_array(), inv.to_array());
        let mut s = Slab32 {
            o_near: [0.0; 3],
            o_far: [0.0; 3],
            inv_near: [0.0; 3],
            inv_far: [0.0; 3],
            near: [0; 3],
            at: [[0; 2]; 3],
        };
        for a in 0..3 {
            // NaN is not within either.
            let within = |x: f64| x.abs() <= RANGE;
            if !within(o[a]) || !within(d[a]) {
                return None;
            }
            let near = inv[a].is_sign_negative() as usize;
            // Lower planes from above the origin, upper ones from below,
            // chosen by index (a version with bit masks, which the
            // compiler could not turn into a branch, measured the same;
            // one written over the three axes without branches was not
            // vectorised and took more instructions under callgrind,
            // 275.8M against 267.7M for the bench's primary rays).
            let o_planes = [up(o[a]), down(o[a])];
            s.o_near[a] = o_planes[near];
            s.o_far[a] = o_planes[1 - near];
            // Rounded to nearest, within 2^-24 of the shrunk and grown
            // values. An entry's inverse beyond the single range is the
            // largest single; the exits' may be infinite (zero components).
            let shrunk = ((inv[a] * (1.0 - SLACK)) as f32).clamp(f32::MIN, f32::MAX);
            let grown = (inv[a] * (1.0 + SLACK)) as f32;
            (s.inv_near[a], s.inv_far[a]) = (shrunk, grown);
            s.near[a] = near;
            s.at[a] = [Wide::plane_at(a, near), Wide::plane_at(a, 1 - near)];
        }
        Some(s)
    }
}

/// The slab test of one ray against a node's four children in single
/// precision: the mask of children entered (bit `i` for child `i`) and
/// their entry distances. Portable code; `enter4_avx2` does the same
/// operations.
#[inline(always)]
pub(super) fn enter4(s: &Slab32, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    let mut t0 = [tmin; 4];
    let mut t1 = [tmax; 4];
    for a in 0..3 {
        let lo = &n.b[a][s.near[a]];
        let hi = &n.b[a][1 - s.near[a]];
        for l in 0..4 {
            let e = (lo[l] - s.o_near[a]) * s.inv_near[a];
            let x = (hi[l] - s.o_far[a]) * s.inv_far[a];
            // `maxps`/`minps`: a NaN keeps the bound.
            t0[l] = if e > t0[l] { e } else { t0[l] };
            t1[l] = if x < t1[l] { x } else { t1[l] };
        }
    }
    let mut m = 0;
    for l in 0..4 {
        m |= ((t0[l] <= t1[l]) as u32) << l;
    }
    (m, t0)
}

/// [`enter4`] with SSE instructions, four children in one register.
///
/// # Safety
/// The processor must have AVX2 (the caller's target features).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) unsafe fn enter4_avx2(s: &Slab32, n: &Wide, tmin: f32, tmax: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    let (m, t0) = lanes_avx2(s, n, tmin, tmax);
    let mut out = [0.0f32; 4];
    _mm_storeu_ps(out.as_mut_ptr(), t0);
    (m, out)
}

/// The mask and entry distances of [`enter4`] in registers.
///
/// # Safety
/// The processor must have AVX2 (the caller's target features).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn lanes_avx2(
    s: &Slab32,
    n: &Wide,
    tmin: f32,
    tmax: f32,
) -> (u32, std::arch::x86_64::__m128) {
    use std::arch::x86_64::*;
    // A plain loop, without closures (see `Avx2::planes`). `Wide` is
    // aligned to 32 bytes, each `[f32; 4]` of it to 16.
    let mut t0 = _mm_set1_ps(tmin);
    let mut t1 = _mm_set1_ps(tmax);
    for a in 0..3 {
        // SAFETY: `at` holds `Wide::plane_at` offsets.
        let (lo, hi) = unsafe {
            (
                _mm_load_ps(n.planes_at(s.at[a][0])),
                _mm_load_ps(n.planes_at(s.at[a][1])),
            )
        };
        let e = _mm_mul_ps(
            _mm_sub_ps(lo, _mm_set1_ps(s.o_near[a])),
            _mm_set1_ps(s.inv_near[a]),
        );
        let x = _mm_mul_ps(
            _mm_sub_ps(hi, _mm_set1_ps(s.o_far[a])),
            _mm_set1_ps(s.inv_far[a]),
        );
        t0 = _mm_max_ps(e, t0);
        t1 = _mm_min_ps(x, t1);
    }
    (_mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32, t0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::bvh::tests::enter_on_every_set;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed};

    /// A node whose lane 2 is the box `lo`..`hi`, the others unused.
    fn node(lo: [f32; 3], hi: [f32; 3]) -> Wide {
        let mut n = Wide::UNUSED;
        for a in 0..3 {
            n.b[a][0][2] = lo[a];
            n.b[a][1][2] = hi[a];
        }
        n
    }

    /// `k * 2^e`: exact, and so are differences of such values with
    /// `|k| < 2^51` and one `e`.
    fn grid(k: i64, e: i32) -> f64 {
        k as f64 * 2f64.powi(e)
    }

    proptest! {
        #![proptest_config(Config { cases: 2000, rng_seed: RngSeed::Fixed(0x5132), ..Config::default() })]

        /// A ray that passes through a box, in exact arithmetic, within
        /// its segment enters it: the point `p` of the box (inside, or on
        /// a face or an edge) and the origin `o` are on a grid, so `p - o`
        /// is exact and the ray is at `p` at `t = 1`, and the segment ends
        /// (or starts) there. Boxes down to one single-precision step wide,
        /// points on their faces, directions along the axes (zero
        /// components) and rays from inside, at scales 2^-60 to 2^60.
        /// Every implementation gives the same mask and distances.
        #[test]
        fn a_box_a_ray_reaches_within_its_segment_is_entered(
            pk in prop::array::uniform3(-(1i64 << 40)..(1i64 << 40)),
            // Few significant bits: points a single holds exactly, on the faces.
            short in any::<bool>(),
            dk in prop::array::uniform3(-(1i64 << 40)..(1i64 << 40)),
            zero in prop::array::uniform3(0u8..4),
            below in prop::array::uniform3(0u32..4),
            above in prop::array::uniform3(0u32..4),
            e in -100i32..20,
            end in 0u8..3,
        ) {
            let pk = if short { pk.map(|k| k >> 17) } else { pk };
            let p: [f64; 3] = std::array::from_fn(|a| grid(pk[a], e));
            // Components zero one time in four.
            let d: [f64; 3] = std::array::from_fn(|a| if zero[a] == 0 { 0.0 } else { grid(dk[a], e) });
            let o: [f64; 3] = std::array::from_fn(|a| p[a] - d[a]);
            prop_assume!(d.iter().any(|&x| x != 0.0));
            // The box: `p` rounded outwards, then `below`/`above` steps
            // more (0: `p` on the face where a single holds it).
            let step_down = |x: f32, n: u32| (0..n).fold(x, |x, _| x - x.abs() * f32::EPSILON - f32::from_bits(1));
            let step_up = |x: f32, n: u32| (0..n).fold(x, |x, _| x + x.abs() * f32::EPSILON + f32::from_bits(1));
            let lo: [f32; 3] = std::array::from_fn(|a| step_down(crate::geometry::bvh::round_down(p[a]), below[a]));
            let hi: [f32; 3] = std::array::from_fn(|a| step_up(crate::geometry::bvh::round_up(p[a]), above[a]));
            let ray = crate::geometry::Ray { origin: Vec3::from(o), dir: Vec3::from(d) };
            let inv = Vec3::ONE / ray.dir;
            // The segment: ending at `p`, starting at it, or through it.
            let (tmin, tmax) = match end { 0 => (0.0, 1.0), 1 => (1.0, f64::INFINITY), _ => (0.5, 2.0) };
            let s = Slab32::new(&ray, inv, tmin).expect("within the range");
            let n = node(lo, hi);
            let all = enter_on_every_set(&s, &n, down(tmin), up(tmax));
            prop_assert!(all.iter().all(|x| *x == all[0]), "{all:?}");
            prop_assert_eq!(all[0].0, 1 << 2, "o {:?} d {:?} box {:?} {:?}: {:?}", o, d, lo, hi, all[0]);
        }
    }

    /// Rays the single-precision test cannot bound are left to the double
    /// one: a negative `tmin`, origins and directions beyond the range,
    /// NaN. The bounds round outwards.
    #[test]
    fn rays_out_of_range_are_refused_and_bounds_round_outwards() {
        let ray = |o: f64, d: f64| crate::geometry::Ray {
            origin: Vec3::new(o, 0.0, 0.0),
            dir: Vec3::new(d, 1.0, 0.0),
        };
        let ok =
            |r: crate::geometry::Ray, tmin: f64| Slab32::new(&r, Vec3::ONE / r.dir, tmin).is_some();
        assert!(ok(ray(1.0, 1.0), 0.0));
        assert!(ok(ray(-1e30, 1e-30), 0.0));
        assert!(ok(ray(0.0, 0.0), 0.0));
        assert!(!ok(ray(1.0, 1.0), -1e-9));
        assert!(!ok(ray(1.0, 1.0), f64::NAN));
        assert!(!ok(ray(2e30, 1.0), 0.0));
        assert!(!ok(ray(1.0, -2e30), 0.0));
        assert!(!ok(ray(f64::NAN, 1.0), 0.0));
        assert!(!ok(ray(1.0, f64::INFINITY), 0.0));
        for x in [
            0.0,
            1e-300,
            -1e-300,
            0.1,
            -0.1,
            1.0 / 3.0,
            1e29,
            -1e29,
            16777217.0,
        ] {
            assert!(f64::from(up(x)) >= x, "{x}");
            assert!(f64::from(down(x)) <= x, "{x}");
        }
        assert_eq!(up(f64::INFINITY), f32::INFINITY);
        assert_eq!(down(f64::NEG_INFINITY), f32::NEG_INFINITY);
        assert!(up(f64::NEG_INFINITY).is_nan() && down(f64::INFINITY).is_nan());
        assert!(up(f64::NAN).is_nan());
        assert!(fits(-1e29, 1e29) && !fits(-1e31, 0.0) && !fits(0.0, f32::INFINITY));
    }
}
