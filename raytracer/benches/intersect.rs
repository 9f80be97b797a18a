//! Intersection micro-benchmarks: ray/triangle, ray/sphere, and octree and
//! hierarchy nearest-hit and occlusion queries on a random scene of a few
//! thousand polygons.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use hybrid_rt::accel::{Bvh, Octree, OctreeParams};
use hybrid_rt::geometry::{intersect_sphere, intersect_triangle, PreparedRay, Ray, Shape, Vec3};
use hybrid_rt::scene::Object;

/// Deterministic uniform numbers in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64) / ((1u64 << 53) as f64)
    }

    fn vec(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

fn random_rays(rng: &mut Lcg, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let o = rng.vec() * 1.2 - Vec3::splat(0.1);
            let t = rng.vec();
            Ray::new(o, t - o)
        })
        .collect()
}

/// A few thousand small random polygons (triangles and quads) in the unit cube.
fn random_scene(rng: &mut Lcg, n: usize) -> Vec<Object> {
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let c = rng.vec();
        let s = 0.01 + 0.03 * rng.next();
        let a = c + (rng.vec() - 0.5) * s;
        let b = c + (rng.vec() - 0.5) * s;
        let d = c + (rng.vec() - 0.5) * s;
        let verts = if out.len() % 2 == 0 {
            vec![a, b, d]
        } else {
            vec![a, b, b + (d - a), d]
        };
        if let Ok(shape) = Shape::polygon(verts) {
            out.push(Object {
                name: String::new(),
                shape,
                material: 0,
            });
        }
    }
    out
}

fn primitives(c: &mut Criterion) {
    let mut rng = Lcg(1);
    let rays = random_rays(&mut rng, 1024);
    let pre: Vec<PreparedRay> = rays.iter().map(PreparedRay::new).collect();
    let (a, b, d) = (
        Vec3::new(0.2, 0.2, 0.5),
        Vec3::new(0.8, 0.3, 0.5),
        Vec3::new(0.4, 0.9, 0.6),
    );
    let mut g = c.benchmark_group("primitive");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("ray_triangle", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for p in &pre {
                n += intersect_triangle(p, black_box(a), b, d, 0.0, f64::INFINITY).is_some() as u32;
            }
            n
        })
    });
    g.bench_function("ray_sphere", |bch| {
        let c = Vec3::splat(0.5);
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                n += intersect_sphere(r, black_box(c), 0.3, 0.0, f64::INFINITY).is_some() as u32;
            }
            n
        })
    });
    g.finish();
}

fn octree(c: &mut Criterion) {
    let mut rng = Lcg(2);
    let objects = random_scene(&mut rng, 4000);
    let tree = Octree::build(&objects, &OctreeParams::default());
    eprintln!("octree over {} polygons: {:?}", objects.len(), tree.stats());
    let rays = random_rays(&mut rng, 4096);
    let mut g = c.benchmark_group("octree");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("build_4000_polygons", |bch| {
        bch.iter(|| {
            Octree::build(black_box(&objects), &OctreeParams::default())
                .stats()
                .leaf_nodes
        })
    });
    g.bench_function("nearest_hit", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                n += tree
                    .intersect(&objects, black_box(r), 0.0, f64::INFINITY)
                    .is_some() as u32;
            }
            n
        })
    });
    g.bench_function("traversal_only", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                tree.for_each_leaf_along_ray(black_box(r), 0.0, f64::INFINITY, |_, _, _| {
                    n += 1;
                    false
                });
            }
            n
        })
    });
    g.bench_function("occlusion", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                n += tree.occluded(&objects, black_box(r), 0.0, 1.0, None) as u32;
            }
            n
        })
    });
    g.finish();
}

/// The hierarchy on the octree group's scene and rays (the same answers;
/// `hybrid-rt bench` times the two side by side on real scenes).
fn bvh(c: &mut Criterion) {
    let mut rng = Lcg(2);
    let objects = random_scene(&mut rng, 4000);
    let bvh = Bvh::build(&objects);
    eprintln!(
        "hierarchy over {} polygons: {:?}",
        objects.len(),
        bvh.stats()
    );
    let rays = random_rays(&mut rng, 4096);
    let mut g = c.benchmark_group("bvh");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("build_4000_polygons", |bch| {
        bch.iter(|| Bvh::build(black_box(&objects)).stats().nodes)
    });
    g.bench_function("nearest_hit", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                n += bvh
                    .intersect(&objects, black_box(r), 0.0, f64::INFINITY)
                    .is_some() as u32;
            }
            n
        })
    });
    g.bench_function("occlusion", |bch| {
        bch.iter(|| {
            let mut n = 0u32;
            for r in &rays {
                n += bvh.occluded(&objects, black_box(r), 0.0, 1.0, None) as u32;
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, primitives, octree, bvh);
criterion_main!(benches);
