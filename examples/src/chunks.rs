//! The book's running example, as its tutorial chapters leave it.
//!
//! Eight chunks of ten numbers are spread over the processors. A *query*
//! (a demand-driven task) sums a few adjacent chunks and reports the sum to
//! the master; it also starts a *walk* (a data-parallel task) that visits
//! the next chunks one at a time, sums their squares and reports to the
//! processor that owns the query's first chunk. With
//! [`Chunks::child_queries`] a root query also spawns one child query (the
//! work a scheduling policy places). A query whose chunks cannot fit the
//! cache becomes a walk that computes the same sum (the data-parallel
//! fallback).
//!
//! The chapters "A first workload" and "Cache budgets and the data-parallel
//! fallback" of the book write this workload out step by step and check
//! that their version computes what this one does.

use hybrid_sched::{Addr, ByteSize, Ctx, DataView, DpOutcome, Placement, Workload};
use serde::{Deserialize, Serialize};

/// Number of chunks.
pub const CHUNKS: u32 = 8;

/// A data item: ten numbers.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Chunk(pub Vec<u64>);

impl ByteSize for Chunk {
    fn byte_size(&self) -> usize {
        24 + 8 * self.0.len()
    }
}

/// A demand-driven task: sum chunks `first..first + len`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Query {
    /// First chunk.
    pub first: u32,
    /// Number of chunks (cut at [`CHUNKS`]).
    pub len: u32,
    /// Whether a root query spawned this one.
    pub child: bool,
}

impl ByteSize for Query {
    fn byte_size(&self) -> usize {
        12
    }
}

/// A data-parallel task: visit chunks `next..end`. A plain walk
/// (`query: None`) sums squares and reports to `to`; a converted query sums
/// values and then finishes the query exactly as
/// [`Workload::execute_dd`] would have.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Walk {
    /// Next chunk to visit.
    pub next: u32,
    /// One past the last chunk.
    pub end: u32,
    /// Running value.
    pub acc: u64,
    /// Where a plain walk reports.
    pub to: Addr,
    /// The query this walk computes (the fallback), if any.
    pub query: Option<Query>,
}

impl ByteSize for Walk {
    fn byte_size(&self) -> usize {
        32
    }
}

/// A result.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Answer {
    /// A query's sum.
    Sum(u64),
    /// A walk's sum of squares.
    Squares(u64),
}

impl ByteSize for Answer {
    fn byte_size(&self) -> usize {
        16
    }
}

/// Where answers are merged. Merging is addition: commutative and
/// associative, as the contract asks.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Totals {
    /// Sum of the queries' sums.
    pub sum: u64,
    /// Sum of the walks' sums of squares.
    pub squares: u64,
    /// Answers merged.
    pub answers: u32,
}

hybrid_sched::work_kinds! {
    /// The work the hooks of [`Chunks`] count (a cost model prices it).
    pub enum ChunksWork {
        /// One data selection.
        Select = "select",
        /// Numbers added.
        Add = "add",
    }
}

/// The running example's workload.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Chunks {
    /// Each root query spawns one child query summing the chunk after its
    /// own (chapter "Priorities, bundling, policies and flow control").
    pub child_queries: bool,
}

impl Chunks {
    /// Chunk `i`: the numbers `10 i .. 10 i + 10`.
    pub fn chunk(i: u32) -> Chunk {
        Chunk((0..10).map(|k| u64::from(i) * 10 + k).collect())
    }

    /// The owner of chunk `i`: round robin.
    pub fn owner(i: u32, procs: usize) -> usize {
        i as usize % procs
    }

    fn ids(q: &Query) -> Vec<u32> {
        (q.first..(q.first + q.len).min(CHUNKS)).collect()
    }

    /// What a query does once its sum is known; shared with the fallback.
    fn finish_query(&self, q: &Query, sum: u64, ctx: &mut Ctx<Self>) {
        ctx.emit_result(Addr::Master, Answer::Sum(sum));
        let to = Addr::Proc(Self::owner(q.first, ctx.procs()));
        let end = (q.first + q.len + 2).min(CHUNKS);
        ctx.spawn_dp(Walk {
            next: q.first + q.len,
            end,
            acc: 0,
            to,
            query: None,
        });
        if self.child_queries && !q.child && q.first + q.len < CHUNKS {
            ctx.spawn_dd(Query {
                first: q.first + q.len,
                len: 1,
                child: true,
            });
        }
    }
}

impl Workload for Chunks {
    type DataId = u32;
    type DataItem = Chunk;
    type DdTask = Query;
    type DpTask = Walk;
    type Result = Answer;
    type Accumulator = Totals;
    type Work = ChunksWork;

    fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
        (0..CHUNKS)
            .map(|i| Placement {
                id: i,
                owner: Self::owner(i, procs),
                bytes: 104,
            })
            .collect()
    }

    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Chunk)> {
        (0..CHUNKS)
            .filter(|&i| Self::owner(i, procs) == proc)
            .map(|i| (i, Self::chunk(i)))
            .collect()
    }

    fn root_tasks(&self, _procs: usize) -> Vec<Query> {
        (0..CHUNKS)
            .map(|first| Query {
                first,
                len: 3,
                child: false,
            })
            .collect()
    }

    fn select_data(&self, q: &Query, ctx: &mut Ctx<Self>) -> Vec<u32> {
        ctx.charge(ChunksWork::Select, 1);
        Self::ids(q)
    }

    fn execute_dd(&self, q: Query, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let sum = Self::ids(&q)
            .iter()
            .map(|id| data.get(id).expect("selected").0.iter().sum::<u64>())
            .sum();
        ctx.charge(ChunksWork::Add, 10 * u64::from(q.len));
        self.finish_query(&q, sum, ctx);
    }

    fn to_data_parallel(&self, q: Query, ctx: &mut Ctx<Self>) {
        let end = (q.first + q.len).min(CHUNKS);
        ctx.spawn_dp(Walk {
            next: q.first,
            end,
            acc: 0,
            to: Addr::Master,
            query: Some(q),
        });
    }

    fn route_dp(&self, w: &Walk) -> Option<u32> {
        (w.next < w.end).then_some(w.next)
    }

    fn execute_dp(
        &self,
        mut w: Walk,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<Walk> {
        while w.next < w.end {
            let Some(chunk) = data.get(&w.next) else {
                return DpOutcome::Migrate(w);
            };
            ctx.charge(ChunksWork::Add, 10);
            w.acc += if w.query.is_some() {
                chunk.0.iter().sum::<u64>()
            } else {
                chunk.0.iter().map(|x| x * x).sum::<u64>()
            };
            w.next += 1;
        }
        match &w.query {
            Some(q) => self.finish_query(q, w.acc, ctx),
            None => ctx.emit_result(w.to, Answer::Squares(w.acc)),
        }
        DpOutcome::Finished
    }

    fn merge(&self, acc: &mut Totals, a: Answer) {
        match a {
            Answer::Sum(s) => acc.sum += s,
            Answer::Squares(s) => acc.squares += s,
        }
        acc.answers += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hybrid_sched::{run_lockstep, run_sequential, Config, Policy};
    use std::sync::Arc;

    #[test]
    fn sums_are_known() {
        // Root query i sums chunks i..i+3 (cut at 8): the sum of the numbers
        // 10 i .. 10 min(i+3, 8).
        let expect: u64 = (0..CHUNKS)
            .map(|i| (10 * u64::from(i)..10 * u64::from((i + 3).min(CHUNKS))).sum::<u64>())
            .sum();
        let r = run_sequential(&Chunks::default(), 3).unwrap();
        assert_eq!(r.master.sum, expect);
        // Eight query answers at the master; eight walks report to processors.
        assert_eq!(r.master.answers, 8);
        assert_eq!(r.procs.iter().map(|t| t.answers).sum::<u32>(), 8);
    }

    #[test]
    fn every_policy_and_cache_gives_the_reference() {
        let w = Chunks {
            child_queries: true,
        };
        let reference = run_sequential(&w, 3).unwrap();
        // Five roots have a next chunk to spawn a child for.
        assert_eq!(reference.master.answers, 8 + 5);
        for policy in [
            Policy::Local,
            Policy::ViaMaster,
            Policy::ToOrigin,
            Policy::RoundRobin,
        ] {
            for cache in [None, Some(208), Some(100)] {
                let config = Config::new(3)
                    .with_policy(policy)
                    .with_cache_bytes(cache)
                    .with_credits(1);
                let r = run_lockstep(Arc::new(w), &config, 5, 1_000_000).unwrap();
                assert_eq!(r.master, reference.master, "{policy} {cache:?}");
                assert_eq!(r.procs, reference.procs, "{policy} {cache:?}");
                let fallbacks = r.stats.sum(|p| p.tasks.fallbacks);
                assert_eq!(fallbacks > 0, cache == Some(100), "{policy} {cache:?}");
            }
        }
    }
}
