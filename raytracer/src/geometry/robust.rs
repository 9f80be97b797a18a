//! Floating-point helpers for robust geometry: error-free products, ulp
//! stepping, orthonormal bases and self-intersection-free ray offsets.

use super::Vec3;

/// Radiance's `FTINY`: the tolerance below which a quantity counts as zero.
pub const FTINY: f64 = 1e-6;

/// `a*b - c*d` with about one ulp of error (Kahan's algorithm with FMA).
/// The sign is exact, and the result is exactly zero iff `a*b == c*d`.
#[inline]
pub fn diff_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    let dop = a.mul_add(b, -cd);
    dop + err
}

/// The smallest `f64` greater than `x` (`x` itself for `+inf` and NaN).
#[inline]
pub fn next_up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f64::from_bits(1);
    }
    let bits = x.to_bits();
    if x > 0.0 {
        f64::from_bits(bits + 1)
    } else {
        f64::from_bits(bits - 1)
    }
}

/// Orthonormal basis `(t, b)` perpendicular to the unit vector `n`, with
/// `(t, b, n)` right-handed (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Relative size of the offset applied by [`offset_origin`]: `2^-32`
/// (about 2.3e-10) of the largest coordinate magnitude, i.e. about 2^20 ulps.
/// Intersection routines in this module compute hit points to within a few
/// ulps of the coordinates' magnitude, so this is a safe margin by a factor of
/// about a million, while still small enough (a relative 2.3e-10) not to skip
/// geometry that is meant to be near.
pub const OFFSET_RELATIVE: f64 = 1.0 / 4_294_967_296.0;

/// Pushes the hit point `p` on a surface with (unit or not) geometric normal
/// `n` off that surface, to the side that `dir` points to, so a ray from the
/// returned origin in direction `dir` cannot re-hit the same surface near `p`
/// because of rounding. The offset scales with the magnitude of the point's
/// coordinates, as in Wächter and Binder, "A Fast and Robust Method for
/// Avoiding Self-Intersection" (Ray Tracing Gems, ch. 6), adapted to f64:
/// the error of a computed hit point is proportional to the magnitude of
/// its coordinates (and of the ray origin), not to a fixed absolute epsilon,
/// so the same code works at scene scales from 1e-4 to 1e4 and beyond.
///
/// Use `tmin = 0` for the secondary ray. See [`offset_origin_scaled`] when the
/// hit point lies near the coordinate origin but the incoming ray came from far.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, dir: Vec3) -> Vec3 {
    offset_origin_scaled(p, n, dir, 0.0)
}

/// [`offset_origin`] with an extra magnitude `scale` that the offset must
/// cover: pass the length of the incoming ray (its hit `t`) or the magnitude
/// of its origin when the hit point may be much closer to the coordinate
/// origin than the ray's origin was (the hit point's error is proportional
/// to `max(|p|, |origin|, t)`).
#[inline]
pub fn offset_origin_scaled(p: Vec3, n: Vec3, dir: Vec3, scale: f64) -> Vec3 {
    let len = n.length();
    if !len.is_finite() || len <= 0.0 {
        return p;
    }
    let n = n / len;
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    // Magnitude: the largest coordinate, never below the smallest normal
    // number times 2^40 so that points at the exact origin still move.
    let mag = p
        .abs()
        .max_element()
        .max(scale.abs())
        .max(f64::MIN_POSITIVE * 1.0e12);
    let d = mag * OFFSET_RELATIVE;
    // Also a step of `d` along the ray: a hit point is off its surface by
    // rounding, and at a concave seam (a floor meeting a wall) it may lie
    // just behind the *other* surface, which the new ray would then hit at
    // once, from behind (a seam shadowing itself). Stepping along the ray
    // moves the origin past any surface within `d`, whatever its
    // orientation; Radiance's absolute `FTINY` minimum distance does the
    // same, at one scale.
    let dl = dir.length();
    let along = if dl.is_finite() && dl > 0.0 {
        dir * (d / dl)
    } else {
        Vec3::ZERO
    };
    p + n * d + along
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dop_exact_sign() {
        // a*b == c*d exactly but naive evaluation is exact too; choose a case
        // where the naive result rounds to zero.
        let a = 1.0 + f64::EPSILON;
        let b = 1.0 - f64::EPSILON;
        // a*b = 1 - eps^2, which rounds to 1 in f64.
        assert_eq!(a * b - 1.0, 0.0);
        assert!(diff_of_products(a, b, 1.0, 1.0) < 0.0);
        assert_eq!(diff_of_products(3.0, 4.0, 6.0, 2.0), 0.0);
    }

    #[test]
    fn next_up_steps() {
        assert!(next_up(1.0) > 1.0);
        assert_eq!(next_up(1.0), 1.0 + f64::EPSILON);
        assert!(next_up(-1.0) > -1.0);
        assert!(next_up(0.0) > 0.0);
        assert!(next_up(-0.0) > 0.0);
        assert_eq!(next_up(f64::INFINITY), f64::INFINITY);
        assert!(next_up(-f64::MIN_POSITIVE) < 0.0);
    }

    #[test]
    fn onb_is_orthonormal() {
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-12);
            assert!((b.length() - 1.0).abs() < 1e-12);
            assert!(t.dot(b).abs() < 1e-12 && t.dot(n).abs() < 1e-12 && b.dot(n).abs() < 1e-12);
            assert!((t.cross(b) - n).length() < 1e-12);
        }
    }

    #[test]
    fn offset_clears_the_other_surface_of_a_concave_seam() {
        // A floor point (normal +z) computed a few ulps behind the wall
        // x = s that meets the floor, and below the floor: the ray into the
        // room (towards -x, up) must start in front of both surfaces, at
        // every scale.
        for s in [1e-5, 1e-3, 1.0, 1e3, 1e5] {
            let p = Vec3::new(
                s * (1.0 + 4.0 * f64::EPSILON),
                0.3 * s,
                -4.0 * f64::EPSILON * s,
            );
            for dir in [
                Vec3::new(-0.3, 0.1, 0.9),
                Vec3::new(-0.01, 0.5, 0.2),
                Vec3::new(-1.0, 0.0, 1e-3),
            ] {
                let o = offset_origin(p, Vec3::Z, dir);
                assert!(o.x < s && o.z > 0.0, "scale {s} dir {dir}: {o}");
                // Still within a relative 1e-9 of the point.
                assert!((o - p).length() < 1e-9 * s);
            }
        }
    }

    #[test]
    fn offset_moves_to_dir_side() {
        let p = Vec3::new(1e4, -3e3, 0.0);
        let n = Vec3::Z;
        let up = offset_origin(p, n, Vec3::new(0.3, 0.1, 0.5));
        let down = offset_origin(p, n, Vec3::new(0.3, 0.1, -0.5));
        assert!(up.z > 0.0 && down.z < 0.0);
        assert!(up.z < 1e-5 && up.z > 1e-7);
        let zero = offset_origin(Vec3::ZERO, n, n);
        assert!(zero.z > 0.0);
    }
}
