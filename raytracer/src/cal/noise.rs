//! Radiance's noise functions (`src/rt/noise3.c`) and calcomp's `rand`
//! (`l_rand` in `calfunc.c`), reproduced to the bit: Perlin-style solid
//! noise by Hermite interpolation of hashed lattice values and gradients, and
//! the fractal `fnoise3` that subdivides a cube of side 1 down to 1/1000.
//!
//! C's `long` is 64 bits on the systems Radiance runs on; its overflowing
//! products wrap there in practice, so the hash uses wrapping `i64`
//! arithmetic. Conversions from `double` to `long` truncate toward zero
//! (Rust's `as` does too, and saturates where C would be undefined).

/// `frand` of noise3.c: a pseudo-random number in (-1, 1] from an integer seed.
pub fn frand(s: i64) -> f64 {
    let s = (s << 13) ^ s;
    let h = s
        .wrapping_mul(s.wrapping_mul(s).wrapping_mul(15731).wrapping_add(789221))
        .wrapping_add(1376312589)
        & 0x7fff_ffff;
    1.0 - h as f64 / 1073741824.0
}

fn rand3(k: [i64; 3], x: i64, y: i64, z: i64) -> f64 {
    frand(
        k[0].wrapping_mul(x)
            .wrapping_add(k[1].wrapping_mul(y))
            .wrapping_add(k[2].wrapping_mul(z)),
    )
}

const RAND3: [[i64; 3]; 4] = [[67, 59, 71], [73, 79, 83], [89, 97, 101], [103, 107, 109]];

fn hpoly1(t: f64) -> f64 {
    (2.0 * t - 3.0) * t * t + 1.0
}
fn hpoly2(t: f64) -> f64 {
    (-2.0 * t + 3.0) * t * t
}

/// The hermite of noise3.c's `l_hermite`, with the same operation order
/// (its `hpoly2..4` macros are not parenthesised, so `p1*hpoly2(t)` is
/// `((p1*(-2t+3))*t)*t`).
pub fn hermite(p0: f64, p1: f64, r0: f64, r1: f64, t: f64) -> f64 {
    p0 * hpoly1(t)
        + p1 * (-2.0 * t + 3.0) * t * t
        + r0 * ((t - 2.0) * t + 1.0) * t
        + r1 * (t - 1.0) * t * t
}

/// `noise3`: returns `[noise3x, noise3y, noise3z, noise3]` at `x`.
pub fn noise3(x: [f64; 3]) -> [f64; 4] {
    let mut xlim = [[0i64; 2]; 3];
    let mut xarg = [0f64; 3];
    for i in 0..3 {
        xlim[i][0] = x[i].floor() as i64;
        xlim[i][1] = xlim[i][0].wrapping_add(1);
        xarg[i] = x[i] - xlim[i][0] as f64;
    }
    interpolate(&xlim, &xarg, 0, 3)
}

fn interpolate(xlim: &[[i64; 2]; 3], xarg: &[f64; 3], i: usize, n: usize) -> [f64; 4] {
    let mut f = [0.0; 4];
    if n == 0 {
        let (x, y, z) = (xlim[0][i & 1], xlim[1][(i >> 1) & 1], xlim[2][i >> 2]);
        for (k, fk) in f.iter_mut().enumerate() {
            *fk = rand3(RAND3[k], x, y, z);
        }
    } else {
        let n = n - 1;
        let f0 = interpolate(xlim, xarg, i, n);
        let f1 = interpolate(xlim, xarg, i | 1 << n, n);
        let t = xarg[n];
        let (hp1, hp2) = (hpoly1(t), hpoly2(t));
        f[0] = f0[0] * hp1 + f1[0] * hp2;
        f[1] = f0[1] * hp1 + f1[1] * hp2;
        f[2] = f0[2] * hp1 + f1[2] * hp2;
        // The macros expand unparenthesised here too.
        f[3] = f0[3] * hp1
            + f1[3] * hp2
            + f0[n] * ((t - 2.0) * t + 1.0) * t
            + f1[n] * (t - 1.0) * t * t;
    }
    f
}

fn frand3(x: i64, y: i64, z: i64) -> f64 {
    rand3([17, 23, 29], x, y, z)
}

const EPSILON: f64 = 0.001;

/// `fnoise3`: fractal noise.
#[allow(clippy::needless_range_loop)] // kept in the shape of the C loops
pub fn fnoise3(p: [f64; 3]) -> f64 {
    let mut s: i64 = (1.0 / EPSILON) as i64;
    let mut t = [0i64; 3];
    let mut v = [0i64; 3];
    let mut beg = [0i64; 3];
    let mut fval = [0f64; 8];
    for i in 0..3 {
        t[i] = (s as f64 * p[i]) as i64;
        beg[i] = (s as f64 * p[i].floor()) as i64;
    }
    for (j, fv) in fval.iter_mut().enumerate() {
        for i in 0..3 {
            v[i] = beg[i];
            if j & 1 << i != 0 {
                v[i] = v[i].wrapping_add(s);
            }
        }
        *fv = frand3(v[0], v[1], v[2]);
    }
    loop {
        let mut fc = 0.0;
        for fv in &fval {
            fc += fv;
        }
        fc *= 0.125;
        s >>= 1;
        if s == 0 {
            return fc;
        }
        let sf = s as f64 * EPSILON;
        let mut branch = 0usize;
        for i in 0..3 {
            v[i] = beg[i].wrapping_add(s);
            if t[i] > v[i] {
                branch |= 1 << i;
            }
        }
        fc += sf * frand3(v[0], v[1], v[2]);
        fval[!branch & 7] = fc;
        for i in 0..3 {
            if branch & 1 << i != 0 {
                v[i] = v[i].wrapping_add(s);
            } else {
                v[i] = v[i].wrapping_sub(s);
            }
            let mut fc = 0.0;
            for (j, fv) in fval.iter().enumerate() {
                if !(j ^ branch) & 1 << i != 0 {
                    fc += fv;
                }
            }
            fc = 0.25 * fc + sf * frand3(v[0], v[1], v[2]);
            fval[!(branch ^ 1 << i) & 7] = fc;
            v[i] = beg[i].wrapping_add(s);
        }
        for i in 0..3 {
            for j in [(i + 1) % 3, (i + 2) % 3] {
                if branch & 1 << j != 0 {
                    v[j] = v[j].wrapping_add(s);
                } else {
                    v[j] = v[j].wrapping_sub(s);
                }
            }
            let mut fc = fval[branch & !(1 << i)];
            fc += fval[branch | 1 << i];
            fc = 0.5 * fc + sf * frand3(v[0], v[1], v[2]);
            fval[branch ^ 1 << i] = fc;
            for j in [(i + 1) % 3, (i + 2) % 3] {
                v[j] = beg[j].wrapping_add(s);
            }
        }
        for i in 0..3 {
            if branch & 1 << i != 0 {
                beg[i] = beg[i].wrapping_add(s);
            }
        }
    }
}

/// calcomp's `rand(x)` (`l_rand`): a hash of `x` into [0, 1).
// calcomp's truncated constants (not `E`, `FRAC_PI_4`) decide its values.
#[allow(clippy::approx_constant)]
pub fn rand(x: f64) -> f64 {
    let mut x = x;
    x *= 1.0 / (1.0 + x * x) + 2.71828182845904;
    x += 0.785398163397447 - x.floor();
    x = 1e5 / x;
    x - x.floor()
}
