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

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::material::{perturbed_normal, ray_vars, Emitter, Facing, RayKind, Surface};
use crate::accel::Hit;
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::image::brightness;
use crate::modifier::{Applied, MaterialEval, MaterialFuncs, MaterialVars, RayVars};
use crate::scene::{BrdfFamily, Color, Material, MaterialId, Scene};

/// What a shadow bundle needs to weigh light from a direction on a
/// function-defined material (Radiance's `BRDFDAT`): the material, the
/// ray as its functions see it, and the oriented, perturbed normal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FuncBsdf {
    pub material: MaterialId,
    /// Material colour times the patterns' colour.
    pub mcolor: Color,
    /// Perturbed normal turned towards the incoming ray, and its cosine
    /// with the reversed ray.
    pub pnorm: Vec3,
    pub pdot: f64,
    /// The ray at the surface as the functions see it (its normal as
    /// the material presents it: turned for `m_brdf2`'s back side).
    pub dir: Vec3,
    pub normal: Vec3,
    pub point: Vec3,
    pub t: f64,
    pub uv: [f64; 2],
    /// `BRTDfunc`: the ray hit the front (the front's diffuse reflectance).
    pub front: bool,
    /// Share of the material in a mixture.
    pub scale: f64,
}

// Shadow bundles of other materials do not grow: the largest variant of
// `Surface` stays `normal.c`'s.
const _: () =
    assert!(std::mem::size_of::<FuncBsdf>() <= std::mem::size_of::<super::material::NormalBsdf>());

/// The reflectances of `BRDFDAT` as a material defines them.
struct Params {
    rdiff: Color,
    tdiff: Color,
    rspec: f64,
    trans: f64,
    tspec: f64,
    funcs: crate::modifier::ModifierId,
    /// The specular part is multiplied by the material colour on the
    /// reflected (metal) or transmitted (trans) side.
    colored_refl: bool,
    colored_trans: bool,
}

impl Params {
    /// `m_brdf`'s or `m_brdf2`'s set-up; `None` for other materials.
    fn of(m: &Material, mcolor: Color, front: bool) -> Option<Params> {
        match m {
            Material::Brtd {
                front: f,
                back,
                tdiff,
                funcs,
                ..
            } => Some(Params {
                rdiff: if front { *f } else { *back } * mcolor,
                tdiff: *tdiff * mcolor,
                // Radiance's dummy values: the functions decide.
                rspec: 1.0,
                trans: 0.5,
                tspec: 1.0,
                funcs: *funcs,
                colored_refl: false,
                colored_trans: false,
            }),
            Material::BrdfFunc {
                family,
                specularity,
                transmissivity,
                transmitted_specular,
                funcs,
                ..
            } => {
                let rspec = *specularity;
                let (trans, tspec) = if *family == BrdfFamily::Trans {
                    let trans = transmissivity * (1.0 - rspec);
                    (trans, trans * transmitted_specular)
                } else {
                    (0.0, 0.0)
                };
                Some(Params {
                    rdiff: mcolor * (1.0 - trans - rspec),
                    tdiff: mcolor * (trans - tspec),
                    rspec,
                    trans,
                    tspec,
                    funcs: *funcs,
                    colored_refl: *family == BrdfFamily::Metal,
                    colored_trans: *family == BrdfFamily::Trans,
                })
            }
            _ => None,
        }
    }
}

impl FuncBsdf {
    fn ray_vars(&self) -> RayVars {
        RayVars {
            dir: self.dir,
            normal: self.normal,
            point: self.point,
            t: self.t,
            ts: 0.0,
            uv: self.uv,
        }
    }

    fn vars(&self) -> MaterialVars {
        MaterialVars {
            pnorm: self.pnorm,
            pdot: self.pdot,
            color: self.mcolor,
        }
    }

    /// Radiance's `dirbrdf()`: the coefficient for light arriving from
    /// unit direction `ldir` within solid angle `omega`.
    pub fn coefficient(&self, scene: &Scene, ldir: Vec3, omega: f64) -> Color {
        self.unscaled(scene, ldir, omega) * self.scale
    }

    fn unscaled(&self, scene: &Scene, ldir: Vec3, omega: f64) -> Color {
        let Some(p) = Params::of(scene.material(self.material), self.mcolor, self.front) else {
            return Color::ZERO;
        };
        let ldot = self.pnorm.dot(ldir);
        if ldot.is_nan() || ldot.abs() <= FTINY {
            return Color::ZERO; // too close to grazing (or NaN)
        }
        if if ldot < 0.0 {
            p.trans <= FTINY
        } else {
            p.trans >= 1.0 - FTINY
        } {
            return Color::ZERO; // wrong side
        }
        let mut cval = if ldot > 0.0 {
            p.rdiff * (ldot * omega / PI)
        } else {
            p.tdiff * (-ldot * omega / PI)
        };
        if if ldot > 0.0 {
            p.rspec <= FTINY
        } else {
            p.tspec <= FTINY
        } {
            return cval; // diffuse only
        }
        let Some(ev) = scene
            .patterns
            .material_eval(p.funcs, &self.ray_vars(), &self.vars())
        else {
            return cval;
        };
        let Some((mut ctmp, dtmp)) = directional(&ev, ldir, omega) else {
            return cval; // a compute error (counted)
        };
        if dtmp.is_nan() || dtmp <= FTINY {
            return cval;
        }
        if ldot > 0.0 {
            if p.colored_refl {
                ctmp *= self.mcolor;
            }
            cval += ctmp * (ldot * omega * p.rspec);
        } else {
            if p.colored_trans {
                ctmp *= self.mcolor;
            }
            cval += ctmp * (-ldot * omega * p.tspec);
        }
        cval
    }
}

/// The directional function's value for light from `ldir` and its
/// brightness (the `BRTDfunc` colour's, or the grey value).
fn directional(ev: &MaterialEval, ldir: Vec3, omega: f64) -> Option<(Color, f64)> {
    let l = ev.dir(ldir);
    let args = [l.x, l.y, l.z, omega];
    match ev.funcs()? {
        MaterialFuncs::Brtd { directional, .. } => {
            let mut c = [0.0; 3];
            for k in 0..3 {
                c[k] = match directional[k] {
                    None => 0.0,
                    // Radiance copies a channel named like an earlier one.
                    Some(f) => match (0..k).find(|&j| directional[j] == Some(f)) {
                        Some(j) => c[j],
                        None => ev.call(f, &args)?,
                    },
                };
            }
            let c = Color::new(c[0], c[1], c[2]);
            Some((c, brightness(c)))
        }
        MaterialFuncs::Func(f) => {
            let v = ev.call(*f, &args)?;
            Some((Color::splat(v), v))
        }
        MaterialFuncs::Data { func, data, coords } => {
            let mut pt = [0.0; crate::modifier::MAX_DATA_DIMS];
            for (k, c) in coords.iter().enumerate().take(pt.len()) {
                pt[k] = ev.call(*c, &args)?;
            }
            let v = data.value(&pt[..coords.len().min(pt.len())]);
            let v = ev.call(*func, &[v, l.x, l.y, l.z, omega])?;
            Some((Color::splat(v), v))
        }
    }
}

/// The specular expressions of a `BRTDfunc` from `first` (0: reflection,
/// 3: transmission), or `None` after a compute error (counted).
fn specular(ev: &MaterialEval, first: usize) -> Option<Color> {
    let Some(MaterialFuncs::Brtd { specular, .. }) = ev.funcs() else {
        return None;
    };
    Some(Color::new(
        ev.expr(specular[first])?,
        ev.expr(specular[first + 1])?,
        ev.expr(specular[first + 2])?,
    ))
}

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
