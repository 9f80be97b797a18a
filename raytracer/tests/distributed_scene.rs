//! Distributed compiled scenes in one process: every processor holds the
//! replicated part and reads only its own cells, and the picture equals
//! the sequential render of the scene loaded whole, bit for bit.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use hybrid_rt::accel::{Octree, OctreeParams};
use hybrid_rt::compiled::{self, CompiledScene, Storage};
use hybrid_rt::parallel::{
    render_parallel_held, CacheSize, Distribution, ParallelOptions, ParallelRender, RtWorkload,
};
use hybrid_rt::render::{RenderOptions, Renderer};
use hybrid_rt::scene::{generate, LoadOptions, View};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-held-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes a generated scene and compiles it (objects stored once, or a
/// copy in every leaf).
fn compiled_scene(dir: &Path, name: &str, storage: Storage) -> (PathBuf, View) {
    let (rad, view) = if name == "conference" {
        // The example's files: its chairs and tables are instances.
        let ex = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
        let view = std::fs::read_to_string(ex.join("conference.vf")).unwrap();
        (ex.join("conference.rad"), view)
    } else {
        let (text, view) = match name {
            "cornell" => (generate::cornell(1), generate::cornell_view().to_string()),
            "studio" => (generate::studio(1), generate::studio_view().to_string()),
            _ => (generate::city(7, 3000), generate::city_view(3000)),
        };
        let rad = dir.join(format!("{name}.rad"));
        std::fs::write(&rad, text).unwrap();
        (rad, view)
    };
    let out = dir.join(format!("{name}-{storage:?}.hrtc"));
    compiled::compile(
        std::slice::from_ref(&rad),
        vec![],
        &OctreeParams::default(),
        storage,
        &out,
    )
    .unwrap();
    let view = View::from_file_text(&view, "generated.vf").unwrap();
    (out, view)
}

#[test]
fn the_skeleton_octree_is_the_whole_scenes_octree() {
    let dir = tmpdir("octree");
    for name in ["cornell", "studio", "conference", "city"] {
        let (path, _) = compiled_scene(&dir, name, Storage::Once);
        let c = CompiledScene::open(&path).unwrap();
        let whole = c_scene(&path);
        let built = Octree::build(&whole.objects, &OctreeParams::default());
        let part = c.held_part(&LoadOptions::default()).unwrap();
        let t = &part.octree;
        assert_eq!(t.node_count(), built.node_count(), "{name}");
        assert_eq!(t.root_cell(), built.root_cell(), "{name}");
        assert_eq!(t.stats(), built.stats(), "{name}");
        for id in 0..t.node_count() as u32 {
            assert_eq!(t.node(id), built.node(id), "{name}: node {id}");
            assert_eq!(
                t.node_bounds(id),
                built.node_bounds(id),
                "{name}: node {id}"
            );
            assert_eq!(t.parent(id), built.parent(id));
            assert_eq!(t.depth(id), built.depth(id));
        }
        assert_eq!(t.subtree_refs(), built.subtree_refs(), "{name}");
        // The held scene: the light sources (and what else every
        // processor needs) under their own ids, the other surfaces known
        // by their materials only.
        let s = &part.scene;
        let d = s.distributed.as_ref().expect("a distributed scene");
        assert_eq!(s.object_count(), whole.objects.len());
        assert_eq!(s.lights, whole.lights, "{name}");
        assert!(!s.objects.is_empty() && s.objects.len() < whole.objects.len() / 2);
        for (id, o) in s.table().iter() {
            let w = &whole.objects[id as usize];
            assert_eq!((&o.name, o.material), (&w.name, w.material), "{name}: {id}");
        }
        for l in &s.lights {
            if let hybrid_rt::scene::LightKind::Area { object } = l.kind {
                assert!(
                    s.object(object).is_some(),
                    "{name}: light {object} not held"
                );
            }
        }
        let mut used: Vec<u32> = whole
            .objects
            .iter()
            .enumerate()
            .filter(|(id, _)| s.object(*id as u32).is_none())
            .map(|(_, o)| o.material)
            .collect();
        used.sort();
        used.dedup();
        assert_eq!(d.elsewhere, used, "{name}");
    }
}

fn c_scene(path: &Path) -> hybrid_rt::scene::Scene {
    compiled::load_scene(path).unwrap()
}

/// The compiled scene at `path` rendered at `w` x `h` by `procs` processors
/// on two threads, each reading its own part (`distribution`, `cache`).
fn render_held(
    path: &Path,
    options: &RenderOptions,
    view: &View,
    (w, h): (usize, usize),
    (procs, distribution, cache): (usize, Distribution, CacheSize),
) -> ParallelRender {
    let mut popts = ParallelOptions::new(procs);
    popts.workload.distribution = distribution;
    popts.cache = cache;
    popts.threads = Some(2);
    let part = CompiledScene::open(path)
        .unwrap()
        .held_part(&LoadOptions::default())
        .unwrap();
    render_parallel_held(part, options.clone(), view, w, h, &popts, None)
        .unwrap()
        .unwrap()
}

/// What a processor reads: its leaves' objects (and, stored once, nothing
/// beyond the objects its leaves list), never the whole scene.
#[test]
fn a_processor_reads_only_the_objects_of_its_cells() {
    let dir = tmpdir("reads");
    for storage in [Storage::Once, Storage::Copies] {
        let (path, _) = compiled_scene(&dir, "city", storage);
        let c = CompiledScene::open(&path).unwrap();
        let part = c.held_part(&LoadOptions::default()).unwrap();
        let leaves: Vec<u32> = part.source.cells().iter().map(|l| l.0).collect();
        let whole = c_scene(&path);
        for chunk in leaves.chunks(leaves.len().div_ceil(4)) {
            let mut read = std::collections::HashMap::new();
            part.source
                .read_objects(&part.scene, &part.octree, chunk, |id, s| {
                    assert!(read.insert(id, s).is_none(), "object {id} read twice");
                    Ok(())
                })
                .unwrap();
            let listed: std::collections::HashSet<u32> = chunk
                .iter()
                .flat_map(|&l| part.octree.leaf_objects(l).iter().copied())
                .collect();
            for (id, s) in &read {
                assert!(listed.contains(id), "object {id} is not in these cells");
                assert_eq!(s.name, whole.objects[*id as usize].name);
            }
            for id in &listed {
                assert!(
                    read.contains_key(id) || part.scene.object(*id).is_some(),
                    "{storage:?}: object {id} listed but not read"
                );
            }
            assert!(read.len() < whole.objects.len() / 2);
        }
    }
}

#[test]
fn distributed_renders_equal_the_whole_scenes_sequential_render() {
    let dir = tmpdir("render");
    let (w, h) = (48, 36);
    for (name, storage) in [
        ("cornell", Storage::Once),
        ("studio", Storage::Once),
        ("conference", Storage::Once),
        ("city", Storage::Copies),
    ] {
        let (path, view) = compiled_scene(&dir, name, storage);
        let whole = c_scene(&path);
        let options = RenderOptions::default();
        let want = Renderer::new(&whole, options.clone())
            .unwrap()
            .render(&view, w, h)
            .unwrap()
            .0;
        for (procs, distribution, cache) in [
            (1, Distribution::Octree, CacheSize::Unlimited),
            (3, Distribution::Octree, CacheSize::Percent(5.0)),
            (4, Distribution::Worst, CacheSize::Percent(10.0)),
        ] {
            let out = render_held(&path, &options, &view, (w, h), (procs, distribution, cache));
            assert!(
                out.film.pixels() == want.pixels(),
                "{name}: {procs} processors, {distribution}: the picture differs"
            );
            // Every processor measured its own copies.
            for p in &out.procs {
                assert!(p.copy_bytes > 0 || p.resident_objects == 0, "{name}");
                // Every processor built its hierarchy here, and reports it.
                let h = p.hierarchy_bytes.expect("built in this process");
                assert!(h > 0 || p.resident_objects == 0, "{name}: no hierarchy");
            }
        }
    }
}

#[test]
fn distributions_that_need_every_object_are_refused() {
    let dir = tmpdir("refused");
    let (path, view) = compiled_scene(&dir, "cornell", Storage::Once);
    for (d, says) in [
        (Distribution::Replicated, "every object"),
        // Compiled without a predictor: no predicted work to cut by.
        (Distribution::Predicted, "predicted when it was compiled"),
    ] {
        let part = CompiledScene::open(&path)
            .unwrap()
            .held_part(&LoadOptions::default())
            .unwrap();
        if d == Distribution::Predicted {
            let e = part.predicted_costs(&view).unwrap_err().to_string();
            assert!(e.contains("compile it with --view-file"), "{e}");
        }
        let r =
            Renderer::with_skeleton(Arc::new(part.scene), RenderOptions::default(), part.octree)
                .unwrap();
        let opts = hybrid_rt::parallel::WorkloadOptions {
            distribution: d,
            ..Default::default()
        };
        let e = RtWorkload::distributed(r, view.clone(), 8, 8, 2, opts, part.source, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{e}");
    }
}

/// `--distribution predicted` on a compiled scene: the work predicted per
/// cell when it was compiled, for its stored view, is the whole scene's
/// prediction at `render`'s default size; the processors cut by it hold
/// their own cells, and the picture is the sequential one. Another view is
/// refused, saying why.
#[test]
fn the_predicted_distribution_cuts_by_the_work_predicted_at_compile_time() {
    let dir = tmpdir("predicted");
    let rad = dir.join("studio.rad");
    std::fs::write(&rad, generate::studio(1)).unwrap();
    let view_text = generate::studio_view().to_string();
    let out = dir.join("studio.hrtc");
    compiled::compile_with(
        std::slice::from_ref(&rad),
        vec![view_text.clone()],
        &OctreeParams::default(),
        Storage::Once,
        Some(&hybrid_rt::parallel::predict::for_compiled_scene),
        &out,
    )
    .unwrap();
    let view = View::from_file_text(&view_text, "studio.vf").unwrap();
    let whole = c_scene(&out);
    let options = RenderOptions::default();
    let renderer = Renderer::new(&whole, options.clone()).unwrap();
    let (fitted, w512, h512) = view.fit_aspect(512, 512);
    let want_costs = hybrid_rt::parallel::predict::subtree_costs(
        &renderer,
        &fitted,
        w512 as usize,
        h512 as usize,
    );
    let part = CompiledScene::open(&out)
        .unwrap()
        .held_part(&LoadOptions::default())
        .unwrap();
    assert_eq!(part.predicted_costs(&view).unwrap(), want_costs);
    let mut elsewhere = view.clone();
    elsewhere.vp.x += 0.5;
    let e = part.predicted_costs(&elsewhere).unwrap_err().to_string();
    assert!(e.contains("not one of them"), "{e}");

    let (w, h) = (48, 36);
    let want = renderer.render(&view, w, h).unwrap().0;
    let mut popts = ParallelOptions::new(3);
    popts.workload.distribution = Distribution::Predicted;
    popts.threads = Some(2);
    let out = render_parallel_held(part, options, &view, w, h, &popts, None)
        .unwrap()
        .unwrap();
    assert!(out.film.pixels() == want.pixels(), "the picture differs");
    // Each processor read its own cells, and together they hold them all.
    assert!(out.procs.iter().all(|p| p.resident_objects > 0));
    assert!(
        out.procs.iter().map(|p| p.resident_objects).max() < Some(whole.objects.len()),
        "one processor holds everything"
    );
}

/// A cell that cannot be read fails the render before it starts, naming
/// the processor, the file and the cell; it does not panic.
#[test]
fn a_damaged_cell_names_the_processor_and_the_cell() {
    let dir = tmpdir("damaged");
    let (path, view) = compiled_scene(&dir, "studio", Storage::Once);
    let part = CompiledScene::open(&path)
        .unwrap()
        .held_part(&LoadOptions::default())
        .unwrap();
    // Damage the file after the replicated part was read: the last cell.
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    for b in &mut bytes[n - 64..n - 8] {
        *b ^= 0x5a;
    }
    std::fs::write(&path, &bytes).unwrap();
    let popts = ParallelOptions::new(2);
    let e = render_parallel_held(part, RenderOptions::default(), &view, 16, 16, &popts, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("processor") && e.contains("cannot read its part"),
        "{e}"
    );
    assert!(e.contains(&path.display().to_string()), "{e}");
    assert!(e.contains("cell"), "{e}");
}

/// The hit ratios stored at compile time serve any `-dr` that makes the
/// same light sources (the studio relays nothing), and a render of the
/// compiled scene equals the render of its sources then too.
#[test]
fn stored_hit_ratios_serve_a_dr_that_makes_the_same_light_sources() {
    let dir = tmpdir("dr");
    let (path, view) = compiled_scene(&dir, "studio", Storage::Once);
    let options = RenderOptions {
        dr: 0,
        ..RenderOptions::default()
    };
    assert_ne!(options.dr, RenderOptions::default().dr);
    let sources = hybrid_rt::scene::load(&[dir.join("studio.rad")]).unwrap();
    let want = Renderer::new(&sources, options.clone())
        .unwrap()
        .render(&view, 32, 24)
        .unwrap()
        .0;
    let part = CompiledScene::open(&path)
        .unwrap()
        .held_part(&LoadOptions::default())
        .unwrap();
    let out = render_parallel_held(part, options, &view, 32, 24, &ParallelOptions::new(2), None)
        .unwrap()
        .unwrap();
    assert!(out.film.pixels() == want.pixels());
}

/// A cell of a distributed scene is charged, where it is cached, what its
/// copies take ([`hybrid_sched::Workload::cache_charge`]): its placement
/// bytes until the processors have read their cells, then the same
/// charge for every object of its list (the average copy read, and its
/// places in the leaf's lists), never less than the placement's bytes,
/// and more than them over the scene (a cached cell holds whole copies,
/// the placement counts each object's share of the leaves listing it).
#[test]
fn a_cached_cell_is_charged_what_its_copies_take() {
    use hybrid_sched::Workload;
    let dir = tmpdir("charged");
    let (path, view) = compiled_scene(&dir, "studio", Storage::Once);
    let part = CompiledScene::open(&path)
        .unwrap()
        .held_part(&LoadOptions::default())
        .unwrap();
    let cells: Vec<(u32, u64)> = part.source.cells().iter().collect();
    let r = Renderer::with_skeleton(Arc::new(part.scene), RenderOptions::default(), part.octree)
        .unwrap();
    let opts = hybrid_rt::parallel::WorkloadOptions::default();
    let wl = RtWorkload::distributed(r, view, 8, 8, 2, opts, part.source, None).unwrap();
    for &(leaf, bytes) in &cells {
        assert_eq!(
            wl.cache_charge(&leaf, bytes),
            bytes,
            "leaf {leaf}, not read"
        );
    }
    wl.read_parts(2).unwrap();
    wl.parts_read();
    let mut per_listing = None;
    let (mut charged, mut placed) = (0u64, 0u64);
    for &(leaf, bytes) in &cells {
        let c = wl.cache_charge(&leaf, bytes);
        let listings = wl.renderer().octree().leaf_objects(leaf).len() as u64;
        assert!(c >= bytes, "leaf {leaf}: {c} < {bytes}");
        if c > bytes {
            assert_eq!(c % listings, 0, "leaf {leaf}");
            let per = *per_listing.get_or_insert(c / listings);
            assert_eq!(c / listings, per, "leaf {leaf}");
            assert!(per > 12, "leaf {leaf}: {per}");
        }
        charged += c;
        placed += bytes;
    }
    assert!(per_listing.is_some(), "no cell charged its copies");
    assert!(charged > placed, "{charged} <= {placed}");
}

/// Diffuse inter-reflection with an irradiance cache on a distributed
/// compiled scene: processors hold their own cells, hemisphere rays and
/// leak tests travel to the cells they need, each pixel's owner decides
/// its lookups in the sequential order; the picture is the whole scene's
/// sequential render, bit for bit.
#[test]
fn the_irradiance_cache_on_a_distributed_scene_gives_the_sequential_picture() {
    let dir = tmpdir("irradiance");
    let (w, h) = (24, 18);
    for (name, ab) in [("cornell", 2), ("studio", 1)] {
        let (path, view) = compiled_scene(&dir, name, Storage::Once);
        let whole = c_scene(&path);
        let options = RenderOptions {
            ab,
            aa: 0.2,
            ad: 32,
            as_: 8,
            ..RenderOptions::default()
        };
        let want = Renderer::new(&whole, options.clone())
            .unwrap()
            .render(&view, w, h)
            .unwrap()
            .0;
        for (procs, distribution, cache) in [
            (3, Distribution::Octree, CacheSize::Percent(5.0)),
            (4, Distribution::Worst, CacheSize::Unlimited),
        ] {
            let out = render_held(&path, &options, &view, (w, h), (procs, distribution, cache));
            assert!(
                out.film.pixels() == want.pixels(),
                "{name} -ab {ab}: {procs} processors, {distribution}: the picture differs"
            );
            let a = out.ambient.as_ref().expect("a render with a cache");
            assert!(a.waves > 1 && a.counts.hemispheres > 0, "{name}");
        }
    }
}
