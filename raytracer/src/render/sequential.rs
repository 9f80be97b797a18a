//! The sequential reference renderer: every pixel's primary ray, its hit
//! shaded by [`shade`], the requested secondary work evaluated depth first
//! in request order. It is the oracle the parallel renderer must match.

use std::ops::{Deref, Range};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

use super::adaptive::Grid;
use super::ambient::{AmbientCache, AmbientRequest, AmbientSettings, AmbientStore, Hemisphere};
use super::caster::{BvhCaster, OctreeCaster, RayCaster};
use super::direct::{estimate_hit_ratios, run_shadow_bundle, Patches};
use super::effects::EffectsReport;
use super::light::PreparedLight;
use super::material::{shade, RayKind, RayTask, Request, ShadeContext};
use super::medium::{self, Media};
use super::options::RenderOptions;
use super::rng::{child_seed, pixel_seed, Rng};
use super::stats::{EffectTimes, RayCounts, RenderStats, Timings};
use super::virtual_source::prepare_lights_relayed;
use super::waves::render_in_waves;
use crate::accel::{Bvh, Hit, Octree, OctreeParams};
use crate::geometry::FTINY;
use crate::geometry::{offset_origin_scaled, Ray, Segment, Vec3, PACKET};
use crate::image::Film;
use crate::scene::{Color, LightKind, Material, MaterialId, Scene};
use crate::{Error, Result};

pub use super::options::{MAX_PIXELS, MAX_SIDE};

/// Maps image coordinates to primary rays: `x` in [0, 1] left to right,
/// `y` in [0, 1] **bottom to top** (Radiance's convention). Returns the
/// ray and its valid distance range, or `None` where the view has no ray
/// (outside a fisheye's circle).
pub trait Camera {
    fn ray(&self, x: f64, y: f64) -> Option<(Ray, f64, f64)>;
}

impl<F: Fn(f64, f64) -> Option<(Ray, f64, f64)>> Camera for F {
    fn ray(&self, x: f64, y: f64) -> Option<(Ray, f64, f64)> {
        self(x, y)
    }
}

impl Camera for crate::scene::View {
    fn ray(&self, x: f64, y: f64) -> Option<(Ray, f64, f64)> {
        crate::scene::View::ray(self, x, y)
    }
}

/// A rectangle of pixels `[x0, x1) x [y0, y1)` (row 0 at the top): a
/// region rendered at once, or a tile of the parallel renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Region {
    /// The region of columns `x` and rows `y` (each below `u32::MAX`).
    pub fn new(x: Range<usize>, y: Range<usize>) -> Region {
        Region {
            x0: x.start as u32,
            y0: y.start as u32,
            x1: x.end as u32,
            y1: y.end as u32,
        }
    }

    /// The columns `x0..x1`.
    pub fn xs(&self) -> Range<usize> {
        self.x0 as usize..self.x1 as usize
    }

    /// The rows `y0..y1`.
    pub fn ys(&self) -> Range<usize> {
        self.y0 as usize..self.y1 as usize
    }
}

/// Per-thread working memory and tallies: reused buffers (so tracing does
/// not allocate per ray) and the counts and times of the work done.
#[derive(Debug, Default)]
pub struct TraceState {
    requests: Vec<Request>,
    patches: Patches,
    pub counts: RayCounts,
    pub times: EffectTimes,
    /// Whether [`TraceState::times`] is measured: two clock readings per
    /// ray and per shadow bundle, about a tenth of a render's time
    /// (`--stats` turns it on).
    pub timing: bool,
    nested: Duration,
    /// The irradiance cache this state reads and fills (`-ab` > 0).
    pub ambient: AmbientStore,
}

impl TraceState {
    /// A state whose irradiance cache is `store` (shared between threads).
    pub fn with_store(store: AmbientStore) -> Self {
        Self {
            ambient: store,
            ..Self::default()
        }
    }
}

#[derive(Clone, Copy)]
enum Bucket {
    Primary,
    Direct,
    Reflection,
    Refraction,
    Ambient,
}

/// The bucket a ray of `kind` is timed in.
fn bucket_of(kind: RayKind) -> Bucket {
    match kind {
        RayKind::Primary | RayKind::PassThrough => Bucket::Primary,
        RayKind::Reflection => Bucket::Reflection,
        RayKind::Refraction => Bucket::Refraction,
        RayKind::Ambient => Bucket::Ambient,
    }
}

/// Counts a ray of `kind` traced.
fn count_ray(kind: RayKind, st: &mut TraceState) {
    let c = &mut st.counts;
    match kind {
        RayKind::Primary => c.primary += 1,
        RayKind::Reflection => c.reflection += 1,
        RayKind::Refraction => c.refraction += 1,
        RayKind::PassThrough => c.pass_through += 1,
        RayKind::Ambient => c.ambient += 1,
    }
}

/// A distant source as rays that leave the scene see it (Radiance's
/// `sourcehit()` and `m_light()`).
#[derive(Debug, Clone)]
struct SkySource {
    dir: Vec3,
    cos_half: f64,
    material: MaterialId,
    role: SkyRole,
}

/// How `sourcehit()` chooses among distant sources containing a direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SkyRole {
    /// Taken at once (the first in scene order wins).
    Source,
    /// A glow: used only when no other source contains the direction.
    Glow,
    /// An illum without alternate: never shown; it hides the glows
    /// behind it from sampled rays.
    TransIllum,
}

/// A scene a renderer reads: borrowed, or shared (for renderers that must
/// be `'static`, such as the parallel workload).
#[derive(Debug, Clone)]
pub enum SceneRef<'s> {
    Borrowed(&'s Scene),
    Shared(Arc<Scene>),
}

impl Deref for SceneRef<'_> {
    type Target = Scene;
    fn deref(&self) -> &Scene {
        match self {
            SceneRef::Borrowed(s) => s,
            SceneRef::Shared(s) => s,
        }
    }
}

/// `f()` and the seconds it took.
fn timed_build<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t0 = Instant::now();
    let r = f();
    (r, t0.elapsed().as_secs_f64())
}

/// The sequential renderer for one scene and option set.
#[derive(Debug)]
pub struct Renderer<'s> {
    scene: SceneRef<'s>,
    options: RenderOptions,
    /// The octree and its build time: built by the constructors for a
    /// parallel render, read with a distributed scene's skeleton, and on
    /// first use for a sequential renderer ([`Renderer::new`]), which
    /// traces through the hierarchy (building it took the 1.5M-triangle
    /// city's sequential render 2.8 s of its 4.4 s to start).
    octree: OnceLock<(Octree, f64)>,
    /// The parameters the octree is built with.
    params: OctreeParams,
    /// The hierarchy and its build time: built with the octree by the
    /// constructors for rendering, on first use for a renderer whose rays
    /// go through the octree's cells ([`Renderer::shared_lazy_bvh`]).
    bvh: OnceLock<(Bvh, f64)>,
    lights: Vec<PreparedLight>,
    sky: Vec<SkySource>,
    effects: EffectsReport,
    warnings: Vec<String>,
    ambient: AmbientSettings,
    media: Media,
    /// Whether renders measure the time of each effect
    /// ([`Renderer::with_effect_times`]).
    effect_times: bool,
}

impl<'s> Renderer<'s> {
    /// Validates the options, builds the hierarchy rays are traced
    /// through, prepares the lights and analyses which effects the scene
    /// needs. The octree (default parameters) is built if something asks
    /// for it ([`Renderer::octree`]).
    pub fn new(scene: &'s Scene, options: RenderOptions) -> Result<Self> {
        Self::build(
            SceneRef::Borrowed(scene),
            options,
            &OctreeParams::default(),
            Build::LazyOctree,
        )
    }

    /// [`Renderer::new`] with the octree built at once with `params`.
    pub fn with_octree(
        scene: &'s Scene,
        options: RenderOptions,
        params: &OctreeParams,
    ) -> Result<Self> {
        Self::build(SceneRef::Borrowed(scene), options, params, Build::Both)
    }

    /// A renderer that shares ownership of its scene.
    pub fn shared(
        scene: Arc<Scene>,
        options: RenderOptions,
        params: &OctreeParams,
    ) -> Result<Renderer<'static>> {
        Renderer::build(SceneRef::Shared(scene), options, params, Build::Both)
    }

    /// [`Renderer::shared`] for a caller whose rays go through the octree's
    /// cells: the hierarchy is built only if something asks for it.
    pub fn shared_lazy_bvh(
        scene: Arc<Scene>,
        options: RenderOptions,
        params: &OctreeParams,
    ) -> Result<Renderer<'static>> {
        Renderer::build(SceneRef::Shared(scene), options, params, Build::LazyBvh)
    }

    /// A renderer for a processor holding part of a scene (a
    /// [`Scene::distributed`] one): `octree` is the whole scene's octree
    /// skeleton, read with it; rays go through the octree's cells, and
    /// only the leaves the caller holds can be traced.
    pub fn with_skeleton(
        scene: Arc<Scene>,
        options: RenderOptions,
        octree: Octree,
    ) -> Result<Renderer<'static>> {
        Renderer::build(
            SceneRef::Shared(scene),
            options,
            &OctreeParams::default(),
            Build::Skeleton(Box::new(octree)),
        )
    }

    fn build(
        scene: SceneRef<'s>,
        options: RenderOptions,
        params: &OctreeParams,
        build: Build,
    ) -> Result<Self> {
        options.validate()?;
        // An empty scene would render a silently black image.
        if scene.object_count() == 0 && scene.lights.is_empty() {
            return Err(Error::Other(
                "the scene is empty: no surfaces and no light sources".into(),
            ));
        }
        let objects = &scene.objects;
        let bvh = OnceLock::new();
        let octree = OnceLock::new();
        match build {
            // The two structures side by side, each timed on its own thread.
            Build::Both => {
                let (built, other) = std::thread::scope(|s| {
                    let other = s.spawn(|| timed_build(|| Bvh::build(objects)));
                    let built = timed_build(|| Octree::build(objects, params));
                    (
                        built,
                        other
                            .join()
                            .unwrap_or_else(|p| std::panic::resume_unwind(p)),
                    )
                });
                let _ = octree.set(built);
                let _ = bvh.set(other);
            }
            Build::LazyOctree => {
                let _ = bvh.set(timed_build(|| Bvh::build(objects)));
            }
            Build::LazyBvh => {
                let _ = octree.set(timed_build(|| Octree::build(objects, params)));
            }
            Build::Skeleton(o) => {
                let _ = octree.set((*o, 0.0));
            }
        }
        let built = octree.get().map(|(o, s): &(Octree, f64)| (o.stats(), *s));
        tracing::debug!(
            objects = objects.len(),
            octree_leaves = built.map(|(st, _)| st.leaf_nodes),
            octree_internal = built.map(|(st, _)| st.internal_nodes),
            octree_depth = built.map(|(st, _)| st.max_depth),
            octree_refs = built.map(|(st, _)| st.object_refs),
            octree_seconds = built.map(|(_, s)| s),
            bvh_nodes = bvh.get().map(|b: &(Bvh, f64)| b.0.stats().nodes),
            bvh_depth = bvh.get().map(|b: &(Bvh, f64)| b.0.stats().depth),
            bvh_seconds = bvh.get().map(|b: &(Bvh, f64)| b.1),
            "acceleration structures built"
        );
        // The octree's root cell, which the irradiance cache's radii scale
        // with: the same whether the octree is built now or later.
        let root_bounds = match octree.get() {
            Some((o, _)) => o.root_bounds(),
            None => Octree::root_bounds_of(objects, params),
        };
        let (mut lights, mut warnings) = prepare_lights_relayed(&scene, options.dr);
        if scene.lights.is_empty() && options.av == Color::ZERO {
            warnings.push(
                "no light sources and no ambient value (-av): only emitting surfaces will be visible"
                    .into(),
            );
        }
        let effects = EffectsReport::analyse(&scene, &options, &lights);
        let (media, media_warnings) = Media::new(&scene, &options, &lights);
        warnings.extend(media_warnings);
        // The stored ratios are for these light sources if there are as
        // many and `-dr` made the same virtual ones (it makes none where
        // nothing relays light).
        let stored = scene.hit_ratios.as_ref().filter(|h| {
            h.ratios.len() == lights.len()
                && (h.dr == options.dr || lights.iter().all(|l| l.virt.is_none()))
        });
        if let Some(h) = stored.filter(|_| effects.adaptive_shadow_testing.enabled) {
            for (l, &r) in lights.iter_mut().zip(&h.ratios) {
                l.hit_ratio = r;
            }
        } else if effects.adaptive_shadow_testing.enabled && scene.distributed.is_some() {
            return Err(Error::Usage(format!(
                "this processor holds part of the scene, and the compiled scene's hit ratios were measured for {}; this render prepares {} light sources with -dr {} (render with the -dr the scene was compiled with, or render it whole: --distribution replicated, or no --procs)",
                scene.hit_ratios.as_ref().map_or("no light sources".to_string(), |h| format!("{} light sources with -dr {}", h.ratios.len(), h.dr)),
                lights.len(),
                options.dr
            )));
        } else if effects.adaptive_shadow_testing.enabled {
            let ctx = ShadeContext {
                scene: &scene,
                options: &options,
                lights: &lights,
                effects: &effects,
                media: &media,
            };
            // Through whichever structure is built: their answers are the
            // same.
            let ratios = match (bvh.get(), octree.get()) {
                (Some((bvh, _)), _) => estimate_hit_ratios(
                    &ctx,
                    &BvhCaster {
                        bvh,
                        objects: &scene.objects,
                    },
                    root_bounds,
                ),
                (None, Some((octree, _))) => estimate_hit_ratios(
                    &ctx,
                    &OctreeCaster {
                        octree,
                        objects: &scene.objects,
                    },
                    root_bounds,
                ),
                (None, None) => {
                    return Err(Error::Other(
                        "internal: the renderer built neither an octree nor a hierarchy".into(),
                    ))
                }
            };
            for (l, r) in lights.iter_mut().zip(ratios) {
                l.hit_ratio = r;
            }
        }
        tracing::debug!(
            lights = lights.len(),
            virtual_lights = lights.iter().filter(|l| l.virt.is_some()).count(),
            // Radiance's nhits/ntests per source (the first 16).
            hit_ratios = ?lights.iter().take(16).map(|l| (l.hit_ratio * 1000.0).round() / 1000.0).collect::<Vec<_>>(),
            "lights prepared"
        );
        let ext = root_bounds;
        let ambient = AmbientSettings::new(&options, (ext.max - ext.min).max_element());
        let sky = scene
            .lights
            .iter()
            .filter_map(|l| {
                let LightKind::Distant {
                    dir, solid_angle, ..
                } = &l.kind
                else {
                    return None;
                };
                let role = match scene.materials.get(l.material as usize)? {
                    Material::Glow { .. } => SkyRole::Glow,
                    Material::Illum {
                        alternate: None, ..
                    } => SkyRole::TransIllum,
                    _ => SkyRole::Source,
                };
                let len = dir.length();
                (len > 0.0 && solid_angle.is_finite() && *solid_angle > 0.0).then(|| SkySource {
                    dir: *dir / len,
                    cos_half: 1.0
                        - solid_angle.min(4.0 * std::f64::consts::PI)
                            / (2.0 * std::f64::consts::PI),
                    material: l.material,
                    role,
                })
            })
            .collect();
        Ok(Self {
            scene,
            options,
            octree,
            params: params.clone(),
            bvh,
            lights,
            sky,
            effects,
            warnings,
            ambient,
            media,
            effect_times: false,
        })
    }

    /// This renderer, measuring in its renders' statistics the time each
    /// effect takes (`RenderStats::time`: primary rays, direct light,
    /// reflection, refraction, inter-reflection). Off by default: two
    /// clock readings per ray and per shadow bundle cost about a tenth of
    /// a render.
    pub fn with_effect_times(mut self, on: bool) -> Self {
        self.effect_times = on;
        self
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    pub fn options(&self) -> &RenderOptions {
        &self.options
    }
    /// The octree over the whole scene (or, for a processor of a
    /// distributed scene, its skeleton), built on first use where the
    /// constructor did not build it.
    pub fn octree(&self) -> &Octree {
        &self
            .octree
            .get_or_init(|| {
                let (o, s) = timed_build(|| Octree::build(&self.scene.objects, &self.params));
                tracing::debug!(
                    leaves = o.stats().leaf_nodes,
                    seconds = s,
                    "octree built on first use"
                );
                (o, s)
            })
            .0
    }
    pub fn lights(&self) -> &[PreparedLight] {
        &self.lights
    }
    pub fn effects(&self) -> &EffectsReport {
        &self.effects
    }
    /// Irradiance cache parameters (derived from `-a*` and the scene size).
    pub fn ambient_settings(&self) -> &AmbientSettings {
        &self.ambient
    }
    /// Warnings from preparing the render (not the scene loader's).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The shading context (what [`shade`] reads).
    pub fn context(&self) -> ShadeContext<'_> {
        ShadeContext {
            scene: &self.scene,
            options: &self.options,
            lights: &self.lights,
            effects: &self.effects,
            media: &self.media,
        }
    }

    /// The hierarchy rays are traced through (see [`crate::accel::Bvh`]).
    pub fn bvh(&self) -> &Bvh {
        debug_assert!(
            self.scene.distributed.is_none(),
            "a hierarchy over a processor's part of a scene"
        );
        &self
            .bvh
            .get_or_init(|| timed_build(|| Bvh::build(&self.scene.objects)))
            .0
    }

    /// The ray caster over the whole scene (through the hierarchy; the
    /// same answers as [`Renderer::octree_caster`]).
    pub fn caster(&self) -> BvhCaster<'_> {
        BvhCaster {
            bvh: self.bvh(),
            objects: &self.scene.objects,
        }
    }

    /// The ray caster through the whole octree.
    pub fn octree_caster(&self) -> OctreeCaster<'_> {
        OctreeCaster {
            octree: self.octree(),
            objects: &self.scene.objects,
        }
    }

    fn timed<R>(st: &mut TraceState, bucket: Bucket, f: impl FnOnce(&mut TraceState) -> R) -> R {
        if !st.timing {
            return f(st);
        }
        let t0 = Instant::now();
        let outer = std::mem::take(&mut st.nested);
        let r = f(st);
        let total = t0.elapsed();
        let own = total.saturating_sub(st.nested);
        let slot = match bucket {
            Bucket::Primary => &mut st.times.primary,
            Bucket::Direct => &mut st.times.direct,
            Bucket::Reflection => &mut st.times.reflection,
            Bucket::Refraction => &mut st.times.refraction,
            Bucket::Ambient => &mut st.times.ambient,
        };
        *slot += own;
        st.nested = outer + total;
        r
    }

    /// Radiance arriving along `task.ray` (recursive; see the module docs).
    pub fn radiance(&self, task: &RayTask, st: &mut TraceState) -> Color {
        self.trace(task, st).0
    }

    /// Radiance along `task.ray` and the distance to the surface it hit
    /// (infinite if it left the scene; through surfaces that only pass the
    /// ray on, as Radiance's `raytrans()` counts it).
    pub fn trace(&self, task: &RayTask, st: &mut TraceState) -> (Color, f64) {
        self.trace_with(&self.caster(), task, st)
    }

    /// [`Renderer::trace`] through `caster`, which must answer as the
    /// renderer's own does (a hierarchy over every object of the scene,
    /// built from copies: the parallel renderer's processor that has come
    /// to hold the whole scene). The same value, bit for bit.
    pub fn trace_with<C: RayCaster>(
        &self,
        caster: &C,
        task: &RayTask,
        st: &mut TraceState,
    ) -> (Color, f64) {
        Self::timed(st, bucket_of(task.kind), |st| {
            count_ray(task.kind, st);
            let hit = caster.intersect(&task.ray, task.tmin, task.tmax);
            self.radiance_from(caster, task, hit, st)
        })
    }

    /// [`Renderer::trace_with`] where the nearest hit along `task`'s ray,
    /// `hit`, is already known (`caster`'s answer: traced in a packet with
    /// its neighbours, [`Renderer::trace_pixels`]). The same value, bit
    /// for bit.
    pub fn trace_from_hit<C: RayCaster>(
        &self,
        caster: &C,
        task: &RayTask,
        hit: Option<Hit>,
        st: &mut TraceState,
    ) -> (Color, f64) {
        Self::timed(st, bucket_of(task.kind), |st| {
            count_ray(task.kind, st);
            self.radiance_from(caster, task, hit, st)
        })
    }

    /// Radiance along `task`'s ray given its nearest hit (none: the sky).
    fn radiance_from<C: RayCaster>(
        &self,
        caster: &C,
        task: &RayTask,
        hit: Option<Hit>,
        st: &mut TraceState,
    ) -> (Color, f64) {
        let Some(hit) = hit else {
            return (self.sky_seen(task), f64::INFINITY);
        };
        let ctx = self.context();
        let start = st.requests.len();
        let shaded = shade(&ctx, task, &hit, &mut st.requests);
        let end = st.requests.len();
        let mut sum = shaded.base;
        if self.options.aw > 0
            && shaded.constant != Color::ZERO
            && ctx.effects.diffuse_interreflection.enabled
        {
            // -aw: the -av term in `base` moves to the cache's average.
            let av = st.ambient.ambient_value(self.options.av, self.options.aw);
            sum += shaded.constant * (av - self.options.av);
        }
        for req in shaded.ambient.iter().flatten() {
            sum += req.coef * self.ambient_value(caster, task, req, st);
        }
        // Radiance's `raytrans()`: a surface that only passes the ray on
        // (a mist's boundary, `void`, a clipped surface, a back face under
        // `-bv-`) is not where the ray ends; its distance is that of the
        // surface beyond (`r->rxt = r->rot + tr.rxt`), which is what a
        // hemisphere's sample measures its neighbourhood by.
        let passes_on = shaded.base == Color::ZERO
            && shaded.ambient.iter().all(Option::is_none)
            && matches!(
                st.requests[start..end],
                [Request::Trace { task: child, coef }, ..]
                    if child.kind == RayKind::PassThrough && coef == Color::ONE
            )
            && st.requests[start + 1..end]
                .iter()
                .all(|r| matches!(r, Request::Scatter(_)));
        let mut dist = hit.t;
        let mut i = start;
        while i < end {
            match st.requests[i] {
                Request::Trace { task: child, coef } => {
                    let (c, t) = self.trace_with(caster, &child, st);
                    if passes_on {
                        dist = hit.t + t;
                    }
                    sum += coef * c;
                    i += 1;
                }
                // In-scattering comes last and is added after attenuation.
                Request::Scatter(_) => break,
                Request::Shadow(_) => {
                    // A run of shadow bundles (one per source) is timed as
                    // one: reading the clock per bundle cost as much as a
                    // bundle in scenes with hundreds of sources.
                    // Run in place (a bundle is a few hundred bytes): the
                    // list is set aside meanwhile, bundles add no requests.
                    Self::timed(st, Bucket::Direct, |st| {
                        let requests = std::mem::take(&mut st.requests);
                        while let Some(Request::Shadow(bundle)) = requests[..end].get(i) {
                            sum += run_shadow_bundle(
                                &ctx,
                                caster,
                                bundle,
                                &mut st.patches,
                                &mut st.counts.shadow,
                            );
                            i += 1;
                        }
                        st.requests = requests;
                    });
                }
            }
        }
        if let Some((factor, add)) =
            medium::participate(&self.options, shaded.extinction, &shaded.medium, hit.t)
        {
            sum *= factor;
            sum += add;
        }
        if i < end {
            Self::timed(st, Bucket::Direct, |st| {
                let requests = std::mem::take(&mut st.requests);
                while let Some(Request::Scatter(bundle)) = requests[..end].get(i) {
                    sum += run_shadow_bundle(
                        &ctx,
                        caster,
                        bundle,
                        &mut st.patches,
                        &mut st.counts.shadow,
                    );
                    i += 1;
                }
                st.requests = requests;
            });
        }
        st.requests.truncate(start);
        (sum, dist)
    }

    /// The ambient radiance for `req` at the hit of `task`: interpolated
    /// from the irradiance cache, else a new hemisphere sampled now (and
    /// cached), else `-av` where the sample rays would be too deep or too
    /// light.
    fn ambient_value<C: RayCaster>(
        &self,
        caster: &C,
        task: &RayTask,
        req: &AmbientRequest,
        st: &mut TraceState,
    ) -> Color {
        let s = &self.ambient;
        st.counts.ambient_cache.lookups += 1;
        let mut occluded =
            |p: Vec3, dir: Vec3, len: f64| self.leak_occluded(caster, req, p, dir, len);
        if let Some(v) = st.ambient.lookup(
            s,
            req.point,
            req.normal,
            task.ambient,
            task.weight,
            &mut occluded,
        ) {
            st.counts.ambient_cache.hits += 1;
            return v;
        }
        let Some(mut h) = Hemisphere::new(s, &self.options, task, req) else {
            st.counts.ambient_cache.fallbacks += 1;
            return st.ambient.ambient_value(self.options.av, self.options.aw);
        };
        st.counts.ambient_cache.hemispheres += 1;
        for (div, t) in h.first_pass() {
            let (c, d) = self.trace_with(caster, &t, st);
            h.add(div, c, d);
        }
        for (div, t) in h.second_pass(s.super_samples) {
            let (c, d) = self.trace_with(caster, &t, st);
            h.add(div, c, d);
        }
        let (value, rec) = h.finish(s);
        if let Some(rec) = rec {
            st.ambient.insert(s, rec);
        }
        value
    }

    /// Radiance's leak test (`plugaleak`): whether an opaque surface
    /// crosses the segment of length `len` from the lookup point `p` along
    /// `dir`. Nominally transparent surfaces (Radiance's `T_TRANSP` types:
    /// glass, dielectrics, `trans` and the like, mist, antimatter) are
    /// passed whatever they transmit.
    pub(crate) fn leak_occluded<C: RayCaster + ?Sized>(
        &self,
        caster: &C,
        req: &AmbientRequest,
        p: Vec3,
        dir: Vec3,
        len: f64,
    ) -> bool {
        const MAX_SEGMENTS: usize = 64;
        let mut ray = Ray::new(
            offset_origin_scaled(p, req.normal, dir, req.offset_scale),
            dir,
        );
        let mut remaining = len;
        for _ in 0..MAX_SEGMENTS {
            let Some(hit) = caster.intersect(&ray, 0.0, remaining) else {
                return false;
            };
            if !nominally_transparent(self.scene.material(hit.material())) {
                return true;
            }
            remaining -= hit.t;
            if remaining.is_nan() || remaining <= 0.0 {
                return false;
            }
            ray.origin =
                offset_origin_scaled(hit.point, hit.normal, dir, req.offset_scale.max(hit.t));
        }
        false
    }

    /// What a ray that leaves the scene brings back: [`Self::sky`] through
    /// the medium the ray travels in (extinguished over its infinite
    /// length, plus the medium's ambient in-scattering).
    pub fn sky_seen(&self, task: &RayTask) -> Color {
        let sky = self.sky(task);
        match medium::participate(&self.options, task.extinction, &task.medium, f64::INFINITY) {
            Some((factor, add)) => sky * factor + add,
            None => sky,
        }
    }

    /// What a ray that leaves the scene sees (Radiance's `sourcehit()`
    /// then `m_light()`): the first distant source in scene order that
    /// contains its direction, else a glow that does; black for rays that
    /// direct lighting already accounts for.
    pub fn sky(&self, task: &RayTask) -> Color {
        let dir = task.ray.dir;
        let mut glow = None;
        let mut trans = false;
        let mut found = None;
        for s in &self.sky {
            if dir.dot(s.dir) < s.cos_half {
                continue;
            }
            match s.role {
                SkyRole::Source => {
                    found = Some(s);
                    break;
                }
                SkyRole::Glow => glow = Some(s),
                SkyRole::TransIllum => trans = true,
            }
        }
        let s = match found {
            Some(s) => s,
            // Avoid counting what an illum passes on twice.
            None if trans && task.sampled => return Color::ZERO,
            None => match glow {
                Some(s) => s,
                None => return Color::ZERO,
            },
        };
        let material = self.scene.material(s.material);
        // At infinity: a glow of any radius >= 0 is too far to be a
        // source, so sampled rays see it; other sources they must not.
        let radiance = match material {
            Material::Glow {
                radiance,
                max_radius,
            } if !task.sampled || *max_radius >= -FTINY => *radiance,
            Material::Light { radiance } if !task.sampled => *radiance,
            Material::Spotlight {
                radiance,
                angle_deg,
                direction,
            } if !task.sampled => {
                let aim = direction.normalize_or_zero();
                if aim == Vec3::ZERO || super::light::spot_admits(aim, *angle_deg, -dir) {
                    *radiance
                } else {
                    Color::ZERO
                }
            }
            _ => Color::ZERO,
        };
        let mods = self.scene.mods(s.material);
        if mods.is_empty() || radiance == Color::ZERO {
            return radiance;
        }
        // Radiance's rays that miss end at FHUGE, facing the source.
        const FHUGE: f64 = 1e10;
        let vars = crate::modifier::RayVars {
            dir,
            normal: -dir,
            point: task.ray.origin + dir * FHUGE,
            t: FHUGE,
            ts: FHUGE,
            uv: [0.0; 2],
        };
        let mut a = crate::modifier::Applied::NONE;
        self.scene.patterns.apply(mods, &vars, &mut a);
        radiance * a.color
    }

    /// Radiance of pixel (`x`, `y`) of a `width` x `height` image (row 0 at
    /// the top). Uses only the pixel's own random stream.
    pub fn pixel<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        x: usize,
        y: usize,
        st: &mut TraceState,
    ) -> Color {
        self.pixel_with(camera, (width, height), &self.caster(), (x, y), st)
    }

    /// The primary ray of sample `k` of pixel (`x`, `y`) when `-pn` > 1:
    /// its own random stream and jitter.
    pub fn sample_task<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        x: usize,
        y: usize,
        k: u32,
    ) -> Option<RayTask> {
        let seed = child_seed(
            pixel_seed(self.options.seed, x as u32, y as u32),
            0x706e_0000 + k,
        );
        self.primary_with_seed(camera, width, height, x, y, seed)
    }

    /// The primary ray of pixel (`x`, `y`) (jittered by `-pj` from the
    /// pixel's own random stream), or `None` where the view has no ray: the
    /// pixel is black.
    pub fn primary_task<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        x: usize,
        y: usize,
    ) -> Option<RayTask> {
        let seed = pixel_seed(self.options.seed, x as u32, y as u32);
        self.primary_with_seed(camera, width, height, x, y, seed)
    }

    fn primary_with_seed<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        x: usize,
        y: usize,
        seed: u64,
    ) -> Option<RayTask> {
        let (mut jx, mut jy) = (0.5, 0.5);
        if self.options.pj > 0.0 {
            let mut rng = Rng::new(seed ^ 0x7069_7865_6c6a_6974);
            jx = 0.5 + self.options.pj * (rng.next_f64() - 0.5);
            jy = 0.5 + self.options.pj * (rng.next_f64() - 0.5);
        }
        let fx = (x as f64 + jx) / width as f64;
        let fy = 1.0 - (y as f64 + jy) / height as f64;
        let (ray, tmin, tmax) = camera.ray(fx, fy)?;
        if !(ray.origin.is_finite() && ray.dir.is_finite()) {
            return None;
        }
        let task = RayTask::primary(ray, tmin, tmax, seed);
        Some(if self.media.active {
            medium::start_in_global(task, &self.options)
        } else {
            task
        })
    }

    /// Renders `region` of a `width` x `height` image into `film`: in
    /// tiles whose primary rays go as packets ([`Renderer::trace_pixels`]),
    /// or with `-ps` > 1 by the adaptive sampler.
    pub fn render_region<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        region: &Region,
        film: &mut Film,
        st: &mut TraceState,
    ) {
        if self.options.ps > 1 {
            self.grid(width, height).fill_region(
                region.xs(),
                region.ys(),
                &mut None,
                &mut |x, y| self.pixel(camera, width, height, x, y, st),
                &mut |x, y, c| film.set(x, y, c),
            );
            return;
        }
        let caster = self.caster();
        for tile in tiles(region.xs(), region.ys()) {
            self.trace_pixels(
                camera,
                (width, height),
                &caster,
                &tile,
                st,
                &mut |x, y, c| film.set(x, y, c),
            );
        }
    }

    /// The adaptive sampling grid (`-ps`, `-pt`) of a `width` x `height`
    /// picture.
    pub fn grid(&self, width: usize, height: usize) -> Grid {
        Grid::new(width, height, self.options.ps, self.options.pt)
    }

    /// Renders the whole image, calling `progress(rows_done)` after each
    /// band of rows (one row of tiles, [`TILE`] rows, whose
    /// primary rays go as packets; a row of the adaptive sampling grid
    /// with `-ps` > 1; a wave's worth with the irradiance cache).
    pub fn render_with_progress<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        progress: &mut dyn FnMut(usize),
    ) -> Result<(Film, RenderStats)> {
        let (film, stats, _) =
            self.render_with_cache(camera, width, height, progress, AmbientStore::default())?;
        Ok((film, stats))
    }

    /// An irradiance cache holding `records` (read from an ambient file),
    /// for [`Renderer::render_with_cache`]; records this render's settings
    /// reject (no cache at `-aa 0`) are left out.
    pub fn ambient_cache(&self, records: &[super::ambient::AmbientRecord]) -> AmbientStore {
        let mut store = AmbientStore::default();
        for r in records {
            store.insert(&self.ambient, *r);
        }
        store
    }

    /// [`Renderer::render_with_progress`] starting from the irradiance
    /// cache `cache` (records of an earlier render, Radiance's `-af`), and
    /// returning the cache as the render left it.
    pub fn render_with_cache<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        progress: &mut dyn FnMut(usize),
        cache: AmbientStore,
    ) -> Result<(Film, RenderStats, AmbientStore)> {
        check_resolution(width, height)?;
        if self.caches_ambient() {
            return self.render_in_waves(camera, width, height, progress, cache);
        }
        let mut film = Film::new(width, height);
        let mut st = TraceState::with_store(cache);
        st.timing = self.effect_times;
        let t0 = Instant::now();
        if self.options.ps > 1 {
            // Band by band, each grid row filled once.
            let grid = self.grid(width, height);
            let mut carry = None;
            for band in grid.bands() {
                let done = band.end;
                grid.fill_region(
                    0..width,
                    band,
                    &mut carry,
                    &mut |x, y| self.pixel(camera, width, height, x, y, &mut st),
                    &mut |x, y, c| film.set(x, y, c),
                );
                progress(done);
            }
            let render_s = t0.elapsed().as_secs_f64();
            let stats = self.stats(width, height, &st, render_s);
            return Ok((film, stats, st.ambient));
        }
        // A band of tiles at a time, their primary rays as packets.
        for y in (0..height).step_by(TILE) {
            let y1 = (y + TILE).min(height);
            let band = Region::new(0..width, y..y1);
            self.render_region(camera, width, height, &band, &mut film, &mut st);
            progress(y1);
        }
        let render_s = t0.elapsed().as_secs_f64();
        let stats = self.stats(width, height, &st, render_s);
        Ok((film, stats, st.ambient))
    }

    /// Whether renders keep an irradiance cache (`-ab` > 0 with `-aa` >
    /// 0): their pixels are shaded in the waves of [`super::waves`].
    pub fn caches_ambient(&self) -> bool {
        self.effects.diffuse_interreflection.enabled && self.ambient.accuracy > 0.0
    }

    /// A trace state reading `base` frozen, with no records of its own.
    pub fn frozen_state(base: &Arc<AmbientCache>) -> AmbientStore {
        AmbientStore::Frozen {
            base: base.clone(),
            own: AmbientCache::default(),
        }
    }

    /// [`Renderer::render_with_cache`] with a cache: pixels in the waves
    /// of [`super::waves`], one after the other.
    fn render_in_waves<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
        progress: &mut dyn FnMut(usize),
        cache: AmbientStore,
    ) -> Result<(Film, RenderStats, AmbientStore)> {
        let t0 = Instant::now();
        let s = &self.ambient;
        let mut st = TraceState {
            timing: self.effect_times,
            ..TraceState::default()
        };
        let total = width * height;
        let out = render_in_waves(
            width,
            height,
            (self.options.ps, self.options.pt),
            s,
            Arc::new(cache.into_cache(s)),
            &mut |wave, base| {
                Ok(wave
                    .iter()
                    .map(|&i| {
                        let i = i as usize;
                        st.ambient = Self::frozen_state(base);
                        let c = self.pixel(camera, width, height, i % width, i / width, &mut st);
                        (c, st.ambient.take_own())
                    })
                    .collect())
            },
            &mut |shaded| progress((height * shaded / total.max(1)).min(height)),
        )?;
        progress(height);
        st.ambient =
            AmbientStore::Local(Arc::try_unwrap(out.cache).unwrap_or_else(|b| (*b).clone()));
        let render_s = t0.elapsed().as_secs_f64();
        let stats = self.stats(width, height, &st, render_s);
        Ok((out.film, stats, st.ambient))
    }

    /// Renders the whole image.
    pub fn render<C: Camera + ?Sized>(
        &self,
        camera: &C,
        width: usize,
        height: usize,
    ) -> Result<(Film, RenderStats)> {
        self.render_with_progress(camera, width, height, &mut |_| {})
    }

    /// Statistics for work tallied in `st`.
    pub fn stats(
        &self,
        width: usize,
        height: usize,
        st: &TraceState,
        render_s: f64,
    ) -> RenderStats {
        let rays = st.counts;
        let per_s = (rays.primary + rays.shadow.tested) as f64 / render_s.max(1e-9) / 1e6;
        RenderStats {
            width,
            height,
            rays,
            mrays_per_s: per_s,
            effects: self.effects.clone(),
            time: Timings {
                octree_build_s: self.octree.get().map(|o| o.1),
                bvh_build_s: self.bvh.get().map_or(0.0, |b| b.1),
                render_s,
                primary_s: st.times.primary.as_secs_f64(),
                direct_s: st.times.direct.as_secs_f64(),
                reflection_s: st.times.reflection.as_secs_f64(),
                refraction_s: st.times.refraction.as_secs_f64(),
                ambient_s: st.times.ambient.as_secs_f64(),
            },
            octree: self.octree.get().map(|o| o.0.stats().clone()),
            scene: self.scene.stats.clone(),
            options: self.options.clone(),
            warnings: self.warnings.clone(),
            ambient_records: st.ambient.len(),
            pattern_errors: {
                let p = &self.scene.patterns;
                super::stats::PatternErrors {
                    math_errors: p.program.warnings(),
                    nans: p.failures.nans(),
                    failures: p.failures.errors(),
                    first: p.failures.first(),
                }
            },
        }
    }
}

/// Rejects impossible resolutions with a usage error.
pub fn check_resolution(width: usize, height: usize) -> Result<()> {
    if width == 0
        || height == 0
        || width > MAX_SIDE
        || height > MAX_SIDE
        || width * height > MAX_PIXELS
    {
        return Err(Error::Usage(format!(
            "resolution {width}x{height}: width and height must be between 1 and {MAX_SIDE} (at most {MAX_PIXELS} pixels)"
        )));
    }
    Ok(())
}

/// Radiance's `istransp`: the material types whose surfaces a leak test
/// looks through, whatever they transmit.
fn nominally_transparent(m: &Material) -> bool {
    use crate::scene::{AnisoKind, BrdfFamily};
    match m {
        Material::Trans { .. }
        | Material::Glass { .. }
        | Material::Dielectric { .. }
        | Material::Interface { .. }
        | Material::Prism { .. }
        | Material::Antimatter { .. }
        | Material::Illum { .. }
        | Material::Mist { .. }
        | Material::Brtd { .. }
        | Material::Bsdf { .. } => true,
        Material::Aniso { kind, .. } => *kind == AnisoKind::Trans2,
        Material::BrdfFunc { family, .. } => *family == BrdfFamily::Trans,
        _ => false,
    }
}

/// Which acceleration structures [`Renderer::build`] builds at once (the
/// other is built on first use).
enum Build {
    /// Both, side by side on two threads: a parallel render's renderer.
    Both,
    /// The hierarchy: the sequential renderer's.
    LazyOctree,
    /// The octree: rays go through its cells.
    LazyBvh,
    /// None: the octree is a distributed scene's skeleton.
    Skeleton(Box<Octree>),
}

// Primary rays traced as packets: the pixels of a tile (8 x 8) have their
// primary rays traced through the hierarchy together
// (`Bvh::intersect_packet`), then each pixel is shaded from its known
// nearest hit ([`Renderer::trace_from_hit`]). A packet's answers are the
// single rays' bit for bit, so no picture changes; the book's benchmarks
// chapter has what the packets save.

/// The side of a square tile whose primary rays make one packet.
pub const TILE: usize = 8;

impl Renderer<'_> {
    /// Radiance of pixel (`x`, `y`) traced through `caster` ([`Renderer::pixel`]
    /// through another caster that answers as the renderer's own).
    pub fn pixel_with<Cam: Camera + ?Sized, C: RayCaster>(
        &self,
        camera: &Cam,
        (width, height): (usize, usize),
        caster: &C,
        (x, y): (usize, usize),
        st: &mut TraceState,
    ) -> Color {
        let n = self.options().pn.max(1);
        if n == 1 {
            return match self.primary_task(camera, width, height, x, y) {
                Some(task) => self.trace_with(caster, &task, st).0,
                None => Color::ZERO,
            };
        }
        let mut sum = Color::ZERO;
        for k in 0..n {
            if let Some(task) = self.sample_task(camera, width, height, x, y, k) {
                sum += self.trace_with(caster, &task, st).0;
            }
        }
        sum / n as f64
    }

    /// Shades the pixels `pixels` ((x, y), in order; best a tile of them)
    /// of a `width` x `height` picture through `caster`, handing each value
    /// to `out`: their primary rays traced as packets of at most
    /// [`PACKET`] where `caster` traces packets and a pixel has one ray
    /// (`-pn 1`), one at a time otherwise. The values are
    /// [`Renderer::pixel_with`]'s, bit for bit.
    pub fn trace_pixels<Cam: Camera + ?Sized, C: RayCaster>(
        &self,
        camera: &Cam,
        (width, height): (usize, usize),
        caster: &C,
        pixels: &[(usize, usize)],
        st: &mut TraceState,
        out: &mut dyn FnMut(usize, usize, Color),
    ) {
        if self.options().pn > 1 || !caster.traces_packets() {
            for &(x, y) in pixels {
                out(
                    x,
                    y,
                    self.pixel_with(camera, (width, height), caster, (x, y), st),
                );
            }
            return;
        }
        let mut values = Vec::with_capacity(PACKET);
        for chunk in pixels.chunks(PACKET) {
            let tasks: Vec<Option<RayTask>> = chunk
                .iter()
                .map(|&(x, y)| self.primary_task(camera, width, height, x, y))
                .collect();
            let traced: Vec<RayTask> = tasks.iter().flatten().cloned().collect();
            values.clear();
            self.trace_tasks(caster, &traced, st, &mut |v| values.push(v));
            let mut values = values.drain(..);
            for (&(x, y), task) in chunk.iter().zip(&tasks) {
                let value = if task.is_some() { values.next() } else { None };
                out(x, y, value.unwrap_or(Color::ZERO));
            }
        }
    }

    /// Traces `tasks` (coherent rays, such as a tile's primary rays)
    /// through `caster`, their nearest hits found as packets of at most
    /// [`PACKET`] where `caster` traces packets; hands each ray's radiance
    /// to `out`, in order. The values are [`Renderer::trace_with`]'s, bit
    /// for bit.
    pub fn trace_tasks<C: RayCaster>(
        &self,
        caster: &C,
        tasks: &[RayTask],
        st: &mut TraceState,
        out: &mut dyn FnMut(Color),
    ) {
        if !caster.traces_packets() {
            for task in tasks {
                out(self.trace_with(caster, task, st).0);
            }
            return;
        }
        let mut segments: Vec<Segment> = Vec::with_capacity(PACKET);
        let mut hits: [Option<Hit>; PACKET] = [None; PACKET];
        for chunk in tasks.chunks(PACKET) {
            segments.clear();
            segments.extend(chunk.iter().map(|t| (t.ray, t.tmin, t.tmax)));
            Self::timed(st, Bucket::Primary, |_| {
                caster.intersect_packet(&segments, &mut hits[..chunk.len()])
            });
            for (task, hit) in chunk.iter().zip(hits) {
                out(self.trace_from_hit(caster, task, hit, st).0);
            }
        }
    }
}

/// The pixels of columns `xs` and rows `ys` in tiles of [`TILE`] x
/// [`TILE`], tile after tile along the rows of tiles, each tile's pixels
/// row by row: the order in which [`Renderer::trace_pixels`] traces them
/// as packets.
pub fn tiles(
    xs: std::ops::Range<usize>,
    ys: std::ops::Range<usize>,
) -> impl Iterator<Item = Vec<(usize, usize)>> {
    let (x0, x1) = (xs.start, xs.end);
    ys.clone().step_by(TILE).flat_map(move |ty| {
        let ty1 = (ty + TILE).min(ys.end);
        (x0..x1).step_by(TILE).map(move |tx| {
            let tx1 = (tx + TILE).min(x1);
            (ty..ty1)
                .flat_map(|y| (tx..tx1).map(move |x| (x, y)))
                .collect()
        })
    })
}
