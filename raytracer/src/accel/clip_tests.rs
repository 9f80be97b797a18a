//! Tests of pyramid clipping: conservativeness of the clip against the
//! octree's own traversal, front-to-back order, selectivity, degenerate
//! bundles.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

use super::*;
use crate::geometry::{Object, Ray, Shape, Vec3};
use crate::testdata::{lcg, obj, random_scene, v};

/// Small spheres at the centres of an `n`^3 grid of unit cells.
fn grid_scene(n: usize) -> Vec<Object> {
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let c = v(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
                out.push(obj(Shape::sphere(c, 0.2, false).unwrap()));
            }
        }
    }
    out
}

/// Checks that every bundle ray's leaves and hit are selected, and that
/// (for `check_order`) the leaves along each ray appear in the clip order in
/// the order the ray meets them.
fn check_conservative(
    tree: &Octree,
    objects: &[Object],
    pyr: &Pyramid,
    dirs: &[Vec3],
    check_order: bool,
) -> Result<(), String> {
    let res = tree.clip(pyr);
    let pos: std::collections::HashMap<NodeId, usize> = res
        .leaves
        .iter()
        .enumerate()
        .map(|(i, &l)| (l, i))
        .collect();
    let objs: std::collections::HashSet<u32> = res.objects.iter().copied().collect();
    if pos.len() != res.leaves.len() || objs.len() != res.objects.len() {
        return Err("duplicates in the clip result".into());
    }
    for &d in dirs {
        let ray = Ray::new(pyr.apex(), d);
        let (tmin, tmax) = (pyr.near(), pyr.far());
        if let Some(h) = tree.intersect(objects, &ray, tmin, tmax) {
            if !objs.contains(&h.object) {
                return Err(format!("hit object {} not selected (dir {d})", h.object));
            }
        }
        let mut last = None;
        for span in tree.leaves_along_ray(&ray, tmin, tmax) {
            let Some(&p) = pos.get(&span.leaf) else {
                return Err(format!("leaf {} along dir {d} not selected", span.leaf));
            };
            // Zero-length spans (edges, corners) have no definite order.
            if check_order && span.t_exit - span.t_enter > 1e-9 {
                if last.is_some_and(|l| p < l) {
                    return Err(format!("leaf {} out of order along dir {d}", span.leaf));
                }
                last = Some(p);
            }
        }
    }
    Ok(())
}

/// A random unit vector.
fn unit(rnd: &mut impl FnMut() -> f64) -> Vec3 {
    loop {
        let p = v(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0);
        let l = p.length();
        if l > 0.1 && l <= 1.0 {
            return p / l;
        }
    }
}

/// `n` random directions within `half_angle` of `axis`.
fn cone_dirs(rnd: &mut impl FnMut() -> f64, axis: Vec3, half_angle: f64, n: usize) -> Vec<Vec3> {
    let (t, b) = crate::geometry::robust::orthonormal_basis(axis);
    (0..n)
        .map(|_| {
            let th = half_angle * rnd().sqrt();
            let ph = std::f64::consts::TAU * rnd();
            (axis * th.cos() + (t * ph.cos() + b * ph.sin()) * th.sin()).normalize()
        })
        .collect()
}

#[test]
fn clip_is_conservative_on_random_scenes() {
    for (seed, n, max_objects) in [(11u64, 300usize, 4usize), (12, 200, 6)] {
        let objects = random_scene(seed, n, 10.0);
        let tree = Octree::build(
            &objects,
            &OctreeParams {
                max_objects,
                ..OctreeParams::default()
            },
        );
        let mut runner = TestRunner::new(Config {
            cases: 24,
            rng_seed: RngSeed::Fixed(seed),
            failure_persistence: None,
            ..Config::default()
        });
        let strat = (
            (-5.0..15.0f64, -5.0..15.0f64, -5.0..15.0f64),
            any::<u64>(),
            4usize..64,
            0.001..0.6f64,
            prop::option::of(1.0..20.0f64),
        );
        runner
            .run(&strat, |((x, y, z), s, nrays, half, far)| {
                let apex = v(x, y, z);
                let mut rnd = lcg(s);
                // Aim roughly at the scene so that rays hit things.
                let aim = (v(5.0, 5.0, 5.0) + unit(&mut rnd) * 4.0 - apex).normalize();
                let dirs = cone_dirs(&mut rnd, aim, half, nrays);
                let mut pyr = Pyramid::from_rays(apex, &dirs);
                if let Some(f) = far {
                    pyr = pyr.with_far(f);
                }
                check_conservative(&tree, &objects, &pyr, &dirs, true)
                    .map_err(TestCaseError::fail)?;
                // The same bundle given as targets at random distances.
                let targets: Vec<Vec3> = dirs.iter().map(|&d| apex + d * (0.5 + rnd())).collect();
                let pyr = Pyramid::from_apex_and_targets(apex, &targets);
                check_conservative(&tree, &objects, &pyr, &dirs, true)
                    .map_err(TestCaseError::fail)?;
                let pyr = Pyramid::to_targets(apex, &targets);
                for (&d, &t) in dirs.iter().zip(&targets) {
                    // Each segment individually, ending at its target.
                    let single = pyr.clone().with_far((t - apex).length());
                    check_conservative(&tree, &objects, &single, &[d], false)
                        .map_err(TestCaseError::fail)?;
                }
                Ok(())
            })
            .unwrap();
    }
}

#[test]
fn degenerate_bundles_stay_conservative() {
    let objects = random_scene(5, 300, 8.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let rb = tree.root_bounds();
    let centre = rb.center();
    let axes = [
        Vec3::X,
        -Vec3::X,
        Vec3::Y,
        -Vec3::Y,
        Vec3::Z,
        -Vec3::Z,
        v(1.0, 1.0, 0.0).normalize(),
        v(1.0, -1.0, 1.0).normalize(),
    ];
    // Apexes on cell boundaries: the root centre, a face centre of the root
    // (outside the scene box), a corner of a child cell, and a leaf corner.
    let leaf = tree.find_leaf(v(2.1, 3.3, 4.7)).unwrap();
    let apexes = [
        centre,
        v(rb.min.x, centre.y, centre.z),
        rb.min + (rb.max - rb.min) * 0.25,
        tree.node_bounds(leaf).min,
    ];
    for &apex in &apexes {
        for &a in &axes {
            // One ray; several identical rays; a tiny axis-parallel cross.
            let cross = [
                a,
                a + Vec3::X * 1e-12,
                a - Vec3::Y * 1e-12,
                a + Vec3::Z * 1e-12,
            ];
            let bundles: [&[Vec3]; 3] = [&[a], &[a, a, a, a], &cross];
            for dirs in bundles {
                for far in [f64::INFINITY, 3.0] {
                    let pyr = Pyramid::from_rays(apex, dirs).with_far(far);
                    check_conservative(&tree, &objects, &pyr, dirs, false)
                        .unwrap_or_else(|e| panic!("apex {apex} axis {a} far {far}: {e}"));
                }
            }
        }
    }
    // Rays in all directions (no side planes): everything is selected.
    let all: Vec<Vec3> = axes.iter().flat_map(|&a| [a, -a]).collect();
    let pyr = Pyramid::from_rays(centre, &all);
    assert!(pyr.planes().is_empty());
    let res = tree.clip(&pyr);
    assert_eq!(res.leaves.len(), tree.leaves().count());
    // No usable direction: nothing constrains, nothing is lost.
    let pyr = Pyramid::from_rays(centre, &[Vec3::ZERO]);
    assert_eq!(tree.clip(&pyr).leaves.len(), tree.leaves().count());
    // The empty tree selects nothing.
    let res = Octree::default().clip(&Pyramid::from_rays(centre, &[Vec3::X]));
    assert!(res.leaves.is_empty() && res.objects.is_empty());
}

#[test]
fn narrow_pyramid_is_selective() {
    let objects = random_scene(7, 400, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let apex = v(5.0, 5.0, -10.0);
    // A 4-ray tile bundle 0.5 units wide at distance 10 (the scene's near face).
    let targets: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .iter()
        .map(|&(x, y)| v(5.0 + 0.25 * x, 5.0 + 0.25 * y, 0.0))
        .collect();
    let pyr = Pyramid::from_apex_and_targets(apex, &targets);
    let res = tree.clip(&pyr);
    let leaves = tree.leaves().count();
    eprintln!(
        "narrow tile: {} of {} objects, {} of {} leaves, {} node visits of {}",
        res.objects.len(),
        objects.len(),
        res.leaves.len(),
        leaves,
        res.node_visits,
        tree.node_count()
    );
    assert!(
        res.objects.len() * 5 < objects.len(),
        "{}",
        res.objects.len()
    );
    assert!(res.leaves.len() * 10 < leaves);
    assert!((res.node_visits as usize) < tree.node_count() / 2);
    // A shadow bundle ending half way selects fewer still.
    let short = tree.clip(&pyr.clone().with_far(15.0));
    assert!(short.objects.len() < res.objects.len());
    assert!(short.objects.iter().all(|o| res.objects.contains(o)));
    // A wide bundle selects more.
    let wide: Vec<Vec3> = targets
        .iter()
        .map(|&t| v(5.0, 5.0, 0.0) + (t - v(5.0, 5.0, 0.0)) * 16.0)
        .collect();
    let wide = tree.clip(&Pyramid::from_apex_and_targets(apex, &wide));
    assert!(wide.objects.len() > 2 * res.objects.len());
}

#[test]
fn grid_leaves_come_front_to_back() {
    let n = 8;
    let objects = grid_scene(n);
    let tree = Octree::build(
        &objects,
        &OctreeParams {
            max_objects: 1,
            ..OctreeParams::default()
        },
    );
    let rb = tree.root_bounds();
    let deepest = tree.leaves().map(|l| tree.depth(l)).max().unwrap();
    let cell = (rb.max.x - rb.min.x) / (1u64 << deepest) as f64;
    let mut rnd = lcg(3);
    for (axis, k) in [(Vec3::X, 0usize), (-Vec3::Y, 1), (Vec3::Z, 2)] {
        for _ in 0..5 {
            // A tube through the centre of a column of finest cells.
            let mut apex = rb.min + Vec3::splat(cell) * 0.5;
            for a in 0..3 {
                if a != k {
                    apex[a] += cell * (rnd() * (1u64 << deepest) as f64).floor();
                }
            }
            apex[k] = if axis[k] > 0.0 {
                rb.min[k] - 5.0
            } else {
                rb.max[k] + 5.0
            };
            let dirs = cone_dirs(&mut rnd, axis, 1e-3, 8);
            let pyr = Pyramid::from_rays(apex, &dirs);
            let res = tree.clip(&pyr);
            assert!(res.leaves.len() >= 2);
            let entry: Vec<f64> = res
                .leaves
                .iter()
                .map(|&l| {
                    let b = tree.node_bounds(l);
                    let near = if axis[k] > 0.0 { b.min } else { b.max };
                    (near - apex).dot(axis)
                })
                .collect();
            assert!(
                entry.windows(2).all(|w| w[1] >= w[0] - 1e-9),
                "axis {axis}: {entry:?}"
            );
            check_conservative(&tree, &objects, &pyr, &dirs, true).unwrap();
        }
    }
}

proptest! {
    #![proptest_config(Config { cases: 200, rng_seed: RngSeed::Fixed(0x4a11), ..Config::default() })]

    /// The hull of two boxes holds every segment from a point of one to a
    /// point of the other, at any scale and offset, and its clip selects
    /// every leaf such a segment passes through.
    #[test]
    fn hull_of_two_boxes_holds_every_segment_between_them(
        a in prop::array::uniform3(-1.0f64..1.0),
        ea in prop::array::uniform3(1e-3f64..1.0),
        b in prop::array::uniform3(-1.0f64..1.0),
        eb in prop::array::uniform3(0.0f64..1.0),
        scale_exp in -6i32..7,
        seed in 0u64..1000,
    ) {
        let s = 10f64.powi(scale_exp);
        let off = Vec3::splat(3.0 * s);
        let ba = crate::geometry::Aabb::new(Vec3::from(a) * s + off, (Vec3::from(a) + Vec3::from(ea)) * s + off);
        let bb = crate::geometry::Aabb::new(Vec3::from(b) * 2.0 * s + off, (Vec3::from(b) * 2.0 + Vec3::from(eb)) * s + off);
        let pts: Vec<Vec3> = ba.corners().into_iter().chain(bb.corners()).collect();
        let hull = Pyramid::hull(&pts, ba.center()).expect("two boxes, one with volume, span a volume");
        let mut rnd = lcg(seed);
        let tol = 1e-9 * s;
        for _ in 0..64 {
            let p = ba.min + (ba.max - ba.min) * v(rnd(), rnd(), rnd());
            let q = bb.min + (bb.max - bb.min) * v(rnd(), rnd(), rnd());
            for k in 0..=8 {
                let x = p + (q - p) * (k as f64 / 8.0);
                prop_assert!(hull.contains(x, tol), "{x:?} on a segment lies outside the hull");
            }
        }
    }
}

#[test]
fn hull_clip_selects_every_leaf_a_cell_to_light_ray_crosses() {
    let objects = random_scene(7, 300, 10.0);
    let octree = Octree::build(&objects, &OctreeParams::default());
    let light = crate::geometry::Aabb::new(v(4.0, 9.5, 4.0), v(6.0, 9.6, 6.0));
    let mut rnd = lcg(99);
    let leaves: Vec<NodeId> = octree
        .leaves()
        .filter(|&l| !octree.leaf_objects(l).is_empty())
        .collect();
    for &cell in leaves.iter().step_by(7) {
        let cb = octree.node_bounds(cell);
        let pts: Vec<Vec3> = cb.corners().into_iter().chain(light.corners()).collect();
        let hull = Pyramid::hull(&pts, cb.center()).unwrap();
        let mut selected = std::collections::HashSet::new();
        octree.clip_leaves(&hull, |l| {
            selected.insert(l);
        });
        for _ in 0..16 {
            let p = cb.min + (cb.max - cb.min) * v(rnd(), rnd(), rnd());
            let q = light.min + (light.max - light.min) * v(rnd(), rnd(), rnd());
            let ray = Ray {
                origin: p,
                dir: (q - p).normalize(),
            };
            octree.for_each_leaf_along_ray(&ray, 0.0, (q - p).length(), |l, _, _| {
                assert!(
                    selected.contains(&l),
                    "leaf {l} on a cell-to-light ray was not selected"
                );
                false
            });
        }
    }
    // Flat input spans no volume.
    assert!(Pyramid::hull(
        &[
            v(0.0, 0.0, 0.0),
            v(1.0, 0.0, 0.0),
            v(0.0, 1.0, 0.0),
            v(1.0, 1.0, 0.0)
        ],
        Vec3::ZERO
    )
    .is_none());
}
