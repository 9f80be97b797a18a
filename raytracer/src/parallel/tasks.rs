//! Everything that travels between processors: the data items, the
//! demand-driven and data-parallel tasks with their byte sizes. (The
//! results, ray-tree records keyed by [`NodeKey`], are in [`super::tree`];
//! the recorded answers of a restartable bundle in [`super::caster`].)

use hybrid_sched::serde::{Deserialize, Serialize};
use hybrid_sched::ByteSize;

use super::caster::{Answer, Replay};
use super::tree::NodeKey;
use crate::accel::{LeafObjects, NodeId, TraceCursor};
use crate::render::{RayTask, ShadowBundle};

/// One octree leaf's objects as a data item: the leaf's own copies of its
/// objects ([`LeafObjects`]), which a data reply carries (serialized, under
/// MPI) and tracing on the receiving processor reads. Caches, requests
/// and replies are accounted in the bytes the objects occupy in the scene
/// (an object listed in n leaves counts 1/n in each), not in the copies'
/// size: the accounting (and the simulated machine) prices a scene whose
/// objects travel once per leaf share.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct CellData {
    pub leaf: NodeId,
    pub bytes: u64,
    /// The leaf's objects (their count is `cell.ids().len()`).
    pub cell: LeafObjects,
}

impl ByteSize for CellData {
    fn byte_size(&self) -> usize {
        self.bytes as usize
    }
}

/// A tile: a rectangle of pixels, the renderer's [`Region`](crate::render::Region).
pub type Tile = crate::render::Region;

/// A shadow bundle scheduled demand-driven.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct ShadowJob {
    pub key: NodeKey,
    pub bundle: ShadowBundle,
}

/// Demand-driven tasks: a tile of primary rays, or the shadow bundles of
/// one shaded point that need cells their processor does not hold (one
/// task, one selection: the union of theirs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum DdTask {
    Tile(Tile),
    Shadows(Vec<ShadowJob>),
}

/// Bytes of the task's origin, which its envelope carries (the framework
/// tracks it: [`hybrid_sched::Ctx::origin`]); tasks carried it themselves before, and the
/// accounting keeps those bytes.
const ORIGIN_BYTES: usize = 8;

impl ByteSize for DdTask {
    fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>()
            + ORIGIN_BYTES
            + match self {
                DdTask::Tile(_) => 0,
                DdTask::Shadows(jobs) => jobs
                    .iter()
                    .map(|j| std::mem::size_of::<ShadowJob>() + 2 * j.key.path.len())
                    .sum(),
            }
    }
}

/// A ray migrating cell by cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct RayJob {
    pub key: NodeKey,
    pub task: RayTask,
    pub cursor: TraceCursor,
    /// The leaf it needs next (`None`: start wherever it is).
    pub next: Option<NodeId>,
}

/// A shadow bundle migrating with its recorded answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct ShadowDp {
    pub key: NodeKey,
    pub bundle: ShadowBundle,
    pub replay: Replay,
    pub next: Option<NodeId>,
}

/// Data-parallel tasks.
// Both variants travel by value between processors; a shadow bundle carries
// its medium, and boxing it would cost an allocation per task.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum DpTask {
    Ray(RayJob),
    Shadow(ShadowDp),
}

impl ByteSize for DpTask {
    fn byte_size(&self) -> usize {
        std::mem::size_of::<Self>()
            + ORIGIN_BYTES
            + match self {
                DpTask::Ray(j) => 2 * j.key.path.len(),
                DpTask::Shadow(s) => {
                    2 * s.key.path.len() + s.replay.answers.len() * std::mem::size_of::<Answer>()
                }
            }
    }
}
