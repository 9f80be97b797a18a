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

use super::aniso::sample_count;
pub use super::surface::ashik_flag as flag;
pub use super::surface::{schlick_fres, AshikBsdf, AshikParams};

use super::rng::{child_seed, Rng};
use super::shading::{ray_vars, Emitter, Facing, MAXITER};
use super::surface::Surface;
use super::task::{intens, RayKind};
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::modifier::{Applied, ModifierId};
use crate::scene::Color;

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
