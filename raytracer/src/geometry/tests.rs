//! Tests for shapes: validation, intersection accuracy (proptest),
//! watertightness, sampling and robust ray offsets.

use std::f64::consts::PI;
use std::sync::Arc;

use proptest::prelude::*;

use super::shape_impl::intersect_triangle;
use super::*;
use crate::scene::Object;

fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}

fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

fn obj(shape: Shape) -> Object {
    Object {
        name: String::new(),
        shape,
        material: 0,
    }
}

/// Nearest hit over a list of shapes.
fn nearest(shapes: &[Shape], ray: &Ray, tmin: f64, tmax: f64) -> Option<(usize, ShapeHit)> {
    let mut best: Option<(usize, ShapeHit)> = None;
    for (i, s) in shapes.iter().enumerate() {
        let bound = best.map_or(tmax, |b| b.1.t);
        if let Some(h) = s.intersect(ray, tmin, bound) {
            best = Some((i, h));
        }
    }
    best
}

// ---------------------------------------------------------------- validation

#[test]
fn polygon_rejects_degenerate_input() {
    let e = Shape::polygon(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)]).unwrap_err();
    assert!(e.contains("at least 3 vertices"), "{e}");
    let e = Shape::polygon(vec![v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(2.0, 2.0, 2.0)]).unwrap_err();
    assert!(e.contains("zero area"), "{e}");
    let e = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(1.0, 1.0, 1.0),
        v(0.0, 0.0, 0.0),
        v(1.0, 1.0, 1.0),
    ])
    .unwrap_err();
    assert!(e.contains("zero area"), "{e}");
    let e = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(f64::NAN, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
    ])
    .unwrap_err();
    assert!(e.contains("vertex 2 is not finite"), "{e}");
    let e = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(f64::INFINITY, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
    ])
    .unwrap_err();
    assert!(e.contains("not finite"), "{e}");
    let e = Shape::polygon(vec![v(1.0, 2.0, 3.0); 5]).unwrap_err();
    assert!(e.contains("distinct vertices"), "{e}");
    let e = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 1.0, 0.3),
        v(0.0, 1.0, 0.0),
    ])
    .unwrap_err();
    assert!(e.contains("not planar"), "{e}");
}

#[test]
fn polygon_drops_duplicates_and_orients_by_vertex_order() {
    let s = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 0.0),
        v(1.0, 0.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(0.0, 1.0, 0.0),
        v(0.0, 0.0, 0.0),
    ])
    .unwrap();
    let Shape::Polygon(p) = &s else { panic!() };
    assert_eq!(p.vertices.len(), 4);
    assert_eq!(p.normal, Vec3::Z);
    assert_eq!(p.triangles.len(), 2);
    assert!((s.area() - 1.0).abs() < 1e-15);
    // Clockwise order gives the opposite normal, and triangles wound alike.
    let s = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(0.0, 1.0, 0.0),
        v(1.0, 1.0, 0.0),
        v(1.0, 0.0, 0.0),
    ])
    .unwrap();
    let Shape::Polygon(p) = &s else { panic!() };
    assert_eq!(p.normal, -Vec3::Z);
    for t in &p.triangles {
        let (a, b, c) = (
            p.vertices[t[0] as usize],
            p.vertices[t[1] as usize],
            p.vertices[t[2] as usize],
        );
        assert!((b - a).cross(c - a).dot(p.normal) > 0.0);
    }
}

#[test]
fn concave_polygon_triangulated_in_its_plane() {
    // An L shape in a tilted plane.
    let t = Transform::identity()
        .rotate_x(37.0)
        .rotate_y(-20.0)
        .translate(v(3.0, -1.0, 2.0));
    let l2d = [
        (0.0, 0.0),
        (2.0, 0.0),
        (2.0, 1.0),
        (1.0, 1.0),
        (1.0, 2.0),
        (0.0, 2.0),
    ];
    let s = Shape::polygon(l2d.iter().map(|&(x, y)| t.point(v(x, y, 0.0))).collect()).unwrap();
    assert!((s.area() - 3.0).abs() < 1e-12);
    let Shape::Polygon(p) = &s else { panic!() };
    assert!((p.normal - t.normal(Vec3::Z)).length() < 1e-12);
    // The notch (1.5, 1.5) is outside; (0.5, 1.5) and (1.5, 0.5) are inside.
    let dir = t.normal(-Vec3::Z);
    let through = |x: f64, y: f64| Ray::new(t.point(v(x, y, 1.0)), dir);
    assert!(s
        .intersect(&through(1.5, 1.5), 0.0, f64::INFINITY)
        .is_none());
    let h = s.intersect(&through(0.5, 1.5), 0.0, f64::INFINITY).unwrap();
    assert!((h.t - 1.0).abs() < 1e-12);
    assert!(s
        .intersect(&through(1.5, 0.5), 0.0, f64::INFINITY)
        .is_some());
}

#[test]
fn quadric_and_instance_validation() {
    assert!(Shape::sphere(Vec3::ZERO, -1.0, false)
        .unwrap_err()
        .contains("radius"));
    assert!(Shape::sphere(Vec3::ZERO, 0.0, false).is_err());
    assert!(Shape::sphere(Vec3::ZERO, f64::NAN, false).is_err());
    assert!(Shape::sphere(v(f64::NAN, 0.0, 0.0), 1.0, false)
        .unwrap_err()
        .contains("not finite"));
    assert!(Shape::cone(Vec3::ZERO, Vec3::ZERO, 1.0, 1.0, false)
        .unwrap_err()
        .contains("zero-length cone axis"));
    assert!(Shape::cone(Vec3::ZERO, Vec3::X, 0.0, 0.0, false)
        .unwrap_err()
        .contains("both zero"));
    assert!(Shape::cone(Vec3::ZERO, Vec3::X, -1.0, 1.0, false)
        .unwrap_err()
        .contains("non-negative"));
    assert!(Shape::cone(Vec3::ZERO, Vec3::X, 0.0, 1.0, false).is_ok());
    assert!(Shape::cone(Vec3::ZERO, v(f64::NAN, 1.0, 0.0), 1.0, 1.0, false).is_err());
    assert!(Shape::ring(Vec3::ZERO, Vec3::ZERO, 0.0, 1.0)
        .unwrap_err()
        .contains("normal"));
    assert!(Shape::ring(Vec3::ZERO, Vec3::Z, 1.0, 1.0)
        .unwrap_err()
        .contains("outer radius"));
    assert!(Shape::ring(Vec3::ZERO, Vec3::Z, -0.5, 1.0).is_err());
    let r = Shape::ring(Vec3::ZERO, v(0.0, 0.0, 2.0), 0.0, 1.0).unwrap();
    assert!(matches!(r, Shape::Ring { normal, .. } if normal == Vec3::Z));
}

// ------------------------------------------------------------- intersection

fn arb_vec(r: f64) -> impl Strategy<Value = Vec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| v(x, y, z))
}

fn arb_unit() -> impl Strategy<Value = Vec3> {
    arb_vec(1.0)
        .prop_filter("non-zero", |d| d.length() > 1e-3)
        .prop_map(|d| d.normalize())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, rng_seed: proptest::test_runner::RngSeed::Fixed(7), ..ProptestConfig::default() })]

    #[test]
    fn triangle_hit_at_aimed_interior_point(
        a in arb_vec(10.0), b in arb_vec(10.0), c in arb_vec(10.0),
        (u, w) in (0.01f64..0.98, 0.01f64..0.98),
        o in arb_vec(30.0),
        scale_exp in -4i32..=4,
    ) {
        let s = 10f64.powi(scale_exp);
        let (a, b, c, o) = (a * s, b * s, c * s, o * s);
        let n = (b - a).cross(c - a);
        prop_assume!(n.length() > 1e-2 * s * s);
        let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
        prop_assume!(u + w < 0.99);
        let p = a + (b - a) * u + (c - a) * w;
        let dist = (p - o).length();
        prop_assume!(dist > 1e-3 * s);
        // Not nearly parallel to the plane.
        prop_assume!(((p - o) / dist).dot(n.normalize()).abs() > 1e-3);
        let ray = Ray::new(o, p - o);
        let shape = Shape::polygon(vec![a, b, c]).unwrap();
        let h = shape.intersect(&ray, 0.0, f64::INFINITY).expect("aimed ray must hit");
        prop_assert!(rel_close(h.t, dist, 1e-9), "t {} vs {}", h.t, dist);
        prop_assert!((h.normal.length() - 1.0).abs() < 1e-12);
        // Hit point on the plane, relative to the size.
        let q = ray.at(h.t);
        prop_assert!((q - a).dot(h.normal).abs() <= 1e-9 * s * 30.0);
        // Open interval.
        prop_assert!(shape.intersect(&ray, 0.0, h.t).is_none());
        prop_assert!(shape.intersect(&ray, h.t, f64::INFINITY).is_none());
    }

    #[test]
    fn polygon_hit_at_random_interior_point(
        n in 3usize..12, seed_r in proptest::collection::vec(0.3f64..1.0, 12),
        rx in 0.0f64..360.0, ry in 0.0f64..360.0, t in arb_vec(5.0),
        (u, w) in (0.0f64..1.0, 0.0f64..1.0),
        o in arb_vec(20.0),
    ) {
        // Star-shaped (possibly concave) polygon around the origin.
        let xf = Transform::identity().rotate_x(rx).rotate_y(ry).translate(t);
        let pts: Vec<Vec3> = (0..n).map(|i| {
            let a = 2.0 * PI * i as f64 / n as f64;
            xf.point(v(seed_r[i] * a.cos(), seed_r[i] * a.sin(), 0.0))
        }).collect();
        let shape = Shape::polygon(pts).unwrap();
        let (p, nrm) = shape.sample(u, w);
        let dir = p - o;
        let dist = dir.length();
        prop_assume!(dist > 1e-3 && (dir / dist).dot(nrm).abs() > 1e-2);
        let ray = Ray::new(o, dir);
        let h = shape.intersect(&ray, 0.0, f64::INFINITY).expect("aimed ray must hit");
        prop_assert!(rel_close(h.t, dist, 1e-9), "t {} vs {}", h.t, dist);
        prop_assert_eq!(h.normal, nrm);
    }

    #[test]
    fn sphere_hits(
        c in arb_vec(100.0), r in 0.01f64..10.0, o in arb_vec(100.0), d in arb_unit(),
        scale_exp in -4i32..=4, inward in any::<bool>(),
    ) {
        let s = 10f64.powi(scale_exp);
        let (c, r, o) = (c * s, r * s, o * s);
        let dist = (c - o).length();
        prop_assume!(dist > r * 1.001);
        let sphere = Shape::sphere(c, r, inward).unwrap();
        // Aimed at the centre: t = |c - o| - r.
        let ray = Ray::new(o, c - o);
        let h = sphere.intersect(&ray, 0.0, f64::INFINITY).expect("aimed at the centre");
        prop_assert!((h.t - (dist - r)).abs() <= 1e-12 * dist, "t {} vs {}", h.t, dist - r);
        prop_assert!((h.normal.length() - 1.0).abs() < 1e-12);
        let facing = if inward { -1.0 } else { 1.0 };
        prop_assert!(h.normal.dot(ray.dir) * facing < 0.0);
        // Random direction: if hit, the point is on the sphere.
        let ray = Ray::new(o, d);
        if let Some(h) = sphere.intersect(&ray, 0.0, f64::INFINITY) {
            prop_assert!(h.t > 0.0);
            let q = ray.at(h.t);
            prop_assert!(((q - c).length() - r).abs() <= 1e-12 * (dist + r));
            // Second hit from inside, after the first.
            let h2 = sphere.intersect(&ray, h.t * (1.0 + 1e-9), f64::INFINITY);
            if let Some(h2) = h2 {
                prop_assert!(h2.t > h.t);
                prop_assert!(((ray.at(h2.t) - c).length() - r).abs() <= 1e-12 * (dist + r));
            }
        }
        // From inside (the centre): exactly r.
        let inner = Ray::new(c, d);
        let h = sphere.intersect(&inner, 0.0, f64::INFINITY).unwrap();
        prop_assert!(rel_close(h.t, r, 1e-12));
    }

    #[test]
    fn cone_hits_sampled_surface_point(
        p0 in arb_vec(10.0), p1 in arb_vec(10.0), r0 in 0.0f64..3.0, r1 in 0.0f64..3.0,
        cyl in any::<bool>(), (u, w) in (0.0f64..1.0, 0.0f64..1.0), o in arb_vec(30.0),
        scale_exp in -4i32..=4,
    ) {
        let s = 10f64.powi(scale_exp);
        let r1 = if cyl { r0 } else { r1 };
        prop_assume!(r0 + r1 > 0.05 && (p1 - p0).length() > 0.1);
        let (p0, p1, r0, r1, o) = (p0 * s, p1 * s, r0 * s, r1 * s, o * s);
        let cone = Shape::cone(p0, p1, r0, r1, false).unwrap();
        let (p, n) = cone.sample(u, w);
        prop_assert!((n.length() - 1.0).abs() < 1e-12);
        let dir = p - o;
        let dist = dir.length();
        prop_assume!(dist > 1e-3 * s && (dir / dist).dot(n).abs() > 1e-2);
        let ray = Ray::new(o, dir);
        let h = cone.intersect(&ray, 0.0, f64::INFINITY).expect("aimed at a surface point");
        prop_assert!(h.t <= dist * (1.0 + 1e-9));
        // The hit lies on the surface.
        let q = ray.at(h.t);
        let a = (p1 - p0).normalize();
        let h_len = (p1 - p0).length();
        let sa = (q - p0).dot(a);
        prop_assert!(sa >= -1e-9 * s * 40.0 && sa <= h_len + 1e-9 * s * 40.0);
        let radial = ((q - p0) - a * sa).length();
        let expect = r0 + (r1 - r0) * sa / h_len;
        prop_assert!((radial - expect).abs() <= 1e-9 * s * 40.0, "radial {} vs {}", radial, expect);
        prop_assert!((h.normal.length() - 1.0).abs() < 1e-12);
        if rel_close(h.t, dist, 1e-9) {
            prop_assert!((h.normal - n).length() < 1e-6);
        }
    }

    #[test]
    fn ring_hits_sampled_point(
        c in arb_vec(10.0), nrm in arb_unit(), ri in 0.0f64..2.0, dr in 0.1f64..3.0,
        (u, w) in (0.0f64..1.0, 0.0f64..1.0), o in arb_vec(30.0),
    ) {
        let ring = Shape::ring(c, nrm, ri, ri + dr).unwrap();
        let (p, n) = ring.sample(u, w);
        prop_assert!((n - nrm).length() < 1e-15);
        let rr = (p - c).length();
        prop_assert!(rr >= ri * (1.0 - 1e-12) && rr <= (ri + dr) * (1.0 + 1e-12));
        let dir = p - o;
        let dist = dir.length();
        prop_assume!(dist > 1e-3 && (dir / dist).dot(n).abs() > 1e-2);
        // Keep clear of the rim where rounding decides.
        prop_assume!(rr > ri + 1e-6 && rr < ri + dr - 1e-6);
        let h = ring.intersect(&Ray::new(o, dir), 0.0, f64::INFINITY).expect("aimed at the ring");
        prop_assert!(rel_close(h.t, dist, 1e-9));
        // Through the hole: no hit.
        if ri > 0.1 {
            let hole = c + (p - c).normalize() * (ri * 0.5);
            prop_assert!(ring.intersect(&Ray::new(o, hole - o), 0.0, f64::INFINITY).is_none());
        }
    }

    #[test]
    fn sampling_stays_on_surface(
        (u, w) in (0.0f64..1.0, 0.0f64..1.0), c in arb_vec(5.0), r in 0.1f64..3.0,
    ) {
        let s = Shape::sphere(c, r, false).unwrap();
        let (p, n) = s.sample(u, w);
        prop_assert!(((p - c).length() - r).abs() < 1e-12 * (1.0 + c.length()));
        prop_assert!((n - (p - c).normalize()).length() < 1e-9);
    }
}

#[test]
fn sampling_is_uniform_by_area() {
    // A polygon made of a big and a small triangle: counts proportional to area.
    let s = Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(3.0, 0.0, 0.0),
        v(3.0, 1.0, 0.0),
        v(2.0, 1.0, 0.0),
    ])
    .unwrap();
    let n = 64;
    let mut left = 0; // points with x < 2
    for i in 0..n {
        for j in 0..n {
            let (p, _) = s.sample((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            if p.x < 2.0 {
                left += 1;
            }
        }
    }
    // Area left of x = 2 is 1 of total 2 (picking the two triangles with equal
    // probability instead of by area would give about 0.56).
    let frac = left as f64 / (n * n) as f64;
    assert!((frac - 0.5).abs() < 0.02, "{frac}");
    // Cone: half the samples in u fall below r^2 midpoint.
    let cone = Shape::cone(Vec3::ZERO, Vec3::Z, 0.0, 1.0, false).unwrap();
    let (p, n0) = cone.sample(0.25, 0.3);
    // Area up to height z of a cone with apex at 0 is proportional to z^2.
    assert!((p.z - 0.5).abs() < 1e-12, "{p}");
    assert!((n0.dot(p - v(0.0, 0.0, p.z))).abs() > 0.0);
    let area = cone.area();
    assert!((area - PI * 2f64.sqrt()).abs() < 1e-12);
    let ring = Shape::ring(Vec3::ZERO, Vec3::Z, 1.0, 2.0).unwrap();
    assert!((ring.area() - 3.0 * PI).abs() < 1e-12);
    let (p, _) = ring.sample(0.5, 0.0);
    assert!((p.length() - 2.5f64.sqrt()).abs() < 1e-12);
}

#[test]
fn cone_axis_parallel_and_tangent_rays() {
    let cyl = Shape::cone(v(0.0, 0.0, 0.0), v(0.0, 0.0, 2.0), 1.0, 1.0, false).unwrap();
    // Parallel to the axis, inside: no hit (open ended).
    assert!(cyl
        .intersect(&Ray::new(v(0.5, 0.0, -1.0), Vec3::Z), 0.0, f64::INFINITY)
        .is_none());
    // Perpendicular through the axis: hits at distance 4 (from x = 5 to x = 1).
    let h = cyl
        .intersect(&Ray::new(v(5.0, 0.0, 1.0), -Vec3::X), 0.0, f64::INFINITY)
        .unwrap();
    assert!((h.t - 4.0).abs() < 1e-12 && (h.normal - Vec3::X).length() < 1e-12);
    // Inward cylinder flips the normal.
    let tube = Shape::cone(v(0.0, 0.0, 0.0), v(0.0, 0.0, 2.0), 1.0, 1.0, true).unwrap();
    let h = tube
        .intersect(&Ray::new(v(5.0, 0.0, 1.0), -Vec3::X), 0.0, f64::INFINITY)
        .unwrap();
    assert!((h.normal + Vec3::X).length() < 1e-12);
    // Beyond the end caps: miss.
    assert!(cyl
        .intersect(&Ray::new(v(5.0, 0.0, 2.5), -Vec3::X), 0.0, f64::INFINITY)
        .is_none());
    // Cone with apex: normal tilts along the axis.
    let cone = Shape::cone(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), 1.0, 0.0, false).unwrap();
    let h = cone
        .intersect(&Ray::new(v(5.0, 0.0, 0.5), -Vec3::X), 0.0, f64::INFINITY)
        .unwrap();
    assert!((h.t - 4.5).abs() < 1e-12);
    assert!((h.normal - v(1.0, 0.0, 1.0).normalize()).length() < 1e-12);
    // Ray along a generator line (A == 0 in the quadratic).
    let r = Ray::new(v(2.0, 0.0, -1.0), v(-1.0, 0.0, 1.0));
    let h = cone.intersect(&r, 0.0, f64::INFINITY);
    assert!(h.is_none() || (ray_dist_to_cone(&r, h.unwrap().t) < 1e-9));
}

fn ray_dist_to_cone(r: &Ray, t: f64) -> f64 {
    let q = r.at(t);
    let radial = (q.x * q.x + q.y * q.y).sqrt();
    (radial - (1.0 - q.z)).abs()
}

// ------------------------------------------------------------ watertightness

/// A box of 6 quads sharing edges, outward normals, under a transform.
fn closed_box(xf: &Transform, lo: Vec3, hi: Vec3) -> Vec<Shape> {
    let c = |i: usize| {
        xf.point(v(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        ))
    };
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    faces
        .iter()
        .map(|f| Shape::polygon(f.iter().map(|&i| c(i)).collect()).unwrap())
        .collect()
}

fn box_targets(xf: &Transform, lo: Vec3, hi: Vec3) -> Vec<Vec3> {
    // Corners, edge midpoints and edge points at awkward fractions.
    let mut out = Vec::new();
    let coord = |a: f64, b: f64, k: u32| match k {
        0 => a,
        1 => b,
        2 => 0.5 * (a + b),
        _ => a + (b - a) / 3.0,
    };
    for kx in 0..4 {
        for ky in 0..4 {
            for kz in 0..4 {
                let at_bound = [kx, ky, kz].iter().filter(|&&k| k < 2).count();
                if at_bound >= 2 {
                    out.push(xf.point(v(
                        coord(lo.x, hi.x, kx),
                        coord(lo.y, hi.y, ky),
                        coord(lo.z, hi.z, kz),
                    )));
                }
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(11), ..ProptestConfig::default() })]

    #[test]
    fn closed_box_is_watertight(
        rx in 0.0f64..360.0, rz in 0.0f64..360.0, t in arb_vec(50.0), scale_exp in -4i32..=4,
        lo in arb_vec(1.0), ext in arb_vec(1.0),
        (a, b, c) in (0.001f64..0.999, 0.001f64..0.999, 0.001f64..0.999),
        dirs in proptest::collection::vec(arb_unit(), 32),
    ) {
        let s = 10f64.powi(scale_exp);
        let hi = lo + ext.abs() + Vec3::splat(0.2);
        let xf = Transform::identity().rotate_x(rx).rotate_z(rz).scale(s).unwrap().translate(t * s);
        let shapes = closed_box(&xf, lo, hi);
        let origin = xf.point(lo + (hi - lo) * v(a, b, c));
        let mut directions: Vec<Vec3> = box_targets(&xf, lo, hi).into_iter().map(|p| p - origin).collect();
        directions.extend(dirs);
        // Axis-parallel directions too.
        for ax in [Vec3::X, Vec3::Y, Vec3::Z] {
            directions.push(ax);
            directions.push(-ax);
        }
        for d in directions {
            let ray = Ray::new(origin, d);
            let hit = nearest(&shapes, &ray, 0.0, f64::INFINITY);
            prop_assert!(hit.is_some(), "ray {:?} escaped the box", ray);
            // Exactly one hit distance class: the exit point lies on the box.
            let (_, h) = hit.unwrap();
            prop_assert!(h.normal.dot(ray.dir) >= -1e-12, "hit a face from outside");
        }
    }

    #[test]
    fn triangle_fan_is_watertight(
        n in 3usize..40, c in arb_vec(3.0), o in arb_vec(3.0), k in 0usize..40, f in 0.0f64..1.0,
    ) {
        // A fan of triangles around `c` in the plane z = 0; rays from above
        // aimed exactly at shared edges (points on them) and at the centre vertex.
        let c = v(c.x, c.y, 0.0);
        let ring: Vec<Vec3> = (0..n).map(|i| {
            let a = 2.0 * PI * i as f64 / n as f64;
            c + v(a.cos(), a.sin(), 0.0)
        }).collect();
        let tris: Vec<Shape> = (0..n).map(|i| Shape::polygon(vec![c, ring[i], ring[(i + 1) % n]]).unwrap()).collect();
        let o = v(o.x, o.y, 1.0 + o.z.abs());
        let i = k % n;
        for target in [c, c + (ring[i] - c) * f, ring[i]] {
            let ray = Ray::new(o, target - o);
            let hit = nearest(&tris, &ray, 0.0, f64::INFINITY);
            if target == ring[i] {
                continue; // the outer rim may be missed legitimately
            }
            prop_assert!(hit.is_some(), "ray to {:?} slipped through", target);
        }
    }
}

#[test]
fn woop_fallback_consistent_on_shared_edge() {
    // Two triangles sharing an edge; a ray exactly through a point of the edge
    // with coordinates that make the edge function round to zero.
    let a = v(0.1, 0.0, 0.0);
    let b = v(0.0, 0.3, 0.0);
    let c1 = v(1.0, 1.0, 0.0);
    let c2 = v(-1.0, -1.0, 0.0);
    for k in 0..200 {
        let f = k as f64 / 199.0;
        let p = a + (b - a) * f;
        let o = v(0.01 * k as f64, -0.3, 2.0);
        let ray = Ray::new(o, p - o);
        let pre = PreparedRay::new(&ray);
        let h1 = intersect_triangle(&pre, a, b, c1, 0.0, f64::INFINITY);
        let h2 = intersect_triangle(&pre, b, a, c2, 0.0, f64::INFINITY);
        assert!(
            h1.is_some() || h2.is_some(),
            "ray through the shared edge at f = {f} missed both"
        );
    }
}

// ---------------------------------------------------------- origin offsets

#[test]
fn offset_origin_never_rehits_own_surface() {
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    for scale in [1e-4, 1.0, 1e4] {
        let plane = Shape::polygon(vec![
            v(-1.0, -1.0, 0.3) * scale,
            v(1.0, -1.0, 0.3) * scale,
            v(1.0, 1.0, 0.3) * scale,
            v(-1.0, 1.0, 0.3) * scale,
        ])
        .unwrap();
        let sphere = Shape::sphere(v(0.3, -0.2, 0.5) * scale, 0.37 * scale, false).unwrap();
        let mut runner = TestRunner::new(Config {
            cases: 500,
            rng_seed: RngSeed::Fixed(5),
            ..Config::default()
        });
        runner
            .run(
                &(arb_vec(0.9), arb_unit(), arb_unit()),
                |(p, d_in, d_out)| {
                    // Camera ray to a point of the plane.
                    let target = v(p.x, p.y, 0.3) * scale;
                    let cam = v(0.2, 0.1, 2.0) * scale;
                    let ray = Ray::new(cam, target - cam);
                    let h = plane.intersect(&ray, 0.0, f64::INFINITY).unwrap();
                    let q = ray.at(h.t);
                    for dir in [d_out, -d_out] {
                        let o = offset_origin(q, h.normal, dir);
                        prop_assert!(plane
                            .intersect(&Ray::new(o, dir), 0.0, f64::INFINITY)
                            .is_none());
                    }
                    // Sphere: reflected rays leave, refracted rays cross to the far side.
                    let ray = Ray::new(sphere_point(scale) + d_in * 3.0 * scale, -d_in);
                    if let Some(h) = sphere.intersect(&ray, 0.0, f64::INFINITY) {
                        let q = ray.at(h.t);
                        let dir = if d_out.dot(h.normal) >= 0.0 {
                            d_out
                        } else {
                            -d_out
                        };
                        let o = offset_origin(q, h.normal, dir);
                        prop_assert!(sphere
                            .intersect(&Ray::new(o, dir), 0.0, f64::INFINITY)
                            .is_none());
                        let o = offset_origin(q, h.normal, -dir);
                        if let Some(h2) = sphere.intersect(&Ray::new(o, -dir), 0.0, f64::INFINITY) {
                            // The far side: the chord length, never a self-hit near 0.
                            let chord = 2.0 * 0.37 * scale * dir.dot(h.normal).abs();
                            prop_assert!(
                                rel_close(h2.t, chord, 1e-3) || (h2.t - chord).abs() < 1e-8 * scale,
                                "far side at {} but chord {} (scale {})",
                                h2.t,
                                chord,
                                scale
                            );
                        }
                    }
                    Ok(())
                },
            )
            .unwrap();
        // Nearby geometry is not skipped: a parallel plane 1e-7 * scale above.
        let near = Shape::polygon(vec![
            v(-1.0, -1.0, 0.3 + 1e-7) * scale,
            v(1.0, -1.0, 0.3 + 1e-7) * scale,
            v(1.0, 1.0, 0.3 + 1e-7) * scale,
            v(-1.0, 1.0, 0.3 + 1e-7) * scale,
        ])
        .unwrap();
        let q = v(0.1, 0.2, 0.3) * scale;
        let o = offset_origin(q, Vec3::Z, v(0.3, 0.1, 1.0));
        assert!(near
            .intersect(&Ray::new(o, v(0.3, 0.1, 1.0)), 0.0, f64::INFINITY)
            .is_some());
    }
}

fn sphere_point(scale: f64) -> Vec3 {
    v(0.3, -0.2, 0.5) * scale
}

// ------------------------------------------------------------------ instances

fn sample_objects() -> Vec<Object> {
    vec![
        obj(Shape::polygon(vec![
            v(0.0, 0.0, 0.0),
            v(2.0, 0.0, 0.0),
            v(2.0, 1.0, 0.5),
            v(0.0, 1.0, 0.5),
        ])
        .unwrap()),
        obj(Shape::sphere(v(1.0, 2.0, 0.5), 0.4, false).unwrap()),
        obj(Shape::sphere(v(-1.0, 0.0, 0.5), 0.3, true).unwrap()),
        obj(Shape::cone(v(0.0, -1.0, 0.0), v(0.0, -1.0, 1.5), 0.5, 0.2, false).unwrap()),
        obj(Shape::ring(v(2.0, -1.0, 0.3), v(0.0, 0.3, 1.0), 0.1, 0.6).unwrap()),
    ]
}

/// The same objects with the transform applied to their parameters, as a
/// loader applying `xform` to raw primitives would.
fn transform_explicitly(objects: &[Object], t: &Transform) -> Vec<Shape> {
    objects
        .iter()
        .map(|o| match &o.shape {
            Shape::Polygon(p) => {
                let mut vs: Vec<Vec3> = p.vertices.iter().map(|&x| t.point(x)).collect();
                if t.is_mirror() {
                    vs.reverse();
                }
                Shape::polygon(vs).unwrap()
            }
            Shape::Sphere {
                center,
                radius,
                inward,
            } => Shape::sphere(t.point(*center), radius * t.scale, *inward).unwrap(),
            Shape::Cone {
                p0,
                p1,
                r0,
                r1,
                inward,
            } => Shape::cone(
                t.point(*p0),
                t.point(*p1),
                r0 * t.scale,
                r1 * t.scale,
                *inward,
            )
            .unwrap(),
            Shape::Ring {
                center,
                normal,
                r_inner,
                r_outer,
            } => Shape::ring(
                t.point(*center),
                t.normal(*normal),
                r_inner * t.scale,
                r_outer * t.scale,
            )
            .unwrap(),
            Shape::Instance(_) => unreachable!(),
        })
        .collect()
}

#[test]
fn instance_hits_equal_explicit_transform() {
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let geo = Arc::new(InstanceGeometry::new("sample", sample_objects()));
    assert_eq!(geo.objects.len(), 5);
    for (k, t) in [
        Transform::identity(),
        Transform::identity()
            .scale(2.5)
            .unwrap()
            .rotate_z(30.0)
            .translate(v(3.0, -2.0, 1.0)),
        Transform::identity()
            .mirror_x()
            .rotate_y(71.0)
            .scale(0.01)
            .unwrap()
            .translate(v(0.1, 0.0, 0.0)),
        Transform::identity()
            .rotate_x(90.0)
            .scale(1e4)
            .unwrap()
            .mirror_z()
            .translate(v(1e4, 2e4, 0.0)),
    ]
    .iter()
    .enumerate()
    {
        let inst = Shape::instance(geo.clone(), *t).unwrap();
        let explicit = transform_explicitly(&geo.objects, t);
        let b = inst.bounds();
        for s in &explicit {
            let sb = s.bounds();
            assert!(
                b.union(sb) == b || (b.union(sb).extent() - b.extent()).length() < 1e-9 * t.scale
            );
        }
        // Area scales with scale^2.
        let ea: f64 = explicit.iter().map(Shape::area).sum();
        assert!(rel_close(inst.area(), ea, 1e-9));
        let c = b.center();
        let size = b.extent().length();
        let mut runner = TestRunner::new(Config {
            cases: 300,
            rng_seed: RngSeed::Fixed(k as u64),
            ..Config::default()
        });
        let hits = std::cell::Cell::new(0);
        runner
            .run(
                &(
                    arb_unit(),
                    0usize..5,
                    (0.0f64..1.0, 0.0f64..1.0),
                    0.0f64..1.0,
                ),
                |(d, k, (u, w), miss)| {
                    // Aimed at a surface point of a random part (or, sometimes, past it).
                    let (p, _) = explicit[k].sample(u, w);
                    let origin = c - d * size * 1.5;
                    let target = if miss < 0.2 {
                        p + d.cross(Vec3::Z) * size * miss
                    } else {
                        p
                    };
                    prop_assume!((target - origin).length() > 1e-9 * size);
                    let ray = Ray::new(origin, target - origin);
                    let hi = inst.intersect(&ray, 0.0, f64::INFINITY);
                    let he = nearest(&explicit, &ray, 0.0, f64::INFINITY);
                    match (hi, he) {
                        (None, None) => {}
                        (Some(a), Some((id, b))) => {
                            hits.set(hits.get() + 1);
                            prop_assert_eq!(a.inner, Some(id as u32));
                            prop_assert!(rel_close(a.t, b.t, 1e-9), "t {} vs {}", a.t, b.t);
                            prop_assert!(
                                (a.normal - b.normal).length() < 1e-6,
                                "n {} vs {}",
                                a.normal,
                                b.normal
                            );
                            // tmax just below the hit excludes it.
                            prop_assert!(inst.intersect(&ray, 0.0, a.t * (1.0 - 1e-9)).is_none());
                            prop_assert!(inst.occludes_prepared(
                                &PreparedRay::new(&ray),
                                0.0,
                                f64::INFINITY
                            ));
                        }
                        (a, b) => prop_assert!(false, "instance {:?} vs explicit {:?}", a, b),
                    }
                    Ok(())
                },
            )
            .unwrap();
        assert!(hits.get() > 30, "too few hits ({}) to compare", hits.get());
        // Every sample point of the explicit geometry is reachable through the instance.
        for (i, s) in explicit.iter().enumerate() {
            let (p, n) = s.sample(0.37, 0.61);
            let o = p + n * size * 0.01 + t.normal(Vec3::new(0.1, 0.2, 0.3)) * size * 1e-3;
            let ray = Ray::new(o, p - o);
            let h = inst
                .intersect(&ray, 0.0, f64::INFINITY)
                .expect("sample point reachable");
            assert_eq!(h.inner, Some(i as u32), "transform {k}");
        }
        let (p, n) = inst.sample(0.3, 0.7);
        assert!(p.is_finite() && (n.length() - 1.0).abs() < 1e-12);
    }
}

// ------------------------------------------------------------- tessellation

#[test]
fn tessellation_lies_on_the_surfaces() {
    let objects = sample_objects();
    let k = 16;
    let mut counts = Vec::new();
    for o in &objects {
        let mut tris = Vec::new();
        tessellate(&o.shape, k, &mut tris);
        counts.push(tris.len());
        for p in tris.iter().flatten() {
            let on = match &o.shape {
                Shape::Polygon(poly) => (*p - poly.vertices[0]).dot(poly.normal).abs() < 1e-12,
                Shape::Sphere { center, radius, .. } => {
                    rel_close(p.distance(*center), *radius, 1e-12)
                }
                Shape::Cone { p0, p1, r0, r1, .. } => {
                    let a = (*p1 - *p0).normalize();
                    let s = (*p - *p0).dot(a) / (*p1 - *p0).length();
                    let r = (*p - *p0 - a * (*p - *p0).dot(a)).length();
                    (s.abs() < 1e-12 || (s - 1.0).abs() < 1e-12)
                        && (r - (r0 + s * (r1 - r0))).abs() < 1e-12
                }
                Shape::Ring {
                    center,
                    normal,
                    r_inner,
                    r_outer,
                } => {
                    let d = *p - *center;
                    let r = d.length();
                    d.dot(*normal).abs() < 1e-12
                        && (r < 1e-12
                            || rel_close(r, *r_inner, 1e-12)
                            || rel_close(r, *r_outer, 1e-12))
                }
                Shape::Instance(_) => unreachable!(),
            };
            assert!(on, "{p} is not on {:?}", o.shape);
        }
    }
    // Polygon: its two triangles; sphere: k per row, the poles' rows fans;
    // cone and ring: two per step.
    assert_eq!(counts, vec![2, 14 * k, 14 * k, 2 * k, 2 * k]);
    let mut disk = Vec::new();
    tessellate(
        &Shape::ring(v(0.0, 0.0, 0.0), Vec3::Z, 0.0, 1.0).unwrap(),
        k,
        &mut disk,
    );
    assert_eq!(disk.len(), k);

    // An instance gives its geometry's triangles, transformed.
    let t = Transform::identity()
        .scale(2.5)
        .unwrap()
        .rotate_z(30.0)
        .translate(v(3.0, -2.0, 1.0));
    let geo = Arc::new(InstanceGeometry::new("sample", objects.clone()));
    let mut inst = Vec::new();
    tessellate(&Shape::instance(geo, t).unwrap(), k, &mut inst);
    let mut direct = Vec::new();
    for o in &objects {
        tessellate(&o.shape, k, &mut direct);
    }
    assert_eq!(inst.len(), direct.len());
    for (a, b) in inst.iter().zip(&direct) {
        for i in 0..3 {
            assert!((a[i] - t.point(b[i])).length() < 1e-12 * 10.0);
        }
    }
}

/// The triangle/box test's specialised axes (two products each) answer as
/// the general cross and dot products do: random triangles and boxes at
/// scales from 1e-30 to 1e30, and the hard cases (edges along an axis,
/// where the zero terms the specialised form leaves out are products
/// with zero; degenerate triangles; triangles touching a face, an edge or
/// a corner of the box; boxes of zero extent), each also shifted far from
/// the origin. Non-finite coordinates take the general form itself.
#[test]
fn specialised_triangle_box_axes_answer_as_the_general_ones() {
    use super::shape_impl::{tri_box_overlap, tri_box_overlap_general};
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let same = |c: Vec3, h: Vec3, t: [Vec3; 3]| {
        let (a, b) = (
            tri_box_overlap(c, h, t[0], t[1], t[2]),
            tri_box_overlap_general(c, h, t[0], t[1], t[2]),
        );
        assert_eq!(a, b, "box {c:?} ± {h:?}, triangle {t:?}");
        a
    };
    // Hard cases around the unit box, at several scales and offsets.
    let mut overlaps = 0;
    let hard: Vec<[Vec3; 3]> = vec![
        // Edges along the axes, crossing a face.
        [
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(1.5, 0.5, 0.0),
            Vec3::new(0.5, 1.5, 0.0),
        ],
        // Touching the face x = 1, the edge, the corner.
        [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
            Vec3::new(2.0, -0.5, 0.3),
        ],
        [
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(2.0, 1.0, 1.0),
        ],
        [
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(2.0, 2.0, 2.0),
            Vec3::new(2.0, 1.0, 3.0),
        ],
        // Just outside a corner, diagonal: only an edge axis separates.
        [
            Vec3::new(1.6, 0.0, 1.6),
            Vec3::new(0.0, 1.6, 1.6),
            Vec3::new(1.6, 1.6, 0.0),
        ],
        [
            Vec3::new(1.4, 0.0, 1.4),
            Vec3::new(0.0, 1.4, 1.4),
            Vec3::new(1.4, 1.4, 0.0),
        ],
        // Degenerate: a segment, a point, a zero-area sliver.
        [
            Vec3::new(-2.0, 0.3, 0.2),
            Vec3::new(2.0, 0.3, 0.2),
            Vec3::new(2.0, 0.3, 0.2),
        ],
        [
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(0.5, 0.5, 0.5),
        ],
        [
            Vec3::new(-3.0, 1.0 + 1e-15, 0.0),
            Vec3::new(3.0, 1.0 + 1e-15, 0.0),
            Vec3::new(0.0, 1.0 + 2e-15, 0.0),
        ],
        // Big and containing the box.
        [
            Vec3::new(-100.0, -100.0, 0.1),
            Vec3::new(100.0, -100.0, 0.1),
            Vec3::new(0.0, 100.0, 0.1),
        ],
    ];
    for scale in [1e-30, 1e-9, 1.0, 3.7, 1e9, 1e30] {
        for offset in [0.0, 1e6, -1e12] {
            let o = Vec3::splat(offset * scale);
            for h in [Vec3::ONE, Vec3::new(1.0, 0.0, 2.0), Vec3::ZERO] {
                for t in &hard {
                    let t = t.map(|v| v * scale + o);
                    overlaps += same(o, h * scale, t) as usize;
                }
            }
        }
    }
    assert!(overlaps > 0);
    // Non-finite coordinates: the general form, whatever it answers.
    let inf = Vec3::new(f64::INFINITY, 0.0, 0.0);
    same(Vec3::ZERO, Vec3::ONE, [inf, Vec3::ZERO, Vec3::Y]);
    same(
        Vec3::ZERO,
        Vec3::splat(f64::INFINITY),
        [Vec3::X, Vec3::ZERO, Vec3::Y],
    );
    same(
        Vec3::ZERO,
        Vec3::ONE,
        [Vec3::splat(f64::NAN), Vec3::ZERO, Vec3::Y],
    );
    // Random ones: most near the box, so that every axis decides some.
    let mut runner = TestRunner::new(Config {
        cases: 4000,
        rng_seed: RngSeed::Fixed(23),
        ..Config::default()
    });
    let coord = -2.0f64..2.0;
    let v = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    let strategy = (
        v.clone(),
        v.clone(),
        v,
        (0.0f64..1.5, 0.0f64..1.5, 0.0f64..1.5),
        prop::sample::select(vec![1e-30, 1e-7, 1.0, 1e7, 1e30]),
    );
    runner
        .run(&strategy, |(a, b, c, (hx, hy, hz), s)| {
            let h = Vec3::new(hx, hy, hz) * s;
            same(Vec3::ZERO, h, [a * s, b * s, c * s]);
            same(Vec3::splat(0.25 * s), h, [a * s, b * s, c * s]);
            Ok(())
        })
        .unwrap();
}
