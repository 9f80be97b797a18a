//! Acceleration: the octree, partitioning and pyramid clipping.

mod octree;

pub use octree::{
    intersect_brute_force, occluded_brute_force, Hit, LeafSpan, NodeId, NodeView, Octree,
    OctreeParams, OctreeStats, MAX_DEPTH,
};

#[cfg(test)]
mod tests;
