//! Constructors, bounds and intersection for [`Shape`].
//! PLACEHOLDER signatures: the geometry work replaces the bodies.

use super::shape::{Shape, ShapeHit};
use super::{Aabb, Ray, Vec3};

impl Shape {
    /// Validated polygon (>= 3 vertices, finite, non-degenerate), triangulated.
    pub fn polygon(vertices: Vec<Vec3>) -> Result<Shape, String> {
        let _ = vertices;
        Err("polygon: not implemented yet".into())
    }

    /// World-space bounds.
    pub fn bounds(&self) -> Aabb {
        Aabb::EMPTY
    }

    /// Nearest hit with `tmin < t < tmax`.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<ShapeHit> {
        let _ = (ray, tmin, tmax);
        None
    }
}
