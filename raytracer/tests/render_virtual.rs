//! Virtual light sources (planar mirrors relaying sources), shadow rays
//! through dielectrics, `interface` and `antimatter`: known answers,
//! energy bounds and Radiance's Cornell box.

mod common;

use std::sync::Arc;

use common::*;
use hybrid_rt::accel::Hit;
use hybrid_rt::geometry::{Ray, Vec3};
use hybrid_rt::render::material::{shade, shadow_refraction, RayTask, Request};
use hybrid_rt::render::{RayKind, RenderOptions, Renderer};
use hybrid_rt::scene::{Color, Material};

const L: f64 = 10.0; // source radiance
const RHO: f64 = 0.5; // floor reflectance
const H: f64 = 1.0; // light height
const A: f64 = 0.1; // half side of the square light

/// A floor at z = 0, a square light (side 2A) at height H facing down
/// over the origin, and `extra` (a mirror); the view looks straight down
/// at a tiny spot around the origin.
fn mirror_scene(extra: &str) -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    let text = format!(
        "void light lamp 0 0 3 {L} {L} {L}\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         lamp polygon bulb 0 0 12 -{A} -{A} {H}  -{A} {A} {H}  {A} {A} {H}  {A} -{A} {H}\n\
         {extra}\n"
    );
    let v = view("-vtl -vp 0 0 0.5 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001");
    (scene(&text), v)
}

/// A mirror of reflectance `r` in the plane x = 1 facing -x, spanning
/// y in [y0, y1] and z in [z0, z1].
fn mirror(r: f64, y0: f64, y1: f64, z0: f64, z1: f64, alternate: &str) -> String {
    let strs = if alternate.is_empty() {
        "0".to_string()
    } else {
        format!("1 {alternate}")
    };
    format!(
        "void mirror glass_mirror {strs} 0 3 {r} {r} {r}\n\
         glass_mirror polygon wall_mirror 0 0 12 1 {y0} {z0}  1 {y0} {z1}  1 {y1} {z1}  1 {y1} {z0}\n"
    )
}

fn spot_radiance(s: &hybrid_rt::scene::Scene, v: &hybrid_rt::scene::View, o: RenderOptions) -> f64 {
    let (film, _) = render(s, v, 8, 8, o);
    film.pixels().iter().map(|c| c.y).sum::<f64>() / film.pixels().len() as f64
}

/// Irradiance at the origin (normal +z) from a downward-facing square of
/// radiance L, side 2A, centred at (cx, 0, H): L * integral of
/// cos * cos' / r^2 over the square (midpoint rule, 400 x 400).
fn square_irradiance_at(cx: f64) -> f64 {
    let n = 400;
    let d = 2.0 * A / n as f64;
    let mut e = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = cx - A + (i as f64 + 0.5) * d;
            let y = -A + (j as f64 + 0.5) * d;
            let r2 = x * x + y * y + H * H;
            e += H * H / (r2 * r2) * d * d;
        }
    }
    L * e
}

/// A point lit by a small source and by its image in a mirror: the
/// radiance is RHO/pi times (direct + mirror reflectance x the image's
/// irradiance), each computed analytically.
#[test]
fn virtual_source_adds_the_mirrored_irradiance() {
    let rm = 0.8;
    let e_direct = square_irradiance_at(0.0);
    let e_image = square_irradiance_at(2.0);
    let (s, v) = mirror_scene(&mirror(rm, -3.0, 3.0, 0.01, 3.0, ""));
    let unrelayed = spot_radiance(&s, &v, direct_only(0));
    let relayed = spot_radiance(&s, &v, direct_only(1));
    let want_direct = RHO / std::f64::consts::PI * e_direct;
    let want = RHO / std::f64::consts::PI * (e_direct + rm * e_image);
    eprintln!("direct {unrelayed} (want {want_direct}), with mirror {relayed} (want {want})");
    assert!(
        (unrelayed / want_direct - 1.0).abs() < 0.01,
        "-dr 0: {unrelayed} vs {want_direct}"
    );
    assert!(
        (relayed / want - 1.0).abs() < 0.005,
        "-dr 1: {relayed} vs {want}"
    );
    // The mirror's share (3%) is well above the tolerance, so a missing or
    // doubled relay fails.
    assert!(relayed - unrelayed > 0.02 * unrelayed);
}

/// A virtual source never adds more than the mirror's reflectance times
/// the image's unobstructed contribution: a small mirror relays only part
/// of the image, a black mirror nothing, and two relays (-dr 2) add
/// nothing where a second mirror cannot see the first's image.
#[test]
fn virtual_source_energy_is_bounded_by_the_mirror() {
    let rm = 0.9;
    let e_image = square_irradiance_at(2.0);
    let bound = RHO / std::f64::consts::PI * rm * e_image;
    let base = {
        let (s, v) = mirror_scene("");
        spot_radiance(&s, &v, direct_only(1))
    };
    // The shadow ray to the image meets the plane x = 1 at z ~ 0.5: a
    // mirror strip z in [0.45, 0.5] relays only part of the image.
    for (z0, z1, full) in [(0.01, 3.0, true), (0.45, 0.5, false), (0.5, 0.52, false)] {
        let (s, v) = mirror_scene(&mirror(rm, -3.0, 3.0, z0, z1, ""));
        let added = spot_radiance(&s, &v, direct_only(1)) - base;
        eprintln!("mirror z {z0}..{z1}: added {added}, bound {bound}");
        assert!(
            added >= -1e-12 && added <= bound * (1.0 + 0.01),
            "{added} > {bound}"
        );
        if full {
            assert!(added > 0.98 * bound);
        } else {
            assert!(added < 0.9 * bound, "a partial mirror relays part only");
        }
    }
    let (s, v) = mirror_scene(&mirror(0.0, -3.0, 3.0, 0.01, 3.0, ""));
    let added = spot_radiance(&s, &v, direct_only(1)) - base;
    assert!(
        added.abs() < 1e-12,
        "a black mirror relays nothing: {added}"
    );
    // A pattern halving the mirror's colour halves what it relays.
    let patterned = mirror(rm, -3.0, 3.0, 0.01, 3.0, "").replace(
        "void mirror",
        "void brightfunc half 2 0.5 . 0 0\nhalf mirror",
    );
    let (s, v) = mirror_scene(&patterned);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let added = spot_radiance(&s, &v, direct_only(1)) - base;
    assert!(
        (added / bound - 0.5).abs() < 0.01,
        "patterned: {added} vs {bound} / 2"
    );
    // A mirror behind the light (facing away from it) relays nothing.
    let (s, v) = mirror_scene(
        "void mirror m 0 0 3 1 1 1\n\
         m polygon back 0 0 12 -3 -3 2  3 -3 2  3 3 2  -3 3 2\n",
    );
    let r = Renderer::new(&s, direct_only(2)).unwrap();
    let facing_down = r
        .context()
        .lights
        .iter()
        .filter(|l| l.virt.is_some())
        .count();
    // The ceiling mirror at z = 2 faces up (vertices counter-clockwise seen
    // from above): the light below it is behind it.
    assert_eq!(facing_down, 0);
    let _ = v;
}

/// -dr counts reflections: two parallel mirrors facing each other make
/// 2 images at -dr 1 and 4 at -dr 2 (each mirror relays the other's image
/// but never its own).
#[test]
fn relay_depth_counts_images() {
    let (s, _) = mirror_scene(
        "void mirror m 0 0 3 .9 .9 .9\n\
         m polygon right 0 0 12 1 -3 0.01  1 -3 3  1 3 3  1 3 0.01\n\
         m polygon left 0 0 12 -1 -3 0.01  -1 3 0.01  -1 3 3  -1 -3 3\n",
    );
    let count = |dr: u32| {
        let r = Renderer::new(&s, direct_only(dr)).unwrap();
        let n = r
            .context()
            .lights
            .iter()
            .filter(|l| l.virt.is_some())
            .count();
        n
    };
    assert_eq!(count(0), 0);
    assert_eq!(count(1), 2);
    assert_eq!(count(2), 4);
    // And the second-order images add light (both mirrors see them).
    let (_, v) = mirror_scene("");
    let one = spot_radiance(&s, &v, direct_only(1));
    let two = spot_radiance(&s, &v, direct_only(2));
    assert!(two > one * 1.001, "-dr 2 {two} vs -dr 1 {one}");
}

/// A mirror with an alternate material looks like the alternate to the
/// camera and still relays the source; `void` as alternate makes it
/// invisible to the camera.
#[test]
fn mirror_alternate_material() {
    let alt = "void plastic pink 0 0 5 .9 .5 .6 0 0\n";
    let (s, _) = mirror_scene(&format!(
        "{alt}{}",
        mirror(0.8, -3.0, 3.0, 0.01, 3.0, "pink")
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(s.materials.iter().any(|m| matches!(
        m,
        Material::Mirror {
            alternate: Some(_),
            ..
        }
    )));
    // Looking at the mirror from the room: pink plastic lit by the lamp,
    // not the mirror image of the (dark) room.
    let v = view("-vtv -vp 0 0 0.5 -vd 1 0 0 -vu 0 0 1 -vh 1 -vv 1");
    let (film, _) = render(&s, &v, 4, 4, direct_only(1));
    let c = film.get(2, 2);
    assert!(c.x > c.y * 1.3, "pink expected, got {c:?}");
    // The relay still works.
    let (_, spot) = mirror_scene("");
    let with = spot_radiance(&s, &spot, direct_only(1));
    let without = spot_radiance(&s, &spot, direct_only(0));
    assert!(with > without * 1.02);
    // Void alternate: the camera sees through it to the background.
    let (s, _) = mirror_scene(&mirror(0.8, -3.0, 3.0, 0.01, 3.0, "void"));
    let (film, _) = render(&s, &v, 4, 4, direct_only(1));
    assert_eq!(film.get(2, 2), Color::ZERO);
}

/// A parallel render of a scene with virtual sources, a dielectric and
/// antimatter equals the sequential one bit for bit.
#[test]
fn parallel_equals_sequential_with_virtual_sources() {
    let (s, _) = mirror_scene(&format!(
        "{}void dielectric water 0 0 5 .9 .95 1 1.33 0\n\
         water sphere drop 0 0 4 0.3 0.3 0.3 0.2\n\
         void plastic red 0 0 5 .8 .1 .1 0 0\n\
         void antimatter cut 1 red 0 0\n\
         red sphere ball 0 0 4 -0.4 -0.3 0.3 0.25\n\
         cut sphere hole 0 0 4 -0.4 -0.3 0.55 0.12\n",
        mirror(0.8, -3.0, 3.0, 0.01, 3.0, "")
    ));
    let v = view("-vtv -vp -2 -2 2.5 -vd 1.5 1.5 -2 -vu 0 0 1 -vh 60 -vv 60");
    let mut o = direct_only(2);
    o.ds = 0.2;
    o.dj = 0.5;
    o.dt = 0.05;
    let (seq, _) = render(&s, &v, 48, 48, o.clone());
    let par = hybrid_rt::parallel::render_parallel(
        Arc::new(s),
        o,
        &v,
        48,
        48,
        &hybrid_rt::parallel::ParallelOptions::new(3),
    )
    .unwrap();
    assert!(seq.pixels().iter().any(|c| c.max_element() > 0.0));
    assert_eq!(seq.pixels(), par.film.pixels());
}

/// Reflection plus transmitted energy of a dielectric and of an interface
/// at every angle, from both sides, is 1 (the refracted ray's coefficient
/// carries the solid-angle ratio n^2, which energy does not), and total
/// internal reflection reflects everything; an interface between equal
/// media passes everything straight on.
#[test]
fn dielectric_and_interface_energy() {
    let cases: [(&str, f64); 4] = [
        ("void dielectric d 0 0 5 1 1 1 1.5 0\n", 1.5),
        ("void interface d 0 0 8 1 1 1 1.5 1 1 1 1.2\n", 1.25),
        ("void interface d 0 0 8 1 1 1 1.33 1 1 1 1.33\n", 1.0),
        ("void interface d 0 0 8 1 1 1 1.0 1 1 1 1.6\n", 0.625),
    ];
    for (mat, n_rel) in cases {
        let s = scene(&format!("{mat}d sphere ball 0 0 4 0 0 0 1\n"));
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        // No weight limit: grazing refractions are tiny but must be there.
        let o = RenderOptions {
            lw: 0.0,
            ..RenderOptions::default()
        };
        let r = Renderer::new(&s, o).unwrap();
        let ctx = r.context();
        for k in 0..=40 {
            let cos = (k as f64 / 40.0).max(1e-6);
            let sin = (1.0 - cos * cos).sqrt();
            for inside in [false, true] {
                // At (1,0,0), outward normal +x; from outside the ray
                // travels -x, from inside +x.
                let dir = if inside {
                    Vec3::new(cos, sin, 0.0)
                } else {
                    Vec3::new(-cos, sin, 0.0)
                };
                let p = Vec3::X;
                let task = RayTask::primary(
                    Ray {
                        origin: p - dir * 0.5,
                        dir,
                    },
                    0.0,
                    f64::INFINITY,
                    3,
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
                shade(&ctx, &task, &hit, &mut out);
                // n(incident side) / n(other side)
                let nratio = if inside { n_rel } else { 1.0 / n_rel };
                let mut energy = 0.0;
                let mut refracted = 0;
                for q in &out {
                    if let Request::Trace { task: t, coef } = q {
                        assert!(coef.is_finite() && coef.min_element() >= 0.0);
                        match t.kind {
                            RayKind::Reflection => energy += coef.x,
                            RayKind::Refraction => {
                                refracted += 1;
                                energy += coef.x / (nratio * nratio);
                                if n_rel == 1.0 {
                                    assert!((coef.x - 1.0).abs() < 1e-9);
                                    assert!((t.ray.dir - dir).length() < 1e-9);
                                }
                            }
                            _ => {}
                        }
                    }
                }
                let tir = nratio * nratio * (1.0 - cos * cos) > 1.0 - 1e-6;
                assert_eq!(
                    refracted,
                    usize::from(!tir),
                    "{mat} cos {cos} inside {inside}"
                );
                assert!(
                    energy <= 1.0 + 1e-9 && energy > 1.0 - 1e-9,
                    "{mat} cos {cos} inside {inside}: R + T = {energy}"
                );
                // The shadow-ray refraction agrees with shading.
                let m = s.material(s.objects[0].material);
                match shadow_refraction(m, dir, Vec3::X) {
                    Some(sr) => {
                        assert!(!tir);
                        let t = out
                            .iter()
                            .find_map(|q| match q {
                                Request::Trace { task: t, coef }
                                    if t.kind == RayKind::Refraction =>
                                {
                                    Some((t.ray.dir, coef.x))
                                }
                                _ => None,
                            })
                            .unwrap();
                        assert!((sr.dir - t.0).length() < 1e-9);
                        assert!((sr.coef - t.1).abs() < 1e-9);
                    }
                    None => assert!(tir),
                }
            }
        }
    }
}

/// A view straight down at the origin over a lit floor, with `extra`.
fn floor_scene(extra: &str) -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    let text = format!(
        "void light lamp 0 0 3 {L} {L} {L}\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         lamp polygon bulb 0 0 12 -{A} -{A} 3  -{A} {A} 3  {A} {A} 3  {A} -{A} 3\n\
         {extra}\n"
    );
    (
        scene(&text),
        view("-vtl -vp 0 0 0.05 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001"),
    )
}

/// Shadow rays through a slab of `interface` between equal media (index
/// and transmission equal on both sides) pass everything; through a
/// clear dielectric slab they keep the Fresnel transmission of two
/// boundaries (the slab shifts the ray but does not turn it).
#[test]
fn shadow_rays_through_interface_and_dielectric_slabs() {
    let open = {
        let (s, v) = floor_scene("");
        spot_radiance(&s, &v, direct_only(0))
    };
    assert!(open > 0.0);
    let slab = |m: &str| {
        format!(
            "{m}\n\
             d polygon top 0 0 12 -5 -5 1.2  5 -5 1.2  5 5 1.2  -5 5 1.2\n\
             d polygon bottom 0 0 12 -5 -5 1  -5 5 1  5 5 1  5 -5 1\n"
        )
    };
    let (s, v) = floor_scene(&slab("void interface d 0 0 8 1 1 1 1.4 1 1 1 1.4"));
    let same = spot_radiance(&s, &v, direct_only(0));
    assert!((same / open - 1.0).abs() < 1e-6, "{same} vs {open}");
    let (s, v) = floor_scene(&slab("void dielectric d 0 0 5 1 1 1 1.5 0"));
    let glassy = spot_radiance(&s, &v, direct_only(0));
    // Normal incidence: R = 0.04 per boundary.
    let want = open * 0.96 * 0.96;
    assert!((glassy / want - 1.0).abs() < 0.01, "{glassy} vs {want}");
    // An absorbing dielectric (transmission 0.5 per unit, 0.2 thick).
    let (s, v) = floor_scene(&slab("void dielectric d 0 0 5 .5 .5 .5 1.5 0"));
    let dark = spot_radiance(&s, &v, direct_only(0));
    let want = open * 0.96 * 0.96 * 0.5f64.powf(0.2);
    assert!((dark / want - 1.0).abs() < 0.01, "{dark} vs {want}");
}

/// Antimatter cuts a hole into a sphere: inside the hole the camera sees
/// the sphere's inside (unlit), elsewhere the sphere as before; an
/// antimatter volume around a whole sphere removes it, but not a sphere of
/// another material within it.
#[test]
fn antimatter_cuts_a_hole_into_a_sphere() {
    let base = "void light lamp 0 0 3 100 100 100\n\
                lamp sphere sun 0 0 4 0 0 10 1\n\
                void plastic red 0 0 5 .8 .1 .1 0 0\n\
                void plastic green 0 0 5 .1 .8 .1 0 0\n\
                void plastic back 0 0 5 .2 .2 .8 0 0\n\
                back polygon ground 0 0 12 -9 -9 -3  9 -9 -3  9 9 -3  -9 9 -3\n\
                red sphere ball 0 0 4 0 0 0 1\n";
    let v = view("-vtl -vp 0 0 5 -vd 0 0 -1 -vu 0 1 0 -vh 2.4 -vv 2.4");
    let o = direct_only(0);
    let (plain, _) = render(&scene(base), &v, 24, 24, o.clone());
    let s = scene(&format!(
        "{base}void antimatter cut 1 red 0 0\n\
         cut sphere hole 0 0 4 0 0 1 0.5\n"
    ));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let (holed, _) = render(&s, &v, 24, 24, o.clone());
    // The centre: the lit top at z = 1 without the hole; with it, the
    // inside of the bottom at z = -1, lit through the hole (its shadow
    // rays pass the clipped top too): a sphere source of radius 1 at
    // z = 10 subtends pi / d^2, so the ratio is (9 / 11)^2.
    let (c0, c1) = (plain.get(12, 12), holed.get(12, 12));
    assert!(c0.x > 0.05, "{c0:?}");
    let ratio = c1.x / c0.x;
    assert!(
        (ratio - 81.0 / 121.0).abs() < 0.02,
        "hole: {c1:?} vs top {c0:?} (ratio {ratio})"
    );
    // Away from the hole (on the sphere, outside the cut): unchanged.
    let (e0, e1) = (plain.get(12, 3), holed.get(12, 3));
    assert!(e0.x > 0.0);
    assert_eq!(e0, e1);
    let holes = plain
        .pixels()
        .iter()
        .zip(holed.pixels())
        .filter(|(a, b)| a != b)
        .count();
    // The cut is about a quarter of the ball's width across: a small disk.
    assert!(holes > 4 && holes < 24 * 24 / 4, "{holes} pixels changed");
    // A cut around the whole ball removes it (the ground shows), but
    // leaves a green ball inside it.
    let s = scene(&format!(
        "{base}void antimatter cut 1 red 0 0\n\
         green sphere pea 0 0 4 0 0 0 0.3\n\
         cut sphere all 0 0 4 0 0 0 2\n"
    ));
    let (gone, _) = render(&s, &v, 24, 24, o);
    let c = gone.get(12, 12);
    assert!(c.y > c.x * 3.0, "green pea expected: {c:?}");
    let c = gone.get(12, 4);
    assert!(
        c.z > c.x * 2.0,
        "ground expected where the red ball was: {c:?}"
    );
}

/// Radiance's Cornell box: the floor in the umbra of the dielectric
/// sphere (every point of the light hidden by it geometrically) is lit
/// where the sphere focuses refracted light, as in Radiance's picture.
#[test]
fn cornell_dielectric_shadow_has_a_lit_patch() {
    let s = scene(RADIANCE_CORNELL);
    let v = view(RADIANCE_CORNELL_VIEW);
    let (w, h) = (96, 96);
    let (film, _) = render(&s, &v, w, h, RenderOptions::default());
    let (c, r) = (Vec3::new(-0.2, 0.1, -0.3), 0.1);
    let hits_sphere = |o: Vec3, d: Vec3, tmax: f64| {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        disc > 0.0 && {
            let t = -b - disc.sqrt();
            t > 0.0 && t < tmax
        }
    };
    let light = [
        Vec3::new(-0.1, -0.1, 0.45),
        Vec3::new(-0.1, 0.1, 0.45),
        Vec3::new(0.1, 0.1, 0.45),
        Vec3::new(0.1, -0.1, 0.45),
        Vec3::new(0.0, 0.0, 0.45),
    ];
    let (mut umbra, mut lit, mut open_sum, mut open_n) = (0, 0, 0.0, 0);
    for y in 0..h {
        for x in 0..w {
            let fx = (x as f64 + 0.5) / w as f64;
            let fy = 1.0 - (y as f64 + 0.5) / h as f64;
            let Some((ray, _, _)) = v.ray(fx, fy) else {
                continue;
            };
            if ray.dir.z >= 0.0 || hits_sphere(ray.origin, ray.dir, f64::INFINITY) {
                continue;
            }
            let t = (-0.5 - ray.origin.z) / ray.dir.z;
            let p = ray.origin + ray.dir * t;
            if p.x.abs() > 0.45 || p.y.abs() > 0.45 {
                continue;
            }
            let hidden = light
                .iter()
                .filter(|q| {
                    let d = **q - p;
                    hits_sphere(p, d.normalize(), d.length())
                })
                .count();
            let b = lum(film.get(x, y));
            if hidden == light.len() {
                umbra += 1;
                if b > 0.0 {
                    lit += 1;
                }
            } else if hidden == 0 {
                open_sum += b;
                open_n += 1;
            }
        }
    }
    let open = open_sum / open_n.max(1) as f64;
    eprintln!("umbra pixels {umbra}, lit {lit}, mean open floor {open}");
    assert!(umbra > 10, "the view shows the umbra");
    assert!(
        lit > 0,
        "the focused patch in the dielectric's shadow is missing"
    );
    assert!(lit < umbra, "not the whole umbra is lit");
}

/// The suite's scenes that use mirrors as virtual sources, antimatter and
/// interface load without a "not supported" warning for them (their
/// missing files, `sunset.hdr`, give warnings of their own).
#[test]
fn suite_scenes_load_without_stand_ins() {
    let dir =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/radiance-tests");
    if !dir.is_dir() {
        eprintln!("skipped: {} is absent", dir.display());
        return;
    }
    let load = |files: &[&str]| {
        let files: Vec<_> = files.iter().map(|f| dir.join(f)).collect();
        hybrid_rt::scene::load_with(
            &files,
            &hybrid_rt::scene::LoadOptions {
                search_path: vec![dir.clone(), dir.join("lib")],
            },
        )
        .unwrap()
    };
    let mirror = load(&[
        "basic.mat",
        "diorama_walls.rad",
        "closed_end.rad",
        "front_cap.rad",
        "glass_pane.rad",
        "antimatter_portal.rad",
        "bubble_in_cube.rad",
        "mirror.rad",
        "sunset_sky.rad",
    ]);
    let tfunc = load(&[
        "basic.mat",
        "diorama_walls.rad",
        "rect_opening.rad",
        "front_cap.rad",
        "ball_in_cube.rad",
        "sunset_sky.rad",
    ]);
    for (name, s) in [("mirror", &mirror), ("tfunc", &tfunc)] {
        for (_, w) in &s.warnings {
            assert!(
                !w.contains("not supported")
                    && !w.contains("antimatter")
                    && !w.contains("interface")
                    && !w.contains("alternate"),
                "{name}: {w}"
            );
        }
        assert!(s
            .materials
            .iter()
            .any(|m| matches!(m, Material::Interface { .. })));
    }
    assert!(mirror
        .materials
        .iter()
        .any(|m| matches!(m, Material::Antimatter { clips, .. } if *clips != 0)));
    // The wall mirror relays the sun (a distant source).
    let r = Renderer::new(&mirror, direct_only(1)).unwrap();
    let virtuals = r
        .context()
        .lights
        .iter()
        .filter(|l| l.virt.is_some())
        .count();
    assert!(virtuals >= 1, "no virtual source");
    // The prism windows (without the vase, whose mesh the suite lacks).
    for (prism, projections) in [("prism1.rad", 1), ("prism2.rad", 2)] {
        let s = load(&[
            "basic.mat",
            "gold.mat",
            "diorama_walls.rad",
            "rect_opening.rad",
            "front_cap.rad",
            "sunset_sky.rad",
            prism,
        ]);
        for (_, w) in &s.warnings {
            assert!(
                !w.contains("not supported") && !w.contains("prism"),
                "{prism}: {w}"
            );
        }
        assert!(s
            .materials
            .iter()
            .any(|m| matches!(m, Material::Prism { projections: n, .. } if *n == projections)));
        let r = Renderer::new(&s, direct_only(1)).unwrap();
        let n = r
            .context()
            .lights
            .iter()
            .filter(|l| l.virt.is_some())
            .count();
        eprintln!("{prism}: {n} virtual source(s)");
        assert!(
            n >= 1 && n <= usize::from(projections),
            "{prism}: {n} virtual sources"
        );
    }
}

/// Antimatter naming an unknown modifier: a warning (as Radiance), and the
/// name is skipped.
#[test]
fn antimatter_unknown_modifier_is_a_warning() {
    let s = scene(
        "void plastic red 0 0 5 .8 .1 .1 0 0\n\
         void antimatter a 2 nosuch red 0 0\n",
    );
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].1.contains("nosuch"));
    assert!(s.materials.iter().any(
        |m| matches!(m, Material::Antimatter { clips, shade: None } if clips.count_ones() == 1)
    ));
}

/// Bad records name file and line.
#[test]
fn parse_errors_name_file_and_line() {
    for (text, what) in [
        ("void interface i 0 0 7 1 1 1 1.5 1 1 1\n", "real arguments"),
        ("void antimatter a 0 0 0\n", "string arguments"),
        ("void mirror m 1 nosuch 0 3 1 1 1\n", "nosuch"),
        ("void mirror m 2 a b 0 3 1 1 1\n", "string arguments"),
        ("void antimatter a 1 void 0 1 2\n", "real arguments"),
    ] {
        let text = format!("# comment\n\n{text}");
        let err = hybrid_rt::scene::load_rad_str(&text, "bad.rad")
            .err()
            .unwrap_or_else(|| panic!("{text:?} loads"))
            .to_string();
        assert!(err.contains("bad.rad") && err.contains(":3"), "{err}");
        assert!(err.contains(what), "{err}");
    }
}

/// A floor under a horizontal window lit by a distant source straight
/// above; the window is `window` (a material named `win`).
fn window_scene(window: &str) -> (hybrid_rt::scene::Scene, hybrid_rt::scene::View) {
    let text = format!(
        "void light sun 0 0 3 1000 1000 1000\n\
         sun source sol 0 0 4 0.3 0 1 0.5\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         {window}\n\
         win polygon pane 0 0 12 -5 -5 2  -5 5 2  5 5 2  5 -5 2\n"
    );
    (
        scene(&text),
        view("-vtl -vp 0 0 0.05 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001"),
    )
}

/// `prism1` whose functions pass rays straight on with coefficient 0.4:
/// the distant source reaches the floor only as its virtual source
/// through the prism, with 0.4 of its direct light; `prism2` with two
/// such projections (0.4 and 0.25) adds both; the prism's own surface
/// sends redirected rays for camera rays.
#[test]
fn prism_relays_a_distant_source() {
    // An invisible window (a mirror whose alternate is void) for reference.
    let open = {
        let (s, v) = window_scene("void mirror win 1 void 0 3 1 1 1");
        spot_radiance(&s, &v, direct_only(0))
    };
    assert!(open > 0.0);
    let (s, v) = window_scene("void prism1 win 5 .4 Dx Dy Dz . 0 0");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // The real source is blocked by the prism, as in Radiance.
    let blocked = spot_radiance(&s, &v, direct_only(0));
    assert_eq!(blocked, 0.0);
    let r = Renderer::new(&s, direct_only(1)).unwrap();
    assert_eq!(
        r.context()
            .lights
            .iter()
            .filter(|l| l.virt.is_some())
            .count(),
        1
    );
    let through = spot_radiance(&s, &v, direct_only(1));
    assert!(
        (through / open - 0.4).abs() < 1e-3,
        "{through} vs 0.4 x {open}"
    );
    let (s, v) = window_scene("void prism2 win 9 .4 Dx Dy Dz .25 Dx Dy Dz . 0 0");
    let both = spot_radiance(&s, &v, direct_only(1));
    assert!((both / open - 0.65).abs() < 1e-3, "{both} vs 0.65 x {open}");
    // A prism whose coefficient is 0 relays nothing.
    let (s, v) = window_scene("void prism1 win 5 0 Dx Dy Dz . 0 0");
    assert_eq!(spot_radiance(&s, &v, direct_only(1)), 0.0);
    // Camera rays through the prism: one redirected ray per projection.
    let (s, _) = window_scene("void prism2 win 9 .4 Dx Dy Dz .25 Dx Dy Dz . 0 0");
    let up = view("-vtl -vp 0 0 1 -vd 0 0 1 -vu 0 1 0 -vh 0.001 -vv 0.001");
    let (_, stats) = render(&s, &up, 2, 2, direct_only(1));
    assert_eq!(stats.rays.refraction, 8);
}

/// A prism that bends light: a source off to the side lights the floor
/// below the window as if it stood overhead (coefficient 1, the source's
/// solid angle kept, as Radiance's projection keeps it).
#[test]
fn prism_bends_a_distant_source() {
    // Rays arriving from above (Dz < 0) leave straight down; rays from
    // below (shadow rays, Dz > 0) leave towards the source at (0.3, 0, 1).
    let (s, v) = window_scene("void prism1 win 5 1 if(Dz,.3,0) 0 if(Dz,1,-1) . 0 0");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let bent = spot_radiance(&s, &v, direct_only(1));
    let (s, v) = window_scene("void mirror win 1 void 0 3 1 1 1");
    let open = spot_radiance(&s, &v, direct_only(1));
    let want = 1.09f64.sqrt();
    assert!(
        (bent / open - want).abs() < 1e-3,
        "{bent} / {open} vs {want}"
    );
}

/// A ray descended from a sampled (ambient or rough specular) ray stays
/// sampled after a mirror, so it sees the lamp as black: the lamp's light
/// by way of the mirror is the virtual source's (Radiance's
/// `badcomponent()`), not counted twice.
#[test]
fn sampled_rays_stay_sampled_after_mirrors() {
    let (s, _) = mirror_scene(&mirror(0.8, -3.0, 3.0, 0.01, 3.0, ""));
    let r = Renderer::new(&s, direct_only(1)).unwrap();
    let ctx = r.context();
    let mirror_obj = s
        .objects
        .iter()
        .position(|o| o.name == "wall_mirror")
        .unwrap() as u32;
    for sampled in [false, true] {
        let dir = Vec3::new(1.0, 0.0, 0.0);
        let p = Vec3::new(1.0, 0.0, 0.5);
        let mut task = RayTask::primary(
            Ray {
                origin: p - dir,
                dir,
            },
            0.0,
            f64::INFINITY,
            5,
        );
        task.sampled = sampled;
        let hit = Hit {
            t: 1.0,
            point: p,
            normal: Vec3::new(-1.0, 0.0, 0.0),
            object: mirror_obj,
            inner: None,
            surface: {
                let (m, f) = ctx.scene.objects[mirror_obj as usize].surface_at(None);
                Hit::surface_word(m, f)
            },
        };
        let mut out = Vec::new();
        shade(&ctx, &task, &hit, &mut out);
        let kids: Vec<bool> = out
            .iter()
            .filter_map(|q| match q {
                Request::Trace { task, .. } => Some(task.sampled),
                _ => None,
            })
            .collect();
        assert_eq!(kids, vec![sampled]);
    }
}
