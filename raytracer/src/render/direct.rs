//! Direct lighting: running a shadow bundle with adaptive shadow testing
//! (Ward 1994, "Adaptive Shadow Testing for Ray Tracing"; Radiance's
//! `direct()`).
//!
//! For each patch of the source the potential contribution (material
//! coefficient times source radiance, as if unoccluded) is computed
//! without tracing anything. The patches are sorted by potential, largest
//! first, and shadow rays are traced in that order until the potential of
//! the next `n^dc` untested patches falls below `-dt / weight` times the
//! brightness known so far (the reference the bundle was given plus what
//! the tested patches contributed). The untested rest is added scaled by
//! the fraction of tested patches that were visible (0.5 if none was
//! tested). `-dt 0` tests every patch.
//!
//! Difference from Radiance: Radiance sorts the patches of all sources
//! together and keeps per-source hit statistics across pixels. Here each
//! source is its own bundle (an independent task for the parallel
//! renderer) and its threshold reference includes the other sources'
//! rough potentials; the hit rate is the bundle's own, so the result
//! depends on nothing but the bundle.

use serde::{Deserialize, Serialize};

use super::caster::RayCaster;
use super::light::{LightExtent, PreparedLight};
use super::material::{
    hit_object, intens, shadow_filter, shadow_refraction, ShadeContext, ShadowBundle, FTINY,
};
use super::rng::Rng;
use super::virtual_source::Relay;
use crate::geometry::{offset_origin_scaled, Ray, Vec3};
use crate::image::brightness;
use crate::scene::{Color, ObjectId};

/// Most surfaces a shadow ray passes through (glass, void) before it is
/// considered blocked.
const MAX_SHADOW_SEGMENTS: u32 = 32;

/// Ray counts of direct lighting.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShadowCounts {
    /// Shadow bundles run (one per shaded point and source).
    pub bundles: u64,
    /// Patches with a non-zero potential contribution.
    pub patches: u64,
    /// Shadow rays traced.
    pub tested: u64,
    /// Patches whose shadow ray was skipped by adaptive testing (estimated).
    pub estimated: u64,
    /// Traced shadow rays that reached the source.
    pub unoccluded: u64,
    /// Extra ray segments traced through transparent occluders.
    pub transparent_segments: u64,
}

impl ShadowCounts {
    pub fn add(&mut self, o: &ShadowCounts) {
        self.bundles += o.bundles;
        self.patches += o.patches;
        self.tested += o.tested;
        self.estimated += o.estimated;
        self.unoccluded += o.unoccluded;
        self.transparent_segments += o.transparent_segments;
    }
}

/// One patch's potential contribution.
#[derive(Debug, Clone, Copy)]
pub struct Contribution {
    dir: Vec3,
    dist: f64,
    val: Color,
    brt: f64,
    /// Sum of `brt` over this and all later (smaller) contributions.
    tail: f64,
}

/// Runs one shadow bundle; `scratch` is reused between calls so the hot
/// path does not allocate.
pub fn run_shadow_bundle<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    b: &ShadowBundle,
    scratch: &mut Vec<Contribution>,
    counts: &mut ShadowCounts,
) -> Color {
    let Some(light) = ctx.lights.get(b.light as usize) else {
        return Color::ZERO;
    };
    counts.bundles += 1;
    scratch.clear();
    let mut rng = Rng::new(b.seed);
    let opts = ctx.options;
    let from = b.point;
    light.for_each_patch(ctx.scene, b.point, opts.ds, opts.dj, &mut rng, |s| {
        let coef = b.surface.coefficient(ctx.scene, s.dir, s.omega);
        let b = brightness(coef);
        if b.is_nan() || b <= 0.0 {
            return;
        }
        let val = coef * light.emission(from, &s);
        let brt = brightness(val);
        if brt > 0.0 && brt.is_finite() {
            scratch.push(Contribution {
                dir: s.dir,
                dist: s.dist,
                val,
                brt,
                tail: 0.0,
            });
        }
    });
    let n = scratch.len();
    counts.patches += n as u64;
    if n == 0 {
        return Color::ZERO;
    }
    // Largest potential first; the sort is stable, so ties keep patch order.
    scratch.sort_by(|a, b| b.brt.total_cmp(&a.brt));
    let mut tail = 0.0;
    for c in scratch.iter_mut().rev() {
        tail += c.brt;
        c.tail = tail;
    }
    let nshadcheck = (((n as f64).powf(opts.dc) + 0.5) as usize).max(1);
    let thresh = if b.weight > 0.0 {
        opts.dt / b.weight
    } else {
        opts.dt
    };
    let mut acc = Color::ZERO;
    let mut nhits = 0u64;
    let mut sn = 0;
    while sn < n {
        let pending = if sn + nshadcheck >= n {
            scratch[sn].tail
        } else {
            scratch[sn].tail - scratch[sn + nshadcheck].tail
        };
        if pending < thresh * (b.reference + brightness(acc)) {
            break;
        }
        let c = scratch[sn];
        let t = shadow_to_light(ctx, caster, b, light, c.dir, c.dist, counts);
        counts.tested += 1;
        if intens(t) > FTINY {
            acc += c.val * t;
            nhits += 1;
            counts.unoccluded += 1;
        }
        sn += 1;
    }
    let hit_rate = if sn > 0 {
        nhits as f64 / sn as f64
    } else {
        0.5
    };
    for c in &scratch[sn..] {
        acc += c.val * hit_rate;
    }
    counts.estimated += (n - sn) as u64;
    acc
}

/// What a shadow ray must reach: the source object (none for distant
/// sources), a distant source's cone (for a ray bent on the way), and the
/// mirrors relaying a virtual source, in order.
#[derive(Debug, Clone, Copy)]
pub struct ShadowAim<'a> {
    pub target: Option<ObjectId>,
    pub cone: Option<(Vec3, f64)>,
    pub relays: &'a [Relay],
}

/// Transmission of the shadow ray of bundle `b` towards a sample of
/// `light` in unit direction `dir` at distance `dist` (see
/// [`shadow_transmission`]; a virtual source's ray must be relayed by its
/// mirrors).
pub fn shadow_to_light<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    b: &ShadowBundle,
    light: &PreparedLight,
    dir: Vec3,
    dist: f64,
    counts: &mut ShadowCounts,
) -> Color {
    let (real, relays): (&PreparedLight, &[Relay]) = match &light.virt {
        Some(v) => (&v.real, &v.relays),
        None => (light, &[]),
    };
    let cone = match real.extent() {
        Some(LightExtent::Distant { dir, cos_half }) => Some((dir, cos_half)),
        _ => None,
    };
    let aim = ShadowAim {
        target: real.object,
        cone,
        relays,
    };
    shadow_transmission_aimed(
        ctx,
        caster,
        b.point,
        b.normal,
        b.offset_scale,
        dir,
        dist,
        &aim,
        b.clip,
        counts,
    )
}

/// Transmission along a shadow ray from the surface point `p` (normal `n`)
/// in unit direction `dir` over `dist` (infinite for distant sources), with
/// the source object `target` itself not counting as an occluder. 1 if
/// unoccluded, 0 if blocked, between for glass on the way.
#[allow(clippy::too_many_arguments)]
pub fn shadow_transmission<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    p: Vec3,
    n: Vec3,
    offset_scale: f64,
    dir: Vec3,
    dist: f64,
    target: Option<ObjectId>,
    counts: &mut ShadowCounts,
) -> Color {
    let aim = ShadowAim {
        target,
        cone: None,
        relays: &[],
    };
    shadow_transmission_aimed(ctx, caster, p, n, offset_scale, dir, dist, &aim, 0, counts)
}

/// [`shadow_transmission`] towards `aim`, for a ray with antimatter clip
/// set `clip`. As Radiance's shadow rays: glass and clear trans filter the
/// ray, a dielectric or interface refracts it (with its Fresnel
/// transmission and absorption; a refracted ray counts only if it still
/// reaches the source), antimatter and clipped surfaces let it pass, and a
/// virtual source's mirrors reflect it in turn.
#[allow(clippy::too_many_arguments)]
pub fn shadow_transmission_aimed<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    p: Vec3,
    n: Vec3,
    offset_scale: f64,
    dir: Vec3,
    dist: f64,
    aim: &ShadowAim,
    clip: u64,
    counts: &mut ShadowCounts,
) -> Color {
    let origin = offset_origin_scaled(p, n, dir, offset_scale);
    // Stop just short of the sample point so a surface coplanar with the
    // source (a ceiling around a luminaire) does not shadow it.
    let tmax = if dist.is_finite() {
        dist * (1.0 - 1e-9)
    } else {
        f64::INFINITY
    };
    let mut ray = Ray { origin, dir };
    if aim.relays.is_empty() {
        // Nothing but the source on the way: what the segment loop below
        // would also find (its first nearest hit is none or the source),
        // for one any-hit query.
        let blocked = caster.occluded(&ray, 0.0, tmax, aim.target);
        if !blocked {
            return Color::ONE;
        }
        if !ctx.effects.transparent_shadows.enabled {
            return Color::ZERO;
        }
    }
    let mut clip = clip;
    let mut trans = Color::ONE;
    let mut remaining = tmax;
    // Mirrors passed so far.
    let mut relayed = 0;
    // Extinction of the medium the ray travels in (after a dielectric).
    let mut ext = Color::ZERO;
    let mut bent = false;
    let absorb = |ext: Color, t: f64| {
        if ext == Color::ZERO {
            Color::ONE
        } else {
            (-ext * t.min(1e30)).exp()
        }
    };
    for _ in 0..MAX_SHADOW_SEGMENTS {
        let Some(hit) = caster.intersect(&ray, 0.0, remaining) else {
            if relayed < aim.relays.len() {
                return Color::ZERO; // missed the mirror
            }
            if bent {
                // A refracted ray must still find the source.
                match (aim.target, aim.cone) {
                    (Some(_), _) => return Color::ZERO,
                    (None, Some((d, cos_half))) if ray.dir.dot(d) < cos_half => return Color::ZERO,
                    _ => {}
                }
            }
            return trans * absorb(ext, remaining);
        };
        trans *= absorb(ext, hit.t);
        if let Some(r) = aim.relays.get(relayed) {
            if hit.object == r.object && hit.inner.is_none() {
                if ray.dir.dot(r.normal) >= 0.0 {
                    return Color::ZERO; // back is black
                }
                if let Some(rd) = &r.redirect {
                    // A prism: its projection's functions bend the ray.
                    let vars = crate::modifier::RayVars {
                        dir: ray.dir,
                        normal: hit.normal,
                        point: hit.point,
                        t: hit.t,
                        ts: hit.t,
                        uv: [0.0; 2],
                    };
                    let Some((coef, d)) =
                        ctx.scene
                            .patterns
                            .redirect(rd.modifier, rd.projection as usize, &vars)
                    else {
                        return Color::ZERO;
                    };
                    if coef <= FTINY {
                        return Color::ZERO;
                    }
                    trans *= coef;
                    ray.dir = d;
                    bent = true;
                } else {
                    // Patterns on the mirror colour the relayed light
                    // (m_mirror.c multiplies by the ray's pattern colour).
                    let mods = ctx.scene.mods(hit_object(ctx.scene, &hit).material);
                    if !mods.is_empty() {
                        let vars = crate::modifier::RayVars {
                            dir: ray.dir,
                            normal: hit.normal,
                            point: hit.point,
                            t: hit.t,
                            ts: hit.t,
                            uv: [0.0; 2],
                        };
                        let mut ap = crate::modifier::Applied::NONE;
                        ctx.scene.patterns.apply(mods, &vars, &mut ap);
                        trans *= ap.color;
                    }
                    ray.dir = r.dir(ray.dir);
                }
                trans *= r.color;
                relayed += 1;
                ray.origin =
                    offset_origin_scaled(hit.point, hit.normal, ray.dir, offset_scale.max(hit.t));
                remaining -= hit.t;
                if intens(trans) <= FTINY || remaining.is_nan() || remaining <= 0.0 {
                    return Color::ZERO;
                }
                continue;
            }
        }
        if Some(hit.object) == aim.target {
            return if relayed == aim.relays.len() {
                trans
            } else {
                Color::ZERO
            };
        }
        let obj = hit_object(ctx.scene, &hit);
        let material = ctx.scene.material(obj.material);
        let mut next_dir = ray.dir;
        if let Some(c) = super::clip::pass_through(ctx.scene, clip, ray.dir, &hit, obj.material) {
            clip = c;
        } else if let Some(r) = shadow_refraction(material, ray.dir, hit.normal) {
            trans *= r.coef;
            ext = r.enters;
            next_dir = r.dir;
            bent = true;
        } else {
            let Some(filter) = shadow_filter(ctx.scene, material, -ray.dir.dot(hit.normal)) else {
                return Color::ZERO;
            };
            trans *= filter;
        }
        if intens(trans) <= FTINY {
            return Color::ZERO;
        }
        counts.transparent_segments += 1;
        ray.origin = offset_origin_scaled(hit.point, hit.normal, next_dir, offset_scale.max(hit.t));
        ray.dir = next_dir;
        remaining = if bent {
            f64::INFINITY
        } else {
            remaining - hit.t
        };
        if remaining.is_nan() || remaining <= 0.0 {
            return if relayed == aim.relays.len() {
                trans
            } else {
                Color::ZERO
            };
        }
    }
    Color::ZERO
}
