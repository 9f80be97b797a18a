//! Radiance's `BSDF` and `aBSDF` materials (`m_bsdf.c`) for tabulated
//! Klems-basis BSDFs in LBNL's XML format (`bsdf.c`, `bsdf_m.c`).
//!
//! [`KlemsData`] is a loaded file: the angle basis and, for the visible
//! (photopic, Radiance's "Y") data, up to four matrices (front and back
//! reflection, front and back transmission) with their Lambertian
//! minimum taken out (`extract_diffuse()`). The material's shadow-bundle
//! data is [`KlemsSurface`] (an index into [`crate::scene::Scene::bsdfs`]
//! and the local frame); its [`KlemsSurface::coefficient`] is
//! `dir_bsdf()`. `shade_bsdf` is `m_bsdf()`: one sampled ray for each
//! of the non-diffuse reflection and transmission (`sample_sdf()`), the
//! diffuse parts with the ambient, the direct light.
//!
//! Conventions follow Radiance's BSDF library: in local coordinates `z`
//! is the (unturned) surface normal, `y` points along the material's up
//! vector; both directions of a query point away from the surface. The
//! XML's "Reflection Back" is Radiance's front reflection and "Reflection
//! Front" its back reflection (WINDOW's front faces the outside, `-z`).

pub use super::surface::KlemsSurface;

use super::rng::{child_seed, Rng};
use super::shading::{perturbed_normal, ray_vars, Emitter};
use super::surface::Surface;
use super::task::RayKind;
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::modifier::{Applied, ModifierId};
use crate::scene::Color;

pub use crate::scene::klems::{KlemsBasis, KlemsData, Matrix, Part};

/// The material's reals and orientation (`Material::Bsdf`).
pub(crate) struct BsdfParams {
    pub data: u32,
    pub rdiff_front: Color,
    pub rdiff_back: Color,
    pub tdiff: Color,
}

/// `m_bsdf()` for a zero-thickness `BSDF` or an `aBSDF`.
pub(crate) fn shade_bsdf(
    em: &mut Emitter,
    p: &BsdfParams,
    direction: ModifierId,
    ap: &Applied,
) -> Color {
    let ctx = em.ctx;
    let task = em.task;
    let Some(d) = ctx.scene.bsdfs.get(p.data as usize) else {
        return Color::ZERO;
    };
    let dir = task.ray.dir;
    let ron = em.hit.normal;
    let hitfront = -dir.dot(ron) > 0.0;
    let (fron, frod, fpert) = if hitfront {
        (ron, -dir.dot(ron), ap.pert)
    } else {
        (-ron, dir.dot(ron), -ap.pert)
    };
    // pnorm: turned towards the ray; znorm: the surface's own side.
    let pnorm = if ap.perturbs() {
        perturbed_normal(fron, frod, dir, fpert).0
    } else {
        fron
    };
    let znorm = if hitfront { pnorm } else { -pnorm };
    let side = |front: Color, back: Color| if hitfront { front } else { back };
    let (rl, tl) = if hitfront {
        (
            d.lamb(Part::ReflFront),
            d.lamb(Part::TransFront).max(d.lamb(Part::TransBack)),
        )
    } else {
        (
            d.lamb(Part::ReflBack),
            d.lamb(Part::TransBack).max(d.lamb(Part::TransFront)),
        )
    };
    let tl = if d.parts[Part::TransFront as usize].is_some()
        && d.parts[Part::TransBack as usize].is_some()
    {
        d.lamb(if hitfront {
            Part::TransFront
        } else {
            Part::TransBack
        })
    } else {
        tl
    };
    let rdiff = (Color::splat(rl) + side(p.rdiff_front, p.rdiff_back)) * ap.color;
    let tdiff = (Color::splat(tl) + p.tdiff) * ap.color;
    // Orientation: SDcompXform(z = normal, x = up × z, y = z × x).
    let mut vars = ray_vars(task, em.hit, em.uv);
    vars.normal = ron;
    let patterns = &ctx.scene.patterns;
    let up = patterns
        .direction(direction, &vars, ap)
        .unwrap_or(Vec3::ZERO);
    let x = up.cross(znorm);
    if !x.is_finite() || x.length_squared() <= 1e-20 {
        // "Illegal orientation vector": Radiance leaves the ray black.
        patterns.report_bad_direction(direction);
        return Color::ZERO;
    }
    let xloc = x.normalize();
    let yloc = znorm.cross(xloc);
    let s = KlemsSurface {
        data: p.data,
        pnorm,
        xloc,
        yloc,
        vray: Vec3::ZERO,
        rdiff,
        tdiff,
        pcol: ap.color,
        scale: 1.0,
    };
    let vray = s.local(-dir);
    let s = KlemsSurface { vray, ..s };
    let to_world = |v: Vec3| xloc * v.x + yloc * v.y + znorm * v.z;
    // sample_sdf(): one ray each for reflection and transmission above
    // -st; below it the non-diffuse part joins the diffuse (grey).
    let mut rng = Rng::new(child_seed(task.seed, 0x6273_6466));
    let ext = task.extinction;
    let mut unsampled = [Color::ZERO; 2];
    let refl = if hitfront {
        Part::ReflFront
    } else {
        Part::ReflBack
    };
    let tran = {
        let (a, b) = if hitfront {
            (Part::TransFront, Part::TransBack)
        } else {
            (Part::TransBack, Part::TransFront)
        };
        if d.parts[a as usize].is_some() {
            a
        } else {
            b
        }
    };
    for (k, part) in [refl, tran].into_iter().enumerate() {
        let Some(m) = &d.parts[part as usize] else {
            continue;
        };
        if m.max_hemi <= FTINY {
            continue;
        }
        let b = d.direct_hemi(part, vray);
        if b <= ctx.options.st + FTINY {
            if b > FTINY {
                unsampled[k] = if k == 1 {
                    ap.color * b
                } else {
                    Color::splat(b)
                };
            }
            continue;
        }
        let r = [rng.next_f64(), rng.next_f64(), rng.next_f64()];
        if let Some((v, total)) = d.sample(part, vray, r) {
            let coef = if k == 1 {
                ap.color * total
            } else {
                Color::splat(total)
            };
            let kind = if k == 1 {
                RayKind::Refraction
            } else {
                RayKind::Reflection
            };
            em.spawn_ray(kind, to_world(v).normalize(), coef, ext, true);
        }
    }
    let mut base = Color::ZERO;
    for (k, coef) in [rdiff + unsampled[0], tdiff + unsampled[1]]
        .into_iter()
        .enumerate()
    {
        if coef.max_element() <= FTINY {
            continue;
        }
        base += em.ambient(if k == 0 { pnorm } else { -pnorm }, coef, k as u32);
    }
    em.direct(&Surface::Klems(s), base * em.scale);
    base
}
