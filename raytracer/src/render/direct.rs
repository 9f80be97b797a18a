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
//! the fraction of tested patches that were visible; if none was tested,
//! by half the source's hit ratio (Radiance's `0.5 * nhits / ntests`).
//! `-dt 0` tests every patch.
//!
//! Differences from Radiance: Radiance sorts the patches of all sources
//! together, compares the next ones' potential with the light the
//! visible ones gave so far, and keeps per-source hit statistics as it
//! renders (a figure that depends on the order pixels are done in). Here
//! each source is its own bundle (an independent task for the parallel
//! renderer), so what brighter sources gave is not known: its threshold
//! reference holds what they are expected to give, their rough
//! potentials times their hit ratios. The ratios are measured once before
//! rendering ([`estimate_hit_ratios`]), so the result depends on nothing
//! but the bundle. A source left wholly untested where a brighter one
//! exists counts with its hit ratio (Radiance's conditional rate, on
//! average); where it is the brightest, with half of it. With every other
//! source's full potential in the reference instead, a window beside a
//! sun that the point cannot see went untested at most points that ambient
//! rays reach and counted as half its ratio: Radiance's glass scene came
//! out 7% (fish view) and 3% (up view) darker than with `-dt 0`. Without
//! any ratio, a sun through a window lit the irradiance cache's records as
//! if half the room were sunlit.

use serde::{Deserialize, Serialize};

use super::caster::RayCaster;
use super::light::Relay;
use super::light::{LightExtent, PatchSample, PreparedLight};
use super::material::{
    intens, shadow_filter, shadow_refraction, ShadeContext, ShadowBundle, Surface,
};
use super::medium::{self, Medium};
use super::rng::Rng;
use crate::geometry::FTINY;
use crate::geometry::{offset_origin_scaled, PerRay, Ray, Segment, Vec3, PACKET};
use crate::image::brightness;
use crate::scene::{Color, Material, ObjectId};

/// Most surfaces a shadow ray passes through (glass, void) before it is
/// considered blocked.
const MAX_SHADOW_SEGMENTS: u32 = 32;

/// Fewest rays of a bundle traced together as a packet.
const MIN_PACKET: usize = 8;

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

/// Patches a bundle sorts in place: the standard library's stable sort
/// sorts up to 20 elements by insertion, which for so few costs less than
/// making and sorting keys (the Cornell box at rpict's ambient settings,
/// `-ds 0.2`: 150 million instructions of 8.9 billion in the keys' sort).
const FEW_PATCHES: usize = 20;

/// A shadow bundle's patches, reused between bundles so that the hot
/// path does not allocate: as made, their sort keys, and sorted.
#[derive(Debug, Default)]
pub struct Patches {
    made: Vec<Contribution>,
    keys: Vec<u128>,
    sorted: Vec<Contribution>,
}

impl Patches {
    /// Sorts the patches made by potential, largest first, ties in the
    /// order they were made (a stable sort's order), into `sorted`.
    ///
    /// Every potential is positive and finite, where the bits of an
    /// `f64` order as its values: the keys (the complemented bits above
    /// the index, in a `u128`) sort as integers, and each patch is then
    /// copied once. A stable sort of the patches themselves (72 bytes
    /// each) took 9.3% of the sequential renderer's instructions with
    /// soft shadows (`-ds 0.05`, the studio), the keys' sort 6.6% (the
    /// book's benchmarks chapter).
    fn sort(&mut self) -> &mut [Contribution] {
        debug_assert!(self.made.iter().all(|c| c.brt > 0.0 && c.brt.is_finite()));
        if self.made.len() <= FEW_PATCHES {
            // A few: sorted in place (by insertion), the same order.
            self.made.sort_by(|a, b| b.brt.total_cmp(&a.brt));
            return &mut self.made;
        }
        self.keys.clear();
        self.keys.extend(
            self.made
                .iter()
                .enumerate()
                .map(|(i, c)| u128::from(!c.brt.to_bits()) << 64 | i as u128),
        );
        self.keys.sort_unstable();
        self.sorted.clear();
        let made = &self.made;
        self.sorted
            .extend(self.keys.iter().map(|&k| made[k as u64 as usize]));
        &mut self.sorted
    }
}

/// Runs one shadow bundle; `patches` is reused between calls so the hot
/// path does not allocate.
pub fn run_shadow_bundle<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    b: &ShadowBundle,
    patches: &mut Patches,
    counts: &mut ShadowCounts,
) -> Color {
    let Some(light) = ctx.lights.get(b.light as usize) else {
        return Color::ZERO;
    };
    counts.bundles += 1;
    let made = &mut patches.made;
    made.clear();
    let mut rng = Rng::new(b.seed);
    let opts = ctx.options;
    let from = b.point;
    // In-scattering samples the whole source at once (srcscatter's nopart).
    let ds = match b.surface {
        Surface::Scatter(_) => 0.0,
        _ => opts.ds,
    };
    let mut add = |coef: Color, s: &PatchSample| {
        let b = brightness(coef);
        if b.is_nan() || b <= 0.0 {
            return;
        }
        let val = coef * light.emission(from, s);
        let brt = brightness(val);
        if brt > 0.0 && brt.is_finite() {
            made.push(Contribution {
                dir: s.dir,
                dist: s.dist,
                val,
                brt,
                tail: 0.0,
            });
        }
    };
    // The common surface gets a loop of its own: no dispatch per sample.
    match &b.surface {
        Surface::Normal(nb) => {
            light.for_each_patch(ctx.scene, b.point, ds, opts.dj, &mut rng, |s| {
                add(nb.coefficient(s.dir, s.omega), &s)
            })
        }
        surface => light.for_each_patch(ctx.scene, b.point, ds, opts.dj, &mut rng, |s| {
            add(surface.coefficient(ctx.scene, s.dir, s.omega), &s)
        }),
    }
    let n = made.len();
    counts.patches += n as u64;
    if n == 0 {
        return Color::ZERO;
    }
    // Largest potential first; ties keep patch order.
    let scratch = patches.sort();
    let mut tail = 0.0;
    for c in scratch.iter_mut().rev() {
        tail += c.brt;
        c.tail = tail;
    }
    caster.begin_bundle(light.shadow_bounds(from, b.offset_scale).as_ref());
    let nshadcheck = (((n as f64).powf(opts.dc) + 0.5) as usize).max(1);
    let thresh = if b.weight > 0.0 {
        opts.dt / b.weight
    } else {
        opts.dt
    };
    // What every shadow ray of the bundle aims at and starts in.
    let aim = ShadowAim::of(light);
    let medium = bundle_medium(ctx, b);
    // The patches tested whatever their rays meet, where the caster traces
    // packets and the rays take the any-hit query alone: traced together
    // ahead of the loop, [`PACKET`] at a time, their answers used in order.
    let sure = if caster.traces_packets() && one_query(ctx, &aim, medium) {
        match surely_tested(scratch, nshadcheck, thresh, b.reference) {
            k if k >= MIN_PACKET => k,
            _ => 0,
        }
    } else {
        0
    };
    let mut packet = PacketAnswers::default();
    let mut acc = Color::ZERO;
    let mut nhits = 0u64;
    let mut sn = 0;
    while sn < n {
        if pending(scratch, sn, nshadcheck) < thresh * (b.reference + brightness(acc)) {
            break;
        }
        let c = scratch[sn];
        let known = (sn < sure).then(|| {
            if sn >= packet.start + packet.len {
                packet.trace(caster, b, &aim, &scratch[sn..sure]);
                packet.start = sn;
            }
            packet.blocked[sn - packet.start]
        });
        let t = shadow_transmission_aimed(
            ctx,
            caster,
            b.point,
            b.normal,
            b.offset_scale,
            c.dir,
            c.dist,
            &aim,
            b.clip,
            medium,
            counts,
            known,
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
    } else if b.brighter {
        // Radiance's conditional rate (hits at this point over the hits
        // the tested sources' ratios predict) times this source's ratio:
        // the source's ratio, on average.
        light.hit_ratio
    } else {
        // Nothing tested at the point: Radiance's half.
        0.5 * light.hit_ratio
    };
    for c in &scratch[sn..] {
        acc += c.val * hit_rate;
    }
    counts.estimated += (n - sn) as u64;
    acc
}

/// What a shadow ray must reach: the source object (none for distant
/// sources), a distant source's cone (for a ray bent on the way), and the
/// mirrors and prisms relaying a virtual source, in order.
#[derive(Debug, Clone, Copy)]
pub struct ShadowAim<'a> {
    pub target: Option<ObjectId>,
    pub cone: Option<(Vec3, f64)>,
    pub relays: &'a [Relay],
    /// A real `illum` or `glow` source: an illum met from the front
    /// blocks the ray (Radiance's `illumblock`, see [`shadow_filter`]).
    pub weak: bool,
    /// The source's samples lie inside it (a sphere's): the ray ends where
    /// it meets the surface, short of the sample's distance.
    pub solid: bool,
}

impl<'a> ShadowAim<'a> {
    /// Where a shadow ray to `light` must go.
    pub fn of(light: &'a PreparedLight) -> Self {
        let (real, relays): (&PreparedLight, &[Relay]) = match &light.virt {
            Some(v) => (&v.real, &v.relays),
            None => (light, &[]),
        };
        let cone = match real.extent() {
            Some(LightExtent::Distant { dir, cos_half }) => Some((dir, cos_half)),
            _ => None,
        };
        ShadowAim {
            target: real.object,
            cone,
            relays,
            weak: light.virt.is_none()
                && matches!(
                    real.material,
                    Material::Illum { .. } | Material::Glow { .. }
                ),
            solid: real.samples_inside(),
        }
    }
}

/// The medium bundle `b`'s shadow rays start in (`None` outside media).
#[inline]
fn bundle_medium(ctx: &ShadeContext, b: &ShadowBundle) -> Option<(Color, Medium)> {
    (ctx.media.active || b.extinction != Color::ZERO).then_some((b.extinction, b.medium))
}

/// The shadow ray [`shadow_transmission_aimed`] traces first: from `p`
/// (offset along `n`) in `dir`, ending just short of the sample point at
/// `dist` so a surface coplanar with the source (a ceiling around a
/// luminaire) does not shadow it.
#[inline]
fn shadow_segment(p: Vec3, n: Vec3, offset_scale: f64, dir: Vec3, dist: f64) -> (Ray, f64) {
    let origin = offset_origin_scaled(p, n, dir, offset_scale);
    let tmax = if dist.is_finite() {
        dist * (1.0 - 1e-9)
    } else {
        f64::INFINITY
    };
    (Ray { origin, dir }, tmax)
}

/// Whether a shadow ray towards `aim` starting in `medium` takes the
/// any-hit query alone (and the segment loop only where that query finds
/// it blocked and shadows are transparent): nothing but the source on
/// the way.
#[inline]
fn one_query(ctx: &ShadeContext, aim: &ShadowAim, medium: Option<(Color, Medium)>) -> bool {
    // A ray inside a mist that names sources (scattering towards them, or
    // lighting a surface in it) nearly always leaves it on the way: the
    // any-hit query would stop at its boundary, so the loop starts at once.
    let in_named_mist =
        ctx.effects.transparent_shadows.enabled && medium.is_some_and(|(_, m)| m.scatter != 0);
    // In a medium the light is attenuated up to where the ray meets the
    // source: for a source sampled inside (a sphere), the loop finds that.
    aim.relays.is_empty() && !(aim.solid && medium.is_some()) && !in_named_mist
}

/// How many of a bundle's patches (sorted, with their tails) the loop of
/// [`run_shadow_bundle`] tests whatever their rays meet: it stops soonest
/// where every tested ray reaches the source (the brightness known is then
/// largest). Only which rays are traced ahead depends on it: a ray traced
/// ahead whose answer the loop does not reach is not used.
fn surely_tested(
    patches: &[Contribution],
    nshadcheck: usize,
    thresh: f64,
    reference: f64,
) -> usize {
    let mut most = Color::ZERO;
    for (sn, c) in patches.iter().enumerate() {
        if pending(patches, sn, nshadcheck) < thresh * (reference + brightness(most)) {
            return sn;
        }
        most += c.val;
    }
    patches.len()
}

/// The potential of the next `nshadcheck` untested patches from `sn` on
/// (sorted, with their tails), which adaptive testing weighs against the
/// brightness known.
#[inline]
fn pending(patches: &[Contribution], sn: usize, nshadcheck: usize) -> f64 {
    match patches.get(sn + nshadcheck) {
        Some(next) => patches[sn].tail - next.tail,
        None => patches[sn].tail,
    }
}

/// The any-hit answers of up to [`PACKET`] of a bundle's rays, traced
/// together: `blocked[i]` for the patch `start + i`.
struct PacketAnswers {
    start: usize,
    len: usize,
    blocked: [bool; PACKET],
}

impl Default for PacketAnswers {
    fn default() -> Self {
        PacketAnswers {
            start: 0,
            len: 0,
            blocked: [false; PACKET],
        }
    }
}

impl PacketAnswers {
    /// Traces the rays of the first [`PACKET`] of `patches` as one packet.
    fn trace<C: RayCaster + ?Sized>(
        &mut self,
        caster: &C,
        b: &ShadowBundle,
        aim: &ShadowAim,
        patches: &[Contribution],
    ) {
        let k = patches.len().min(PACKET);
        // Only the rays written: an array of 64 zeroed first for every
        // packet was 1.7% of the studio's instructions at `-ds 0.05`.
        let mut rays = PerRay::<Segment>::new();
        for c in &patches[..k] {
            let (ray, tmax) = shadow_segment(b.point, b.normal, b.offset_scale, c.dir, c.dist);
            rays.push((ray, 0.0, tmax));
        }
        caster.occluded_packet(&rays, aim.target, &mut self.blocked[..k]);
        self.len = k;
    }
}

/// Transmission along a shadow ray from the surface point `p` (normal `n`)
/// in unit direction `dir` over `dist` (infinite for distant sources)
/// towards `aim` (its source object does not count as an occluder), for a
/// ray with antimatter clip set `clip`: 1 if unoccluded, 0 if blocked,
/// between for glass on the way. `medium` is the extinction and medium the
/// ray starts in (`None` outside media): the ray loses the absorbed part
/// over every segment, and mists it crosses change the medium. As
/// Radiance's shadow rays: glass and clear trans filter the ray, a
/// dielectric or interface refracts it (with its Fresnel transmission and
/// absorption; a refracted ray counts only if it still reaches the
/// source), antimatter and clipped surfaces let it pass, and a virtual
/// source's mirrors reflect it and its prisms redirect it in turn.
/// `known` may hold the answer of its first any-hit query, traced ahead
/// (the same query: the same answer).
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
    medium: Option<(Color, Medium)>,
    counts: &mut ShadowCounts,
    known: Option<bool>,
) -> Color {
    let (mut ray, tmax) = shadow_segment(p, n, offset_scale, dir, dist);
    if one_query(ctx, aim, medium) {
        // Nothing but the source on the way: what the segment loop below
        // would also find (its first nearest hit is none or the source),
        // for one any-hit query.
        let blocked = known.unwrap_or_else(|| caster.occluded(&ray, 0.0, tmax, aim.target));
        if !blocked {
            return match medium {
                None => Color::ONE,
                Some((ext, m)) => medium::shadow_attenuation(ext, m.albedo, tmax),
            };
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
    // The medium the ray travels in: where it starts, then what mists
    // and dielectric boundaries on the way make it.
    let mut medium = medium;
    let attenuation = |medium: Option<(Color, Medium)>, t: f64| match medium {
        Some((ext, m)) => medium::shadow_attenuation(ext, m.albedo, t),
        None => Color::ONE,
    };
    let mut bent = false;
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
            return trans * attenuation(medium, remaining);
        };
        let material_id = hit.material();
        if let Material::Mist {
            extinction,
            albedo,
            gecc,
            ..
        } = ctx.scene.material(material_id)
        {
            let (ext, m) = medium.unwrap_or((ctx.options.me, Medium::default()));
            let mist = medium::Mist {
                extinction: *extinction,
                albedo: *albedo,
                gecc: *gecc,
                slot: ctx.media.slot(material_id),
            };
            let c = medium::cross_mist(ctx.options, &mist, -ray.dir.dot(hit.normal) > 0.0, ext, m);
            let (ext, m) = c.before.unwrap_or((ext, m));
            trans *= medium::shadow_attenuation(ext, m.albedo, hit.t);
            medium = Some((c.extinction, c.medium));
        } else {
            trans *= attenuation(medium, hit.t);
        }
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
                    let mods = ctx.scene.mods(hit.material());
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
                // A mirror keeps the distance to the source; a prism does
                // not, and its ray must meet the source itself.
                remaining = if r.redirect.is_some() {
                    f64::INFINITY
                } else {
                    remaining - hit.t
                };
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
        let material = ctx.scene.material(hit.material());
        let mut next_dir = ray.dir;
        if let Some(c) = super::clip::pass_through(ctx.scene, clip, ray.dir, &hit, hit.material()) {
            clip = c;
        } else if let Some(r) = shadow_refraction(material, ray.dir, hit.normal) {
            trans *= r.coef;
            medium = Some((r.enters, medium.map_or(Medium::default(), |(_, m)| m)));
            next_dir = r.dir;
            bent = true;
        } else {
            let rod = -ray.dir.dot(hit.normal);
            let filter = if let Material::Brtd { .. } = material {
                super::brdf::shadow_filter(ctx.scene, hit.material(), &hit, ray.dir)
            } else {
                shadow_filter(ctx.scene, material, rod, aim.weak)
            };
            let Some(filter) = filter else {
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

/// Shadow rays per light at most in [`estimate_hit_ratios`], and in all.
const RATIO_RAYS: (usize, usize) = (1024, 1 << 16);

/// Each light's hit ratio (Radiance's `nhits / ntests`): the fraction of
/// shadow rays that reach it from surface points that face it. Radiance
/// counts them while it renders; here a fixed set of points stands in:
/// where rays from a grid of points inside the scene's bounds, in fixed
/// directions, first meet a surface. The same for every renderer and every run.
pub fn estimate_hit_ratios<C: RayCaster + ?Sized>(
    ctx: &ShadeContext,
    caster: &C,
    bounds: crate::geometry::Aabb,
) -> Vec<f64> {
    let n = ctx.lights.len();
    if n == 0
        || bounds.min.cmpgt(bounds.max).any()
        || !bounds.min.is_finite()
        || !bounds.max.is_finite()
    {
        return vec![1.0; n];
    }
    let rays = (RATIO_RAYS.1 / n).clamp(64, RATIO_RAYS.0);
    let size = bounds.max - bounds.min;
    // A 4 x 4 x 4 grid of origins: enough that no one object near an
    // origin (a torus around the centre) dominates the points.
    let origins: Vec<Vec3> = (0..64)
        .map(|k| {
            let f = |i: usize| (i as f64 + 0.5) / 4.0;
            bounds.min + size * Vec3::new(f(k % 4), f(k / 4 % 4), f(k / 16))
        })
        .collect();
    let mut rng = Rng::new(0x6869_745f_7261_7469);
    let mut points = Vec::with_capacity(rays);
    for i in 0..rays {
        let origin = origins[i % origins.len()];
        let z = 1.0 - 2.0 * rng.next_f64();
        let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        if let Some(hit) = caster.intersect(&Ray { origin, dir }, 0.0, f64::INFINITY) {
            let normal = if hit.normal.dot(dir) > 0.0 {
                -hit.normal
            } else {
                hit.normal
            };
            let scale = hit.point.abs().max_element().max(hit.t);
            points.push((hit.point, normal, scale));
        }
    }
    let mut counts = ShadowCounts::default();
    ctx.lights
        .iter()
        .map(|light| {
            let aim = ShadowAim::of(light);
            // Radiance starts every source at one hit in one test.
            let (mut tests, mut hits) = (1u64, 1u64);
            for &(p, normal, scale) in &points {
                if !light.may_reach(p) {
                    continue;
                }
                let Some(s) = light.rough_sample(ctx.scene, p) else {
                    continue;
                };
                if s.dir.dot(normal) <= 0.0 {
                    continue;
                }
                tests += 1;
                let t = shadow_transmission_aimed(
                    ctx,
                    caster,
                    p,
                    normal,
                    scale,
                    s.dir,
                    s.dist,
                    &aim,
                    0,
                    None,
                    &mut counts,
                    None,
                );
                if intens(t) > FTINY {
                    hits += 1;
                }
            }
            hits as f64 / tests as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn patch(brt: f64) -> Contribution {
        Contribution {
            dir: Vec3::Z,
            dist: brt,
            val: Color::ONE,
            brt,
            tail: 0.0,
        }
    }

    proptest! {
        /// The keys' sort is the stable sort by potential, largest first:
        /// ties (drawn often here) keep the order the patches were made in,
        /// tiny and huge potentials included.
        #[test]
        fn patches_sort_as_a_stable_sort_by_potential(
            levels in prop::collection::vec(0usize..6, 0..300),
            scale in prop::sample::select(vec![1e-300, 1e-9, 1.0, 1e9, 1e300]),
        ) {
            let mut p = Patches::default();
            for (i, &l) in levels.iter().enumerate() {
                // The index in `dist` tells equal potentials apart.
                let mut c = patch(scale * (1.0 + l as f64));
                c.dist = i as f64;
                p.made.push(c);
            }
            let mut want = p.made.clone();
            want.sort_by(|a, b| b.brt.total_cmp(&a.brt));
            let got: Vec<(f64, f64)> = p.sort().iter().map(|c| (c.brt, c.dist)).collect();
            let want: Vec<(f64, f64)> = want.iter().map(|c| (c.brt, c.dist)).collect();
            prop_assert_eq!(got, want);
        }
    }
}
