//! How the octree's cells are spread over the processors: the choice
//! ([`Distribution`]); the cut itself is [`super::partition`].

use hybrid_sched::serde::{Deserialize, Serialize};

use super::partition::Partition;
use crate::accel::NodeId;
use crate::render::Renderer;

/// [`subtree_owners`]: no non-empty leaf below.
pub(super) const EMPTY: u32 = u32::MAX - 1;
/// [`subtree_owners`]: several owners below.
pub(super) const MIXED: u32 = u32::MAX;

/// How the octree's objects are spread over the processors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Distribution {
    /// The paper's: the octree cut near the root into pieces of equal cost.
    Octree,
    /// The worst case: processor 0 holds everything.
    Worst,
    /// Beyond the paper: the same cut, with each cell weighted by its
    /// predicted work (see [`super::predict`]) instead of its objects, so
    /// processors get equal work rather than equal memory.
    Predicted,
    /// Every processor holds the whole scene (under the threads runtime one
    /// shared copy; under MPI a copy per rank): nothing is selected,
    /// fetched or cached, only the work is scheduled: tiles on demand, each
    /// traced whole. The mode for a scene that fits one machine; the others
    /// emulate or use distributed memory.
    Replicated,
}

impl std::str::FromStr for Distribution {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "octree" | "balanced" => Ok(Distribution::Octree),
            "worst" | "worst-case" | "one" => Ok(Distribution::Worst),
            "predicted" | "cost-predicted" | "work" => Ok(Distribution::Predicted),
            "replicated" | "shared" => Ok(Distribution::Replicated),
            _ => Err(format!(
                "unknown distribution {s:?}: expected octree, predicted, replicated or worst"
            )),
        }
    }
}

impl std::fmt::Display for Distribution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Distribution::Octree => "octree",
            Distribution::Worst => "worst",
            Distribution::Predicted => "predicted",
            Distribution::Replicated => "replicated",
        })
    }
}

/// The cut of the octree's cells for `procs` processors under `d`
/// (`predicted`: subtree costs, [`Distribution::Predicted`] only).
pub(super) fn partition_for(
    renderer: &Renderer<'static>,
    d: Distribution,
    procs: usize,
    predicted: &[u64],
) -> Partition {
    let scene = renderer.scene();
    // A processor's part of a distributed scene counts its resident bytes
    // from the objects it reads (see `RtWorkload::read_part`).
    let objects: &[crate::geometry::Object] = match scene.distributed {
        None => &scene.objects,
        Some(_) => &[],
    };
    let octree = renderer.octree();
    let procs = u32::try_from(procs.max(1)).unwrap_or(u32::MAX);
    match d {
        // Replicated: the memory cut, for the per-processor report only.
        Distribution::Octree | Distribution::Replicated => Partition::new(octree, objects, procs),
        Distribution::Worst => Partition::worst_case(octree, objects, procs),
        Distribution::Predicted => Partition::by_cost(octree, objects, procs, predicted),
    }
}

/// Per node: the one processor owning every non-empty leaf below it,
/// [`EMPTY`] if there is none, [`MIXED`] if several own some.
pub(super) fn subtree_owners(renderer: &Renderer<'static>, part: &Partition) -> Vec<u32> {
    let octree = renderer.octree();
    let n = octree.node_count();
    let mut out = vec![EMPTY; n];
    // Children always have larger ids than their parent.
    for id in (0..n as NodeId).rev() {
        out[id as usize] = match octree.children(id) {
            None if octree.leaf_objects(id).is_empty() => EMPTY,
            None => part.owner(id),
            Some(ch) => ch
                .iter()
                .fold(EMPTY, |acc, &c| match (acc, out[c as usize]) {
                    (a, EMPTY) => a,
                    (EMPTY, b) => b,
                    (a, b) if a == b => a,
                    _ => MIXED,
                }),
        };
    }
    out
}
