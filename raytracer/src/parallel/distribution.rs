//! How the octree's cells are spread over the processors: the choice
//! ([`Distribution`]); the cut itself is [`super::partition`].

use hybrid_sched::serde::{Deserialize, Serialize};

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
