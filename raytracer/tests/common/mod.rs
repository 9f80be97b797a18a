//! Helpers shared by the render tests.
#![allow(dead_code)]

use hybrid_rt::image::Film;
use hybrid_rt::render::{RenderOptions, RenderStats, Renderer};
use hybrid_rt::scene::{load_rad_str, Color, Scene, View};

/// The Cornell box as shipped with Radiance (resources/cornell_box).
pub const RADIANCE_CORNELL: &str = include_str!("../data/radiance-cornell.rad");
pub const RADIANCE_CORNELL_VIEW: &str = "-vtv -vp 0.49 0 0 -vd -1 0 0 -vu 0 0 1 -vh 80 -vv 80";

pub fn scene(text: &str) -> Scene {
    load_rad_str(text, "test.rad").unwrap_or_else(|e| panic!("scene does not load: {e}"))
}

pub fn view(opts: &str) -> View {
    View::from_options(opts).unwrap_or_else(|e| panic!("bad view: {e}"))
}

pub fn render(
    scene: &Scene,
    view: &View,
    w: usize,
    h: usize,
    opts: RenderOptions,
) -> (Film, RenderStats) {
    let r = Renderer::new(scene, opts).expect("renderer");
    r.render(view, w, h).expect("render")
}

/// Direct light only, every patch tested, sources split finely, `-dr dr`:
/// the virtual-source tests' settings.
pub fn direct_only(dr: u32) -> RenderOptions {
    let mut o = RenderOptions::default();
    o.apply_words("-ds 0.02 -dj 0 -dt 0 -av 0 0 0 -ab 0")
        .unwrap();
    o.dr = dr;
    o
}

pub fn lum(c: Color) -> f64 {
    hybrid_rt::image::brightness(c)
}

/// Largest relative difference between two films, ignoring pixels darker
/// than `floor` in both.
pub fn max_rel_diff(a: &Film, b: &Film, floor: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        let m = p.max_element().max(q.max_element());
        if m > floor {
            worst = worst.max((*p - *q).abs().max_element() / m);
        }
    }
    worst
}

/// Mean absolute difference of brightness, relative to the mean brightness.
pub fn mean_rel_diff(a: &Film, b: &Film) -> f64 {
    let n = a.pixels().len() as f64;
    let d: f64 = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(p, q)| (lum(*p) - lum(*q)).abs())
        .sum::<f64>()
        / n;
    d / (a.mean_brightness().max(1e-300))
}
