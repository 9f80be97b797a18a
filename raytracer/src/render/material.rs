//! Shading of one hit point, after Radiance's material routines
//! (`normal.c` for plastic, metal and trans; `glass.c`; `dielectric.c`;
//! `m_mirror.c`; emitters from `source.c`).
//!
//! [`shade`] never traces anything itself. It returns the part of the
//! result it can compute locally (emission, constant ambient) and appends
//! the secondary work it needs to `out`, each item with its coefficient:
//! - [`Request::Shadow`]: direct light from one source (a shadow bundle,
//!   a coherent demand-driven task in the parallel renderer);
//! - [`Request::Trace`]: a reflected, refracted or passed-through ray (a
//!   data-parallel task).
//!
//! The pixel's value is `base + sum of (coefficient x result)` over the
//! requests in order, then attenuated by the medium the ray crossed. The
//! sequential renderer evaluates requests recursively in that order; a
//! parallel renderer can run them anywhere and add the results in the same
//! order. Each request carries its own random seed derived from its
//! parent's, so where and when it runs cannot change the image.

use std::f64::consts::PI;

pub use super::shading::{scatter_requests, Request, ShadeContext, Shaded, ShadowBundle};
pub use super::surface::{spec, NormalBsdf, Surface};

use super::surface::{fresne, FRESTHRESH};
pub use super::task::{intens, RayKind, RayTask};

use super::rng::{child_seed, Rng};
use super::shading::{perturbed_normal, ray_vars, Emitter, Facing, MAXITER};
use crate::accel::Hit;
use crate::geometry::robust::orthonormal_basis;
use crate::geometry::{Shape, Vec3};
use crate::modifier::Applied;
use crate::scene::{Color, Material, Scene};

pub use crate::geometry::FTINY;
/// Radiance's `MLAMBDA`: mean wavelength (nm) for Hartmann's formula.
const MLAMBDA: f64 = 500.0;
/// Longest chain of `illum` alternates followed before giving up.
const MAX_ALTERNATES: usize = 8;

/// Shades `hit` of the ray `task`: returns the local part and appends the
/// requests (see the module documentation).
pub fn shade(ctx: &ShadeContext, task: &RayTask, hit: &Hit, out: &mut Vec<Request>) -> Shaded {
    let flat = hit.flat();
    let offset_scale = task.ray.origin.abs().max_element().max(hit.t);
    let mut em = Emitter {
        ctx,
        task,
        hit,
        out,
        start: 0,
        offset_scale,
        ambient: [None; 2],
        constant: Color::ZERO,
        scale: 1.0,
        salt: 0,
        uv: [0.0; 2],
    };
    em.start = em.out.len();
    let mut shaded = Shaded {
        base: Color::ZERO,
        extinction: task.extinction,
        medium: task.medium,
        ambient: [None; 2],
        constant: Color::ZERO,
    };
    if !ctx.scene.clip_bits.is_empty() {
        // Antimatter (m_clip.c): clipped surfaces are not there for this
        // ray; an antimatter surface changes the clip set.
        if let Some(clip) =
            super::clip::pass_through(ctx.scene, task.clip, task.ray.dir, hit, hit.material())
        {
            em.spawn(
                RayKind::PassThrough,
                task.ray.dir,
                Color::ONE,
                task.extinction,
            );
            for r in &mut em.out[em.start..] {
                if let Request::Trace { task, .. } = r {
                    task.clip = clip;
                }
            }
            return shaded;
        }
    }
    let (start, uv) = mesh_shading(ctx.scene, hit);
    em.uv = uv;
    shade_material(&mut em, &mut shaded, hit.material(), flat, start, 0);
    shaded.ambient = em.ambient;
    shaded.constant = em.constant;
    if shaded.medium.scatter != 0 {
        scatter_requests(ctx, task, shaded.extinction, &shaded.medium, hit.t, em.out);
    }
    shaded
}

/// A Radiance mesh's smooth shading at the hit (`o_mesh`): the
/// interpolated vertex normal as a perturbation of the geometric one, and
/// the interpolated (u, v).
fn mesh_shading(scene: &Scene, hit: &Hit) -> (Applied, [f64; 2]) {
    // A surface a processor of a distributed scene does not hold is no
    // instance (instances are held everywhere).
    let Some(top) = scene.object(hit.object) else {
        return (Applied::NONE, [0.0; 2]);
    };
    let (Shape::Instance(inst), Some(k)) = (&top.shape, hit.inner) else {
        return (Applied::NONE, [0.0; 2]);
    };
    let Some(sh) = &inst.geometry.shading else {
        return (Applied::NONE, [0.0; 2]);
    };
    let p = inst.transform.inv_point(hit.point);
    let (n, uv) = sh.at(k as usize, p);
    let mut a = Applied::NONE;
    if let Some(n) = n {
        let w = inst.transform.vector(n).normalize_or_zero();
        if w != Vec3::ZERO {
            a.pert = w - hit.normal;
        }
    }
    (a, uv.unwrap_or([0.0; 2]))
}

/// Deepest nesting of material mixtures followed.
const MAX_MIX_DEPTH: usize = 16;

/// Shades material `id` with the patterns applied so far (`applied`) and
/// its own; a mixture shades both sides with their shares.
fn shade_material(
    em: &mut Emitter,
    shaded: &mut Shaded,
    id: crate::scene::MaterialId,
    flat: bool,
    applied: Applied,
    depth: usize,
) {
    let ctx = em.ctx;
    let task = em.task;
    let hit = em.hit;
    let mut id = id;
    let mut material = ctx.scene.material(id);
    let rod = -task.ray.dir.dot(hit.normal);
    // Radiance's `badcomponent()`: an illum is a source that direct
    // lighting samples, so a sampled ray meeting its front sees nothing.
    if matches!(material, Material::Illum { .. }) && task.sampled && rod >= 0.0 {
        return;
    }
    // Rays other than shadow rays see an illum as its alternate material.
    let mut hops = 0;
    while let Material::Illum {
        alternate: Some(a), ..
    } = material
    {
        hops += 1;
        if hops > MAX_ALTERNATES {
            break;
        }
        id = *a;
        material = ctx.scene.material(id);
    }
    // -i: the first surface seen (a primary ray's, or one continued
    // through pure transmission: Radiance's crtype test; every other ray
    // is a level deeper) is shaded as irradiance.
    if ctx.options.irradiance && task.depth == 0 && irradiance(em, shaded, material, flat, &applied)
    {
        return;
    }
    let mut ap = applied;
    let mods = ctx.scene.mods(id);
    if !mods.is_empty() {
        ctx.scene
            .patterns
            .apply(mods, &ray_vars(task, hit, em.uv), &mut ap);
    }
    let dir = task.ray.dir;
    let scale = em.scale;
    match material {
        Material::Void | Material::Illum { .. } => {
            em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction);
        }
        Material::Mix {
            fore,
            back,
            modifier,
        } => {
            let c = ctx
                .scene
                .patterns
                .mix_coefficient(*modifier, &ray_vars(task, hit, em.uv));
            let (Some(c), true) = (c, depth < MAX_MIX_DEPTH) else {
                em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction);
                return;
            };
            let salt = em.salt;
            for (k, (side, share)) in [(fore, c), (back, 1.0 - c)].into_iter().enumerate() {
                // raymixture(): a side below FTINY is not shaded.
                if share <= FTINY {
                    continue;
                }
                em.scale = scale * share;
                em.salt = salt.wrapping_mul(3).wrapping_add(k as u32 + 1);
                match side {
                    Some(m) => shade_material(em, shaded, *m, flat, ap, depth + 1),
                    None => em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction),
                }
            }
            em.scale = scale;
            em.salt = salt;
        }
        // Radiance's `m_light()`: the back of a source is black, and
        // sampled rays (ambient, rough specular, and all they lead to)
        // skip the sources that direct lighting samples (`badcomponent`):
        // all lights and spotlights, and glows within their radius; a glow
        // with a negative radius lights nothing indirectly.
        Material::Light { .. } | Material::Spotlight { .. } | Material::Glow { .. }
            if rod < 0.0 => {}
        Material::Light { .. } | Material::Spotlight { .. } if task.sampled => {}
        Material::Glow { max_radius, .. }
            if task.sampled && !(*max_radius >= -FTINY && hit.t > *max_radius) => {}
        Material::Light { radiance } | Material::Glow { radiance, .. } => {
            shaded.base += *radiance * ap.color * scale
        }
        Material::Spotlight {
            radiance,
            angle_deg,
            direction,
        } => {
            if super::light::spot_lights(*direction, hit.normal, *angle_deg, -dir) {
                shaded.base += *radiance * ap.color * scale;
            }
        }
        Material::Mirror {
            alternate: Some(alt),
            ..
        } => {
            // Only shadow rays relaying a source see the mirror itself.
            match alt {
                crate::scene::Alternate::Void => {
                    em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction)
                }
                // The alternate is shaded as if hit directly (m_mirror.c
                // switches before applying the mirror's own patterns).
                crate::scene::Alternate::Material(m) if depth < MAX_MIX_DEPTH => {
                    shade_material(em, shaded, *m, flat, applied, depth + 1)
                }
                crate::scene::Alternate::Material(_) => {}
            }
        }
        Material::Prism {
            modifier,
            projections,
        } => {
            // m_direct.c: each projection sends one redirected ray.
            let vars = ray_vars(task, hit, em.uv);
            for k in 0..*projections as usize {
                if let Some((coef, d)) = ctx.scene.patterns.redirect(*modifier, k, &vars) {
                    if coef > FTINY {
                        em.spawn(RayKind::Refraction, d, Color::splat(coef), task.extinction);
                    }
                }
            }
        }
        Material::Antimatter { .. } => {
            // Reached only inside a mixture: invisible there.
            em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction);
        }
        Material::Mirror { color, .. } => {
            // Back is black (m_mirror.c).
            if rod >= 0.0 {
                let (n, pdot) = if ap.perturbs() {
                    perturbed_normal(hit.normal, rod, dir, ap.pert)
                } else {
                    (hit.normal, rod)
                };
                em.spawn(
                    RayKind::Reflection,
                    dir + n * (2.0 * pdot),
                    *color * ap.color,
                    task.extinction,
                );
            }
        }
        Material::Plastic {
            color,
            specularity,
            roughness,
        } => {
            shaded.base += normal(
                em,
                Kind::Plastic,
                *color,
                *specularity,
                *roughness,
                0.0,
                0.0,
                flat,
                &ap,
            ) * scale
        }
        Material::Metal {
            color,
            specularity,
            roughness,
        } => {
            shaded.base += normal(
                em,
                Kind::Metal,
                *color,
                *specularity,
                *roughness,
                0.0,
                0.0,
                flat,
                &ap,
            ) * scale
        }
        Material::Trans {
            color,
            specularity,
            roughness,
            transmissivity,
            transmitted_specular,
        } => {
            shaded.base += normal(
                em,
                Kind::Trans,
                *color,
                *specularity,
                *roughness,
                *transmissivity,
                *transmitted_specular,
                flat,
                &ap,
            ) * scale
        }
        Material::Aniso {
            kind,
            color,
            specularity,
            u_rough,
            v_rough,
            transmissivity,
            transmitted_specular,
            direction,
        } => {
            let p = super::aniso::AnisoParams {
                kind: *kind,
                color: *color,
                specularity: *specularity,
                u_rough: *u_rough,
                v_rough: *v_rough,
                transmissivity: *transmissivity,
                transmitted_specular: *transmitted_specular,
            };
            shaded.base += super::aniso::shade_aniso(em, &p, *direction, flat, &ap) * scale
        }
        Material::Ashik {
            diffuse,
            specular,
            u_power,
            v_power,
            direction,
        } => {
            let p = super::ashik::AshikParams {
                diffuse: *diffuse,
                specular: *specular,
                u_power: *u_power,
                v_power: *v_power,
            };
            shaded.base += super::ashik::shade_ashik(em, &p, *direction, flat, &ap) * scale
        }
        Material::Bsdf {
            data,
            rdiff_front,
            rdiff_back,
            tdiff,
            direction,
        } => {
            let p = super::bsdf::BsdfParams {
                data: *data,
                rdiff_front: *rdiff_front,
                rdiff_back: *rdiff_back,
                tdiff: *tdiff,
            };
            shaded.base += super::bsdf::shade_bsdf(em, &p, *direction, &ap) * scale
        }
        Material::Glass {
            transmission,
            index,
        } => glass(em, *transmission * ap.color, *index, &ap),
        Material::Dielectric {
            transmission,
            index,
            hartmann,
        } => {
            let mut nratio = index + hartmann / MLAMBDA;
            if !(nratio.is_finite() && nratio > 0.0) {
                nratio = 1.0;
            }
            let inside = extinction_of(*transmission);
            if let Some(ext) = dielectric(em, nratio, inside, None) {
                shaded.extinction = ext;
            }
        }
        Material::Interface {
            inside_transmission,
            inside_index,
            outside_transmission,
            outside_index,
        } => {
            let nratio = interface_ratio(*inside_index, *outside_index);
            let inside = extinction_of(*inside_transmission);
            let outside = extinction_of(*outside_transmission);
            if let Some(ext) = dielectric(em, nratio, inside, Some(outside)) {
                shaded.extinction = ext;
            }
        }
        Material::Brtd { .. } => {
            shaded.base += super::brdf::shade_brtd(em, id, material, &ap) * scale
        }
        Material::BrdfFunc { .. } => {
            shaded.base += super::brdf::shade_brdf_func(em, id, material, &ap) * scale
        }
        Material::Mist {
            extinction,
            albedo,
            gecc,
            ..
        } => {
            let mist = super::medium::Mist {
                extinction: *extinction * ap.color,
                albedo: *albedo,
                gecc: *gecc,
                slot: ctx.media.slot(id),
            };
            let c = super::medium::cross_mist(
                ctx.options,
                &mist,
                rod > 0.0,
                shaded.extinction,
                shaded.medium,
            );
            if let Some((ext, med)) = c.before {
                shaded.extinction = ext;
                shaded.medium = med;
            }
            let n = em.out.len();
            em.spawn(RayKind::PassThrough, dir, Color::ONE, c.extinction);
            if let Some(Request::Trace { task, .. }) = em.out.get_mut(n) {
                task.medium = c.medium;
            }
        }
    }
}

/// Radiance's `Lamb`: `plastic` of colour (pi, pi, pi), no specularity,
/// whose value is the irradiance at the point.
const LAMB: Color = Color::splat(PI);

/// `-i` at a surface a primary ray sees (Radiance's `rayshade` with
/// `do_irrad`): light sources, `void` and antimatter shade as usual (false);
/// the materials Radiance marks `T_IRR_IGN` (trans, trans2, dielectric,
/// interface, mist, glass) pass the ray on unchanged, and every other
/// material and mixture is shaded as [`LAMB`] without its patterns (the
/// mesh's smooth normal stays). True when the point is done.
fn irradiance(
    em: &mut Emitter,
    shaded: &mut Shaded,
    material: &Material,
    flat: bool,
    mesh: &Applied,
) -> bool {
    use crate::scene::AnisoKind;
    match material {
        Material::Light { .. }
        | Material::Spotlight { .. }
        | Material::Glow { .. }
        | Material::Illum { .. }
        | Material::Void
        | Material::Antimatter { .. } => false,
        Material::Trans { .. }
        | Material::Aniso {
            kind: AnisoKind::Trans2,
            ..
        }
        | Material::Dielectric { .. }
        | Material::Interface { .. }
        | Material::Mist { .. }
        | Material::Glass { .. } => {
            let (dir, ext) = (em.task.ray.dir, em.task.extinction);
            em.spawn(RayKind::PassThrough, dir, Color::ONE, ext);
            true
        }
        _ => {
            let ap = Applied {
                color: Color::ONE,
                pert: mesh.pert,
            };
            let scale = em.scale;
            shaded.base += normal(em, Kind::Plastic, LAMB, 0.0, 0.0, 0.0, 0.0, flat, &ap) * scale;
            true
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Plastic,
    Metal,
    Trans,
}

/// `m_normal()` for plastic, metal and trans.
#[allow(clippy::too_many_arguments)]
fn normal(
    em: &mut Emitter,
    kind: Kind,
    color: Color,
    specularity: f64,
    roughness: f64,
    transmissivity: f64,
    tspec_frac: f64,
    flat: bool,
    ap: &Applied,
) -> Color {
    let opts = em.ctx.options;
    let task = em.task;
    let dir = task.ray.dir;
    if -dir.dot(em.hit.normal) < 0.0 && !opts.bv && kind != Kind::Trans {
        // -bv-: plastic and metal back faces let rays through (m_normal's raytrans).
        em.spawn(RayKind::PassThrough, dir, Color::ONE, task.extinction);
        return Color::ZERO;
    }
    let facing = Facing::of(em.hit.normal, dir, ap);
    let (n, rod) = (facing.pnorm, facing.pdot);
    let mut b = NormalBsdf {
        mcolor: color * ap.color,
        scolor: Color::ZERO,
        alpha2: roughness * roughness,
        rdiff: 0.0,
        rspec: specularity,
        trans: 0.0,
        tdiff: 0.0,
        tspec: 0.0,
        specfl: 0,
        pnorm: n,
        pdot: rod.max(0.001),
        rdir: dir,
        prdir: dir,
    };
    if b.alpha2 <= FTINY {
        b.specfl |= spec::PURE;
    }
    if flat {
        b.specfl |= spec::FLAT;
    }
    let pure = b.specfl & spec::PURE != 0;
    let fest = if pure && b.rspec >= FRESTHRESH {
        let f = fresne(rod);
        b.rspec += f * (1.0 - b.rspec);
        f
    } else {
        0.0
    };
    if kind == Kind::Trans {
        b.trans = transmissivity * (1.0 - b.rspec);
        b.tspec = b.trans * tspec_frac;
        b.tdiff = b.trans - b.tspec;
        if b.tspec > FTINY {
            b.specfl |= spec::TRAN;
            if !pure && opts.st >= b.tspec - FTINY {
                b.specfl |= spec::TBLT;
            }
        }
    }
    // Specular transmission straight through (no refraction for a thin surface).
    if b.specfl & (spec::TRAN | spec::PURE | spec::TBLT) == (spec::TRAN | spec::PURE) {
        em.spawn(
            RayKind::Refraction,
            b.prdir,
            b.mcolor * b.tspec,
            task.extinction,
        );
    }
    let mut vrefl = dir;
    if b.rspec > FTINY {
        b.specfl |= spec::REFL;
        b.scolor = if kind != Kind::Metal {
            Color::splat(b.rspec)
        } else if fest > FTINY {
            let d = b.rspec * (1.0 - fest);
            Color::splat(fest) + b.mcolor * d
        } else {
            b.mcolor * b.rspec
        };
        if !pure && opts.st >= b.rspec - FTINY {
            b.specfl |= spec::RBLT;
        }
        vrefl = dir + n * (2.0 * b.pdot);
    }
    if b.specfl & (spec::REFL | spec::PURE | spec::RBLT) == (spec::REFL | spec::PURE) {
        em.spawn(RayKind::Reflection, vrefl, b.scolor, task.extinction);
    }
    b.rdiff = 1.0 - b.trans - b.rspec;
    if pure && b.rdiff <= FTINY && b.tdiff <= FTINY {
        return Color::ZERO; // 100% pure specular
    }
    if !pure {
        // The sampled rays are kept above the unperturbed surface.
        gaussamp(em, &b, facing.ron, facing.rod);
    }
    let mut base = Color::ZERO;
    if b.rdiff > FTINY {
        base += em.ambient(n, reflected_ambient(&b), 0);
    }
    if b.tdiff > FTINY {
        let f = if b.specfl & spec::TBLT != 0 {
            b.trans
        } else {
            b.tdiff
        };
        base += em.ambient(-n, b.mcolor * f, 1);
    }
    em.direct(&Surface::Normal(b), base * em.scale);
    base
}

/// The coefficient of ambient light on the reflected side (normal.c):
/// the diffuse reflection, plus the specular one when it is below the
/// `-st` threshold and so not sampled (white for plastic, the material's
/// colour for metal: `scolor`).
fn reflected_ambient(b: &NormalBsdf) -> Color {
    let diffuse = b.mcolor * b.rdiff;
    if b.specfl & spec::RBLT != 0 {
        diffuse + b.scolor
    } else {
        diffuse
    }
}

/// `gaussamp()`: one sampled ray for a rough specular reflection and/or
/// transmission above the `-st` threshold.
fn gaussamp(em: &mut Emitter, b: &NormalBsdf, ron: Vec3, rod: f64) {
    let refl = b.specfl & (spec::REFL | spec::RBLT) == spec::REFL;
    let tran = b.specfl & (spec::TRAN | spec::TBLT) == spec::TRAN;
    if !refl && !tran {
        return;
    }
    let (u, v) = orthonormal_basis(b.pnorm);
    let ss = em.ctx.options.ss;
    // Radiance 5: -ss above 1.5 asks for that many rays (times the ray's
    // weight, within -lw); -ss below 1 reduces the jitter of one ray.
    let jitter = if (0.0..1.0).contains(&ss) { ss } else { 1.0 };
    let dir = b.rdir;
    let mut rng = Rng::new(child_seed(em.task.seed, 0x6761_7573));
    let ext = em.task.extinction;
    if refl {
        let samples = super::aniso::sample_count(em, b.scolor);
        // With several samples each is weighted by W-G-M-D's
        // 2 / (1 + cos_i / cos_r), and all by the share of trials taken
        // (a rejected trial counts as a dark sample).
        let mut taken: Vec<(Vec3, f64)> = Vec::with_capacity(samples);
        let mut trials = 0;
        while taken.len() < samples && trials < MAXITER * samples {
            trials += 1;
            let phi = 2.0 * PI * rng.next_f64();
            let r1 = 1.0 - jitter * rng.next_f64();
            let d = if r1 <= FTINY {
                1.0
            } else {
                (b.alpha2 * -r1.ln()).sqrt()
            };
            let h = b.pnorm + (u * phi.cos() + v * phi.sin()) * d;
            let k = -2.0 * h.dot(dir) / (1.0 + d * d);
            let rdir = dir + h * k;
            let dn = rdir.dot(ron);
            if dn <= FTINY {
                continue;
            }
            let w = if samples > 1 {
                2.0 / (1.0 + rod / dn)
            } else {
                1.0
            };
            taken.push((rdir, w));
        }
        let share = if samples > 1 {
            1.0 / trials as f64
        } else {
            1.0
        };
        for (rdir, w) in taken {
            em.spawn_ray(RayKind::Reflection, rdir, b.scolor * (share * w), ext, true);
        }
    }
    if tran {
        let tcoef = b.mcolor * b.tspec;
        let samples = super::aniso::sample_count(em, tcoef);
        let share = 1.0 / samples as f64;
        let mut taken = 0;
        let mut trials = 0;
        while taken < samples && trials < MAXITER * samples {
            trials += 1;
            let phi = 2.0 * PI * rng.next_f64();
            let r1 = 1.0 - jitter * rng.next_f64();
            let d = if r1 <= FTINY {
                1.0
            } else {
                (b.alpha2 * -r1.ln()).sqrt()
            };
            let rdir = b.prdir + (u * phi.cos() + v * phi.sin()) * d;
            if rdir.dot(ron) < -FTINY {
                em.spawn_ray(RayKind::Refraction, rdir, tcoef * share, ext, true);
                taken += 1;
            }
        }
    }
}

/// Thin glass (`glass.c`): transmitted and reflected fractions per channel
/// for a ray meeting the surface at cosine `pdot` (0 < pdot <= 1).
/// Returns `(transmission, reflection)`.
pub fn glass_coefficients(transmission: Color, index: f64, pdot: f64) -> (Color, Color) {
    let pdot = pdot.clamp(1e-9, 1.0);
    let n = if index.is_finite() && index > 0.0 {
        index
    } else {
        1.52
    };
    let hastrans = intens(transmission) > 1e-15;
    let mut mcolor = transmission.max(Color::splat(1e-15));
    let cos2 = ((1.0 - 1.0 / (n * n)) + pdot * pdot / (n * n)).sqrt();
    if hastrans {
        mcolor = Color::new(
            mcolor.x.powf(1.0 / cos2),
            mcolor.y.powf(1.0 / cos2),
            mcolor.z.powf(1.0 / cos2),
        );
    }
    let r1e = ((pdot - n * cos2) / (pdot + n * cos2)).powi(2);
    let r1m = ((1.0 / pdot - n / cos2) / (1.0 / pdot + n / cos2)).powi(2);
    let mut trans = Color::ZERO;
    if hastrans {
        for i in 0..3 {
            let d = mcolor[i];
            trans[i] = 0.5 * (1.0 - r1e).powi(2) * d / (1.0 - r1e * r1e * d * d)
                + 0.5 * (1.0 - r1m).powi(2) * d / (1.0 - r1m * r1m * d * d);
        }
    }
    let mut refl = Color::ZERO;
    for i in 0..3 {
        let d = mcolor[i] * mcolor[i];
        refl[i] = 0.5 * r1e * (1.0 + (1.0 - 2.0 * r1e) * d) / (1.0 - r1e * r1e * d)
            + 0.5 * r1m * (1.0 + (1.0 - 2.0 * r1m) * d) / (1.0 - r1m * r1m * d);
    }
    (trans, refl)
}

fn glass(em: &mut Emitter, transmission: Color, index: f64, ap: &Applied) {
    let dir = em.task.ray.dir;
    let Facing {
        pnorm: n, mut pdot, ..
    } = Facing::of(em.hit.normal, dir, ap);
    if ap.perturbs() {
        pdot = pdot.max(1e-6);
    }
    let (trans, refl) = glass_coefficients(transmission, index, pdot);
    let ext = em.task.extinction;
    if intens(trans) > 0.0 {
        em.spawn(RayKind::Refraction, dir, trans, ext);
    }
    em.spawn(RayKind::Reflection, dir + n * (2.0 * pdot), refl, ext);
}

/// Radiance's `mylog()` for extinction coefficients.
fn mylog(x: f64) -> f64 {
    if x < 1e-40 {
        -100.0
    } else if x >= 1.0 {
        0.0
    } else {
        x.ln()
    }
}

/// Fresnel reflectance of a dielectric boundary (unpolarised), the cosine
/// of the refracted ray, or `None` for total internal reflection.
/// `nratio` is n(incident side) / n(other side); `cos1` in (0, 1].
pub fn fresnel_dielectric(nratio: f64, cos1: f64) -> (f64, Option<f64>) {
    let d2 = 1.0 - nratio * nratio * (1.0 - cos1 * cos1);
    if d2 < FTINY {
        return (1.0, None);
    }
    let cos2 = d2.sqrt();
    let a = (cos1 - nratio * cos2) / (cos1 + nratio * cos2);
    let b = (1.0 / cos1 - nratio / cos2) / (1.0 / cos1 + nratio / cos2);
    (0.5 * (a * a + b * b), Some(cos2))
}

/// Extinction per unit length of a medium with transmission `t` per unit
/// length (Radiance's `-mylog(t)` per channel).
pub fn extinction_of(t: Color) -> Color {
    Color::new(-mylog(t.x), -mylog(t.y), -mylog(t.z))
}

/// The relative index inside / outside of an `interface` (1 where it is
/// not a positive finite number).
pub fn interface_ratio(inside_index: f64, outside_index: f64) -> f64 {
    let r = inside_index / outside_index;
    if r.is_finite() && r > 0.0 {
        r
    } else {
        1.0
    }
}

/// `m_dielectric()` for `dielectric` (`outside` is `None`: the ray's own
/// medium outside) and `interface`. `nratio` is n(inside) / n(outside).
/// Returns the extinction of the ray being shaded when the surface fixes
/// it (the ray reached it from inside, or an interface's outside medium).
fn dielectric(
    em: &mut Emitter,
    nratio: f64,
    inside: Color,
    outside: Option<Color>,
) -> Option<Color> {
    let dir = em.task.ray.dir;
    let mut dnorm = em.hit.normal;
    let mut cos1 = -dir.dot(dnorm);
    let mut nratio = nratio;
    let (own, ctrans);
    if cos1 < 0.0 {
        // Inside, leaving the medium: this ray travelled through it.
        cos1 = -cos1;
        dnorm = -dnorm;
        own = Some(inside);
        ctrans = outside.unwrap_or(Color::ZERO);
    } else {
        nratio = 1.0 / nratio;
        own = outside;
        ctrans = inside;
    }
    let cos1 = cos1.max(1e-12);
    let own_ext = own.unwrap_or(em.task.extinction);
    let (refl, cos2) = fresnel_dielectric(nratio, cos1);
    if let Some(cos2) = cos2 {
        let trans = (1.0 - refl) * nratio * nratio; // solid angle ratio
        let d1 = nratio * cos1 - cos2;
        let rdir = dir * nratio + dnorm * d1;
        em.spawn(RayKind::Refraction, rdir, Color::splat(trans), ctrans);
    }
    em.spawn(
        RayKind::Reflection,
        dir + dnorm * (2.0 * cos1),
        Color::splat(refl),
        own_ext,
    );
    own
}

/// A shadow ray meeting a `dielectric` or `interface` surface with unit
/// normal `normal` (as the shape orients it): Radiance traces the refracted
/// ray only. Returns the refracted unit direction, its coefficient
/// (Fresnel transmission times the solid-angle ratio), the extinction of
/// the medium it enters and of the medium it left; `None` for total
/// internal reflection or another material.
pub fn shadow_refraction(material: &Material, dir: Vec3, normal: Vec3) -> Option<ShadowRefraction> {
    let (nratio, inside, outside) = match material {
        Material::Dielectric {
            transmission,
            index,
            hartmann,
        } => {
            let mut n = index + hartmann / MLAMBDA;
            if !(n.is_finite() && n > 0.0) {
                n = 1.0;
            }
            (n, extinction_of(*transmission), Color::ZERO)
        }
        Material::Interface {
            inside_transmission,
            inside_index,
            outside_transmission,
            outside_index,
        } => (
            interface_ratio(*inside_index, *outside_index),
            extinction_of(*inside_transmission),
            extinction_of(*outside_transmission),
        ),
        _ => return None,
    };
    let mut cos1 = -dir.dot(normal);
    let mut dnorm = normal;
    let (mut nratio, enters, left) = (nratio, inside, outside);
    let (enters, left) = if cos1 < 0.0 {
        cos1 = -cos1;
        dnorm = -dnorm;
        (left, enters)
    } else {
        nratio = 1.0 / nratio;
        (enters, left)
    };
    let cos1 = cos1.max(1e-12);
    let (refl, cos2) = fresnel_dielectric(nratio, cos1);
    let cos2 = cos2?;
    let d1 = nratio * cos1 - cos2;
    let rdir = (dir * nratio + dnorm * d1).normalize_or_zero();
    if rdir == Vec3::ZERO {
        return None;
    }
    Some(ShadowRefraction {
        dir: rdir,
        coef: (1.0 - refl) * nratio * nratio,
        enters,
        left,
    })
}

/// See [`shadow_refraction`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowRefraction {
    pub dir: Vec3,
    pub coef: f64,
    /// Extinction per unit length of the medium the ray now travels in.
    pub enters: Color,
    /// Extinction per unit length of the medium it came through.
    pub left: Color,
}

/// How a shadow ray fares at a surface of `material` it meets at cosine
/// `rod` (either sign): `Some(filter)` if it passes with that per-channel
/// transmission (invisible surfaces pass unchanged, thin glass and pure
/// specular trans pass their specular transmission, as in Radiance's
/// shadow-ray shading), `None` if the surface blocks it. A dielectric
/// bends the ray away from the source, so it blocks.
///
/// `weak_target`: the ray is aimed at an `illum` or `glow` source. An
/// illum met from the front then blocks it (Radiance's `illumblock`: an
/// illum must not pass light from another illum, which it already
/// accounts for, nor from a glow behind it).
pub fn shadow_filter(
    scene: &Scene,
    material: &Material,
    rod: f64,
    weak_target: bool,
) -> Option<Color> {
    let mut material = material;
    if matches!(material, Material::Illum { .. }) && weak_target && rod > 0.0 {
        return None;
    }
    let mut hops = 0;
    // For rays aimed at *another* source an illum is its alternate; a
    // mirror with an alternate is it for shadow rays it does not relay.
    while let Material::Illum {
        alternate: Some(next),
        ..
    }
    | Material::Mirror {
        alternate: Some(crate::scene::Alternate::Material(next)),
        ..
    } = material
    {
        hops += 1;
        if hops > MAX_ALTERNATES {
            return None;
        }
        material = scene.material(*next);
    }
    let pdot = rod.abs();
    match material {
        Material::Void
        | Material::Mist { .. }
        | Material::Illum {
            alternate: None, ..
        }
        | Material::Mirror {
            alternate: Some(crate::scene::Alternate::Void),
            ..
        }
        | Material::Antimatter { .. } => Some(Color::ONE),
        Material::Glass {
            transmission,
            index,
        } => {
            let (t, _) = glass_coefficients(*transmission, *index, pdot);
            Some(t)
        }
        Material::Trans {
            color,
            specularity,
            roughness,
            transmissivity,
            transmitted_specular,
        } => {
            if roughness * roughness > FTINY {
                return None;
            }
            let mut rspec = *specularity;
            if rspec >= FRESTHRESH {
                rspec += fresne(pdot) * (1.0 - rspec);
            }
            let tspec = transmissivity * (1.0 - rspec) * transmitted_specular;
            (tspec > FTINY).then(|| *color * tspec)
        }
        // m_aniso() and m_ashikhmin() return at once for shadow rays (the
        // roughness of trans2 is never 0): they block, even trans2 with
        // specular transmission, whose light comes through sampled rays.
        Material::Aniso { .. } | Material::Ashik { .. } => None,
        _ => None,
    }
}
