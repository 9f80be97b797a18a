//! The parallel renderer against the sequential one: bit for bit, for every
//! processor count, policy, cache size and distribution; every spawned ray
//! and shadow bundle retired; ray counts equal to the sequential render's.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use hybrid_rt::parallel::tasks::screen_tiles;
use hybrid_rt::parallel::Work;
use hybrid_rt::parallel::{
    render_parallel, walks_worth_the_rest, CacheSize, Distribution, FetchLimit, ParallelOptions,
    ParallelRender, RuntimeKind,
};
use hybrid_rt::render::{RayCounts, RenderOptions, Renderer};
use hybrid_rt::scene::{self, Scene, View};
use hybrid_sched::Policy;

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes")
}

struct Case {
    scene: Arc<Scene>,
    view: View,
    options: RenderOptions,
    width: usize,
    height: usize,
    pixels: Vec<[u64; 3]>,
    counts: RayCounts,
}

fn bits(film: &hybrid_rt::image::Film) -> Vec<[u64; 3]> {
    film.pixels()
        .iter()
        .map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()])
        .collect()
}

fn case(name: &str, width: usize, height: usize, options: RenderOptions) -> Case {
    let (view, w, h) = scene_view(name).fit_aspect(width as u32, height as u32);
    render_case(name, view, w as usize, h as usize, options)
}

/// [`case`] with `options` applied over the scene's view file.
fn case_view(name: &str, options: &str, width: usize, height: usize) -> Case {
    let mut view = scene_view(name);
    view.apply_options(options, &Default::default())
        .expect("view options");
    render_case(name, view, width, height, RenderOptions::default())
}

fn scene_view(name: &str) -> View {
    View::from_file(scenes_dir().join(format!("{name}.vf"))).expect("view loads")
}

/// Scene `name` rendered sequentially from `view`: the reference.
fn render_case(
    name: &str,
    view: View,
    width: usize,
    height: usize,
    options: RenderOptions,
) -> Case {
    let path = scenes_dir().join(format!("{name}.rad"));
    let scene = Arc::new(scene::load(&[path]).expect("scene loads"));
    let r = Renderer::new(&scene, options.clone()).expect("renderer");
    let (film, stats) = r.render(&view, width, height).expect("render");
    Case {
        pixels: bits(&film),
        counts: stats.rays,
        scene,
        view,
        options,
        width,
        height,
    }
}

fn run(c: &Case, popts: &ParallelOptions) -> ParallelRender {
    let mut popts = popts.clone();
    popts.time_limit = Some(Duration::from_secs(120));
    render_parallel(
        c.scene.clone(),
        c.options.clone(),
        &c.view,
        c.width,
        c.height,
        &popts,
    )
    .unwrap_or_else(|e| panic!("{popts:?}: {e}"))
}

fn check(c: &Case, popts: &ParallelOptions) -> ParallelRender {
    let out = run(c, popts);
    let what = format!(
        "procs {} policy {} cache {:?} distribution {}",
        popts.procs, popts.policy, popts.cache, popts.workload.distribution
    );
    let got = bits(&out.film);
    let differ = got.iter().zip(&c.pixels).filter(|(a, b)| a != b).count();
    assert_eq!(
        differ, 0,
        "{what}: {differ} pixels differ from the sequential render"
    );
    assert_eq!(
        out.work(Work::RaysSpawned),
        out.work(Work::RaysRetired),
        "{what}: rays lost"
    );
    assert_eq!(
        out.work(Work::ShadowSpawned),
        out.work(Work::ShadowRetired),
        "{what}: shadow bundles lost"
    );
    let k = &c.counts;
    assert_eq!(
        out.work(Work::RaysPrimary),
        k.primary,
        "{what}: primary rays"
    );
    assert_eq!(
        out.work(Work::RaysReflection),
        k.reflection,
        "{what}: reflection rays"
    );
    assert_eq!(
        out.work(Work::RaysRefraction),
        k.refraction,
        "{what}: refraction rays"
    );
    assert_eq!(
        out.work(Work::RaysAmbient),
        k.ambient,
        "{what}: hemispheres' rays"
    );
    assert_eq!(
        out.work(Work::ShadowTested),
        k.shadow.tested,
        "{what}: shadow rays"
    );
    assert_eq!(
        out.work(Work::ShadowBundles),
        k.shadow.bundles,
        "{what}: shadow bundles"
    );
    out
}

/// Checks the framework's bounds at the end of a run: input buffers within
/// the credit bound, cached bytes within the budget.
fn check_bounds(out: &ParallelRender, what: &str) {
    let bound = hybrid_sched::Config::new(out.options.procs).input_buffer_bound();
    for (i, p) in out.stats.procs.iter().enumerate() {
        assert!(
            p.memory.input_buffer_items <= bound,
            "{what}: processor {i} input buffer {} > {bound}",
            p.memory.input_buffer_items
        );
        if let Some(budget) = out.cache_bytes {
            assert!(
                p.memory.cached_bytes <= budget,
                "{what}: processor {i} cached {} bytes > budget {budget}",
                p.memory.cached_bytes
            );
        }
    }
}

/// The four cache sizes of the issue: unlimited, 50 %, 10 %, and smaller
/// than one task's data (the largest single cell: every task needing two
/// cells or more must fall back to data-parallel execution).
fn caches(c: &Case) -> Vec<CacheSize> {
    vec![
        CacheSize::Unlimited,
        CacheSize::Percent(50.0),
        CacheSize::Percent(10.0),
        CacheSize::Bytes(largest_cell(c)),
    ]
}

fn largest_cell(c: &Case) -> u64 {
    use hybrid_rt::parallel::RtWorkload;
    use hybrid_sched::Workload;
    let r = Renderer::shared(c.scene.clone(), c.options.clone(), &Default::default()).unwrap();
    let wl = RtWorkload::new(r, c.view.clone(), c.width, c.height, 1, Default::default());
    wl.placement(1).iter().map(|p| p.bytes).max().unwrap_or(1)
}

/// The options most runs here vary: `procs` processors, the data
/// `distribution`, the `cache` and tiles of side `tile`.
fn options(
    procs: usize,
    distribution: Distribution,
    cache: CacheSize,
    tile: usize,
) -> ParallelOptions {
    let mut p = ParallelOptions::new(procs);
    p.cache = cache;
    p.workload.tile = tile;
    p.workload.distribution = distribution;
    p
}

#[test]
fn cornell_equals_sequential_for_every_procs_policy_cache_distribution() {
    let c = case("cornell", 24, 24, RenderOptions::default());
    let mut fallbacks = 0;
    let mut migrations = 0;
    for procs in [1, 2, 3, 4, 8, 16] {
        for distribution in [Distribution::Octree, Distribution::Worst] {
            for cache in caches(&c) {
                for policy in Policy::ALL {
                    let mut p = options(procs, distribution, cache, 4);
                    p.policy = policy;
                    let out = check(&c, &p);
                    check_bounds(&out, &format!("{p:?}"));
                    fallbacks += out.stats.sum(|s| s.tasks.fallbacks);
                    migrations += out.stats.sum(|s| s.tasks.migrations);
                }
            }
        }
    }
    // The matrix exercised both escape routes of the hybrid scheduler.
    assert!(fallbacks > 0, "no task ever fell back to data-parallel");
    assert!(migrations > 0, "no ray ever migrated");
}

/// `--fetch-limit`: a demand-driven task with more to fetch than the limit
/// traces data-parallel (its rays migrate); the picture and every ray
/// count stay the sequential ones. At zero nothing is fetched at all.
#[test]
fn a_fetch_limit_sends_large_fetches_data_parallel_and_changes_no_pixel() {
    let c = case("studio", 48, 36, RenderOptions::default());
    for procs in [2, 3] {
        for limit in [
            CacheSize::Bytes(0),
            CacheSize::Bytes(largest_cell(&c)),
            CacheSize::Percent(5.0),
        ] {
            let mut p = ParallelOptions::new(procs);
            p.fetch_limit = FetchLimit::Size(limit);
            p.workload.distribution = Distribution::Octree;
            let out = check(&c, &p);
            check_bounds(&out, &format!("{p:?}"));
            if limit == CacheSize::Bytes(0) {
                assert_eq!(out.stats.sum(|s| s.data_items_requested), 0, "{p:?}");
                assert!(out.stats.sum(|s| s.tasks.fallbacks) > 0, "{p:?}");
            }
        }
    }
}

/// Coarse shadow tasks. Shadow bundles start in the step that shaded their
/// point (data-parallel ones, and demand-driven ones whose cells are all
/// resident), and the bundles of one point that need cells held elsewhere
/// travel as one task: the picture and every ray count stay the same, and
/// steps are saved. On one processor, which holds the scene, tiles are
/// traced whole: the only tasks are the tiles.
#[test]
fn shadow_bundles_start_in_the_step_that_shaded_their_point() {
    let c = case("studio", 32, 32, RenderOptions::default());
    let tile = 8;
    for procs in [1, 3] {
        // The frame's last tiles are handed out in quarters.
        let tiles = screen_tiles(c.width, c.height, tile, 1, procs, true).len() as u64;
        for policy in Policy::ALL {
            let mut on = ParallelOptions::new(procs);
            on.policy = policy;
            on.workload.tile = tile;
            let mut off = on.clone();
            off.workload.inline_local_shadows = false;
            let (a, b) = (check(&c, &on), check(&c, &off));
            let what = format!("procs {procs} policy {policy}");
            let inline = a.work(Work::ShadowBundlesInline);
            assert_eq!(b.work(Work::ShadowBundlesInline), 0, "{what}");
            assert!(
                inline > a.work(Work::ShadowBundlesDp),
                "{what}: no demand-driven bundle ran inline"
            );
            let dd = |r: &ParallelRender| r.stats.sum(|s| s.tasks.demand_driven);
            let dp = |r: &ParallelRender| r.stats.sum(|s| s.tasks.data_parallel_steps);
            // Without inline starts, a point's scheduled bundles share tasks.
            let bundles = b.work(Work::ShadowSpawned) - b.work(Work::ShadowBundlesDp);
            assert!(dd(&b) - tiles < bundles, "{what}: one task per bundle");
            if procs == 1 {
                // Holding the scene, it traces each tile whole: every
                // bundle inline, no data-parallel step at all, where the
                // paper's schedule runs each data-parallel bundle as one.
                assert_eq!(inline, a.work(Work::ShadowSpawned), "{what}: all inline");
                assert_eq!(dd(&a), tiles, "{what}: only tiles are tasks");
                assert_eq!(dp(&a), 0, "{what}: a data-parallel step");
                assert_eq!(a.work(Work::ShadowBundlesDp), 0, "{what}");
                assert!(
                    dp(&b) >= b.work(Work::ShadowBundlesDp),
                    "{what}: a data-parallel bundle took no step"
                );
            } else {
                assert!(dd(&a) + dp(&a) < dd(&b) + dp(&b), "{what}: no step saved");
            }
        }
    }
}

/// Two runs traced and shaded the same rays and shadow rays (and so gave
/// every query the same answer).
fn assert_same_rays(a: &ParallelRender, b: &ParallelRender, what: &str) {
    for w in [
        Work::RaysRetired,
        Work::ShadowRetired,
        Work::ShadowTested,
        Work::ShadowUnoccluded,
        Work::ShadowSegments,
    ] {
        assert_eq!(a.work(w), b.work(w), "{what}: {w:?}");
    }
}

/// The processor's own hierarchy answers the queries its resident
/// objects decide, the rest walk the octree: the pictures and every ray
/// and shadow count are those of the walk alone (and of the sequential
/// renderer), under every policy and distribution, with a cache too small
/// to hold a cell; on one processor (which holds everything) nothing walks.
/// On several, more bundles run where their point was shaded (one tried
/// there and then scheduled walks twice, so leaves walked need not fall).
#[test]
fn the_processors_own_hierarchy_changes_no_answer() {
    let c = case("studio", 32, 32, RenderOptions::default());
    let small = CacheSize::Bytes(largest_cell(&c) / 2);
    let mut runs: Vec<_> = Policy::ALL
        .iter()
        .map(|&p| (p, Distribution::Octree, CacheSize::Unlimited))
        .collect();
    runs.push((Policy::Local, Distribution::Worst, CacheSize::Unlimited));
    runs.push((Policy::Local, Distribution::Octree, small));
    for procs in [1, 3] {
        for &(policy, distribution, cache) in &runs {
            let mut on = ParallelOptions::new(procs);
            on.policy = policy;
            on.cache = cache;
            on.workload.distribution = distribution;
            let mut off = on.clone();
            off.workload.local_kernel = false;
            let (a, b) = (check(&c, &on), check(&c, &off));
            let what = format!("procs {procs} policy {policy} {distribution} {cache:?}");
            assert_same_rays(&a, &b, &what);
            assert_eq!(b.work(Work::TraceLocal), 0, "{what}");
            assert!(
                a.work(Work::TraceLocal) > 0,
                "{what}: nothing answered locally"
            );
            assert_eq!(b.work(Work::ShadowTriedElsewhere), 0, "{what}");
            // (With `worst`, processor 0 holds every cell and the others
            // none: no bundle can be tried anywhere it was not before.)
            if procs > 1 && distribution == Distribution::Octree {
                assert!(
                    a.work(Work::ShadowBundlesInline) > b.work(Work::ShadowBundlesInline),
                    "{what}: no bundle ran where its point was shaded"
                );
            }
            if procs == 1 {
                assert!(
                    a.work(Work::TraceLeaves) < b.work(Work::TraceLeaves),
                    "{what}: no walk saved"
                );
                assert_eq!(a.work(Work::TraceLeaves), 0, "{what}: a query walked");
                // It casts through the renderer's hierarchy and reads the
                // scene itself (no copies), charging each bundle as the
                // walk does; none goes data-parallel where the tiles are
                // traced whole.
                assert_eq!(a.work(Work::ShadowBundlesDp), 0, "{what}");
                for w in [
                    Work::ShadowSpawned,
                    Work::ShadowBundlesInline,
                    Work::ShadowBundles,
                    Work::ShadowPatches,
                    Work::ShadowEstimated,
                ] {
                    assert_eq!(a.work(w), b.work(w), "{what}: {w:?}");
                }
                assert_eq!(a.procs[0].copy_bytes, 0, "{what}: copies made");
                assert!(b.procs[0].copy_bytes > 0, "{what}: the walk needs copies");
            }
        }
    }
    // The simulator prices the walk: it runs without the hierarchy.
    let mut sim = ParallelOptions::new(2);
    sim.runtime = RuntimeKind::Sim;
    assert!(!sim.workload_options().local_kernel);
    let out = check(&c, &sim);
    assert_eq!(out.work(Work::TraceLocal), 0);
}

/// With a cache that never evicts, a processor's hierarchy grows over what
/// it has cached: more queries are answered without walking the octree,
/// and no answer changes. A bounded cache (here one that could hold the
/// whole scene, so nothing is evicted either) keeps the hierarchy over the
/// resident objects only: the same run, for comparison.
#[test]
fn a_hierarchy_grown_over_the_cache_changes_no_answer() {
    let c = case("studio", 48, 36, RenderOptions::default());
    let whole = largest_cell(&c) * 1_000_000;
    for procs in [2, 3] {
        let mut grown = ParallelOptions::new(procs);
        grown.cache = CacheSize::Unlimited;
        let mut resident = grown.clone();
        resident.cache = CacheSize::Bytes(whole);
        let (a, b) = (check(&c, &grown), check(&c, &resident));
        assert_same_rays(&a, &b, &format!("procs {procs}"));
        assert!(
            a.work(Work::TraceLocal) > b.work(Work::TraceLocal),
            "procs {procs}: the grown hierarchy answered no more ({} against {})",
            a.work(Work::TraceLocal),
            b.work(Work::TraceLocal)
        );
        assert!(
            a.work(Work::TraceLeaves) < b.work(Work::TraceLeaves),
            "procs {procs}: no walk saved"
        );
    }
}

/// Completing the cache (`complete_cache`): with a cache without budget a
/// processor that has asked for the given share of the cells held
/// elsewhere asks for the rest, and once its hierarchy is grown over every
/// cell it traces as a processor holding the scene (no selection, no
/// judgement, no walk). The picture and every ray count stay the
/// sequential ones; at 0 every processor completes at its first fetch and
/// walks fewer octree leaves than the paper's cache (`None`) does.
#[test]
fn completing_the_cache_changes_no_answer() {
    let c = case("studio", 96, 72, RenderOptions::default());
    for procs in [2, 3] {
        let mut paper = ParallelOptions::new(procs);
        paper.workload.tile = 8;
        let (mut at_once, mut half) = (paper.clone(), paper.clone());
        at_once.complete_cache = Some(0);
        half.complete_cache = Some(50);
        let (a, b) = (check(&c, &at_once), check(&c, &paper));
        check(&c, &half);
        let what = format!("procs {procs}");
        assert_same_rays(&a, &b, &what);
        for s in &a.stats.procs {
            if s.data_items_requested > 0 {
                assert!(s.cache_completed, "{what}: {:?} did not complete", s.addr);
            }
        }
        assert!(b.stats.procs.iter().all(|s| !s.cache_completed), "{what}");
        assert!(
            a.work(Work::TraceLeaves) < b.work(Work::TraceLeaves),
            "{what}: no walk saved ({} against {})",
            a.work(Work::TraceLeaves),
            b.work(Work::TraceLeaves)
        );
    }
}

/// A processor whose walks past its hierarchy cost what holding the whole
/// scene would (`walks_worth_the_rest`), walked or projected over its
/// share of the frame at its rate so far, asks for the rest whatever the
/// completion percentage (here 100, which alone completes only a processor
/// that asked for everything); the paper's cache (`None`) never completes.
/// On the studio the projection asks before the walks reach the price.
/// The picture and ray counts stay the sequential ones.
#[test]
fn walks_that_pay_for_the_scene_complete_the_cache() {
    let c = case("studio", 160, 120, RenderOptions::default());
    let walked = |s: &hybrid_sched::ProcStats| s.work.get(Work::TraceLeaves.name()).copied();
    let mut popts = ParallelOptions::new(2);
    popts.complete_cache = Some(100);
    let a = check(&c, &popts);
    popts.complete_cache = None;
    let b = check(&c, &popts);
    assert_same_rays(&a, &b, "studio");
    let worth = walks_worth_the_rest(c.scene.object_count(), a.data_bytes);
    let mut sooner = 0;
    for s in &a.stats.procs {
        let w = walked(s).unwrap_or(0);
        if w >= worth {
            assert!(
                s.cache_completed,
                "{:?} walked {w} leaves of {worth}",
                s.addr
            );
        } else if s.cache_completed {
            sooner += 1;
        }
    }
    assert!(
        sooner > 0,
        "no processor asked before walking {worth} leaves: {:?}",
        a.stats
            .procs
            .iter()
            .map(|s| (walked(s), s.cache_completed))
            .collect::<Vec<_>>()
    );
    assert!(b.stats.procs.iter().all(|s| !s.cache_completed));
    assert!(
        a.work(Work::TraceLeaves) < b.work(Work::TraceLeaves),
        "no walk saved ({} against {})",
        a.work(Work::TraceLeaves),
        b.work(Work::TraceLeaves)
    );
}

/// Data requests answered on arrival by the owner's data server (the
/// threads runtime: a one-sided read in the requester's step; the
/// simulator: at arrival, on the owner's CPU) change no answer: the
/// sequential picture and ray counts, every request answered once, and on
/// threads no processor spends a step serving.
#[test]
fn serving_data_on_arrival_changes_no_answer() {
    let c = case("studio", 96, 72, RenderOptions::default());
    for (procs, runtime) in [(2, RuntimeKind::Threads), (3, RuntimeKind::Sim)] {
        let mut between = ParallelOptions::new(procs);
        between.runtime = runtime;
        between.workload.tile = 8;
        let mut arrival = between.clone();
        arrival.data_service = hybrid_sched::DataService::OnArrival;
        let (a, b) = (check(&c, &arrival), check(&c, &between));
        let what = format!("procs {procs}, {runtime:?}");
        assert_same_rays(&a, &b, &what);
        for out in [&a, &b] {
            let sent = out.stats.sum(|s| s.data_requests_sent);
            assert!(sent > 0, "{what}: nothing fetched");
            assert_eq!(out.stats.sum(|s| s.data_requests_served), sent, "{what}");
        }
        if runtime == RuntimeKind::Threads {
            assert_eq!(a.stats.sum(|s| s.time_ns.serving_data), 0, "{what}");
        } else {
            assert!(a.stats.sum(|s| s.time_ns.serving_data) > 0, "{what}");
        }
    }
}

/// Views whose tiles have no bounding pyramid (fisheye, parallel): a
/// tile's selection walks its primary rays and leaves them for its
/// execution or its data-parallel fallback, which must still trace each
/// pixel once and equal the sequential picture.
#[test]
fn views_without_a_tile_pyramid_equal_sequential() {
    for opts in [
        "-vta -vh 180 -vv 180",
        "-vtl -vh 6 -vv 6",
        "-vth -vh 150 -vv 150",
    ] {
        let c = case_view("cornell", opts, 20, 20);
        let mut fallbacks = 0;
        for procs in [1, 3] {
            for distribution in [Distribution::Octree, Distribution::Worst] {
                for cache in [CacheSize::Unlimited, CacheSize::Bytes(largest_cell(&c))] {
                    let p = options(procs, distribution, cache, 6);
                    let out = check(&c, &p);
                    fallbacks += out.stats.sum(|s| s.tasks.fallbacks);
                }
            }
        }
        assert!(fallbacks > 0, "{opts}: no tile fell back to data-parallel");
    }
}

#[test]
fn studio_with_glass_and_metal_equals_sequential() {
    let c = case("studio", 40, 30, RenderOptions::default());
    assert!(
        c.counts.reflection + c.counts.refraction > 0,
        "the view must see specular surfaces"
    );
    for procs in [2, 3, 8] {
        for cache in caches(&c) {
            for policy in Policy::ALL {
                let mut p = ParallelOptions::new(procs);
                p.policy = policy;
                p.cache = cache;
                p.workload.tile = 8;
                let out = check(&c, &p);
                check_bounds(&out, &format!("{p:?}"));
            }
        }
    }
}

#[test]
fn every_shadow_bundle_data_parallel_and_the_worst_distribution() {
    // All bundles migrate with their recorded answers; a tiny cache forces
    // tiles to fall back too: the whole render runs data-parallel.
    let c = case("studio", 32, 24, RenderOptions::default());
    for distribution in [Distribution::Octree, Distribution::Worst] {
        let mut p = ParallelOptions::new(4);
        p.policy = Policy::RoundRobin;
        p.cache = CacheSize::Bytes(1);
        p.workload.tile = 8;
        p.workload.shadow_dp_below = usize::MAX;
        p.workload.distribution = distribution;
        // As the paper schedules them: with coarse tasks a bundle that
        // stops where its point was shaded joins the point's task instead
        // (below).
        p.workload.inline_local_shadows = false;
        let out = check(&c, &p);
        assert_eq!(
            out.work(Work::ShadowBundlesDp),
            out.work(Work::ShadowSpawned),
            "every bundle should have run data-parallel"
        );
        assert!(out.stats.sum(|s| s.tasks.fallbacks) > 0);
        if distribution == Distribution::Octree {
            assert!(
                out.work(Work::ShadowRestarts) > 0,
                "bundles should have migrated mid-way"
            );
        }
    }
}

/// With coarse tasks a data-parallel bundle starts where its point was
/// shaded; one that stops at a cell held elsewhere joins the point's
/// demand-driven task (selected, fetched and run again there) instead of
/// migrating on its own. The picture is the sequential one.
#[test]
fn stopped_data_parallel_bundles_join_their_points_task() {
    let c = case("studio", 32, 24, RenderOptions::default());
    for (procs, cache) in [(3, CacheSize::Unlimited), (4, CacheSize::Percent(5.0))] {
        let mut p = ParallelOptions::new(procs);
        p.cache = cache;
        p.workload.tile = 8;
        p.workload.shadow_dp_below = usize::MAX;
        let out = check(&c, &p);
        let what = format!("{procs} processors, cache {cache:?}");
        assert_eq!(
            out.work(Work::ShadowBundlesDp),
            out.work(Work::ShadowSpawned),
            "{what}: every bundle should have started data-parallel"
        );
        assert!(
            out.work(Work::ShadowJoined) > 0,
            "{what}: no bundle stopped and joined its point's task"
        );
        p.workload.inline_local_shadows = false;
        assert_eq!(check(&c, &p).work(Work::ShadowJoined), 0, "{what}");
    }
}

/// Finished pixels travel to the master in batches
/// (`WorkloadOptions::pixel_batch`), so a processor holds fewer than a
/// batch at the end of the run, whatever the runtime; the picture is the
/// sequential one.
#[test]
fn finished_pixels_sent_to_the_master_in_batches_change_no_pixel() {
    let c = case("cornell", 20, 20, RenderOptions::default());
    for runtime in [
        RuntimeKind::Threads,
        RuntimeKind::Sim,
        RuntimeKind::Sequential,
    ] {
        for (batch, distribution) in [(7, Distribution::Octree), (1, Distribution::Replicated)] {
            let mut p = options(3, distribution, CacheSize::Percent(10.0), 5);
            p.runtime = runtime;
            p.workload.pixel_batch = batch;
            let out = check(&c, &p);
            let what = format!("{runtime:?}, batches of {batch}, {distribution}");
            let pixels: usize = out.procs.iter().map(|s| s.pixels).sum();
            let sent: usize = out.procs.iter().map(|s| s.pixels_sent).sum();
            assert_eq!(pixels, 400, "{what}: pixels assembled");
            assert!(sent > 0, "{what}: no batch was sent");
            for (i, s) in out.procs.iter().enumerate() {
                assert!(
                    s.pixels - s.pixels_sent < batch,
                    "{what}: processor {i} kept {} of its {} pixels",
                    s.pixels - s.pixels_sent,
                    s.pixels
                );
            }
        }
    }
    // Held to the end (0): nothing is sent.
    let mut p = options(3, Distribution::Octree, CacheSize::Unlimited, 5);
    p.workload.pixel_batch = 0;
    let out = check(&c, &p);
    assert!(out.procs.iter().all(|s| s.pixels_sent == 0));
}

#[test]
fn jittered_pixels_and_sources_and_the_framework_sequential_runtime() {
    let options = RenderOptions {
        pj: 0.9,
        dj: 0.7,
        seed: 11,
        ..RenderOptions::default()
    };
    let c = case("cornell", 20, 20, options);
    let mut p = ParallelOptions::new(3);
    p.policy = Policy::ToOrigin;
    p.cache = CacheSize::Percent(10.0);
    p.workload.tile = 5;
    check(&c, &p);
    p.runtime = RuntimeKind::Sequential;
    check(&c, &p);
}

#[test]
fn resident_bytes_are_reported_and_the_worst_case_puts_everything_on_one() {
    let c = case("cornell", 8, 8, RenderOptions::default());
    let mut p = ParallelOptions::new(4);
    let balanced = run(&c, &p);
    assert_eq!(balanced.procs.len(), 4);
    assert!(balanced.procs.iter().all(|s| s.resident_bytes > 0));
    p.workload.distribution = Distribution::Worst;
    let worst = run(&c, &p);
    assert!(worst.procs[0].resident_bytes > 0);
    assert!(worst.procs[1..].iter().all(|s| s.resident_bytes == 0));
    assert!(
        worst.procs[0].resident_bytes
            >= balanced
                .procs
                .iter()
                .map(|s| s.resident_bytes)
                .max()
                .unwrap()
    );
}

#[test]
fn cache_size_parses_bytes_suffixes_and_percentages() {
    assert_eq!("unlimited".parse::<CacheSize>(), Ok(CacheSize::Unlimited));
    assert_eq!("64M".parse::<CacheSize>(), Ok(CacheSize::Bytes(64 << 20)));
    assert_eq!("512k".parse::<CacheSize>(), Ok(CacheSize::Bytes(512 << 10)));
    assert_eq!("1000".parse::<CacheSize>(), Ok(CacheSize::Bytes(1000)));
    assert_eq!("10%".parse::<CacheSize>(), Ok(CacheSize::Percent(10.0)));
    for bad in ["", "ten", "-5%", "5X", "99999999999999999999G"] {
        assert!(bad.parse::<CacheSize>().is_err(), "{bad:?}");
    }
    assert_eq!(CacheSize::Percent(10.0).resolve(1000), Some(100));
    assert_eq!("worst".parse::<Distribution>(), Ok(Distribution::Worst));
    assert!("diagonal".parse::<Distribution>().is_err());
    assert!("mpi".parse::<RuntimeKind>().is_err());
}

#[test]
fn the_simulated_cluster_renders_the_sequential_picture_deterministically() {
    use hybrid_sched::Network;
    let c = case("studio", 32, 24, RenderOptions::default());
    for net in [Network::parsytec_cc(), Network::ten_gbe()] {
        for procs in [1, 3, 8] {
            for policy in [Policy::Local, Policy::ViaMaster, Policy::LoadAware] {
                for distribution in [Distribution::Octree, Distribution::Predicted] {
                    for cache in [CacheSize::Unlimited, CacheSize::Percent(5.0)] {
                        let mut p = ParallelOptions::new(procs);
                        p.runtime = RuntimeKind::Sim;
                        p.network = net.clone();
                        p.policy = policy;
                        p.cache = cache;
                        p.workload.tile = 8;
                        p.workload.distribution = distribution;
                        p.workload.clip_cache = distribution == Distribution::Predicted;
                        let a = check(&c, &p);
                        check_bounds(&a, &format!("{p:?}"));
                        let v = a.simulated_s.expect("virtual time");
                        assert!(v > 0.0 && v.is_finite());
                        assert!(a.timeline.is_some());
                        if procs == 3 && cache == CacheSize::Percent(5.0) {
                            // Same inputs, same statistics, byte for byte.
                            let b = run(&c, &p);
                            assert_eq!(
                                serde_json::to_string(&a.stats).unwrap(),
                                serde_json::to_string(&b.stats).unwrap()
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn the_predicted_distribution_equalises_predicted_work() {
    let c = case("studio", 64, 48, RenderOptions::default());
    for procs in [2, 4, 8] {
        for distribution in [Distribution::Octree, Distribution::Predicted] {
            let mut p = ParallelOptions::new(procs);
            p.workload.distribution = distribution;
            p.runtime = RuntimeKind::Sequential;
            // Every distribution renders the same picture.
            check(&c, &p);
        }
    }
    // The predicted cut balances predicted work better than the memory cut.
    let renderer = Renderer::new(&c.scene, c.options.clone()).unwrap();
    let costs = hybrid_rt::parallel::predict::subtree_costs(&renderer, &c.view, c.width, c.height);
    let octree = renderer.octree();
    let objects = &c.scene.objects;
    let spread = |part: &hybrid_rt::parallel::Partition| {
        let mut per = vec![0u64; part.procs() as usize];
        for leaf in octree.leaves() {
            per[part.owner(leaf) as usize] += costs[leaf as usize];
        }
        let max = *per.iter().max().unwrap() as f64;
        let mean = per.iter().sum::<u64>() as f64 / per.len() as f64;
        max / mean
    };
    let by_memory = hybrid_rt::parallel::Partition::new(octree, objects, 8);
    let by_work = hybrid_rt::parallel::Partition::by_cost(octree, objects, 8, &costs);
    assert!(
        spread(&by_work) < spread(&by_memory),
        "predicted work imbalance: by work {:.2}, by memory {:.2}",
        spread(&by_work),
        spread(&by_memory)
    );
}

#[test]
fn the_clip_cache_selects_enough_for_every_bundle() {
    // One clip per (processor, cell, light), reused by every later bundle:
    // the picture is unchanged and no bundle misses a cell. (Whether it
    // saves clipping steps depends on the bundles per cell: at this tiny
    // size it does not; at 256x190 it removes most of them, see the
    // `speedup` experiment.)
    let c = case("studio", 40, 30, RenderOptions::default());
    for procs in [2, 4] {
        for cache in [CacheSize::Unlimited, CacheSize::Percent(10.0)] {
            for policy in [Policy::Local, Policy::RoundRobin] {
                let mut p = ParallelOptions::new(procs);
                p.policy = policy;
                p.cache = cache;
                p.workload.tile = 8;
                let plain = check(&c, &p);
                p.workload.clip_cache = true;
                let cached = check(&c, &p);
                check_bounds(&cached, &format!("{p:?}"));
                assert_eq!(cached.work(Work::ClipMisses), 0, "{p:?}");
                assert!(cached.work(Work::ClipReused) > 0, "{p:?}");
                // Both selected the same cells or more: the same picture, and
                // no bundle ran short of data.
                assert_eq!(plain.work(Work::ClipMisses), 0);
            }
        }
    }
}

#[test]
fn clipping_skips_the_subtrees_a_processor_holds_whole() {
    // With the clip cache and a cache that never evicts, clipping does not
    // enter subtrees whose every non-empty leaf the processor holds: fewer
    // nodes visited than with a budget as large as the scene (which may
    // evict, so clipping enters everything it does not own), and still no
    // bundle or tile short of a cell. On the simulated cluster, where the
    // walk and the selections are those of the paper's processors.
    let c = case("studio", 64, 48, RenderOptions::default());
    let mut p = ParallelOptions::new(8);
    p.runtime = RuntimeKind::Sim;
    p.complete_cache = None;
    p.workload.clip_cache = true;
    p.workload.distribution = Distribution::Predicted;
    p.workload.tile = 8;
    let mut budget = p.clone();
    budget.cache = CacheSize::Percent(100.0);
    let (pruned, whole) = (check(&c, &p), check(&c, &budget));
    for r in [&pruned, &whole] {
        assert_eq!(r.work(Work::ClipMisses), 0);
    }
    let nodes = |r: &ParallelRender| r.work(Work::ClipNodes);
    assert!(
        nodes(&pruned) * 2 < nodes(&whole),
        "clipping visited {} nodes with an unlimited cache, {} with a budget",
        nodes(&pruned),
        nodes(&whole)
    );
}

#[test]
fn the_replicated_distribution_schedules_only_work() {
    // Every processor holds the scene: tiles are traced whole, nothing is
    // selected, fetched or migrated, and the picture is the sequential one
    // on threads, on the framework's sequential runtime and on the
    // simulated cluster, with and without asking for work ahead.
    let c = case("studio", 40, 30, RenderOptions::default());
    for runtime in [
        RuntimeKind::Threads,
        RuntimeKind::Sequential,
        RuntimeKind::Sim,
    ] {
        for procs in [1, 2, 3] {
            if runtime == RuntimeKind::Sequential && procs > 1 {
                continue;
            }
            for prefetch in [true, false] {
                let mut p = ParallelOptions::new(procs);
                p.runtime = runtime;
                p.workload.distribution = Distribution::Replicated;
                p.workload.tile = 8;
                p.prefetch_work = prefetch;
                let out = check(&c, &p);
                let what = format!("{runtime:?} procs {procs} prefetch {prefetch}");
                for st in &out.stats.procs {
                    assert_eq!(st.data_items_requested, 0, "{what}");
                    assert_eq!(st.tasks.migrations, 0, "{what}");
                }
                assert_eq!(out.work(Work::ClipNodes), 0, "{what}");
                // Every processor reads the whole scene.
                for s in &out.procs {
                    assert_eq!(s.resident_objects, c.scene.objects.len(), "{what}");
                }
            }
        }
    }
}

#[test]
fn asking_for_work_ahead_keeps_every_distribution_exact() {
    let c = case("cornell", 24, 24, RenderOptions::default());
    for distribution in [Distribution::Octree, Distribution::Worst] {
        for procs in [2, 3] {
            for prefetch in [true, false] {
                let mut p = ParallelOptions::new(procs);
                p.workload.distribution = distribution;
                p.workload.tile = 4;
                p.cache = CacheSize::Percent(20.0);
                p.prefetch_work = prefetch;
                check(&c, &p);
            }
        }
    }
}

#[test]
fn adaptive_pixel_sampling_equals_sequential_for_every_tiling_and_distribution() {
    // -ps 4: the sequential renderer samples a grid and refines where
    // neighbours differ by more than -pt. Replicated tiles sample the same
    // way with their grid cells as apron (tiles of 5 are not aligned to the
    // grid, tiles of 8 are); the other distributions trace every pixel and
    // keep the adaptive picture of them. Either way: the sequential picture.
    let options = RenderOptions {
        ps: 4,
        pt: 0.05,
        pj: 0.67,
        seed: 5,
        ..RenderOptions::default()
    };
    let c = case("studio", 40, 30, options.clone());
    let full = case(
        "studio",
        40,
        30,
        RenderOptions {
            ps: 1,
            ..options.clone()
        },
    );
    let w = c.width * c.height;
    assert!(
        (c.counts.primary as usize) < w,
        "-ps 4 traced {} of {w} pixels",
        c.counts.primary
    );
    assert_ne!(c.pixels, full.pixels, "-ps 4 interpolated nothing");
    for distribution in [
        Distribution::Replicated,
        Distribution::Octree,
        Distribution::Worst,
    ] {
        for runtime in [RuntimeKind::Threads, RuntimeKind::Sim] {
            for tile in [5, 8] {
                let mut p = ParallelOptions::new(3);
                p.runtime = runtime;
                p.workload.distribution = distribution;
                p.workload.tile = tile;
                let out = run(&c, &p);
                let what = format!("{distribution} {runtime:?} tile {tile}");
                let got = bits(&out.film);
                let differ = got.iter().zip(&c.pixels).filter(|(a, b)| a != b).count();
                assert_eq!(differ, 0, "{what}: {differ} pixels differ");
                assert_eq!(
                    out.work(Work::RaysSpawned),
                    out.work(Work::RaysRetired),
                    "{what}: rays lost"
                );
                let primary = out.work(Work::RaysPrimary) as usize;
                if distribution == Distribution::Replicated {
                    // Sampled adaptively too, tiles rounded up to the grid:
                    // the sequential samples, plus at most a tile's shared
                    // border grid row and column traced again per tile, and
                    // on each of its grid rows one grid cell more on each
                    // side (the apron whose columns decide the refinement
                    // of the tile's outer columns).
                    // (The frame's last tiles are split, each part at
                    // most `t` on a side.)
                    let t = tile.div_ceil(4) * 4;
                    let tiles = screen_tiles(c.width, c.height, t, 4, 3, true).len();
                    let seq = c.counts.primary as usize;
                    let apron = (t / 4 + 1) * 2 * 4;
                    assert!(
                        primary >= seq && primary <= seq + tiles * (2 * (t + 1) + apron),
                        "{what}: {primary} primary rays, sequential {seq}"
                    );
                } else {
                    assert_eq!(primary, w, "{what}: every pixel traced");
                }
            }
        }
    }
}

/// The processor count has one source: a workload built for two
/// processors says so (`laid_out_for`), and every runtime refuses to run it
/// on three with a configuration error, before any hook runs.
#[test]
fn a_workload_runs_only_on_the_processor_count_it_was_built_for() {
    use hybrid_rt::parallel::RtWorkload;
    use hybrid_sched::{Config, ConfigError, RunError, Runtime, Sequential, Threads, Workload};
    let c = case("cornell", 8, 8, RenderOptions::default());
    let r = Renderer::shared(c.scene.clone(), c.options.clone(), &Default::default()).unwrap();
    let wl = Arc::new(RtWorkload::new(
        r,
        c.view.clone(),
        c.width,
        c.height,
        2,
        Default::default(),
    ));
    assert_eq!(wl.laid_out_for(), Some(2));
    let runtimes: [Box<dyn Runtime<RtWorkload>>; 2] = [Box::new(Threads), Box::new(Sequential)];
    for rt in runtimes {
        match rt.run_blocking(wl.clone(), &Config::new(3)) {
            Err(RunError::Config(ConfigError::ProcsMismatch {
                laid_out: 2,
                procs: 3,
            })) => {}
            other => panic!(
                "{}: expected a count mismatch, got {:?}",
                rt.name(),
                other.err()
            ),
        }
        assert!(rt.run_blocking(wl.clone(), &Config::new(2)).is_ok());
    }
}

/// One processor, three on threads and on the simulated cluster, two on
/// the sequential runtime.
const FOUR_RUNS: [(usize, RuntimeKind); 4] = [
    (1, RuntimeKind::Threads),
    (3, RuntimeKind::Threads),
    (3, RuntimeKind::Sim),
    (2, RuntimeKind::Sequential),
];

/// [`check`] for each of `runs` (processors, runtime) with the octree and
/// the replicated distribution, an unlimited cache and one of 10%, tiles
/// of 4 pixels; returns the migrations.
fn check_everywhere(c: &Case, runs: &[(usize, RuntimeKind)]) -> u64 {
    let mut migrations = 0;
    for &(procs, runtime) in runs {
        for distribution in [Distribution::Octree, Distribution::Replicated] {
            for cache in [CacheSize::Unlimited, CacheSize::Percent(10.0)] {
                let mut p = options(procs, distribution, cache, 4);
                p.runtime = runtime;
                let out = check(c, &p);
                migrations += out.stats.sum(|s| s.tasks.migrations);
            }
        }
    }
    migrations
}

/// Diffuse inter-reflection without an irradiance cache or super-samples
/// (`-ab 2 -aa 0 -as 0`) in the hybrid workload: every hemisphere's
/// sample rays are data-parallel tasks that migrate to the cells they
/// need, and each pixel's owner evaluates the hemispheres; the picture and
/// every ray count are the sequential renderer's, on every runtime,
/// distribution and cache (one that holds almost nothing included).
#[test]
fn hemisphere_rays_migrate_and_change_no_pixel() {
    let mut o = RenderOptions::default();
    (o.ab, o.aa, o.as_, o.ad) = (2, 0.0, 0, 16);
    let c = case("cornell", 16, 16, o);
    assert!(c.counts.ambient > 0, "the reference samples hemispheres");
    let runs = [
        (1, RuntimeKind::Threads),
        (2, RuntimeKind::Threads),
        (3, RuntimeKind::Threads),
        (5, RuntimeKind::Threads),
        (3, RuntimeKind::Sim),
        (2, RuntimeKind::Sequential),
    ];
    let migrations = check_everywhere(&c, &runs);
    assert!(migrations > 0, "no hemisphere ray ever migrated");
    // Three bounces, the deepest hemispheres refused by -lw (their -av
    // term carried in the point's record), -aw moving -av.
    let mut o = RenderOptions::default();
    (o.ab, o.aa, o.as_, o.ad, o.lw, o.aw) = (3, 0.0, 0, 16, 0.1, 2);
    o.av = hybrid_rt::scene::Color::splat(0.1);
    let c = case("cornell", 12, 12, o);
    for procs in [1, 3] {
        let mut p = ParallelOptions::new(procs);
        p.cache = CacheSize::Percent(30.0);
        p.workload.tile = 4;
        check(&c, &p);
    }
}

/// A hemisphere's super-samples (`-as`) depend on its first samples'
/// values: the pixel's owner makes them when the last of those is merged
/// (`Workload::merge_in`) and spawns them as data-parallel tasks like the
/// first. The picture and every ray count are the sequential renderer's,
/// on every runtime, distribution and cache, with one bounce and two.
#[test]
fn super_samples_are_made_where_the_first_samples_meet_and_change_no_pixel() {
    let mut o = RenderOptions::default();
    (o.ab, o.aa, o.as_, o.ad) = (1, 0.0, 32, 64);
    let c = case("cornell", 16, 16, o.clone());
    o.as_ = 0;
    let without = case("cornell", 16, 16, o);
    assert!(
        c.counts.ambient > without.counts.ambient,
        "the reference takes super-samples ({} against {} ambient rays)",
        c.counts.ambient,
        without.counts.ambient
    );
    assert!(
        check_everywhere(&c, &FOUR_RUNS) > 0,
        "no sample ray ever migrated"
    );
    let mut o = RenderOptions::default();
    (o.ab, o.aa, o.as_, o.ad) = (2, 0.0, 16, 64);
    let c = case("cornell", 8, 8, o);
    for (procs, runtime) in [(3, RuntimeKind::Threads), (2, RuntimeKind::Sim)] {
        let mut p = options(procs, Distribution::Octree, CacheSize::Percent(10.0), 4);
        p.runtime = runtime;
        check(&c, &p);
    }
}

/// Several primary rays per pixel (`-pn`): each sample's ray is a ray job
/// of its own and the pixel the mean of its samples, in sample order
/// (`Child::Mean`). Three samples (a division that is not a power of two),
/// jittered, and two with hemispheres: the sequential picture and ray
/// counts on every runtime and distribution.
#[test]
fn pixel_samples_are_ray_jobs_and_change_no_pixel() {
    let mut o = RenderOptions {
        pn: 3,
        pj: 0.67,
        ..RenderOptions::default()
    };
    let c = case("studio", 24, 18, o.clone());
    assert_eq!(c.counts.primary, 3 * 24 * 18, "three samples a pixel");
    check_everywhere(&c, &FOUR_RUNS);
    (o.pn, o.ab, o.aa, o.as_, o.ad) = (2, 1, 0.0, 16, 64);
    let c = case("cornell", 8, 8, o);
    check(
        &c,
        &options(3, Distribution::Octree, CacheSize::Percent(10.0), 4),
    );
}

/// Where nearly every hemisphere ray migrates (a cache of 10% of the
/// cells), depth first (`Workload::data_parallel_newest_first`) keeps the
/// tasks queued short. On the simulated cluster (deterministic) with the
/// `render` command's data options, the processors' queues held at most
/// 246, 3,049 and 309 tasks; before demand-driven children ran ahead of
/// data-parallel tasks (and waiting tasks left newest first), 11,287,
/// 21,446 and 16,292: a level of the ray trees at once.
#[test]
fn depth_first_keeps_migrating_hemispheres_queued_short() {
    let mut o = RenderOptions::default();
    (o.ab, o.aa, o.as_, o.ad) = (2, 0.0, 0, 32);
    let c = case("cornell", 16, 16, o);
    let mut p = options(3, Distribution::Octree, CacheSize::Percent(10.0), 16);
    p.runtime = RuntimeKind::Sim;
    p.fetch_limit = FetchLimit::Auto;
    p.complete_cache = Some(50);
    p.data_service = hybrid_sched::DataService::OnArrival;
    let out = check(&c, &p);
    let migrations = out.stats.sum(|s| s.tasks.migrations);
    assert!(migrations > 50_000, "{migrations} migrations");
    let queued: Vec<usize> = out
        .stats
        .procs
        .iter()
        .map(|s| s.memory.queued_tasks)
        .collect();
    assert!(
        queued.iter().sum::<usize>() < 10_000,
        "queued at most {queued:?}"
    );
}
