//! Virtual light sources (Radiance's `virtuals.c` and `m_mirror.c`'s
//! `mir_proj`): a planar mirror relays every light source in front of it,
//! so direct lighting also arrives by way of the mirror.
//!
//! For each source and each planar mirror (a top-level polygon or ring
//! made of `mirror`) the source's mirror image becomes one more light,
//! and so on up to `-dr` reflections. A virtual source is sampled by
//! sampling the real source from the shaded point's mirror image and
//! reflecting the samples back (reflections keep distances and solid
//! angles). Its shadow rays must meet the mirrors in order, each one
//! reflecting the ray and scaling it by the mirror's colour, before they
//! reach the real source (see [`crate::render::direct`]).
//!
//! As Radiance, a source is relayed only by a mirror whose front faces the
//! source's centre, a mirror never relays its own image, and a relay of a
//! relay needs the second mirror to be at least partly on the far side of
//! the first one from the image (`getdisk`). Not done: Radiance's
//! visibility pretest (`-dp`), which drops relays it finds completely
//! obstructed (an optimisation: an obstructed relay contributes nothing
//! here either), and its spot cones that bound a relay's reach (the shadow
//! ray's mirror test bounds it exactly). Patterns on the mirror colour
//! the relayed light (evaluated where the shadow ray meets it).
//!
//! `prism1`/`prism2` surfaces (`m_direct.c`) relay distant sources: each
//! projection of their functions that sends the source's central direction
//! on through the surface makes one virtual distant source, its direction
//! bent by Radiance's shear (`dir_proj`) and its solid angle kept; its
//! shadow rays are redirected by the same functions where they meet the
//! surface, scaled by their coefficient.

pub use super::light::{Redirect, Relay, Virtual};

use super::light::{prepare_lights, LightExtent, PreparedLight};
use crate::geometry::{Aabb, Shape, Vec3};
use crate::scene::{Color, Material, ObjectId, Scene};

/// Radiance's `FTINY`.
const FTINY: f64 = 1e-6;

/// Most virtual sources made for one scene (Radiance has no limit; a mirror
/// made of thousands of polygons times many sources would otherwise
/// explode the light list).
pub const MAX_VIRTUAL_SOURCES: usize = 4096;

/// A planar mirror that can relay sources.
#[derive(Debug, Clone, Copy)]
struct Mirror {
    relay: Relay,
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
    fn reflect(self, r: &Relay) -> Self {
        match self {
            Location::Point(p) => Location::Point(r.point(p)),
            Location::Direction(d) => Location::Direction(r.dir(d)),
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

/// The planar mirrors among the scene's top-level objects; non-planar
/// mirror surfaces are reported (Radiance: "secondary sources not
/// supported").
fn mirrors(scene: &Scene, warnings: &mut Vec<String>) -> Vec<Mirror> {
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
        let Material::Mirror { color, .. } = m else {
            continue;
        };
        let (normal, point, center, radius2) = match &o.shape {
            Shape::Polygon(p) => {
                let c = p.vertices.iter().fold(Vec3::ZERO, |a, v| a + *v)
                    / p.vertices.len().max(1) as f64;
                let r2 = p
                    .vertices
                    .iter()
                    .map(|v| (*v - c).length_squared())
                    .fold(0.0, f64::max);
                (p.normal, p.vertices[0], c, r2)
            }
            Shape::Ring {
                center,
                normal,
                r_outer,
                ..
            } => (*normal, *center, *center, r_outer * r_outer),
            Shape::Instance(_) => continue,
            _ => {
                curved += 1;
                first_curved.get_or_insert(o.name.clone());
                continue;
            }
        };
        let len = normal.length();
        if !(len > 0.0 && len.is_finite()) || radius2 <= FTINY {
            continue;
        }
        let normal = normal / len;
        out.push(Mirror {
            relay: Relay {
                object: i,
                normal,
                offset: normal.dot(point),
                color: *color,
                redirect: None,
            },
            center,
            radius2,
        });
    }
    if let Some(name) = first_curved {
        warnings.push(format!(
            "mirror surface {name:?}{}: not planar, so it relays no light sources (secondary sources not supported)",
            if curved > 1 {
                format!(" and {} more", curved - 1)
            } else {
                String::new()
            }
        ));
    }
    out
}

/// [`prepare_lights`] plus the virtual sources planar mirrors make of
/// them, up to `relays` reflections (`-dr`; see the module doc).
pub fn prepare_lights_relayed(scene: &Scene, relays: u32) -> (Vec<PreparedLight>, Vec<String>) {
    let (mut lights, mut warnings) = prepare_lights(scene);
    add_virtual_lights(scene, &mut lights, relays, &mut warnings);
    (lights, warnings)
}

/// Appends the virtual sources of `lights` (real sources only) through the
/// scene's planar mirrors, up to `depth` reflections (`-dr`), in a fixed
/// order: per real source, per mirror in object order, depth first.
pub fn add_virtual_lights(
    scene: &Scene,
    lights: &mut Vec<PreparedLight>,
    depth: u32,
    warnings: &mut Vec<String>,
) {
    if depth == 0 {
        return;
    }
    let reals = lights.len();
    add_prism_relays(scene, lights, reals, warnings);
    let mirrors = mirrors(scene, warnings);
    if mirrors.is_empty() {
        return;
    }
    let mut capped = false;
    for i in 0..reals {
        let real = lights[i].clone();
        let Some(loc) = location(&real) else {
            continue;
        };
        let mut chain = Vec::new();
        project(
            &real,
            loc,
            real.object,
            &mirrors,
            &mut chain,
            depth,
            lights,
            &mut capped,
        );
    }
    if capped {
        warnings.push(format!(
            "more than {MAX_VIRTUAL_SOURCES} virtual light sources (mirror relays); the rest are left out"
        ));
    }
}

fn location(l: &PreparedLight) -> Option<Location> {
    match l.extent()? {
        LightExtent::Finite(b) => Some(Location::Point(b.center())),
        LightExtent::Distant { dir, .. } => Some(Location::Direction(dir)),
    }
}

/// `vproject()` / `makevsrc()`: the relays of the source at `loc` (its
/// image so far through `chain`, last mirror `so`).
#[allow(clippy::too_many_arguments)]
fn project(
    real: &PreparedLight,
    loc: Location,
    so: Option<ObjectId>,
    mirrors: &[Mirror],
    chain: &mut Vec<Relay>,
    depth: u32,
    out: &mut Vec<PreparedLight>,
    capped: &mut bool,
) {
    if depth == 0 {
        return;
    }
    for m in mirrors {
        let r = &m.relay;
        if Some(r.object) == so {
            continue; // objects cannot project themselves
        }
        // mir_proj(): the mirror must face the source.
        if loc.side(r) <= FTINY {
            continue;
        }
        // getdisk(): relaying an image, the new mirror must reach the far
        // side of the previous mirror's plane.
        if let Some(prev) = chain.first() {
            let rd = loc.side(prev);
            let d = prev.normal.dot(m.center) - prev.offset;
            if (d > 0.0) == (rd > 0.0) {
                if d * d >= m.radius2 {
                    continue;
                }
                let c = prev.normal.dot(r.normal);
                if d * d >= m.radius2 * (1.0 - c * c) {
                    continue;
                }
            }
        }
        if out.len() >= MAX_VIRTUAL_SOURCES {
            *capped = true;
            return;
        }
        chain.insert(0, *r);
        let virt = Virtual {
            relays: chain.clone(),
            real: Box::new(real.clone()),
        };
        out.push(real.relayed(virt, reflect_extent(real.extent(), chain)));
        project(
            real,
            loc.reflect(r),
            Some(r.object),
            mirrors,
            chain,
            depth - 1,
            out,
            capped,
        );
        chain.remove(0);
    }
}

/// The extent of the image of a source through `chain` (the box around
/// the mirrored box's corners; a mirrored cone for distant sources).
fn reflect_extent(e: Option<LightExtent>, chain: &[Relay]) -> Option<LightExtent> {
    Some(match e? {
        LightExtent::Finite(b) => {
            let mut out = Aabb::EMPTY;
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                );
                let p = chain.iter().rev().fold(c, |p, r| r.point(p));
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

/// A plane's unit normal, offset and disk centre for a polygon or ring;
/// `None` for other shapes.
fn plane_of(shape: &Shape) -> Option<(Vec3, f64, Vec3)> {
    let (normal, point, center) = match shape {
        Shape::Polygon(p) => {
            let c =
                p.vertices.iter().fold(Vec3::ZERO, |a, v| a + *v) / p.vertices.len().max(1) as f64;
            (p.normal, *p.vertices.first()?, c)
        }
        Shape::Ring { center, normal, .. } => (*normal, *center, *center),
        _ => return None,
    };
    let len = normal.length();
    if !(len > 0.0 && len.is_finite()) {
        return None;
    }
    let n = normal / len;
    Some((n, n.dot(point), center))
}

/// `dir_proj()` of `m_direct.c` for the scene's planar `prism1`/`prism2`
/// surfaces and the distant ones among the first `reals` lights: the
/// direction of the source's centre redirected at the surface's centre
/// gives the shear that maps the source onto its image. Not done: local
/// sources through prisms, redirections back to the source's side (a
/// mirroring projection), and relays of relays through prisms.
fn add_prism_relays(
    scene: &Scene,
    lights: &mut Vec<PreparedLight>,
    reals: usize,
    warnings: &mut Vec<String>,
) {
    let mut skipped_local = false;
    for (i, o) in scene.table().iter() {
        let Material::Prism {
            modifier,
            projections,
        } = scene.material(o.material)
        else {
            continue;
        };
        let Some((nv, od, center)) = plane_of(&o.shape) else {
            warnings.push(format!(
                "{:?}: a prism that is not a polygon or ring relays no light sources",
                o.name
            ));
            continue;
        };
        for l in 0..reals {
            let (sdir, cos_half) = match lights[l].extent() {
                Some(LightExtent::Distant { dir, cos_half }) => (dir, cos_half),
                _ => {
                    skipped_local = true;
                    continue;
                }
            };
            let olddir = -sdir;
            let olddot = olddir.dot(nv);
            if olddot.abs() <= FTINY {
                continue;
            }
            let vars = crate::modifier::RayVars {
                dir: olddir,
                normal: nv,
                point: center,
                t: 1.0,
                ts: 1.0,
                uv: [0.0; 2],
            };
            for k in 0..*projections {
                let Some((coef, newdir)) = scene.patterns.redirect(*modifier, k as usize, &vars)
                else {
                    continue;
                };
                let newdot = newdir.dot(nv);
                if coef <= FTINY || newdot.abs() <= FTINY || (newdot > 0.0) != (olddot > 0.0) {
                    continue;
                }
                if lights.len() >= MAX_VIRTUAL_SOURCES {
                    return;
                }
                let shear = newdir / newdot - olddir / olddot;
                // Points the redirected light reaches lie on this side.
                let side = newdot.signum();
                let relay = Relay {
                    object: i,
                    normal: nv * side,
                    offset: od * side,
                    color: Color::ONE,
                    redirect: Some(Redirect {
                        modifier: *modifier,
                        projection: k,
                        plane: nv,
                        shear,
                    }),
                };
                let real = lights[l].clone();
                let dir = relay.image_dir(sdir);
                let virt = Virtual {
                    relays: vec![relay],
                    real: Box::new(real.clone()),
                };
                lights.push(real.relayed(virt, Some(LightExtent::Distant { dir, cos_half })));
            }
        }
    }
    if skipped_local {
        warnings.push(
            "prism1/prism2: local light sources are not relayed through prisms (distant ones are)"
                .into(),
        );
    }
}
