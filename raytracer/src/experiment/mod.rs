//! The paper's experiments on the simulated cluster (`hybrid-rt
//! experiment`).
//!
//! Every experiment runs the hybrid renderer on the deterministic simulator
//! ([`hybrid_sched::Sim`] with [`crate::parallel::cost::model`] and a
//! [`hybrid_sched::Network`] preset) and writes, into the output
//! directory, `NAME.md` (a markdown table), `NAME.json` (every figure
//! plotted) and one or more `NAME*.svg` plots. Nothing is measured on the wall clock, so the same
//! arguments give the same files, byte for byte.
//!
//! "The paper's algorithm" is the system as published: the octree
//! distribution with equal memory, shadow tasks kept where they are spawned
//! (`local`), every shadow bundle clipped. "Ours" adds, one step at a time:
//! the clip cache (one clip per cell and light), the cost-predicted
//! distribution and the `load-aware` policy. Flow control is on in both; the
//! `flow` experiment shows what it bounds.
//!
//! `harness` holds what they share (the [`Setup`], the memoised
//! per-run runner, the output writing); each figure or table has its own
//! file; [`calibrate`] fits the simulator's cost model on this machine and
//! [`sweep`] measures what accuracy costs.

mod breakdown;
mod cache;
pub mod calibrate;
mod communication;
mod data;
mod efficiency;
mod flow;
mod harness;
mod hemispheres;
mod interreflection;
mod memory;
mod speedup;
mod states;
pub mod sweep;
mod table1;

use std::collections::BTreeMap;
use std::path::Path;

use harness::Ctx;
pub use harness::{Output, Setup};

use crate::{Error, Result};

/// Experiment names in `all` order.
pub const NAMES: [&str; 11] = [
    "table1",
    "speedup",
    "efficiency",
    "clipping",
    "idle",
    "communication",
    "data",
    "cache",
    "breakdown",
    "memory",
    "flow",
];

/// Experiments beyond the paper's, not in `all` (they need other render
/// options: `interreflection` needs `-ab`, `hemispheres` `-ab` with `-aa 0
/// -as 0`).
pub const EXTRA: [&str; 2] = ["interreflection", "hemispheres"];

/// Runs experiment `name` (or every one of [`NAMES`] for `all`), writing
/// into `out`.
pub fn run(name: &str, setup: &Setup, out: &Path) -> Result<Vec<Output>> {
    let names: Vec<&str> = if name == "all" {
        NAMES.to_vec()
    } else if NAMES.contains(&name) || EXTRA.contains(&name) {
        vec![name]
    } else {
        return Err(Error::Usage(format!(
            "unknown experiment {name:?}: expected all or one of {}, {}",
            NAMES.join(", "),
            EXTRA.join(", ")
        )));
    };
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let mut cx = Ctx {
        s: setup,
        out,
        written: Vec::new(),
        memo: BTreeMap::new(),
        seq_s: None,
    };
    for n in names {
        match n {
            "table1" => table1::table1(&mut cx)?,
            "speedup" => speedup::speedup(&mut cx)?,
            "efficiency" => efficiency::efficiency(&mut cx)?,
            "clipping" => states::clipping(&mut cx)?,
            "idle" => states::idle(&mut cx)?,
            "communication" => communication::communication(&mut cx)?,
            "data" => data::data(&mut cx)?,
            "cache" => cache::cache(&mut cx)?,
            "breakdown" => breakdown::breakdown(&mut cx)?,
            "memory" => memory::memory(&mut cx)?,
            "flow" => flow::flow(&mut cx)?,
            "interreflection" => interreflection::interreflection(&mut cx)?,
            "hemispheres" => hemispheres::hemispheres(&mut cx)?,
            _ => unreachable!("names are checked above"),
        }
    }
    Ok(cx.written)
}
