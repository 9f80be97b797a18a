//! Shapes as triangles: what a triangle-only kernel (Embree, in the
//! benchmark that measures this project's hierarchy against it) is given.
//!
//! Polygons contribute their triangulation exactly; spheres, cones and
//! rings are replaced by inscribed triangle meshes of `segments` steps
//! around (a sphere also `segments / 2` steps from pole to pole);
//! instances contribute their geometry's triangles in world space.
//! Nothing is left out. The renderer never uses this: its curved surfaces
//! stay exact.

use super::shape::Shape;
use super::Vec3;

/// Two unit vectors perpendicular to the unit vector `n` and to each other.
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x.abs() < 0.6 { Vec3::X } else { Vec3::Y };
    let u = n.cross(a).normalize();
    (u, n.cross(u))
}

/// Appends the triangles of `shape` to `out` (see the module's note).
/// `segments` is clamped to at least 3.
pub fn tessellate(shape: &Shape, segments: usize, out: &mut Vec<[Vec3; 3]>) {
    let k = segments.max(3);
    let angle = |i: usize| std::f64::consts::TAU * (i % k) as f64 / k as f64;
    match shape {
        Shape::Polygon(p) => out.extend_from_slice(&p.tri_verts),
        Shape::Sphere { center, radius, .. } => {
            let rows = (k / 2).max(2);
            let at = |i: usize, j: usize| {
                let th = std::f64::consts::PI * j as f64 / rows as f64;
                let ph = angle(i);
                *center + *radius * Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
            };
            for j in 0..rows {
                for i in 0..k {
                    let (a, b) = (at(i, j), at(i + 1, j));
                    let (c, d) = (at(i, j + 1), at(i + 1, j + 1));
                    // The poles' rows are fans: one triangle per step.
                    if j > 0 {
                        out.push([a, c, b]);
                    }
                    if j + 1 < rows {
                        out.push([b, c, d]);
                    }
                }
            }
        }
        Shape::Cone { p0, p1, r0, r1, .. } => {
            let (u, v) = basis((*p1 - *p0).normalize());
            let at = |p: Vec3, r: f64, i: usize| p + r * (angle(i).cos() * u + angle(i).sin() * v);
            for i in 0..k {
                let (a, b) = (at(*p0, *r0, i), at(*p0, *r0, i + 1));
                let (c, d) = (at(*p1, *r1, i), at(*p1, *r1, i + 1));
                if *r0 > 0.0 {
                    out.push([a, b, c]);
                }
                if *r1 > 0.0 {
                    out.push([b, d, c]);
                }
            }
        }
        Shape::Ring {
            center,
            normal,
            r_inner,
            r_outer,
        } => {
            let (u, v) = basis(*normal);
            let at = |r: f64, i: usize| *center + r * (angle(i).cos() * u + angle(i).sin() * v);
            for i in 0..k {
                let (a, b) = (at(*r_outer, i), at(*r_outer, i + 1));
                if *r_inner > 0.0 {
                    let (c, d) = (at(*r_inner, i), at(*r_inner, i + 1));
                    out.push([a, b, c]);
                    out.push([b, d, c]);
                } else {
                    out.push([a, b, *center]);
                }
            }
        }
        Shape::Instance(inst) => {
            let mut local = Vec::new();
            for o in &inst.geometry.objects {
                local.clear();
                tessellate(&o.shape, segments, &mut local);
                out.extend(local.iter().map(|t| t.map(|p| inst.transform.point(p))));
            }
        }
    }
}
