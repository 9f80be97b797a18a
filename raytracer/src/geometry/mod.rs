//! Rays, bounds and primitive shapes, all in double precision.
//!
//! Conventions: world space is right-handed; `Ray::dir` is unit length;
//! intersection distances are along `dir`, so `t` is a distance in scene
//! units. Surface normals returned by intersection routines are unit length
//! and point to the side the primitive's orientation calls "front" (for a
//! Radiance polygon: the side from which its vertices appear counter-clockwise).

mod aabb;
mod bvh;
pub(crate) mod prims;
mod ray;
pub mod rng;
pub mod robust;
pub mod shape;
mod shape_impl;
mod tessellate;
mod transform;
mod triangulate;
mod tripair;

pub use aabb::Aabb;
pub(crate) use bvh::PerRay;
pub use bvh::{Bvh, BvhStats, Segment, PACKET};
pub use ray::{PreparedRay, Ray};
pub use robust::{offset_origin, offset_origin_scaled, FTINY};
pub use shape::{
    Hit, Instance, InstanceGeometry, MaterialId, Object, ObjectId, ObjectIndex, ObjectSet,
    ObjectTable, Polygon, Shape, ShapeHit, Transform,
};
pub(crate) use shape_impl::sphere_normal;
pub use shape_impl::{
    intersect_cone, intersect_cone_consts, intersect_polygon, intersect_ring, intersect_sphere,
    intersect_triangle, ConeConsts, PLANARITY_TOLERANCE,
};
pub use tessellate::tessellate;

/// Double-precision vector used for all geometry.
pub type Vec3 = glam::DVec3;

/// RGB radiometric colour (Radiance's units: watts/sr/m^2 per channel).
pub type Color = glam::DVec3;

#[cfg(test)]
mod packet_tests;
#[cfg(test)]
mod tests;
