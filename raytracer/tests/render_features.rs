//! Effects the scene calls for, adaptive shadow testing, determinism.

mod common;

use common::*;
use hybrid_rt::image::Film;
use hybrid_rt::render::{Region, RenderOptions, Renderer, TraceState};

const DIFFUSE: &str = "void light lamp 0 0 3 10 10 10\n\
    void plastic w 0 0 5 .6 .6 .6 0 .05\n\
    lamp polygon light 0 0 12 -0.2 -0.2 1.9  -0.2 0.2 1.9  0.2 0.2 1.9  0.2 -0.2 1.9\n\
    w polygon floor 0 0 12 -2 -2 0  2 -2 0  2 2 0  -2 2 0\n\
    w sphere ball 0 0 4 0.3 0 0.4 0.4\n";

#[test]
fn diffuse_scene_spawns_no_reflection_or_refraction() {
    let s = scene(DIFFUSE);
    let v = view("-vtv -vp 0 -3 1.5 -vd 0 1 -0.5 -vu 0 0 1 -vh 60 -vv 60");
    let (_, stats) = render(&s, &v, 32, 32, RenderOptions::default());
    assert_eq!(stats.rays.reflection, 0);
    assert_eq!(stats.rays.refraction, 0);
    assert!(!stats.effects.reflection.enabled);
    assert!(
        stats.effects.reflection.reason.contains("no mirror"),
        "{}",
        stats.effects.reflection.reason
    );
    assert!(!stats.effects.refraction.enabled);
    assert!(stats.effects.refraction.reason.contains("no glass"));
    assert!(stats.effects.area_shadows.enabled);
    assert!(stats.rays.shadow.bundles > 0);
    // The JSON names both.
    let json = serde_json::to_value(&stats).unwrap();
    assert_eq!(json["effects"]["reflection"]["enabled"], false);
}

#[test]
fn scene_without_lights_builds_no_shadow_bundles() {
    let s = scene("void plastic w 0 0 5 .6 .6 .6 0 0\nw sphere b 0 0 4 0 0 0 1\n");
    let v = view("-vtv -vp 0 -3 0 -vd 0 1 0 -vu 0 0 1");
    let opts = RenderOptions {
        av: hybrid_rt::scene::Color::splat(0.1),
        ..Default::default()
    };
    let (film, stats) = render(&s, &v, 16, 16, opts);
    assert_eq!(stats.rays.shadow.bundles, 0);
    assert!(!stats.effects.area_shadows.enabled);
    assert!(stats.effects.area_shadows.reason.contains("no area light"));
    assert!(stats.effects.ambient.enabled);
    assert!(film.mean_brightness() > 0.0);
}

#[test]
fn empty_scene_is_an_error_and_unlit_scene_warns() {
    let empty = scene("# nothing here\n");
    let Err(err) = Renderer::new(&empty, RenderOptions::default()) else {
        panic!("an empty scene must not render a black image silently");
    };
    assert!(err.to_string().contains("scene is empty"), "{err}");

    let unlit = scene("void plastic w 0 0 5 .6 .6 .6 0 0\nw sphere b 0 0 4 0 0 0 1\n");
    let r = Renderer::new(&unlit, RenderOptions::default()).unwrap();
    assert!(
        r.warnings().iter().any(|w| w.contains("no light sources")),
        "{:?}",
        r.warnings()
    );
    let diffuse = scene(DIFFUSE);
    let lit = Renderer::new(&diffuse, RenderOptions::default()).unwrap();
    assert!(!lit
        .warnings()
        .iter()
        .any(|w| w.contains("no light sources")));
}

#[test]
fn mirror_scene_reflects() {
    let s = scene(&format!("{DIFFUSE}void mirror m 0 0 3 .9 .9 .9\nm polygon mir 0 0 12 -2 2 0  2 2 0  2 2 2  -2 2 2\n"));
    let v = view("-vtv -vp 0 -3 1.5 -vd 0 1 -0.2 -vu 0 0 1 -vh 60 -vv 60");
    let (_, stats) = render(&s, &v, 16, 16, RenderOptions::default());
    assert!(stats.effects.reflection.enabled);
    assert!(stats.rays.reflection > 0);
    assert_eq!(stats.rays.refraction, 0);
    let (_, stats0) = render(
        &s,
        &v,
        16,
        16,
        RenderOptions {
            lr: 0,
            ..Default::default()
        },
    );
    assert_eq!(stats0.rays.reflection, 0);
    assert!(stats0.effects.reflection.reason.contains("-lr 0"));
}

/// Several sources of very different power and an occluder: adaptive
/// testing traces fewer shadow rays and stays close to testing all.
#[test]
fn adaptive_shadow_testing_saves_rays_within_tolerance() {
    let mut t = String::from(
        "void light bright 0 0 3 50 50 50\n\
         void light dim 0 0 3 0.5 0.5 0.5\n\
         void plastic w 0 0 5 .6 .6 .6 0 0\n\
         bright polygon l0 0 0 12 -0.3 -0.3 3  -0.3 0.3 3  0.3 0.3 3  0.3 -0.3 3\n\
         w polygon floor 0 0 12 -4 -4 0  4 -4 0  4 4 0  -4 4 0\n\
         w polygon blocker 0 0 12 -0.5 -0.5 1  0.5 -0.5 1  0.5 0.5 1  -0.5 0.5 1\n",
    );
    for (i, (x, y)) in [
        (-2.0, -2.0),
        (2.0, -2.0),
        (-2.0, 2.0),
        (2.0, 2.0),
        (0.0, 2.5),
        (2.5, 0.0),
    ]
    .iter()
    .enumerate()
    {
        t += &format!(
            "dim polygon d{i} 0 0 12 {a} {b} 2  {a} {d} 2  {c} {d} 2  {c} {b} 2\n",
            a = x - 0.3,
            b = y - 0.3,
            c = x + 0.3,
            d = y + 0.3
        );
    }
    let s = scene(&t);
    let v = view("-vtv -vp 0 -5 4 -vd 0 1 -0.8 -vu 0 0 1 -vh 60 -vv 60");
    let all = RenderOptions {
        dt: 0.0,
        dj: 0.5,
        ..Default::default()
    };
    let (f0, s0) = render(&s, &v, 48, 48, all.clone());
    assert_eq!(s0.rays.shadow.estimated, 0, "-dt 0 traces every patch");
    assert_eq!(s0.rays.shadow.tested, s0.rays.shadow.patches);
    let mut prev = s0.rays.shadow.tested;
    for dt in [0.05, 0.2] {
        let (f, st) = render(&s, &v, 48, 48, RenderOptions { dt, ..all.clone() });
        assert!(
            st.rays.shadow.tested < prev,
            "-dt {dt}: {} rays, not fewer than {prev}",
            st.rays.shadow.tested
        );
        assert!(st.rays.shadow.estimated > 0);
        assert_eq!(
            st.rays.shadow.tested + st.rays.shadow.estimated,
            st.rays.shadow.patches
        );
        prev = st.rays.shadow.tested;
        let d = mean_rel_diff(&f0, &f);
        assert!(d < 0.05, "-dt {dt}: image differs by {d:.4} on average");
    }
}

fn cornell() -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    (scene(RADIANCE_CORNELL), view(RADIANCE_CORNELL_VIEW))
}

/// Rendering the image by rows, by shuffled tiles or all at once gives
/// bit-identical pixels (jittered sources and pixels included).
#[test]
fn tile_order_does_not_change_pixels() {
    let (s, v) = cornell();
    let opts = RenderOptions {
        dj: 0.7,
        pj: 0.5,
        seed: 42,
        ..Default::default()
    };
    let r = Renderer::new(&s, opts).unwrap();
    let (w, h) = (40, 30);
    let (whole, stats) = r.render(&v, w, h).unwrap();
    // Bottom-up rows.
    let mut rows = Film::new(w, h);
    let mut st = TraceState::default();
    for y in (0..h).rev() {
        r.render_region(&v, w, h, &Region::new(0..w, y..y + 1), &mut rows, &mut st);
    }
    assert_eq!(whole, rows);
    assert_eq!(st.counts, stats.rays, "ray counts do not depend on order");
    // 7x4 tiles in a scrambled order, each with its own state.
    let mut tiles = Vec::new();
    for ty in (0..h).step_by(4) {
        for tx in (0..w).step_by(7) {
            tiles.push(Region::new(tx..(tx + 7).min(w), ty..(ty + 4).min(h)));
        }
    }
    let n = tiles.len();
    let mut tiled = Film::new(w, h);
    for k in 0..n {
        let t = &tiles[(k * 17 + 5) % n];
        r.render_region(&v, w, h, t, &mut tiled, &mut TraceState::default());
    }
    assert_eq!(whole, tiled);
    // A different seed changes the jittered image.
    let r2 = Renderer::new(
        &s,
        RenderOptions {
            seed: 43,
            ..r.options().clone()
        },
    )
    .unwrap();
    assert_ne!(whole, r2.render(&v, w, h).unwrap().0);
}

/// Primary rays traced as packets of a tile (the renderer's way) give
/// the pixels of rays traced one at a time, bit for bit: through the
/// hierarchy without packets and through the octree.
#[test]
fn primary_packets_equal_rays_one_at_a_time() {
    use hybrid_rt::render::{BvhCaster, RayCaster};
    /// The renderer's hierarchy, asked one ray at a time.
    struct OneAtATime<'a>(BvhCaster<'a>);
    impl RayCaster for OneAtATime<'_> {
        fn intersect(
            &self,
            ray: &hybrid_rt::geometry::Ray,
            tmin: f64,
            tmax: f64,
        ) -> Option<hybrid_rt::accel::Hit> {
            self.0.intersect(ray, tmin, tmax)
        }
        fn occluded(
            &self,
            ray: &hybrid_rt::geometry::Ray,
            tmin: f64,
            tmax: f64,
            ignore: Option<hybrid_rt::scene::ObjectId>,
        ) -> bool {
            self.0.occluded(ray, tmin, tmax, ignore)
        }
    }
    let (s, v) = cornell();
    let opts = RenderOptions {
        dj: 0.7,
        pj: 0.67,
        seed: 7,
        ..Default::default()
    };
    let r = Renderer::new(&s, opts).unwrap();
    // Not a multiple of the tile side, so edge tiles are partial.
    let (w, h) = (45, 37);
    let (whole, stats) = r.render(&v, w, h).unwrap();
    assert_eq!(stats.rays.primary, (w * h) as u64);
    let single = OneAtATime(r.caster());
    assert!(r.caster().traces_packets() && !single.traces_packets());
    for (name, film) in [
        ("one at a time", one_at_a_time(&r, &v, (w, h), &single)),
        (
            "the octree",
            one_at_a_time(&r, &v, (w, h), &r.octree_caster()),
        ),
    ] {
        assert!(whole == film, "packets differ from {name}");
    }
}

fn one_at_a_time<C: hybrid_rt::render::RayCaster>(
    r: &Renderer<'_>,
    v: &hybrid_rt::scene::View,
    (w, h): (usize, usize),
    caster: &C,
) -> Film {
    let mut film = Film::new(w, h);
    let mut st = TraceState::default();
    for y in 0..h {
        for x in 0..w {
            film.set(x, y, r.pixel_with(v, (w, h), caster, (x, y), &mut st));
        }
    }
    film
}

/// The Radiance Cornell box looks like itself: red wall left, blue right,
/// lit floor, the light at the top, a sphere near the floor.
#[test]
fn radiance_cornell_box_layout() {
    let (s, v) = cornell();
    let (film, stats) = render(&s, &v, 64, 64, RenderOptions::default());
    let px = |x: usize, y: usize| film.get(x, y);
    let left = px(3, 32);
    let right = px(60, 32);
    assert!(left.x > 2.0 * left.z, "left wall is red: {left}");
    assert!(right.z > 2.0 * right.x, "right wall is blue: {right}");
    // The light source, seen directly at the top centre, is the brightest.
    let top = px(32, 1);
    assert!(top.x >= 99.0, "light at the top centre: {top}");
    assert!(
        stats.rays.refraction > 0 && stats.rays.reflection > 0,
        "dielectric sphere"
    );
    assert!(film.pixels().iter().all(|c| c.is_finite()));
}

/// Pattern functions that go wrong are counted in the render's statistics
/// (and the first named), never printed per ray and never a crash.
#[test]
fn pattern_errors_are_counted_in_the_report() {
    let dir = std::env::temp_dir().join(format!("hybrid-rt-paterr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("bad.cal"),
        "deep(x) = deep(x + 1) + 1;\nloop = deep(Px);\n",
    )
    .unwrap();
    let text = "void light lamp 0 0 3 10 10 10\n\
        void brightfunc oops 2 sqrt(-1) . 0 0\n\
        void brightfunc forever 2 loop bad.cal 0 0\n\
        oops plastic w 0 0 5 .6 .6 .6 0 0\n\
        forever plastic v 0 0 5 .6 .6 .6 0 0\n\
        lamp polygon light 0 0 12 -0.2 -0.2 1.9  -0.2 0.2 1.9  0.2 0.2 1.9  0.2 -0.2 1.9\n\
        w polygon floor 0 0 12 -2 -2 0  2 -2 0  2 2 0  -2 2 0\n\
        v sphere ball 0 0 4 0.3 0 0.4 0.4\n";
    let s = hybrid_rt::scene::load_rad_str(text, dir.join("s.rad")).unwrap();
    let v = view("-vtv -vp 0 -3 1.5 -vd 0 1 -0.5 -vu 0 0 1 -vh 60 -vv 60");
    let (film, stats) = render(&s, &v, 16, 16, RenderOptions::default());
    let e = &stats.pattern_errors;
    assert!(e.math_errors > 0, "{e:?}");
    assert!(e.failures > 0, "{e:?}");
    let first = e.first.as_deref().unwrap();
    assert!(
        first.contains("forever") && first.contains("s.rad"),
        "{first}"
    );
    assert!(stats.effects.patterns.enabled);
    // The floor reads the failed brightness as 0 (black); the ball is unpatterned.
    assert!(film.mean_brightness() > 0.0);
    std::fs::remove_dir_all(&dir).ok();
}
