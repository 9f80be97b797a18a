//! Virtual light sources (Radiance's `virtuals.c`, `m_mirror.c`'s
//! `mir_proj` and `m_direct.c`'s `dir_proj`): a planar mirror or prism
//! relays every light source in front of it, so direct lighting also
//! arrives by way of the mirror or through the prism.
//!
//! For each source and each planar relay (a top-level polygon or ring made
//! of `mirror`, `prism1` or `prism2`, or of an `illum` whose alternate is
//! one) the source's image becomes one more light, and so on up to `-dr`
//! relays, mirrors and prisms mixed. A mirror's image is the source
//! reflected; a prism's, for each projection of its functions that carries
//! light from the source's centre on through the prism's centre, is
//! Radiance's projection: the affine map that keeps the prism's plane in
//! place and turns the old direction into the new one (a shear, plus a
//! reflection where the functions send light back to the source's side).
//! A virtual source is sampled by sampling the real source from the point
//! the relays map the shaded point to and mapping the samples back; a
//! mirror keeps distances and solid angles, and through a prism a sample's
//! solid angle is its patch's seen at the image's distance, as Radiance's
//! `makevsrc()` keeps the source's area. A virtual source's shadow rays
//! must meet the relays in order, each mirror reflecting the ray and
//! scaling it by its colour and each prism redirecting it by its functions
//! and scaling it by their coefficient, before they reach the real source
//! (see [`crate::render::direct`]).
//!
//! As Radiance, a mirror relays a source only if its front faces the
//! source's centre, a relay never relays its own image, and a relay of a
//! relay needs the second surface to be at least partly on the far side of
//! the first one from the image (`getdisk`). Radiance also bounds each
//! virtual source by a spot cone around the relay (`makevsrc()`) and
//! pretests its visibility (`-dp`); both only skip shadow rays that cannot
//! reach the source: here the shadow ray's test that it meets each relay
//! in turn is exact, and a test shows a relayed spotlight lighting exactly
//! the reflected cone. Patterns on the mirror colour the relayed light
//! (evaluated where the shadow ray meets it).

pub use super::light::{Redirect, Relay, Virtual};

use super::light::{prepare_lights, LightExtent, PreparedLight};
use crate::geometry::{Aabb, Shape, Vec3};
use crate::modifier::ModifierId;
use crate::scene::{Color, Material, ObjectId, Scene};

/// Radiance's `FTINY`.
const FTINY: f64 = 1e-6;

/// Most virtual sources made for one scene (Radiance has no limit; a mirror
/// made of thousands of polygons times many sources would otherwise
/// explode the light list).
pub const MAX_VIRTUAL_SOURCES: usize = 4096;

/// What a relay surface does with a source.
#[derive(Debug, Clone, Copy)]
enum RelayKind {
    /// A mirror of this reflectance.
    Mirror(Color),
    /// A prism: its redirecting functions.
    Prism {
        modifier: ModifierId,
        projections: u8,
    },
}

/// A planar mirror or prism that can relay sources.
#[derive(Debug, Clone, Copy)]
struct RelaySurface {
    object: ObjectId,
    kind: RelayKind,
    /// Unit normal of its plane (a mirror's front), `normal . x = offset`
    /// on it.
    normal: Vec3,
    offset: f64,
    /// Centre and squared radius of a disk holding it (`getmaxdisk`).
    center: Vec3,
    radius2: f64,
}

/// Where a (real or virtual) source is, for the relay tests.
#[derive(Debug, Clone, Copy)]
enum Location {
    /// Centre of a local source.
    Point(Vec3),
    /// Direction towards a distant source.
    Direction(Vec3),
}

impl Location {
    /// The image of this location through `r`.
    fn image(self, r: &Relay) -> Self {
        match self {
            Location::Point(p) => Location::Point(r.image_point(p)),
            Location::Direction(d) => Location::Direction(r.image_dir(d)),
        }
    }

    /// Signed distance to the plane of `r` (distant: cosine with its normal).
    fn side(self, r: &Relay) -> f64 {
        match self {
            Location::Point(p) => r.normal.dot(p) - r.offset,
            Location::Direction(d) => r.normal.dot(d),
        }
    }
}

/// A polygon's or ring's unit normal, plane offset, disk centre and
/// squared disk radius; `None` for other shapes and degenerate ones.
fn plane_of(shape: &Shape) -> Option<(Vec3, f64, Vec3, f64)> {
    let (normal, point, center, radius2) = match shape {
        Shape::Polygon(p) => {
            let c =
                p.vertices.iter().fold(Vec3::ZERO, |a, v| a + *v) / p.vertices.len().max(1) as f64;
            let r2 = p
                .vertices
                .iter()
                .map(|v| (*v - c).length_squared())
                .fold(0.0, f64::max);
            (p.normal, *p.vertices.first()?, c, r2)
        }
        Shape::Ring {
            center,
            normal,
            r_outer,
            ..
        } => (*normal, *center, *center, r_outer * r_outer),
        _ => return None,
    };
    let len = normal.length();
    if !(len > 0.0 && len.is_finite()) || radius2 <= FTINY {
        return None;
    }
    let n = normal / len;
    Some((n, n.dot(point), center, radius2))
}

/// The planar mirrors and prisms among the scene's top-level objects, in
/// object order; others made of them are reported (Radiance: "secondary
/// sources not supported").
fn relay_surfaces(scene: &Scene, warnings: &mut Vec<String>) -> Vec<RelaySurface> {
    let mut out = Vec::new();
    let mut curved = 0usize;
    let mut first_curved = None;
    for (i, o) in scene.table().iter() {
        // vsmaterial(): an illum's alternate decides.
        let mut m = scene.material(o.material);
        if let Material::Illum {
            alternate: Some(a), ..
        } = m
        {
            m = scene.material(*a);
        }
        if !matches!(m, Material::Mirror { .. } | Material::Prism { .. })
            || matches!(o.shape, Shape::Instance(_))
        {
            continue;
        }
        let Some((normal, offset, center, radius2)) = plane_of(&o.shape) else {
            if !matches!(o.shape, Shape::Polygon(_) | Shape::Ring { .. }) {
                curved += 1;
                let kind = if matches!(m, Material::Mirror { .. }) {
                    "mirror"
                } else {
                    "prism"
                };
                first_curved.get_or_insert((kind, o.name.clone()));
            }
            continue;
        };
        let kind = match m {
            Material::Mirror { color, .. } => RelayKind::Mirror(*color),
            Material::Prism {
                modifier,
                projections,
            } => RelayKind::Prism {
                modifier: *modifier,
                projections: *projections,
            },
            _ => continue,
        };
        out.push(RelaySurface {
            object: i,
            kind,
            normal,
            offset,
            center,
            radius2,
        });
    }
    if let Some((kind, name)) = first_curved {
        warnings.push(format!(
            "{kind} surface {name:?}{}: not planar, so it relays no light sources (secondary sources not supported)",
            if curved > 1 {
                format!(" and {} more", curved - 1)
            } else {
                String::new()
            }
        ));
    }
    out
}

/// [`prepare_lights`] plus the virtual sources planar mirrors and prisms
/// make of them, up to `relays` relays (`-dr`; see the module doc).
pub fn prepare_lights_relayed(scene: &Scene, relays: u32) -> (Vec<PreparedLight>, Vec<String>) {
    let (mut lights, mut warnings) = prepare_lights(scene);
    add_virtual_lights(scene, &mut lights, relays, &mut warnings);
    (lights, warnings)
}

/// Appends the virtual sources of `lights` (real sources only) through the
/// scene's planar mirrors and prisms, up to `depth` relays (`-dr`), in a
/// fixed order: per real source, per relay surface in object order, per
/// projection, depth first.
pub fn add_virtual_lights(
    scene: &Scene,
    lights: &mut Vec<PreparedLight>,
    depth: u32,
    warnings: &mut Vec<String>,
) {
    if depth == 0 {
        return;
    }
    let surfaces = relay_surfaces(scene, warnings);
    if surfaces.is_empty() {
        return;
    }
    let reals = lights.len();
    let mut capped = false;
    for i in 0..reals {
        let real = lights[i].clone();
        let Some(loc) = location(&real) else {
            continue;
        };
        let mut chain = Vec::new();
        let mut p = Projector {
            scene,
            real: &real,
            surfaces: &surfaces,
            out: lights,
            capped: &mut capped,
        };
        p.project(loc, real.object, &mut chain, depth);
    }
    if capped {
        warnings.push(format!(
            "more than {MAX_VIRTUAL_SOURCES} virtual light sources (mirror and prism relays); the rest are left out"
        ));
    }
}

fn location(l: &PreparedLight) -> Option<Location> {
    match l.extent()? {
        LightExtent::Finite(b) => Some(Location::Point(b.center())),
        LightExtent::Distant { dir, .. } => Some(Location::Direction(dir)),
    }
}

/// The relays of one real source (`vproject()` / `makevsrc()`).
struct Projector<'a> {
    scene: &'a Scene,
    real: &'a PreparedLight,
    surfaces: &'a [RelaySurface],
    out: &'a mut Vec<PreparedLight>,
    capped: &'a mut bool,
}

impl Projector<'_> {
    /// The relays of the source at `loc` (its image so far through
    /// `chain`, last relay `so`), up to `depth` more.
    fn project(&mut self, loc: Location, so: Option<ObjectId>, chain: &mut Vec<Relay>, depth: u32) {
        if depth == 0 {
            return;
        }
        let mut relays = Vec::new();
        for m in self.surfaces {
            if Some(m.object) == so {
                continue; // objects cannot project themselves
            }
            // getdisk(): relaying an image, the new surface must reach the
            // far side of the previous relay's plane.
            if let Some(prev) = chain.first() {
                let rd = loc.side(prev);
                let d = prev.normal.dot(m.center) - prev.offset;
                if (d > 0.0) == (rd > 0.0) {
                    if d * d >= m.radius2 {
                        continue;
                    }
                    let c = prev.normal.dot(m.normal);
                    if d * d >= m.radius2 * (1.0 - c * c) {
                        continue;
                    }
                }
            }
            relays.clear();
            m.projections(self.scene, loc, &mut relays);
            for r in &relays {
                if self.out.len() >= MAX_VIRTUAL_SOURCES {
                    *self.capped = true;
                    return;
                }
                chain.insert(0, *r);
                let virt = Virtual {
                    relays: chain.clone(),
                    real: Box::new(self.real.clone()),
                };
                let extent = image_extent(self.real.extent(), chain);
                self.out.push(self.real.relayed(virt, extent));
                self.project(loc.image(r), Some(r.object), chain, depth - 1);
                chain.remove(0);
            }
        }
    }
}

impl RelaySurface {
    /// The relays of a source at `loc` through this surface: a mirror's if
    /// its front faces the source (`mir_proj()`); a prism's for each
    /// projection whose functions, for light from the source's centre
    /// through the prism's centre, give a significant coefficient and a
    /// direction not along the plane (`dir_proj()`).
    fn projections(&self, scene: &Scene, loc: Location, out: &mut Vec<Relay>) {
        let (nv, od) = (self.normal, self.offset);
        let (modifier, projections) = match self.kind {
            RelayKind::Mirror(color) => {
                let r = Relay {
                    object: self.object,
                    normal: nv,
                    offset: od,
                    color,
                    redirect: None,
                };
                if loc.side(&r) > FTINY {
                    out.push(r);
                }
                return;
            }
            RelayKind::Prism {
                modifier,
                projections,
            } => (modifier, projections),
        };
        // The direction light travels from the source to the prism.
        let olddir = match loc {
            Location::Direction(d) => -d,
            Location::Point(p) => {
                let d = self.center - p;
                let len = d.length();
                if !(len > 0.0 && len.is_finite()) {
                    return; // at the source
                }
                d / len
            }
        };
        let olddot = olddir.dot(nv);
        if olddot.abs() <= FTINY {
            return; // parallel to the plane
        }
        let vars = crate::modifier::RayVars {
            dir: olddir,
            normal: nv,
            point: self.center,
            t: 1.0,
            ts: 1.0,
            uv: [0.0; 2],
        };
        for k in 0..projections {
            let Some((coef, newdir)) = scene.patterns.redirect(modifier, k as usize, &vars) else {
                continue;
            };
            let newdot = newdir.dot(nv);
            if coef <= FTINY || newdot.abs() <= FTINY {
                continue;
            }
            // Light sent back to the source's side: the image is the
            // reflection (in the plane) of the image through the reflected
            // new direction. Radiance's dir_proj() shears towards the new
            // direction itself and then reflects, which puts the image of
            // a source off the prism's normal on the wrong side of it (a
            // prism whose functions mirror would then relay nothing there);
            // for light sent on through the prism both agree.
            let mirrored = (newdot > 0.0) != (olddot > 0.0);
            let shear = if mirrored {
                let reflected = newdir - nv * (2.0 * newdot);
                reflected / -newdot - olddir / olddot - nv * 2.0
            } else {
                newdir / newdot - olddir / olddot
            };
            // Points the redirected light reaches lie on this side.
            let side = newdot.signum();
            out.push(Relay {
                object: self.object,
                normal: nv * side,
                offset: od * side,
                color: Color::ONE,
                redirect: Some(Redirect {
                    modifier,
                    projection: k,
                    plane: nv,
                    offset: od,
                    shear,
                    mirrored,
                }),
            });
        }
    }
}

/// The extent of the image of a source through `chain` (the box around
/// the images of its box's corners: the relays are affine; the image of a
/// distant source's cone, its width kept).
fn image_extent(e: Option<LightExtent>, chain: &[Relay]) -> Option<LightExtent> {
    Some(match e? {
        LightExtent::Finite(b) => {
            let mut out = Aabb::EMPTY;
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                );
                let p = chain.iter().rev().fold(c, |p, r| r.image_point(p));
                out = out.union(Aabb { min: p, max: p });
            }
            LightExtent::Finite(out)
        }
        LightExtent::Distant { dir, cos_half } => LightExtent::Distant {
            dir: chain.iter().rev().fold(dir, |d, r| r.image_dir(d)),
            cos_half,
        },
    })
}
