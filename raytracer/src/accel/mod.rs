//! Acceleration: the octree, partitioning and pyramid clipping.

/// PLACEHOLDER: replaced by the octree work.
#[derive(Debug, Default)]
pub struct Octree {}
