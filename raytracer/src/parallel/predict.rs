//! Predicted work per octree cell, for a data distribution that equalises
//! work instead of memory (the paper's third open problem).
//!
//! A coarse pre-pass (at most 64 x 64 primary rays over the image) traces
//! each sample's primary ray and, from its hit, one shadow ray towards the
//! middle of every light source, and charges every non-empty leaf the ray
//! passes before it stops with what the cost model says a visit costs
//! there: a leaf step plus one intersection test per object listed. Shadow
//! rays are weighted by the number of rays adaptive testing would trace
//! towards that source, and a hit's leaf is charged one shading. The
//! prediction is cheap (a few thousand rays) and deterministic.

use crate::accel::Octree;
use crate::geometry::Ray;
use crate::render::light::LightExtent;
use crate::render::Renderer;
use crate::scene::View;

use super::cost::unit_ns as unit;
use super::work::Work;

/// Predicted cost of every node's subtree (ns of the cost model), indexed
/// by node id: each leaf's predicted work, summed upwards.
pub fn subtree_costs(
    renderer: &Renderer<'_>,
    view: &View,
    width: usize,
    height: usize,
) -> Vec<u64> {
    let octree = renderer.octree();
    let scene = renderer.scene();
    let objects = &scene.objects;
    let mut leaf = vec![0f64; octree.node_count()];
    let (leaf_ns, object_ns) = (unit(Work::TraceLeaves), unit(Work::TraceObjects));
    let shade_ns = unit(Work::Shade);
    let walk = |leaf: &mut [f64], o: &Octree, ray: &Ray, t0: f64, t1: f64, weight: f64| {
        o.for_each_leaf_along_ray(ray, t0, t1, |l, _, _| {
            let n = o.leaf_objects(l).len();
            if n > 0 {
                leaf[l as usize] += weight * (leaf_ns + object_ns * n as f64);
            }
            false
        });
    };
    let sx = width.clamp(1, 64);
    let sy = height.clamp(1, 64);
    let ds = renderer.options().ds;
    let mut hits = Vec::new();
    for j in 0..sy {
        for i in 0..sx {
            let x = (i * width / sx).min(width - 1);
            let y = (j * height / sy).min(height - 1);
            let Some(task) = renderer.primary_task(view, width, height, x, y) else {
                continue;
            };
            let hit = octree.intersect(objects, &task.ray, task.tmin, task.tmax);
            let tmax = hit.map_or(task.tmax, |h| h.t);
            walk(&mut leaf, octree, &task.ray, task.tmin, tmax, 1.0);
            if let Some(h) = hit {
                hits.push(h);
            }
        }
    }
    for h in &hits {
        if let Some(l) = octree.find_leaf(h.point) {
            leaf[l as usize] += shade_ns;
        }
        for light in renderer.lights() {
            let weight = light.patch_estimate(h.point, ds) as f64;
            let (dir, dist) = match light.extent() {
                Some(LightExtent::Finite(b)) => {
                    let d = b.center() - h.point;
                    let len = d.length();
                    if !(len > 0.0 && len.is_finite()) {
                        continue;
                    }
                    (d / len, len)
                }
                Some(LightExtent::Distant { dir, .. }) => (dir, f64::INFINITY),
                None => continue,
            };
            let ray = Ray {
                origin: h.point,
                dir,
            };
            let eps = 1e-6 * (1.0 + h.t);
            walk(&mut leaf, octree, &ray, eps, dist, weight);
        }
    }
    let mut out: Vec<u64> = leaf.iter().map(|&c| c.round() as u64).collect();
    octree.sum_subtrees(&mut out);
    out
}

/// Image size the prediction of a compiled scene's stored view is made
/// at: `render`'s default maxima, fitted to the view's aspect.
const COMPILED_SIZE: u32 = 512;

/// [`subtree_costs`] for `hybrid-rt compile`
/// ([`crate::compiled::Predictor`]), for each view: the whole scene's,
/// with the octree built as the compiled skeleton is (one renderer for
/// every view), the default options, at `render`'s default image size
/// fitted to the view.
pub fn for_compiled_scene(
    scene: &crate::scene::Scene,
    params: &crate::accel::OctreeParams,
    views: &[View],
) -> crate::Result<Vec<Vec<u64>>> {
    let renderer = Renderer::with_octree(scene, crate::render::RenderOptions::default(), params)?;
    Ok(views
        .iter()
        .map(|view| {
            let (view, w, h) = view.fit_aspect(COMPILED_SIZE, COMPILED_SIZE);
            subtree_costs(&renderer, &view, w as usize, h as usize)
        })
        .collect())
}
