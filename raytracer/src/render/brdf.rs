//! Function- and data-defined materials, after Radiance's `m_brdf.c`:
//!
//! - `BRTDfunc` ([`Material::Brtd`], `m_brdf`): diffuse reflectance of the
//!   front and of the back and diffuse transmittance as reals; specular
//!   reflection and transmission as three expressions each, evaluated per
//!   ray (a mirror ray and a straight-through ray, which shadow rays take
//!   too); and a directional part towards light sources, three functions
//!   of the light direction (`0` for none).
//! - `plasfunc`, `metfunc`, `transfunc`, `plasdata`, `metdata`,
//!   `transdata` ([`Material::BrdfFunc`], `m_brdf2`): plastic, metal or
//!   trans whose non-diffuse part is given towards light sources only, as
//!   a function of the light direction or a data file looked up at
//!   coordinates computed from it. Nothing is traced for it: the rest of
//!   the non-diffuse light is in the ambient term.
//!
//! The functions see Radiance's ray variables (`Dx`, `Nx`, `Rdot`, `Px`,
//! ...), the perturbed normal `NxP` and its cosine `RdotP`, the material
//! colour `CrP`, and are called with the light direction in function
//! space and the source's solid angle (`f(lx, ly, lz, omega)`; a data
//! type's function gets the data value first). A shadow bundle carries a
//! [`FuncBsdf`] (ids and vectors, no references) whose
//! [`FuncBsdf::coefficient`] evaluates them for each light sample:
//! Radiance's `dirbrdf`. Failed evaluations count with the pattern
//! failures of the render and leave out the part they were for.

pub use super::surface::FuncBsdf;

use super::shading::{perturbed_normal, ray_vars, Emitter, Facing};
use super::surface::{specular, Params, Surface};
use super::task::RayKind;
use crate::accel::Hit;
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::image::brightness;
use crate::modifier::{Applied, MaterialVars, RayVars};
use crate::scene::{Color, Material, MaterialId, Scene};

/// `m_brdf()`: a ray that hit a `BRTDfunc` surface. Returns the local
/// value (constant ambient); the rest goes to requests.
pub(super) fn shade_brtd(em: &mut Emitter, id: MaterialId, m: &Material, ap: &Applied) -> Color {
    let Material::Brtd {
        front,
        back,
        tdiff,
        funcs,
        directional,
    } = m
    else {
        return Color::ZERO;
    };
    let task = em.task;
    let hit = em.hit;
    let dir = task.ray.dir;
    let rod = -dir.dot(hit.normal);
    let mut rdiff = if rod > 0.0 { *front } else { *back };
    let mut tdiff = *tdiff;
    let hastexture = ap.perturbs();
    let mut pert = ap.pert;
    let (mut pnorm, mut pdot) = if hastexture {
        perturbed_normal(hit.normal, rod, dir, pert)
    } else {
        (hit.normal, rod)
    };
    let hitfront = rod >= 0.0;
    if !hitfront {
        pdot = -pdot;
        pnorm = -pnorm;
        pert = -pert;
    }
    let mcolor = ap.color;
    rdiff *= mcolor;
    tdiff *= mcolor;
    let hasrefl = brightness(rdiff) > FTINY;
    let hastrans = brightness(tdiff) > FTINY;
    let rv = ray_vars(task, hit, em.uv);
    let vars = MaterialVars {
        pnorm,
        pdot,
        color: mcolor,
    };
    let scene = em.ctx.scene;
    if let Some(ev) = scene.patterns.material_eval(*funcs, &rv, &vars) {
        let ext = task.extinction;
        if let Some(c) = specular(&ev, 3) {
            // Straight through, bent by a texture (not for shadow rays).
            let mut tdir = dir;
            if hastexture {
                let d = dir - pert;
                if d.length() > 0.0 {
                    tdir = d;
                }
            }
            em.spawn(RayKind::Refraction, tdir, c, ext);
        }
        if let Some(c) = specular(&ev, 0) {
            em.spawn(RayKind::Reflection, dir + pnorm * (2.0 * pdot), c, ext);
        }
    }
    let mut base = Color::ZERO;
    if hasrefl {
        base += em.ambient(pnorm, rdiff, 0);
    }
    if hastrans {
        base += em.ambient(-pnorm, tdiff, 1);
    }
    if hasrefl || hastrans || *directional {
        let b = FuncBsdf {
            material: id,
            mcolor,
            pnorm,
            pdot,
            dir,
            normal: hit.normal,
            point: hit.point,
            t: hit.t,
            uv: em.uv,
            front: rod > 0.0,
            scale: 1.0,
        };
        em.direct(&Surface::Func(b), base * em.scale);
    }
    base
}

/// `m_brdf2()`: a ray that hit a `plasfunc`, `metfunc`, `transfunc`,
/// `plasdata`, `metdata` or `transdata` surface (back faces are turned
/// towards the ray, Radiance's `-bv` default).
pub(super) fn shade_brdf_func(
    em: &mut Emitter,
    id: MaterialId,
    m: &Material,
    ap: &Applied,
) -> Color {
    let Material::BrdfFunc { color, .. } = m else {
        return Color::ZERO;
    };
    let task = em.task;
    let hit = em.hit;
    let dir = task.ray.dir;
    // flipsurface(): the functions see the turned surface too.
    let Facing {
        ron: normal,
        pnorm,
        pdot,
        ..
    } = Facing::of(hit.normal, dir, ap);
    let mcolor = *color * ap.color;
    let Some(p) = Params::of(m, mcolor, true) else {
        return Color::ZERO;
    };
    let mut base = Color::ZERO;
    if p.trans < 1.0 - FTINY {
        base += em.ambient(pnorm, mcolor * (1.0 - p.trans), 0);
    }
    if p.trans > FTINY {
        base += em.ambient(-pnorm, mcolor * p.trans, 1);
    }
    let b = FuncBsdf {
        material: id,
        mcolor,
        pnorm,
        pdot,
        dir,
        normal,
        point: hit.point,
        t: hit.t,
        uv: em.uv,
        front: true,
        scale: 1.0,
    };
    em.direct(&Surface::Func(b), base * em.scale);
    base
}

/// How a shadow ray fares at a `BRTDfunc` surface of material `id` it
/// hits at `hit` going in `dir`: it passes with the transmission
/// expressions' value (`m_brdf` traces the transmitted ray for shadow
/// rays too); `None` if they cannot be computed or `id` is not one.
pub fn shadow_filter(scene: &Scene, id: MaterialId, hit: &Hit, dir: Vec3) -> Option<Color> {
    let Material::Brtd { funcs, .. } = scene.material(id) else {
        return None;
    };
    let rv = RayVars {
        dir,
        normal: hit.normal,
        point: hit.point,
        t: hit.t,
        ts: hit.t,
        uv: [0.0; 2],
    };
    let mut ap = Applied::NONE;
    let mods = scene.mods(id);
    if !mods.is_empty() {
        scene.patterns.apply(mods, &rv, &mut ap);
    }
    let rod = -dir.dot(hit.normal);
    let (mut pnorm, mut pdot) = if ap.perturbs() {
        perturbed_normal(hit.normal, rod, dir, ap.pert)
    } else {
        (hit.normal, rod)
    };
    if rod < 0.0 {
        pnorm = -pnorm;
        pdot = -pdot;
    }
    let vars = MaterialVars {
        pnorm,
        pdot,
        color: ap.color,
    };
    let ev = scene.patterns.material_eval(*funcs, &rv, &vars)?;
    specular(&ev, 3)
}

#[cfg(test)]
#[path = "brdf_tests.rs"]
mod tests;
