//! Prisms (`prism1`, `prism2`) relaying local light sources, prisms whose
//! functions mirror, and relayed spotlights: known answers from the
//! geometry of Radiance's projection (`dir_proj()`, `makevsrc()`).

mod common;

use common::*;
use hybrid_rt::render::{RenderOptions, Renderer};

const L: f64 = 10.0; // source radiance
const RHO: f64 = 0.5; // floor reflectance
const A: f64 = 0.1; // half side of the square light

/// Mean luminance of a tiny view straight down at the floor point (x, 0, 0).
fn floor_radiance(text: &str, x: f64, o: RenderOptions) -> f64 {
    let s = scene(text);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let v = view(&format!(
        "-vtl -vp {x} 0 0.05 -vd 0 0 -1 -vu 0 1 0 -vh 0.001 -vv 0.001"
    ));
    let (film, _) = render(&s, &v, 8, 8, o);
    film.pixels().iter().map(|c| c.y).sum::<f64>() / film.pixels().len() as f64
}

/// A floor at z = 0 under a horizontal pane at z = 2 made of `pane`
/// (material `win`), and a square light (side 2A) facing down at
/// (`sx`, 0, `sz`).
fn pane_scene(pane: &str, sx: f64, sz: f64) -> String {
    format!(
        "void light lamp 0 0 3 {L} {L} {L}\n\
         lamp polygon bulb 0 0 12 {x0} -{A} {sz}  {x0} {A} {sz}  {x1} {A} {sz}  {x1} -{A} {sz}\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         {pane}\n\
         win polygon pane 0 0 12 -5 -5 2  -5 5 2  5 5 2  5 -5 2\n",
        x0 = sx - A,
        x1 = sx + A,
    )
}

fn virtual_count(text: &str, dr: u32) -> usize {
    let s = scene(text);
    let r = Renderer::new(&s, direct_only(dr)).unwrap();
    r.context()
        .lights
        .iter()
        .filter(|l| l.virt.is_some())
        .count()
}

/// A prism whose functions pass light straight on with coefficient 0.4
/// relays a local source as itself: 0.4 of the light the floor gets
/// through an open pane; the real source is blocked, as in Radiance.
#[test]
fn prism_passes_a_local_source_with_its_coefficient() {
    let open = floor_radiance(
        &pane_scene("void mirror win 1 void 0 3 1 1 1", 0.0, 4.0),
        0.0,
        direct_only(0),
    );
    assert!(open > 0.0);
    let prism = pane_scene("void prism1 win 5 .4 Dx Dy Dz . 0 0", 0.0, 4.0);
    assert_eq!(virtual_count(&prism, 1), 1);
    assert_eq!(floor_radiance(&prism, 0.0, direct_only(0)), 0.0);
    let through = floor_radiance(&prism, 0.0, direct_only(1));
    assert!(
        (through / open - 0.4).abs() < 1e-6,
        "{through} vs 0.4 x {open}"
    );
    // Two projections add; and off the axis too.
    let prism2 = pane_scene("void prism2 win 9 .4 Dx Dy Dz .25 Dx Dy Dz . 0 0", 0.0, 4.0);
    let open = floor_radiance(
        &pane_scene("void mirror win 1 void 0 3 1 1 1", 0.0, 4.0),
        0.7,
        direct_only(0),
    );
    let both = floor_radiance(&prism2, 0.7, direct_only(1));
    assert!((both / open - 0.65).abs() < 1e-6, "{both} vs 0.65 x {open}");
}

/// A prism that sends the light of a source off to the side straight down
/// and every ray from below towards the source: its image stands straight
/// above the pane's centre at the source's height, as Radiance's
/// projection puts it, with the source's area and its normal sheared
/// (`makevsrc()`). The floor under the centre gets that image's light:
/// L A cos / d^2, the cosine between the sheared normal and the vertical.
#[test]
fn prism_relays_a_local_source_to_its_projected_image() {
    // Source centre (1, 0, 4): light through the pane's centre (0, 0, 2)
    // leaves straight down; rays from below leave towards the source.
    let prism = pane_scene(
        "void prism1 win 5 .5 if(Dz,1-Px,0) if(Dz,-Py,0) if(Dz,4-Pz,-1) . 0 0",
        1.0,
        4.0,
    );
    assert_eq!(virtual_count(&prism, 1), 1);
    let got = floor_radiance(&prism, 0.0, direct_only(1));
    // Shear h = (-1/2, 0, 0) per unit height above the pane: the image is
    // at (0, 0, 4), and the source's normal (0, 0, -1) becomes (1/2, 0, -1).
    let cos = 1.0 / (1.0f64 + 0.25).sqrt();
    let d = 4.0;
    let area = (2.0 * A) * (2.0 * A);
    let want = RHO / std::f64::consts::PI * 0.5 * L * area * cos / (d * d);
    eprintln!("through the prism {got}, Radiance's projection {want}");
    assert!((got / want - 1.0).abs() < 2e-3, "{got} vs {want}");
    // Without the relay the pane blocks the source.
    assert_eq!(floor_radiance(&prism, 0.0, direct_only(0)), 0.0);
}

/// A vertical mirror, or a prism in its place whose functions reflect as
/// the mirror does (their projection mirrors: light goes back to the
/// source's side), relays a source beside it: the two pictures agree, at
/// points lit from different angles.
#[test]
fn prism_that_mirrors_relays_as_the_mirror() {
    let base = |surface: &str| {
        format!(
            "void light lamp 0 0 3 {L} {L} {L}\n\
             lamp polygon bulb 0 0 12 -{A} -{A} 1  -{A} {A} 1  {A} {A} 1  {A} -{A} 1\n\
             void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
             floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
             {surface}\n\
             win polygon wall 0 0 12 1 -3 .01  1 -3 3  1 3 3  1 3 .01\n"
        )
    };
    let mirror = base("void mirror win 0 0 3 .8 .8 .8");
    let prism = base("void prism1 win 5 .8 -Dx Dy Dz . 0 0");
    assert_eq!(virtual_count(&prism, 1), 1);
    for x in [0.0, -0.5, 0.6] {
        let m = floor_radiance(&mirror, x, direct_only(1));
        let p = floor_radiance(&prism, x, direct_only(1));
        let direct = floor_radiance(&mirror, x, direct_only(0));
        eprintln!("x = {x}: mirror {m}, prism {p}, direct only {direct}");
        assert!(m > direct * 1.01, "the mirror adds light at {x}");
        assert!((p / m - 1.0).abs() < 1e-6, "{p} vs {m} at {x}");
    }
}

/// A spotlight aimed at a mirror lights, by way of the mirror, exactly the
/// floor its reflected cone reaches (Radiance bounds a relayed spotlight by
/// the common part of its cone and the mirror's; here the shadow ray's test
/// of the mirror and the real spotlight's cone give the same answer).
#[test]
fn relayed_spotlight_lights_the_reflected_cone() {
    // A small spotlight at (0, 0, 1) facing +x, cone 40 degrees; a mirror
    // in the plane x = 1 facing it. The image at (2, 0, 1) faces -x: it
    // reaches the floor point (x, 0, 0) where (2 - x) / sqrt((2 - x)^2 + 1)
    // >= cos 20 degrees, that is x <= 2 - 1 / tan 20 = -0.747.
    let a = 0.005;
    let text = format!(
        "void spotlight spot 0 0 7 {L} {L} {L} 40 1 0 0\n\
         spot polygon bulb 0 0 12 0 {a} {z0}  0 {a} {z1}  0 -{a} {z1}  0 -{a} {z0}\n\
         void plastic floor_mat 0 0 5 {RHO} {RHO} {RHO} 0 0\n\
         floor_mat polygon floor 0 0 12 -100 -100 0  100 -100 0  100 100 0  -100 100 0\n\
         void mirror silver 0 0 3 .9 .9 .9\n\
         silver polygon wall 0 0 12 1 -3 .01  1 -3 3  1 3 3  1 3 .01\n",
        z0 = 1.0 - a,
        z1 = 1.0 + a,
    );
    let edge = 2.0 - 1.0 / 20f64.to_radians().tan();
    for (x, lit) in [
        (edge - 0.02, true),
        (edge - 0.5, true),
        (edge + 0.02, false),
        (0.0, false),
    ] {
        let direct = floor_radiance(&text, x, direct_only(0));
        let relayed = floor_radiance(&text, x, direct_only(1));
        eprintln!("x = {x}: direct {direct}, relayed {relayed}");
        assert_eq!(direct, 0.0, "the spotlight faces away from {x}");
        assert_eq!(relayed > 0.0, lit, "x = {x}: {relayed}");
    }
}

/// A lamp relayed through a bending prism, a mirror, and both (`-dr 2`),
/// seen through a mist that scatters the lamp by way of the mirror: the
/// parallel render equals the sequential one bit for bit.
#[test]
fn parallel_equals_sequential_with_prism_relays() {
    let text = format!(
        "{}void mirror silver 0 0 3 .8 .8 .8\n\
         silver polygon wall 0 0 12 3 -5 .01  3 -5 5  3 5 5  3 5 .01\n\
         void mist fog 1 wall>bulb 0 6 .1 .1 .1 .8 .8 .8\n\
         fog sphere cloud 0 0 4 0 0 1 .8\n",
        pane_scene(
            "void prism1 win 5 .5 if(Dz,1-Px,Dx) if(Dz,-Py,Dy) if(Dz,4-Pz,Dz) . 0 0",
            1.0,
            4.0
        )
    );
    let s = scene(&text);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(virtual_count(&text, 2) >= 3, "{}", virtual_count(&text, 2));
    let v = view("-vtv -vp -2 -2 1.5 -vd 1.5 1.5 -1 -vu 0 0 1 -vh 60 -vv 60");
    let mut o = direct_only(2);
    o.ds = 0.2;
    o.dj = 0.5;
    o.dt = 0.05;
    o.ms = 0.2;
    let (seq, _) = render(&s, &v, 40, 40, o.clone());
    let par = hybrid_rt::parallel::render_parallel(
        std::sync::Arc::new(s),
        o,
        &v,
        40,
        40,
        &hybrid_rt::parallel::ParallelOptions::new(3),
    )
    .unwrap();
    assert!(seq.pixels().iter().any(|c| c.max_element() > 0.0));
    assert_eq!(seq.pixels(), par.film.pixels());
}
