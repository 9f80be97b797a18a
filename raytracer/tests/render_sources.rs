//! Light sources as Radiance's `m_light()` and `sourcehit()` treat them,
//! checked against values known in closed form: what an indirect ray may
//! see of a source, what a shadow ray may pass, what a ray leaving the
//! scene sees.

mod common;

use common::*;
use hybrid_rt::render::RenderOptions;

const L: f64 = 10.0;
const RHO: f64 = 0.5;
const PI: f64 = std::f64::consts::PI;

/// E under the centre of a square of side 2a at height h.
fn square_irradiance(radiance: f64, a: f64, h: f64) -> f64 {
    let x = a / h;
    let s = (1.0 + x * x).sqrt();
    4.0 * radiance * (x / s) * (x / s).atan()
}

/// A floor at z = 0 and `extra`; the mean radiance of a tiny spot under
/// the origin seen straight down.
fn floor_radiance(extra: &str, opts: &str) -> f64 {
    let text = format!(
        "void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         {extra}\n"
    );
    let s = scene(&text);
    let v = view("-vtl -vp 0 0 0.2 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001");
    let mut o = RenderOptions::default();
    o.apply_words(opts).unwrap();
    let (film, _) = render(&s, &v, 4, 4, o);
    film.pixels().iter().map(|c| c.y).sum::<f64>() / film.pixels().len() as f64
}

/// A square emitter of side 2a at height h facing down, made of `mat`.
fn square(mat: &str, a: f64, h: f64) -> String {
    let m = -a;
    format!("{mat} polygon lamp 0 0 12 {m} {m} {h}  {m} {a} {h}  {a} {a} {h}  {a} {m} {h}")
}

/// Radiance's `distglow`: a glow with a negative radius never takes part
/// in illumination (neither as a source nor through the ambient
/// calculation); one with radius 0 lights only indirectly.
#[test]
fn glow_of_negative_radius_lights_nothing_indirectly() {
    let (a, h) = (0.5, 1.0);
    let ambient = "-ab 1 -aa 0 -ad 4096 -as 0 -av 0 0 0 -lw 1e-6";
    let neg = floor_radiance(
        &format!("void glow g 0 0 4 {L} {L} {L} -1\n{}", square("g", a, h)),
        ambient,
    );
    assert_eq!(neg, 0.0, "a glow with negative radius lit the floor");
    let zero = floor_radiance(
        &format!("void glow g 0 0 4 {L} {L} {L} 0\n{}", square("g", a, h)),
        ambient,
    );
    let expected = RHO / PI * square_irradiance(L, a, h);
    let err = (zero - expected).abs() / expected;
    assert!(err < 0.05, "radius 0: {zero} vs {expected} (err {err:.3})");
}

/// The back of a light source is black (`m_light`: "check for behind").
#[test]
fn back_of_a_source_is_black() {
    // The lamp faces up (counter-clockwise seen from above): the floor
    // sees its back, and so does the camera looking down at it.
    let (a, h) = (0.5, 0.1);
    let m = -a;
    let up = format!(
        "void light l 0 0 3 {L} {L} {L}\n\
         l polygon lamp 0 0 12 {m} {m} {h}  {a} {m} {h}  {a} {a} {h}  {m} {a} {h}"
    );
    let text = format!("{up}\n");
    let s = scene(&text);
    let v = view("-vtl -vp 0 0 1 -vd 0 0 -1 -vu 0 1 0 -vh 0.1 -vv 0.1");
    let (film, _) = render(&s, &v, 4, 4, RenderOptions::default());
    assert!(film.pixels().iter().all(|c| c.max_element() > 0.0));
    let v = view("-vtl -vp 0 0 0.05 -vd 0 0 1 -vu 0 1 0 -vh 0.1 -vv 0.1");
    let (film, _) = render(&s, &v, 4, 4, RenderOptions::default());
    assert!(
        film.pixels()
            .iter()
            .all(|c| *c == hybrid_rt::scene::Color::ZERO),
        "the back of a light is visible"
    );
}

/// An ambient ray that reaches a light through glass must not count it:
/// direct lighting already brings it through the glass. With nothing
/// else to reflect, `-ab 1` adds only the glass's own reflection of the
/// floor (a few per cent), never the light a second time.
#[test]
fn ambient_rays_through_glass_do_not_count_the_light_again() {
    let (a, h) = (0.5, 1.0);
    let scene_text = format!(
        "void light l 0 0 3 {L} {L} {L}\n{}\n\
         void glass clear 0 0 3 .9 .9 .9\n\
         clear polygon pane 0 0 12 -3 -3 0.5  -3 3 0.5  3 3 0.5  3 -3 0.5",
        square("l", a, h)
    );
    let direct = floor_radiance(&scene_text, "-ab 0 -av 0 0 0 -dt 0");
    let with_ambient = floor_radiance(
        &scene_text,
        "-ab 1 -aa 0 -ad 2048 -as 0 -av 0 0 0 -dt 0 -lw 1e-6",
    );
    assert!(direct > 0.0);
    let gain = with_ambient / direct - 1.0;
    assert!(
        (0.0..0.08).contains(&gain),
        "-ab 1 adds {:.1}% to the direct light through glass",
        gain * 100.0
    );
}

/// Radiance's `illumblock`: a shadow ray aimed at a glow source is
/// blocked by an illum it meets from the front (the illum already
/// accounts for what lies behind it); a shadow ray to a `light` passes.
#[test]
fn illum_blocks_shadow_rays_to_glows_behind_it() {
    let (a, h) = (0.5, 1.0);
    // The illum: transparent (void alternate), facing down at height 1.
    let illum = format!("void illum win 0 0 3 {L} {L} {L}\n{}", square("win", a, h));
    // A large glow source above it (radius 100: sampled as a source).
    let glow = format!(
        "void glow sky 0 0 4 {L} {L} {L} 100\n{}",
        square("sky", 4.0, 2.0).replace("lamp", "skypanel")
    );
    let only_illum = floor_radiance(&illum, "-ab 0 -av 0 0 0 -dt 0");
    let expected = RHO / PI * square_irradiance(L, a, h);
    let err = (only_illum - expected).abs() / expected;
    assert!(err < 0.02, "illum alone: {only_illum} vs {expected}");
    let both = floor_radiance(&format!("{illum}\n{glow}"), "-ab 0 -av 0 0 0 -dt 0");
    let glow_alone = floor_radiance(&glow, "-ab 0 -av 0 0 0 -dt 0");
    // What the glow gives outside the illum's solid angle, plus the illum.
    let glow_outside = glow_alone - RHO / PI * square_irradiance(L, a, h);
    let expected = only_illum + glow_outside;
    let err = (both - expected).abs() / expected;
    assert!(
        err < 0.03,
        "illum + glow: {both} vs {expected} (glow alone {glow_alone}); the glow passed through the illum"
    );
}

/// `sourcehit()`: of the distant sources containing a direction, the
/// first `light` in the scene wins over a glow (the sky) whatever their
/// sizes; the glow shows where no other source does.
#[test]
fn leaving_rays_see_the_first_source_else_the_glow() {
    let text = "void glow skyglow 0 0 4 1 1 1 0\n\
                skyglow source sky 0 0 4 0 0 1 180\n\
                void light sun 0 0 3 1000 1000 1000\n\
                sun source disc 0 0 4 0 0 1 2\n";
    let s = scene(text);
    let at_sun = view("-vtl -vp 0 0 0 -vd 0 0 1 -vu 0 1 0 -vh 0.001 -vv 0.001");
    let (film, _) = render(&s, &at_sun, 2, 2, RenderOptions::default());
    assert!(film.pixels().iter().all(|c| c.x == 1000.0));
    let aside = view("-vtl -vp 0 0 0 -vd 0 1 1 -vu 0 0 1 -vh 0.001 -vv 0.001");
    let (film, _) = render(&s, &aside, 2, 2, RenderOptions::default());
    assert!(film.pixels().iter().all(|c| c.x == 1.0));
}
