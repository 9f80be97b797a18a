//! Acceleration: the octree, partitioning and pyramid clipping.

mod bvh;
pub mod clip;
mod octree;
pub mod partition;
mod prims;

pub use bvh::{Bvh, BvhStats};
pub use clip::{ClipResult, Plane, Pyramid};
pub use octree::{
    intersect_brute_force, occluded_brute_force, Hit, LeafSpan, NodeId, NodeView, Octree,
    OctreeParams, OctreeStats, Partial, TraceCursor, MAX_DEPTH,
};
pub use partition::Partition;

#[cfg(test)]
mod clip_partition_tests;
#[cfg(test)]
mod tests;
