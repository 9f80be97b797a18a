//! A deterministic single-threaded runtime for tests and debugging.
//!
//! Actors run in rounds. In each round every packet in flight is delivered
//! with probability 1/2 (FIFO per link is kept, as channels and MPI keep it),
//! and every actor takes a pseudo-random number of steps. The same seed gives
//! the same run, while different seeds explore very different interleavings
//! (delayed probes, late credits, data replies overtaken by tasks), which is
//! how the termination and flow-control arguments are tested. Time is a
//! virtual counter; no cost model is applied (that is the simulator's job).

use std::collections::{HashSet, VecDeque};
use std::sync::Arc;

use super::{assemble, Node, RunReport, Runtime};
use crate::config::Config;
use crate::error::RunError;
use crate::message::{Addr, Packet};
use crate::processor::Step;
use crate::workload::Workload;

/// The lockstep runtime with its interleaving seed.
#[derive(Clone, Copy, Debug)]
pub struct Lockstep {
    /// Seed of the interleaving.
    pub seed: u64,
    /// Give up (with [`RunError::Runtime`]) after this many rounds.
    pub max_rounds: u64,
}

impl Lockstep {
    /// Lockstep runtime with `seed` and a generous round limit.
    pub fn new(seed: u64) -> Self {
        Lockstep {
            seed,
            max_rounds: 10_000_000,
        }
    }
}

impl Runtime for Lockstep {
    fn name(&self) -> &'static str {
        "lockstep"
    }

    fn run<W: Workload>(
        &self,
        workload: Arc<W>,
        config: &Config,
    ) -> Result<RunReport<W>, RunError> {
        run_lockstep(workload, config, self.seed, self.max_rounds)
    }
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // SplitMix64.
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
}

/// Runs `workload` deterministically (see the module documentation).
pub fn run_lockstep<W: Workload>(
    workload: Arc<W>,
    config: &Config,
    seed: u64,
    max_rounds: u64,
) -> Result<RunReport<W>, RunError> {
    let mut nodes = Node::build_all(&workload, config)?;
    let procs = config.procs;
    let mut rng = Rng(seed);
    let mut net: VecDeque<Packet<W>> = VecDeque::new();
    let mut done = vec![false; nodes.len()];
    let mut now = 0u64;
    for _ in 0..max_rounds {
        now += 1 + rng.next() % 500_000;
        let mut held: HashSet<(Addr, Addr)> = HashSet::new();
        let mut keep = VecDeque::with_capacity(net.len());
        while let Some(p) = net.pop_front() {
            let link = (p.from, p.to);
            if held.contains(&link) || rng.next() % 2 == 0 {
                held.insert(link);
                keep.push_back(p);
                continue;
            }
            let slot = p.to.slot(procs);
            if done[slot] {
                // Only control traffic (a late credit) may reach a finished
                // actor; a basic message would be work lost.
                if p.has_basic() {
                    return Err(RunError::Runtime(format!(
                        "{} sent {:?} to {}, which has already finished",
                        p.from, p.items, p.to
                    )));
                }
                continue;
            }
            nodes[slot].deliver(p, now);
        }
        net = keep;
        for (slot, node) in nodes.iter_mut().enumerate() {
            if done[slot] {
                continue;
            }
            for _ in 0..=rng.next() % 3 {
                let step = node.step(now)?;
                net.extend(node.take_packets(now));
                match step {
                    Step::Finished => {
                        done[slot] = true;
                        break;
                    }
                    Step::Idle => break,
                    Step::Worked(_) => {}
                }
            }
        }
        if done.iter().all(|&d| d) {
            if let Some(p) = net.iter().find(|p| p.has_basic()) {
                return Err(RunError::Runtime(format!(
                    "{:?} still in flight after termination",
                    p
                )));
            }
            let finished = nodes
                .into_iter()
                .map(|n| {
                    let addr = n.addr();
                    let (acc, stats) = n.finish();
                    (addr, acc, stats)
                })
                .collect();
            return Ok(assemble("lockstep", procs, finished, now));
        }
    }
    Err(RunError::Runtime(format!(
        "lockstep run did not terminate within {max_rounds} rounds"
    )))
}
