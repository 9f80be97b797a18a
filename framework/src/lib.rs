//! # hybrid-sched
//!
//! A generic, actor-based framework for hybrid task scheduling after Reinhard,
//! Chalmers and Jansen, "Hybrid Scheduling for Parallel Rendering using
//! Coherent Ray Tasks": coherent work runs *demand-driven* anywhere after
//! fetching (and caching) its small data set, incoherent work runs
//! *data-parallel* by migrating to the processors that own its data.
//!
//! * An application implements [`Workload`].
//! * Each processor is a [`Processor`] state machine (private state, a priority
//!   [`Mailbox`], a [`DataStore`] with a byte-budgeted LRU [`ByteLru`] cache);
//!   the [`Master`] hands out root tasks and detects termination.
//! * A runtime moves [`Packet`]s between them: [`run_threads`] (tokio) or
//!   [`run_sequential`] (the reference), or one processor per MPI rank
//!   (`runtime::mpi`, feature `mpi`); a simulator can drive the same state
//!   machines through [`runtime::Node`].
//!
//! See `SEMANTICS.md` for the guarantees and the book chapter for a tutorial.

pub mod bundle;
pub mod cache;
pub mod clock;
pub mod config;
pub mod error;
pub mod flow;
pub mod mailbox;
pub mod master;
pub mod message;
pub mod policy;
pub mod processor;
pub mod runtime;
pub mod stats;
pub mod store;
pub mod workload;

#[cfg(test)]
mod tests;

/// Re-exported so that workloads can derive the serde traits without their
/// own dependency: `#[derive(Serialize, Deserialize)]` with
/// `#[serde(crate = "hybrid_sched::serde")]`.
pub use serde;

pub use cache::ByteLru;
pub use clock::{Clock, Time, WallClock};
pub use config::{BundleConfig, Config};
pub use error::{ConfigError, RunError};
pub use mailbox::Mailbox;
pub use master::Master;
pub use message::{Addr, Class, Msg, Packet};
pub use policy::Policy;
pub use processor::{Processor, Step};
pub use runtime::lockstep::{run_lockstep, Lockstep};
pub use runtime::sequential::{run_sequential, run_sequential_observed, Sequential};
pub use runtime::sim::{run_sim, CostModel, Network, Sim, Timeline};
pub use runtime::threads::{run_threads, Threads};
pub use runtime::{Node, RunReport, Runtime};
pub use stats::{ProcStats, RankTraffic, RunStats, State};
pub use store::{DataStore, IdMap};
pub use workload::{ByteSize, Ctx, DataView, DpOutcome, Placement, Workload};
