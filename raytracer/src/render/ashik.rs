//! Radiance's Ashikhmin-Shirley material `ashik2` (`ashikhmin.c`): a
//! diffuse term and an anisotropic Phong-like specular lobe with
//! exponents along and across an orientation vector computed per ray
//! ([`crate::modifier::Patterns::direction`]), with Schlick's Fresnel
//! approximation.
//!
//! [`AshikBsdf`] is what a shadow bundle carries (Radiance's
//! `ASHIKDAT`); its [`AshikBsdf::coefficient`] is `dirashik()`.
//! `shade_ashik` is `m_ashikhmin()`.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::aniso::sample_count;
use super::material::{intens, ray_vars, Emitter, Facing, RayKind, Surface, MAXITER};
use super::rng::{child_seed, Rng};
use crate::geometry::robust::orthonormal_basis;
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::image::brightness;
use crate::modifier::{Applied, ModifierId};
use crate::scene::Color;

/// Specularity flags of `ashikhmin.c`.
pub mod flag {
    /// Reflected specular component.
    pub const REFL: u8 = 1;
    /// The surface is flat.
    pub const FLAT: u8 = 2;
    /// Reflection below the `-st` threshold (not sampled).
    pub const RBLT: u8 = 8;
}

/// Schlick's Fresnel factor `(1 - cos)^5`.
#[inline]
pub fn schlick_fres(dprod: f64) -> f64 {
    let pf = 1.0 - dprod;
    pf * pf * pf * pf * pf
}

/// The data `dirashik()` needs (Radiance's `ASHIKDAT`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AshikBsdf {
    /// Diffuse colour (times the pattern colour).
    pub mcolor: Color,
    /// Specular colour, raised by the Fresnel factor at the view angle.
    pub scolor: Color,
    /// Unit vectors in the surface plane: along and across the
    /// orientation vector.
    pub u: Vec3,
    pub v: Vec3,
    pub u_power: f64,
    pub v_power: f64,
    pub specfl: u8,
    /// Perturbed normal, turned towards the incoming ray.
    pub pnorm: Vec3,
    /// Cosine between `pnorm` and the reversed ray (at least 0.001).
    pub pdot: f64,
    /// Incoming ray direction.
    pub rdir: Vec3,
}

/// The material's parameters (the reals of `ashik2`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AshikParams {
    pub diffuse: Color,
    pub specular: Color,
    pub u_power: f64,
    pub v_power: f64,
}

impl AshikBsdf {
    /// `m_ashikhmin()`'s setup and `getacoords_as()`: `pnorm` and `pdot`
    /// are the (perturbed) normal facing the ray and its cosine, `up` the
    /// orientation vector in world space (zero when it could not be
    /// computed), `pcol` the pattern colour, `st` the `-st` threshold.
    /// The flag is true when the vector was unusable and Radiance's
    /// fallback was taken (an arbitrary orientation, the harmonic mean of
    /// the two powers).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        p: &AshikParams,
        dir: Vec3,
        pnorm: Vec3,
        pdot: f64,
        pcol: Color,
        flat: bool,
        up: Vec3,
        st: f64,
    ) -> (Self, bool) {
        let mut b = AshikBsdf {
            mcolor: p.diffuse * pcol,
            scolor: p.specular,
            u: Vec3::ZERO,
            v: Vec3::ZERO,
            u_power: p.u_power,
            v_power: p.v_power,
            specfl: 0,
            pnorm,
            pdot: pdot.max(0.001),
            rdir: dir,
        };
        if intens(b.scolor) > FTINY {
            b.specfl |= flag::REFL;
            if st >= brightness(b.scolor) - FTINY {
                b.specfl |= flag::RBLT;
            }
            let fres = schlick_fres(b.pdot);
            b.scolor += (Color::ONE - b.scolor) * fres;
        }
        if flat {
            b.specfl |= flag::FLAT;
        }
        let v = b.pnorm.cross(up);
        let len = v.length();
        let fallback = !(len > 0.0 && len.is_finite());
        if fallback {
            b.u = orthonormal_basis(b.pnorm).0;
            b.v = b.pnorm.cross(b.u);
            let m = 2.0 / (1.0 / (b.u_power + 1e-5) + 1.0 / (b.v_power + 1e-5));
            b.u_power = m;
            b.v_power = m;
        } else {
            b.v = v / len;
            b.u = b.v.cross(b.pnorm);
        }
        (b, fallback)
    }

    /// Radiance's `dirashik()`: the coefficient for light arriving from
    /// unit direction `ldir` within solid angle `omega`.
    pub fn coefficient(&self, ldir: Vec3, omega: f64) -> Color {
        let ldot = self.pnorm.dot(ldir);
        if ldot <= FTINY {
            return Color::ZERO; // wrong side
        }
        let mut cval = self.mcolor * (ldot * omega / PI * (1.0 - schlick_fres(ldot)));
        if self.specfl & flag::REFL == 0 {
            return cval;
        }
        let h = (ldir - self.rdir).normalize_or_zero();
        let hu = h.dot(self.u);
        let hv = h.dot(self.v);
        let e = hu * hu * self.u_power + hv * hv * self.v_power;
        let hn = self.pnorm.dot(h);
        let mut g = hn.powf(e / (1.0 - hn * hn));
        g *= ((self.u_power + 1.0) * (self.v_power + 1.0)).sqrt();
        g /= 8.0 * PI * ldir.dot(h) * ldot.max(self.pdot);
        if g > FTINY && g.is_finite() {
            cval += self.scolor * (g * ldot * omega);
        }
        cval
    }

    /// True if no light direction can contribute.
    pub fn is_black_to_lights(&self) -> bool {
        intens(self.mcolor) <= FTINY && self.specfl & flag::REFL == 0
    }
}

/// `m_ashikhmin()`: returns the constant ambient part; asks for sampled
/// rays, diffuse inter-reflection and direct light through `em`.
pub(crate) fn shade_ashik(
    em: &mut Emitter,
    p: &AshikParams,
    direction: ModifierId,
    flat: bool,
    ap: &Applied,
) -> Color {
    let ctx = em.ctx;
    let task = em.task;
    let dir = task.ray.dir;
    let Facing {
        ron, pnorm, pdot, ..
    } = Facing::of(em.hit.normal, dir, ap);
    let mut vars = ray_vars(task, em.hit, em.uv);
    vars.normal = ron;
    let patterns = &ctx.scene.patterns;
    let up = patterns
        .direction(direction, &vars, ap)
        .unwrap_or(Vec3::ZERO);
    let (b, fallback) = AshikBsdf::new(p, dir, pnorm, pdot, ap.color, flat, up, ctx.options.st);
    if fallback && (p.u_power - p.v_power).abs() > 0.1 {
        patterns.report_bad_direction(direction);
    }
    if b.specfl & (flag::REFL | flag::RBLT) == flag::REFL {
        ashiksamp(em, &b, ron);
    }
    let mut base = Color::ZERO;
    if intens(b.mcolor) > FTINY {
        let mut coef = b.mcolor;
        if b.specfl & flag::RBLT != 0 {
            coef += b.scolor;
        }
        base += em.ambient(b.pnorm, coef, 0);
    }
    em.direct(&Surface::Ashik(b), base * em.scale);
    base
}

/// `ashiksamp()`: sampled rays for the specular lobe.
fn ashiksamp(em: &mut Emitter, b: &AshikBsdf, ron: Vec3) {
    let n = sample_count(em, b.scolor);
    let share = 1.0 / n as f64;
    let ext = em.task.extinction;
    let dir = b.rdir;
    let mut rng = Rng::new(child_seed(em.task.seed, 0x6173_686b));
    let mut taken = 0;
    let mut trials = 0;
    while taken < n && trials < MAXITER * n {
        trials += 1;
        let phi = 2.0 * PI * rng.next_f64();
        let mut cosph = (b.v_power + 1.0).sqrt() * phi.cos();
        let mut sinph = (b.u_power + 1.0).sqrt() * phi.sin();
        let d = 1.0 / (cosph * cosph + sinph * sinph).sqrt();
        cosph *= d;
        sinph *= d;
        let costh = rng
            .next_f64()
            .powf(1.0 / (b.u_power * cosph * cosph + b.v_power * sinph * sinph + 1.0));
        if costh <= FTINY {
            continue;
        }
        let sinth = (1.0 - costh * costh).sqrt();
        let h = b.u * (cosph * sinth) + b.v * (sinph * sinth) + b.pnorm * costh;
        let rdir = dir - h * (2.0 * h.dot(dir));
        if rdir.dot(ron) <= FTINY {
            continue;
        }
        em.spawn_ray(RayKind::Reflection, rdir, b.scolor * share, ext, true);
        taken += 1;
    }
}
