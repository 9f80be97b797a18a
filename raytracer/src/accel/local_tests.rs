//! The processor's own hierarchy ([`LocalKernel`]): wherever it decides a
//! query, its answer is the octree's, and where it does not, the walk
//! that starts from its answer and passes its leaves finishes with the
//! octree's, for random scenes at every scale,
//! random splits of the leaves among processors, and rays exactly along
//! cell faces; and it does decide the queries that stay among its cells.

use std::collections::HashMap;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

use super::tests::{arb_dir, cube, obj, random_scene, v};
use super::*;
use crate::geometry::{ObjectTable, Ray, Shape, Vec3};
use crate::scene::{Object, ObjectId};

/// Leaf `l`'s processor: a hash of its id.
fn home(l: NodeId, places: u32, salt: u32) -> u32 {
    l.wrapping_mul(2654435761).wrapping_add(salt) % places
}

/// One processor of a split: its kernel and who owns what.
struct Place {
    kernel: LocalKernel,
    /// Per node: the one place owning every non-empty leaf below, or
    /// `MIXED`; `EMPTY` for none.
    owner: Vec<u32>,
    me: u32,
    places: u32,
    salt: u32,
}

const EMPTY: u32 = u32::MAX - 1;
const MIXED: u32 = u32::MAX;

impl Place {
    fn new(tree: &Octree, objects: &[Object], places: u32, salt: u32, me: u32) -> Place {
        let mut copies = ObjectCopies::default();
        let cells: Vec<LeafObjects> = tree
            .leaves()
            .filter(|&l| !tree.leaf_objects(l).is_empty() && home(l, places, salt) == me)
            .map(|l| LeafObjects::copy_from(tree.leaf_objects(l), objects, &mut copies))
            .collect();
        let kernel = LocalKernel::build(&cells, ObjectTable::dense(objects));
        let n = tree.node_count();
        let mut owner = vec![EMPTY; n];
        for id in (0..n as NodeId).rev() {
            owner[id as usize] = match tree.children(id) {
                None if tree.leaf_objects(id).is_empty() => EMPTY,
                None => home(id, places, salt),
                Some(ch) => ch
                    .iter()
                    .fold(EMPTY, |acc, &c| match (acc, owner[c as usize]) {
                        (a, EMPTY) => a,
                        (EMPTY, b) => b,
                        (a, b) if a == b => a,
                        _ => MIXED,
                    }),
            };
        }
        Place {
            kernel,
            owner,
            me,
            places,
            salt,
        }
    }

    fn owned(&self, n: NodeId) -> bool {
        let o = self.owner[n as usize];
        o == EMPTY || o == self.me
    }

    fn resident(&self, l: NodeId) -> bool {
        home(l, self.places, self.salt) == self.me
    }
}

/// Every leaf's objects, as copies (the walk reads them as a processor
/// that has fetched them would).
fn all_cells(tree: &Octree, objects: &[Object]) -> HashMap<NodeId, LeafObjects> {
    let mut copies = ObjectCopies::default();
    tree.leaves()
        .filter(|&l| !tree.leaf_objects(l).is_empty())
        .map(|l| {
            (
                l,
                LeafObjects::copy_from(tree.leaf_objects(l), objects, &mut copies),
            )
        })
        .collect()
}

/// Checks every place's decided answers against the octree's, and its
/// undecided ones finished by the walk that passes its leaves
/// ([`Octree::intersect_partial_past`], [`Octree::occluded_partial_past`],
/// every other leaf held as if fetched); returns how many queries were
/// decided and asked.
fn check_ray(
    tree: &Octree,
    objects: &[Object],
    cells: &HashMap<NodeId, LeafObjects>,
    places: &[Place],
    ray: &Ray,
    tmax: f64,
) -> Result<(u32, u32), TestCaseError> {
    let want = tree.intersect(objects, ray, 0.0, tmax);
    let ignore = want.map(|h| h.object);
    let blocked = tree.occluded(objects, ray, 0.0, tmax, ignore);
    let shared = ObjectTable::dense(objects);
    let (mut decided, mut asked) = (0, 0);
    for p in places {
        let h = p.kernel.hierarchy();
        let owned = |n| p.owned(n);
        let resident = |l| p.resident(l);
        match h.intersect(tree, ray, 0.0, tmax, &owned, &resident) {
            Judged::Decided(got) => {
                prop_assert_eq!(got, want);
                decided += 1;
            }
            Judged::Partly(best) => {
                let mut cursor = TraceCursor {
                    leaves_done: 0,
                    best,
                };
                let got = tree.intersect_partial_past(
                    shared,
                    ray,
                    0.0,
                    tmax,
                    &mut cursor,
                    |l| cells.get(&l),
                    &resident,
                );
                prop_assert_eq!(got, Partial::Done(want));
            }
        }
        match h.occluded(tree, ray, 0.0, tmax, ignore, &owned, &resident) {
            Judged::Decided(got) => {
                prop_assert_eq!(got, blocked);
                decided += 1;
            }
            Judged::Partly(got) => {
                prop_assert!(!got, "an undecided any-hit query found a blocker");
                let got = tree.occluded_partial_past(
                    shared,
                    ray,
                    0.0,
                    tmax,
                    ignore,
                    &mut TraceCursor::default(),
                    |l| cells.get(&l),
                    &resident,
                );
                prop_assert_eq!(got, Partial::Done(blocked));
            }
        }
        asked += 2;
    }
    Ok((decided, asked))
}

#[test]
fn a_decided_answer_is_the_octrees_at_every_scale_and_split() {
    for (seed, n, size, max_objects) in [
        (11u64, 400usize, 10.0f64, 4usize),
        (12, 150, 1e-5, 2),
        (13, 150, 1e5, 6),
        (14, 80, 10.0, 1),
    ] {
        let objects = random_scene(seed, n, size);
        let tree = Octree::build(
            &objects,
            &OctreeParams {
                max_objects,
                ..OctreeParams::default()
            },
        );
        let cells = all_cells(&tree, &objects);
        let mut runner = TestRunner::new(Config {
            cases: 60,
            rng_seed: RngSeed::Fixed(seed),
            ..Config::default()
        });
        let totals = std::cell::Cell::new((0u32, 0u32));
        runner
            .run(&(1u32..5, any::<u32>()), |(places, salt)| {
                let split: Vec<Place> = (0..places)
                    .map(|me| Place::new(&tree, &objects, places, salt, me))
                    .collect();
                // Every object is in some place's kernel.
                let held: usize = split.iter().map(|p| p.kernel.len()).sum();
                prop_assert!(held >= objects.len() - 2 || objects.is_empty());
                let mut s = u64::from(salt) | 1;
                let mut rnd = move || {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    ((s >> 11) as f64) / ((1u64 << 53) as f64)
                };
                for _ in 0..25 {
                    let (x, y, z) = (rnd() * 1.4 - 0.2, rnd() * 1.4 - 0.2, rnd() * 1.4 - 0.2);
                    let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5 + 1e-3).normalize();
                    let tm = rnd();
                    let ray = Ray::new(Vec3::new(x, y, z) * size, d);
                    for tmax in [f64::INFINITY, tm * 0.8 * size] {
                        let (a, b) = check_ray(&tree, &objects, &cells, &split, &ray, tmax)?;
                        let (ta, tb) = totals.get();
                        totals.set((ta + a, tb + b));
                    }
                }
                Ok(())
            })
            .unwrap();
        let (decided, asked) = totals.get();
        // One place holds everything now and then: plenty is decided, and
        // not everything (the rest walks).
        assert!(
            decided * 5 > asked && decided < asked,
            "seed {seed}: {decided} of {asked} decided"
        );
    }
}

#[test]
fn rays_exactly_along_cell_faces_decide_the_octrees_answer() {
    let (objects, tree, rays) = boundary_scene();
    let cells = all_cells(&tree, &objects);
    let mut decided = 0;
    for (places, salt) in [(1u32, 0u32), (2, 7), (3, 1), (5, 99)] {
        let split: Vec<Place> = (0..places)
            .map(|me| Place::new(&tree, &objects, places, salt, me))
            .collect();
        for ray in &rays {
            for tmax in [f64::INFINITY, 3.0] {
                decided += check_ray(&tree, &objects, &cells, &split, ray, tmax)
                    .unwrap()
                    .0;
            }
        }
    }
    assert!(decided as usize > rays.len(), "{decided} decided");
}

#[test]
fn one_processor_decides_every_query() {
    let objects = random_scene(21, 300, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let cells = all_cells(&tree, &objects);
    let place = Place::new(&tree, &objects, 1, 0, 0);
    assert_eq!(place.kernel.len(), objects.len());
    let mut runner = TestRunner::new(Config {
        cases: 200,
        rng_seed: RngSeed::Fixed(21),
        ..Config::default()
    });
    runner
        .run(
            &((-2.0f64..12.0, -2.0f64..12.0, -2.0f64..12.0), arb_dir()),
            |((x, y, z), d)| {
                let ray = Ray::new(Vec3::new(x, y, z), d);
                let (decided, asked) = check_ray(
                    &tree,
                    &objects,
                    &cells,
                    std::slice::from_ref(&place),
                    &ray,
                    1e9,
                )?;
                prop_assert_eq!(decided, asked);
                Ok(())
            },
        )
        .unwrap();
}

/// The kernel reads the copies the leaves hold, it does not make its own:
/// each copy is referenced once more, by the kernel, and the kernel's own
/// bytes (lists, hierarchy, intersection data) are far below the copies'.
#[test]
fn the_kernel_shares_the_leaves_copies() {
    let objects = random_scene(5, 400, 10.0);
    let tree = Octree::build(&objects, &OctreeParams::default());
    let mut copies = ObjectCopies::default();
    let cells: Vec<LeafObjects> = tree
        .leaves()
        .filter(|&l| !tree.leaf_objects(l).is_empty() && home(l, 2, 0) == 0)
        .map(|l| LeafObjects::copy_from(tree.leaf_objects(l), &objects, &mut copies))
        .collect();
    let before: Vec<(ObjectId, usize)> = copies
        .iter()
        .map(|(&id, c)| (id, std::sync::Arc::strong_count(c)))
        .collect();
    assert!(
        before.len() > 50,
        "too few copies to test: {}",
        before.len()
    );
    let kernel = LocalKernel::build(&cells, ObjectTable::dense(&objects));
    assert_eq!(kernel.len(), copies.len());
    for (id, n) in before {
        assert_eq!(
            std::sync::Arc::strong_count(&copies[&id]),
            n + 1,
            "object {id}: the kernel holds another copy, or none"
        );
    }
    let copy_bytes: usize = copies.values().map(|c| c.bytes()).sum();
    assert!(
        kernel.memory_bytes() < copy_bytes,
        "kernel {} B, copies {copy_bytes} B",
        kernel.memory_bytes()
    );
}

/// Cubes and spheres centred exactly on the planes that split the root
/// into 8 x 8 x 8 cells, and axis-parallel rays along those planes (two
/// coordinates on planes), both ways, and diagonal rays through corners.
fn boundary_scene() -> (Vec<Object>, Octree, Vec<Ray>) {
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
    let mut rays = Vec::new();
    for axis in 0..3 {
        let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
        for i in 0..=8 {
            for j in 0..=8 {
                for sign in [1.0, -1.0] {
                    let mut o = Vec3::ZERO;
                    o[axis] = if sign > 0.0 {
                        root.min[axis] - 1.0
                    } else {
                        root.max[axis] + 1.0
                    };
                    o[u] = g(i, u);
                    o[w] = g(j, w);
                    let mut d = Vec3::ZERO;
                    d[axis] = sign;
                    rays.push(Ray { origin: o, dir: d });
                    // Starting on a cell corner inside the tree.
                    o[axis] = g((i + j) % 9, axis);
                    rays.push(Ray { origin: o, dir: d });
                }
            }
        }
    }
    for i in 0..=8 {
        let p = v(g(i, 0), g((i * 3) % 9, 1), g((i * 7) % 9, 2));
        for d in [v(1.0, 1.0, 1.0), v(1.0, -1.0, 0.0), v(-1.0, -1.0, 1.0)] {
            rays.push(Ray::new(p, d));
            rays.push(Ray::new(p - d * 20.0, d));
        }
    }
    (objects, tree, rays)
}

/// The judgement of a box ([`Octree::leaves_in_box_all`], a shadow
/// bundle's region): with budget to spare it says whether every
/// non-empty leaf whose cell meets the box is held (checked leaf by
/// leaf), and where it says so, every segment inside the box is judged
/// held one by one too ([`Octree::leaves_along_all`]), for random scenes
/// at every scale and split, and segments exactly along cell faces.
#[test]
fn a_held_box_holds_every_leaf_a_segment_inside_it_enters() {
    type Scene = (Vec<Object>, Octree, Vec<(Ray, f64)>);
    let mut scenes: Vec<Scene> = Vec::new();
    for (seed, n, size) in [(31u64, 300usize, 10.0f64), (32, 150, 1e-5), (33, 150, 1e5)] {
        let objects = random_scene(seed, n, size);
        let tree = Octree::build(
            &objects,
            &OctreeParams {
                max_objects: 2,
                ..OctreeParams::default()
            },
        );
        let mut s = seed;
        let mut rnd = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64) / ((1u64 << 53) as f64)
        };
        let segments = (0..300)
            .map(|_| {
                let o = Vec3::new(rnd(), rnd(), rnd()) * 1.2 * size - Vec3::splat(0.1 * size);
                let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5 + 1e-3).normalize();
                // Short segments (a bundle towards a near light) to long.
                (Ray::new(o, d), rnd() * rnd() * size)
            })
            .collect();
        scenes.push((objects, tree, segments));
    }
    let (objects, tree, rays) = boundary_scene();
    scenes.push((objects, tree, rays.into_iter().map(|r| (r, 3.0)).collect()));
    let (mut held, mut judged) = (0, 0);
    for (objects, tree, segments) in &scenes {
        let leaves: Vec<NodeId> = tree
            .leaves()
            .filter(|&l| !tree.leaf_objects(l).is_empty())
            .collect();
        for (places, salt) in [(1u32, 0u32), (2, 7), (3, 1), (5, 99)] {
            for me in 0..places {
                let p = Place::new(tree, objects, places, salt, me);
                let (owned, resident) = (|n| p.owned(n), |l| p.resident(l));
                for (ray, tmax) in segments {
                    let (a, b) = (ray.at(0.0), ray.at(*tmax));
                    let (lo, hi) = (a.min(b), a.max(b));
                    let slack = Vec3::splat(tree.box_slack(lo, hi));
                    let (lo, hi) = (lo - slack, hi + slack);
                    let mut budget = u32::MAX;
                    let all = tree.leaves_in_box_all(lo, hi, &owned, &resident, &mut budget);
                    let meets = |l: NodeId| {
                        let c = tree.node_bounds(l);
                        c.min.cmple(hi).all() && c.max.cmpge(lo).all()
                    };
                    let want = leaves.iter().all(|&l| !meets(l) || p.resident(l));
                    assert_eq!(all, want, "box {lo:?} {hi:?}, {places} places");
                    if all {
                        assert!(
                            tree.leaves_along_all(ray, 0.0, *tmax, *tmax, &owned, &resident),
                            "a held box, a segment inside it entering a leaf held elsewhere"
                        );
                        held += 1;
                    }
                    judged += 1;
                    // Out of budget: not known to be held.
                    let mut none = 0;
                    let small = tree.leaves_in_box_all(lo, hi, &owned, &resident, &mut none);
                    assert!(!small || all);
                }
            }
        }
    }
    // Both verdicts are common.
    assert!(
        held * 10 > judged && held * 10 < judged * 9,
        "{held} of {judged}"
    );
}
