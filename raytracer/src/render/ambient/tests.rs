//! The cache's rules (Radiance 5.4's `sumambient`) and hemispheres over
//! scenes whose light is known in closed form.

use super::*;
use crate::geometry::Ray;
use crate::render::rng::Rng;
use crate::render::task::{RayKind, RayTask};

fn options(aa: f64, ad: u32, as_: u32) -> RenderOptions {
    RenderOptions {
        ab: 1,
        aa,
        ar: 16,
        ad,
        as_,
        ..Default::default()
    }
}

fn settings(aa: f64) -> AmbientSettings {
    AmbientSettings::new(&options(aa, 64, 0), 16.0)
}

fn rec(p: Vec3, r: f64, v: f64) -> AmbientRecord {
    AmbientRecord {
        point: p,
        normal: Vec3::Z,
        u: Vec3::X,
        value: Color::splat(v),
        radii: [r, r],
        gpos: [0.0; 2],
        gdir: [0.0; 2],
        level: 0,
        weight: 1.0,
        corral: 0,
    }
}

#[test]
fn radii_limits_follow_setambres() {
    let s = settings(0.1);
    assert_eq!(s.min_radius, 1.0);
    // 64 x 1 is more than a fifth of the scene: the fifth wins.
    assert!((s.max_radius - 3.2).abs() < 1e-12);
    let s = AmbientSettings::new(&options(0.1, 64, 0).clone_with_ar(0), 16.0);
    assert_eq!(s.min_radius, 10.0 * FTINY);
    assert!((s.max_radius - 3.2).abs() < 1e-12);
}

trait WithAr {
    fn clone_with_ar(&self, ar: u32) -> RenderOptions;
}

impl WithAr for RenderOptions {
    fn clone_with_ar(&self, ar: u32) -> RenderOptions {
        RenderOptions { ar, ..self.clone() }
    }
}

#[test]
fn records_serve_their_ellipse_with_hat_weights() {
    let s = settings(0.2);
    let mut c = AmbientCache::default();
    assert_eq!(c.lookup(&s, Vec3::ZERO, Vec3::Z, 0, 1.0), None);
    c.insert(&s, rec(Vec3::ZERO, 1.0, 1.0));
    c.insert(&s, rec(Vec3::new(0.1, 0.0, 0.0), 1.0, 3.0));
    // Half way: equal weights.
    let mid = c
        .lookup(&s, Vec3::new(0.05, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .unwrap();
    assert!((mid.x - 2.0).abs() < 1e-9, "{mid}");
    // The hat: at a quarter of the way the nearer record weighs 3 : 1
    // ((1 - .025/.2) against (1 - .075/.2)), so 1.5 + 0.5 ... = 1.8.
    let q = c
        .lookup(&s, Vec3::new(0.025, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .unwrap();
    let (w0, w1) = (1.0 - 0.025 / 0.2, 1.0 - 0.075 / 0.2);
    assert!((q.x - (w0 + 3.0 * w1) / (w0 + w1)).abs() < 1e-9, "{q}");
    // Beyond a R of both: no answer.
    assert!(c
        .lookup(&s, Vec3::new(0.5, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .is_none());
    // Normals more than 10 degrees + a radians apart do not share.
    let tilted = Vec3::new((0.45f64).sin(), 0.0, (0.45f64).cos());
    assert!(c.lookup(&s, Vec3::ZERO, tilted, 0, 1.0).is_none());
    let slight = Vec3::new((0.3f64).sin(), 0.0, (0.3f64).cos());
    assert!(c.lookup(&s, Vec3::ZERO, slight, 0, 1.0).is_some());
    // A lighter ray accepts a larger angle.
    assert!(c.lookup(&s, Vec3::ZERO, tilted, 0, 0.01).is_some());
    // A record lying in front of the point by more than a minimum radius
    // times a is not used, however large it is.
    let mut big = AmbientCache::default();
    big.insert(&s, rec(Vec3::ZERO, 10.0, 1.0));
    let ahead = |z: f64| big.lookup(&s, Vec3::new(0.0, 0.0, z), Vec3::Z, 0, 1.0);
    assert!(ahead(-0.19).is_some() && ahead(-0.21).is_none() && ahead(0.5).is_some());
    // Deeper records are not used by shallower lookups, and a record of
    // the same level not by rays much heavier than its own.
    let mut d = AmbientCache::default();
    d.insert(
        &s,
        AmbientRecord {
            level: 1,
            weight: 0.5,
            ..rec(Vec3::ZERO, 1.0, 1.0)
        },
    );
    assert!(d.lookup(&s, Vec3::ZERO, Vec3::Z, 0, 1.0).is_none());
    assert!(d.lookup(&s, Vec3::ZERO, Vec3::Z, 1, 0.5).is_some());
    assert!(d.lookup(&s, Vec3::ZERO, Vec3::Z, 1, 0.6).is_none());
}

#[test]
fn elliptical_records_reach_further_along_their_long_axis() {
    let s = settings(0.2);
    let mut c = AmbientCache::default();
    c.insert(
        &s,
        AmbientRecord {
            radii: [1.0, 2.0],
            ..rec(Vec3::ZERO, 1.0, 1.0)
        },
    );
    // u = x (radius 1), v = z x x = y (radius 2).
    assert!(c
        .lookup(&s, Vec3::new(0.0, 0.3, 0.0), Vec3::Z, 0, 1.0)
        .is_some());
    assert!(c
        .lookup(&s, Vec3::new(0.3, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .is_none());
}

#[test]
fn values_follow_the_gradients() {
    let s = settings(0.5);
    let mut c = AmbientCache::default();
    c.insert(
        &s,
        AmbientRecord {
            gpos: [0.5, 0.0],
            gdir: [0.0, 1.0],
            ..rec(Vec3::ZERO, 1.0, 2.0)
        },
    );
    // Translation along u by 0.2: 1 + 0.5 * 0.2.
    let v = c
        .lookup(&s, Vec3::new(0.2, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .unwrap();
    assert!((v.x - 2.0 * 1.1).abs() < 1e-12, "{v}");
    // Rotation: N x n for n tilted towards +x is along +y = v.
    let a = 0.1f64;
    let n = Vec3::new(a.sin(), 0.0, a.cos());
    let v = c.lookup(&s, Vec3::ZERO, n, 0, 1.0).unwrap();
    assert!((v.x - 2.0 * (1.0 + a.sin())).abs() < 1e-12, "{v}");
    // The extrapolation is clamped, and a record extrapolated to nothing
    // does not count.
    let mut d = AmbientCache::default();
    d.insert(
        &s,
        AmbientRecord {
            gpos: [-10.0, 0.0],
            ..rec(Vec3::ZERO, 1.0, 2.0)
        },
    );
    assert!(d
        .lookup(&s, Vec3::new(0.3, 0.0, 0.0), Vec3::Z, 0, 1.0)
        .is_none());
}

#[test]
fn grid_finds_records_of_every_size() {
    let s = settings(0.5);
    let mut c = AmbientCache::default();
    let mut rng = Rng::new(3);
    let recs: Vec<AmbientRecord> = (0..300)
        .map(|i| {
            let p = Vec3::new(rng.next_f64(), rng.next_f64(), 0.0) * 16.0 - 8.0;
            let r = s.min_radius * (1.0 + 2.0 * rng.next_f64());
            AmbientRecord {
                radii: [r, r * (1.0 + rng.next_f64())],
                u: Vec3::new(1.0, rng.next_f64(), 0.0).normalize(),
                ..rec(p, r, i as f64)
            }
        })
        .collect();
    for r in &recs {
        c.insert(&s, *r);
    }
    let max_angle = MIN_ANGLE + s.accuracy;
    for _ in 0..500 {
        let p = Vec3::new(rng.next_f64(), rng.next_f64(), 0.0) * 16.0 - 8.0;
        let (mut sum, mut w) = (0.0, 0.0);
        for r in &recs {
            if let Some((v, wi)) = r.serve(p, Vec3::Z, s.accuracy, max_angle, s.min_radius) {
                sum += v.x * wi;
                w += wi;
            }
        }
        let brute = (w > FTINY).then(|| sum / w);
        let got = c.lookup(&s, p, Vec3::Z, 0, 1.0).map(|c| c.x);
        match (brute, got) {
            (None, None) => {}
            (Some(a), Some(b)) => assert!((a - b).abs() < 1e-9 * a.abs().max(1.0)),
            other => panic!("{other:?} at {p}"),
        }
    }
}

#[test]
fn no_cache_at_aa_zero_and_bad_records_ignored() {
    let s = settings(0.0);
    let mut c = AmbientCache::default();
    c.insert(&s, rec(Vec3::ZERO, 1.0, 1.0));
    assert!(c.is_empty());
    let s = settings(0.1);
    c.insert(&s, rec(Vec3::splat(f64::NAN), 1.0, 1.0));
    c.insert(&s, rec(Vec3::ZERO, 0.0, 1.0));
    assert!(c.is_empty());
    c.insert(&s, rec(Vec3::splat(1e300), 1.0, 1.0));
    assert_eq!(c.len(), 1);
    assert!(c.lookup(&s, Vec3::splat(1e300), Vec3::Z, 0, 1.0).is_some());
}

fn primary_at_origin() -> RayTask {
    RayTask::primary(
        Ray {
            origin: Vec3::Z,
            dir: -Vec3::Z,
        },
        0.0,
        f64::INFINITY,
        7,
    )
}

fn request(normal: Vec3) -> AmbientRequest {
    AmbientRequest {
        point: Vec3::ZERO,
        normal,
        coef: Color::ONE,
        offset_scale: 1.0,
        side: 0,
    }
}

/// Samples a hemisphere at the origin under `scene`, which answers a
/// ray with (radiance, distance).
fn sample(
    s: &AmbientSettings,
    o: &RenderOptions,
    scene: impl Fn(&Ray) -> (Color, f64),
) -> (Color, Option<AmbientRecord>) {
    let mut h = Hemisphere::new(s, o, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    for (d, t) in h.first_pass() {
        let (c, dist) = scene(&t.ray);
        h.add(d, c, dist);
    }
    for (d, t) in h.second_pass(s.super_samples) {
        let (c, dist) = scene(&t.ray);
        h.add(d, c, dist);
    }
    h.finish(s)
}

/// A ceiling at height `h` (the plane z = h), of radiance `l(x)` where
/// a ray meets it; nothing elsewhere.
fn ceiling(h: f64, l: impl Fn(f64) -> f64) -> impl Fn(&Ray) -> (Color, f64) {
    move |r: &Ray| {
        if r.dir.z <= 0.0 {
            return (Color::ZERO, f64::INFINITY);
        }
        let t = (h - r.origin.z) / r.dir.z;
        let x = r.origin.x + r.dir.x * t;
        (Color::splat(l(x)), t)
    }
}

#[test]
fn hemisphere_rays_are_cosine_distributed_stratified_and_spaced() {
    let s = AmbientSettings::new(&options(0.1, 1024, 0), 16.0);
    let o = options(0.1, 1024, 0);
    let h = Hemisphere::new(&s, &o, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    let rays = h.first_pass();
    // sqrt(1024) = 32 strata per side.
    assert_eq!(rays.len(), 32 * 32);
    // E[cos] = 2/3 for a cosine-weighted hemisphere.
    let mean_cos: f64 = rays.iter().map(|(_, t)| t.ray.dir.z).sum::<f64>() / rays.len() as f64;
    assert!((mean_cos - 2.0 / 3.0).abs() < 0.01, "{mean_cos}");
    // No two neighbouring first samples within a quarter stratum.
    let min = 1.0 - 0.5 * ((PI / 4.0) / 32.0f64).powi(2);
    for (i, (_, a)) in rays.iter().enumerate() {
        assert!(a.ray.dir.z > 0.0 && a.ray.origin.z > 0.0);
        assert_eq!((a.kind, a.ambient, a.sampled), (RayKind::Ambient, 1, true));
        // Sample rays carry half the weight of the ray they start from.
        assert_eq!(a.weight, 0.5);
        for (j, (_, b)) in rays.iter().enumerate() {
            let (di, dj) = ((i / 32).abs_diff(j / 32), (i % 32).abs_diff(j % 32));
            if i != j && di <= 1 && dj <= 1 {
                assert!(a.ray.dir.dot(b.ray.dir) < min, "{i} {j}");
            }
        }
    }
    // At least 7 strata a side with a cache, one without.
    let few = options(0.1, 4, 0);
    let h = Hemisphere::new(&s, &few, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    assert_eq!(h.divisions(), 49);
    let none = options(0.0, 4, 0);
    let s0 = AmbientSettings::new(&none, 16.0);
    let h = Hemisphere::new(&s0, &none, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    assert_eq!(h.divisions(), 4);
    // Too light a ray: no hemisphere.
    let light = RayTask {
        weight: 1e-3,
        ..primary_at_origin()
    };
    assert!(Hemisphere::new(&s, &o, &light, &request(Vec3::Z)).is_none());
}

#[test]
fn a_uniform_ceiling_gives_its_radiance_and_no_gradient() {
    let o = options(0.1, 1024, 256);
    let s = AmbientSettings::new(&o, 1000.0);
    let (v, rec) = sample(&s, &o, ceiling(2.0, |_| 3.0));
    // The horizon misses the ceiling (the plane is met by every upward ray).
    assert!((v.x - 3.0).abs() < 1e-12, "{v}");
    let rec = rec.unwrap();
    assert!(
        rec.gpos[0].abs() < 1e-3 && rec.gpos[1].abs() < 1e-3,
        "{rec:?}"
    );
    // The rotational gradient is an estimate from the samples' directions
    // (ambdirgrad): small, not zero.
    assert!(
        rec.gdir[0].abs() < 0.1 && rec.gdir[1].abs() < 0.1,
        "{rec:?}"
    );
    // No variance: no super-samples.
    let mut h = Hemisphere::new(&s, &o, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    for (d, t) in h.first_pass() {
        h.add(d, Color::splat(3.0), t.ray.dir.z.recip() * 2.0);
    }
    assert!(h.second_pass(256).is_empty());
}

#[test]
fn radii_and_gradients_scale_with_the_scene() {
    let o = options(0.1, 1024, 0);
    let s = AmbientSettings {
        min_radius: 1e-6,
        max_radius: 1e6,
        ..AmbientSettings::new(&o, 1000.0)
    };
    // Radiance's radius is (4 / eigenvalue)^(1/4) of the Hessian, whose
    // eigenvalues go as 1 / length^2: radii grow as the square root of
    // the scene's scale.
    let (_, a) = sample(&s, &o, ceiling(1.0, |_| 1.0));
    let (_, b) = sample(&s, &o, ceiling(4.0, |_| 1.0));
    let (a, b) = (a.unwrap(), b.unwrap());
    for k in 0..2 {
        assert!((b.radii[k] / a.radii[k] - 2.0).abs() < 1e-3, "{a:?} {b:?}");
    }
    // A ceiling whose radiance rises along x, at two scales: gradients go
    // inversely with the scale.
    let (_, a) = sample(&s, &o, ceiling(1.0, |x| 1.0 + 0.5 * x.clamp(-1.0, 1.0)));
    let (_, b) = sample(
        &s,
        &o,
        ceiling(4.0, |x| 1.0 + 0.5 * (x / 4.0).clamp(-1.0, 1.0)),
    );
    let (a, b) = (a.unwrap(), b.unwrap());
    for k in 0..2 {
        // (Within 1%: far points are clamped at one distance for both.)
        assert!((b.gpos[k] * 4.0 - a.gpos[k]).abs() < 0.01 * a.gpos[k].abs().max(0.1));
    }
    // Moving towards +x brightens: the gradient along x is positive, and
    // limits the radius (1 / |gradient|).
    let g = a.u * a.gpos[0] + a.v() * a.gpos[1];
    assert!(g.x > 0.1 && g.y.abs() < 0.1 * g.x, "{a:?}");
    assert!(a.radii[0] * a.gpos[0].abs() <= 1.0 + 1e-9);
    assert!(a.radii[1] * a.gpos[1].abs() <= 1.0 + 1e-9);
    // Tilting the normal towards +x brightens too.
    let tilt = Vec3::new(0.1, 0.0, 1.0).normalize();
    let rot = a
        .normal
        .cross(tilt)
        .dot(a.u * a.gdir[0] + a.v() * a.gdir[1]);
    assert!(rot > 0.0, "{a:?}");
}

#[test]
fn nearer_walls_make_smaller_records() {
    // A low ceiling gives records a fraction of the size of a high one's:
    // radius follows the distance to what the hemisphere sees.
    let o = options(0.1, 512, 0);
    let s = AmbientSettings::new(&o, 100.0);
    let (_, low) = sample(&s, &o, ceiling(0.5, |_| 1.0));
    let (_, high) = sample(&s, &o, ceiling(5.0, |_| 1.0));
    let (low, high) = (low.unwrap(), high.unwrap());
    assert!(low.radii[0] < high.radii[0], "{low:?} {high:?}");
    assert!(low.radii[0] >= s.min_radius && high.radii[1] <= s.max_radius);
    assert!(low.radii[1] <= 2.0 * low.radii[0] + 1e-12);
}

#[test]
fn super_samples_go_where_the_light_changes() {
    let o = options(0.1, 1024, 256);
    let s = AmbientSettings::new(&o, 1000.0);
    let mut h = Hemisphere::new(&s, &o, &primary_at_origin(), &request(Vec3::Z)).unwrap();
    let scene = ceiling(1.0, |x| if x > 0.0 { 10.0 } else { 1.0 });
    for (d, t) in h.first_pass() {
        let (c, dist) = scene(&t.ray);
        h.add(d, c, dist);
    }
    let more = h.second_pass(256);
    assert!(!more.is_empty() && more.len() <= 256);
    // Every super-sample looks near the edge x = 0, where the ceiling's
    // brightness changes (within a few strata of it).
    for (_, t) in &more {
        let x = t.ray.dir.x / t.ray.dir.z;
        assert!(x.abs() < 0.5 || t.ray.dir.z < 0.3, "{x}");
    }
}

#[test]
fn degenerate_hemispheres_give_finite_records_that_serve_their_point() {
    let o = options(0.1, 256, 64);
    let s = AmbientSettings::new(&o, 10.0);
    type Scene = Box<dyn Fn(&Ray) -> (Color, f64)>;
    let cases: Vec<(&str, Scene)> = vec![
        // In a corner: everything at distance zero.
        ("touching", Box::new(|_: &Ray| (Color::ONE, 0.0))),
        // Nothing in sight.
        (
            "open sky",
            Box::new(|_: &Ray| (Color::splat(2.0), f64::INFINITY)),
        ),
        // No light at all: the geometric Hessian alone.
        (
            "dark",
            Box::new(|r: &Ray| (Color::ZERO, 1.0 / r.dir.z.max(1e-3))),
        ),
        // A few samples without a value.
        (
            "nan",
            Box::new(|r: &Ray| {
                let c = if r.dir.x > 0.9 { f64::NAN } else { 1.0 };
                (Color::splat(c), 1.0)
            }),
        ),
        // Radiance spanning 300 orders of magnitude.
        (
            "extreme",
            Box::new(|r: &Ray| {
                (
                    Color::splat(if r.dir.x > 0.0 { 1e150 } else { 1e-150 }),
                    2.0,
                )
            }),
        ),
    ];
    for (name, scene) in cases {
        let (v, rec) = sample(&s, &o, scene);
        assert!(v.is_finite(), "{name}: {v}");
        let rec = rec.unwrap_or_else(|| panic!("{name}: no record"));
        assert!(
            rec.radii
                .iter()
                .all(|r| *r >= s.min_radius * 0.999 && *r <= s.max_radius * 1.001),
            "{name}: {rec:?}"
        );
        assert!(
            rec.gpos.iter().chain(&rec.gdir).all(|g| g.is_finite()),
            "{name}: {rec:?}"
        );
        let mut c = AmbientCache::default();
        c.insert(&s, rec);
        assert_eq!(
            c.lookup(&s, rec.point, rec.normal, 0, 1.0),
            Some(rec.value),
            "{name}"
        );
    }
}

#[test]
fn a_record_serves_the_point_it_was_made_for_whatever_the_ray_weight() {
    let o = options(0.1, 64, 0);
    let s = AmbientSettings::new(&o, 10.0);
    for w in [0.05, 0.3, 1.0, 1.5, 4.0] {
        let task = RayTask {
            weight: w,
            ..primary_at_origin()
        };
        let mut h = Hemisphere::new(&s, &o, &task, &request(Vec3::Z)).unwrap();
        let scene = ceiling(1.0, |_| 1.0);
        for (d, t) in h.first_pass() {
            let (c, dist) = scene(&t.ray);
            h.add(d, c, dist);
        }
        let (_, rec) = h.finish(&s);
        let mut c = AmbientCache::default();
        c.insert(&s, rec.unwrap());
        assert!(
            c.lookup(&s, Vec3::ZERO, Vec3::Z, 0, w).is_some(),
            "weight {w}"
        );
    }
}

#[test]
fn the_leak_test_aims_20_degrees_above_the_plane_over_the_record() {
    let mut r = rec(Vec3::ZERO, 1.0, 1.0);
    assert_eq!(r.leak_test(Vec3::X, Vec3::Z), LeakTest::Keep, "no corral");
    r.corral = u32::MAX;
    let LeakTest::Trace(dir, len) = r.leak_test(Vec3::new(0.5, 0.2, 0.0), Vec3::Z) else {
        panic!("expected a test ray");
    };
    assert!((dir.length() - 1.0).abs() < 1e-12);
    assert!((dir.z - (70f64).to_radians().cos()).abs() < 1e-6, "{dir:?}");
    // It ends straight above the record's point.
    let end = Vec3::new(0.5, 0.2, 0.0) + dir * len;
    assert!(
        end.x.abs() < 1e-9 && end.y.abs() < 1e-9 && end.z > 0.0,
        "{end:?}"
    );
    // Only the flagged sectors test: +x is sector 0, +y sector 8.
    r.corral = 1 << 8;
    assert_eq!(r.leak_test(Vec3::X, Vec3::Z), LeakTest::Keep);
    assert!(matches!(r.leak_test(Vec3::Y, Vec3::Z), LeakTest::Trace(..)));
    // At the record's own point there is nothing to test.
    r.corral = u32::MAX;
    assert_eq!(r.leak_test(Vec3::ZERO, Vec3::Z), LeakTest::Keep);
}

#[test]
fn a_low_wall_beside_a_hemisphere_keeps_its_record_on_its_own_side() {
    // A low wall (the plane x = 0.3, 0.05 high) beside a point under a
    // high ceiling: a few rim samples meet it inside the record's reach
    // (it hardly changes the Hessian), so the record flags directions
    // towards +x, and a lookup beyond the wall is served only if its test
    // ray, which the wall crosses, is clear.
    let mut o = options(0.2, 512, 128);
    o.ar = 256;
    let s = AmbientSettings::new(&o, 16.0);
    let (_, r) = sample(&s, &o, ceiling_and_wall(4.0, 0.3, 0.05));
    let r = r.unwrap();
    let centre = |k: u32| {
        let a = (k as f64 + 0.5) * PI / 16.0;
        r.u * a.cos() + r.v() * a.sin()
    };
    let flagged: Vec<u32> = (0..32).filter(|k| r.corral >> k & 1 != 0).collect();
    assert!(!flagged.is_empty());
    assert!(
        flagged.iter().all(|&k| centre(k).x > 0.0),
        "{:032b}",
        r.corral
    );
    let toward = centre(
        *flagged
            .iter()
            .max_by(|a, b| centre(**a).x.total_cmp(&centre(**b).x))
            .unwrap(),
    );
    let beyond = toward * (0.32 / toward.x);
    let mut c = AmbientCache::default();
    c.insert(&s, r);
    let mut wall = |p: Vec3, d: Vec3, len: f64| {
        d.x < 0.0 && p.x > 0.3 && {
            let t = (0.3 - p.x) / d.x;
            t < len && p.z + d.z * t <= 0.05
        }
    };
    assert!(
        c.lookup(&s, beyond, Vec3::Z, 0, 1.0).is_some(),
        "served where nothing is in the way"
    );
    assert!(c
        .lookup_plugged(&s, beyond, Vec3::Z, 0, 1.0, &mut wall)
        .is_none());
    // On the open side nothing is tested.
    let open = -beyond;
    let mut never = |_: Vec3, _: Vec3, _: f64| -> bool { panic!("no test ray expected") };
    assert!(c
        .lookup_plugged(&s, open, Vec3::Z, 0, 1.0, &mut never)
        .is_some());
}

/// A ceiling at height `h` and a wall (the plane x = `w`, up to height
/// `hw`), both of radiance 1.
fn ceiling_and_wall(h: f64, w: f64, hw: f64) -> impl Fn(&Ray) -> (Color, f64) {
    move |r: &Ray| {
        let mut t = f64::INFINITY;
        if r.dir.z > 0.0 {
            t = (h - r.origin.z) / r.dir.z;
        }
        if r.dir.x > 0.0 {
            let tw = (w - r.origin.x) / r.dir.x;
            if tw < t && r.origin.z + r.dir.z * tw <= hw {
                t = tw;
            }
        }
        (Color::ONE, t)
    }
}

/// `-aw` (Radiance's `multambient()`): the constant ambient value's
/// brightness becomes the weighted geometric mean of its own (weight
/// `aw`) and the stored records' (weight 1 each), its colour kept; a black
/// `-av` gives the records' geometric mean as grey; `-aw 0`, or no record,
/// leaves `-av` as it is. A frozen store counts its base and its own
/// records.
#[test]
fn ambient_value_weight_averages_in_the_records() {
    let s = settings(0.1);
    let av = Color::new(0.2, 0.1, 0.05);
    let l = crate::image::brightness(av);
    let mut store = AmbientStore::default();
    assert_eq!(store.ambient_value(av, 4), av);
    store.insert(&s, rec(Vec3::ZERO, 1.0, 0.5));
    store.insert(&s, rec(Vec3::X, 1.0, 2.0));
    // A black record (no light) does not count, as in Radiance's avstore.
    store.insert(&s, rec(Vec3::Y, 1.0, 0.0));
    assert_eq!(store.ambient_value(av, 0), av);
    let b = |v: f64| crate::image::brightness(Color::splat(v));
    for aw in [1u32, 4, 1000] {
        let mean = ((l.ln() * aw as f64 + b(0.5).ln() + b(2.0).ln()) / (aw as f64 + 2.0)).exp();
        let got = store.ambient_value(av, aw);
        assert!(((crate::image::brightness(got) / mean) - 1.0).abs() < 1e-12);
        // The colour of -av is kept.
        assert!((got.x / got.y - 2.0).abs() < 1e-12 && (got.y / got.z - 2.0).abs() < 1e-12);
    }
    // With a large weight -av itself comes back.
    let heavy = store.ambient_value(av, 1_000_000_000);
    assert!((heavy - av).abs().max_element() < 1e-6 * l);
    // Black -av: the records' geometric mean, grey.
    let grey = store.ambient_value(Color::ZERO, 3);
    let want = ((b(0.5).ln() + b(2.0).ln()) / 2.0).exp();
    assert_eq!(grey, Color::splat(grey.x));
    assert!((grey.x / want - 1.0).abs() < 1e-12);
    // A frozen store: its base's records and its own.
    let mut base = AmbientCache::default();
    base.insert(&s, rec(Vec3::ZERO, 1.0, 0.5));
    let mut frozen = AmbientStore::Frozen {
        base: std::sync::Arc::new(base),
        own: AmbientCache::default(),
    };
    frozen.insert(&s, rec(Vec3::X, 1.0, 2.0));
    assert_eq!(frozen.ambient_value(av, 4), store.ambient_value(av, 4));
}
