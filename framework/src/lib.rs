//! # hybrid-sched
//!
//! A generic, actor-based framework for hybrid task scheduling after Reinhard,
//! Chalmers and Jansen, "Hybrid Scheduling for Parallel Rendering using
//! Coherent Ray Tasks": coherent work runs *demand-driven* anywhere after
//! fetching (and caching) its small data set, incoherent work runs
//! *data-parallel* by migrating to the processors that own its data.
//!
//! * An application implements [`Workload`]: its data, its two kinds of task,
//!   its results and the [`WorkKind`]s of work it charges.
//! * Each processor is an actor with private state, a priority mailbox and a
//!   data store with a byte-budgeted LRU cache ([`ByteLru`]); the master
//!   hands out root tasks and detects termination. They exchange the
//!   messages of [`protocol`].
//! * Work in rounds runs in *epochs* ([`Workload::next_epoch`]): when an
//!   epoch's work is all done, the master starts the next one, with
//!   write-once data broadcast to every processor before its first task.
//! * A [`Runtime`] moves the messages between them: [`Threads`] (tokio),
//!   [`Sequential`] (the reference), [`Lockstep`] (seeded interleavings),
//!   [`Sim`] (a simulated cluster in virtual time) or one processor per MPI
//!   rank (`runtime::mpi`, feature `mpi`). All return a [`RunReport`].
//!
//! See `SEMANTICS.md` for the guarantees and the book chapter for a tutorial.
//!
//! # Example
//!
//! A minimal workload end to end. Six numbers `1..=6` are spread over the
//! processors; root task `i` (demand-driven) adds items `i` and `i + 1`,
//! fetching the one it does not own into its cache, and reports the sum to
//! the master. When a task's data cannot fit the cache at all, the framework
//! asks for the same work as a data-parallel walk that migrates to each
//! item's owner instead.
//!
//! ```rust
//! use std::sync::Arc;
//! use hybrid_sched::serde::{Deserialize, Serialize};
//! use hybrid_sched::{
//!     run_sequential, run_threads, Addr, ByteSize, Config, Ctx, DataView, DpOutcome,
//!     Placement, Workload,
//! };
//!
//! /// A data item, and a result: one number.
//! #[derive(Clone, Debug, Serialize, Deserialize)]
//! #[serde(crate = "hybrid_sched::serde")]
//! struct Num(u64);
//! impl ByteSize for Num {
//!     fn byte_size(&self) -> usize { 8 }
//! }
//!
//! /// Demand-driven task: add items `i` and `i + 1`.
//! #[derive(Clone, Debug, Serialize, Deserialize)]
//! #[serde(crate = "hybrid_sched::serde")]
//! struct Pair(u32);
//! impl ByteSize for Pair {
//!     fn byte_size(&self) -> usize { 4 }
//! }
//!
//! /// Data-parallel task: add items `next..end`, moving to each one's owner.
//! #[derive(Clone, Debug, Serialize, Deserialize)]
//! #[serde(crate = "hybrid_sched::serde")]
//! struct Walk { next: u32, end: u32, acc: u64 }
//! impl ByteSize for Walk {
//!     fn byte_size(&self) -> usize { 16 }
//! }
//!
//! hybrid_sched::work_kinds! {
//!     /// The work this workload counts (see `Ctx::charge`).
//!     enum PairsWork { Select = "select" }
//! }
//!
//! struct Pairs;
//!
//! impl Workload for Pairs {
//!     type DataId = u32;
//!     type DataItem = Num;
//!     type DdTask = Pair;
//!     type DpTask = Walk;
//!     type Result = Num;
//!     type Accumulator = u64;
//!     type Work = PairsWork;
//!
//!     fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
//!         (0..6).map(|id| Placement { id, owner: id as usize % procs, bytes: 8 }).collect()
//!     }
//!     fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Num)> {
//!         (0..6u32).filter(|&i| i as usize % procs == proc).map(|i| (i, Num(u64::from(i) + 1))).collect()
//!     }
//!     fn root_tasks(&self, _procs: usize) -> Vec<Pair> {
//!         (0..5).map(Pair).collect()
//!     }
//!     fn select_data(&self, t: &Pair, ctx: &mut Ctx<Self>) -> Vec<u32> {
//!         ctx.charge(PairsWork::Select, 1);
//!         vec![t.0, t.0 + 1]
//!     }
//!     fn execute_dd(&self, t: Pair, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
//!         // Every selected id is local (resident or cached) by now.
//!         let sum = data.get(&t.0).unwrap().0 + data.get(&(t.0 + 1)).unwrap().0;
//!         ctx.emit_result(Addr::Master, Num(sum));
//!     }
//!     fn to_data_parallel(&self, t: Pair, ctx: &mut Ctx<Self>) {
//!         ctx.spawn_dp(Walk { next: t.0, end: t.0 + 2, acc: 0 });
//!     }
//!     fn route_dp(&self, w: &Walk) -> Option<u32> {
//!         (w.next < w.end).then_some(w.next)
//!     }
//!     fn execute_dp(&self, mut w: Walk, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) -> DpOutcome<Walk> {
//!         while w.next < w.end {
//!             let Some(item) = data.get(&w.next) else {
//!                 return DpOutcome::Migrate(w); // continues at the owner of `w.next`
//!             };
//!             w.acc += item.0;
//!             w.next += 1;
//!         }
//!         ctx.emit_result(Addr::Master, Num(w.acc));
//!         DpOutcome::Finished
//!     }
//!     fn merge(&self, acc: &mut u64, r: Num) {
//!         *acc += r.0;
//!     }
//! }
//!
//! // (1+2) + (2+3) + (3+4) + (4+5) + (5+6) = 35, on 2 processors (plus the
//! // master) with room for two fetched items each, and in the sequential
//! // reference.
//! let config = Config::new(2).with_cache_bytes(Some(16));
//! let report = run_threads(Arc::new(Pairs), &config).unwrap();
//! assert_eq!(report.master, 35);
//! assert_eq!(run_sequential(&Pairs, 2).unwrap().master, 35);
//! assert_eq!(report.stats.sum(|p| p.tasks.demand_driven), 5);
//! assert_eq!(report.stats.sum(|p| p.tasks.fallbacks), 0);
//! // Each pair has one item on the other processor; a fetched item stays
//! // cached and may serve the next pair, so at most 5 fetches.
//! let fetched = report.stats.sum(|p| p.data_items_requested);
//! assert!((1..=5).contains(&fetched), "{fetched} items fetched");
//!
//! // A cache smaller than one item: every task falls back to a walk, which
//! // migrates instead of fetching, with the same result.
//! let report = run_threads(Arc::new(Pairs), &Config::new(2).with_cache_bytes(Some(4))).unwrap();
//! assert_eq!(report.master, 35);
//! assert_eq!(report.stats.sum(|p| p.tasks.fallbacks), 5);
//! assert!(report.stats.sum(|p| p.tasks.migrations) >= 5);
//! assert_eq!(report.stats.sum(|p| p.data_items_requested), 0);
//! ```

mod bundle;
pub mod cache;
pub mod clock;
pub mod config;
mod directory;
pub mod error;
mod flow;
mod mailbox;
mod master;
pub mod par;
pub mod policy;
mod processor;
pub mod protocol;
pub mod resident;
pub mod rng;
pub mod runtime;
mod server;
pub mod stats;
mod store;

#[cfg(test)]
mod tests;

/// Re-exported so that workloads can derive the serde traits without their
/// own dependency: `#[derive(Serialize, Deserialize)]` with
/// `#[serde(crate = "hybrid_sched::serde")]`.
pub use serde;

pub use cache::{ByteLru, IdMap};
pub use clock::{Clock, Time, WallClock};
pub use config::{BundleConfig, Config, DataService};
pub use error::{ConfigError, RunError};
pub use policy::Policy;
pub use protocol::message::{Msg, Packet};
pub use protocol::workload::{ByteSize, Ctx, DataView, Epoch, NoWork, WorkKind, Workload};
pub use protocol::{Addr, Class, DpOutcome, Placement, Pool};
pub use resident::Resident;
pub use runtime::lockstep::{run_lockstep, Lockstep};
pub use runtime::sequential::{run_sequential, run_sequential_observed, Sequential};
pub use runtime::sim::{run_sim, CostModel, Network, Sim};
pub use runtime::threads::{run_threads, Threads};
pub use runtime::{Extras, RunReport, Runtime, Timeline};
pub use stats::{ProcStats, RankTraffic, RunStats, State};
