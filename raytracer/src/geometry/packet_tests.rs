//! Packets give the single-ray answers, bit for bit: coherent and
//! incoherent packets (proptest), rays along the axes (infinite inverse
//! directions) beside oblique ones, origins on the boxes' planes, grazing
//! rays, and scenes from 1e-5 to 1e5 in size.

use proptest::prelude::*;

use super::rng::Rng;
use super::*;
use crate::scene::Object;

fn obj(shape: Shape) -> Object {
    Object {
        name: String::new(),
        shape,
        material: 0,
    }
}

/// Random triangles, quads and spheres in a cube of side `10 * s`, with
/// coincident copies (equal distances: the smaller id wins).
fn scene(seed: u64, n: usize, s: f64) -> Vec<Object> {
    let mut rng = Rng::new(seed);
    let mut v = || Vec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64());
    let mut out = Vec::new();
    while out.len() < n {
        let c = v() * 10.0 * s;
        let (a, b) = (c + v() * s, c + v() * s);
        let shape = match out.len() % 5 {
            0 => Shape::sphere(c, 0.3 * s, false),
            1 => Shape::polygon(vec![c, a, a + (b - c), b]),
            _ => Shape::polygon(vec![c, a, b]),
        };
        if let Ok(shape) = shape {
            out.push(obj(shape));
        }
    }
    for k in 0..5 {
        out.push(out[1 + k].clone());
    }
    out
}

/// Every ray of `rays` through `intersect_packet` and `occluded_packet`
/// against one ray at a time.
fn check(bvh: &Bvh, objects: &[Object], rays: &[Segment]) -> Result<(), TestCaseError> {
    let mut hits = [None; PACKET];
    bvh.intersect_packet(objects, rays, &mut hits);
    let mut blocked = [false; PACKET];
    for (i, (r, t0, t1)) in rays.iter().enumerate() {
        let want = bvh.intersect(objects, r, *t0, *t1);
        prop_assert_eq!(hits[i], want, "ray {} {:?} ({}, {})", i, r, t0, t1);
    }
    for ignore in [None, Some(1)] {
        bvh.occluded_packet(objects, rays, ignore, &mut blocked);
        for (i, (r, t0, t1)) in rays.iter().enumerate() {
            let want = bvh.occluded(objects, r, *t0, *t1, ignore);
            prop_assert_eq!(
                blocked[i],
                want,
                "shadow ray {} {:?} ignoring {:?}",
                i,
                r,
                ignore
            );
        }
    }
    Ok(())
}

/// `n` rays from around `o` (spread `spread`) towards directions within
/// `cone` of `d`, each with its own segment.
fn packet(seed: u64, n: usize, o: Vec3, d: Vec3, spread: f64, cone: f64) -> Vec<Segment> {
    let mut rng = Rng::new(seed);
    let mut u = || 2.0 * rng.next_f64() - 1.0;
    (0..n)
        .map(|k| {
            let origin = o + Vec3::new(u(), u(), u()) * spread;
            let dir = (d + Vec3::new(u(), u(), u()) * cone).normalize();
            let tmin = if k % 3 == 0 { 0.0 } else { 1e-3 * u().abs() };
            let tmax = if k % 4 == 0 {
                f64::INFINITY
            } else {
                5.0 + 30.0 * u().abs()
            };
            (Ray::new(origin, dir), tmin, tmax)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(23), ..ProptestConfig::default() })]

    /// Coherent (narrow cones from one point or a small patch) and
    /// incoherent packets (wide cones: inverse directions of both signs),
    /// of every size up to a full one.
    #[test]
    fn packets_answer_as_single_rays(
        seed in 0u64..1000,
        n in 1usize..=PACKET,
        (ox, oy, oz) in (-5.0f64..15.0, -5.0f64..15.0, -5.0f64..15.0),
        (dx, dy, dz) in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        spread in prop_oneof![Just(0.0), 0.0f64..0.5],
        cone in prop_oneof![0.0f64..0.05, 0.05f64..2.0],
    ) {
        let d = Vec3::new(dx, dy, dz);
        prop_assume!(d.length() > 1e-3);
        let objects = scene(seed % 7, 400, 1.0);
        let bvh = Bvh::build(&objects);
        let rays = packet(seed, n, Vec3::new(ox, oy, oz), d, spread, cone);
        check(&bvh, &objects, &rays)?;
    }
}

/// Rays along the axes (zero direction components: infinite inverses,
/// the interval test leaves those axes out) mixed with oblique ones, and
/// origins exactly on the planes of objects' boxes.
#[test]
fn axis_rays_and_origins_on_box_planes() {
    // A grid of axis-aligned unit squares: every box face is on a plane
    // the rays start on or run along.
    let mut objects = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            let (x, y) = (i as f64, j as f64);
            for z in [0.0, 2.0, 4.0] {
                objects.push(obj(Shape::polygon(vec![
                    Vec3::new(x, y, z),
                    Vec3::new(x + 1.0, y, z),
                    Vec3::new(x + 1.0, y + 1.0, z),
                    Vec3::new(x, y + 1.0, z),
                ])
                .unwrap()));
            }
        }
    }
    let bvh = Bvh::build(&objects);
    let mut rays = Vec::new();
    for k in 0..PACKET {
        let (x, y) = ((k % 8) as f64 * 0.75, (k / 8) as f64 * 0.75);
        let dir = match k % 4 {
            0 => Vec3::Z,
            1 => Vec3::new(0.0, 1e-300, 1.0),
            2 => Vec3::new(0.3, 0.0, 1.0),
            _ => Vec3::new(-0.2, 0.1, 1.0),
        };
        // On a grid line (x, y integers) or inside a square, on the plane
        // z = 0 of the lowest squares.
        rays.push((Ray::new(Vec3::new(x, y, 0.0), dir), 0.0, f64::INFINITY));
    }
    check(&bvh, &objects, &rays).unwrap();
    // Along a plane of squares (grazing: zero z direction), from the side.
    let grazing: Vec<Segment> = (0..PACKET)
        .map(|k| {
            let o = Vec3::new(
                -1.0,
                0.1 * k as f64,
                2.0 + if k % 2 == 0 { 0.0 } else { 1e-12 },
            );
            let d = Vec3::new(1.0, (k % 5) as f64 * 0.01, 0.0);
            (Ray::new(o, d), 0.0, f64::INFINITY)
        })
        .collect();
    check(&bvh, &objects, &grazing).unwrap();
    // Every ray the same (a packet of one ray 64 times), and one ray.
    let same = vec![rays[2]; PACKET];
    check(&bvh, &objects, &same).unwrap();
    check(&bvh, &objects, &rays[..1]).unwrap();
    check(&bvh, &objects, &[]).unwrap();
}

/// The same scene and rays at every scale from 1e-5 to 1e5: the interval
/// test stays conservative in the rounded arithmetic.
#[test]
fn packets_at_every_scale() {
    for e in -5..=5 {
        let s = 10f64.powi(e);
        let objects = scene(3, 300, s);
        let bvh = Bvh::build(&objects);
        for (k, cone) in [0.01, 0.3, 2.0].into_iter().enumerate() {
            let rays = packet(
                (e + 5) as u64 * 10 + k as u64,
                PACKET,
                Vec3::new(-2.0, 4.0, 5.0) * s,
                Vec3::new(1.0, 0.1, 0.05),
                0.01 * s,
                cone,
            );
            // Segments scaled with the scene.
            let rays: Vec<Segment> = rays
                .into_iter()
                .map(|(r, t0, t1)| (r, t0 * s, t1 * s))
                .collect();
            check(&bvh, &objects, &rays).unwrap();
        }
    }
}

/// An empty hierarchy misses everything.
#[test]
fn empty_hierarchy_misses() {
    let bvh = Bvh::build(&[]);
    let rays = packet(1, 10, Vec3::ZERO, Vec3::X, 0.0, 0.1);
    check(&bvh, &[], &rays).unwrap();
}
