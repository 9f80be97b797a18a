//! Participating media (`mist`, `-me -ma -mg -ms`) and spotlight focus
//! against analytic answers: Beer-Lambert transmittance, a furnace (a
//! scattering medium in a uniform radiance field neither gains nor loses
//! light), single scattering from a small source, the spotlight's focal
//! length in its solid angle; and the parallel renderer's picture equal to
//! the sequential one with media.

mod common;

use std::f64::consts::PI;
use std::sync::Arc;

use common::*;
use hybrid_rt::parallel::{render_parallel, Distribution, ParallelOptions, RuntimeKind};
use hybrid_rt::render::RenderOptions;
use hybrid_rt::scene::{load_rad_str, Color};

/// Mean luminance-like value (channel `k`) of a small render.
fn mean_channel(text: &str, view_opts: &str, n: usize, opts: RenderOptions, k: usize) -> f64 {
    let s = scene(text);
    let v = view(view_opts);
    let (film, _) = render(&s, &v, n, n, opts);
    film.pixels().iter().map(|c| c[k]).sum::<f64>() / film.pixels().len() as f64
}

/// A parallel view of a 1e-3 wide spot straight down the -z axis from `(x, 0, z)`.
fn axis_view(x: f64, z: f64) -> String {
    format!("-vtl -vp {x} 0 {z} -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001")
}

#[test]
fn spotlight_focal_length_sets_the_solid_angle() {
    // A spotlight disk of radius r at height h facing down onto a plastic
    // floor; its direction vector has length f. Radiance (srcray) counts
    // each sample's solid angle at its distance plus f: the irradiance on
    // the axis is L * integral over the disk of cos^2 / (d + f)^2.
    let (l, rho, r, h) = (10.0, 0.5, 0.2, 1.0);
    for f in [1.0, 3.5, 10.0] {
        let text = format!(
            "void spotlight spot 0 0 7 {l} {l} {l} 60 0 0 {}\n\
             void plastic floor_mat 0 0 5 {rho} {rho} {rho} 0 0\n\
             floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
             spot ring lamp 0 0 8 0 0 {h}  0 0 -1  0 {r}\n",
            -f
        );
        let n = 20_000;
        let mut e = 0.0;
        for i in 0..n {
            let p = r * (i as f64 + 0.5) / n as f64;
            let d = (h * h + p * p).sqrt();
            let cos = h / d;
            e += 2.0 * PI * p * (r / n as f64) * cos * cos / ((d + f) * (d + f));
        }
        let expected = rho / PI * l * e;
        let opts = RenderOptions {
            dt: 0.0,
            ..Default::default()
        };
        let got = mean_channel(&text, &axis_view(0.0, 0.5), 8, opts, 1);
        let err = (got - expected).abs() / expected;
        assert!(err < 0.01, "f {f}: {got} vs {expected} (err {err:.4})");
        // Without the focus the same source is brighter by about ((h+f)/h)^2.
        let plain = rho / PI * l * PI * r * r / (h * h + r * r);
        let focus = (h / (h + f)).powi(2);
        assert!(
            (got / plain - focus).abs() < 0.05 * focus,
            "f {f}: {got} is not about {focus} x the unfocused {plain}"
        );
    }
}

/// An emitting wall at z = -5 facing +z, seen from z = 5 through a mist
/// sphere of radius 1 at the origin.
fn beer_scene(mist_reals: &str) -> String {
    format!(
        "void light wall_mat 0 0 3 2 2 2\n\
         wall_mat polygon wall 0 0 12 -50 -50 -5  50 -50 -5  50 50 -5  -50 50 -5\n\
         void mist fog 0 0 {mist_reals}\n\
         fog sphere ball 0 0 4 0 0 0 1\n"
    )
}

#[test]
fn mist_transmittance_is_beer_lambert() {
    let ext = [0.1f64, 0.7, 2.5];
    let text = beer_scene(&format!("3 {} {} {}", ext[0], ext[1], ext[2]));
    for (k, e) in ext.iter().enumerate() {
        let got = mean_channel(&text, &axis_view(0.0, 5.0), 4, RenderOptions::default(), k);
        let expected = 2.0 * (-2.0 * e).exp();
        assert!(
            (got - expected).abs() < 1e-6 * expected,
            "channel {k}: {got} vs {expected}"
        );
    }
    // The global medium adds its extinction over the whole path (10), and
    // a mist's extinction adds to it inside.
    let opts = RenderOptions {
        me: Color::splat(0.05),
        ..Default::default()
    };
    let got = mean_channel(&text, &axis_view(0.0, 5.0), 4, opts, 1);
    let expected = 2.0 * (-0.05 * 10.0 - 2.0 * 0.7f64).exp();
    assert!(
        (got - expected).abs() < 1e-6 * expected,
        "{got} vs {expected}"
    );
    // A ray that misses the sphere sees the wall unattenuated.
    let got = mean_channel(&text, &axis_view(3.0, 5.0), 4, RenderOptions::default(), 2);
    assert!((got - 2.0).abs() < 1e-12, "{got}");
}

#[test]
fn scattering_medium_in_a_furnace_creates_no_energy() {
    // Inside a closed box of glow walls of radiance L (glows of radius 0
    // are not light sources) in a global medium lit by the same uniform
    // ambient L: with albedo 1 every ray returns exactly L, with less it
    // returns less, never more.
    let l = 0.8;
    let walls = "void glow g 0 0 4 0.8 0.8 0.8 0\n\
                 !genbox g box 4 4 4 -i | xform -t -2 -2 -2\n";
    let s = scene(walls);
    let v = view("-vtv -vp 0 0 0 -vd 1 0.3 0.2 -vu 0 0 1 -vh 90 -vv 90");
    for (albedo, sigma) in [(1.0, 0.3), (1.0, 3.0), (0.6, 0.3), (0.0, 1.0)] {
        let opts = RenderOptions {
            me: Color::splat(sigma),
            ma: Color::splat(albedo),
            mg: 0.4,
            av: Color::splat(l),
            ..Default::default()
        };
        let (film, _) = render(&s, &v, 8, 8, opts);
        for c in film.pixels() {
            for k in 0..3 {
                assert!(
                    c[k] <= l * (1.0 + 1e-9),
                    "albedo {albedo} sigma {sigma}: {c}"
                );
                if albedo == 1.0 {
                    assert!((c[k] - l).abs() < 1e-9 * l, "furnace: {c}");
                } else {
                    assert!(
                        c[k] < l * (1.0 - 1e-6),
                        "absorbing medium lost nothing: {c}"
                    );
                }
            }
        }
    }
}

/// A small sphere light at the origin inside a mist sphere (radius 3)
/// that names it; eye rays pass it at distance `dx`, then end on a black
/// wall.
fn scatter_scene(sigma: f64, albedo: f64) -> String {
    format!(
        "void light lamp_mat 0 0 3 100 100 100\n\
         lamp_mat sphere lamp 0 0 4 0 0 0 0.05\n\
         void plastic black 0 0 5 0 0 0 0 0\n\
         black polygon wall 0 0 12 -50 -50 -4  50 -50 -4  50 50 -4  -50 50 -4\n\
         void mist fog 1 lamp 0 6 {sigma} {sigma} {sigma} {albedo} {albedo} {albedo}\n\
         fog sphere cloud 0 0 4 0 0 0 3\n"
    )
}

/// Single scattering (isotropic) into an eye ray down the z axis through
/// a mist from z = `zmax` to `-zmax` (midpoint rule): `source(z)` gives the
/// source's radiance times solid angle seen from height `z` and the
/// length of the way to it through the mist, over which the absorbed part
/// attenuates it (srcscatter()).
fn single_scattering(
    sigma: f64,
    albedo: f64,
    zmax: f64,
    source: impl Fn(f64) -> (f64, f64),
) -> f64 {
    let n = 100_000;
    let dz = 2.0 * zmax / n as f64;
    (0..n)
        .map(|i| {
            let z = zmax - (i as f64 + 0.5) * dz;
            let (l_omega, way) = source(z);
            let to_eye = (-sigma * (zmax - z)).exp();
            let to_source = (-sigma * (1.0 - albedo) * way).exp();
            sigma * albedo / (4.0 * PI) * l_omega * to_eye * to_source * dz
        })
        .sum()
}

#[test]
fn single_scattering_from_a_small_source_matches_the_integral() {
    let (sigma, albedo, dx, a, l) = (0.2, 0.8, 1.0, 0.05, 100.0);
    let text = scatter_scene(sigma, albedo);
    let zmax = (9.0f64 - dx * dx).sqrt();
    // srcscatter with an isotropic phase: sigma * albedo / (4 pi) * L *
    // omega, attenuated to the eye over the mist and to the source by
    // the absorbed part only.
    let expected = single_scattering(sigma, albedo, zmax, |z| {
        let d2 = dx * dx + z * z;
        // Radiance attenuates a shadow ray up to where it meets the
        // sphere (rayparticipate() over its length).
        (l * PI * a * a / d2, d2.sqrt() - a)
    });
    let opts = RenderOptions {
        ms: 0.05,
        pj: 1.0,
        ..Default::default()
    };
    let got = mean_channel(&text, &axis_view(dx, 5.0), 24, opts, 0);
    let err = (got - expected).abs() / expected;
    assert!(err < 0.02, "{got} vs {expected} (err {err:.4})");
    // Without the source in its list the mist scatters nothing from it.
    let unlisted = text.replace("1 lamp 0 6", "0 0 6");
    let got = mean_channel(
        &unlisted,
        &axis_view(dx, 5.0),
        4,
        RenderOptions::default(),
        0,
    );
    assert_eq!(got, 0.0);
}

#[test]
fn mist_errors_name_file_and_line() {
    for (text, line, needle) in [
        (
            "void mist m\n0\n0\n4 1 1 1 1\n",
            1,
            "expected 0 or 3 or 6 or 7 real arguments",
        ),
        ("\n\nvoid mist m\n0\n0\n3 -1 0 0\n", 3, "not negative"),
        (
            "void mist m\n0\n0\n7 .1 .1 .1 .5 .5 .5 2\n",
            1,
            "eccentricity",
        ),
        ("void mist m\n0\n1 3\n0\n", 1, "integer"),
        (
            "# a\nvoid spotlight s\n0\n0\n7 1 1 1 30 0 0 0\n",
            2,
            "zero focus vector",
        ),
    ] {
        match load_rad_str(text, "bad.rad") {
            Err(hybrid_rt::Error::Parse { loc, reason }) => {
                assert_eq!(loc.line, line, "{reason}");
                assert!(loc.file.ends_with("bad.rad"), "{loc:?}");
                assert!(reason.contains(needle), "{reason:?} lacks {needle:?}");
            }
            other => panic!("{text:?}: expected a parse error, got {other:?}"),
        }
    }
}

#[test]
fn parallel_renders_equal_the_sequential_one_with_media() {
    // In-scattering bundles, mist crossings of rays and shadow rays, the
    // global medium and a spotlight: every parallel runtime and
    // distribution gives the sequential picture bit for bit.
    let text = format!(
        "{}\n\
         void spotlight spot 0 0 7 50 40 30 40 0.5 0 -2\n\
         spot ring sl 0 0 8 0.5 1 1.5  0.5 0 -2  0 0.1\n\
         void mist beam 1 sl 0 0\n\
         beam sphere beam_ball 0 0 4 0.5 1 0.5 1.2\n\
         void plastic grey 0 0 5 .5 .5 .5 0 0\n\
         grey sphere blob 0 0 4 -0.5 -0.5 -1 0.5\n",
        scatter_scene(0.3, 0.7)
    );
    let s = scene(&text);
    let v = view("-vtv -vp 0 0 5 -vd 0 0 -1 -vu 0 1 0 -vh 60 -vv 60");
    let opts = RenderOptions {
        ms: 0.3,
        me: Color::splat(0.01),
        ma: Color::splat(0.5),
        mg: 0.2,
        av: Color::splat(0.05),
        dj: 0.5,
        ..Default::default()
    };
    let (seq, _) = render(&s, &v, 24, 24, opts.clone());
    assert!(seq.pixels().iter().any(|c| c.x > 0.0));
    let scene = Arc::new(s);
    for (runtime, distribution) in [
        (RuntimeKind::Threads, Distribution::Octree),
        (RuntimeKind::Sim, Distribution::Octree),
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

#[test]
fn xform_scales_mist_extinction_and_prefixes_its_sources() {
    // Radiance's xform (m_mist): extinction per unit length divides by the
    // scale; with -n the source names get the prefix.
    let dir = std::env::temp_dir().join(format!("hybrid-rt-mist-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("fog.rad");
    std::fs::write(&file, "void mist fog 2 lamp a>b 0 6 .2 .4 .8 .5 .5 .5\n").unwrap();
    let s = load_rad_str(
        &format!("!xform -n pre -s 2 {}\n", file.display()),
        dir.join("main.rad"),
    )
    .unwrap();
    let m = s
        .materials
        .iter()
        .find(|m| matches!(m, hybrid_rt::scene::Material::Mist { .. }))
        .unwrap();
    assert_eq!(
        *m,
        hybrid_rt::scene::Material::Mist {
            extinction: Color::new(0.1, 0.2, 0.4),
            albedo: Some(Color::splat(0.5)),
            gecc: None,
            sources: vec!["pre.lamp".into(), "pre.a>pre.b".into()],
        }
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn back_faces_are_invisible_with_bv_off() {
    // A plastic wall seen from behind in front of an emitter: -bv (the
    // default) shows the wall (black here: nothing lights it), -bv- lets
    // the ray through to the emitter; trans keeps its back face (m_normal).
    for (mat, through) in [("plastic", true), ("trans", false)] {
        let reals = if mat == "plastic" {
            "5 .5 .5 .5 0 0"
        } else {
            "7 .5 .5 .5 0 0 .5 0"
        };
        let text = format!(
            "void light lit 0 0 3 3 3 3\n\
             lit polygon back 0 0 12 -50 -50 -5  50 -50 -5  50 50 -5  -50 50 -5\n\
             void {mat} wall_mat 0 0 {reals}\n\
             wall_mat polygon wall 0 0 12 -9 -9 0  -9 9 0  9 9 0  9 -9 0\n"
        );
        let v = axis_view(0.0, 5.0);
        let shown = mean_channel(&text, &v, 4, RenderOptions::default(), 0);
        let mut o = RenderOptions::default();
        o.apply_words("-bv-").unwrap();
        let hidden = mean_channel(&text, &v, 4, o, 0);
        assert!(
            shown < 3.0,
            "{mat}: the back face hides the emitter: {shown}"
        );
        if through {
            assert_eq!(hidden, 3.0, "{mat} -bv-");
        } else {
            assert_eq!(hidden, shown, "{mat}: -bv- does not apply");
        }
    }
}

#[test]
fn hemisphere_samples_measure_distance_through_mist_boundaries() {
    // A floor under a lamp and a ceiling, with and without a sheet of
    // clear mist 0.01 above the floor (as the suite's mist box lies just
    // inside its walls). Radiance's raytrans() counts a sample's distance
    // to the surface beyond the sheet, so the sheet changes nothing in the
    // records' radii: about as many hemispheres either way. Counted to the
    // sheet, every sample would be 0.01 away and every record the
    // smallest `-ar` allows.
    let room = "void plastic grey 0 0 5 .5 .5 .5 0 0\n\
                grey polygon floor 0 0 12 -10 -10 0  10 -10 0  10 10 0  -10 10 0\n\
                grey polygon ceiling 0 0 12 -10 -10 6  -10 10 6  10 10 6  10 -10 6\n\
                void light lamp 0 0 3 50 50 50\n\
                lamp polygon bulb 0 0 12 -.5 -.5 5  -.5 .5 5  .5 .5 5  .5 -.5 5\n";
    let sheet = "void mist veil 0 0 3 0 0 0\n\
                 veil polygon sheet 0 0 12 -10 -10 .01  10 -10 .01  10 10 .01  -10 10 .01\n";
    let v = view("-vtv -vp 0 0 4 -vd 0 0 -1 -vu 0 1 0 -vh 90 -vv 90");
    let mut o = RenderOptions::default();
    o.apply_words("-ab 1 -aa .1 -ar 64 -ad 256 -as 0 -av 0 0 0")
        .unwrap();
    let count = |text: &str| {
        let (_, stats) = render(&scene(text), &v, 24, 24, o.clone());
        stats.rays.ambient_cache.hemispheres
    };
    let clear = count(room);
    let veiled = count(&format!("{room}{sheet}"));
    assert!(clear > 0);
    assert!(
        (veiled as f64) < 1.2 * clear as f64 + 2.0,
        "the sheet multiplied the hemispheres: {veiled} against {clear}"
    );
}

/// A mist may name a distant source by its `source` primitive's name: a
/// sun straight overhead scatters into eye rays down the middle of a mist
/// sphere as the single-scattering integral says (its light attenuated by
/// the absorbed part over the way up and out of the sphere).
#[test]
fn mist_scatters_a_named_distant_source() {
    let (sigma, albedo, r, l, angle): (f64, f64, f64, f64, f64) = (0.2, 0.8, 3.0, 100.0, 5.0);
    let text = format!(
        "void light sun_mat 0 0 3 {l} {l} {l}\n\
         sun_mat source sun 0 0 4 0 0 1 {angle}\n\
         void plastic black 0 0 5 0 0 0 0 0\n\
         black polygon wall 0 0 12 -50 -50 -4  50 -50 -4  50 50 -4  -50 50 -4\n\
         void mist fog 1 sun 0 6 {sigma} {sigma} {sigma} {albedo} {albedo} {albedo}\n\
         fog sphere cloud 0 0 4 0 0 0 {r}\n"
    );
    let s = scene(&text);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let omega = 2.0 * PI * (1.0 - (0.5 * angle).to_radians().cos());
    let expected = single_scattering(sigma, albedo, r, |z| (l * omega, r - z));
    let opts = RenderOptions {
        ms: 0.05,
        pj: 1.0,
        ..Default::default()
    };
    let got = mean_channel(&text, &axis_view(0.0, 5.0), 24, opts, 0);
    let err = (got - expected).abs() / expected;
    eprintln!("distant source in a mist: {got} vs {expected}");
    assert!(err < 0.02, "{got} vs {expected} (err {err:.4})");
}

/// A mist may name a virtual source as Radiance does, `mirror>lamp`: the
/// light a lamp scatters into eye rays by way of a mirror equals the
/// mirror's reflectance times what a lamp at its image scatters.
#[test]
fn mist_scatters_a_named_relayed_source() {
    let (sigma, albedo, rm) = (0.2, 0.8, 0.7);
    // A small square lamp in the plane x = lamp_x, facing +x (towards the
    // mirror) or -x (its image, towards the eye rays).
    let scene_text = |lamp_x: f64, mirror: bool, names: &str| {
        let (a, b) = if mirror { (0.05, -0.05) } else { (-0.05, 0.05) };
        format!(
            "void light lamp_mat 0 0 3 100 100 100\n\
             lamp_mat polygon lamp 0 0 12 {lamp_x} {a} -.05  {lamp_x} {a} .05  {lamp_x} {b} .05  {lamp_x} {b} -.05\n\
             void plastic black 0 0 5 0 0 0 0 0\n\
             black polygon floor 0 0 12 -50 -50 -4  50 -50 -4  50 50 -4  -50 50 -4\n\
             {}\
             void mist fog {names} 0 6 {sigma} {sigma} {sigma} {albedo} {albedo} {albedo}\n\
             fog sphere cloud 0 0 4 0 0 0 10\n",
            if mirror {
                format!(
                    "void mirror silver 0 0 3 {rm} {rm} {rm}\n\
                     silver polygon wall 0 0 12 1.5 -20 -20  1.5 -20 20  1.5 20 20  1.5 20 -20\n"
                )
            } else {
                String::new()
            }
        )
    };
    let opts = RenderOptions {
        ms: 0.1,
        pj: 1.0,
        ..Default::default()
    };
    let relayed_text = scene_text(0.0, true, "1 wall>lamp");
    let s = scene(&relayed_text);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let relayed = mean_channel(&relayed_text, &axis_view(0.5, 12.0), 8, opts.clone(), 0);
    let image = mean_channel(
        &scene_text(3.0, false, "1 lamp"),
        &axis_view(0.5, 12.0),
        8,
        opts.clone(),
        0,
    );
    eprintln!("through the mirror {relayed}, from the image {image}");
    assert!(image > 0.0);
    assert!(
        (relayed / image - rm).abs() < 1e-6,
        "{relayed} vs {rm} x {image}"
    );
    // A relay name that matches no virtual source is reported.
    let s = scene(&scene_text(0.0, true, "1 floor>lamp"));
    let r = hybrid_rt::render::Renderer::new(&s, opts).unwrap();
    assert!(
        r.warnings()
            .iter()
            .any(|w| w.contains("unknown source \"floor>lamp\"")),
        "{:?}",
        r.warnings()
    );
}

/// A shadow ray to a sphere source in a medium is attenuated up to where it
/// meets the sphere, as Radiance's (the sample lies on the disk through its
/// centre, half a radius or more further on).
#[test]
fn shadow_rays_to_a_sphere_in_a_medium_stop_at_its_surface() {
    let (h, radius, sigma) = (2.0, 0.5, 1.0);
    let text = format!(
        "void light lamp_mat 0 0 3 10 10 10\n\
         lamp_mat sphere lamp 0 0 4 0 0 {h} {radius}\n\
         void plastic floor_mat 0 0 5 .5 .5 .5 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n"
    );
    let mut clear = RenderOptions::default();
    clear
        .apply_words("-ds 0 -dj 0 -dt 0 -av 0 0 0 -ab 0")
        .unwrap();
    let mut murky = clear.clone();
    murky
        .apply_words(&format!("-me {sigma} {sigma} {sigma} -ma 0 0 0"))
        .unwrap();
    let eye = 0.05;
    let a = mean_channel(&text, &axis_view(0.0, eye), 2, clear, 0);
    let b = mean_channel(&text, &axis_view(0.0, eye), 2, murky, 0);
    let want = (-sigma * (eye + h - radius)).exp();
    eprintln!("attenuation {} (want {want})", b / a);
    assert!((b / a / want - 1.0).abs() < 1e-6, "{} vs {want}", b / a);
}
