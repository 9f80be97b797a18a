//! Diffuse inter-reflection in parallel against the sequential renderer:
//! bit for bit, for any number of processors, with the irradiance cache
//! (both shade pixels in the same waves, see `render::waves`), with two
//! bounces, with adaptive pixel sampling, and without a cache.

use std::path::PathBuf;

use hybrid_rt::parallel::ambient::{render_ambient_parallel, AmbientParallelOptions};
use hybrid_rt::render::{RenderOptions, Renderer};
use hybrid_rt::scene::{self, Scene, View};

fn cornell(width: u32) -> (Scene, View, usize, usize) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let scene = scene::load(&[dir.join("cornell.rad")]).expect("scene loads");
    let view = View::from_file(dir.join("cornell.vf")).expect("view loads");
    let (view, w, h) = view.fit_aspect(width, width);
    (scene, view, w as usize, h as usize)
}

fn options() -> RenderOptions {
    RenderOptions {
        ab: 1,
        aa: 0.2,
        ad: 32,
        as_: 8,
        ..Default::default()
    }
}

/// The parallel render of `o` on each of `procs` equals the sequential one.
fn agrees(o: &RenderOptions, width: u32, procs: &[usize]) {
    let (scene, view, w, h) = cornell(width);
    let r = Renderer::new(&scene, o.clone()).unwrap();
    let (seq, stats) = r.render(&view, w, h).unwrap();
    for &p in procs {
        let out = render_ambient_parallel(
            &scene,
            o.clone(),
            &view,
            w,
            h,
            &AmbientParallelOptions { procs: p },
        )
        .unwrap();
        assert!(
            out.film.pixels() == seq.pixels(),
            "-ab {} -aa {} -ps {} on {p} processors differs from the sequential render",
            o.ab,
            o.aa,
            o.ps
        );
        assert_eq!(out.records, stats.ambient_records, "{p} processors");
        if o.ps == 1 {
            // The same pixels shaded the same way: the same hemispheres.
            assert_eq!(out.rays.ambient_cache, stats.rays.ambient_cache);
        }
        if o.aa > 0.0 {
            assert!(
                out.waves > 1 && out.hemispheres > 0 && out.records > 0,
                "{p}"
            );
        }
    }
}

#[test]
fn one_bounce_equals_the_sequential_render_on_any_number_of_processors() {
    agrees(&options(), 24, &[1, 2, 3, 5]);
}

#[test]
fn two_bounces_equal_the_sequential_render() {
    let o = RenderOptions { ab: 2, ..options() };
    agrees(&o, 16, &[1, 3]);
}

#[test]
fn adaptive_pixel_sampling_equals_the_sequential_render() {
    // -ps 3: the waves cover the sampler's lattice; the pixels it adds are
    // shaded with the final cache (here all of them, then resampled).
    let o = RenderOptions { ps: 3, ..options() };
    agrees(&o, 48, &[1, 2]);
}

#[test]
fn without_a_cache_parallel_equals_sequential() {
    for ps in [1, 3] {
        let o = RenderOptions {
            aa: 0.0,
            ps,
            ..options()
        };
        agrees(&o, 10, &[2]);
    }
}

#[test]
fn bad_parallel_options_are_usage_errors() {
    let (scene, view, w, h) = cornell(8);
    let e = render_ambient_parallel(
        &scene,
        options(),
        &view,
        w,
        h,
        &AmbientParallelOptions { procs: 0 },
    )
    .unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}
