//! Radiance's noise functions (`src/rt/noise3.c`) and calcomp's `rand`
//! (`l_rand` in `calfunc.c`), reproduced to the bit as Radiance 5 has them
//! (noise3.c 2.14, 2018): Perlin's improved noise with its partial
//! derivatives as backward differences, and the fractal `fnoise3` that
//! subdivides a cube of side 1 down to 1/2000.
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

fn hpoly1(t: f64) -> f64 {
    (2.0 * t - 3.0) * t * t + 1.0
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

/// Ken Perlin's permutation of 0..=255 from his reference implementation
/// of improved noise (SIGGRAPH 2002), which Radiance 5 uses.
const PERM: [u8; 256] = [
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69,
    142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219,
    203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175,
    74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230,
    220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76,
    132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173,
    186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163,
    70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232,
    178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162,
    241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204,
    176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141,
    128, 195, 78, 66, 215, 61, 156, 180,
];

#[inline]
fn perm(i: i32) -> i32 {
    PERM[(i & 0xff) as usize] as i32
}

#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// One of twelve gradient directions from the hash's low four bits, dotted
/// with the offset (Perlin's `grad`).
#[inline]
fn grad(hash: i32, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

/// Improved Perlin noise in [-1, 1], 0 at every lattice point.
pub fn perlin(x: f64, y: f64, z: f64) -> f64 {
    // C's `(int)x - (x<0)`: truncation, one less for negative values
    // (also at negative integers, as there).
    let cell = |v: f64| -> i32 { (v as i32).wrapping_sub(i32::from(v < 0.0)) };
    let (xi, yi, zi) = (cell(x), cell(y), cell(z));
    let (x, y, z) = (x - xi as f64, y - yi as f64, z - zi as f64);
    let (xi, yi, zi) = (xi & 0xff, yi & 0xff, zi & 0xff);
    let (u, v, w) = (fade(x), fade(y), fade(z));
    let a = perm(xi) + yi;
    let aa = perm(a) + zi;
    let ab = perm(a + 1) + zi;
    let b = perm(xi + 1) + yi;
    let ba = perm(b) + zi;
    let bb = perm(b + 1) + zi;
    lerp(
        w,
        lerp(
            v,
            lerp(u, grad(perm(aa), x, y, z), grad(perm(ba), x - 1.0, y, z)),
            lerp(
                u,
                grad(perm(ab), x, y - 1.0, z),
                grad(perm(bb), x - 1.0, y - 1.0, z),
            ),
        ),
        lerp(
            v,
            lerp(
                u,
                grad(perm(aa + 1), x, y, z - 1.0),
                grad(perm(ba + 1), x - 1.0, y, z - 1.0),
            ),
            lerp(
                u,
                grad(perm(ab + 1), x, y - 1.0, z - 1.0),
                grad(perm(bb + 1), x - 1.0, y - 1.0, z - 1.0),
            ),
        ),
    )
}

/// The step of noise3's partial derivatives and of fnoise3's finest cell.
const EPSILON: f64 = 0.0005;

/// `noise3` of Radiance 5 (noise3.c 2.14): returns `[noise3x, noise3y,
/// noise3z, noise3]` at `x`: improved Perlin noise and its partial
/// derivatives as backward differences over [`EPSILON`].
pub fn noise3(x: [f64; 3]) -> [f64; 4] {
    let f3 = perlin(x[0], x[1], x[2]);
    let d = |fc: f64| (f3 - fc) / EPSILON;
    [
        d(perlin(x[0] - EPSILON, x[1], x[2])),
        d(perlin(x[0], x[1] - EPSILON, x[2])),
        d(perlin(x[0], x[1], x[2] - EPSILON)),
        f3,
    ]
}

fn frand3(x: i64, y: i64, z: i64) -> f64 {
    rand3([17, 23, 29], x, y, z)
}

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
