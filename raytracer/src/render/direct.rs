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
use super::material::{
    hit_object, intens, shadow_filter, ShadeContext, ShadowBundle, Surface, FTINY,
};
use super::medium::{self, Medium};
use super::rng::Rng;
use crate::geometry::{offset_origin_scaled, Ray, Vec3};
use crate::image::brightness;
use crate::scene::Material;
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
    // In-scattering samples the whole source at once (srcscatter's nopart).
    let ds = match b.surface {
        Surface::Scatter(_) => 0.0,
        _ => opts.ds,
    };
    let medium =
        (ctx.media.active || b.extinction != Color::ZERO).then_some((b.extinction, b.medium));
    light.for_each_patch(ctx.scene, b.point, ds, opts.dj, &mut rng, |s| {
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
        let t = shadow_transmission(
            ctx,
            caster,
            b.point,
            b.normal,
            b.offset_scale,
            c.dir,
            c.dist,
            light.object,
            medium,
            counts,
        );
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

/// Transmission along a shadow ray from the surface point `p` (normal `n`)
/// in unit direction `dir` over `dist` (infinite for distant sources), with
/// the source object `target` itself not counting as an occluder. 1 if
/// unoccluded, 0 if blocked, between for glass on the way. `medium` is the
/// extinction and medium the ray starts in (`None` outside media): the ray
/// loses the absorbed part over every segment, and mists it crosses change
/// the medium.
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
    medium: Option<(Color, Medium)>,
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
    // Nothing but the source on the way: what the segment loop below would
    // also find (its first nearest hit is none or the source), for one
    // any-hit query.
    let blocked = caster.occluded(&ray, 0.0, tmax, target);
    if !blocked {
        return match medium {
            None => Color::ONE,
            Some((ext, m)) => medium::shadow_attenuation(ext, m.albedo, tmax),
        };
    }
    if !ctx.effects.transparent_shadows.enabled {
        return Color::ZERO;
    }
    let mut trans = Color::ONE;
    let mut remaining = tmax;
    let mut medium = medium;
    for _ in 0..MAX_SHADOW_SEGMENTS {
        let Some(hit) = caster.intersect(&ray, 0.0, remaining) else {
            if let Some((ext, m)) = medium {
                trans *= medium::shadow_attenuation(ext, m.albedo, remaining);
            }
            return trans;
        };
        let material = ctx.scene.material(hit_object(ctx.scene, &hit).material);
        if let Material::Mist {
            extinction,
            albedo,
            gecc,
            ..
        } = material
        {
            let (ext, m) = medium.unwrap_or((ctx.options.me, Medium::default()));
            let mist = medium::Mist {
                extinction: *extinction,
                albedo: *albedo,
                gecc: *gecc,
                slot: ctx.media.slot(hit_object(ctx.scene, &hit).material),
            };
            let c = medium::cross_mist(ctx.options, &mist, -dir.dot(hit.normal) > 0.0, ext, m);
            let (ext, m) = c.before.unwrap_or((ext, m));
            trans *= medium::shadow_attenuation(ext, m.albedo, hit.t);
            medium = Some((c.extinction, c.medium));
        } else if let Some((ext, m)) = medium {
            trans *= medium::shadow_attenuation(ext, m.albedo, hit.t);
        }
        if Some(hit.object) == target {
            return trans;
        }
        let Some(filter) = shadow_filter(ctx.scene, material, -dir.dot(hit.normal)) else {
            return Color::ZERO;
        };
        trans *= filter;
        if intens(trans) <= FTINY {
            return Color::ZERO;
        }
        counts.transparent_segments += 1;
        ray.origin = offset_origin_scaled(hit.point, hit.normal, dir, offset_scale.max(hit.t));
        remaining -= hit.t;
        if remaining.is_nan() || remaining <= 0.0 {
            return trans;
        }
    }
    Color::ZERO
}
