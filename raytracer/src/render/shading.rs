//! What shading passes around: the requests a shaded point makes
//! ([`Request`], [`ShadowBundle`]), what it reads ([`ShadeContext`]) and
//! the `Emitter` through which every material routine asks for rays,
//! diffuse inter-reflection and direct light. The routines themselves are
//! in [`super::material`] and the files of each material family.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::ambient::AmbientRequest;
use super::effects::EffectsReport;
use super::light::PreparedLight;
use super::medium::{extinction_factor, Media, Medium, ScatterSurface, FHUGE, MAX_SCATTER_SAMPLES};
use super::options::RenderOptions;
use super::rng::{child_seed, Rng};
use super::surface::Surface;
use super::task::{intens, RayKind, RayTask};
use crate::accel::Hit;
use crate::geometry::{offset_origin_scaled, Ray, Vec3, FTINY};
use crate::image::brightness;
use crate::modifier::{Applied, RayVars};
use crate::scene::{Color, Scene};

/// Radiance's `MAXITER`: attempts to sample a rough specular direction.
pub(crate) const MAXITER: usize = 10;
/// Most rays one rough specular sample sends (`-ss` above 1.5).
pub(crate) const MAX_SPECULAR_RAYS: usize = 1024;
/// Direct light from one source to one surface point: a shadow bundle.
/// Everything needed to run it is in here (no references), so it can be
/// stored, sent and run later.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ShadowBundle {
    /// Index into the prepared lights.
    pub light: u32,
    /// Some other source has a larger potential at this point: Radiance
    /// would have tested it first, and estimates this source's untested
    /// light from the hit rates found there (see [`super::direct`]).
    #[serde(default)]
    pub brighter: bool,
    /// The surface point and its geometric normal (shadow ray origins are
    /// offset from it to the side each ray leaves through).
    pub point: Vec3,
    pub normal: Vec3,
    /// Magnitude the origin offset must cover (see [`offset_origin_scaled`]).
    pub offset_scale: f64,
    pub surface: Surface,
    /// Brightness expected at this point before this source is tested:
    /// the ambient term, plus the rough potential of each brighter source
    /// times its hit ratio (Radiance tests sources brightest first and
    /// compares with what the visible ones gave): the base of the `-dt`
    /// threshold.
    pub reference: f64,
    /// Weight of the ray that hit the point (the threshold is `-dt / weight`).
    pub weight: f64,
    pub seed: u64,
    /// The antimatter clip set of the ray that hit the point.
    #[serde(default)]
    pub clip: u64,
    /// The medium the shadow rays start in (zero extinction outside
    /// media): they lose `exp(-ext * (1 - albedo) * length)`.
    #[serde(default)]
    pub extinction: Color,
    #[serde(default)]
    pub medium: Medium,
}

/// Secondary work a shaded point asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Request {
    /// Trace `task` and add `coef` times its radiance.
    Trace { task: RayTask, coef: Color },
    /// Run the shadow bundle and add its (already weighted) result.
    Shadow(ShadowBundle),
    /// Light scattered into the ray by its medium: run the shadow bundle
    /// and add its result *after* the medium's attenuation of the ray
    /// (these come last, after every other request of the hit).
    Scatter(ShadowBundle),
}

/// The locally computed part of a shaded point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shaded {
    /// Emission and constant ambient.
    pub base: Color,
    /// Extinction to apply over the ray's length `t` (Radiance sets it when
    /// a ray reaches a dielectric from inside).
    pub extinction: Color,
    /// The rest of the medium of the ray's length (a mist corrects it for
    /// a ray that started inside).
    pub medium: Medium,
    /// Diffuse inter-reflection wanted here (`-ab` > bounces so far): the
    /// reflected and transmitted sides. Their value replaces the `-av`
    /// term; see [`super::ambient`].
    pub ambient: [Option<AmbientRequest>; 2],
    /// The coefficients `-av` was multiplied by in `base` (where no
    /// bounces were left): with `-aw` the renderer moves that term to the
    /// average of the irradiance cache ([`super::ambient::AmbientStore::ambient_value`]).
    pub constant: Color,
}

/// Everything shading reads: scene, options, lights, enabled effects.
#[derive(Debug, Clone, Copy)]
pub struct ShadeContext<'a> {
    pub scene: &'a Scene,
    pub options: &'a RenderOptions,
    pub lights: &'a [PreparedLight],
    pub effects: &'a EffectsReport,
    /// The mists' scattering sources.
    pub media: &'a Media,
}

/// Scratch of [`Emitter::direct`], per source: its rough potential, the
/// expected light of the sources brighter than it, and the sources of
/// positive potential in order (as sort keys: the potential's bits
/// inverted above the source's index, so that an integer sort puts the
/// brightest first and ties in index order).
#[derive(Default)]
struct Potentials {
    pot: Vec<f64>,
    ahead: Vec<f64>,
    order: Vec<u128>,
}

thread_local! {
    static POTENTIALS: std::cell::RefCell<Potentials> = std::cell::RefCell::new(Potentials::default());
}

/// Writes requests for one hit point; see the module documentation.
pub(crate) struct Emitter<'c, 'o> {
    pub(crate) ctx: &'c ShadeContext<'c>,
    pub(crate) task: &'c RayTask,
    pub(crate) hit: &'c Hit,
    pub(super) out: &'o mut Vec<Request>,
    pub(super) start: usize,
    pub(crate) offset_scale: f64,
    pub(super) ambient: [Option<AmbientRequest>; 2],
    /// See [`Shaded::constant`].
    pub(super) constant: Color,
    /// Share of the current material in a mixture (1 outside mixtures):
    /// every coefficient this point asks for is scaled by it.
    pub(crate) scale: f64,
    /// Distinguishes the two sides of a mixture in shadow-bundle seeds.
    pub(super) salt: u32,
    /// Local surface coordinates of a mesh hit (`Lu`, `Lv`).
    pub(crate) uv: [f64; 2],
}

impl Emitter<'_, '_> {
    /// Records a request for diffuse inter-reflection on `side`; the two
    /// sides of a mixture add their coefficients.
    /// Asks for diffuse inter-reflection from `normal`'s side (`side` 0:
    /// reflected, 1: transmitted) while `-ab` has bounces left; otherwise
    /// the constant ambient term, `coef` times `-av`. Returns what it adds
    /// to the local value.
    pub(crate) fn ambient(&mut self, normal: Vec3, coef: Color, side: u32) -> Color {
        let opts = self.ctx.options;
        if opts.ab > self.task.ambient && self.ctx.effects.diffuse_interreflection.enabled {
            self.want_ambient(AmbientRequest {
                point: self.hit.point,
                normal,
                coef,
                offset_scale: self.offset_scale,
                side,
            });
            Color::ZERO
        } else {
            self.constant += coef * self.scale;
            coef * opts.av
        }
    }

    pub(crate) fn want_ambient(&mut self, req: AmbientRequest) {
        let k = req.side as usize;
        let req = AmbientRequest {
            coef: req.coef * self.scale,
            ..req
        };
        match &mut self.ambient[k] {
            Some(a) => a.coef += req.coef,
            slot => *slot = Some(req),
        }
    }

    fn next_seed(&self) -> u64 {
        child_seed(self.task.seed, (self.out.len() - self.start) as u32)
    }

    /// Spawns a ray if the depth and weight limits allow it (Radiance's
    /// `rayorigin()` test).
    pub(super) fn spawn(&mut self, kind: RayKind, dir: Vec3, coef: Color, extinction: Color) {
        self.spawn_ray(kind, dir, coef, extinction, false)
    }

    pub(crate) fn spawn_ray(
        &mut self,
        kind: RayKind,
        dir: Vec3,
        coef: Color,
        extinction: Color,
        sampled: bool,
    ) {
        let enabled = match kind {
            RayKind::Reflection => self.ctx.effects.reflection.enabled,
            RayKind::Refraction => self.ctx.effects.refraction.enabled,
            _ => true,
        };
        if !enabled {
            return;
        }
        let (depth, weight) = if kind == RayKind::PassThrough {
            (self.task.depth, self.task.weight)
        } else {
            (self.task.depth + 1, self.task.weight * intens(coef))
        };
        if depth > self.ctx.options.lr
            || weight < self.ctx.options.lw
            || weight.is_nan()
            || weight <= 0.0
        {
            return;
        }
        let len = dir.length();
        if !(len > 0.0 && len.is_finite()) {
            return;
        }
        let dir = dir / len;
        let coef = coef * self.scale;
        // Radiance's `crtype`: a ray descended from an ambient or sampled
        // specular ray is one too (it must not count the sources that
        // direct lighting samples).
        let sampled = sampled || self.task.sampled;
        let origin = offset_origin_scaled(self.hit.point, self.hit.normal, dir, self.offset_scale);
        let seed = self.next_seed();
        let task = RayTask {
            ray: Ray { origin, dir },
            tmin: 0.0,
            tmax: f64::INFINITY,
            kind,
            depth,
            weight,
            seed,
            extinction,
            sampled,
            ambient: self.task.ambient,
            clip: self.task.clip,
            medium: self.task.medium,
        };
        self.out.push(Request::Trace { task, coef });
    }

    /// One shadow bundle per light that can reach this surface.
    pub(crate) fn direct(&mut self, bsdf: &Surface, base: Color) {
        let ctx = self.ctx;
        if ctx.lights.is_empty() || bsdf.is_black_to_lights() {
            return;
        }
        if ctx.lights.len() == 1 {
            // One source: nothing is brighter than it and nothing is
            // expected ahead of it, whatever its potential (what the
            // general case below computes for it), so that is not
            // computed: a rough sample, a coefficient and an emission per
            // shaded point, of which Radiance's Cornell box at rpict's
            // `-ab 1` settings shades a million at 512x512.
            self.bundles(bsdf, base, &[0.0], &[0.0], None);
            return;
        }
        // Rough potential of every source, for the threshold reference:
        // computed once per source (a scene may have hundreds) into a
        // per-thread buffer, summed in source order.
        let point = self.hit.point;
        let potential = |l: &PreparedLight| {
            l.rough_sample(ctx.scene, point).map_or(0.0, |s| {
                brightness(bsdf.coefficient(ctx.scene, s.dir, s.omega) * l.emission(point, &s))
            })
        };
        POTENTIALS.with_borrow_mut(|p| {
            p.pot.clear();
            p.pot.extend(ctx.lights.iter().map(potential));
            // Brightest first (ties by index): each source's reference
            // holds what the brighter ones are expected to give. Sources
            // without potential come last (their reference: all of it).
            // The bits of a positive float order as the float does.
            p.order.clear();
            p.order.extend(
                p.pot
                    .iter()
                    .enumerate()
                    .filter(|&(_, &v)| v > 0.0)
                    .map(|(k, &v)| (u128::from(!v.to_bits()) << 32) | k as u128),
            );
            p.order.sort_unstable();
            p.ahead.clear();
            p.ahead.resize(p.pot.len(), 0.0);
            let mut acc = 0.0;
            for &key in &p.order {
                let k = key as u32 as usize;
                p.ahead[k] = acc;
                acc += p.pot[k] * ctx.lights[k].hit_ratio;
            }
            for (a, &v) in p.ahead.iter_mut().zip(&p.pot) {
                if v.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                    *a = acc;
                }
            }
            let first = p.order.first().map(|&key| key as u32 as usize);
            self.bundles(bsdf, base, &p.pot, &p.ahead, first);
        });
    }

    fn bundles(
        &mut self,
        bsdf: &Surface,
        base: Color,
        potentials: &[f64],
        ahead: &[f64],
        brightest: Option<usize>,
    ) {
        let ctx = self.ctx;
        let point = self.hit.point;
        let top = brightest.map_or(0.0, |k| potentials[k]);
        for (i, (l, &own)) in ctx.lights.iter().zip(potentials).enumerate() {
            if !l.may_reach(point) {
                continue;
            }
            let brighter = brightest != Some(i) && top > 0.0 && top >= own;
            // Seeded by the light's index, not the request's position.
            let mut seed = child_seed(self.task.seed, 0x1_0000 + i as u32);
            if self.salt != 0 {
                seed = child_seed(seed, self.salt);
            }
            let mut surface = *bsdf;
            if self.scale != 1.0 {
                surface.scale(self.scale);
            }
            self.out.push(Request::Shadow(ShadowBundle {
                light: i as u32,
                brighter,
                point,
                normal: self.hit.normal,
                offset_scale: self.offset_scale,
                surface,
                reference: brightness(base) + ahead[i],
                weight: self.task.weight,
                seed,
                clip: self.task.clip,
                extinction: self.task.extinction,
                medium: self.task.medium,
            }));
        }
    }
}

/// The ray variables of the ray being shaded, for patterns.
pub(crate) fn ray_vars(task: &RayTask, hit: &Hit, uv: [f64; 2]) -> RayVars {
    RayVars {
        dir: task.ray.dir,
        normal: hit.normal,
        point: hit.point,
        t: hit.t,
        ts: 0.0,
        uv,
    }
}

/// Radiance's `raynormal()`: the normal `n` (facing the ray, cosine `rod`
/// with the reversed ray) perturbed by `pert`, turned back if the
/// perturbation would flip the surface's orientation towards the ray.
pub(crate) fn perturbed_normal(n: Vec3, rod: f64, dir: Vec3, pert: Vec3) -> (Vec3, f64) {
    let p = n + pert;
    let len = p.length();
    if !(len > 0.0 && len.is_finite()) {
        return (n, rod);
    }
    let mut p = p / len;
    let mut newdot = -p.dot(dir);
    if (newdot > 0.0) != (rod > 0.0) {
        p += dir * (2.0 * newdot);
        newdot = -newdot;
    }
    (p, newdot)
}

/// The surface as a ray sees it: Radiance's `flipsurface()` (back faces
/// are visible, the normal and its perturbation turned towards the ray)
/// then `raynormal()` (the perturbed normal).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Facing {
    /// The geometric normal facing the ray, and its cosine with the
    /// reversed ray (at least 0).
    pub(crate) ron: Vec3,
    pub(crate) rod: f64,
    /// The perturbation, turned with the surface.
    pub(crate) pert: Vec3,
    /// The perturbed normal and its cosine with the reversed ray.
    pub(crate) pnorm: Vec3,
    pub(crate) pdot: f64,
}

impl Facing {
    pub(crate) fn of(normal: Vec3, dir: Vec3, ap: &Applied) -> Self {
        let (mut ron, mut rod, mut pert) = (normal, -dir.dot(normal), ap.pert);
        if rod < 0.0 {
            ron = -ron;
            rod = -rod;
            pert = -pert;
        }
        let (pnorm, pdot) = if ap.perturbs() {
            perturbed_normal(ron, rod, dir, pert)
        } else {
            (ron, rod)
        };
        Facing {
            ron,
            rod,
            pert,
            pnorm,
            pdot,
        }
    }
}

thread_local! {
    static SCATTER_LIGHTS: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// `srcscatter()`: appends one [`Request::Scatter`] per in-scattering
/// sample of the segment of `task` of length `t` in medium (`ext`, `med`).
/// Nothing where the medium does not scatter towards any listed source.
pub fn scatter_requests(
    ctx: &ShadeContext,
    task: &RayTask,
    ext: Color,
    med: &Medium,
    t: f64,
    out: &mut Vec<Request>,
) {
    let opts = ctx.options;
    if med.scatter == 0
        || t.is_nan()
        || t >= FHUGE
        || med.gecc >= 1.0 - FTINY
        || intens(ext) <= 1.0 / FHUGE
        || intens(med.albedo) <= FTINY
    {
        return;
    }
    let nsamps = if opts.ms <= FTINY {
        1
    } else {
        ((t / opts.ms + 0.5) as usize).clamp(1, MAX_SCATTER_SAMPLES)
    };
    let base = ext * med.albedo * (t / (4.0 * PI * nsamps as f64));
    SCATTER_LIGHTS.with_borrow_mut(|lights| {
        ctx.media.lights_of(med.scatter, lights);
        for (i, &light) in lights.iter().enumerate() {
            for j in 0..nsamps {
                let seed = child_seed(
                    task.seed,
                    0x5ca7_0000 + (i * MAX_SCATTER_SAMPLES + j) as u32,
                );
                let mut rng = Rng::new(child_seed(seed, 1));
                let tj = t * (j as f64 + rng.next_f64()) / nsamps as f64;
                let cvext = extinction_factor(ext * tj);
                if intens(cvext) <= FTINY {
                    break; // too far away
                }
                let point = task.ray.origin + task.ray.dir * tj;
                if !ctx
                    .lights
                    .get(light as usize)
                    .is_some_and(|l| l.may_reach(point))
                {
                    continue;
                }
                out.push(Request::Scatter(ShadowBundle {
                    brighter: false,
                    light,
                    point,
                    normal: Vec3::ZERO,
                    offset_scale: point.abs().max_element(),
                    surface: Surface::Scatter(ScatterSurface {
                        rdir: task.ray.dir,
                        gecc: med.gecc,
                        factor: base * cvext,
                    }),
                    reference: 0.0,
                    weight: task.weight,
                    seed,
                    extinction: ext,
                    medium: *med,
                    clip: task.clip,
                }));
            }
        }
    });
}
