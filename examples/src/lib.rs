//! Example workloads for `hybrid-sched`.
//!
//! [`Chunks`] (module [`chunks`]) is the book's running example: the
//! smallest workload with both kinds of task, grown chapter by chapter.
//!
//! [`Blocks`] is a non-rendering workload that exercises every part of the
//! framework: data blocks owned by different processors, demand-driven tasks
//! that select a few blocks and checksum them (and spawn child tasks),
//! data-parallel tasks that hop from block owner to block owner, and results
//! merged at their destination. Its outcome is a deterministic value that any
//! parallel run must reproduce exactly.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use hybrid_sched::{
    Addr, ByteSize, Ctx, DataView, DpOutcome, Placement, RunStats, State, Workload,
};
use serde::{Deserialize, Serialize};

pub mod chunks;
pub use chunks::Chunks;

/// SplitMix64's mixer: a tiny, good-enough deterministic hash.
pub use hybrid_sched::rng::mix;

/// How blocks are spread over processors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Distribution {
    /// Block `b` on processor `b % procs`.
    RoundRobin,
    /// Contiguous ranges of blocks per processor.
    Ranges,
    /// Every block on processor 0: a data and migration hot spot (the paper's
    /// worst case of one processor holding everything).
    Hotspot,
}

/// Parameters of a [`Blocks`] workload.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlocksParams {
    /// Seed of everything.
    pub seed: u64,
    /// Number of data blocks.
    pub blocks: u32,
    /// Words per block: between `min_words` and `max_words` (inclusive).
    pub min_words: usize,
    /// See `min_words`.
    pub max_words: usize,
    /// Number of root demand-driven tasks.
    pub roots: u32,
    /// A demand-driven task selects between 1 and this many blocks.
    pub max_select: u32,
    /// Children per demand-driven task: between 0 and this many.
    pub max_children: u32,
    /// Depth limit of child tasks (roots have depth 0).
    pub max_depth: u8,
    /// Data-parallel walks per demand-driven task: between 0 and this many.
    pub max_walks: u32,
    /// Blocks a walk visits.
    pub walk_len: usize,
    /// Data placement.
    pub distribution: Distribution,
    /// Times each block is folded when it is read: scales computation
    /// relative to communication.
    pub rounds: u32,
}

impl Default for BlocksParams {
    fn default() -> Self {
        BlocksParams {
            seed: 1,
            blocks: 96,
            min_words: 16,
            max_words: 256,
            roots: 64,
            max_select: 6,
            max_children: 2,
            max_depth: 2,
            max_walks: 2,
            walk_len: 5,
            distribution: Distribution::RoundRobin,
            rounds: 1,
        }
    }
}

/// A block of data.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Block(pub Vec<u64>);

impl ByteSize for Block {
    fn byte_size(&self) -> usize {
        block_bytes(self.0.len())
    }
}

fn block_bytes(words: usize) -> usize {
    24 + 8 * words
}

/// A demand-driven task: checksum a few blocks.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlockTask {
    /// Unique key (root index in bits 24..56, child path below).
    pub key: u64,
    /// Depth in the task tree.
    pub depth: u8,
}

impl ByteSize for BlockTask {
    fn byte_size(&self) -> usize {
        16
    }
}

/// A data-parallel task.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum BlockWalk {
    /// Visit `path` in order, folding each block into `acc`.
    Walk {
        /// Unique key (bit 63 set).
        key: u64,
        /// Blocks to visit.
        path: Vec<u32>,
        /// Next position in `path`.
        pos: usize,
        /// Running value.
        acc: u64,
    },
    /// The data-parallel fallback of a demand-driven task whose blocks do not
    /// fit the cache: visit its blocks, then finish it exactly as
    /// [`Workload::execute_dd`] would have.
    Fallback {
        /// The converted task.
        task: BlockTask,
        /// Its selected blocks.
        path: Vec<u32>,
        /// Next position.
        pos: usize,
        /// Running checksum.
        acc: u64,
    },
}

impl ByteSize for BlockWalk {
    fn byte_size(&self) -> usize {
        match self {
            BlockWalk::Walk { path, .. } | BlockWalk::Fallback { path, .. } => 40 + 4 * path.len(),
        }
    }
}

/// A result: one per task, keyed by the task.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlockResult {
    /// The task that produced it.
    pub key: u64,
    /// Its value.
    pub value: u64,
}

impl ByteSize for BlockResult {
    fn byte_size(&self) -> usize {
        16
    }
}

/// Where results are merged: a wrapping checksum plus the key of every task
/// that reported (to check that every task ran exactly once).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BlocksAcc {
    /// Wrapping sum of mixed (key, value) pairs: independent of merge order.
    pub sum: u64,
    /// Results merged.
    pub count: u64,
    /// Times each task key was merged.
    pub seen: BTreeMap<u64, u32>,
}

/// The blocks workload. See the crate documentation.
#[derive(Clone, Debug)]
pub struct Blocks {
    params: BlocksParams,
    words: Vec<usize>,
}

const DP_BIT: u64 = 1 << 63;

impl Blocks {
    /// A workload with these parameters.
    pub fn new(params: BlocksParams) -> Self {
        let span = params.max_words.saturating_sub(params.min_words) as u64 + 1;
        let words = (0..params.blocks)
            .map(|b| params.min_words + (mix(params.seed ^ (u64::from(b) << 20)) % span) as usize)
            .collect();
        Blocks { params, words }
    }

    /// The parameters.
    pub fn params(&self) -> &BlocksParams {
        &self.params
    }

    /// Bytes of the largest block.
    pub fn largest_block_bytes(&self) -> usize {
        self.words
            .iter()
            .map(|&w| block_bytes(w))
            .max()
            .unwrap_or(0)
    }

    /// Bytes of the smallest block.
    pub fn smallest_block_bytes(&self) -> usize {
        self.words
            .iter()
            .map(|&w| block_bytes(w))
            .min()
            .unwrap_or(0)
    }

    /// Bytes of all blocks.
    pub fn total_bytes(&self) -> usize {
        self.words.iter().map(|&w| block_bytes(w)).sum()
    }

    fn block(&self, b: u32) -> Block {
        let base = mix(self.params.seed.wrapping_add(u64::from(b)));
        Block(
            (0..self.words[b as usize] as u64)
                .map(|i| mix(base ^ i))
                .collect(),
        )
    }

    fn owner(&self, b: u32, procs: usize) -> usize {
        match self.params.distribution {
            Distribution::RoundRobin => b as usize % procs,
            Distribution::Ranges => {
                let per = (self.params.blocks as usize).div_ceil(procs).max(1);
                (b as usize / per).min(procs - 1)
            }
            Distribution::Hotspot => 0,
        }
    }

    fn h(&self, key: u64, salt: u64) -> u64 {
        mix(key ^ mix(self.params.seed ^ salt))
    }

    /// The blocks a task reads, sorted and distinct.
    fn selection(&self, task: &BlockTask) -> Vec<u32> {
        let n = 1 + self.h(task.key, 1) % u64::from(self.params.max_select.max(1));
        let mut ids: Vec<u32> = (0..n)
            .map(|i| (self.h(task.key, 100 + i) % u64::from(self.params.blocks)) as u32)
            .collect();
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    fn fold(&self, acc: u64, id: u32, block: &Block) -> u64 {
        let mut s = 0u64;
        for _ in 0..self.params.rounds.max(1) {
            s = block.0.iter().fold(s, |a, &w| mix(a.rotate_left(7) ^ w));
        }
        acc.rotate_left(9) ^ mix(s ^ u64::from(id))
    }

    fn units(&self, block: &Block) -> u64 {
        block.0.len() as u64 * u64::from(self.params.rounds.max(1))
    }

    fn dest(&self, key: u64, procs: usize) -> Addr {
        let h = self.h(key, 7);
        if h.is_multiple_of(5) {
            Addr::Master
        } else {
            Addr::Proc((h as usize / 5) % procs)
        }
    }

    /// Everything a demand-driven task does once its checksum is known.
    fn finish_dd(&self, task: &BlockTask, checksum: u64, ctx: &mut Ctx<Self>) {
        let procs = ctx.procs();
        ctx.emit_result(
            self.dest(task.key, procs),
            BlockResult {
                key: task.key,
                value: checksum,
            },
        );
        if task.depth < self.params.max_depth {
            let n = self.h(task.key, 2) % (u64::from(self.params.max_children) + 1);
            for i in 0..n {
                ctx.spawn_dd(BlockTask {
                    key: (task.key << 3) | (i + 1),
                    depth: task.depth + 1,
                });
            }
        }
        let walks = self.h(task.key, 3) % (u64::from(self.params.max_walks) + 1);
        for w in 0..walks {
            let path = (0..self.params.walk_len as u64)
                .map(|i| {
                    (self.h(task.key, 1000 + 64 * w + i) % u64::from(self.params.blocks)) as u32
                })
                .collect();
            ctx.spawn_dp(BlockWalk::Walk {
                key: DP_BIT | (w << 56) | task.key,
                path,
                pos: 0,
                acc: checksum,
            });
        }
    }
}

hybrid_sched::work_kinds! {
    /// The work [`Blocks`] counts.
    pub enum BlocksWork {
        /// Blocks named by data selection.
        Select = "select",
        /// Checksum units of demand-driven tasks.
        Checksum = "checksum",
        /// Checksum units of data-parallel walks.
        Hop = "hop",
    }
}

impl Workload for Blocks {
    type DataId = u32;
    type DataItem = Block;
    type DdTask = BlockTask;
    type DpTask = BlockWalk;
    type Result = BlockResult;
    type Accumulator = BlocksAcc;
    type Work = BlocksWork;

    fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
        (0..self.params.blocks)
            .map(|b| Placement {
                id: b,
                owner: self.owner(b, procs),
                bytes: block_bytes(self.words[b as usize]) as u64,
            })
            .collect()
    }

    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Block)> {
        (0..self.params.blocks)
            .filter(|&b| self.owner(b, procs) == proc)
            .map(|b| (b, self.block(b)))
            .collect()
    }

    fn root_tasks(&self, _procs: usize) -> Vec<BlockTask> {
        (0..self.params.roots)
            .map(|r| BlockTask {
                key: u64::from(r) << 24,
                depth: 0,
            })
            .collect()
    }

    fn select_data(&self, task: &BlockTask, ctx: &mut Ctx<Self>) -> Vec<u32> {
        let ids = self.selection(task);
        ctx.charge(BlocksWork::Select, ids.len() as u64);
        ids
    }

    fn execute_dd(&self, task: BlockTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let mut acc = task.key;
        for id in self.selection(&task) {
            let block = data
                .get(&id)
                .expect("the framework provides all selected data");
            ctx.charge(BlocksWork::Checksum, self.units(block));
            acc = self.fold(acc, id, block);
        }
        self.finish_dd(&task, acc, ctx);
    }

    fn to_data_parallel(&self, task: BlockTask, ctx: &mut Ctx<Self>) {
        let path = self.selection(&task);
        ctx.spawn_dp(BlockWalk::Fallback {
            acc: task.key,
            task,
            path,
            pos: 0,
        });
    }

    fn route_dp(&self, task: &BlockWalk) -> Option<u32> {
        match task {
            BlockWalk::Walk { path, pos, .. } | BlockWalk::Fallback { path, pos, .. } => {
                path.get(*pos).copied()
            }
        }
    }

    fn execute_dp(
        &self,
        mut task: BlockWalk,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<BlockWalk> {
        let (path, pos, acc) = match &mut task {
            BlockWalk::Walk { path, pos, acc, .. } | BlockWalk::Fallback { path, pos, acc, .. } => {
                (path, pos, acc)
            }
        };
        while let Some(&id) = path.get(*pos) {
            let Some(block) = data.get(&id) else {
                return DpOutcome::Migrate(task);
            };
            ctx.charge(BlocksWork::Hop, self.units(block));
            *acc = self.fold(*acc, id, block);
            *pos += 1;
        }
        match task {
            BlockWalk::Walk { key, acc, .. } => {
                let dest = self.dest(key, ctx.procs());
                ctx.emit_result(dest, BlockResult { key, value: acc });
            }
            BlockWalk::Fallback { task, acc, .. } => self.finish_dd(&task, acc, ctx),
        }
        DpOutcome::Finished
    }

    fn merge(&self, acc: &mut BlocksAcc, r: BlockResult) {
        acc.sum = acc.sum.wrapping_add(mix(r.key ^ mix(r.value)));
        acc.count += 1;
        *acc.seen.entry(r.key).or_default() += 1;
    }
}

/// Merges every accumulator of a report into one (for whole-run checks).
pub fn combined<'a>(accs: impl IntoIterator<Item = &'a BlocksAcc>) -> BlocksAcc {
    let mut out = BlocksAcc::default();
    for a in accs {
        out.sum = out.sum.wrapping_add(a.sum);
        out.count += a.count;
        for (k, n) in &a.seen {
            *out.seen.entry(*k).or_default() += n;
        }
    }
    out
}

/// A per-processor time breakdown table (percent of each processor's
/// accounted time per state, tasks, messages, cache hit rate).
pub fn breakdown_table(stats: &RunStats) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>7} {:>6}",
        "proc",
        "exec%",
        "sel%",
        "wait%",
        "idle%",
        "send%",
        "recv%",
        "serve%",
        "dd",
        "dp",
        "migr",
        "fallbk",
        "msgs",
        "hit%"
    );
    let mut rows: Vec<&hybrid_sched::ProcStats> = stats.procs.iter().collect();
    rows.push(&stats.master);
    for p in rows {
        let total = p.time_ns.total().max(1) as f64;
        let pct = |s: State| 100.0 * p.time_ns.get(s) as f64 / total;
        let hit = p
            .cache_hit_rate()
            .map_or("-".to_string(), |r| format!("{:.0}", 100.0 * r));
        let _ = writeln!(
            out,
            "{:>6} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>6.1} {:>6} {:>6} {:>6} {:>6} {:>7} {:>6}",
            p.addr.to_string(),
            pct(State::Executing),
            pct(State::Selecting),
            pct(State::WaitingData),
            pct(State::Idle),
            pct(State::Sending),
            pct(State::Receiving),
            pct(State::ServingData),
            p.tasks.demand_driven,
            p.tasks.data_parallel_finished,
            p.tasks.migrations,
            p.tasks.fallbacks,
            p.sent.total().packets,
            hit
        );
    }
    out
}
