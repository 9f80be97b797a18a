//! `hybrid-rt bench`: measured ray throughput.
//!
//! Primary rays: nearest-hit queries for every pixel's primary ray.
//! Shadow rays: any-hit queries from every primary hit on a lit surface
//! towards every patch of every source (the rays adaptive testing would
//! trace with `-dt 0`). Only the queries are timed; generating the rays is
//! not. Optionally a full render for its rate of primary plus shadow rays.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::args::BenchArgs;
use super::common::options_from;
use super::view::resolve_scene_view;
use crate::geometry::{offset_origin_scaled, InstanceGeometry, Ray, Shape};
use crate::render::rng::Rng;
use crate::render::{check_resolution, RayCaster, Renderer};
use crate::scene::{self, Object, ObjectId, View};
use crate::{Error, Result};

/// FNV-1a over 64-bit words: a fingerprint of the query results, so a
/// faster build can be checked to answer every query exactly as before.
struct Fingerprint(u64);

impl Fingerprint {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn word(&mut self, w: u64) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn hit(&mut self, h: &Option<crate::accel::Hit>) {
        match h {
            None => self.word(u64::MAX),
            Some(h) => {
                self.word(h.t.to_bits());
                self.word(h.object as u64);
                self.word(h.inner.map_or(u64::MAX, u64::from));
                for a in 0..3 {
                    self.word(h.normal[a].to_bits());
                }
            }
        }
    }
}

/// Bytes of the scene's objects (inline and heap), each instanced geometry
/// (its objects and octree) counted once.
fn object_bytes(objects: &[Object]) -> usize {
    fn walk(objects: &[Object], seen: &mut HashSet<*const InstanceGeometry>) -> usize {
        let mut n = 0;
        for o in objects {
            n += std::mem::size_of::<Object>() + o.name.capacity() + o.shape.heap_bytes();
            if let Shape::Instance(i) = &o.shape {
                if seen.insert(Arc::as_ptr(&i.geometry)) {
                    n += i.geometry.accel.memory_bytes() + walk(&i.geometry.objects, seen);
                }
            }
        }
        n
    }
    walk(objects, &mut HashSet::new())
}

use crate::report::peak_resident_bytes as peak_rss;

fn mib(b: usize) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

/// The timed nearest-hit queries (not inlined, so a profiler can attribute
/// them: `valgrind --tool=callgrind --toggle-collect='*trace_primary*'`).
#[inline(never)]
fn trace_primary<C: RayCaster>(
    caster: &C,
    rays: &[(Ray, f64, f64)],
    hits: &mut Vec<Option<crate::accel::Hit>>,
) {
    hits.clear();
    hits.extend(rays.iter().map(|(r, t0, t1)| caster.intersect(r, *t0, *t1)));
}

/// The timed any-hit queries (see [`trace_primary`]).
#[inline(never)]
fn trace_shadow<C: RayCaster>(
    caster: &C,
    rays: &[(Ray, f64, Option<ObjectId>)],
    blocked: &mut Vec<bool>,
) {
    blocked.clear();
    blocked.extend(
        rays.iter()
            .map(|(r, tmax, ign)| caster.occluded(r, 0.0, *tmax, *ign)),
    );
}

/// How many answers differ between two kernels' runs over the same rays.
fn differing<T: PartialEq>(a: &[T], b: &[T]) -> u64 {
    a.iter().zip(b).filter(|(x, y)| x != y).count() as u64
}

fn resolve_scene(a: &BenchArgs) -> Result<(PathBuf, View)> {
    resolve_scene_view(&a.scene, a.view_file.as_deref())
}

fn rate(n: u64, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64().max(1e-12) / 1e6
}

pub(super) fn run(a: &BenchArgs) -> Result<()> {
    check_resolution(a.width as usize, a.height as usize)?;
    if !a.scaling.is_empty() {
        return scaling(a);
    }
    if a.embree {
        return embree_run(a);
    }
    let options = options_from(&a.radiance, 0)?;
    let (path, view) = resolve_scene(a)?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let (w, h) = (w as usize, h as usize);
    let scene = scene::load(&[&path])?;
    let renderer = Renderer::new(&scene, options.clone())?;
    let caster = renderer.caster();
    let octree_caster = renderer.octree_caster();
    let ctx = renderer.context();
    let os = renderer.octree().stats();
    let built = renderer.stats(w, h, &Default::default(), 1.0).time;
    outln!(
        "scene {}: {} objects, {} lights; octree {} leaves, {} internal nodes, {} references, built in {:.3} s",
        path.display(),
        scene.stats.objects,
        scene.lights.len(),
        os.leaf_nodes,
        os.internal_nodes,
        os.object_refs,
        built.octree_build_s.unwrap_or(0.0)
    );

    let bs = renderer.bvh().stats();
    outln!(
        "hierarchy: {} nodes, {} leaves, {} objects, depth {}, built in {:.3} s",
        bs.nodes,
        bs.leaves,
        bs.objects,
        bs.depth,
        built.bvh_build_s
    );
    let rss_scene = peak_rss();

    // Primary rays, a chunk of pixels at a time, then the shadow rays from
    // their hits, a chunk at a time: the benchmark's own buffers do not grow
    // with the image.
    const CHUNK: usize = 4096;
    let pixels = w * h;
    let mut rays: Vec<(Ray, f64, f64)> = Vec::with_capacity(CHUNK);
    let mut hits: Vec<Option<crate::accel::Hit>> = Vec::with_capacity(CHUNK);
    let mut octree_hits: Vec<Option<crate::accel::Hit>> = Vec::with_capacity(CHUNK);
    let mut shadow: Vec<(Ray, f64, Option<ObjectId>)> = Vec::new();
    let mut blocked: Vec<bool> = Vec::new();
    let mut octree_blocked: Vec<bool> = Vec::new();
    let (mut primary_time, mut shadow_time) = (Duration::ZERO, Duration::ZERO);
    // The same queries through the octree, batch by batch beside the
    // hierarchy's (a slow spell of a shared machine hits both), and the
    // answers on which the two differ (there should be none).
    let (mut octree_primary, mut octree_shadow) = (Duration::ZERO, Duration::ZERO);
    let (mut differ_primary, mut differ_shadow) = (0u64, 0u64);
    let (mut n_primary, mut n_hits, mut n_shadow, mut n_blocked) = (0u64, 0u64, 0u64, 0u64);
    let (mut fp_primary, mut fp_shadow) = (Fingerprint::new(), Fingerprint::new());
    let mut rng = Rng::new(1);
    // Times one batch of shadow rays and folds its answers in.
    let mut flush = |shadow: &mut Vec<(Ray, f64, Option<ObjectId>)>| {
        if shadow.is_empty() {
            return;
        }
        let t0 = Instant::now();
        trace_shadow(&caster, shadow, &mut blocked);
        shadow_time += t0.elapsed();
        if a.octree {
            let t0 = Instant::now();
            trace_shadow(&octree_caster, shadow, &mut octree_blocked);
            octree_shadow += t0.elapsed();
            differ_shadow += differing(&blocked, &octree_blocked);
        }
        n_blocked += blocked.iter().filter(|&&b| b).count() as u64;
        for &b in &blocked {
            fp_shadow.word(b as u64);
        }
        n_shadow += shadow.len() as u64;
        shadow.clear();
    };
    let mut pixel = 0;
    while pixel < pixels {
        let end = (pixel + CHUNK).min(pixels);
        rays.clear();
        for p in pixel..end {
            let (x, y) = (p % w, p / w);
            let fx = (x as f64 + 0.5) / w as f64;
            let fy = 1.0 - (y as f64 + 0.5) / h as f64;
            if let Some(r) = crate::render::Camera::ray(&view, fx, fy) {
                rays.push(r);
            }
        }
        pixel = end;
        let t0 = Instant::now();
        trace_primary(&caster, &rays, &mut hits);
        primary_time += t0.elapsed();
        if a.octree {
            let t0 = Instant::now();
            trace_primary(&octree_caster, &rays, &mut octree_hits);
            octree_primary += t0.elapsed();
            differ_primary += differing(&hits, &octree_hits);
        }
        n_primary += rays.len() as u64;
        for h in &hits {
            fp_primary.hit(h);
        }
        for (i, hit) in hits.iter().enumerate() {
            let Some(hit) = hit else { continue };
            n_hits += 1;
            if scene.material(hit.material()).is_emitter() {
                continue;
            }
            let ray = &rays[i].0;
            let n = if hit.normal.dot(ray.dir) > 0.0 {
                -hit.normal
            } else {
                hit.normal
            };
            for l in renderer.lights() {
                l.for_each_patch(&scene, hit.point, options.ds, options.dj, &mut rng, |s| {
                    if s.dir.dot(n) > 0.0 {
                        let origin = offset_origin_scaled(hit.point, hit.normal, s.dir, hit.t);
                        let tmax = if s.dist.is_finite() {
                            s.dist * (1.0 - 1e-9)
                        } else {
                            f64::INFINITY
                        };
                        shadow.push((Ray { origin, dir: s.dir }, tmax, l.object));
                    }
                });
            }
            if shadow.len() >= 1 << 16 {
                flush(&mut shadow);
            }
        }
    }
    // Whatever is left, however the image ended.
    flush(&mut shadow);
    let _ = ctx;
    outln!(
        "primary rays: {} in {:.3} s = {:.2} Mrays/s ({} hits)",
        n_primary,
        primary_time.as_secs_f64(),
        rate(n_primary, primary_time),
        n_hits
    );
    outln!(
        "shadow rays: {} in {:.3} s = {:.2} Mrays/s ({} blocked)",
        n_shadow,
        shadow_time.as_secs_f64(),
        rate(n_shadow, shadow_time),
        n_blocked
    );
    outln!(
        "primary + shadow: {:.2} Mrays/s",
        rate(n_primary + n_shadow, primary_time + shadow_time)
    );
    outln!(
        "fingerprint: primary {:016x}, shadow {:016x}",
        fp_primary.0,
        fp_shadow.0
    );
    if a.octree {
        outln!(
        "octree kernel on the same rays: primary {:.2}, shadow {:.2}, primary + shadow {:.2} Mrays/s; hierarchy / octree {:.2}x; {} answers differ",
        rate(n_primary, octree_primary),
        rate(n_shadow, octree_shadow),
        rate(n_primary + n_shadow, octree_primary + octree_shadow),
        (octree_primary + octree_shadow).as_secs_f64()
            / (primary_time + shadow_time).as_secs_f64().max(1e-12),
        differ_primary + differ_shadow
    );
    }
    let rss_bench = peak_rss();

    let mut rss_render = None;
    if a.render {
        let (film, st) = renderer.render(&view, w, h)?;
        rss_render = peak_rss();
        drop(film);
        outln!(
            "full render {}x{}: {:.3} s, {} primary + {} shadow rays traced ({} estimated) = {:.2} Mrays/s",
            w, h, st.time.render_s, st.rays.primary, st.rays.shadow.tested, st.rays.shadow.estimated, st.mrays_per_s
        );
    }
    let show = |b: Option<usize>| b.map_or("n/a".to_string(), |b| format!("{:.1} MiB", mib(b)));
    outln!(
        "memory: octree {:.2} MiB, hierarchy {:.2} MiB, objects {:.2} MiB, film {:.2} MiB; peak RSS {} after loading, {} after the ray benchmark, {} after the render",
        mib(renderer.octree().memory_bytes()),
        mib(renderer.bvh().memory_bytes()),
        mib(object_bytes(&scene.objects)),
        mib(w * h * std::mem::size_of::<crate::scene::Color>()),
        show(rss_scene),
        show(rss_bench),
        if a.render { show(rss_render) } else { "-".to_string() }
    );
    Ok(())
}

/// `bench --scaling N,N,...`: the sequential renderer and the parallel
/// renderer (threads runtime, replicated and octree distributions, the
/// clip cache on as `render` has it) on each
/// processor count, every configuration run `--repeat` times in
/// interleaved rounds (so a slow spell of a shared machine hits all of
/// them), medians reported with their ratio to one processor.
fn scaling(a: &BenchArgs) -> Result<()> {
    use crate::parallel::{render_parallel, Distribution, ParallelOptions};
    if a.scaling.contains(&0) || a.repeat == 0 {
        return Err(super::common::usage(
            "--scaling counts and --repeat must be at least 1",
        ));
    }
    let options = options_from(&a.radiance, 0)?;
    let (path, view) = resolve_scene(a)?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let (w, h) = (w as usize, h as usize);
    let scene = Arc::new(scene::load(&[&path])?);
    let mut configs: Vec<(String, Option<ParallelOptions>)> = vec![("sequential".into(), None)];
    // The octree cut three times: with `render`'s defaults (a cache that
    // completes itself, `--complete-cache 50`, and data requests answered
    // on arrival); with requests answered between the owner's steps; and
    // the paper's way (its cache, which fetches only what tasks select,
    // and requests answered between steps).
    use hybrid_sched::DataService::{BetweenSteps, OnArrival};
    let groups = [
        ("replicated", Distribution::Replicated, Some(50), OnArrival),
        ("octree", Distribution::Octree, Some(50), OnArrival),
        (
            "octree, served between steps",
            Distribution::Octree,
            Some(50),
            BetweenSteps,
        ),
        (
            "octree, the paper's cache and service",
            Distribution::Octree,
            None,
            BetweenSteps,
        ),
    ];
    for (name, dist, complete, service) in groups {
        for &n in &a.scaling {
            let mut p = ParallelOptions::new(n);
            p.workload.distribution = dist;
            // As `render` does by default.
            p.workload.clip_cache = true;
            p.complete_cache = complete;
            p.data_service = service;
            configs.push((format!("{name} {n}"), Some(p)));
        }
    }
    // What the machine allows: N sequential renders at once, each on its
    // own thread, against one alone (the sequential row). Their speed-up is
    // N times one render's time over the N renders' time: it includes
    // whatever the cores share (caches, memory, clocks, a busy host), and
    // nothing of the parallel renderer.
    let at_once: Vec<usize> = a.scaling.iter().copied().filter(|&n| n > 1).collect();
    let mut once_times = vec![Vec::new(); at_once.len()];
    let sequential = || -> Result<crate::image::Film> {
        Ok(Renderer::new(&scene, options.clone())?
            .render(&view, w, h)?
            .0)
    };
    let mut times = vec![Vec::new(); configs.len()];
    let mut reference: Option<Vec<[u64; 3]>> = None;
    let bits = |f: &crate::image::Film| -> Vec<[u64; 3]> {
        f.pixels()
            .iter()
            .map(|c| c.to_array().map(f64::to_bits))
            .collect()
    };
    for round in 0..a.repeat {
        for (i, (name, popts)) in configs.iter().enumerate() {
            let t0 = Instant::now();
            let film = match popts {
                None => sequential()?,
                Some(p) => render_parallel(scene.clone(), options.clone(), &view, w, h, p)?.film,
            };
            let dt = t0.elapsed().as_secs_f64();
            let b = bits(&film);
            match &reference {
                None => reference = Some(b),
                Some(r) if *r != b => {
                    return Err(Error::Other(format!(
                        "{name}: the picture differs from the sequential one"
                    )))
                }
                _ => {}
            }
            eprintln!("  round {} {name}: {dt:.3} s", round + 1);
            times[i].push(dt);
        }
        for (k, &n) in at_once.iter().enumerate() {
            let t0 = Instant::now();
            let films: Vec<Result<crate::image::Film>> = std::thread::scope(|s| {
                let runs: Vec<_> = (0..n).map(|_| s.spawn(sequential)).collect();
                runs.into_iter()
                    .map(|r| {
                        r.join().unwrap_or_else(|_| {
                            Err(Error::Other("a sequential render panicked".into()))
                        })
                    })
                    .collect()
            });
            let dt = t0.elapsed().as_secs_f64();
            for film in films {
                if reference.as_ref() != Some(&bits(&film?)) {
                    return Err(Error::Other(format!(
                        "{n} sequential renders at once: a picture differs from the sequential one"
                    )));
                }
            }
            eprintln!(
                "  round {} {n} sequential renders at once: {dt:.3} s",
                round + 1
            );
            once_times[k].push(dt);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let med: Vec<f64> = times.iter_mut().map(median).collect();
    let once_med: Vec<f64> = once_times.iter_mut().map(median).collect();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    outln!(
        "{} at {w}x{h}, {} runs each (median), {cores} cores; every picture equals the sequential one bit for bit",
        path.display(),
        a.repeat
    );
    outln!("| renderer | processors | time (s) | speed-up over 1 processor | over sequential |");
    outln!("| --- | --- | --- | --- | --- |");
    outln!("| sequential | - | {:.3} | - | 1.00 |", med[0]);
    for (&n, &t) in at_once.iter().zip(&once_med) {
        // Throughput: n frames in t against one frame in med[0].
        outln!(
            "| {n} sequential renders at once (what the machine allows) | {n} | {t:.3} | {:.2} | - |",
            n as f64 * med[0] / t
        );
    }
    let per = a.scaling.len();
    for (d, (dist, ..)) in groups.iter().enumerate() {
        let one = a
            .scaling
            .iter()
            .position(|&n| n == 1)
            .map(|k| med[1 + d * per + k]);
        for (k, &n) in a.scaling.iter().enumerate() {
            let t = med[1 + d * per + k];
            let rel = one.map_or("-".to_string(), |o| format!("{:.2}", o / t));
            outln!("| {dist} | {n} | {t:.3} | {rel} | {:.2} |", med[0] / t);
        }
    }
    Ok(())
}

/// Steps around a curved surface.
#[cfg(feature = "embree")]
const SEGMENTS: usize = 16;
/// Rays per Embree stream (`rtcIntersect1M`, `rtcOccluded1M`).
#[cfg(feature = "embree")]
const STREAM: usize = 4096;

/// `bench --embree` without the `embree` feature: a usage error.
#[cfg(not(feature = "embree"))]
fn embree_run(_: &BenchArgs) -> Result<()> {
    Err(super::common::usage(
        "bench --embree needs a build with the `embree` feature (cargo build --release --features embree; Debian's libembree-dev)",
    ))
}

/// `bench --embree`: this project's hierarchy against Embree on the same
/// triangles and the same rays, in one run. The scene's shapes become
/// triangles ([`crate::geometry::tessellate`], curved surfaces in
/// [`SEGMENTS`] steps), each triangle one object of a [`Bvh`]
/// and one primitive of an Embree mesh. Primary rays: one per pixel centre.
/// Shadow rays: from each primary hit on a surface that does not emit,
/// towards the centre of each area light in front of it. Each query kind
/// is timed `--repeat` times in interleaved rounds (so a slow spell of a
/// shared machine hits all of them); medians are reported. The answers are
/// compared ray by ray: Embree's are single precision, so a ray may differ
/// where it grazes an edge or a corner, and the count of such rays is shown.
///
/// [`Bvh`]: crate::geometry::Bvh
#[cfg(feature = "embree")]
fn embree_run(a: &BenchArgs) -> Result<()> {
    use crate::accel::embree::{self as rtc, Embree, RtcRayHit, INVALID_ID};
    use crate::geometry::{tessellate, Bvh, Segment, Vec3, PACKET};
    use crate::render::Camera;
    use crate::scene::LightKind;

    if a.repeat == 0 {
        return Err(super::common::usage("--repeat must be at least 1"));
    }
    let (path, view) = resolve_scene(a)?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let (w, h) = (w as usize, h as usize);
    let scene = scene::load(&[&path])?;

    // The scene as triangles; `owner[i]`: the scene object triangle `i`
    // came from. Triangles too thin to be a polygon are left out of both.
    let (mut tris, mut owner, mut objects) = (Vec::new(), Vec::new(), Vec::new());
    let mut skipped = 0usize;
    let mut buf = Vec::new();
    for (i, o) in scene.objects.iter().enumerate() {
        buf.clear();
        tessellate(&o.shape, SEGMENTS, &mut buf);
        for t in &buf {
            match Shape::polygon(t.to_vec()) {
                Ok(shape) => {
                    tris.push(*t);
                    owner.push(i as ObjectId);
                    objects.push(Object {
                        name: String::new(),
                        shape,
                        material: o.material,
                    });
                }
                Err(_) => skipped += 1,
            }
        }
    }
    let extent = objects
        .iter()
        .fold(crate::geometry::Aabb::EMPTY, |b, o| {
            b.union(o.shape.bounds())
        })
        .extent()
        .max_element();

    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mut build_ours, mut build_embree) = (Vec::new(), Vec::new());
    let mut bvh = Bvh::default();
    let mut rtc_scene = None;
    for _ in 0..a.repeat {
        let t0 = Instant::now();
        bvh = Bvh::build(&objects);
        build_ours.push(t0.elapsed().as_secs_f64());
        drop(rtc_scene.take());
        let t0 = Instant::now();
        rtc_scene = Some(Embree::new(&tris).map_err(Error::Other)?);
        build_embree.push(t0.elapsed().as_secs_f64());
    }
    let rtc_scene = rtc_scene.expect("at least one round");

    // Primary rays.
    let mut primary = Vec::with_capacity(w * h);
    // Each tile of 8 x 8 pixels: the indices into `primary` of its rays.
    let tiles_x = w.div_ceil(8);
    let mut tiles: Vec<Vec<usize>> = vec![Vec::new(); tiles_x * h.div_ceil(8)];
    for p in 0..w * h {
        let (x, y) = (p % w, p / w);
        let fx = (x as f64 + 0.5) / w as f64;
        let fy = 1.0 - (y as f64 + 0.5) / h as f64;
        if let Some(r) = Camera::ray(&view, fx, fy) {
            tiles[(y / 8) * tiles_x + x / 8].push(primary.len());
            primary.push(r);
        }
    }
    tiles.retain(|t| !t.is_empty());
    // The packets' rays in one array, tile after tile, as Embree's
    // streams read theirs from one array; their hits written in place in
    // another, and put back in pixel order after the rounds.
    let packet_rays: Vec<Segment> = tiles.iter().flatten().map(|&i| primary[i]).collect();
    let packets: Vec<std::ops::Range<usize>> = tiles
        .iter()
        .scan(0, |at, t| {
            *at += t.len();
            Some(*at - t.len()..*at)
        })
        .collect();
    let mut tile_hits: Vec<Option<crate::accel::Hit>> = vec![None; primary.len()];
    let primary_rtc: Vec<RtcRayHit> = primary
        .iter()
        .map(|(r, t0, t1)| RtcRayHit {
            ray: rtc::ray(r.origin, r.dir, *t0, *t1),
            hit: rtc::RtcHit {
                geom_id: INVALID_ID,
                ..Default::default()
            },
        })
        .collect();
    let mut ours: Vec<Option<crate::accel::Hit>> = Vec::new();
    let (mut e1, mut em) = (primary_rtc.clone(), primary_rtc.clone());
    let (mut t_ours, mut t_e1, mut t_em) = (Vec::new(), Vec::new(), Vec::new());
    let mut t_packets = Vec::new();
    for _ in 0..a.repeat {
        let t0 = Instant::now();
        ours.clear();
        ours.extend(
            primary
                .iter()
                .map(|(r, t0, t1)| bvh.intersect(&objects, r, *t0, *t1)),
        );
        t_ours.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        for range in &packets {
            let rays = &packet_rays[range.clone()];
            bvh.intersect_packet(&objects, rays, &mut tile_hits[range.clone()]);
        }
        t_packets.push(t0.elapsed().as_secs_f64());
        e1.copy_from_slice(&primary_rtc);
        let t0 = Instant::now();
        rtc_scene.intersect1(&mut e1);
        t_e1.push(t0.elapsed().as_secs_f64());
        em.copy_from_slice(&primary_rtc);
        let t0 = Instant::now();
        rtc_scene.intersect_streams(&mut em, STREAM);
        t_em.push(t0.elapsed().as_secs_f64());
    }
    // Ray by ray: hit or miss, which triangle, how far.
    let hits_ours = ours.iter().filter(|h| h.is_some()).count();
    let hits_e1 = e1.iter().filter(|r| r.hit.geom_id != INVALID_ID).count();
    let hits_em = em.iter().filter(|r| r.hit.geom_id != INVALID_ID).count();
    let (mut other_prim, mut worst_dt, mut streams_differ) = (0usize, 0.0f64, 0usize);
    for ((h, r1), rm) in ours.iter().zip(&e1).zip(&em) {
        if (r1.hit.geom_id, r1.hit.prim_id, r1.ray.tfar.to_bits())
            != (rm.hit.geom_id, rm.hit.prim_id, rm.ray.tfar.to_bits())
        {
            streams_differ += 1;
        }
        match h {
            Some(h) if r1.hit.geom_id != INVALID_ID => {
                if h.object != r1.hit.prim_id {
                    other_prim += 1;
                }
                worst_dt = worst_dt.max((h.t - r1.ray.tfar as f64).abs() / h.t.max(1.0));
            }
            None if r1.hit.geom_id == INVALID_ID => {}
            _ => other_prim += 1,
        }
    }

    // Shadow rays from the hits towards the area lights' centres.
    let centres: Vec<Vec3> = scene
        .lights
        .iter()
        .filter_map(|l| match l.kind {
            LightKind::Area { object } => {
                Some(scene.objects[object as usize].shape.bounds().center())
            }
            LightKind::Distant { .. } => None,
        })
        .collect();
    let tmin = 1e-4 * extent;
    let mut shadow = Vec::new();
    // Each shadow ray's tile and light, to bundle them as packets.
    let mut tile_of = vec![0usize; primary.len()];
    for (k, t) in tiles.iter().enumerate() {
        for &i in t {
            tile_of[i] = k;
        }
    }
    let mut bundle_of = Vec::new();
    for (i, ((r, _, _), h)) in primary.iter().zip(&ours).enumerate() {
        let Some(h) = h else { continue };
        let o = &scene.objects[owner[h.object as usize] as usize];
        if scene.material(o.material).is_emitter() {
            continue;
        }
        let n = if h.normal.dot(r.dir) > 0.0 {
            -h.normal
        } else {
            h.normal
        };
        for (l, &c) in centres.iter().enumerate() {
            let d = c - h.point;
            let dist = d.length();
            if dist > 0.0 && d.dot(n) > 0.0 {
                bundle_of.push((tile_of[i], l, shadow.len()));
                shadow.push((Ray::new(h.point, d), dist * (1.0 - 1e-4)));
            }
        }
    }
    // Packets: the rays of one tile towards one light, at most PACKET.
    bundle_of.sort_unstable();
    let mut shadow_packets: Vec<(Vec<usize>, Vec<Segment>)> = Vec::new();
    for run in bundle_of.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
        for part in run.chunks(PACKET) {
            let idx: Vec<usize> = part.iter().map(|b| b.2).collect();
            let rays = idx
                .iter()
                .map(|&k| (shadow[k].0, tmin, shadow[k].1))
                .collect();
            shadow_packets.push((idx, rays));
        }
    }
    let mut packet_blocked = vec![false; shadow.len()];
    let mut buf_blocked = [false; PACKET];
    let shadow_rtc: Vec<rtc::RtcRay> = shadow
        .iter()
        .map(|(r, tmax)| rtc::ray(r.origin, r.dir, tmin, *tmax))
        .collect();
    let mut blocked: Vec<bool> = Vec::new();
    let (mut s1, mut sm) = (shadow_rtc.clone(), shadow_rtc.clone());
    let (mut ts_ours, mut ts_e1, mut ts_em) = (Vec::new(), Vec::new(), Vec::new());
    let mut ts_packets = Vec::new();
    for _ in 0..a.repeat {
        let t0 = Instant::now();
        blocked.clear();
        blocked.extend(
            shadow
                .iter()
                .map(|(r, tmax)| bvh.occluded(&objects, r, tmin, *tmax, None)),
        );
        ts_ours.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        for (idx, rays) in &shadow_packets {
            bvh.occluded_packet(&objects, rays, None, &mut buf_blocked);
            for (&k, &b) in idx.iter().zip(&buf_blocked) {
                packet_blocked[k] = b;
            }
        }
        ts_packets.push(t0.elapsed().as_secs_f64());
        s1.copy_from_slice(&shadow_rtc);
        let t0 = Instant::now();
        rtc_scene.occluded1(&mut s1);
        ts_e1.push(t0.elapsed().as_secs_f64());
        sm.copy_from_slice(&shadow_rtc);
        let t0 = Instant::now();
        rtc_scene.occluded_streams(&mut sm, STREAM);
        ts_em.push(t0.elapsed().as_secs_f64());
    }
    let is_blocked = |r: &rtc::RtcRay| r.tfar == f32::NEG_INFINITY;
    let blocked_ours = blocked.iter().filter(|&&b| b).count();
    let blocked_e1 = s1.iter().filter(|r| is_blocked(r)).count();
    let blocked_em = sm.iter().filter(|r| is_blocked(r)).count();
    let shadow_differ = blocked
        .iter()
        .zip(&s1)
        .filter(|(&b, r)| b != is_blocked(r))
        .count();

    let mrays = |n: usize, t: f64| n as f64 / t.max(1e-12) / 1e6;
    let (p, s) = (primary.len(), shadow.len());
    let (b_o, b_e) = (median(&mut build_ours), median(&mut build_embree));
    let (po, p1, pm) = (median(&mut t_ours), median(&mut t_e1), median(&mut t_em));
    let pp = median(&mut t_packets);
    let mut packet_hits: Vec<Option<crate::accel::Hit>> = vec![None; primary.len()];
    for (&i, h) in tiles.iter().flatten().zip(&tile_hits) {
        packet_hits[i] = *h;
    }
    let packets_differ = differing(&ours, &packet_hits);
    let (so, s1t, smt) = (median(&mut ts_ours), median(&mut ts_e1), median(&mut ts_em));
    let sp = median(&mut ts_packets);
    let shadow_packets_differ = differing(&blocked, &packet_blocked);
    outln!(
        "{} at {w}x{h}: {} objects as {} triangles ({} too thin, left out; curved surfaces in {SEGMENTS} steps), {} area lights; median of {} rounds",
        path.display(),
        scene.objects.len(),
        tris.len(),
        skipped,
        centres.len(),
        a.repeat
    );
    outln!("| | this project (hierarchy) | Embree, one ray at a time | Embree, streams of {STREAM} | speed here / one at a time | speed here / streams |");
    outln!("| --- | --- | --- | --- | --- | --- |");
    outln!(
        "| build (ms) | {:.1} | {:.1} | - | {:.3} | - |",
        b_o * 1e3,
        b_e * 1e3,
        b_e / b_o.max(1e-12)
    );
    // A row of rays: here (time `here`) against Embree one at a time and
    // in streams.
    let row = |what: String, n: usize, here: f64, one: f64, streams: f64| {
        outln!(
            "| {what}, Mrays/s | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} |",
            mrays(n, here),
            mrays(n, one),
            mrays(n, streams),
            one / here.max(1e-12),
            streams / here.max(1e-12)
        );
    };
    row(format!("primary rays ({p})"), p, po, p1, pm);
    row(
        format!("primary rays as packets of 8x8 ({} tiles)", packets.len()),
        p,
        pp,
        p1,
        pm,
    );
    row(format!("shadow rays ({s})"), s, so, s1t, smt);
    row(
        format!(
            "shadow rays as packets ({} of one tile towards one light)",
            shadow_packets.len()
        ),
        s,
        sp,
        s1t,
        smt,
    );
    outln!(
        "primary hits: {hits_ours} here ({packets_differ} answered differently as packets), {hits_e1} Embree one at a time, {hits_em} streams; {other_prim} rays hit another triangle (or only one kernel hits); largest distance difference on the same triangle {worst_dt:.1e} (relative); {streams_differ} rays differ between Embree's two modes"
    );
    outln!(
        "shadow rays blocked: {blocked_ours} here ({shadow_packets_differ} answered differently as packets), {blocked_e1} Embree one at a time, {blocked_em} streams; {shadow_differ} rays answered differently"
    );
    Ok(())
}
