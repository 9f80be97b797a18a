//! Physical truths with known answers: irradiance from uniform area
//! sources (form factors), energy conservation and no NaN at glass and
//! dielectric boundaries including total internal reflection.

mod common;

use common::*;
use hybrid_rt::accel::Hit;
use hybrid_rt::geometry::{Ray, Vec3};
use hybrid_rt::render::material::{
    fresnel_dielectric, glass_coefficients, shade, RayTask, Request,
};
use hybrid_rt::render::{RayKind, RenderOptions, Renderer};
use hybrid_rt::scene::Color;

const L: f64 = 10.0; // source radiance
const RHO: f64 = 0.5; // floor reflectance

/// Floor (plastic RHO, no specular) at z = 0, a light at height `h`
/// facing down, and a parallel view looking straight down at a 1e-3
/// wide spot under the light's centre (so every pixel sees the axis).
fn scene_with_light(light: &str, h: f64) -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    let text = format!(
        "void light glow_mat 0 0 3 {L} {L} {L}\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         {light}\n"
    );
    let _ = h;
    let v = view(&format!(
        "-vtl -vp 0 0 {} -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001",
        h * 0.5
    ));
    (scene(&text), v)
}

/// Mean pixel radiance of a small parallel render.
fn axis_radiance(
    s: &hybrid_rt::scene::Scene,
    v: &hybrid_rt::scene::View,
    opts: RenderOptions,
) -> f64 {
    let (film, stats) = render(s, v, 16, 16, opts);
    assert_eq!(stats.rays.reflection + stats.rays.refraction, 0);
    film.pixels().iter().map(|c| c.y).sum::<f64>() / film.pixels().len() as f64
}

/// E at a point under the centre of a square of side 2a at height h
/// (four corner rectangles; Howell's catalogue, configuration B-3).
fn square_irradiance(a: f64, h: f64) -> f64 {
    let x = a / h;
    let s = (1.0 + x * x).sqrt();
    4.0 * L * (x / s) * (x / s).atan()
}

#[test]
fn lambertian_under_square_light_matches_form_factor() {
    for &(a, h) in &[(0.5, 1.0), (2.0, 1.0), (0.05, 1.0)] {
        // Vertices clockwise seen from above, so the light faces down.
        let light = format!(
            "glow_mat polygon lamp 0 0 12 {m} {m} {h}  {m} {a} {h}  {a} {a} {h}  {a} {m} {h}",
            m = -a
        );
        let (s, v) = scene_with_light(&light, h);
        let expected = RHO / std::f64::consts::PI * square_irradiance(a, h);
        // Centre-aimed patches (-dj 0): midpoint rule over at most 64 patches.
        let got = axis_radiance(
            &s,
            &v,
            RenderOptions {
                dt: 0.0,
                ..Default::default()
            },
        );
        let err = (got - expected).abs() / expected;
        assert!(
            err < 0.01,
            "a={a} h={h}: {got} vs {expected} (err {err:.4})"
        );
        // Jittered patches: stratified Monte Carlo, averaged over 256 pixels.
        let got = axis_radiance(
            &s,
            &v,
            RenderOptions {
                dt: 0.0,
                dj: 1.0,
                ..Default::default()
            },
        );
        let err = (got - expected).abs() / expected;
        assert!(
            err < 0.01,
            "a={a} h={h} jittered: {got} vs {expected} (err {err:.4})"
        );
    }
}

/// The same square as two triangular sources (patches clipped to each
/// triangle): the irradiances add up to the square's.
#[test]
fn triangular_sources_add_up_to_the_square() {
    let (a, h) = (0.5, 1.0);
    let m = -a;
    let light = format!(
        "glow_mat polygon t1 0 0 9 {m} {m} {h}  {m} {a} {h}  {a} {a} {h}\n\
         glow_mat polygon t2 0 0 9 {m} {m} {h}  {a} {a} {h}  {a} {m} {h}"
    );
    let (s, v) = scene_with_light(&light, h);
    assert_eq!(s.lights.len(), 2);
    let expected = RHO / std::f64::consts::PI * square_irradiance(a, h);
    for dj in [0.0, 1.0] {
        let got = axis_radiance(
            &s,
            &v,
            RenderOptions {
                dt: 0.0,
                dj,
                ..Default::default()
            },
        );
        let err = (got - expected).abs() / expected;
        assert!(err < 0.01, "dj {dj}: {got} vs {expected} (err {err:.4})");
    }
}

#[test]
fn lambertian_under_disk_light_matches_form_factor() {
    // (radius, height, tolerance of centre-aimed patches). A disk six times
    // wider than its height needs more than the 64 patches Radiance allows
    // (MAXSPART), so the midpoint rule is coarse there; jittered patches
    // are unbiased and stay within 1% everywhere. The small disk splits
    // into four quarter sectors aimed at their area centroids, where
    // cos^2/d^2 is 1.1% above its mean over the sector.
    for &(r, h, tol) in &[(1.0, 1.0, 0.01), (0.2, 1.0, 0.015), (3.0, 0.5, 0.1)] {
        let light = format!("glow_mat ring lamp 0 0 8 0 0 {h}  0 0 -1  0 {r}");
        let (s, v) = scene_with_light(&light, h);
        // E = pi L R^2 / (h^2 + R^2) for a point on the axis of a disk.
        let expected =
            RHO / std::f64::consts::PI * (std::f64::consts::PI * L * r * r / (h * h + r * r));
        let got = axis_radiance(
            &s,
            &v,
            RenderOptions {
                dt: 0.0,
                ..Default::default()
            },
        );
        let err = (got - expected).abs() / expected;
        assert!(err < tol, "r={r} h={h}: {got} vs {expected} (err {err:.4})");
        let got = axis_radiance(
            &s,
            &v,
            RenderOptions {
                dt: 0.0,
                dj: 1.0,
                ..Default::default()
            },
        );
        let err = (got - expected).abs() / expected;
        assert!(
            err < 0.01,
            "r={r} h={h} jittered: {got} vs {expected} (err {err:.4})"
        );
    }
}

#[test]
fn sphere_light_matches_solid_angle() {
    // A small sphere of radius r at height h: E = L pi r^2 / h^2 (exactly,
    // for a point on the axis: sin^2 of the half angle times pi L).
    let (r, h) = (0.1, 2.0);
    let light = format!("glow_mat sphere lamp 0 0 4 0 0 {h} {r}");
    let (s, v) = scene_with_light(&light, h);
    let expected = RHO / std::f64::consts::PI * (std::f64::consts::PI * L * r * r / (h * h));
    let got = axis_radiance(
        &s,
        &v,
        RenderOptions {
            dt: 0.0,
            ..Default::default()
        },
    );
    let err = (got - expected).abs() / expected;
    assert!(err < 0.01, "{got} vs {expected} (err {err:.4})");
}

#[test]
fn glass_conserves_energy_at_all_angles() {
    for i in 0..=1000 {
        let pdot = if i == 0 {
            0.0
        } else {
            (i as f64 / 1000.0).powi(3)
        };
        // Clear glass loses nothing: transmitted + reflected = 1.
        let (t, r) = glass_coefficients(Color::ONE, 1.52, pdot);
        assert!(t.is_finite() && r.is_finite(), "pdot {pdot}: {t} {r}");
        assert!(
            ((t + r) - Color::ONE).abs().max_element() < 1e-9,
            "pdot {pdot}: {t} + {r}"
        );
        // Tinted glass absorbs: the sum is below 1 but never negative.
        let (t, r) = glass_coefficients(Color::new(0.2, 0.5, 0.9), 1.52, pdot);
        assert!(t.min_element() >= 0.0 && r.min_element() >= 0.0);
        assert!((t + r).max_element() <= 1.0 + 1e-12);
    }
    // Grazing incidence reflects everything.
    let (t, r) = glass_coefficients(Color::ONE, 1.52, 0.0);
    assert!(t.max_element() < 1e-6 && (r - Color::ONE).abs().max_element() < 1e-6);
}

#[test]
fn dielectric_fresnel_and_total_internal_reflection() {
    let n: f64 = 1.5;
    let critical = (1.0 / n).asin(); // from inside
    for i in 0..=2000 {
        let theta = std::f64::consts::FRAC_PI_2 * i as f64 / 2000.0;
        let cos1 = theta.cos().max(1e-12);
        // Entering (outside -> inside): never total reflection.
        let (r_in, c2) = fresnel_dielectric(1.0 / n, cos1);
        assert!((0.0..=1.0).contains(&r_in) && c2.is_some(), "theta {theta}");
        // Leaving (inside -> outside).
        let (r_out, c2) = fresnel_dielectric(n, cos1);
        assert!(r_out.is_finite() && (0.0..=1.0).contains(&r_out));
        if theta > critical + 1e-6 {
            assert_eq!(
                (r_out, c2),
                (1.0, None),
                "theta {theta} beyond critical {critical}"
            );
        } else if theta < critical - 1e-3 {
            assert!(c2.is_some() && r_out < 1.0);
        }
    }
    // Normal incidence: ((n-1)/(n+1))^2.
    let (r0, _) = fresnel_dielectric(1.0 / n, 1.0);
    assert!((r0 - 0.04).abs() < 1e-12);
}

/// Shading a dielectric hit from inside beyond the critical angle asks
/// for one reflected ray with coefficient 1 and no refracted ray.
#[test]
fn tir_reflects_everything_in_shading() {
    let s = scene(
        "void dielectric d 0 0 5 1 1 1 1.5 0\n\
         d sphere ball 0 0 4 0 0 0 1\n",
    );
    let r = Renderer::new(&s, RenderOptions::default()).unwrap();
    let ctx = r.context();
    for &(cos_out, expect_tir) in &[
        (0.3, true),
        (0.9, false),
        (0.75, false),
        (0.74, true),
        (1e-9, true),
    ] {
        // Ray inside the sphere hitting the surface at (1,0,0), where the
        // outward normal is +x, at angle acos(cos_out) to the normal.
        let sin = (1.0f64 - cos_out * cos_out).sqrt();
        let dir = Vec3::new(cos_out, sin, 0.0);
        let p = Vec3::X;
        let task = RayTask::primary(
            Ray {
                origin: p - dir * 0.5,
                dir,
            },
            0.0,
            f64::INFINITY,
            7,
        );
        let hit = Hit {
            t: 0.5,
            point: p,
            normal: Vec3::X,
            object: 0,
            inner: None,
            surface: {
                let (m, f) = ctx.scene.objects[0].surface_at(None);
                Hit::surface_word(m, f)
            },
        };
        let mut out = Vec::new();
        let shaded = shade(&ctx, &task, &hit, &mut out);
        assert!(shaded.base.is_finite());
        let refl: Vec<_> = out
            .iter()
            .filter_map(|q| match q {
                Request::Trace { task, coef } if task.kind == RayKind::Reflection => Some(*coef),
                _ => None,
            })
            .collect();
        let refr = out.iter().filter(
            |q| matches!(q, Request::Trace { task, .. } if task.kind == RayKind::Refraction),
        );
        let nrefr = refr.count();
        assert_eq!(refl.len(), 1);
        assert!(refl[0].is_finite());
        if expect_tir {
            assert_eq!(
                nrefr, 0,
                "cos {cos_out}: no refraction beyond the critical angle"
            );
            assert_eq!(
                refl[0],
                Color::ONE,
                "cos {cos_out}: TIR reflects everything"
            );
        } else {
            assert_eq!(nrefr, 1, "cos {cos_out}");
            assert!(refl[0].x < 1.0);
        }
        for q in &out {
            if let Request::Trace { task, coef } = q {
                assert!(task.ray.dir.is_finite() && (task.ray.dir.length() - 1.0).abs() < 1e-12);
                assert!(coef.is_finite() && coef.min_element() >= 0.0);
            }
        }
    }
}

/// Renders looking through glass and dielectric spheres and a slab, from
/// outside and from inside, at all angles: no NaN or infinite pixel.
#[test]
fn transparent_renders_have_no_nan() {
    let s = scene(
        "void light l 0 0 3 5 5 5\n\
         l polygon lamp 0 0 12 -1 -1 3  -1 1 3  1 1 3  1 -1 3\n\
         void plastic wall 0 0 5 .6 .6 .6 0 0\n\
         wall polygon floor 0 0 12 -5 -5 -1  5 -5 -1  5 5 -1  -5 5 -1\n\
         void dielectric d 0 0 5 .5 .8 .9 1.5 0\n\
         void glass g 0 0 3 .9 .9 .9\n\
         d sphere ball 0 0 4 0 0 0 0.8\n\
         g sphere thin 0 0 4 1.5 0 0 0.5\n\
         d polygon slab 0 0 12 -3 -3 -0.5  3 -3 -0.5  3 3 -0.5  -3 3 -0.5\n",
    );
    for vp in [
        "-vp 0 -4 0.2 -vd 0 1 0",
        "-vp 0 0 0 -vd 0.3 1 0.1",
        "-vp 1.5 0 0 -vd 0 1 0.01",
    ] {
        let v = view(&format!("-vtv {vp} -vu 0 0 1 -vh 120 -vv 120"));
        let (film, stats) = render(
            &s,
            &v,
            24,
            24,
            RenderOptions {
                dj: 0.7,
                ..Default::default()
            },
        );
        assert!(
            film.pixels()
                .iter()
                .all(|c| c.is_finite() && c.min_element() >= 0.0),
            "{vp}"
        );
        assert!(stats.rays.refraction > 0 && stats.rays.reflection > 0);
    }
}
