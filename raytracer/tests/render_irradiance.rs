//! `-i`: irradiance instead of radiance (Radiance's `do_irrad`), against
//! closed forms, and the parallel renderer's picture bit for bit.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use common::*;
use hybrid_rt::parallel::{render_parallel, Distribution, ParallelOptions, RuntimeKind};
use hybrid_rt::render::RenderOptions;
use hybrid_rt::scene::Color;

const L: f64 = 10.0; // source radiance

/// Mean of the pixels' green channel.
fn mean(film: &hybrid_rt::image::Film) -> f64 {
    film.pixels().iter().map(|c| c.y).sum::<f64>() / film.pixels().len() as f64
}

/// E at a point under the centre of a square of side 2a at height h
/// (Howell's catalogue, configuration B-3, four corner rectangles).
fn square_irradiance(a: f64, h: f64) -> f64 {
    let x = a / h;
    let s = (1.0 + x * x).sqrt();
    4.0 * L * (x / s) * (x / s).atan()
}

/// A square light of side 2a at height h facing down over a floor of
/// `floor` (any material: -i shades it as a white Lambertian), seen from
/// straight above through a sheet of glass (which -i passes through), on
/// a 1e-3 wide spot under the light's centre.
fn square_light_scene(a: f64, h: f64, floor: &str) -> hybrid_rt::scene::Scene {
    scene(&format!(
        "void light lamp_mat 0 0 3 {L} {L} {L}\n\
         {floor}\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         void glass pane_mat 0 0 3 0.5 0.5 0.5\n\
         pane_mat polygon pane 0 0 12 -0.01 -0.01 {z}  0.01 -0.01 {z}  0.01 0.01 {z}  -0.01 0.01 {z}\n\
         lamp_mat polygon lamp 0 0 12 {m} {m} {h}  {m} {a} {h}  {a} {a} {h}  {a} {m} {h}\n",
        m = -a,
        z = 0.3 * h,
    ))
}

#[test]
fn irradiance_under_a_square_light_matches_the_form_factor() {
    let h = 1.0;
    let v = view("-vtl -vp 0 0 0.6 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001");
    for floor in [
        "void plastic floor_mat 0 0 5 0.2 0.4 0.6 0.05 0.1",
        "void metal floor_mat 0 0 5 0.9 0.9 0.9 0.9 0",
        "void mirror floor_mat 0 0 3 0.9 0.9 0.9",
    ] {
        for a in [0.5, 2.0] {
            let s = square_light_scene(a, h, floor);
            let opts = RenderOptions {
                dt: 0.0,
                irradiance: true,
                ..Default::default()
            };
            let (film, _) = render(&s, &v, 8, 8, opts.clone());
            let expected = square_irradiance(a, h);
            let got = mean(&film);
            let err = (got - expected).abs() / expected;
            // Centre-aimed source patches: the midpoint rule, as the
            // radiance test of the same configuration.
            assert!(err < 0.01, "{floor}, a={a}: {got} vs {expected}");
            // Without -i the picture is the floor's radiance, not E.
            let (plain, _) = render(
                &s,
                &v,
                8,
                8,
                RenderOptions {
                    irradiance: false,
                    ..opts
                },
            );
            assert!((mean(&plain) - expected).abs() / expected > 0.1, "{floor}");
        }
    }
}

#[test]
fn irradiance_of_a_uniform_ambient_is_pi_times_its_radiance() {
    // No sources: -av alone lights a Lambertian with E = pi * av; the
    // light source seen directly keeps its radiance.
    let s = scene(
        "void trans floor_mat 0 0 7 0.3 0.3 0.3 0 0 0.5 0\n\
         floor_mat polygon floor 0 0 12 -10 -10 0  10 -10 0  10 10 0  -10 10 0\n\
         void plastic under_mat 0 0 5 0.1 0.1 0.1 0 0\n\
         under_mat polygon under 0 0 12 -10 -10 -1  10 -10 -1  10 10 -1  -10 10 -1\n\
         void glow g 0 0 4 7 7 7 0\n\
         g sphere ball 0 0 4 5 5 -0.5 0.2\n",
    );
    let av = 0.25;
    let opts = RenderOptions {
        av: Color::splat(av),
        irradiance: true,
        ..Default::default()
    };
    // Straight down: through the trans floor (passed on by -i) to the
    // plastic under it.
    let v = view("-vtl -vp 0 0 1 -vd 0 0 -1 -vu 0 1 0 -vh 1 -vv 1");
    let (film, _) = render(&s, &v, 4, 4, opts.clone());
    for c in film.pixels() {
        assert!((c.y - PI * av).abs() < 1e-9, "{c} vs {}", PI * av);
    }
    // The glow ball directly: its radiance.
    let v = view("-vtl -vp 5 5 1 -vd 0 0 -1 -vu 0 1 0 -vh 0.01 -vv 0.01");
    let (film, _) = render(&s, &v, 2, 2, opts);
    for c in film.pixels() {
        assert_eq!(c.y, 7.0);
    }
}

#[test]
fn irradiance_in_parallel_equals_sequential() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let opts = RenderOptions {
        irradiance: true,
        av: Color::splat(0.01),
        ..Default::default()
    };
    let (seq, _) = render(&s, &v, 24, 24, opts.clone());
    let (plain, _) = render(
        &s,
        &v,
        24,
        24,
        RenderOptions {
            irradiance: false,
            ..opts.clone()
        },
    );
    assert!(seq.pixels() != plain.pixels(), "-i changes the picture");
    let scene = Arc::new(s);
    for (runtime, distribution) in [
        (RuntimeKind::Threads, Distribution::Octree),
        (RuntimeKind::Threads, Distribution::Replicated),
    ] {
        let mut p = ParallelOptions::new(3);
        p.runtime = runtime;
        p.workload.distribution = distribution;
        let par = render_parallel(scene.clone(), opts.clone(), &v, 24, 24, &p).unwrap();
        for (i, (a, b)) in seq.pixels().iter().zip(par.film.pixels()).enumerate() {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits),
                "{runtime:?} {distribution:?}: pixel {i} {a} vs {b}"
            );
        }
    }
}
