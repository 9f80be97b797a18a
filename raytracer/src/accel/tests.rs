//! Octree tests: structure invariants, traversal equal to brute force on
//! random scenes and on rays exactly along cell faces, edges and corners,
//! scale invariance, instances, and the leaf sequence along a ray.

use std::sync::Arc;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

use super::*;
use crate::geometry::{InstanceGeometry, ObjectTable, Ray, Shape, Transform, Vec3};
use crate::scene::{Material, Object, Scene};

pub(super) fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}

pub(super) fn obj(shape: Shape) -> Object {
    Object {
        name: String::new(),
        shape,
        material: 0,
    }
}

pub(super) fn cube(lo: Vec3, hi: Vec3) -> Vec<Object> {
    let c = |i: usize| {
        v(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
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
        .map(|f| obj(Shape::polygon(f.iter().map(|&i| c(i)).collect()).unwrap()))
        .collect()
}

/// A deterministic pseudo-random scene of `n` objects of all kinds in a box of size `size`.
pub(super) fn random_scene(seed: u64, n: usize, size: f64) -> Vec<Object> {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let mut out = Vec::new();
    while out.len() < n {
        let c = v(rnd(), rnd(), rnd()) * size;
        let r = (0.005 + 0.05 * rnd() * rnd()) * size;
        let k = (rnd() * 10.0) as u32;
        let shape = match k {
            0..=4 => {
                let a = c + v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * r * 4.0;
                let b = c + v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * r * 4.0;
                let d = c + v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * r * 4.0;
                Shape::polygon(vec![a, b, d])
            }
            5 => {
                // Quad in a random plane.
                let n = v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                let (t, b) = crate::geometry::robust::orthonormal_basis(n.normalize());
                Shape::polygon(vec![
                    c - t * r - b * r,
                    c + t * r - b * r,
                    c + t * r + b * r,
                    c - t * r + b * r,
                ])
            }
            6 | 7 => Shape::sphere(c, r, rnd() < 0.2),
            8 => Shape::cone(
                c,
                c + v(rnd() - 0.5, rnd() - 0.5, rnd()) * r * 4.0,
                r * rnd(),
                r * rnd(),
                false,
            ),
            _ => Shape::ring(
                c,
                v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5),
                r * 0.3 * rnd(),
                r,
            ),
        };
        if let Ok(shape) = shape {
            out.push(obj(shape));
        }
    }
    // A few big objects spanning many cells.
    out.push(obj(Shape::polygon(vec![
        v(0.0, 0.0, 0.0),
        v(size, 0.0, 0.0),
        v(size, size, 0.0),
        v(0.0, size, 0.0),
    ])
    .unwrap()));
    out.push(obj(Shape::sphere(
        v(0.5, 0.5, 0.5) * size,
        0.3 * size,
        false,
    )
    .unwrap()));
    out
}

fn check_structure(tree: &Octree, objects: &[Object]) {
    let st = tree.stats();
    assert_eq!(st.leaf_nodes + st.internal_nodes, tree.node_count());
    assert_eq!(tree.node_count(), 1 + 8 * st.internal_nodes);
    let subtree_refs = tree.subtree_refs();
    assert_eq!(subtree_refs[0], st.object_refs as u64);
    let root = tree.root_bounds();
    for (i, o) in objects.iter().enumerate() {
        let b = o.shape.bounds();
        assert!(root.union(b) == root, "object {i} outside the root cube");
    }
    let mut refs = 0;
    let mut empty = 0;
    for id in 0..tree.node_count() as u32 {
        match tree.node(id) {
            NodeView::Internal { children } => {
                let mut sum = 0;
                for c in children {
                    assert_eq!(tree.parent(c), Some(id));
                    assert_eq!(tree.depth(c), tree.depth(id) + 1);
                    let cb = tree.node_bounds(c);
                    let pb = tree.node_bounds(id);
                    let tol = 1e-12 * (pb.magnitude() + pb.extent().x);
                    assert!(cb.min.cmpge(pb.min - tol).all() && cb.max.cmple(pb.max + tol).all());
                    assert!(
                        (cb.extent() * 2.0 - pb.extent()).length() <= 1e-12 * pb.extent().length()
                    );
                    sum += subtree_refs[c as usize];
                }
                assert_eq!(sum, subtree_refs[id as usize]);
                assert!(tree.leaf_objects(id).is_empty());
            }
            NodeView::Leaf { objects: list } => {
                assert!(
                    list.windows(2).all(|w| w[0] < w[1]),
                    "leaf list not ascending"
                );
                refs += list.len();
                if list.is_empty() {
                    empty += 1;
                }
                // Every listed object comes near the cell.
                let m = tree.margin();
                let cb = tree.node_bounds(id);
                let cb = crate::geometry::Aabb::new(cb.min - m, cb.max + m);
                for &o in list {
                    assert!(objects[o as usize].shape.bounds().overlaps(&cb));
                }
            }
        }
    }
    assert_eq!(refs, st.object_refs);
    assert_eq!(empty, st.empty_leaves);
    assert_eq!(tree.parent(0), None);
    assert_eq!(tree.leaves().count(), st.leaf_nodes);
}

/// The octree and the hierarchy answer like the brute-force reference.
fn assert_same(objects: &[Object], tree: &Octree, bvh: &Bvh, ray: &Ray, tmin: f64, tmax: f64) {
    let a = tree.intersect(objects, ray, tmin, tmax);
    let b = intersect_brute_force(objects, ray, tmin, tmax);
    assert_eq!(a, b, "octree vs brute force for {ray:?}");
    assert_eq!(
        bvh.intersect(objects, ray, tmin, tmax),
        b,
        "bvh vs brute force for {ray:?} in [{tmin}, {tmax}]"
    );
    assert_eq!(tree.occluded(objects, ray, tmin, tmax, None), b.is_some());
    assert_eq!(bvh.occluded(objects, ray, tmin, tmax, None), b.is_some());
    if let Some(h) = b {
        // Ignoring the nearest object: occluded iff some other object is hit.
        let others = occluded_brute_force(objects, ray, tmin, tmax, Some(h.object));
        assert_eq!(
            tree.occluded(objects, ray, tmin, tmax, Some(h.object)),
            others
        );
        assert_eq!(
            bvh.occluded(objects, ray, tmin, tmax, Some(h.object)),
            others
        );
    }
}

#[test]
fn build_statistics_and_structure() {
    let objects = random_scene(1, 400, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    check_structure(&tree, &objects);
    let st = tree.stats();
    assert_eq!(st.objects, objects.len());
    assert!(st.internal_nodes > 10 && st.leaf_nodes > 80, "{st:?}");
    assert!(st.object_refs >= objects.len());
    assert!(st.max_depth >= 3 && st.max_depth <= 14);
    // Serialisable like the paper's Table 1.
    let json = serde_json::to_string(st).unwrap();
    assert!(json.contains("\"object_refs\""));
    // Deterministic.
    let again = Octree::build(&objects, &OctreeParams::default());
    assert_eq!(again.stats(), st);
    // Leaf limit respected except where depth or stall stopped the subdivision.
    let p = OctreeParams::default();
    for l in tree.leaves() {
        assert!(tree.leaf_objects(l).len() <= p.max_objects || tree.depth(l) > 0);
    }
    // find_leaf agrees with the cell bounds.
    for o in objects.iter().take(50) {
        let c = o.shape.bounds().center();
        let l = tree.find_leaf(c).unwrap();
        assert!(tree.node_bounds(l).contains(c));
    }
    assert!(tree.memory_bytes() > 0);
}

#[test]
fn empty_and_degenerate_scenes() {
    let empty = Octree::build(&[], &OctreeParams::default());
    assert_eq!(empty.stats().leaf_nodes, 1);
    let r = Ray::new(Vec3::ZERO, Vec3::X);
    assert!(empty.intersect(&[], &r, 0.0, f64::INFINITY).is_none());
    assert!(!empty.occluded(&[], &r, 0.0, f64::INFINITY, None));
    let def = Octree::default();
    assert!(def.root().is_none());
    assert!(def.intersect(&[], &r, 0.0, f64::INFINITY).is_none());
    assert!(def.leaves_along_ray(&r, 0.0, f64::INFINITY).is_empty());
    // A flat scene (all in z = 0) and many coincident objects.
    let mut objs: Vec<Object> = (0..20)
        .map(|_| {
            obj(Shape::polygon(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0)]).unwrap())
        })
        .collect();
    objs.push(obj(Shape::sphere(v(0.5, 0.5, 0.0), 1e-3, false).unwrap()));
    let tree = Octree::build(&objs, &OctreeParams::default());
    let bvh = Bvh::build(&objs);
    check_structure(&tree, &objs);
    // Coincident surfaces stop subdividing (stall rule): the tree stays small.
    assert!(tree.node_count() < 20_000, "{:?}", tree.stats());
    let ray = Ray::new(v(0.7, 0.2, 1.0), -Vec3::Z);
    let h = tree.intersect(&objs, &ray, 0.0, f64::INFINITY).unwrap();
    assert_eq!(h.object, 0, "ties resolve to the smallest id");
    assert_same(&objs, &tree, &bvh, &ray, 0.0, f64::INFINITY);
}

#[test]
fn void_objects_are_geometry() {
    let mut scene = Scene::default();
    scene.materials.push(Material::Void);
    scene.objects.push(Object {
        name: "v".into(),
        shape: Shape::sphere(Vec3::ZERO, 1.0, false).unwrap(),
        material: 0,
    });
    let tree = Octree::build(&scene.objects, &OctreeParams::default());
    let h = tree
        .intersect(
            &scene.objects,
            &Ray::new(v(0.0, 0.0, 5.0), -Vec3::Z),
            0.0,
            f64::INFINITY,
        )
        .unwrap();
    assert_eq!(h.object, 0);
    assert!((h.t - 4.0).abs() < 1e-12);
    assert_eq!(h.point, v(0.0, 0.0, 1.0));
}

#[test]
fn early_out_does_not_stop_at_far_hit_of_earlier_cell() {
    // A big tilted polygon listed in the first cell the ray crosses but hit
    // far away, and a small sphere in a later cell that is nearer than that hit.
    let mut objs = vec![obj(Shape::polygon(vec![
        v(0.0, -10.0, -10.0),
        v(20.0, -10.0, 10.0),
        v(20.0, 10.0, 10.0),
        v(0.0, 10.0, -10.0),
    ])
    .unwrap())];
    // Clutter so the tree subdivides.
    for i in 0..40 {
        let x = i as f64 * 0.5;
        objs.push(obj(Shape::sphere(v(x, 8.0, 8.0), 0.1, false).unwrap()));
    }
    objs.push(obj(Shape::sphere(v(6.0, 0.0, 0.0), 0.5, false).unwrap()));
    let tree = Octree::build(
        &objs,
        &OctreeParams {
            max_objects: 2,
            ..OctreeParams::default()
        },
    );
    let bvh = Bvh::build(&objs);
    let ray = Ray::new(v(0.5, 0.0, 0.0), Vec3::X);
    let h = tree.intersect(&objs, &ray, 0.0, f64::INFINITY).unwrap();
    assert_eq!(h.object, objs.len() as u32 - 1);
    assert!((h.t - 5.0).abs() < 1e-12);
    assert_same(&objs, &tree, &bvh, &ray, 0.0, f64::INFINITY);
}

pub(super) fn arb_dir() -> impl Strategy<Value = Vec3> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 1e-4)
        .prop_map(|(x, y, z)| v(x, y, z).normalize())
}

#[test]
fn octree_equals_brute_force_on_random_scenes() {
    for (seed, n, max_objects) in [
        (2u64, 300usize, 6usize),
        (3, 1000, 6),
        (4, 200, 1),
        (5, 60, 3),
    ] {
        let objects = random_scene(seed, n, 10.0);
        let params = OctreeParams {
            max_objects,
            ..OctreeParams::default()
        };
        let tree = Octree::build(&objects, &params);
        let bvh = Bvh::build(&objects);
        check_structure(&tree, &objects);
        let mut runner = TestRunner::new(Config {
            cases: 400,
            rng_seed: RngSeed::Fixed(seed),
            ..Config::default()
        });
        runner
            .run(
                &(
                    (-2.0f64..12.0, -2.0f64..12.0, -2.0f64..12.0),
                    arb_dir(),
                    0.0f64..1.0,
                ),
                |((x, y, z), d, tm)| {
                    let ray = Ray::new(v(x, y, z), d);
                    assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
                    // Limited segments (shadow rays) too.
                    assert_same(&objects, &tree, &bvh, &ray, 0.0, tm * 8.0);
                    // Rays aimed at an object's sample point.
                    let k = ((x + 2.0) * 1000.0) as usize % objects.len();
                    let (p, _) = objects[k].shape.sample(tm, (y + 2.0) / 14.0);
                    let o = v(x, y, z);
                    if (p - o).length() > 1e-6 {
                        let ray = Ray::new(o, p - o);
                        assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
                        prop_assert!(tree.intersect(&objects, &ray, 0.0, f64::INFINITY).is_some());
                    }
                    Ok(())
                },
            )
            .unwrap();
    }
}

#[test]
fn rays_along_cell_faces_edges_and_corners() {
    // Small cubes and spheres centred exactly on cell boundaries: the root
    // cube is fixed by two tiny "frame" spheres, the objects sit at the
    // planes that split it into 8 x 8 x 8 cells.
    let frame = vec![
        obj(Shape::sphere(v(0.0, 0.0, 0.0), 1e-3, false).unwrap()),
        obj(Shape::sphere(v(8.0, 8.0, 8.0), 1e-3, false).unwrap()),
    ];
    let root = Octree::build(&frame, &OctreeParams::default()).root_bounds();
    let step = root.extent().x / 8.0;
    let g = |k: usize, a: usize| root.min[a] + k as f64 * step;
    let mut objects = frame;
    for i in 1..=7 {
        for j in 1..=7 {
            let (x, y, z) = (g(i, 0), g(j, 1), g(4, 2));
            if (i + j) % 2 == 0 {
                objects.extend(cube(
                    v(x - 0.1, y - 0.1, z - 0.1),
                    v(x + 0.1, y + 0.1, z + 0.1),
                ));
            } else {
                objects.push(obj(Shape::sphere(v(x, y, z), 0.1, false).unwrap()));
            }
        }
    }
    let tree = Octree::build(
        &objects,
        &OctreeParams {
            max_objects: 2,
            ..OctreeParams::default()
        },
    );
    let bvh = Bvh::build(&objects);
    check_structure(&tree, &objects);
    assert_eq!(tree.root_bounds(), root);
    // Collect every distinct cell-boundary coordinate per axis.
    let mut planes: [Vec<f64>; 3] = Default::default();
    for l in tree.leaves() {
        let b = tree.node_bounds(l);
        for (a, p) in planes.iter_mut().enumerate() {
            p.push(b.min[a]);
            p.push(b.max[a]);
        }
    }
    for p in &mut planes {
        p.sort_by(f64::total_cmp);
        p.dedup();
    }
    let mut count = 0;
    let mut hits = 0;
    let root = tree.root_bounds();
    // Axis-parallel rays along cell edges (two coordinates on planes) and
    // through corners, in both directions along each axis.
    for axis in 0..3 {
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        for (iu, &cu) in planes[u].iter().enumerate().step_by(3) {
            for &cw in planes[w].iter().step_by(2) {
                for sign in [1.0, -1.0] {
                    let mut o = Vec3::ZERO;
                    o[axis] = if sign > 0.0 {
                        root.min[axis] - 1.0
                    } else {
                        root.max[axis] + 1.0
                    };
                    o[u] = cu;
                    o[w] = cw;
                    let mut d = Vec3::ZERO;
                    d[axis] = sign;
                    let ray = Ray { origin: o, dir: d };
                    assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
                    // Starting exactly on a cell corner, inside the tree.
                    let mut o2 = o;
                    o2[axis] = planes[axis][iu % planes[axis].len()];
                    let ray2 = Ray { origin: o2, dir: d };
                    assert_same(&objects, &tree, &bvh, &ray2, 0.0, f64::INFINITY);
                    count += 2;
                    hits += tree.intersect(&objects, &ray, 0.0, f64::INFINITY).is_some() as usize;
                }
            }
        }
    }
    // Diagonal rays through cell corners (all three planes at once).
    for (i, &x) in planes[0].iter().enumerate() {
        let y = planes[1][i % planes[1].len()];
        let z = planes[2][(i * 7) % planes[2].len()];
        for d in [
            v(1.0, 1.0, 1.0),
            v(1.0, -1.0, 0.0),
            v(0.0, 1.0, -1.0),
            v(-1.0, -1.0, 1.0),
        ] {
            let ray = Ray::new(v(x, y, z), d);
            assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
            let back = Ray::new(v(x, y, z) - ray.dir * 20.0, d);
            assert_same(&objects, &tree, &bvh, &back, 0.0, f64::INFINITY);
            count += 2;
        }
    }
    // Rays through rows of object centres (exactly along cell faces and edges).
    for j in 1..=7 {
        let ray = Ray {
            origin: v(root.min.x - 1.0, g(j, 1), g(4, 2)),
            dir: Vec3::X,
        };
        assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
        let h = tree
            .intersect(&objects, &ray, 0.0, f64::INFINITY)
            .expect("row of objects");
        assert!((h.point.x - (g(1, 0) - 0.1)).abs() < 1e-12, "{h:?}");
        let ray = Ray {
            origin: v(g(j, 0), g(j, 1), root.max.z + 1.0),
            dir: -Vec3::Z,
        };
        assert_same(&objects, &tree, &bvh, &ray, 0.0, f64::INFINITY);
        assert!(tree.intersect(&objects, &ray, 0.0, f64::INFINITY).is_some());
        count += 2;
    }
    assert!(count > 200 && hits > 10, "{count} rays, {hits} hits");
}

#[test]
fn same_hits_at_all_scales() {
    let base = random_scene(9, 400, 1.0);
    let scaled = |s: f64| -> Vec<Object> {
        base.iter()
            .map(|o| {
                let shape = match &o.shape {
                    Shape::Polygon(p) => {
                        Shape::polygon(p.vertices.iter().map(|x| *x * s).collect()).unwrap()
                    }
                    Shape::Sphere {
                        center,
                        radius,
                        inward,
                    } => Shape::sphere(*center * s, radius * s, *inward).unwrap(),
                    Shape::Cone {
                        p0,
                        p1,
                        r0,
                        r1,
                        inward,
                    } => Shape::cone(*p0 * s, *p1 * s, r0 * s, r1 * s, *inward).unwrap(),
                    Shape::Ring {
                        center,
                        normal,
                        r_inner,
                        r_outer,
                    } => Shape::ring(*center * s, *normal, r_inner * s, r_outer * s).unwrap(),
                    Shape::Instance(_) => unreachable!(),
                };
                obj(shape)
            })
            .collect()
    };
    let scenes: Vec<(f64, Vec<Object>)> =
        [1e-4, 1.0, 1e4].iter().map(|&s| (s, scaled(s))).collect();
    let trees: Vec<Octree> = scenes
        .iter()
        .map(|(_, o)| Octree::build(o, &OctreeParams::default()))
        .collect();
    let bvhs: Vec<Bvh> = scenes.iter().map(|(_, o)| Bvh::build(o)).collect();
    let mut runner = TestRunner::new(Config {
        cases: 500,
        rng_seed: RngSeed::Fixed(99),
        ..Config::default()
    });
    let mut agree = std::cell::Cell::new(0);
    runner
        .run(
            &(
                (-0.2f64..1.2, -0.2f64..1.2, -0.2f64..1.2),
                0usize..400,
                (0.0f64..1.0, 0.0f64..1.0),
            ),
            |(o, k, (u, w))| {
                let o = v(o.0, o.1, o.2);
                let (p, _) = base[k].shape.sample(u, w);
                prop_assume!((p - o).length() > 1e-3);
                let d = (p - o).normalize();
                let hits: Vec<Option<Hit>> = scenes
                    .iter()
                    .zip(&trees)
                    .map(|((s, objs), t)| {
                        t.intersect(
                            objs,
                            &Ray {
                                origin: o * *s,
                                dir: d,
                            },
                            0.0,
                            f64::INFINITY,
                        )
                    })
                    .collect();
                for (((s, objs), t), b) in scenes.iter().zip(&trees).zip(&bvhs) {
                    let ray = Ray {
                        origin: o * *s,
                        dir: d,
                    };
                    let want = t.intersect(objs, &ray, 0.0, f64::INFINITY);
                    prop_assert_eq!(b.intersect(objs, &ray, 0.0, f64::INFINITY), want);
                    if let Some(h) = want {
                        // A shadow ray to just short of the hit, and past it.
                        prop_assert!(!b.occluded(objs, &ray, 0.0, h.t * (1.0 - 1e-9), None));
                        prop_assert!(b.occluded(objs, &ray, 0.0, h.t * (1.0 + 1e-9), None));
                    }
                }
                let h1 = hits[1].expect("aimed at an object");
                for (i, h) in hits.iter().enumerate() {
                    let s = scenes[i].0;
                    let h = h.expect("hit at every scale");
                    prop_assert_eq!(h.object, h1.object, "scale {}", s);
                    prop_assert!(
                        (h.t / s - h1.t).abs() <= 1e-9 * h1.t.max(1e-3),
                        "t {} vs {}",
                        h.t / s,
                        h1.t
                    );
                    prop_assert!((h.normal - h1.normal).length() < 1e-6);
                }
                agree.set(agree.get() + 1);
                Ok(())
            },
        )
        .unwrap();
    assert!(*agree.get_mut() > 300);
}

#[test]
fn leaves_along_ray_are_ordered_and_contiguous() {
    let objects = random_scene(21, 500, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let mut runner = TestRunner::new(Config {
        cases: 200,
        rng_seed: RngSeed::Fixed(21),
        ..Config::default()
    });
    runner
        .run(
            &((-5.0f64..15.0, -5.0f64..15.0, -5.0f64..15.0), arb_dir()),
            |((x, y, z), d)| {
                let ray = Ray::new(v(x, y, z), d);
                let spans = tree.leaves_along_ray(&ray, 0.0, f64::INFINITY);
                let root = tree.root_bounds();
                let clip = root.hit(&ray, Vec3::ONE / d, 0.0, f64::INFINITY);
                if spans.is_empty() {
                    prop_assert!(clip.is_none_or(|(a, b)| b - a < 1e-9));
                    return Ok(());
                }
                let (a, b) = clip.unwrap();
                prop_assert!((spans[0].t_enter - a).abs() < 1e-9);
                prop_assert!((spans.last().unwrap().t_exit - b).abs() < 1e-9);
                for w in spans.windows(2) {
                    prop_assert_eq!(w[0].t_exit, w[1].t_enter);
                }
                for s in &spans {
                    prop_assert!(tree.is_leaf(s.leaf));
                    prop_assert!(s.t_enter <= s.t_exit);
                    let mid = ray.at(0.5 * (s.t_enter + s.t_exit));
                    let cb = tree.node_bounds(s.leaf);
                    let m = 1e-9 * root.extent().x;
                    let cb = crate::geometry::Aabb::new(cb.min - m, cb.max + m);
                    prop_assert!(cb.contains(mid), "midpoint of span outside its leaf");
                }
                // The leaf containing the nearest hit is on the list before or at the exit.
                if let Some(h) = tree.intersect(&objects, &ray, 0.0, f64::INFINITY) {
                    let l = tree.find_leaf(h.point).unwrap();
                    let near = spans
                        .iter()
                        .any(|s| s.leaf == l || (s.t_enter <= h.t && h.t <= s.t_exit));
                    prop_assert!(near);
                    let listed = tree.leaf_objects(l).contains(&h.object)
                        || spans.iter().any(|s| {
                            s.t_enter <= h.t
                                && h.t <= s.t_exit
                                && tree.leaf_objects(s.leaf).contains(&h.object)
                        });
                    prop_assert!(listed);
                }
                Ok(())
            },
        )
        .unwrap();
}

#[test]
fn instances_in_the_octree() {
    // A "chair" (a few shapes) instanced on a grid, against the same geometry
    // placed explicitly.
    let chair = vec![
        obj(Shape::polygon(vec![
            v(0.0, 0.0, 0.5),
            v(1.0, 0.0, 0.5),
            v(1.0, 1.0, 0.5),
            v(0.0, 1.0, 0.5),
        ])
        .unwrap()),
        obj(Shape::polygon(vec![
            v(0.0, 1.0, 0.5),
            v(1.0, 1.0, 0.5),
            v(1.0, 1.0, 1.5),
            v(0.0, 1.0, 1.5),
        ])
        .unwrap()),
        obj(Shape::cone(v(0.1, 0.1, 0.0), v(0.1, 0.1, 0.5), 0.05, 0.05, false).unwrap()),
        obj(Shape::cone(v(0.9, 0.1, 0.0), v(0.9, 0.1, 0.5), 0.05, 0.05, false).unwrap()),
        obj(Shape::sphere(v(0.5, 0.5, 0.8), 0.2, false).unwrap()),
    ];
    let geo = Arc::new(InstanceGeometry::new("chair", chair.clone()));
    let mut inst_objs = Vec::new();
    let mut explicit = Vec::new();
    let mut owner = Vec::new();
    for i in 0..6 {
        for j in 0..6 {
            let t = Transform::identity()
                .rotate_z(37.0 * (i * 6 + j) as f64)
                .scale(0.5 + 0.1 * i as f64)
                .unwrap()
                .translate(v(i as f64 * 2.0, j as f64 * 2.0, 0.0));
            let t = if (i + j) % 3 == 0 { t.mirror_y() } else { t };
            inst_objs.push(obj(Shape::instance(geo.clone(), t).unwrap()));
            for (k, o) in chair.iter().enumerate() {
                let s = match &o.shape {
                    Shape::Polygon(p) => {
                        let mut vs: Vec<Vec3> = p.vertices.iter().map(|x| t.point(*x)).collect();
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
                    _ => unreachable!(),
                };
                explicit.push(obj(s));
                owner.push(((i * 6 + j) as u32, k as u32));
            }
        }
    }
    let t_inst = Octree::build(&inst_objs, &OctreeParams::default());
    let t_expl = Octree::build(&explicit, &OctreeParams::default());
    check_structure(&t_inst, &inst_objs);
    let mut runner = TestRunner::new(Config {
        cases: 500,
        rng_seed: RngSeed::Fixed(3),
        ..Config::default()
    });
    let hits = std::cell::Cell::new(0);
    runner
        .run(
            &(
                (-2.0f64..13.0, -2.0f64..13.0, 0.0f64..4.0),
                0usize..1_000_000,
                (0.0f64..1.0, 0.0f64..1.0),
            ),
            |((x, y, z), k, (u, w))| {
                // Aimed at a surface point of a random part.
                let (p, _) = explicit[k % explicit.len()].shape.sample(u, w);
                let o = v(x, y, z);
                prop_assume!((p - o).length() > 1e-6);
                let ray = Ray::new(o, p - o);
                let a = t_inst.intersect(&inst_objs, &ray, 0.0, f64::INFINITY);
                let b = t_expl.intersect(&explicit, &ray, 0.0, f64::INFINITY);
                prop_assert_eq!(a.is_some(), b.is_some(), "{:?} vs {:?}", a, b);
                if let (Some(a), Some(b)) = (a, b) {
                    hits.set(hits.get() + 1);
                    prop_assert_eq!((a.object, a.inner.unwrap()), owner[b.object as usize]);
                    prop_assert!(
                        (a.t - b.t).abs() <= 1e-9 * b.t.max(1.0),
                        "t {} vs {}",
                        a.t,
                        b.t
                    );
                    prop_assert!((a.point - b.point).length() <= 1e-9 * (1.0 + b.point.length()));
                    prop_assert!((a.normal - b.normal).length() < 1e-6);
                    prop_assert_eq!(
                        a,
                        intersect_brute_force(&inst_objs, &ray, 0.0, f64::INFINITY).unwrap()
                    );
                    // Shadow ray to just before the hit: not occluded; past it: occluded.
                    prop_assert!(!t_inst.occluded(&inst_objs, &ray, 0.0, a.t * (1.0 - 1e-9), None));
                    prop_assert!(t_inst.occluded(&inst_objs, &ray, 0.0, a.t * (1.0 + 1e-9), None));
                }
                Ok(())
            },
        )
        .unwrap();
    assert!(hits.get() > 400, "{} hits", hits.get());
}

/// Runs a resumable query the way a migrating ray does: at "place"
/// `home(leaf) = hash(leaf) % places`, moving to the home of each leaf it
/// is blocked on, until it is answered. Returns the answer and the number
/// of migrations.
fn migrate<T>(
    places: u32,
    salt: u32,
    mut step: impl FnMut(&mut TraceCursor, &dyn Fn(NodeId) -> bool) -> Partial<T>,
) -> (T, u32) {
    let home = move |leaf: NodeId| leaf.wrapping_mul(2654435761).wrapping_add(salt) % places;
    let mut here = 0u32;
    let mut cursor = TraceCursor::default();
    let mut hops = 0;
    loop {
        let local = move |leaf: NodeId| home(leaf) == here;
        match step(&mut cursor, &local) {
            Partial::Done(t) => return (t, hops),
            Partial::Blocked(leaf) => {
                assert_ne!(home(leaf), here, "blocked on a local leaf");
                here = home(leaf);
                hops += 1;
                assert!(hops < 100_000, "no progress");
            }
        }
    }
}

#[test]
fn resumable_traversal_equals_intersect_and_occluded_wherever_it_stops() {
    let mut total_hops = 0;
    for (seed, n, max_objects) in [(7u64, 400usize, 4usize), (8, 120, 1)] {
        let objects = random_scene(seed, n, 10.0);
        let params = OctreeParams {
            max_objects,
            ..OctreeParams::default()
        };
        let tree = Octree::build(&objects, &params);
        // Each leaf's objects as a processor receives them: copied, sent
        // (serialized) and rebuilt.
        let mut copies = ObjectCopies::default();
        let cells: std::collections::HashMap<NodeId, LeafObjects> = tree
            .leaves()
            .map(|l| {
                let sent = postcard::to_allocvec(&LeafObjects::copy_from(
                    tree.leaf_objects(l),
                    &objects,
                    &mut copies,
                ))
                .unwrap();
                (l, postcard::from_bytes(&sent).unwrap())
            })
            .collect();
        let cell = |local: &dyn Fn(NodeId) -> bool, l: NodeId| local(l).then(|| &cells[&l]);
        let mut runner = TestRunner::new(Config {
            cases: 300,
            rng_seed: RngSeed::Fixed(seed),
            ..Config::default()
        });
        let hops = std::cell::Cell::new(0u32);
        runner
            .run(
                &(
                    (-2.0f64..12.0, -2.0f64..12.0, -2.0f64..12.0),
                    arb_dir(),
                    0.0f64..1.0,
                    1u32..6,
                    any::<u32>(),
                ),
                |((x, y, z), d, tm, procs, salt)| {
                    let ray = Ray::new(v(x, y, z), d);
                    for tmax in [f64::INFINITY, tm * 8.0] {
                        let want = tree.intersect(&objects, &ray, 0.0, tmax);
                        let (got, h) = migrate(procs, salt, |c, local| {
                            tree.intersect_partial(
                                ObjectTable::dense(&objects),
                                &ray,
                                0.0,
                                tmax,
                                c,
                                |l| cell(local, l),
                            )
                        });
                        prop_assert_eq!(got, want);
                        hops.set(hops.get() + h);
                        let ignore = want.map(|h| h.object);
                        let want = tree.occluded(&objects, &ray, 0.0, tmax, ignore);
                        let (got, _) = migrate(procs, salt, |c, local| {
                            tree.occluded_partial(
                                ObjectTable::dense(&objects),
                                &ray,
                                0.0,
                                tmax,
                                ignore,
                                c,
                                |l| cell(local, l),
                            )
                        });
                        prop_assert_eq!(got, want);
                    }
                    Ok(())
                },
            )
            .unwrap();
        total_hops += hops.get();
    }
    assert!(total_hops > 100, "rays should have migrated: {total_hops}");
}

#[test]
fn bvh_on_empty_single_and_coincident_scenes() {
    let r = Ray::new(v(0.2, 0.3, 5.0), -Vec3::Z);
    let none: &[Object] = &[];
    for bvh in [Bvh::default(), Bvh::build(none)] {
        assert!(bvh.intersect(none, &r, 0.0, f64::INFINITY).is_none());
        assert!(!bvh.occluded(none, &r, 0.0, f64::INFINITY, None));
        assert_eq!(bvh.stats().nodes, 0);
    }
    // One object: a single leaf beside an unused child.
    let one = vec![obj(Shape::sphere(Vec3::ZERO, 1.0, false).unwrap())];
    let bvh = Bvh::build(&one);
    assert_eq!(bvh.stats().leaves, 1);
    assert_eq!(
        bvh.intersect(&one, &r, 0.0, f64::INFINITY),
        intersect_brute_force(&one, &r, 0.0, f64::INFINITY)
    );
    // 300 coincident triangles (no centre spread: split by count) plus a
    // flat sheet of them in one plane, hit on the plane's edge and along it.
    let mut objs: Vec<Object> = (0..300)
        .map(|_| {
            obj(Shape::polygon(vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.0, 1.0, 0.0)]).unwrap())
        })
        .collect();
    for i in 0..50 {
        let x = i as f64;
        objs.push(obj(Shape::polygon(vec![
            v(x, 2.0, 0.0),
            v(x + 1.0, 2.0, 0.0),
            v(x + 1.0, 3.0, 0.0),
        ])
        .unwrap()));
    }
    let tree = Octree::build(&objs, &OctreeParams::default());
    let bvh = Bvh::build(&objs);
    let s = bvh.stats();
    assert_eq!(s.objects, objs.len());
    assert!(s.depth < 96, "{s:?}");
    for ray in [
        Ray::new(v(0.7, 0.2, 1.0), -Vec3::Z),
        Ray::new(v(0.5, 0.5, 1.0), -Vec3::Z),
        Ray::new(v(10.0, 2.0, 1.0), -Vec3::Z),
        Ray::new(v(-1.0, 2.5, 0.0), Vec3::X),
        Ray::new(v(-1.0, 2.0, 0.0), v(1.0, 0.0, 1e-300)),
        Ray::new(v(25.5, 2.5, 1.0), v(1e-9, 0.0, -1.0)),
    ] {
        assert_same(&objs, &tree, &bvh, &ray, 0.0, f64::INFINITY);
        assert_same(&objs, &tree, &bvh, &ray, 0.0, 1.0);
    }
    let h = bvh
        .intersect(
            &objs,
            &Ray::new(v(0.7, 0.2, 1.0), -Vec3::Z),
            0.0,
            f64::INFINITY,
        )
        .unwrap();
    assert_eq!(h.object, 0, "ties resolve to the smallest id");
    assert!(bvh.memory_bytes() > 0);
}

/// A surface of revolution made of coaxial cone bands (Radiance's genrev
/// torus in its glass regression scene): every band's overlap test is its
/// bounding box, so the bands crowd every cell of the region. The build
/// stops at the node budget instead of subdividing 8^14 cells, and rays
/// still find the same surfaces as brute force.
#[test]
fn crowded_cone_bands_build_a_bounded_octree() {
    let n = 32;
    let profile = |t: f64| {
        let a = 2.0 * std::f64::consts::PI * t;
        (0.2 * a.sin(), 0.2 * (2.0 + a.cos()))
    };
    // Tilted as the scene's `xform -ry 52`: the bands' boxes grow.
    let (s52, c52) = 52f64.to_radians().sin_cos();
    let tilt = |z: f64| Vec3::new(z * s52, 0.0, z * c52);
    let objects: Vec<Object> = (0..n)
        .map(|k| {
            let (z0, r0) = profile(k as f64 / n as f64);
            let (z1, r1) = profile((k + 1) as f64 / n as f64);
            obj(Shape::cone(tilt(z0), tilt(z1), r0, r1, false)
                .or_else(|_| Shape::ring(tilt(z0), tilt(1.0), r0.min(r1), r0.max(r1)))
                .unwrap())
        })
        .collect();
    let t = Octree::build(&objects, &OctreeParams::default());
    let s = t.stats();
    assert!(s.leaf_nodes + s.internal_nodes <= 1 << 20, "{s:?}");
    let mut rng = crate::geometry::rng::Rng::new(7);
    for _ in 0..200 {
        let o = Vec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, 1.0) * 2.0;
        let d = (Vec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, -1.0)).normalize();
        let ray = Ray::new(o, d);
        let brute = objects
            .iter()
            .enumerate()
            .filter_map(|(i, ob)| {
                ob.shape
                    .intersect(&ray, 1e-9, f64::INFINITY)
                    .map(|h| (h.t, i))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let hit = t.intersect(&objects, &ray, 1e-9, f64::INFINITY);
        assert_eq!(hit.map(|h| h.t), brute.map(|b| b.0));
    }
}

#[test]
fn leaf_objects_cross_the_wire_bit_for_bit() {
    // Polygons, spheres, cones, rings and an instance (shared, not copied).
    let mut objects = random_scene(11, 300, 10.0);
    let inner = random_scene(12, 20, 1.0);
    let geometry = Arc::new(InstanceGeometry::new("inner", inner));
    let t = Transform::identity().translate(v(5.0, 5.0, 5.0));
    objects.push(obj(Shape::instance(geometry, t).unwrap()));
    let tree = Octree::build(&objects, &OctreeParams::default());
    // A copy made from a reference is the copy of a clone, for every kind.
    for o in objects
        .iter()
        .filter(|o| !matches!(o.shape, Shape::Instance(_)))
    {
        assert_eq!(
            format!("{:?}", HeldObject::of(o)),
            format!("{:?}", HeldObject::new(o.clone())),
            "{}",
            o.name
        );
    }
    let (mut copied, mut shared) = (0, 0);
    let mut copies = ObjectCopies::default();
    for leaf in tree.leaves() {
        let held = LeafObjects::copy_from(tree.leaf_objects(leaf), &objects, &mut copies);
        let bytes = postcard::to_allocvec(&held).unwrap();
        let got: LeafObjects = postcard::from_bytes(&bytes).unwrap();
        assert_eq!(got.ids(), tree.leaf_objects(leaf));
        assert_eq!(got.copies().count(), held.copies().count());
        for (k, &id) in got.ids().iter().enumerate() {
            match (got.own(k), held.own(k)) {
                (Some(a), Some(b)) => {
                    // Debug prints each f64 exactly (shortest round trip):
                    // the shape or vertices, the intersection data, the
                    // name (none for a polygon) and the material.
                    assert_eq!(format!("{a:?}"), format!("{b:?}"), "object {id}");
                    let o = &objects[id as usize];
                    match a.name() {
                        Some(name) => assert_eq!(name, o.name, "object {id}"),
                        None => assert!(matches!(o.shape, Shape::Polygon(_)), "object {id}"),
                    }
                    copied += 1;
                }
                (None, None) => {
                    assert!(matches!(objects[id as usize].shape, Shape::Instance(_)));
                    shared += 1;
                }
                _ => panic!("object {id}: copied on one side only"),
            }
        }
    }
    assert!(
        copied > 300 && shared > 0,
        "{copied} copies, {shared} shared"
    );
    // A processor's leaves share one copy of each object.
    let plain = objects
        .iter()
        .filter(|o| !matches!(o.shape, Shape::Instance(_)))
        .count();
    assert_eq!(copies.len(), plain);
}

#[test]
fn damaged_leaf_data_is_an_error_not_a_panic() {
    let objects = random_scene(13, 40, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let leaf = tree
        .leaves()
        .max_by_key(|&l| tree.leaf_objects(l).len())
        .unwrap();
    let held = LeafObjects::copy_from(
        tree.leaf_objects(leaf),
        &objects,
        &mut ObjectCopies::default(),
    );
    let bytes = postcard::to_allocvec(&held).unwrap();
    // Every truncation and every single-byte change: an error or a leaf,
    // never a panic.
    for n in 0..bytes.len() {
        assert!(postcard::from_bytes::<LeafObjects>(&bytes[..n]).is_err());
    }
    for i in 0..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x5a;
        let _ = postcard::from_bytes::<LeafObjects>(&b);
    }
}

/// An octree rebuilt from a skeleton (a compiled scene's) equals the built
/// one's cells; a skeleton that is not a tree, or deeper than the octree
/// can be, is an error, not a panic or a wrong tree.
#[test]
fn skeletons_that_are_not_octrees_are_errors() {
    use super::SkeletonNode as N;
    let objects = random_scene(9, 60, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let n = tree.node_count();
    let nodes: Vec<N<'_>> = (0..n as NodeId)
        .map(|id| match tree.node(id) {
            NodeView::Internal { children } => N::Internal {
                first_child: children[0],
            },
            NodeView::Leaf { objects } => N::Leaf(objects),
        })
        .collect();
    let root = tree.root_cell();
    let again = Octree::from_skeleton(root, objects.len(), n, |i| Ok(nodes[i])).unwrap();
    for id in 0..n as NodeId {
        assert_eq!(again.node_bounds(id), tree.node_bounds(id), "node {id}");
    }
    // A chain of internal nodes one deeper than the maximum.
    let deep = MAX_DEPTH as usize + 1;
    let chain = |i: usize| {
        Ok(if i == 0 || (i % 8 == 1 && i / 8 < deep) {
            N::Internal {
                first_child: (if i == 0 { 1 } else { i + 8 }) as NodeId,
            }
        } else {
            N::Leaf(&[])
        })
    };
    let err = Octree::from_skeleton(root, 0, 1 + 8 * (deep + 1), chain).unwrap_err();
    assert!(err.contains("deeper"), "{err}");
    // A node reached twice, and one never reached.
    let twice = |i: usize| {
        Ok(match i {
            0 => N::Internal { first_child: 1 },
            1 => N::Internal { first_child: 2 },
            _ => N::Leaf(&[]),
        })
    };
    assert!(Octree::from_skeleton(root, 0, 17, twice).is_err());
    let lost = |i: usize| {
        Ok(match i {
            0 => N::Internal { first_child: 1 },
            _ => N::Leaf(&[]),
        })
    };
    assert!(Octree::from_skeleton(root, 0, 10, lost)
        .unwrap_err()
        .contains("not reached"));
}

/// A polygon's copy keeps its vertices in its pair of triangles where the
/// pair holds them all (triangles and quadrilaterals), else in a list of
/// its own (more vertices, or a vertex the triangulation left out); either
/// way it gives back the source's vertices and bounds bit for bit, and it
/// travels as the source does.
#[test]
fn a_polygon_copy_gives_back_its_vertices_from_its_pair_or_its_own_list() {
    let v = |x: f64, y: f64, z: f64| Vec3::new(x, y, z);
    let shapes = [
        // (vertices, whether the pair holds them)
        (
            vec![v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)],
            true,
        ),
        (
            vec![
                v(-0.0, 0.0, 1e-300),
                v(3.0, 0.0, 0.0),
                v(3.0, 2.0, 0.0),
                v(0.0, 2.0, -0.0),
            ],
            true,
        ),
        // Concave: ear clipping starts elsewhere, the pair still holds all.
        (
            vec![
                v(0.0, 0.0, 5.0),
                v(4.0, 0.0, 5.0),
                v(1.0, 1.0, 5.0),
                v(0.0, 4.0, 5.0),
            ],
            true,
        ),
        // A vertex on an edge, and a reflex corner: their triangles still
        // hold every vertex.
        (
            vec![
                v(0.0, 0.0, 0.0),
                v(1.0, 0.0, 0.0),
                v(2.0, 0.0, 0.0),
                v(0.0, 2.0, 0.0),
            ],
            true,
        ),
        (
            vec![
                v(0.0, 0.0, 0.0),
                v(2.0, 0.0, 0.0),
                v(2.0, 2.0, 0.0),
                v(1.0, 1.0, 0.0),
            ],
            true,
        ),
        // More than two triangles: a list of its own.
        (
            vec![
                v(0.0, 0.0, 0.0),
                v(2.0, 0.0, 0.0),
                v(3.0, 1.0, 0.0),
                v(1.0, 3.0, 0.0),
                v(-1.0, 1.0, 0.0),
            ],
            false,
        ),
    ];
    for (k, (vertices, in_pair)) in shapes.into_iter().enumerate() {
        let o = Object {
            name: format!("p{k}"),
            shape: Shape::polygon(vertices).unwrap(),
            material: 3,
        };
        let Shape::Polygon(p) = &o.shape else {
            unreachable!()
        };
        let copy = HeldObject::new(o.clone());
        // Made from a reference without the clone: the same copy.
        assert_eq!(
            format!("{:?}", HeldObject::of(&o)),
            format!("{copy:?}"),
            "polygon {k}"
        );
        let bits = |vs: &[Vec3]| {
            vs.iter()
                .map(|v| v.to_array().map(f64::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(
            bits(&copy.vertices().unwrap()),
            bits(&p.vertices),
            "polygon {k}"
        );
        let (a, b) = (copy.bounds(), o.shape.bounds());
        assert_eq!(
            (
                a.min.to_array().map(f64::to_bits),
                a.max.to_array().map(f64::to_bits)
            ),
            (
                b.min.to_array().map(f64::to_bits),
                b.max.to_array().map(f64::to_bits)
            ),
            "polygon {k}"
        );
        assert_eq!(
            (copy.name(), copy.material(), copy.surface_at(None)),
            (None, 3, (3, true))
        );
        // Its own list costs its bytes; the pair's corners cost none; no name.
        let own = std::mem::size_of_val(&*p.vertices);
        let held =
            LeafObjects::copy_from(&[0], std::slice::from_ref(&o), &mut ObjectCopies::default());
        let sent: LeafObjects =
            postcard::from_bytes(&postcard::to_allocvec(&held).unwrap()).unwrap();
        assert_eq!(
            format!("{:?}", sent.own(0).unwrap()),
            format!("{copy:?}"),
            "polygon {k}"
        );
        let pair_bytes = copy.prim().memory_bytes();
        let base = std::mem::size_of::<HeldObject>() + pair_bytes;
        assert_eq!(
            copy.bytes(),
            base + if in_pair { 0 } else { own },
            "polygon {k}"
        );
    }
}
