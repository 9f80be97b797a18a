//! Constructors, bounds, intersection, areas and sampling for [`Shape`].
//!
//! Intersection is watertight for polygons (Woop, Benthin and Wald 2013,
//! "Watertight Ray/Triangle Intersection", with an exact-sign fallback for
//! edge functions that evaluate to zero) and numerically stable for the
//! quadrics (origin shifted to the point of the ray nearest the shape, the
//! discriminant computed from a perpendicular distance or with an error-free
//! difference of products, and the stable root formula).

use std::f64::consts::PI;
use std::sync::Arc;

use super::robust::{diff_of_products, orthonormal_basis};
use super::shape::{
    Hit, Instance, InstanceGeometry, MeshShading, Polygon, Shape, ShapeHit, Transform,
};
use super::triangulate::{ear_clip, project};
use super::{Aabb, PreparedRay, Ray, Vec3};

/// Largest distance of a polygon vertex from the polygon's plane, relative
/// to the polygon's size (its bounding-box diagonal), that is still accepted
/// as planar.
pub const PLANARITY_TOLERANCE: f64 = 1e-3;

fn finite(v: Vec3) -> bool {
    v.is_finite()
}

fn fmt_v(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

impl Shape {
    /// Validated polygon: at least three distinct vertices (duplicate
    /// consecutive vertices, including a closing copy of the first, are
    /// dropped), finite coordinates, non-zero area, planar within
    /// [`PLANARITY_TOLERANCE`] of its size. The normal follows the vertex
    /// order (Newell's method); the polygon is triangulated by ear clipping in
    /// its plane, every triangle wound like the polygon.
    pub fn polygon(vertices: Vec<Vec3>) -> Result<Shape, String> {
        if vertices.len() < 3 {
            return Err(format!(
                "polygon needs at least 3 vertices, got {}",
                vertices.len()
            ));
        }
        if let Some((i, v)) = vertices.iter().enumerate().find(|(_, v)| !finite(**v)) {
            return Err(format!(
                "polygon vertex {} is not finite: {}",
                i + 1,
                fmt_v(*v)
            ));
        }
        let mut vs: Vec<Vec3> = Vec::with_capacity(vertices.len());
        for v in vertices {
            if vs.last() != Some(&v) {
                vs.push(v);
            }
        }
        while vs.len() > 1 && vs.first() == vs.last() {
            vs.pop();
        }
        if vs.len() < 3 {
            return Err(format!(
                "polygon has only {} distinct vertices (at least 3 needed)",
                vs.len()
            ));
        }
        let bounds = Aabb::from_points(vs.iter().copied());
        let size = bounds.extent().length();
        let c = bounds.center();
        let n = vs.len();
        let mut newell = Vec3::ZERO;
        for i in 0..n {
            newell += (vs[i] - c).cross(vs[(i + 1) % n] - c);
        }
        let nl = newell.length();
        if !nl.is_finite() || nl <= 1e-12 * size * size {
            return Err("degenerate polygon: zero area (collinear or coincident vertices)".into());
        }
        let normal = newell / nl;
        let centroid = vs.iter().fold(Vec3::ZERO, |s, v| s + (*v - c)) / n as f64;
        let (worst, dev) = vs
            .iter()
            .map(|v| (*v - c - centroid).dot(normal).abs())
            .enumerate()
            .fold(
                (0, 0.0f64),
                |(bi, bd), (i, d)| if d > bd { (i, d) } else { (bi, bd) },
            );
        if dev > PLANARITY_TOLERANCE * size {
            return Err(format!(
                "polygon is not planar: vertex {} lies {dev:.3e} off the polygon's plane (polygon size {size:.3e})",
                worst + 1
            ));
        }
        let triangles = ear_clip(&project(&vs, normal));
        let mut cdf = Vec::with_capacity(triangles.len());
        let mut area = 0.0;
        for t in &triangles {
            let (a, b, cc) = (vs[t[0] as usize], vs[t[1] as usize], vs[t[2] as usize]);
            area += 0.5 * (b - a).cross(cc - a).length();
            cdf.push(area);
        }
        if triangles.is_empty() || area.is_nan() || area <= 0.0 {
            return Err("degenerate polygon: zero area after triangulation".into());
        }
        for x in &mut cdf {
            *x /= area;
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let tri_verts = triangles
            .iter()
            .map(|t| [vs[t[0] as usize], vs[t[1] as usize], vs[t[2] as usize]])
            .collect();
        Ok(Shape::Polygon(Polygon {
            vertices: vs.into_boxed_slice(),
            normal,
            triangles: triangles.into_boxed_slice(),
            tri_verts,
            area,
            cdf: cdf.into_boxed_slice(),
        }))
    }

    /// Validated sphere (`radius > 0`, finite). `inward` flips the normal (Radiance `bubble`).
    pub fn sphere(center: Vec3, radius: f64, inward: bool) -> Result<Shape, String> {
        if !finite(center) {
            return Err(format!("sphere centre is not finite: {}", fmt_v(center)));
        }
        if !radius.is_finite() || radius <= 0.0 {
            return Err(format!(
                "sphere radius must be positive and finite, got {radius}"
            ));
        }
        Ok(Shape::Sphere {
            center,
            radius,
            inward,
        })
    }

    /// Validated truncated cone (a cylinder when `r0 == r1`), open ended.
    /// Radii must be non-negative and not both zero; the axis must have
    /// non-zero length. `inward` flips the normal (Radiance `cup`, `tube`).
    pub fn cone(p0: Vec3, p1: Vec3, r0: f64, r1: f64, inward: bool) -> Result<Shape, String> {
        if !finite(p0) || !finite(p1) {
            return Err(format!(
                "cone end points are not finite: {} {}",
                fmt_v(p0),
                fmt_v(p1)
            ));
        }
        if !r0.is_finite() || !r1.is_finite() || r0 < 0.0 || r1 < 0.0 {
            return Err(format!(
                "cone radii must be non-negative and finite, got {r0} and {r1}"
            ));
        }
        if r0 == 0.0 && r1 == 0.0 {
            return Err("cone radii are both zero".into());
        }
        let h = (p1 - p0).length();
        let mag = p0.abs().max(p1.abs()).max_element();
        if h.is_nan() || h <= 1e-12 * mag || h == 0.0 {
            return Err(format!(
                "zero-length cone axis: {} to {}",
                fmt_v(p0),
                fmt_v(p1)
            ));
        }
        Ok(Shape::Cone {
            p0,
            p1,
            r0,
            r1,
            inward,
        })
    }

    /// Validated ring (disk when `r_inner == 0`): non-zero normal (normalised
    /// here), `0 <= r_inner < r_outer`.
    pub fn ring(center: Vec3, normal: Vec3, r_inner: f64, r_outer: f64) -> Result<Shape, String> {
        if !finite(center) || !finite(normal) {
            return Err(format!(
                "ring centre or normal is not finite: {} {}",
                fmt_v(center),
                fmt_v(normal)
            ));
        }
        let l = normal.length();
        if !l.is_finite() || l <= 0.0 {
            return Err("ring normal has zero length".into());
        }
        if !r_inner.is_finite() || !r_outer.is_finite() || r_inner < 0.0 {
            return Err(format!(
                "ring radii must be non-negative and finite, got {r_inner} and {r_outer}"
            ));
        }
        if r_outer <= r_inner {
            return Err(format!(
                "ring outer radius {r_outer} must exceed inner radius {r_inner}"
            ));
        }
        Ok(Shape::Ring {
            center,
            normal: normal / l,
            r_inner,
            r_outer,
        })
    }

    /// A transformed reference to shared geometry.
    pub fn instance(
        geometry: Arc<InstanceGeometry>,
        transform: Transform,
    ) -> Result<Shape, String> {
        if !transform.is_finite() || transform.scale <= 0.0 {
            return Err(format!(
                "instance '{}': transform is not finite or has non-positive scale",
                geometry.name
            ));
        }
        Ok(Shape::Instance(Box::new(Instance {
            geometry,
            transform,
        })))
    }

    /// World-space bounds (tight for polygons and spheres, conservative for
    /// cones, rings and instances).
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Polygon(p) => Aabb::from_points(p.vertices.iter().copied()),
            Shape::Sphere { center, radius, .. } => Aabb::new(*center - *radius, *center + *radius),
            Shape::Cone { p0, p1, r0, r1, .. } => {
                let a = (*p1 - *p0).normalize();
                let e = disk_extent(a);
                Aabb::new(*p0 - e * *r0, *p0 + e * *r0)
                    .union(Aabb::new(*p1 - e * *r1, *p1 + e * *r1))
            }
            Shape::Ring {
                center,
                normal,
                r_outer,
                ..
            } => {
                let e = disk_extent(*normal) * *r_outer;
                Aabb::new(*center - e, *center + e)
            }
            Shape::Instance(inst) => transform_bounds(&inst.transform, &inst.geometry.bounds),
        }
    }

    /// Nearest hit with `tmin < t < tmax`. Prepares the ray; use
    /// [`Shape::intersect_prepared`] when testing many shapes with one ray.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<ShapeHit> {
        self.intersect_prepared(&PreparedRay::new(ray), tmin, tmax)
    }

    /// Nearest hit with `tmin < t < tmax` for a prepared ray.
    #[inline]
    pub fn intersect_prepared(&self, pre: &PreparedRay, tmin: f64, tmax: f64) -> Option<ShapeHit> {
        match self {
            Shape::Polygon(p) => {
                let t = intersect_polygon(pre, p, tmin, tmax)?;
                Some(ShapeHit {
                    t,
                    normal: p.normal,
                    inner: None,
                    surface: None,
                })
            }
            Shape::Sphere {
                center,
                radius,
                inward,
            } => {
                let t = intersect_sphere(&pre.ray, *center, *radius, tmin, tmax)?;
                let n = sphere_normal(pre.ray.at(t), *center, *inward);
                Some(ShapeHit {
                    t,
                    normal: n,
                    inner: None,
                    surface: None,
                })
            }
            Shape::Cone {
                p0,
                p1,
                r0,
                r1,
                inward,
            } => {
                let (t, n) = intersect_cone(&pre.ray, *p0, *p1, *r0, *r1, tmin, tmax)?;
                Some(ShapeHit {
                    t,
                    normal: if *inward { -n } else { n },
                    inner: None,
                    surface: None,
                })
            }
            Shape::Ring {
                center,
                normal,
                r_inner,
                r_outer,
            } => {
                let t = intersect_ring(&pre.ray, *center, *normal, *r_inner, *r_outer, tmin, tmax)?;
                Some(ShapeHit {
                    t,
                    normal: *normal,
                    inner: None,
                    surface: None,
                })
            }
            Shape::Instance(inst) => {
                let (r, k) = inst.transform.ray_to_object(&pre.ray);
                let g = &inst.geometry;
                let h = g.accel.intersect(&g.objects, &r, tmin * k, tmax * k)?;
                let t = h.t / k;
                if !(t > tmin && t < tmax) {
                    return None;
                }
                Some(ShapeHit {
                    t,
                    normal: inst.transform.normal(h.normal),
                    inner: Some(h.object),
                    surface: Some(if g.modified_instances.binary_search(&h.object).is_ok() {
                        Hit::surface_word(g.objects[h.object as usize].material, h.flat())
                    } else {
                        h.surface
                    }),
                })
            }
        }
    }

    /// True if the shape has any hit with `tmin < t < tmax` (shadow rays).
    #[inline]
    pub fn occludes_prepared(&self, pre: &PreparedRay, tmin: f64, tmax: f64) -> bool {
        match self {
            Shape::Polygon(p) => p.triangles.iter().any(|tri| {
                let v = &p.vertices;
                intersect_triangle(
                    pre,
                    v[tri[0] as usize],
                    v[tri[1] as usize],
                    v[tri[2] as usize],
                    tmin,
                    tmax,
                )
                .is_some()
            }),
            Shape::Instance(inst) => {
                let (r, k) = inst.transform.ray_to_object(&pre.ray);
                let g = &inst.geometry;
                g.accel.occluded(&g.objects, &r, tmin * k, tmax * k, None)
            }
            _ => self.intersect_prepared(pre, tmin, tmax).is_some(),
        }
    }

    /// Heap bytes owned by the shape itself (a polygon's vertex, triangle
    /// and sampling arrays). Instanced geometry is shared and not counted.
    pub fn heap_bytes(&self) -> usize {
        match self {
            Shape::Polygon(p) => {
                std::mem::size_of_val(&*p.vertices)
                    + std::mem::size_of_val(&*p.triangles)
                    + std::mem::size_of_val(&*p.tri_verts)
                    + std::mem::size_of_val(&*p.cdf)
            }
            _ => 0,
        }
    }

    /// Surface area (instances: the area of the transformed geometry).
    pub fn area(&self) -> f64 {
        match self {
            Shape::Polygon(p) => p.area,
            Shape::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Shape::Cone { p0, p1, r0, r1, .. } => {
                let h = (*p1 - *p0).length();
                PI * (r0 + r1) * ((r1 - r0) * (r1 - r0) + h * h).sqrt()
            }
            Shape::Ring {
                r_inner, r_outer, ..
            } => PI * (r_outer - r_inner) * (r_outer + r_inner),
            Shape::Instance(inst) => {
                let s = inst.transform.scale;
                inst.geometry.area() * s * s
            }
        }
    }

    /// A point on the surface and its unit normal, uniformly distributed by
    /// area for `(u, v)` uniform in `[0, 1)^2`.
    pub fn sample(&self, u: f64, v: f64) -> (Vec3, Vec3) {
        match self {
            Shape::Polygon(p) => {
                let i = p
                    .cdf
                    .partition_point(|&c| c <= u)
                    .min(p.triangles.len() - 1);
                let lo = if i == 0 { 0.0 } else { p.cdf[i - 1] };
                let w = p.cdf[i] - lo;
                let u = if w > 0.0 {
                    ((u - lo) / w).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                let tri = p.triangles[i];
                let (a, b, c) = (
                    p.vertices[tri[0] as usize],
                    p.vertices[tri[1] as usize],
                    p.vertices[tri[2] as usize],
                );
                let su = u.sqrt();
                let (b0, b1) = (1.0 - su, v * su);
                (a * b0 + b * b1 + c * (1.0 - b0 - b1), p.normal)
            }
            Shape::Sphere {
                center,
                radius,
                inward,
            } => {
                let z = 1.0 - 2.0 * u;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (s, c) = (2.0 * PI * v).sin_cos();
                let n = Vec3::new(r * c, r * s, z);
                (*center + n * *radius, if *inward { -n } else { n })
            }
            Shape::Cone {
                p0,
                p1,
                r0,
                r1,
                inward,
            } => {
                let axis = *p1 - *p0;
                let h = axis.length();
                let a = axis / h;
                // Area density is proportional to the radius: r(s)^2 is uniform in u.
                let r = (r0 * r0 + u * (r1 - r0) * (r1 + r0)).max(0.0).sqrt();
                let denom = r0 + r;
                let s = if denom > 0.0 {
                    u * h * (r0 + r1) / denom
                } else {
                    0.0
                };
                let (tx, ty) = orthonormal_basis(a);
                let (sn, cs) = (2.0 * PI * v).sin_cos();
                let radial = tx * cs + ty * sn;
                let k = (r1 - r0) / h;
                let n = (radial - a * k).normalize();
                (*p0 + a * s + radial * r, if *inward { -n } else { n })
            }
            Shape::Ring {
                center,
                normal,
                r_inner,
                r_outer,
            } => {
                let r = (r_inner * r_inner + u * (r_outer - r_inner) * (r_outer + r_inner)).sqrt();
                let (tx, ty) = orthonormal_basis(*normal);
                let (sn, cs) = (2.0 * PI * v).sin_cos();
                (*center + (tx * cs + ty * sn) * r, *normal)
            }
            Shape::Instance(inst) => {
                let g = &inst.geometry;
                let total = g.area();
                let target = u * total;
                let mut acc = 0.0;
                let mut chosen = None;
                for o in &g.objects {
                    let a = o.shape.area();
                    if a > 0.0 {
                        chosen = Some((o, acc, a));
                        if acc + a > target {
                            break;
                        }
                    }
                    acc += a;
                }
                let Some((o, lo, a)) = chosen else {
                    return (inst.transform.point(g.bounds.center()), Vec3::Z);
                };
                let u = ((target - lo) / a).clamp(0.0, 1.0 - f64::EPSILON);
                let (p, n) = o.shape.sample(u, v);
                (inst.transform.point(p), inst.transform.normal(n))
            }
        }
    }

    /// Unit surface normal at a point on (or very near) the surface, oriented
    /// like the shape. `None` for instances (use the hit's normal).
    pub fn normal_at(&self, p: Vec3) -> Option<Vec3> {
        match self {
            Shape::Polygon(poly) => Some(poly.normal),
            Shape::Sphere { center, inward, .. } => Some(sphere_normal(p, *center, *inward)),
            Shape::Cone {
                p0,
                p1,
                r0,
                r1,
                inward,
            } => {
                let axis = *p1 - *p0;
                let h = axis.length();
                let a = axis / h;
                let w = p - *p0;
                let s = w.dot(a);
                let k = (r1 - r0) / h;
                let perp = w - a * s;
                let n = (perp - a * ((r0 + k * s) * k)).normalize();
                Some(if *inward { -n } else { n })
            }
            Shape::Ring { normal, .. } => Some(*normal),
            Shape::Instance(_) => None,
        }
    }

    /// Conservative test whether the surface may intersect the box `b` (the
    /// caller enlarges `b` by its rounding margin). Used by the octree build.
    pub fn overlaps_box(&self, b: &Aabb) -> bool {
        self.bounds().overlaps(b) && self.overlaps_box_within_bounds(b)
    }

    /// [`Shape::overlaps_box`] where the caller has found that the shape's
    /// bounds overlap `b` (the octree's build keeps every object's bounds:
    /// a polygon's, a pass over its vertices, were computed again for
    /// each of the 8 children of every cell it was a candidate in).
    pub(crate) fn overlaps_box_within_bounds(&self, b: &Aabb) -> bool {
        let c = b.center();
        let h = b.extent() * 0.5;
        match self {
            Shape::Polygon(p) => p.triangles.iter().any(|t| {
                tri_box_overlap(
                    c,
                    h,
                    p.vertices[t[0] as usize],
                    p.vertices[t[1] as usize],
                    p.vertices[t[2] as usize],
                )
            }),
            Shape::Sphere { center, radius, .. } => {
                // Surface meets the box iff nearest point is inside and farthest outside.
                let d = (*center - c).abs();
                let near = (d - h).max(Vec3::ZERO).length_squared();
                let far = (d + h).length_squared();
                let r2 = radius * radius;
                near <= r2 && far >= r2
            }
            Shape::Ring { center, normal, .. } => {
                // The plane must cut the box.
                let r = h.dot(normal.abs());
                (normal.dot(c - *center)).abs() <= r
            }
            Shape::Cone { .. } | Shape::Instance(_) => true,
        }
    }
}

impl MeshShading {
    /// Barycentric weights of `p` (object space, in the triangle's plane)
    /// in triangle `k`, `None` for a degenerate triangle.
    fn weights(&self, k: usize, p: Vec3) -> Option<([usize; 3], [f64; 3])> {
        let t = self.triangles.get(k)?;
        let v = t.map(|i| i as usize);
        let [a, b, c] = v.map(|i| self.positions[i]);
        let n = (b - a).cross(c - a);
        let den = n.length_squared();
        if !(den > 0.0 && den.is_finite()) {
            return None;
        }
        let w0 = (b - p).cross(c - p).dot(n) / den;
        let w1 = (c - p).cross(a - p).dot(n) / den;
        Some((v, [w0, w1, 1.0 - w0 - w1]))
    }

    /// The interpolated unit normal (object space) and (u, v) at `p` on
    /// triangle `k`, as Radiance's `o_mesh` computes them.
    pub fn at(&self, k: usize, p: Vec3) -> (Option<Vec3>, Option<[f64; 2]>) {
        let Some((v, w)) = self.weights(k, p) else {
            return (None, None);
        };
        let n = self.normals.as_ref().and_then(|ns| {
            let n = ns[v[0]] * w[0] + ns[v[1]] * w[1] + ns[v[2]] * w[2];
            let len = n.length();
            (len > 0.0 && len.is_finite()).then(|| n / len)
        });
        let uv = self.uv.as_ref().map(|uv| {
            [
                uv[v[0]][0] * w[0] + uv[v[1]][0] * w[1] + uv[v[2]][0] * w[2],
                uv[v[0]][1] * w[0] + uv[v[1]][1] * w[1] + uv[v[2]][1] * w[2],
            ]
        });
        (n, uv)
    }
}

impl InstanceGeometry {
    /// Total surface area of the geometry in object space.
    pub fn area(&self) -> f64 {
        self.objects.iter().map(|o| o.shape.area()).sum()
    }
}

/// Half-extent per unit radius of a disk with unit normal `n`.
fn disk_extent(n: Vec3) -> Vec3 {
    let n2 = n * n;
    Vec3::new(
        (1.0 - n2.x).max(0.0).sqrt(),
        (1.0 - n2.y).max(0.0).sqrt(),
        (1.0 - n2.z).max(0.0).sqrt(),
    )
}

/// Bounds of a transformed box (all eight corners).
pub(crate) fn transform_bounds(t: &Transform, b: &Aabb) -> Aabb {
    if b.is_empty() {
        return Aabb::EMPTY;
    }
    let mut out = Aabb::EMPTY;
    for p in b.corners() {
        out = out.grow(t.point(p));
    }
    // Rounding of the matrix product: widen by a few ulps of the magnitude.
    let pad = out.magnitude() * 8.0 * f64::EPSILON;
    Aabb::new(out.min - pad, out.max + pad)
}

#[inline]
pub(crate) fn sphere_normal(p: Vec3, center: Vec3, inward: bool) -> Vec3 {
    let n = (p - center).normalize();
    if inward {
        -n
    } else {
        n
    }
}

/// Watertight ray/triangle test (Woop, Benthin, Wald 2013). Returns `t` with
/// `tmin < t < tmax`. Two triangles sharing an edge (same vertex values)
/// evaluate that edge's function to exactly opposite values, so a ray through
/// the edge hits at least one of them; exact zeros are re-evaluated with an
/// error-free difference of products, whose sign is exact.
#[inline]
pub fn intersect_triangle(
    pre: &PreparedRay,
    a: Vec3,
    b: Vec3,
    c: Vec3,
    tmin: f64,
    tmax: f64,
) -> Option<f64> {
    let o = pre.ray.origin;
    // Arrays: indexing by the runtime axis permutation without glam's
    // per-index match.
    let (a, b, c) = ((a - o).to_array(), (b - o).to_array(), (c - o).to_array());
    let (kx, ky, kz) = (pre.kx, pre.ky, pre.kz);
    let ax = a[kx] - pre.sx * a[kz];
    let ay = a[ky] - pre.sy * a[kz];
    let bx = b[kx] - pre.sx * b[kz];
    let by = b[ky] - pre.sy * b[kz];
    let cx = c[kx] - pre.sx * c[kz];
    let cy = c[ky] - pre.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = diff_of_products(cx, by, cy, bx);
        v = diff_of_products(ax, cy, ay, cx);
        w = diff_of_products(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = pre.sz * a[kz];
    let bz = pre.sz * b[kz];
    let cz = pre.sz * c[kz];
    let t = (u * az + v * bz + w * cz) / det;
    if t > tmin && t < tmax {
        Some(t)
    } else {
        None
    }
}

/// Nearest hit of a polygon's triangles.
#[inline]
pub fn intersect_polygon(pre: &PreparedRay, p: &Polygon, tmin: f64, mut tmax: f64) -> Option<f64> {
    let mut best = None;
    for [a, b, c] in &p.tri_verts {
        if let Some(t) = intersect_triangle(pre, *a, *b, *c, tmin, tmax) {
            tmax = t;
            best = Some(t);
        }
    }
    best
}

/// Nearest ray/sphere hit in `(tmin, tmax)`. The discriminant is computed from
/// the distance between the centre and the ray's point nearest to it (no
/// cancellation for distant origins), and the near root with the stable form
/// `c / q` (no cancellation when the origin lies on the sphere).
#[inline]
pub fn intersect_sphere(ray: &Ray, center: Vec3, radius: f64, tmin: f64, tmax: f64) -> Option<f64> {
    let f = ray.origin - center;
    let b = f.dot(ray.dir); // nearest point at t = -b
    let perp = f - ray.dir * b;
    let pl = perp.length();
    let disc = (radius - pl) * (radius + pl);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let fl = f.length();
    let c = (fl - radius) * (fl + radius);
    // q = -b - sign(b) * s; roots are q and c / q.
    let q = if b > 0.0 { -b - s } else { -b + s };
    let (mut t0, mut t1) = if q != 0.0 { (c / q, q) } else { (0.0, 0.0) };
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > tmin && t0 < tmax {
        Some(t0)
    } else if t1 > tmin && t1 < tmax {
        Some(t1)
    } else {
        None
    }
}

/// The per-cone constants of [`intersect_cone`] (axis length and unit
/// direction, centre, slope). Computing them once per cone and passing them
/// to [`intersect_cone_consts`] gives exactly the hits of [`intersect_cone`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeConsts {
    pub p0: Vec3,
    /// Unit axis direction.
    pub a: Vec3,
    /// Midpoint of the axis.
    pub mid: Vec3,
    /// Axis length.
    pub h: f64,
    /// Radius change per unit length along the axis.
    pub k: f64,
    pub r0: f64,
}

impl ConeConsts {
    #[inline]
    pub fn new(p0: Vec3, p1: Vec3, r0: f64, r1: f64) -> Self {
        let axis = p1 - p0;
        let h = axis.length();
        Self {
            p0,
            a: axis / h,
            mid: (p0 + p1) * 0.5,
            h,
            k: (r1 - r0) / h,
            r0,
        }
    }
}

/// Nearest ray/cone hit in `(tmin, tmax)` and the outward unit normal there
/// (outward: away from the axis). The quadratic is set up with the ray origin
/// moved to the point of the ray nearest the cone's centre.
#[inline]
pub fn intersect_cone(
    ray: &Ray,
    p0: Vec3,
    p1: Vec3,
    r0: f64,
    r1: f64,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, Vec3)> {
    intersect_cone_consts(ray, &ConeConsts::new(p0, p1, r0, r1), tmin, tmax)
}

/// [`intersect_cone`] with the cone's constants computed beforehand.
#[inline]
pub fn intersect_cone_consts(
    ray: &Ray,
    c: &ConeConsts,
    tmin: f64,
    tmax: f64,
) -> Option<(f64, Vec3)> {
    let ConeConsts {
        p0,
        a,
        mid,
        h,
        k,
        r0,
    } = *c;
    let d = ray.dir;
    let tc = (mid - ray.origin).dot(d);
    let o = ray.origin + d * tc;
    let w = o - p0;
    let ws = w.dot(a);
    let ds = d.dot(a);
    let wp = w - a * ws;
    let dp = d - a * ds;
    let r_at = r0 + k * ws;
    let qa = dp.length_squared() - k * k * ds * ds;
    let qb = wp.dot(dp) - k * ds * r_at; // half b
    let wl = wp.length();
    let qc = (wl - r_at) * (wl + r_at);
    let mut roots = [f64::NAN; 2];
    if qa == 0.0 {
        if qb == 0.0 {
            return None;
        }
        roots[0] = -qc / (2.0 * qb);
    } else {
        let disc = diff_of_products(qb, qb, qa, qc);
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let q = -(qb + sq.copysign(qb));
        roots[0] = q / qa;
        roots[1] = if q != 0.0 { qc / q } else { roots[0] };
        if roots[0] > roots[1] {
            roots.swap(0, 1);
        }
    }
    for tp in roots {
        let t = tc + tp;
        if !(t > tmin && t < tmax) {
            continue;
        }
        let s = ws + tp * ds;
        if !(0.0..=h).contains(&s) {
            continue;
        }
        let perp = wp + dp * tp;
        let n = perp - a * ((r0 + k * s) * k);
        let nl = n.length();
        if nl > 0.0 {
            return Some((t, n / nl));
        }
    }
    None
}

/// Ray/ring hit in `(tmin, tmax)`: plane through `center` with unit `normal`,
/// distance from the centre in `[r_inner, r_outer]`.
#[inline]
pub fn intersect_ring(
    ray: &Ray,
    center: Vec3,
    normal: Vec3,
    r_inner: f64,
    r_outer: f64,
    tmin: f64,
    tmax: f64,
) -> Option<f64> {
    let denom = ray.dir.dot(normal);
    if denom == 0.0 {
        return None;
    }
    let t = (center - ray.origin).dot(normal) / denom;
    if !(t > tmin && t < tmax) {
        return None;
    }
    let r2 = (ray.at(t) - center).length_squared();
    if r2 >= r_inner * r_inner && r2 <= r_outer * r_outer {
        Some(t)
    } else {
        None
    }
}

/// Triangle/box overlap by the separating axis theorem (Akenine-Möller 2001).
/// `c`, `h`: box centre and half extents.
///
/// The nine axes across an edge `e` and a box axis are `e × X = (0, e.z,
/// -e.y)`, `e × Y = (-e.z, 0, e.x)` and `e × Z = (e.y, -e.x, 0)`: each
/// projection is two products, where the general cross and dot products
/// (`tri_box_overlap_general`) make nine and add terms that are zero. For
/// finite coordinates every projection and radius is the general one's
/// bit for bit but for the sign of a zero (a zero term is `±0`, and `x +
/// ±0` is `x`; a sum of two terms does not depend on their order), which
/// no comparison here sees, so the answer is the same. Non-finite
/// coordinates (where `0 × ∞` is NaN) take the general test. The octree's
/// build spent most of its time here.
pub(crate) fn tri_box_overlap(c: Vec3, h: Vec3, v0: Vec3, v1: Vec3, v2: Vec3) -> bool {
    let (v0, v1, v2) = (v0 - c, v1 - c, v2 - c);
    if !(v0.is_finite() && v1.is_finite() && v2.is_finite() && h.is_finite()) {
        return tri_box_overlap_centred(h, v0, v1, v2);
    }
    let Some([e0, e1, e2]) = faces_and_plane_meet(h, v0, v1, v2) else {
        return false;
    };
    // Edge x axis cross products.
    let apart =
        |p0: f64, p1: f64, p2: f64, r: f64| p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r;
    for e in [e0, e1, e2] {
        let (ax, ay, az) = (e.x.abs(), e.y.abs(), e.z.abs());
        let x = |v: Vec3| e.z * v.y - e.y * v.z;
        if apart(x(v0), x(v1), x(v2), h.y * az + h.z * ay) {
            return false;
        }
        let y = |v: Vec3| e.x * v.z - e.z * v.x;
        if apart(y(v0), y(v1), y(v2), h.x * az + h.z * ax) {
            return false;
        }
        let z = |v: Vec3| e.y * v.x - e.x * v.y;
        if apart(z(v0), z(v1), z(v2), h.x * ay + h.y * ax) {
            return false;
        }
    }
    true
}

/// The box's face axes and the triangle's plane (vertices relative to the
/// box centre): `None` where one separates them, else the triangle's edges
/// (`v1 - v0`, `v2 - v1`, `v0 - v2`).
#[inline(always)]
fn faces_and_plane_meet(h: Vec3, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<[Vec3; 3]> {
    // Box face normals.
    let mn = v0.min(v1).min(v2);
    let mx = v0.max(v1).max(v2);
    if mn.cmpgt(h).any() || mx.cmplt(-h).any() {
        return None;
    }
    // Triangle plane.
    let e0 = v1 - v0;
    let e1 = v2 - v1;
    let e2 = v0 - v2;
    let n = e0.cross(e1);
    if n.dot(v0).abs() > h.dot(n.abs()) {
        return None;
    }
    Some([e0, e1, e2])
}

/// The general form of [`tri_box_overlap`] (vertices relative to the box
/// centre): full cross and dot products for every axis.
fn tri_box_overlap_centred(h: Vec3, v0: Vec3, v1: Vec3, v2: Vec3) -> bool {
    let Some([e0, e1, e2]) = faces_and_plane_meet(h, v0, v1, v2) else {
        return false;
    };
    // Edge x axis cross products.
    for e in [e0, e1, e2] {
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            let ax = e.cross(axis);
            let (p0, p1, p2) = (ax.dot(v0), ax.dot(v1), ax.dot(v2));
            let r = h.dot(ax.abs());
            if p0.min(p1).min(p2) > r || p0.max(p1).max(p2) < -r {
                return false;
            }
        }
    }
    true
}

/// [`tri_box_overlap`] through the general axes only (its tests compare
/// the two).
#[cfg(test)]
pub(crate) fn tri_box_overlap_general(c: Vec3, h: Vec3, v0: Vec3, v1: Vec3, v2: Vec3) -> bool {
    tri_box_overlap_centred(h, v0 - c, v1 - c, v2 - c)
}
