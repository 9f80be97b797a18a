//! Acceleration: the octree, the bounding volume hierarchy and pyramid
//! clipping.

mod bvh;
pub mod clip;
mod octree;
mod prims;

pub use bvh::{Bvh, BvhStats};
pub use clip::{ClipResult, Plane, Pyramid};
pub use octree::{
    intersect_brute_force, occluded_brute_force, Hit, LeafSpan, NodeId, NodeView, Octree,
    OctreeParams, OctreeStats, Partial, TraceCursor, MAX_DEPTH,
};

#[cfg(test)]
mod clip_tests;
#[cfg(test)]
mod tests;
