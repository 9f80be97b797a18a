//! The parallel renderer against the sequential one: bit for bit, for every
//! processor count, policy, cache size and distribution; every spawned ray
//! and shadow bundle retired; ray counts equal to the sequential render's.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use hybrid_rt::parallel::workload::work;
use hybrid_rt::parallel::{
    render_parallel, CacheSize, Distribution, ParallelOptions, ParallelRender, RuntimeKind,
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
    let dir = scenes_dir();
    let scene = Arc::new(scene::load(&[dir.join(format!("{name}.rad"))]).expect("scene loads"));
    let view = View::from_file(&dir.join(format!("{name}.vf"))).expect("view loads");
    let (view, w, h) = view.fit_aspect(width as u32, height as u32);
    let (width, height) = (w as usize, h as usize);
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
        out.work(work::RAYS_SPAWNED),
        out.work(work::RAYS_RETIRED),
        "{what}: rays lost"
    );
    assert_eq!(
        out.work(work::SHADOW_SPAWNED),
        out.work(work::SHADOW_RETIRED),
        "{what}: shadow bundles lost"
    );
    let k = &c.counts;
    assert_eq!(
        out.work(work::RAYS_PRIMARY),
        k.primary,
        "{what}: primary rays"
    );
    assert_eq!(
        out.work(work::RAYS_REFLECTION),
        k.reflection,
        "{what}: reflection rays"
    );
    assert_eq!(
        out.work(work::RAYS_REFRACTION),
        k.refraction,
        "{what}: refraction rays"
    );
    assert_eq!(
        out.work(work::SHADOW_TESTED),
        k.shadow.tested,
        "{what}: shadow rays"
    );
    assert_eq!(
        out.work(work::SHADOW_BUNDLES),
        k.shadow.bundles,
        "{what}: shadow bundles"
    );
    out
}

#[test]
fn cornell_smoke() {
    let c = case("cornell", 32, 32, RenderOptions::default());
    for procs in [1, 2, 3] {
        for policy in Policy::ALL {
            let mut p = ParallelOptions::new(procs);
            p.policy = policy;
            p.workload.tile = 8;
            let out = check(&c, &p);
            eprintln!(
                "{procs} {policy}: {} s, clip misses {}",
                out.render_s,
                out.work(work::CLIP_MISSES)
            );
        }
    }
    let _ = (
        CacheSize::Unlimited,
        Distribution::Worst,
        RuntimeKind::Threads,
    );
}
