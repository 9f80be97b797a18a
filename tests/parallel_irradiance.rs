//! Diffuse inter-reflection with an irradiance cache in the hybrid
//! workload against the sequential renderer: bit for bit, for any number
//! of processors, runtime (threads, the framework's sequential reference,
//! the simulator), policy, distribution and cache size. Both shade pixels
//! in the same waves (`render::waves`); in parallel each wave is an epoch
//! of the framework, hemisphere rays migrate to their cells, and each
//! pixel's owner decides its lookups in the sequential renderer's order
//! (`parallel/cursor.rs`). (MPI: `raytracer/tests/mpi.rs`.)

use std::path::PathBuf;
use std::sync::Arc;

use hybrid_rt::parallel::{
    render_parallel, CacheSize, Distribution, ParallelOptions, ParallelRender, RuntimeKind, Work,
};
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

fn popts(procs: usize, distribution: Distribution, cache: CacheSize) -> ParallelOptions {
    let mut p = ParallelOptions::new(procs);
    p.workload.distribution = distribution;
    p.cache = cache;
    p
}

/// The parallel renders of `o` in `runs` equal the sequential one; the
/// renders, in order.
fn agrees(o: &RenderOptions, width: u32, runs: &[ParallelOptions]) -> Vec<ParallelRender> {
    let mut renders = Vec::new();
    let (scene, view, w, h) = cornell(width);
    let r = Renderer::new(&scene, o.clone()).unwrap();
    let (seq, stats) = r.render(&view, w, h).unwrap();
    for p in runs {
        let out: ParallelRender =
            render_parallel(scene.clone(), o.clone(), &view, w, h, p).unwrap();
        let what = format!(
            "-ab {} -aa {} -ps {} -pn {} -aw {} on {} processors ({:?}, {}, cache {:?})",
            o.ab, o.aa, o.ps, o.pn, o.aw, p.procs, p.runtime, p.workload.distribution, p.cache
        );
        if out.film.pixels() != seq.pixels() {
            let differ = (out.film.pixels().iter().zip(seq.pixels()))
                .filter(|(a, b)| a != b)
                .count();
            panic!("{what}: {differ} pixels differ from the sequential render");
        }
        let summary = out.ambient.as_ref().expect("a render with a cache");
        assert_eq!(summary.records, stats.ambient_records, "{what}");
        assert_eq!(
            out.stats.master.epochs as usize + 1,
            summary.waves,
            "{what}"
        );
        if o.ps == 1 {
            // The same pixels shaded the same way: the same decisions.
            assert_eq!(summary.counts, stats.rays.ambient_cache, "{what}");
        }
        assert!(
            summary.counts.hemispheres > 0 && summary.records > 0,
            "{what}"
        );
        renders.push(out);
    }
    renders
}

fn every_kind(procs: usize) -> Vec<ParallelOptions> {
    let mut runs = Vec::new();
    for d in [
        Distribution::Octree,
        Distribution::Replicated,
        Distribution::Predicted,
    ] {
        runs.push(popts(procs, d, CacheSize::Unlimited));
    }
    runs.push(popts(procs, Distribution::Octree, CacheSize::Percent(10.0)));
    // Without hierarchies of their own, processors that come to hold every
    // cell still decide each pixel's lookups as their records arrive
    // (with them, they trace such pixels whole).
    let mut own = popts(procs, Distribution::Octree, CacheSize::Unlimited);
    own.workload.local_kernel = false;
    runs.push(own);
    for runtime in [RuntimeKind::Sim, RuntimeKind::Sequential] {
        let mut p = popts(procs, Distribution::Octree, CacheSize::Percent(10.0));
        p.runtime = runtime;
        p.policy = Policy::LoadAware;
        runs.push(p);
    }
    runs
}

#[test]
fn one_bounce_equals_the_sequential_render() {
    let mut runs = every_kind(3);
    runs.push(popts(1, Distribution::Octree, CacheSize::Unlimited));
    runs.push(popts(5, Distribution::Octree, CacheSize::Percent(10.0)));
    agrees(&options(), 24, &runs);
}

#[test]
fn two_bounces_equal_the_sequential_render() {
    let o = RenderOptions { ab: 2, ..options() };
    agrees(&o, 16, &every_kind(3));
}

#[test]
fn the_aw_term_super_samples_and_several_rays_a_pixel_equal_the_sequential_render() {
    let runs = [
        popts(3, Distribution::Octree, CacheSize::Percent(10.0)),
        popts(2, Distribution::Replicated, CacheSize::Unlimited),
    ];
    for o in [
        RenderOptions { aw: 4, ..options() },
        RenderOptions { pn: 3, ..options() },
        RenderOptions {
            ad: 64,
            as_: 32,
            ..options()
        },
    ] {
        agrees(&o, 12, &runs);
    }
}

#[test]
fn adaptive_pixel_sampling_equals_the_sequential_render() {
    // -ps 3: the waves cover the sampler's lattice; the pixels it adds are
    // shaded with the final cache.
    let o = RenderOptions { ps: 3, ..options() };
    agrees(
        &o,
        30,
        &[
            popts(2, Distribution::Octree, CacheSize::Unlimited),
            popts(3, Distribution::Replicated, CacheSize::Unlimited),
        ],
    );
}

#[test]
fn leak_tests_travel_and_the_picture_is_the_sequential_one() {
    // Records next to the boxes' edges ask for leak tests (Radiance's
    // `plugaleak`); with caches of 10% some cross cells the pixel's owner
    // does not hold and travel as tasks.
    let o = RenderOptions {
        ad: 64,
        ar: 128,
        ..options()
    };
    let mut runs = every_kind(2);
    runs.push(popts(4, Distribution::Octree, CacheSize::Percent(5.0)));
    let renders = agrees(&o, 32, &runs);
    // Where the pixels' owners decide: a processor holding every cell
    // traces its pixels whole (with a hierarchy of its own), as under the
    // replicated distribution and the framework's sequential reference.
    let decided = |r: &&ParallelRender| {
        let o = &r.options;
        o.runtime != RuntimeKind::Sequential
            && o.workload.distribution != Distribution::Replicated
            && (o.cache != CacheSize::Unlimited || !o.workload.local_kernel)
    };
    for r in renders.iter().filter(decided) {
        assert!(r.work(Work::LeakTests) > 0, "{:?}", r.options);
    }
    let bounded = |r: &&ParallelRender| decided(r) && r.options.cache != CacheSize::Unlimited;
    assert!(
        renders
            .iter()
            .filter(bounded)
            .any(|r| r.work(Work::LeakJobs) > 0),
        "no leak test left its pixel's owner"
    );
}

#[test]
fn without_a_cache_parallel_equals_sequential() {
    let (scene, view, w, h) = cornell(10);
    for ps in [1, 3] {
        let o = RenderOptions {
            aa: 0.0,
            ps,
            ..options()
        };
        let (seq, _) = Renderer::new(&scene, o.clone())
            .unwrap()
            .render(&view, w, h)
            .unwrap();
        for p in every_kind(2) {
            let out = render_parallel(scene.clone(), o.clone(), &view, w, h, &p).unwrap();
            assert!(out.film.pixels() == seq.pixels(), "-ps {ps}: {p:?}");
            assert!(out.ambient.is_none(), "no cache, no waves");
        }
    }
}

#[test]
fn bad_parallel_options_are_usage_errors() {
    let (scene, view, w, h) = cornell(8);
    let e = render_parallel(scene, options(), &view, w, h, &ParallelOptions::new(0)).unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
}

/// Radiance's ambient file (`-af`) in parallel: a render that starts from
/// an earlier render's records gives the sequential renderer's picture
/// and adds the same records, on a distributed scene and replicated.
#[test]
fn records_of_an_earlier_render_start_the_cache_as_sequentially() {
    let (scene, view, w, h) = cornell(16);
    let o = options();
    let r = Renderer::new(&scene, o.clone()).unwrap();
    // The records of a first frame (smaller: its points are not the
    // second's), then a second frame from them.
    let (_, small, sw, sh) = cornell(6);
    let (_, _, first) = r
        .render_with_cache(&small, sw, sh, &mut |_| {}, Default::default())
        .unwrap();
    let earlier = first.records_since(0);
    assert!(!earlier.is_empty());
    let (want, _, after) = r
        .render_with_cache(&view, w, h, &mut |_| {}, r.ambient_cache(&earlier))
        .unwrap();
    let added = after.records_since(earlier.len());
    assert!(
        !added.is_empty(),
        "the second frame samples hemispheres of its own"
    );
    for mut p in [
        popts(3, Distribution::Octree, CacheSize::Percent(10.0)),
        popts(2, Distribution::Replicated, CacheSize::Unlimited),
    ] {
        p.ambient_records = Arc::new(earlier.clone());
        let out = render_parallel(scene.clone(), o.clone(), &view, w, h, &p).unwrap();
        assert!(out.film.pixels() == want.pixels(), "{p:?}");
        let a = out.ambient.expect("a render with a cache");
        assert_eq!(a.new_records, added, "{p:?}");
        assert_eq!(a.records, earlier.len() + added.len());
    }
}

/// Hemispheres of more samples than a ray-tree path can name are refused
/// with a usage error, with a cache and without, not sampled in part.
#[test]
fn hemispheres_too_large_to_name_are_refused() {
    let (scene, view, w, h) = cornell(4);
    for aa in [0.2, 0.0] {
        let o = RenderOptions {
            aa,
            ad: 60_000,
            as_: 1,
            ..options()
        };
        let e =
            render_parallel(scene.clone(), o, &view, w, h, &ParallelOptions::new(2)).unwrap_err();
        assert_eq!(e.exit_code(), 2, "{e}");
        assert!(e.to_string().contains("-ad plus -as"), "{e}");
    }
}
