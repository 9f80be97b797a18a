//! Acceleration over a scene: the octree and pyramid clipping (the
//! bounding volume hierarchy, which instances hold, is in [`crate::geometry`]).

mod cell_table;
mod cells;
pub mod clip;
#[cfg(feature = "embree")]
pub mod embree;
mod local;
mod octree;
mod rank;

pub use crate::geometry::{Bvh, BvhStats, Hit};
pub use cell_table::CellTable;
pub use cells::{
    copy_bytes, object_bytes, share_copies_in_process, HeldObject, LeafObjects, ObjectCopies,
};
pub use clip::{ClipResult, Plane, Pyramid};
pub use local::{
    Grown, GrownKernel, GrownSlot, Hierarchy, HierarchyObjects, Judged, LocalIds, LocalKernel,
    NodeSet, ProcessorKernel,
};
pub use octree::{
    intersect_brute_force, occluded_brute_force, LeafSpan, NodeId, NodeTest, NodeView, Octree,
    OctreeParams, OctreeStats, Partial, SkeletonNode, TraceCursor, MAX_DEPTH,
};
pub use rank::RankedSet;

#[cfg(test)]
mod clip_tests;
#[cfg(test)]
mod local_tests;
#[cfg(test)]
mod tests;
