//! Light sources prepared for sampling: area sources split into patches
//! after Radiance's `srcsamp.c`, distant sources as one direction.
//!
//! A source is split recursively along its longest dimension until every
//! patch's size over its distance from the shaded point is below `-ds`
//! (at most [`MAX_PATCHES`] patches, Radiance's `MAXSPART`). Each patch
//! contributes one sample point, at its centre for `-dj 0` and moved
//! towards a uniformly random point of the patch by the fraction `-dj`.
//!
//! A virtual source ([`Virtual`]: the mirrors or prisms relaying a real
//! source) is a prepared light too, sampled through the real one it holds;
//! the two are one recursive type and live here. Finding the relays is
//! [`super::virtual_source`]'s work.

use std::f64::consts::PI;

use glam::DVec2;

use super::rng::Rng;
use crate::accel::Pyramid;
use crate::geometry::robust::orthonormal_basis;
use crate::geometry::{Aabb, Shape, Vec3};
use crate::scene::{Color, LightKind, Material, ObjectId, Scene};

/// Radiance's `MAXSPART`: the most patches one source is split into.
pub const MAX_PATCHES: usize = 64;

/// One sample towards a light from a shaded point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatchSample {
    /// Unit direction from the shaded point to the sample point.
    pub dir: Vec3,
    /// Distance to the sample point (infinite for distant sources).
    pub dist: f64,
    /// Solid angle the patch subtends (projected towards the point).
    pub omega: f64,
    /// Unit normal of the source at the sample (zero for distant sources).
    pub normal: Vec3,
}

/// How a source's geometry is sampled.
#[derive(Debug, Clone)]
enum Geometry {
    /// Planar polygon: patches are rectangles of its bounding rectangle in
    /// the plane frame `(u, v)`, clipped to the polygon's triangles.
    Polygon {
        origin: Vec3,
        u: Vec3,
        v: Vec3,
        normal: Vec3,
        rect: [f64; 4],
        tris: Vec<[DVec2; 3]>,
        area: f64,
        /// The polygon fills its bounding rectangle (the common luminaire):
        /// patches need no clipping.
        rectangular: bool,
    },
    /// Sphere, seen as the disk facing the point (Radiance's sphere sources).
    Sphere { center: Vec3, radius: f64 },
    /// Disk or annulus facing `normal`: patches are polar cells, split in
    /// radius or angle.
    Ring {
        center: Vec3,
        normal: Vec3,
        r_inner: f64,
        r_outer: f64,
    },
    /// Any other shape with an area-uniform `(u, v)` parameterisation
    /// (cones): patches are rectangles of the parameter square.
    Param { area: f64 },
    /// Distant source (Radiance `source`).
    Distant {
        dir: Vec3,
        solid_angle: f64,
        cos_half: f64,
    },
}

/// A light ready for sampling.
#[derive(Debug, Clone)]
pub struct PreparedLight {
    /// Index into `Scene::lights`.
    pub index: usize,
    /// The emitting object (None for distant sources).
    pub object: Option<ObjectId>,
    /// The light's emitting material (already resolved).
    pub material: Material,
    /// Patterns on the emitting material (a luminaire's distribution):
    /// evaluated per shadow ray; empty for most lights.
    mods: Vec<crate::modifier::ModifierId>,
    patterns: std::sync::Arc<crate::modifier::Patterns>,
    geometry: Geometry,
    /// Where its samples can lie, worked out once (see [`LightExtent`]).
    extent: Option<LightExtent>,
    /// Fraction of shadow rays that reach it (Radiance's per-source
    /// `nhits / ntests`); scales its untested contributions. 1 until
    /// [`super::direct::estimate_hit_ratios`] measures it.
    pub hit_ratio: f64,
    /// A virtual source: the mirrors and prisms relaying a real one
    /// (see [`super::virtual_source`]); `None` for real sources.
    pub virt: Option<Box<Virtual>>,
    /// A spotlight's focal length: the length of its direction vector
    /// (Radiance's `flen`, 0 for other sources). Samples' solid angles are
    /// those of the source seen from `flen` further away.
    flen: f64,
}

/// Prepares all of the scene's lights. Lights that cannot be sampled
/// (emitters inside instances, glow `source`s that Radiance never samples)
/// are left out with a warning each.
pub fn prepare_lights(scene: &Scene) -> (Vec<PreparedLight>, Vec<String>) {
    let mut out = Vec::new();
    let mut warnings = Vec::new();
    for (index, light) in scene.lights.iter().enumerate() {
        let Some(material) = scene.materials.get(light.material as usize).cloned() else {
            warnings.push(format!(
                "light {index}: material {} does not exist; ignored",
                light.material
            ));
            continue;
        };
        let name = |o: ObjectId| scene.object(o).map_or("?", |o| o.name.as_str()).to_string();
        let geometry = match &light.kind {
            LightKind::Distant {
                dir, solid_angle, ..
            } => {
                if matches!(material, Material::Glow { .. }) {
                    // Radiance (source.c): a glow `source` is seen, never sampled.
                    continue;
                }
                let len = dir.length();
                if !(len.is_finite() && len > 0.0 && solid_angle.is_finite() && *solid_angle > 0.0)
                {
                    warnings.push(format!(
                        "distant light {index}: bad direction or solid angle; ignored"
                    ));
                    continue;
                }
                let omega = solid_angle.min(4.0 * PI);
                Geometry::Distant {
                    dir: *dir / len,
                    solid_angle: omega,
                    cos_half: 1.0 - omega / (2.0 * PI),
                }
            }
            LightKind::Area { object } => {
                let Some(obj) = scene.object(*object) else {
                    warnings.push(format!(
                        "light {index}: object {object} does not exist; ignored"
                    ));
                    continue;
                };
                match &obj.shape {
                    Shape::Polygon(p) => polygon_geometry(&p.vertices, &p.triangles, p.normal),
                    Shape::Sphere { center, radius, .. } => Geometry::Sphere {
                        center: *center,
                        radius: *radius,
                    },
                    Shape::Ring {
                        center,
                        normal,
                        r_inner,
                        r_outer,
                    } => Geometry::Ring {
                        center: *center,
                        normal: *normal,
                        r_inner: *r_inner,
                        r_outer: *r_outer,
                    },
                    Shape::Cone { .. } => Geometry::Param {
                        area: obj.shape.area(),
                    },
                    Shape::Instance(_) => {
                        warnings.push(format!(
                            "light source {:?} is an instance; emitters inside instances are not sampled as lights",
                            name(*object)
                        ));
                        continue;
                    }
                }
            }
        };
        let object = match light.kind {
            LightKind::Area { object } => Some(object),
            LightKind::Distant { .. } => None,
        };
        let extent = match &geometry {
            Geometry::Distant { dir, cos_half, .. } => Some(LightExtent::Distant {
                dir: *dir,
                cos_half: *cos_half,
            }),
            _ => object
                .and_then(|o| scene.object(o))
                .map(|o| LightExtent::Finite(o.shape.bounds())),
        };
        let flen = match &material {
            Material::Spotlight { direction, .. } if object.is_some() => direction.length(),
            _ => 0.0,
        };
        out.push(PreparedLight {
            index,
            object,
            flen,
            material,
            mods: scene.mods(light.material).to_vec(),
            patterns: scene.patterns.clone(),
            geometry,
            extent,
            hit_ratio: 1.0,
            virt: None,
        });
    }
    (out, warnings)
}

fn polygon_geometry(vertices: &[Vec3], triangles: &[[u32; 3]], normal: Vec3) -> Geometry {
    let origin = vertices[0];
    // Frame: u along the longest edge, so rectangles fit rectangular sources.
    let mut u = Vec3::ZERO;
    let mut best = 0.0;
    for i in 0..vertices.len() {
        let e = vertices[(i + 1) % vertices.len()] - vertices[i];
        let e = e - normal * e.dot(normal);
        if e.length_squared() > best {
            best = e.length_squared();
            u = e;
        }
    }
    let u = if best > 0.0 {
        u.normalize()
    } else {
        orthonormal_basis(normal).0
    };
    let v = normal.cross(u);
    let to2 = |p: Vec3| DVec2::new((p - origin).dot(u), (p - origin).dot(v));
    let mut rect = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for &p in vertices {
        let q = to2(p);
        rect = [
            rect[0].min(q.x),
            rect[1].max(q.x),
            rect[2].min(q.y),
            rect[3].max(q.y),
        ];
    }
    let tris: Vec<[DVec2; 3]> = triangles
        .iter()
        .map(|t| {
            [
                to2(vertices[t[0] as usize]),
                to2(vertices[t[1] as usize]),
                to2(vertices[t[2] as usize]),
            ]
        })
        .collect();
    let area: f64 = tris.iter().map(|t| tri_area(t[0], t[1], t[2])).sum();
    let rect_area = (rect[1] - rect[0]) * (rect[3] - rect[2]);
    let rectangular = (area - rect_area).abs() <= 1e-9 * rect_area;
    Geometry::Polygon {
        origin,
        u,
        v,
        normal,
        rect,
        tris,
        area,
        rectangular,
    }
}

#[inline]
fn tri_area(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    0.5 * (b - a).perp_dot(c - a).abs()
}

/// Clips triangle `t` to the rectangle `r = [u0, u1, v0, v1]` (Sutherland-
/// Hodgman on a fixed-size buffer). Returns the clipped convex polygon.
fn clip_triangle(t: &[DVec2; 3], r: [f64; 4]) -> ([DVec2; 8], usize) {
    let mut a = [DVec2::ZERO; 8];
    let mut b = [DVec2::ZERO; 8];
    a[..3].copy_from_slice(t);
    let mut n = 3;
    // (axis, bound, keep if coordinate >= bound when sign > 0)
    let planes = [
        (0usize, r[0], 1.0),
        (0, r[1], -1.0),
        (1, r[2], 1.0),
        (1, r[3], -1.0),
    ];
    for (axis, bound, sign) in planes {
        let d = |p: DVec2| sign * (p[axis] - bound);
        let mut m = 0;
        for i in 0..n {
            let (p, q) = (a[i], a[(i + 1) % n]);
            let (dp, dq) = (d(p), d(q));
            if dp >= 0.0 {
                b[m] = p;
                m += 1;
            }
            if (dp >= 0.0) != (dq >= 0.0) {
                let s = dp / (dp - dq);
                b[m] = p + (q - p) * s;
                m += 1;
            }
            if m >= 8 {
                break;
            }
        }
        std::mem::swap(&mut a, &mut b);
        n = m;
        if n < 3 {
            return (a, 0);
        }
    }
    (a, n)
}

/// Area and area-weighted centroid of a convex polygon (fan from vertex 0).
fn poly_area_centroid(p: &[DVec2]) -> (f64, DVec2) {
    let mut area = 0.0;
    let mut c = DVec2::ZERO;
    for i in 1..p.len().saturating_sub(1) {
        let a = tri_area(p[0], p[i], p[i + 1]);
        area += a;
        c += (p[0] + p[i] + p[i + 1]) * (a / 3.0);
    }
    if area > 0.0 {
        (area, c / area)
    } else {
        (0.0, p.first().copied().unwrap_or(DVec2::ZERO))
    }
}

/// A uniformly distributed point of the convex polygon `p` with area `area`.
fn uniform_in_poly(p: &[DVec2], area: f64, rng: &mut Rng) -> DVec2 {
    let target = rng.next_f64() * area;
    let (r1, r2) = (rng.next_f64(), rng.next_f64());
    let mut acc = 0.0;
    let last = p.len() - 2;
    for i in 1..=last {
        let a = tri_area(p[0], p[i], p[i + 1]);
        acc += a;
        if acc >= target || i == last {
            let s = r1.sqrt();
            return p[0] * (1.0 - s) + p[i] * (s * (1.0 - r2)) + p[i + 1] * (s * r2);
        }
    }
    p[0]
}

/// Radiance's `-dj` blend: the cell centre moved by `dj` towards `random`.
#[inline]
fn jitter(center: f64, random: f64, dj: f64) -> f64 {
    center + dj * (random - center)
}

/// The region a source's shadow rays can end in, for bounding a shadow
/// bundle with a pyramid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightExtent {
    /// Every sample lies in this box (the emitting object's bounds).
    Finite(crate::geometry::Aabb),
    /// Every sample direction lies in this cone (`cos_half` of its half angle).
    Distant { dir: Vec3, cos_half: f64 },
}

impl PreparedLight {
    /// Where this source's samples can lie (see [`LightExtent`]); `None` if
    /// the emitting object was missing from the scene it was prepared from.
    pub fn extent(&self) -> Option<LightExtent> {
        self.extent
    }

    /// The box holding every shadow ray from `point` to this (finite)
    /// source, padded for the rays' origin offsets (`offset_scale`, see
    /// [`ShadowBundle::offset_scale`](super::ShadowBundle)); `None` for a
    /// distant or missing source.
    pub fn shadow_bounds(&self, point: Vec3, offset_scale: f64) -> Option<Aabb> {
        match self.extent()? {
            LightExtent::Finite(bb) => {
                let lo = bb.min.min(point);
                let hi = bb.max.max(point);
                let pad = shadow_pad(lo, hi, offset_scale);
                Some(Aabb::new(lo - pad, hi + pad))
            }
            LightExtent::Distant { .. } => None,
        }
    }

    /// The corners of `cell` and of this (finite) source's box, each padded
    /// as [`PreparedLight::shadow_bounds`] pads the box around `cell`, the
    /// source and `point`: a pyramid from `point` around them holds every
    /// shadow ray from a point of `cell` to the source. `None` for a distant
    /// or missing source.
    pub fn shadow_hull_points(
        &self,
        cell: Aabb,
        point: Vec3,
        offset_scale: f64,
    ) -> Option<Vec<Vec3>> {
        let LightExtent::Finite(lb) = self.extent()? else {
            return None;
        };
        let lo = cell.min.min(lb.min).min(point);
        let hi = cell.max.max(lb.max).max(point);
        let pad = shadow_pad(lo, hi, offset_scale);
        let padded = |bb: Aabb| Aabb::new(bb.min - pad, bb.max + pad).corners();
        Some(padded(cell).into_iter().chain(padded(lb)).collect())
    }

    /// Whether `point` lies in this finite source's box (padded by a
    /// relative 1e-6), where no pyramid from `point` bounds the source.
    /// False for a distant or missing source.
    pub fn box_holds(&self, point: Vec3) -> bool {
        let Some(LightExtent::Finite(bb)) = self.extent() else {
            return false;
        };
        let pad = 1e-6 * (bb.extent().max_element() + point.abs().max_element());
        (point.cmpge(bb.min - pad) & point.cmple(bb.max + pad)).all()
    }

    /// A pyramid from `point` holding every shadow ray to this source: to
    /// the corners of a finite source's box, or around the cone of a
    /// distant one's directions. `None` for a missing source.
    pub fn shadow_pyramid(&self, point: Vec3) -> Option<Pyramid> {
        match self.extent()? {
            LightExtent::Finite(bb) => Some(Pyramid::to_targets(point, &bb.corners())),
            LightExtent::Distant { dir, cos_half } => {
                let sin = (1.0 - cos_half * cos_half).max(0.0).sqrt();
                let tan = sin / cos_half.max(1e-12);
                let (u, v) = orthonormal_basis(dir);
                let dirs: Vec<Vec3> = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
                    .iter()
                    .map(|&(a, c)| dir + (u * a + v * c) * (tan * 1.000001))
                    .collect();
                Some(Pyramid::from_rays(point, &dirs))
            }
        }
    }

    /// A virtual copy of this (real) light relayed by `virt`, its samples
    /// lying within `extent`.
    pub fn relayed(&self, virt: Virtual, extent: Option<LightExtent>) -> Self {
        Self {
            object: None,
            extent,
            virt: Some(Box::new(virt)),
            ..self.clone()
        }
    }

    /// A cheap estimate of the number of shadow rays a bundle from `p` to
    /// this source traces at source subdivision `ds`: 1 for distant sources
    /// or `ds == 0`, otherwise (size / (ds x distance))^2 clamped to
    /// `1..=MAX_PATCHES`, the subdivision rule of [`Self::for_each_patch`].
    pub fn patch_estimate(&self, p: Vec3, ds: f64) -> usize {
        let Some(LightExtent::Finite(b)) = self.extent() else {
            return 1;
        };
        if ds <= 0.0 {
            return 1;
        }
        let size = b.extent().max_element();
        let dist = (b.center() - p).length();
        if !(size.is_finite() && dist.is_finite()) || dist <= 0.0 {
            return MAX_PATCHES;
        }
        let per_side = (size / (ds * dist)).ceil().max(1.0);
        (per_side * per_side).min(MAX_PATCHES as f64) as usize
    }

    /// The name of a real source: its surface's, or the distant `source`
    /// primitive's.
    pub fn name<'s>(&self, scene: &'s Scene) -> Option<&'s str> {
        match &scene.lights.get(self.index)?.kind {
            LightKind::Area { object } => scene.object(*object).map(|o| o.name.as_str()),
            LightKind::Distant { name, .. } => Some(name),
        }
    }

    /// True where samples lie inside the source (on a sphere's disk
    /// through its centre), not on its surface.
    pub fn samples_inside(&self) -> bool {
        matches!(self.geometry, Geometry::Sphere { .. })
    }

    /// True for flat sources (polygons and rings), whose samples' solid
    /// angles carry the cosine at the source.
    fn is_flat(&self) -> bool {
        matches!(
            self.geometry,
            Geometry::Polygon { .. } | Geometry::Ring { .. }
        )
    }

    /// True for distant sources.
    pub fn is_distant(&self) -> bool {
        matches!(self.geometry, Geometry::Distant { .. })
    }

    /// False if no part of the source can send light to `p` (the point is
    /// behind a one-sided flat source, or inside a spherical one): a cheap
    /// test that saves running an empty shadow bundle.
    #[inline]
    pub fn may_reach(&self, p: Vec3) -> bool {
        if let Some(v) = &self.virt {
            return v.may_reach(p);
        }
        match &self.geometry {
            Geometry::Polygon { origin, normal, .. } => (p - *origin).dot(*normal) > 0.0,
            Geometry::Ring { center, normal, .. } => (p - *center).dot(*normal) > 0.0,
            Geometry::Sphere { center, radius } => (p - *center).length_squared() > radius * radius,
            Geometry::Distant { .. } | Geometry::Param { .. } => true,
        }
    }

    /// Emitted radiance from a sample towards the shaded point `from`,
    /// after the light material (glow's radius of influence, spotlight's
    /// cone) and its patterns (evaluated for the shadow ray from `from`).
    #[inline]
    pub fn emission(&self, from: Vec3, s: &PatchSample) -> Color {
        if let Some(v) = &self.virt {
            return v.emission(from, s);
        }
        let c = self.bare_emission(s);
        if self.mods.is_empty() || c == Color::ZERO {
            return c;
        }
        self.patterned(from, s, c)
    }

    /// `c` times the light's patterns for the sample `s` seen from `from`.
    #[inline(never)]
    fn patterned(&self, from: Vec3, s: &PatchSample, c: Color) -> Color {
        let point = if s.dist.is_finite() {
            from + s.dir * s.dist
        } else {
            Vec3::ZERO
        };
        // A distant source faces the ray (Radiance: Rdot = 1).
        let normal = if s.normal == Vec3::ZERO {
            -s.dir
        } else {
            s.normal
        };
        let vars = crate::modifier::RayVars {
            dir: s.dir,
            normal,
            point,
            t: if s.dist.is_finite() { s.dist } else { 0.0 },
            ts: if s.dist.is_finite() { s.dist } else { 0.0 },
            uv: [0.0; 2],
        };
        let mut a = crate::modifier::Applied::NONE;
        self.patterns.apply(&self.mods, &vars, &mut a);
        c * a.color
    }

    #[inline]
    fn bare_emission(&self, s: &PatchSample) -> Color {
        match &self.material {
            Material::Light { radiance } | Material::Illum { radiance, .. } => *radiance,
            Material::Glow {
                radiance,
                max_radius,
            } => {
                if *max_radius > 0.0 && s.dist > *max_radius {
                    Color::ZERO
                } else {
                    *radiance
                }
            }
            Material::Spotlight {
                radiance,
                angle_deg,
                direction,
            } => {
                if spot_lights(*direction, s.normal, *angle_deg, -s.dir) {
                    *radiance
                } else {
                    Color::ZERO
                }
            }
            _ => Color::ZERO,
        }
    }

    /// A cheap estimate of the light's total solid angle and direction from
    /// `p` (one sample at its centre, no subdivision): used only to weigh
    /// the threshold of adaptive shadow testing across lights.
    pub fn rough_sample(&self, scene: &Scene, p: Vec3) -> Option<PatchSample> {
        if let Some(v) = &self.virt {
            return v.rough_sample(scene, p);
        }
        self.rough_sample_unfocused(scene, p)
            .map(|s| spot_focus(s, self.flen))
    }

    fn rough_sample_unfocused(&self, scene: &Scene, p: Vec3) -> Option<PatchSample> {
        match &self.geometry {
            Geometry::Distant {
                dir, solid_angle, ..
            } => Some(PatchSample {
                dir: *dir,
                dist: f64::INFINITY,
                omega: *solid_angle,
                normal: Vec3::ZERO,
            }),
            Geometry::Polygon {
                origin,
                u,
                v,
                normal,
                rect,
                area,
                ..
            } => {
                let c =
                    *origin + *u * (0.5 * (rect[0] + rect[1])) + *v * (0.5 * (rect[2] + rect[3]));
                flat_sample(p, c, *normal, *area)
            }
            Geometry::Sphere { center, radius } => {
                let d = *center - p;
                let dist = d.length();
                (dist > *radius).then(|| PatchSample {
                    dir: d / dist,
                    dist,
                    omega: PI * radius * radius / (dist * dist),
                    normal: -d / dist,
                })
            }
            Geometry::Ring {
                center,
                normal,
                r_inner,
                r_outer,
            } => {
                let area = PI * (r_outer - r_inner) * (r_outer + r_inner);
                flat_sample(p, *center, *normal, area)
            }
            Geometry::Param { area } => {
                let shape = &scene.object(self.object?)?.shape;
                let c = shape.bounds().center();
                let d = c - p;
                let dist = d.length();
                (dist > 0.0).then(|| PatchSample {
                    dir: d / dist,
                    dist,
                    omega: 0.5 * area / (dist * dist),
                    normal: -d / dist,
                })
            }
        }
    }

    /// Calls `f` with one sample per patch of this light as seen from the
    /// point `p`, in a fixed order. Patches that face away from `p` are
    /// skipped; random numbers come from `rng` only when `dj > 0`.
    pub fn for_each_patch<F: FnMut(PatchSample)>(
        &self,
        scene: &Scene,
        p: Vec3,
        ds: f64,
        dj: f64,
        rng: &mut Rng,
        mut f0: F,
    ) {
        if let Some(v) = &self.virt {
            return v.for_each_patch(scene, p, ds, dj, rng, &mut f0);
        }
        if self.flen > 0.0 {
            let flen = self.flen;
            self.for_each_unfocused(scene, p, ds, dj, rng, |s| f0(spot_focus(s, flen)));
        } else {
            self.for_each_unfocused(scene, p, ds, dj, rng, f0);
        }
    }

    /// [`PreparedLight::for_each_patch`] without a spotlight's focus.
    fn for_each_unfocused<F: FnMut(PatchSample)>(
        &self,
        scene: &Scene,
        p: Vec3,
        ds: f64,
        dj: f64,
        rng: &mut Rng,
        mut f: F,
    ) {
        match &self.geometry {
            Geometry::Distant {
                dir,
                solid_angle,
                cos_half,
            } => {
                let mut d = *dir;
                if dj > 0.0 {
                    // A direction within the source's cone, pulled towards its centre by dj.
                    let cos_t = 1.0 - dj * rng.next_f64() * (1.0 - cos_half);
                    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                    let phi = 2.0 * PI * rng.next_f64();
                    let (a, b) = orthonormal_basis(*dir);
                    d = (*dir * cos_t + (a * phi.cos() + b * phi.sin()) * sin_t).normalize();
                }
                f(PatchSample {
                    dir: d,
                    dist: f64::INFINITY,
                    omega: *solid_angle,
                    normal: Vec3::ZERO,
                });
            }
            Geometry::Polygon {
                origin,
                u,
                v,
                normal,
                rect,
                tris,
                rectangular,
                ..
            } => {
                // Sources are one-sided: nothing reaches points behind them.
                if (p - *origin).dot(*normal) <= 0.0 {
                    return;
                }
                let frame = (origin, u, v);
                let to3 = |q: DVec2| *frame.0 + *frame.1 * q.x + *frame.2 * q.y;
                let mut leaf = |r: [f64; 4], mid: Vec3, rng: &mut Rng| {
                    if *rectangular {
                        let area = (r[1] - r[0]) * (r[3] - r[2]);
                        let (cu, cv) = (0.5 * (r[0] + r[1]), 0.5 * (r[2] + r[3]));
                        // Without jitter, the cell's centre as the split
                        // computed it (`centre` below), the same bits.
                        let q = if dj > 0.0 {
                            let uu = r[0] + rng.next_f64() * (r[1] - r[0]);
                            let vv = r[2] + rng.next_f64() * (r[3] - r[2]);
                            to3(DVec2::new(jitter(cu, uu, dj), jitter(cv, vv, dj)))
                        } else {
                            mid
                        };
                        if let Some(s) = flat_sample(p, q, *normal, area) {
                            f(s);
                        }
                        return;
                    }
                    let mut area = 0.0;
                    let mut cen = DVec2::ZERO;
                    for t in tris {
                        let (c, n) = clip_triangle(t, r);
                        if n >= 3 {
                            let (a, ce) = poly_area_centroid(&c[..n]);
                            area += a;
                            cen += ce * a;
                        }
                    }
                    if area <= 0.0 {
                        return;
                    }
                    let cen = cen / area;
                    let mut q = cen;
                    if dj > 0.0 {
                        // A uniform point of the clipped region, then blended.
                        let target = rng.next_f64() * area;
                        let mut acc = 0.0;
                        let mut chosen = cen;
                        for t in tris {
                            let (c, n) = clip_triangle(t, r);
                            if n >= 3 {
                                let (a, _) = poly_area_centroid(&c[..n]);
                                acc += a;
                                if acc >= target && a > 0.0 {
                                    chosen = uniform_in_poly(&c[..n], a, rng);
                                    break;
                                }
                            }
                        }
                        q = DVec2::new(jitter(cen.x, chosen.x, dj), jitter(cen.y, chosen.y, dj));
                    }
                    if let Some(s) = flat_sample(p, to3(q), *normal, area) {
                        f(s);
                    }
                };
                let centre =
                    |r: [f64; 4]| to3(DVec2::new(0.5 * (r[0] + r[1]), 0.5 * (r[2] + r[3])));
                split_rect(
                    *rect,
                    MAX_PATCHES,
                    &|r| (r[1] - r[0], r[3] - r[2], centre(r)),
                    p,
                    ds,
                    rng,
                    &mut leaf,
                );
            }
            Geometry::Sphere { center, radius } => {
                let w = p - *center;
                let d = w.length();
                if d <= *radius {
                    return;
                }
                let w = w / d;
                polar_patches(p, *center, w, 0.0, *radius, ds, dj, rng, &mut f);
            }
            Geometry::Ring {
                center,
                normal,
                r_inner,
                r_outer,
            } => {
                if (p - *center).dot(*normal) <= 0.0 {
                    return;
                }
                polar_patches(p, *center, *normal, *r_inner, *r_outer, ds, dj, rng, &mut f);
            }
            Geometry::Param { area } => {
                let Some(obj) = self.object.and_then(|o| scene.object(o)) else {
                    return;
                };
                let shape = &obj.shape;
                let dims = |c: [f64; 4]| {
                    let (um, vm) = (0.5 * (c[0] + c[1]), 0.5 * (c[2] + c[3]));
                    let pm = shape.sample(um, vm).0;
                    let du = (shape.sample(c[1], vm).0 - shape.sample(c[0], vm).0).length();
                    let dv = (shape.sample(um, c[2]).0 - pm).length()
                        + (pm - shape.sample(um, c[3]).0).length();
                    (du, dv, pm)
                };
                let mut leaf = |c: [f64; 4], _: Vec3, rng: &mut Rng| {
                    let cell_area = area * (c[1] - c[0]) * (c[3] - c[2]);
                    let uu = jitter(
                        0.5 * (c[0] + c[1]),
                        c[0] + (c[1] - c[0]) * rng_if(rng, dj),
                        dj,
                    );
                    let vv = jitter(
                        0.5 * (c[2] + c[3]),
                        c[2] + (c[3] - c[2]) * rng_if(rng, dj),
                        dj,
                    );
                    let (q, n) =
                        shape.sample(uu.min(1.0 - f64::EPSILON), vv.min(1.0 - f64::EPSILON));
                    if let Some(s) = flat_sample(p, q, n, cell_area) {
                        f(s);
                    }
                };
                split_rect(
                    [0.0, 1.0, 0.0, 1.0],
                    MAX_PATCHES,
                    &dims,
                    p,
                    ds,
                    rng,
                    &mut leaf,
                );
            }
        }
    }
}

/// Patches of the annulus `r_inner..r_outer` around `center` in the plane
/// with unit normal `n` (emitting towards `n`): polar cells split in radius
/// or angle, whichever is longer, sampled at their area centroid (moved
/// towards a uniform random point by `dj`).
#[allow(clippy::too_many_arguments)]
fn polar_patches<F: FnMut(PatchSample)>(
    p: Vec3,
    center: Vec3,
    n: Vec3,
    r_inner: f64,
    r_outer: f64,
    ds: f64,
    dj: f64,
    rng: &mut Rng,
    f: &mut F,
) {
    let (a, b) = orthonormal_basis(n);
    let point = |r: f64, phi: f64| center + (a * phi.cos() + b * phi.sin()) * r;
    // Cells are [r0, r1, phi0, phi1].
    let dims = |c: [f64; 4]| {
        let (rm, pm) = (0.5 * (c[0] + c[1]), 0.5 * (c[2] + c[3]));
        (c[1] - c[0], rm * (c[3] - c[2]), point(rm, pm))
    };
    let mut leaf = |c: [f64; 4], _: Vec3, rng: &mut Rng| {
        let (r0, r1) = (c[0], c[1]);
        let area = 0.5 * (c[3] - c[2]) * (r1 - r0) * (r1 + r0);
        if area <= 0.0 {
            return;
        }
        // Area centroid of the cell (on its middle angle, at the centroid
        // radius of the annulus times sinc of the half span: the centre of
        // an unsplit disk), and a uniform-by-area random point.
        let half = 0.5 * (c[3] - c[2]);
        let sinc = if half > 1e-9 { half.sin() / half } else { 1.0 };
        let rc = 2.0 / 3.0 * (r1 * r1 * r1 - r0 * r0 * r0) / ((r1 - r0) * (r1 + r0)) * sinc;
        let pc = 0.5 * (c[2] + c[3]);
        let (mut r, mut phi) = (rc, pc);
        if dj > 0.0 {
            let ru = (r0 * r0 + rng.next_f64() * (r1 - r0) * (r1 + r0)).sqrt();
            let pu = c[2] + rng.next_f64() * (c[3] - c[2]);
            r = jitter(rc, ru, dj);
            phi = jitter(pc, pu, dj);
        }
        if let Some(s) = flat_sample(p, point(r, phi), n, area) {
            f(s);
        }
    };
    split_rect(
        [r_inner, r_outer, 0.0, 2.0 * PI],
        MAX_PATCHES,
        &dims,
        p,
        ds,
        rng,
        &mut leaf,
    );
}

/// A random number only when jitter is on (so `-dj 0` consumes none).
#[inline]
fn rng_if(rng: &mut Rng, dj: f64) -> f64 {
    if dj > 0.0 {
        rng.next_f64()
    } else {
        0.5
    }
}

/// A sample at `q` of a one-sided emitting patch with unit normal `n` and
/// area `area`, seen from `p`: None if `p` is behind the patch.
#[inline]
fn flat_sample(p: Vec3, q: Vec3, n: Vec3, area: f64) -> Option<PatchSample> {
    let d = q - p;
    let dist = d.length();
    if !(dist > 0.0 && dist.is_finite()) {
        return None;
    }
    let dir = d / dist;
    let cos_l = -dir.dot(n);
    if cos_l <= 0.0 {
        return None;
    }
    Some(PatchSample {
        dir,
        dist,
        omega: area * cos_l / (dist * dist),
        normal: n,
    })
}

/// Radiance's recursive partition (`flt_partit`): split the cell along its
/// longer dimension while its size over the distance from `p` exceeds
/// `ds`, giving each half half of the remaining patch budget `mp`.
/// `dims(cell)` returns the cell's two world-space sizes and its centre,
/// which `leaf(cell, centre, rng)` is given with the cell.
/// Returns the number of leaves produced.
fn split_rect<D, L>(
    cell: [f64; 4],
    mp: usize,
    dims: &D,
    p: Vec3,
    ds: f64,
    rng: &mut Rng,
    leaf: &mut L,
) -> usize
where
    D: Fn([f64; 4]) -> (f64, f64, Vec3),
    L: FnMut([f64; 4], Vec3, &mut Rng),
{
    let (su, sv, c) = dims(cell);
    let d2 = (c - p).length_squared();
    let lim = ds * ds * d2;
    if mp < 2 || ds <= 0.0 || (su * su <= lim && sv * sv <= lim) {
        leaf(cell, c, rng);
        return 1;
    }
    let (a, b) = if su >= sv {
        let m = 0.5 * (cell[0] + cell[1]);
        (
            [cell[0], m, cell[2], cell[3]],
            [m, cell[1], cell[2], cell[3]],
        )
    } else {
        let m = 0.5 * (cell[2] + cell[3]);
        (
            [cell[0], cell[1], cell[2], m],
            [cell[0], cell[1], m, cell[3]],
        )
    };
    let n1 = split_rect(a, mp / 2, dims, p, ds, rng, leaf);
    n1 + split_rect(b, mp - n1, dims, p, ds, rng, leaf)
}

/// Radiance's spotlight focus (`srcray()` in source.c): a spotlight's
/// sample subtends the solid angle its patch would have at the sample's
/// distance plus the focal length `flen`, `omega * d^2 / (d + flen)^2`.
#[inline]
pub fn spot_focus(mut s: PatchSample, flen: f64) -> PatchSample {
    if flen > 0.0 && s.dist.is_finite() {
        let r = s.dist / (s.dist + flen);
        s.omega *= r * r;
    }
    s
}

/// The padding of a box `lo..hi` holding shadow rays whose origins are
/// offset at scale `offset_scale`: far more than the origin offset (a
/// relative 1e-9 or so of the coordinates and the offset scale).
fn shadow_pad(lo: Vec3, hi: Vec3, offset_scale: f64) -> f64 {
    let mag = hi.abs().max(lo.abs()).max_element() + offset_scale.abs();
    1e-6 * ((hi - lo).max_element() + mag)
}

/// A spotlight's emission test: the light aims along `direction` (or, if
/// that is zero, along the emitting surface's `normal`) and lights the
/// points `to_point` (unit, from the light) within its cone of full angle
/// `angle_deg` ([`spot_admits`]).
pub fn spot_lights(direction: Vec3, normal: Vec3, angle_deg: f64, to_point: Vec3) -> bool {
    let aim = if direction.length_squared() > 0.0 {
        direction.normalize()
    } else {
        normal
    };
    spot_admits(aim, angle_deg, to_point)
}

/// Radiance's spotlight test: `to_point` (unit, from the light towards the
/// lit point) lies within the cone of full angle `angle_deg` about `aim`.
pub fn spot_admits(aim: Vec3, angle_deg: f64, to_point: Vec3) -> bool {
    let half = (0.5 * angle_deg).to_radians();
    aim.dot(to_point) >= half.cos()
}

/// One mirror or prism plane a virtual source's light is relayed through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relay {
    /// The mirror or prism object (top level).
    pub object: ObjectId,
    /// Unit normal of the side the relayed light reaches (a mirror's
    /// reflecting front).
    pub normal: Vec3,
    /// `normal . x = offset` on the plane.
    pub offset: f64,
    /// The mirror's reflectance per channel (one for a prism, whose
    /// functions give the coefficient per ray).
    pub color: Color,
    /// For a prism (`prism1`/`prism2`) instead of a mirror: which
    /// projection of which redirecting functions relays the source.
    pub redirect: Option<Redirect>,
}

/// A prism's relay: projection `projection` of the functions `modifier`
/// maps the source onto its image by Radiance's projection (`dir_proj`),
/// the affine map `x -> x + ((x . plane) - offset) shear` that keeps the
/// prism's plane in place. Where the functions send light back to the
/// source's side the projection also mirrors (`mirrored`), and `shear`
/// holds that reflection too (`shear . plane` is -2, 0 otherwise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Redirect {
    pub modifier: crate::modifier::ModifierId,
    pub projection: u8,
    /// Unit normal of the prism's plane, `plane . x = offset` on it.
    pub plane: Vec3,
    pub offset: f64,
    pub shear: Vec3,
    pub mirrored: bool,
}

impl Redirect {
    /// The sign that inverts the projection: `x = y - sign ((y . plane) -
    /// offset) shear` for its image `y` (the plane distance keeps its size
    /// and, mirrored, changes sign).
    #[inline]
    fn inverse_sign(&self) -> f64 {
        if self.mirrored {
            -1.0
        } else {
            1.0
        }
    }
}

impl Relay {
    /// The point whose view of the relayed source equals `p`'s view of the
    /// image: the mirror image of `p`, or the prism's inverse projection.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        match &self.redirect {
            None => p - self.normal * (2.0 * (self.normal.dot(p) - self.offset)),
            Some(r) => p - r.shear * (r.inverse_sign() * (r.plane.dot(p) - r.offset)),
        }
    }

    /// The image of the point `p` of the relayed source (the inverse of
    /// [`Self::point`]).
    #[inline]
    pub fn image_point(&self, p: Vec3) -> Vec3 {
        match &self.redirect {
            None => self.point(p),
            Some(r) => p + r.shear * (r.plane.dot(p) - r.offset),
        }
    }

    /// Mirror image of the direction `d` (a mirror is its own inverse).
    #[inline]
    pub fn dir(&self, d: Vec3) -> Vec3 {
        d - self.normal * (2.0 * self.normal.dot(d))
    }

    /// The projection's linear part: the image of the vector `v`, not
    /// normalised.
    #[inline]
    fn image_vec(&self, v: Vec3) -> Vec3 {
        match &self.redirect {
            None => self.dir(v),
            Some(r) => v + r.shear * v.dot(r.plane),
        }
    }

    /// The inverse of [`Self::image_vec`].
    #[inline]
    fn real_vec(&self, v: Vec3) -> Vec3 {
        match &self.redirect {
            None => self.dir(v),
            Some(r) => v - r.shear * (r.inverse_sign() * v.dot(r.plane)),
        }
    }

    /// A direction towards the real source seen as towards its image.
    pub(super) fn image_dir(&self, d: Vec3) -> Vec3 {
        match &self.redirect {
            None => self.dir(d),
            Some(_) => self.image_vec(d).normalize_or_zero(),
        }
    }

    /// The inverse of [`Self::image_dir`].
    fn real_dir(&self, d: Vec3) -> Vec3 {
        match &self.redirect {
            None => self.dir(d),
            Some(_) => self.real_vec(d).normalize_or_zero(),
        }
    }
}

/// What makes a prepared light virtual.
#[derive(Debug, Clone)]
pub struct Virtual {
    /// The mirrors and prisms, in the order a shadow ray meets them.
    pub relays: Vec<Relay>,
    /// The real source behind them.
    pub real: Box<PreparedLight>,
}

impl Virtual {
    /// The point whose view of the real source equals `p`'s view of this
    /// virtual one.
    pub fn to_real(&self, p: Vec3) -> Vec3 {
        self.relays.iter().fold(p, |p, r| r.point(p))
    }

    fn dir_to_real(&self, d: Vec3) -> Vec3 {
        self.relays.iter().fold(d, |d, r| r.real_dir(d))
    }

    fn dir_from_real(&self, d: Vec3) -> Vec3 {
        self.relays.iter().rev().fold(d, |d, r| r.image_dir(d))
    }

    /// Whether a prism relays the source: its projection keeps neither
    /// distances nor solid angles, as a mirror's does.
    fn sheared(&self) -> bool {
        self.relays.iter().any(|r| r.redirect.is_some())
    }

    /// A sample of the real source seen from [`Self::to_real`]`(p)` as the
    /// same sample of the image seen from `p`. Through a prism the image of
    /// a local source lies at another distance: as Radiance's virtual
    /// sources (`makevsrc()` keeps the source's area and projects its
    /// normal), the sample's solid angle is the patch's seen from there.
    fn sample_from_real(&self, s: PatchSample) -> PatchSample {
        let mut out = PatchSample {
            dir: self.dir_from_real(s.dir),
            normal: self.dir_from_real(s.normal),
            ..s
        };
        if s.dist.is_finite() && self.sheared() {
            let v = self
                .relays
                .iter()
                .rev()
                .fold(s.dir * s.dist, |v, r| r.image_vec(v));
            let dist = v.length();
            if !(dist > 0.0 && dist.is_finite()) {
                out.omega = 0.0;
                return out;
            }
            let r = s.dist / dist;
            let mut scale = r * r;
            if self.real.is_flat() {
                let before = s.normal.dot(s.dir).abs();
                if before > 0.0 {
                    scale *= out.normal.dot(out.dir).abs() / before;
                }
            }
            out.dist = dist;
            out.omega *= scale;
        }
        out
    }

    /// The sample of the real source behind the image's sample `s` (its
    /// direction, distance and normal; the solid angle is the image's).
    fn sample_to_real(&self, s: &PatchSample) -> PatchSample {
        let mut out = PatchSample {
            dir: self.dir_to_real(s.dir),
            normal: self.dir_to_real(s.normal),
            ..*s
        };
        if s.dist.is_finite() && self.sheared() {
            out.dist = self
                .relays
                .iter()
                .fold(s.dir * s.dist, |v, r| r.real_vec(v))
                .length();
        }
        out
    }

    /// See [`PreparedLight::may_reach`]: `p` must be in front of the first
    /// mirror and its image must see the real source.
    pub fn may_reach(&self, p: Vec3) -> bool {
        let Some(first) = self.relays.first() else {
            return false;
        };
        first.normal.dot(p) > first.offset && self.real.may_reach(self.to_real(p))
    }

    /// See [`PreparedLight::emission`].
    pub fn emission(&self, from: Vec3, s: &PatchSample) -> Color {
        self.real
            .emission(self.to_real(from), &self.sample_to_real(s))
    }

    /// See [`PreparedLight::rough_sample`].
    pub fn rough_sample(&self, scene: &Scene, p: Vec3) -> Option<PatchSample> {
        if !self.may_reach(p) {
            return None;
        }
        self.real
            .rough_sample(scene, self.to_real(p))
            .map(|s| self.sample_from_real(s))
    }

    /// See [`PreparedLight::for_each_patch`].
    /// (The callback is dynamic: the real light's method is generic over it.)
    pub fn for_each_patch(
        &self,
        scene: &Scene,
        p: Vec3,
        ds: f64,
        dj: f64,
        rng: &mut Rng,
        f: &mut dyn FnMut(PatchSample),
    ) {
        if !self.may_reach(p) {
            return;
        }
        self.real
            .for_each_patch(scene, self.to_real(p), ds, dj, rng, |s| {
                f(self.sample_from_real(s))
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_preserves_area() {
        let t = [
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, 2.0),
        ];
        let whole = tri_area(t[0], t[1], t[2]);
        let mut sum = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                let r = [
                    i as f64 * 0.5,
                    (i + 1) as f64 * 0.5,
                    j as f64 * 0.5,
                    (j + 1) as f64 * 0.5,
                ];
                let (c, n) = clip_triangle(&t, r);
                if n >= 3 {
                    sum += poly_area_centroid(&c[..n]).0;
                }
            }
        }
        assert!((sum - whole).abs() < 1e-12, "{sum} vs {whole}");
    }

    #[test]
    fn split_respects_ratio_and_budget() {
        let dims = |c: [f64; 4]| {
            (
                c[1] - c[0],
                c[3] - c[2],
                Vec3::new(0.5 * (c[0] + c[1]), 0.5 * (c[2] + c[3]), 0.0),
            )
        };
        let mut rng = Rng::new(1);
        let p = Vec3::new(0.5, 0.5, 2.0);
        let mut cells = Vec::new();
        let n = split_rect(
            [0.0, 1.0, 0.0, 1.0],
            MAX_PATCHES,
            &dims,
            p,
            0.2,
            &mut rng,
            &mut |c, _, _| cells.push(c),
        );
        assert_eq!(n, cells.len());
        let area: f64 = cells.iter().map(|c| (c[1] - c[0]) * (c[3] - c[2])).sum();
        assert!((area - 1.0).abs() < 1e-12);
        for c in &cells {
            let (su, sv, cen) = dims(*c);
            assert!(su.max(sv) <= 0.2 * (cen - p).length() + 1e-12);
        }
        let mut count = 0;
        split_rect(
            [0.0, 1.0, 0.0, 1.0],
            MAX_PATCHES,
            &dims,
            Vec3::new(0.5, 0.5, 0.01),
            0.2,
            &mut rng,
            &mut |_, _, _| count += 1,
        );
        assert!(count <= MAX_PATCHES && count > 16, "{count}");
        let mut one = 0;
        split_rect(
            [0.0, 1.0, 0.0, 1.0],
            MAX_PATCHES,
            &dims,
            p,
            0.0,
            &mut rng,
            &mut |_, _, _| one += 1,
        );
        assert_eq!(one, 1, "-ds 0 means no subdivision");
    }

    fn one_light(text: &str) -> (Scene, PreparedLight) {
        let scene = crate::scene::load_rad_str(text, "l.rad").unwrap();
        let (mut lights, w) = prepare_lights(&scene);
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(lights.len(), 1);
        (scene, lights.remove(0))
    }

    #[test]
    fn unsplit_disk_and_sphere_are_sampled_at_their_centre() {
        // Radiance aims an unsubdivided source at its centre (sloc); a
        // polar cell spanning the whole disk has its centroid there.
        for text in [
            "void light l 0 0 3 1 1 1\nl ring r 0 0 8 0 0 2 0 0 -1 0 0.3\n",
            "void light l 0 0 3 1 1 1\nl sphere s 0 0 4 0 0 2 0.3\n",
        ] {
            let (scene, light) = one_light(text);
            let mut n = 0;
            light.for_each_patch(&scene, Vec3::ZERO, 0.0, 0.0, &mut Rng::new(1), |s| {
                n += 1;
                assert!((s.dir - Vec3::Z).length() < 1e-12, "{:?}", s.dir);
                assert!((s.dist - 2.0).abs() < 1e-12);
            });
            assert_eq!(n, 1);
        }
    }

    #[test]
    fn spotlight_focus_divides_the_solid_angle() {
        // A spotlight's samples subtend omega * d^2 / (d + flen)^2 (srcray).
        for (flen, d) in [(1.0, 2.0), (3.5, 2.0), (0.25, 7.0)] {
            let text = format!(
                "void spotlight s 0 0 7 1 1 1 90 0 0 {}\ns ring r 0 0 8 0 0 {d} 0 0 -1 0 0.1\n",
                -flen
            );
            let (scene, light) = one_light(&text);
            let area = PI * 0.01;
            let mut omega = 0.0;
            light.for_each_patch(&scene, Vec3::ZERO, 0.0, 0.0, &mut Rng::new(1), |s| {
                omega += s.omega;
                assert_eq!(light.emission(Vec3::ZERO, &s), Color::ONE);
            });
            let want = area / ((d + flen) * (d + flen));
            assert!((omega - want).abs() < 1e-12 * want, "{omega} vs {want}");
            let rough = light.rough_sample(&scene, Vec3::ZERO).unwrap();
            assert!((rough.omega - want).abs() < 1e-12 * want);
        }
        // Other sources are not focused.
        let (scene, light) =
            one_light("void light l 0 0 3 1 1 1\nl ring r 0 0 8 0 0 2 0 0 -1 0 0.1\n");
        let mut omega = 0.0;
        light.for_each_patch(&scene, Vec3::ZERO, 0.0, 0.0, &mut Rng::new(1), |s| {
            omega += s.omega
        });
        assert!((omega - PI * 0.01 / 4.0).abs() < 1e-15);
    }

    #[test]
    fn spot_cone() {
        assert!(spot_admits(
            Vec3::Z,
            90.0,
            Vec3::new(0.0, 0.5, 1.0).normalize()
        ));
        assert!(!spot_admits(
            Vec3::Z,
            90.0,
            Vec3::new(0.0, 1.5, 1.0).normalize()
        ));
    }
}
