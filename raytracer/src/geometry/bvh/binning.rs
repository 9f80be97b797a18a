//! The heuristic's binning: each object's box added to the bin of its
//! centre on each of the three axes, in one pass.
//!
//! On x86-64 the pass is written with SSE2 (part of every x86-64
//! processor): a ref's three positions in one register, its box added to
//! a bin with one `minps` and one `maxps`. Compiled from the portable
//! loop, the positions' clamps became a compare, a mask and two branches
//! a lane, and the pass took 75 instructions a ref (55 of the 180 million
//! the studio's build took, callgrind) against 47. Both do the same IEEE
//! operations in the same order (`maxps`/`minps` are the selects
//! `fmax`/`fmin` write): the same bins, bit for bit (a test compares
//! them).

use super::{fmax, fmin, Bins, Ref, BINS};

/// Where a split's bins lie: a centre `c` (twice the box's centre) has
/// the position `min(max((c - cmin[k]) * scale[k], 0), top)` on axis `k`
/// (a NaN position is 0), its bin that position's integer part.
#[derive(Debug, Clone, Copy)]
pub(super) struct Grid {
    pub(super) cmin: [f32; 4],
    pub(super) scale: [f32; 4],
    /// The last bin, `nb - 1`.
    pub(super) top: f32,
}

impl Grid {
    /// The bin of centre `c` on axis `k`.
    #[inline(always)]
    pub(super) fn bin(&self, c: f32, k: usize) -> usize {
        let x = fmin(fmax((c - self.cmin[k]) * self.scale[k], 0.0), self.top);
        // SAFETY: `x` is in `[0, top]`, finite. The mask changes no bin
        // (`nb <= BINS`, a power of two); it drops the bounds checks.
        unsafe { x.to_int_unchecked::<u32>() as usize & (BINS - 1) }
    }
}

/// Adds each of `refs` to `bins` (the bins in use cleared by the caller).
#[inline(always)]
pub(super) fn bin_all(refs: &[Ref], g: &Grid, bins: &mut [Bins; 3]) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: every x86-64 processor has SSE2.
    unsafe {
        sse2(refs, g, bins)
    }
    #[cfg(not(target_arch = "x86_64"))]
    portable(refs, g, bins)
}

/// The pass lane by lane.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn portable(refs: &[Ref], g: &Grid, bins: &mut [Bins; 3]) {
    for r in refs {
        let c = r.centre();
        for (a, bins) in bins.iter_mut().enumerate() {
            let b = g.bin(c[a], a);
            bins.b[b].add(&r.lo, &r.hi);
            bins.n[b] += 1;
        }
    }
}

/// # Safety
/// The processor must have SSE2 (every x86-64 one has).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sse2(refs: &[Ref], g: &Grid, bins: &mut [Bins; 3]) {
    use std::arch::x86_64::*;
    let cmin = _mm_loadu_ps(g.cmin.as_ptr());
    let scale = _mm_loadu_ps(g.scale.as_ptr());
    let top = _mm_set1_ps(g.top);
    let zero = _mm_setzero_ps();
    // Lanes 0 to 2: lane 3 of `lo` is the id, whose bits are a subnormal
    // number (slow arithmetic on some processors: on an AMD EPYC the
    // build ran 1.2 times as fast without it); lane 3 of `hi` is a normal
    // number (the rounding flags, `FLAGS`), and lane 3's scale is 0.
    let xyz = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
    let mut at = [0i32; 4];
    for r in refs {
        // `Ref` and `Box4` are aligned to 16 bytes.
        let lo = _mm_load_ps(r.lo.as_ptr());
        let hi = _mm_load_ps(r.hi.as_ptr());
        let c = _mm_add_ps(_mm_and_ps(lo, xyz), hi);
        let x = _mm_min_ps(
            _mm_max_ps(_mm_mul_ps(_mm_sub_ps(c, cmin), scale), zero),
            top,
        );
        _mm_storeu_si128(at.as_mut_ptr().cast(), _mm_cvttps_epi32(x));
        for (a, bins) in bins.iter_mut().enumerate() {
            let b = at[a] as usize & (BINS - 1);
            let bx = &mut bins.b[b];
            _mm_store_ps(
                bx.lo.as_mut_ptr(),
                _mm_min_ps(_mm_load_ps(bx.lo.as_ptr()), lo),
            );
            _mm_store_ps(
                bx.hi.as_mut_ptr(),
                _mm_max_ps(_mm_load_ps(bx.hi.as_ptr()), hi),
            );
            bins.n[b] += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::rng::Rng;

    /// Refs at scales from 1e-30 to 1e30, some on one point, some with
    /// infinite or NaN coordinates, binned both ways: the same bins.
    #[test]
    fn sse2_bins_equal_portable_bins() {
        let mut rng = Rng::new(11);
        for round in 0..200 {
            let n = 1 + (rng.next_f64() * 60.0) as usize;
            let scale = 10f32.powi((rng.next_f64() * 60.0 - 30.0) as i32);
            let refs: Vec<Ref> = (0..n)
                .map(|i| {
                    let mut lo = [0.0f32; 4];
                    let mut hi = [0.0f32; 4];
                    for k in 0..3 {
                        let a = (rng.next_f64() as f32 - 0.5) * scale;
                        let w = rng.next_f64() as f32 * scale * 0.1;
                        lo[k] = a;
                        hi[k] = a + w;
                        match (rng.next_f64() * 100.0) as u32 {
                            0 => lo[k] = f32::NEG_INFINITY,
                            1 => hi[k] = f32::INFINITY,
                            2 => lo[k] = f32::NAN,
                            3 => hi[k] = lo[k],
                            _ => {}
                        }
                    }
                    lo[3] = f32::from_bits(i as u32);
                    Ref { lo, hi }
                })
                .collect();
            let nb = 1 + round % BINS;
            let mut g = Grid {
                cmin: [0.0; 4],
                scale: [0.0; 4],
                top: (nb - 1) as f32,
            };
            for k in 0..3 {
                g.cmin[k] = -scale * (rng.next_f64() as f32);
                g.scale[k] = match round % 7 {
                    0 => 0.0,
                    1 => f32::INFINITY,
                    _ => nb as f32 / scale,
                };
            }
            let (mut a, mut b) = ([Bins::EMPTY; 3], [Bins::EMPTY; 3]);
            bin_all(&refs, &g, &mut a);
            portable(&refs, &g, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert_eq!(x.n, y.n, "round {round}");
                for (p, q) in x.b.iter().zip(&y.b) {
                    let bits =
                        |v: &[f32; 4]| v[..3].iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&p.lo), bits(&q.lo), "round {round}");
                    assert_eq!(bits(&p.hi), bits(&q.hi), "round {round}");
                }
            }
        }
    }
}
