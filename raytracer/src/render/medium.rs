//! Participating media, after Radiance's `m_mist.c`, `rayparticipate()`
//! (raytrace.c) and `srcscatter()` (source.c).
//!
//! A ray travels through a medium with an extinction coefficient per unit
//! length (`RayTask::extinction`, Radiance's `r->cext`), a scattering
//! albedo and a Henyey-Greenstein eccentricity ([`Medium`], Radiance's
//! `r->albedo` and `r->gecc`). The global medium (`-me`, `-ma`, `-mg`)
//! is where primary rays start. A `mist` surface is an invisible boundary:
//! a ray entering it (hitting its front) adds the mist's extinction, takes
//! its albedo and eccentricity, and adds the mist's light sources to the
//! ones it scatters; leaving undoes that.
//!
//! Over each segment of length `t` the ray's value is multiplied by
//! `exp(-t * ext)`, then gains `albedo * -av * (1 - exp(-t * ext))` (the
//! ambient in-scattering) and the in-scattering of the listed sources,
//! sampled at `max(1, t / -ms)` (at most [`MAX_SCATTER_SAMPLES`]) points
//! along the segment. Each in-scattering sample is a shadow bundle
//! ([`Request::Scatter`](super::shading::Request::Scatter)) with a [`ScatterSurface`] that weighs the light
//! by the phase function, so the parallel renderers run it like any
//! other shadow bundle. Shadow rays in a medium lose `exp(-t * ext * (1 -
//! albedo))` (Radiance counts scattered light as not lost for sources).
//!
//! Differences from Radiance: the scattering sources a ray carries are a
//! set of mists (up to [`MAX_SCATTER_MISTS`]) rather than a list of
//! sources, so two mists naming the same source (which Radiance's
//! documentation rules out) keep it until the ray leaves both.

use serde::{Deserialize, Serialize};

use super::light::PreparedLight;
pub use super::task::Medium;

use super::options::RenderOptions;
use super::task::{intens, RayTask};
use crate::geometry::Vec3;
use crate::geometry::FTINY;
use crate::scene::{Color, Material, MaterialId, Scene};

/// Radiance's `FHUGE`: the length of a ray that hits nothing.
pub const FHUGE: f64 = 1e10;
/// Radiance's `MAXSSAMP`: most in-scattering samples per segment and source.
pub const MAX_SCATTER_SAMPLES: usize = 16;
/// Most mists with light sources a scene may have (a ray carries the set of
/// those it is inside as bits).
pub const MAX_SCATTER_MISTS: usize = 64;
pub use crate::scene::MAX_MIST_SOURCES;

/// What the render knows of its media: the mists that name light sources
/// and those sources as prepared lights.
#[derive(Debug, Clone, Default)]
pub struct Media {
    /// Per material: its slot if it is a mist with sources.
    slot: Vec<Option<u8>>,
    /// Per slot: indices into the prepared lights, in Radiance's order.
    sources: Vec<Vec<u32>>,
    /// Some mist exists or the global medium is not empty: rays may
    /// participate.
    pub active: bool,
}

impl Media {
    /// Resolves every mist's source names to prepared lights (the last
    /// light whose object has the name, as Radiance's `m_mist()`), with a
    /// warning for each name that matches none.
    pub fn new(
        scene: &Scene,
        options: &RenderOptions,
        lights: &[PreparedLight],
    ) -> (Self, Vec<String>) {
        let mut media = Media {
            active: intens(options.me) > 1.0 / FHUGE,
            ..Media::default()
        };
        let mut warnings = Vec::new();
        for (id, m) in scene.materials.iter().enumerate() {
            let Material::Mist { sources, .. } = m else {
                continue;
            };
            media.active = true;
            let name = scene
                .material_names
                .get(id)
                .map_or("?", |s| s.as_str())
                .to_string();
            let mut list: Vec<u32> = Vec::new();
            for s in sources {
                let found = lights
                    .iter()
                    .enumerate()
                    .rev()
                    .find(|(_, l)| names_source(scene, l, s));
                match found {
                    None => warnings.push(format!(
                        "mist '{name}': unknown source \"{s}\" (not a sampled light source); ignored"
                    )),
                    Some((i, _)) if list.contains(&(i as u32)) => warnings.push(format!(
                        "mist '{name}': duplicate source \"{s}\"; ignored"
                    )),
                    Some((i, _)) => list.push(i as u32),
                }
            }
            if list.is_empty() {
                continue;
            }
            if media.sources.len() >= MAX_SCATTER_MISTS {
                warnings.push(format!(
                    "mist '{name}': more than {MAX_SCATTER_MISTS} mists name light sources; its sources do not scatter"
                ));
                continue;
            }
            if media.slot.is_empty() {
                media.slot = vec![None; scene.materials.len()];
            }
            media.slot[id] = Some(media.sources.len() as u8);
            media.sources.push(list);
        }
        (media, warnings)
    }

    /// The scattering slot of mist material `id`, if it names sources.
    pub fn slot(&self, id: MaterialId) -> Option<u8> {
        self.slot.get(id as usize).copied().flatten()
    }

    /// The prepared lights the mists in `scatter` name, each once, in slot
    /// order.
    pub(super) fn lights_of(&self, scatter: u64, out: &mut Vec<u32>) {
        out.clear();
        for (k, list) in self.sources.iter().enumerate() {
            if scatter & (1u64 << k) != 0 {
                for &l in list {
                    if !out.contains(&l) {
                        out.push(l);
                    }
                }
            }
        }
    }
}

/// Radiance's `srcmatch()`: whether `id` names the light `l`: a real
/// source by its surface's (or distant `source`'s) name, a virtual one by
/// its relays' names and the real source's, joined by `>` in the order a
/// shadow ray meets them (`mirror2>mirror1>lamp`).
fn names_source(scene: &Scene, l: &PreparedLight, id: &str) -> bool {
    let mut parts = id.split('>');
    if let Some(v) = &l.virt {
        for r in &v.relays {
            let Some(name) = parts.next() else {
                return false;
            };
            if scene.object(r.object).is_none_or(|o| o.name != name) {
                return false;
            }
        }
        return parts.next() == v.real.name(scene) && parts.next().is_none();
    }
    parts.next() == l.name(scene) && parts.next().is_none()
}

/// A primary ray starts in the global medium (`-me`, `-ma`, `-mg`).
pub fn start_in_global(mut task: RayTask, options: &RenderOptions) -> RayTask {
    task.extinction = options.me;
    task.medium = Medium {
        albedo: options.ma,
        gecc: options.mg,
        scatter: 0,
    };
    task
}

/// A mist's parameters (Radiance's `MAT_MIST` arguments).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mist {
    /// Extinction added inside (after the material's patterns).
    pub extinction: Color,
    /// Albedo and eccentricity inside, where given.
    pub albedo: Option<Color>,
    pub gecc: Option<f64>,
    /// Its scattering slot, if it names sources.
    pub slot: Option<u8>,
}

/// The media on both sides of a crossing: what `m_mist()` does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// The medium of the ray beyond the boundary.
    pub extinction: Color,
    pub medium: Medium,
    /// The medium of the segment that reached the boundary, where the
    /// crossing corrects it: a ray leaving a mist with sources that it was
    /// not known to be inside (it started there).
    pub before: Option<(Color, Medium)>,
}

/// `m_mist()`: a ray in medium (`ext`, `med`) meets the boundary of
/// `mist`, entering it (hitting its front) or leaving.
pub fn cross_mist(
    options: &RenderOptions,
    mist: &Mist,
    entering: bool,
    ext: Color,
    med: Medium,
) -> Crossing {
    let bit = mist.slot.map_or(0, |k| 1u64 << k);
    let inside = |ext: Color, med: Medium| {
        (
            ext + mist.extinction,
            Medium {
                albedo: mist.albedo.unwrap_or(med.albedo),
                gecc: mist.gecc.unwrap_or(med.gecc),
                scatter: med.scatter | bit,
            },
        )
    };
    if entering {
        let (extinction, medium) = inside(ext, med);
        return Crossing {
            extinction,
            medium,
            before: None,
        };
    }
    // Leaving: a ray that did not know it was inside is fixed first.
    let before = (bit != 0 && med.scatter & bit == 0).then(|| inside(ext, med));
    let (ext, med) = before.unwrap_or((ext, med));
    let d = ext - mist.extinction;
    Crossing {
        extinction: d.max(options.me),
        medium: Medium {
            albedo: if mist.albedo.is_some() {
                options.ma
            } else {
                med.albedo
            },
            gecc: if mist.gecc.is_some() {
                options.mg
            } else {
                med.gecc
            },
            scatter: med.scatter & !bit,
        },
        before,
    }
}

/// Radiance's extinction factor for optical depth `re` (per channel):
/// 1 at or below FTINY, 0 above 92.
#[inline]
pub(super) fn extinction_factor(re: Color) -> Color {
    let f = |x: f64| {
        if x <= FTINY {
            1.0
        } else if x > 92.0 {
            0.0
        } else {
            (-x).exp()
        }
    };
    Color::new(f(re.x), f(re.y), f(re.z))
}

/// `rayparticipate()` for a segment of length `t` (infinite for a ray that
/// hit nothing) in medium (`ext`, `med`): the factor the segment's value is
/// multiplied by, and the ambient in-scattering then added; `None` where
/// there is no medium.
pub fn participate(
    options: &RenderOptions,
    ext: Color,
    med: &Medium,
    t: f64,
) -> Option<(Color, Color)> {
    if intens(ext) <= 1.0 / FHUGE {
        return None;
    }
    let ce = extinction_factor(ext * t.min(FHUGE));
    let add = if intens(med.albedo) > FTINY {
        med.albedo * options.av * (Color::ONE - ce)
    } else {
        Color::ZERO
    };
    Some((ce, add))
}

/// The transmission of a shadow ray over `len` in medium (`ext`, `albedo`):
/// only the absorbed part is lost (Radiance's rule for source rays).
#[inline]
pub fn shadow_attenuation(ext: Color, albedo: Color, len: f64) -> Color {
    if intens(ext) <= 1.0 / FHUGE {
        return Color::ONE;
    }
    extinction_factor(ext * (Color::ONE - albedo) * len.min(FHUGE))
}

/// How an in-scattering sample weighs light arriving from a direction:
/// the phase function times the sample's share of the segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScatterSurface {
    /// Direction of the ray whose segment scatters.
    pub rdir: Vec3,
    /// Henyey-Greenstein eccentricity.
    pub gecc: f64,
    /// `ext * albedo * t / (4 pi n) * exp(-ext * t_j)`: everything but the
    /// phase function and the solid angle.
    pub factor: Color,
}

impl ScatterSurface {
    /// `srcscatter()`'s weight for light from unit direction `ldir` within
    /// solid angle `omega`.
    #[inline]
    pub fn coefficient(&self, ldir: Vec3, omega: f64) -> Color {
        self.factor * (hg_phase(self.gecc, self.rdir.dot(ldir)) * omega)
    }
}

/// Radiance's Henyey-Greenstein phase function times 4 pi, for the cosine
/// `cos` between the ray's direction and the direction to the light.
#[inline]
pub fn hg_phase(g: f64, cos: f64) -> f64 {
    if g <= FTINY {
        return 1.0;
    }
    let d = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (d * d.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> RenderOptions {
        RenderOptions::default()
    }

    #[test]
    fn beer_lambert_transmittance() {
        let ext = Color::new(0.1, 0.5, 2.0);
        for t in [0.0, 0.3, 1.0, 7.5] {
            let (f, add) = participate(&opts(), ext, &Medium::default(), t).unwrap();
            for k in 0..3 {
                let want = if ext[k] * t <= FTINY {
                    1.0
                } else {
                    (-ext[k] * t).exp()
                };
                assert!(
                    (f[k] - want).abs() < 1e-15,
                    "t {t} channel {k}: {} vs {want}",
                    f[k]
                );
            }
            assert_eq!(add, Color::ZERO, "no albedo, no in-scattering");
        }
        // Optical depth beyond 92 and rays to infinity are black.
        let (f, _) = participate(&opts(), ext, &Medium::default(), f64::INFINITY).unwrap();
        assert_eq!(f, Color::ZERO);
        // A zero channel next to an infinite length is 1, not NaN.
        let (f, _) = participate(
            &opts(),
            Color::new(0.0, 1.0, 1.0),
            &Medium::default(),
            f64::INFINITY,
        )
        .unwrap();
        assert_eq!(f, Color::new(1.0, 0.0, 0.0));
        assert!(participate(&opts(), Color::ZERO, &Medium::default(), 5.0).is_none());
        // Shadow rays lose only the absorbed part.
        let s = shadow_attenuation(Color::splat(0.4), Color::splat(0.75), 2.0);
        assert!((s.x - (-0.4f64 * 0.25 * 2.0).exp()).abs() < 1e-15);
    }

    #[test]
    fn ambient_in_scattering_conserves_energy() {
        // A segment seeing a surface of radiance L in a medium lit by a
        // uniform ambient L: with albedo 1 the result is exactly L (a
        // furnace), with albedo below 1 it is less, never more.
        let l = 0.7;
        let o = RenderOptions {
            av: Color::splat(l),
            ..opts()
        };
        let ext = Color::new(0.05, 0.8, 3.0);
        for albedo in [1.0, 0.9, 0.3, 0.0] {
            let med = Medium {
                albedo: Color::splat(albedo),
                gecc: 0.3,
                scatter: 0,
            };
            for t in [0.01, 1.0, 10.0, 1e3, f64::INFINITY] {
                let (f, add) = participate(&o, ext, &med, t).unwrap();
                let v = Color::splat(if t.is_finite() { l } else { 0.0 }) * f + add;
                for k in 0..3 {
                    assert!(v[k] <= l * (1.0 + 1e-12), "albedo {albedo} t {t}: {v}");
                    if albedo == 1.0 {
                        assert!((v[k] - l).abs() < 1e-12, "furnace broken: {v}");
                    }
                }
            }
        }
    }

    #[test]
    fn phase_function_is_normalised() {
        // (1/4pi) * integral of hg over the sphere = 1 (midpoint rule in cos).
        for g in [0.0f64, 0.3, 0.8, -0.5] {
            let n = 200_000;
            let mut sum = 0.0;
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                sum += hg_phase(g.max(0.0), c) * 2.0 / n as f64;
            }
            // integral over phi gives 2 pi; times 1/(4 pi) -> sum/2.
            assert!((sum / 2.0 - 1.0).abs() < 1e-4, "g {g}: {}", sum / 2.0);
        }
        assert!(
            hg_phase(0.5, 1.0) > hg_phase(0.5, -1.0),
            "forward scattering"
        );
    }

    #[test]
    fn crossing_mists() {
        let o = RenderOptions {
            me: Color::splat(0.01),
            ma: Color::splat(0.2),
            mg: 0.1,
            ..opts()
        };
        let box_mist = Mist {
            extinction: Color::new(0.1, 0.1, 0.4),
            albedo: Some(Color::splat(0.9)),
            gecc: Some(0.3),
            slot: None,
        };
        let start = Medium {
            albedo: o.ma,
            gecc: o.mg,
            scatter: 0,
        };
        let inside = cross_mist(&o, &box_mist, true, o.me, start);
        assert_eq!(inside.extinction, o.me + box_mist.extinction);
        assert_eq!(inside.medium.albedo, Color::splat(0.9));
        assert_eq!(inside.medium.gecc, 0.3);
        assert!(inside.before.is_none());
        let out = cross_mist(&o, &box_mist, false, inside.extinction, inside.medium);
        assert!((out.extinction - o.me).abs().max_element() < 1e-15);
        assert_eq!(out.medium, start);
        // Leaving a sourceless mist one never entered: never below -me.
        let out = cross_mist(&o, &box_mist, false, o.me, start);
        assert_eq!(out.extinction, o.me);
        // A cone naming a source: entering adds its slot, leaving removes it.
        let cone = Mist {
            extinction: Color::ZERO,
            albedo: None,
            gecc: None,
            slot: Some(3),
        };
        let c = cross_mist(&o, &cone, true, inside.extinction, inside.medium);
        assert_eq!(c.medium.scatter, 1 << 3);
        assert_eq!(c.medium.albedo, inside.medium.albedo);
        let l = cross_mist(&o, &cone, false, c.extinction, c.medium);
        assert_eq!(l.medium.scatter, 0);
        assert!(l.before.is_none());
        // Leaving it without having entered (the ray started inside): the
        // segment before the boundary is fixed to scatter.
        let l = cross_mist(&o, &cone, false, inside.extinction, inside.medium);
        assert_eq!(l.before.unwrap().1.scatter, 1 << 3);
        assert_eq!(l.medium.scatter, 0);
    }
}
