//! Diffuse inter-reflection with the irradiance cache: the geometric
//! series of an integrating sphere, `-ab 0` unchanged, determinism, and
//! the effect simulated only where the scene and options call for it.

mod common;

use common::*;
use hybrid_rt::image::Film;
use hybrid_rt::render::{Region, RenderOptions, Renderer, TraceState};

const RHO: f64 = 0.5;
const LE: f64 = 100.0;
const R_LAMP: f64 = 0.05;

/// A white sphere of radius 1 seen from inside, lit by a small spherical
/// source at its centre; the camera looks at the wall point (1, 0, 0.5).
/// Every wall point receives the same direct irradiance `E = pi Le r^2 /
/// d^2`, and the light it reflects illuminates every other wall point
/// equally (the integrating sphere), so with `n` bounces the wall's
/// radiance is `rho / pi E (1 + rho + ... + rho^n)`.
fn integrating_sphere() -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    let text = format!(
        "void light lamp_mat 0 0 3 {LE} {LE} {LE}\n\
         void plastic wall_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         wall_mat sphere room 0 0 4 0 0 0 1\n\
         lamp_mat sphere lamp 0 0 4 0 0 0 {R_LAMP}\n"
    );
    let v = view("-vtv -vp 0 0 0.5 -vd 1 0 0 -vu 0 0 1 -vh 0.01 -vv 0.01");
    (scene(&text), v)
}

fn mean_y(f: &Film) -> f64 {
    f.pixels().iter().map(|c| c.y).sum::<f64>() / f.pixels().len() as f64
}

fn ambient_opts(ab: u32) -> RenderOptions {
    RenderOptions {
        ab,
        aa: 0.2,
        ar: 16,
        ad: 64,
        as_: 16,
        dt: 0.0,
        ..Default::default()
    }
}

#[test]
fn integrating_sphere_follows_the_geometric_series() {
    let (s, v) = integrating_sphere();
    // Distance from the lamp to the wall point seen.
    let d2 = 1.0f64;
    let e = std::f64::consts::PI * LE * R_LAMP * R_LAMP / d2;
    let direct = RHO / std::f64::consts::PI * e;
    let (f0, st0) = render(&s, &v, 4, 4, ambient_opts(0));
    assert_eq!(st0.rays.ambient, 0);
    let l0 = mean_y(&f0);
    assert!((l0 - direct).abs() / direct < 0.02, "{l0} vs {direct}");
    for ab in 1..=3u32 {
        let (f, st) = render(&s, &v, 4, 4, ambient_opts(ab));
        let got = mean_y(&f) / l0;
        let expected = (1.0 - RHO.powi(ab as i32 + 1)) / (1.0 - RHO);
        // The lamp hides about (r / 1)^2 of each hemisphere from
        // inter-reflection: well below the tolerance.
        assert!(
            (got - expected).abs() / expected < 0.02,
            "-ab {ab}: ratio {got} vs {expected}"
        );
        assert!(st.rays.ambient > 0);
        let c = st.rays.ambient_cache;
        assert!(c.hits > 0 && c.hemispheres > 0, "{c:?}");
        assert!(st.ambient_records > 0);
        assert!(st.effects.diffuse_interreflection.enabled);
    }
}

#[test]
fn ab_zero_ignores_the_ambient_options() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let (a, sa) = render(&s, &v, 12, 12, RenderOptions::default());
    let (b, sb) = render(
        &s,
        &v,
        12,
        12,
        RenderOptions {
            aa: 0.3,
            ar: 8,
            ad: 16,
            as_: 2,
            ..Default::default()
        },
    );
    assert_eq!(a.pixels(), b.pixels());
    assert_eq!(sa.rays, sb.rays);
    assert!(!sa.effects.diffuse_interreflection.enabled);
    assert_eq!(sa.rays.ambient_cache.lookups, 0);
}

/// One cached bounce with few hemisphere rays: small renders of
/// Radiance's Cornell box.
fn one_bounce(seed: u64) -> RenderOptions {
    RenderOptions {
        ab: 1,
        ad: 32,
        as_: 8,
        seed,
        ..Default::default()
    }
}

#[test]
fn cached_render_is_deterministic_and_brighter() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let o = one_bounce(7);
    let (a, sa) = render(&s, &v, 12, 12, o.clone());
    let (b, sb) = render(&s, &v, 12, 12, o.clone());
    assert_eq!(a.pixels(), b.pixels());
    assert_eq!(sa.rays, sb.rays);
    let (d, _) = render(&s, &v, 12, 12, RenderOptions::default());
    assert!(
        a.mean_brightness() > 1.05 * d.mean_brightness(),
        "{} vs {} ({:?})",
        a.mean_brightness(),
        d.mean_brightness(),
        sa.rays
    );
    assert!(a
        .pixels()
        .iter()
        .all(|c| c.is_finite() && c.min_element() >= 0.0));
    // Another seed gives another (but similar) picture.
    let (c, _) = render(&s, &v, 12, 12, RenderOptions { seed: 8, ..o });
    assert_ne!(a.pixels(), c.pixels());
    assert!(mean_rel_diff(&a, &c) < 0.1);
}

#[test]
fn without_a_cache_tile_order_does_not_matter() {
    // -aa 0: every diffuse point samples its own hemisphere, so pixels are
    // independent again and tiles can be rendered in any order.
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let o = RenderOptions {
        ab: 1,
        aa: 0.0,
        ad: 8,
        as_: 0,
        ..Default::default()
    };
    let r = Renderer::new(&s, o).unwrap();
    let (w, h) = (6, 6);
    let (whole, stats) = r.render(&v, w, h).unwrap();
    assert_eq!(stats.ambient_records, 0);
    assert_eq!(stats.rays.ambient_cache.hits, 0);
    let mut film = Film::new(w, h);
    let mut st = TraceState::default();
    for (x0, y0) in [(3, 3), (0, 3), (3, 0), (0, 0)] {
        let region = Region::new(x0..x0 + 3, y0..y0 + 3);
        r.render_region(&v, w, h, &region, &mut film, &mut st);
    }
    assert_eq!(whole.pixels(), film.pixels());
}

#[test]
fn only_simulated_where_the_scene_calls_for_it() {
    // Only a mirror and a light: nothing diffuse to gather light.
    let s = scene(
        "void light l 0 0 3 1 1 1\n\
         void mirror m 0 0 3 .9 .9 .9\n\
         m polygon floor 0 0 12 -1 -1 0 1 -1 0 1 1 0 -1 1 0\n\
         l sphere lamp 0 0 4 0 0 2 0.3\n",
    );
    let v = view("-vtv -vp 0 -2 1 -vd 0 1 -0.5 -vh 40 -vv 40");
    let (_, st) = render(
        &s,
        &v,
        8,
        8,
        RenderOptions {
            ab: 2,
            ..Default::default()
        },
    );
    assert!(!st.effects.diffuse_interreflection.enabled);
    assert!(st
        .effects
        .diffuse_interreflection
        .reason
        .contains("no diffuse"));
    assert_eq!(st.rays.ambient, 0);
    assert_eq!(st.rays.ambient_cache.lookups, 0);
}

#[test]
fn pixel_samples_average_independent_streams() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let (one, s1) = render(&s, &v, 8, 8, RenderOptions::default());
    // Without jitter (and nothing else random) four samples see the same.
    let (four, s4) = render(
        &s,
        &v,
        8,
        8,
        RenderOptions {
            pn: 4,
            ..Default::default()
        },
    );
    assert_eq!(s4.rays.primary, 4 * s1.rays.primary);
    assert!(max_rel_diff(&one, &four, 0.0) < 1e-12);
    // With jitter every sample has its own position.
    let (jittered, _) = render(
        &s,
        &v,
        8,
        8,
        RenderOptions {
            pn: 4,
            pj: 1.0,
            ..Default::default()
        },
    );
    assert_ne!(one.pixels(), jittered.pixels());
    assert!(jittered.pixels().iter().all(|c| c.is_finite()));
}

#[test]
fn a_tiny_sweep_finds_a_front() {
    use hybrid_rt::experiment::sweep::{configurations, run};
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let reference = RenderOptions {
        ab: 1,
        ad: 16,
        as_: 4,
        pn: 2,
        pj: 1.0,
        ..Default::default()
    };
    let configs: Vec<_> = configurations(0)
        .into_iter()
        .filter(|c| ["defaults", "dt 0", "ab 1 aa .3 ad 64"].contains(&c.name.as_str()))
        .collect();
    assert_eq!(configs.len(), 3);
    let (report, film) = run("cornell", &s, &v, 6, 6, reference, &configs, &mut |_| {}).unwrap();
    assert_eq!(film.pixels().len(), 36);
    assert_eq!(report.points.len(), 3);
    assert!(report.points.iter().any(|p| p.pareto));
    // Inter-reflection brings the error down against a reference that has it.
    let err = |n: &str| report.points.iter().find(|p| p.name == n).unwrap().rel_rmse;
    assert!(err("ab 1 aa .3 ad 64") < err("defaults"));
    assert!(report.to_csv().lines().count() == 4);
    assert!(report.to_markdown().contains("**yes**"));
    assert!(report.chart().to_svg().unwrap().starts_with("<svg"));
}

#[test]
fn an_ambient_file_carries_the_cache_to_the_next_render() {
    // Radiance's `-af`: the second render of the same view reads the
    // first one's records from the file and samples (almost) no new
    // hemisphere; its picture differs only by the file's precision.
    use hybrid_rt::render::ambient::{append_ambient_file, read_ambient_file};
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let o = RenderOptions {
        ab: 1,
        aa: 0.2,
        ar: 64,
        ad: 64,
        as_: 16,
        ..Default::default()
    };
    let r = Renderer::new(&s, o.clone()).unwrap();
    let dir = std::env::temp_dir().join(format!("hybrid-rt-af-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cornell.amb");
    let _ = std::fs::remove_file(&path);
    let (first, st1, cache) = r
        .render_with_cache(&v, 32, 32, &mut |_| {}, Default::default())
        .unwrap();
    let made = st1.rays.ambient_cache.hemispheres;
    assert!(made > 50, "{made}");
    append_ambient_file(&path, &o, &cache.records_since(0)).unwrap();
    let file = read_ambient_file(&path).unwrap();
    assert_eq!(file.records.len(), cache.len());
    let (second, st2, _) = r
        .render_with_cache(&v, 32, 32, &mut |_| {}, r.ambient_cache(&file.records))
        .unwrap();
    let again = st2.rays.ambient_cache.hemispheres;
    assert!(
        again * 20 < made,
        "{again} of {made} hemispheres sampled again"
    );
    let d = mean_rel_diff(&first, &second);
    assert!(d < 0.01, "mean difference {d}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `-aw` moves the constant `-av` met past the last bounce towards the
/// cache's values (Radiance's moving average): `-aw 0` is the default
/// picture bit for bit; a weight changes the picture, brightening a dark
/// `-av`; a huge weight gives `-av` back; and the parallel renderer's
/// picture equals the sequential one bit for bit (every pixel averages the
/// records of its wave's cache and its own, in their order).
#[test]
fn ambient_weight_averages_the_constant_ambient() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let o = RenderOptions {
        av: hybrid_rt::scene::Color::splat(0.001),
        ..one_bounce(3)
    };
    let (plain, _) = render(&s, &v, 12, 12, o.clone());
    let mut zero = o.clone();
    zero.apply_words("-aw 0").unwrap();
    assert_eq!(render(&s, &v, 12, 12, zero).0.pixels(), plain.pixels());
    let mut weighted = o.clone();
    weighted.apply_words("-aw 2").unwrap();
    let (avg, _) = render(&s, &v, 12, 12, weighted.clone());
    assert!(
        avg.mean_brightness() > 1.01 * plain.mean_brightness(),
        "{} vs {}",
        avg.mean_brightness(),
        plain.mean_brightness()
    );
    let mut heavy = o.clone();
    heavy.aw = 1_000_000_000;
    let (back, _) = render(&s, &v, 12, 12, heavy);
    assert!(mean_rel_diff(&back, &plain) < 1e-6);
    let par = hybrid_rt::parallel::render_parallel(
        std::sync::Arc::new(s),
        weighted,
        &v,
        12,
        12,
        &hybrid_rt::parallel::ParallelOptions::new(3),
    )
    .unwrap();
    assert_eq!(par.film.pixels(), avg.pixels());
}
