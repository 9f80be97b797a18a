//! Diffuse inter-reflection in parallel against the sequential renderer:
//! bit for bit, for any number of processors, runtime (threads, the
//! framework's sequential reference, the simulator) and policy, with the
//! irradiance cache (both shade pixels in the same waves, see
//! `render::waves`; in parallel each wave is one of the framework's
//! epochs), with two bounces, with adaptive pixel sampling, and without a
//! cache. (MPI: `raytracer/tests/mpi.rs`.)

use std::path::PathBuf;
use std::sync::Arc;

use hybrid_rt::parallel::ambient::{render_ambient_parallel, AmbientParallelReport};
use hybrid_rt::parallel::{ParallelOptions, RuntimeKind};
use hybrid_rt::render::{RenderOptions, Renderer};
use hybrid_rt::scene::{self, Scene, View};
use hybrid_sched::Policy;

fn cornell(width: u32) -> (Arc<Scene>, View, usize, usize) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let scene = Arc::new(scene::load(&[dir.join("cornell.rad")]).expect("scene loads"));
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

fn render(
    scene: &Arc<Scene>,
    o: &RenderOptions,
    view: &View,
    (w, h): (usize, usize),
    popts: &ParallelOptions,
) -> AmbientParallelReport {
    render_ambient_parallel(scene.clone(), o.clone(), view, w, h, popts, &[], None)
        .unwrap()
        .expect("not an MPI rank")
}

/// The parallel render of `o` on each of `procs` equals the sequential one
/// (on threads; the simulator and the framework's sequential reference
/// too, on the last count).
fn agrees(o: &RenderOptions, width: u32, procs: &[usize]) {
    let (scene, view, w, h) = cornell(width);
    let r = Renderer::new(&scene, o.clone()).unwrap();
    let (seq, stats) = r.render(&view, w, h).unwrap();
    let mut runs: Vec<ParallelOptions> = procs.iter().map(|&p| ParallelOptions::new(p)).collect();
    if let Some(&p) = procs.last() {
        for runtime in [RuntimeKind::Sim, RuntimeKind::Sequential] {
            runs.push(ParallelOptions {
                runtime,
                policy: Policy::LoadAware,
                ..ParallelOptions::new(p)
            });
        }
    }
    for popts in runs {
        let p = popts.procs;
        let out = render(&scene, o, &view, (w, h), &popts);
        assert!(
            out.film.pixels() == seq.pixels(),
            "-ab {} -aa {} -ps {} on {p} processors ({:?}) differs from the sequential render",
            o.ab,
            o.aa,
            o.ps,
            popts.runtime
        );
        assert_eq!(
            out.stats.master.epochs as usize + 1,
            out.waves.max(1),
            "{p}"
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
        scene,
        options(),
        &view,
        w,
        h,
        &ParallelOptions::new(0),
        &[],
        None,
    )
    .unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}
