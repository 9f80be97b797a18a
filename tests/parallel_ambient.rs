//! Diffuse inter-reflection in parallel against the sequential renderer.
//! With an irradiance cache the image depends on the order in which points
//! are shaded, so the two agree within a tolerance, not bit for bit: the
//! stated tolerance is a mean relative luminance difference below 5% and
//! an RMSE below 10% of the mean luminance (the sequential renderer with
//! another seed differs by about as much). With `-aa 0` (no cache) the
//! parallel image equals the sequential one bit for bit.

use std::path::PathBuf;

use hybrid_rt::image::{brightness, Film};
use hybrid_rt::parallel::ambient::{
    render_ambient_parallel, AmbientParallelOptions, HemisphereMode,
};
use hybrid_rt::render::{RenderOptions, Renderer};
use hybrid_rt::scene::{self, Scene, View};

fn cornell(width: u32) -> (Scene, View, usize, usize) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let scene = scene::load(&[dir.join("cornell.rad")]).expect("scene loads");
    let view = View::from_file(dir.join("cornell.vf")).expect("view loads");
    let (view, w, h) = view.fit_aspect(width, width);
    (scene, view, w as usize, h as usize)
}

/// (mean |dL| / mean L, RMSE of L / mean L).
fn difference(a: &Film, b: &Film) -> (f64, f64) {
    let n = a.pixels().len() as f64;
    let mean = b.pixels().iter().map(|c| brightness(*c)).sum::<f64>() / n;
    let (mut abs, mut sq) = (0.0, 0.0);
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        let d = brightness(*p) - brightness(*q);
        abs += d.abs();
        sq += d * d;
    }
    (abs / n / mean, (sq / n).sqrt() / mean)
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

#[test]
fn both_modes_agree_with_the_sequential_render() {
    let (scene, view, w, h) = cornell(24);
    let r = Renderer::new(&scene, options()).unwrap();
    let (seq, stats) = r.render(&view, w, h).unwrap();
    for mode in [HemisphereMode::OneAtATime, HemisphereMode::Extra] {
        for procs in [1, 3] {
            let out = render_ambient_parallel(
                &scene,
                options(),
                &view,
                w,
                h,
                &AmbientParallelOptions {
                    procs,
                    mode,
                    tile: 8,
                },
            )
            .unwrap();
            let (mean, rmse) = difference(&out.film, &seq);
            assert!(
                mean < 0.05 && rmse < 0.10,
                "{mode} on {procs}: mean {mean:.4} rmse {rmse:.4}"
            );
            assert!(out.hemispheres > 0 && out.records > 0);
            assert!(out.redundant <= out.hemispheres);
            assert!(out.hemisphere_tasks >= out.hemispheres);
            // Every pixel that missed was traced again.
            assert!(out.retraced_pixels >= out.hemispheres / 2);
            assert_eq!(
                out.rays.ambient_cache.fallbacks,
                stats.rays.ambient_cache.fallbacks
            );
            if mode == HemisphereMode::Extra {
                assert_eq!(out.waits, 0);
            }
        }
    }
}

#[test]
fn without_a_cache_parallel_equals_sequential() {
    // Also with adaptive pixel sampling (-ps 3, whose grid the tiles of 4
    // do not follow: every pixel is traced, the adaptive picture kept).
    for ps in [1, 3] {
        without_a_cache(ps);
    }
}

fn without_a_cache(ps: u32) {
    let (scene, view, w, h) = cornell(10);
    let o = RenderOptions {
        aa: 0.0,
        ps,
        ..options()
    };
    let r = Renderer::new(&scene, o.clone()).unwrap();
    let (seq, _) = r.render(&view, w, h).unwrap();
    for mode in [HemisphereMode::OneAtATime, HemisphereMode::Extra] {
        let out = render_ambient_parallel(
            &scene,
            o.clone(),
            &view,
            w,
            h,
            &AmbientParallelOptions {
                procs: 2,
                mode,
                tile: 4,
            },
        )
        .unwrap();
        assert_eq!(out.film.pixels(), seq.pixels(), "{mode} -ps {ps}");
        assert_eq!(out.redundant, 0);
    }
}

#[test]
fn bad_parallel_options_are_usage_errors() {
    let (scene, view, w, h) = cornell(8);
    for (procs, tile) in [(0, 8), (2, 0)] {
        let e = render_ambient_parallel(
            &scene,
            options(),
            &view,
            w,
            h,
            &AmbientParallelOptions {
                procs,
                mode: HemisphereMode::Extra,
                tile,
            },
        )
        .unwrap_err();
        assert_eq!(e.exit_code(), 2, "{e}");
    }
}
