//! Deterministic random streams.
//!
//! Every pixel gets its own stream, seeded by hashing (seed, x, y), and
//! every secondary task gets a seed derived from its parent's seed and its
//! index among the parent's requests. So the numbers a ray or shadow bundle
//! uses depend only on *which* ray it is, never on the order in which work
//! was done: any split of the work gives the same picture bit for bit.
//!
//! The one SplitMix64 of the renderer: the scene generators
//! (`scene::generate`) draw from it too, with their own seeding.

/// SplitMix64's finaliser: a bijective 64-bit mix with good avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// SplitMix64's increment (the golden ratio in 64 bits).
pub const GOLDEN: u64 = 0x9e37_79b9_7f4a_7c15;

/// Seed of the stream for pixel (x, y) of a render with `seed`.
#[inline]
pub fn pixel_seed(seed: u64, x: u32, y: u32) -> u64 {
    mix64(mix64(seed ^ GOLDEN).wrapping_add(((y as u64) << 32) | x as u64))
}

/// Seed of the `k`-th child task of a task with seed `parent`.
#[inline]
pub fn child_seed(parent: u64, k: u32) -> u64 {
    mix64(parent.wrapping_add(GOLDEN.wrapping_mul(k as u64 + 1)) ^ 0x5851_f42d_4c95_7f2d)
}

/// A SplitMix64 generator: tiny, fast, and good enough for jittering
/// sample positions (it passes BigCrush as a 64-bit generator).
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN);
        mix64(self.state)
    }

    /// Uniform in [0, 1), 53 random bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_repeat() {
        let a: Vec<u64> = (0..4).map(|x| pixel_seed(1, x, 0)).collect();
        for i in 0..4 {
            for j in 0..i {
                assert_ne!(a[i], a[j]);
            }
        }
        assert_ne!(pixel_seed(1, 1, 0), pixel_seed(1, 0, 1));
        assert_ne!(pixel_seed(1, 0, 0), pixel_seed(2, 0, 0));
        assert_eq!(pixel_seed(7, 3, 9), pixel_seed(7, 3, 9));
        assert_ne!(child_seed(5, 0), child_seed(5, 1));
    }

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(42);
        let n = 100_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let v = r.next_f64();
            assert!((0.0..1.0).contains(&v));
            sum += v;
        }
        // Standard error of the mean is 1/sqrt(12 n) ~ 0.0009.
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
    }
}
