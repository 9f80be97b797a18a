//! `hybrid-rt bench`: measured ray throughput.
//!
//! Primary rays: nearest-hit queries for every pixel's primary ray.
//! Shadow rays: any-hit queries from every primary hit on a lit surface
//! towards every patch of every source (the rays adaptive testing would
//! trace with `-dt 0`). Only the queries are timed; generating the rays is
//! not. Optionally a full render for its rate of primary plus shadow rays.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use super::args::BenchArgs;
use super::options_from;
use super::render::build_view;
use crate::geometry::{offset_origin_scaled, Ray};
use crate::render::material::hit_object;
use crate::render::rng::Rng;
use crate::render::{check_resolution, RayCaster, Renderer};
use crate::scene::{self, ObjectId, View};
use crate::{Error, Result};

/// Where the built-in scenes live: `examples/scenes` under the current
/// directory or the workspace this binary was built from.
fn builtin_dir() -> Vec<PathBuf> {
    vec![
        PathBuf::from("examples/scenes"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes"),
    ]
}

/// A built-in scene name (cornell, studio, conference) or a scene file, with
/// its view file (`view_file`, else the `.vf` next to the scene).
pub(super) fn resolve_scene_view(scene: &str, view_file: Option<&Path>) -> Result<(PathBuf, View)> {
    let (scene_path, default_vf) = if matches!(scene, "cornell" | "studio" | "conference") {
        let found = builtin_dir()
            .into_iter()
            .map(|d| d.join(format!("{scene}.rad")))
            .find(|p| p.is_file());
        let Some(p) = found else {
            return Err(Error::Other(format!(
                "built-in scene {scene:?} not found (looked for examples/scenes/{scene}.rad)"
            )));
        };
        let vf = p.with_extension("vf");
        (p, vf)
    } else {
        let p = PathBuf::from(scene);
        let vf = p.with_extension("vf");
        (p, vf)
    };
    if !scene_path.is_file() {
        return Err(Error::io(
            &scene_path,
            std::io::Error::from(std::io::ErrorKind::NotFound),
        ));
    }
    let vf = view_file.map(Path::to_path_buf).unwrap_or(default_vf);
    let view = build_view(Some(&vf), &[], &[])?;
    Ok((scene_path, view))
}

fn resolve_scene(a: &BenchArgs) -> Result<(PathBuf, View)> {
    resolve_scene_view(&a.scene, a.view_file.as_deref())
}

fn rate(n: u64, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64().max(1e-12) / 1e6
}

pub(super) fn run(a: &BenchArgs) -> Result<()> {
    check_resolution(a.width as usize, a.height as usize)?;
    let options = options_from(&a.radiance, 0)?;
    let (path, view) = resolve_scene(a)?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let (w, h) = (w as usize, h as usize);
    let scene = scene::load(&[&path])?;
    let renderer = Renderer::new(&scene, options.clone())?;
    let caster = renderer.caster();
    let ctx = renderer.context();
    let os = renderer.octree().stats();
    println!(
        "scene {}: {} objects, {} lights; octree {} leaves, {} internal nodes, {} references, built in {:.3} s",
        path.display(),
        scene.stats.objects,
        scene.lights.len(),
        os.leaf_nodes,
        os.internal_nodes,
        os.object_refs,
        renderer.stats(w, h, &Default::default(), 1.0).time.octree_build_s
    );

    // Primary rays.
    let mut rays: Vec<(Ray, f64, f64)> = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let fx = (x as f64 + 0.5) / w as f64;
            let fy = 1.0 - (y as f64 + 0.5) / h as f64;
            if let Some(r) = crate::render::Camera::ray(&view, fx, fy) {
                rays.push(r);
            }
        }
    }
    let t0 = Instant::now();
    let hits: Vec<_> = rays
        .iter()
        .map(|(r, t0, t1)| caster.intersect(r, *t0, *t1))
        .collect();
    let primary_time = t0.elapsed();
    println!(
        "primary rays: {} in {:.3} s = {:.2} Mrays/s ({} hits)",
        rays.len(),
        primary_time.as_secs_f64(),
        rate(rays.len() as u64, primary_time),
        hits.iter().flatten().count()
    );

    // Shadow rays, one chunk at a time so memory stays small.
    let mut shadow: Vec<(Ray, f64, Option<ObjectId>)> = Vec::new();
    let mut shadow_time = Duration::ZERO;
    let mut n_shadow = 0u64;
    let mut n_blocked = 0u64;
    let mut rng = Rng::new(1);
    for (i, hit) in hits.iter().enumerate() {
        let Some(hit) = hit else { continue };
        if scene
            .material(hit_object(&scene, hit).material)
            .is_emitter()
        {
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
        if shadow.len() >= 1 << 16 || i + 1 == hits.len() {
            let t0 = Instant::now();
            n_blocked += shadow
                .iter()
                .filter(|(r, tmax, ign)| caster.occluded(r, 0.0, *tmax, *ign))
                .count() as u64;
            shadow_time += t0.elapsed();
            n_shadow += shadow.len() as u64;
            shadow.clear();
        }
    }
    let _ = ctx;
    println!(
        "shadow rays: {} in {:.3} s = {:.2} Mrays/s ({} blocked)",
        n_shadow,
        shadow_time.as_secs_f64(),
        rate(n_shadow, shadow_time),
        n_blocked
    );
    let both = rays.len() as u64 + n_shadow;
    println!(
        "primary + shadow: {:.2} Mrays/s",
        rate(both, primary_time + shadow_time)
    );

    if a.render {
        let (_, st) = renderer.render(&view, w, h)?;
        let traced = st.rays.primary + st.rays.shadow.tested;
        println!(
            "full render {}x{}: {:.3} s, {} primary + {} shadow rays traced ({} estimated) = {:.2} Mrays/s",
            w, h, st.time.render_s, st.rays.primary, st.rays.shadow.tested, st.rays.shadow.estimated, st.mrays_per_s
        );
        let _ = traced;
    }
    Ok(())
}
