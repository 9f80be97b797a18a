//! Error types: configuration problems and run failures. Nothing in the
//! framework panics on bad input; it returns one of these.

use std::time::Duration;

use thiserror::Error;

use crate::protocol::Addr;

/// A configuration that cannot be run.
#[derive(Clone, Debug, PartialEq, Eq, Error)]
pub enum ConfigError {
    /// `procs` was 0.
    #[error("the number of processors must be at least 1 (got 0)")]
    NoProcessors,
    /// `procs` was above [`crate::config::MAX_PROCS`].
    #[error("{procs} processors is more than the supported maximum of {max}")]
    TooManyProcessors {
        /// Requested.
        procs: usize,
        /// Allowed.
        max: usize,
    },
    /// A cache budget of 0 bytes.
    #[error("the cache budget must be at least 1 byte (use no limit for an unlimited cache)")]
    ZeroCache,
    /// A cache budget so large that byte accounting could overflow.
    #[error("a cache budget of {bytes} bytes is absurd (the maximum is {max}); leave it unset for an unlimited cache")]
    CacheTooLarge {
        /// Requested.
        bytes: u64,
        /// Allowed.
        max: u64,
    },
    /// Bundles of 0 items.
    #[error("the bundle size limit must be at least 1 message (got 0)")]
    ZeroBundleItems,
    /// Bundles of 0 bytes.
    #[error("the bundle byte limit must be at least 1 byte (got 0)")]
    ZeroBundleBytes,
    /// No credits: nothing could ever be sent.
    #[error("flow control needs at least 1 credit per link (got 0): with none, no task could ever be sent")]
    ZeroCredits,
    /// Credits above the maximum.
    #[error("{credits} credits per link is absurd (the maximum is {max})")]
    TooManyCredits {
        /// Requested.
        credits: usize,
        /// Allowed.
        max: usize,
    },
    /// A work-in-flight budget too small to give every sender a byte.
    #[error("the work-in-flight budget must be at least 2 bytes per processor (got {bytes} for {procs} processors)")]
    FlightBudgetTooSmall {
        /// Requested.
        bytes: usize,
        /// Processors.
        procs: usize,
    },
    /// A processor must be allowed at least one task waiting for data.
    #[error("max_waiting_tasks must be at least 1 (got 0)")]
    ZeroWaitingTasks,
    /// Zero runtime threads.
    #[error("the number of runtime threads must be at least 1 (got 0)")]
    ZeroThreads,
    /// A zero time limit.
    #[error("the time limit must be positive")]
    ZeroTimeLimit,
    /// A cache completion percentage above 100.
    #[error("the cache completes after a percentage of the data held elsewhere: {0} is above 100")]
    CompletionPercent(u8),
    /// An unknown scheduling policy name.
    #[error("unknown scheduling policy '{0}' (expected one of: local, via-master, to-origin, round-robin)")]
    UnknownPolicy(String),
    /// A cost model names a work kind the workload does not declare.
    #[error("the cost model names work kind '{name}', which the workload does not declare (its kinds: {known})")]
    UnknownWorkKind {
        /// The unknown name.
        name: String,
        /// The workload's kinds.
        known: String,
    },
    /// The workload's data layout was made for another processor count
    /// (see [`crate::Workload::laid_out_for`]).
    #[error("the workload's data is laid out for {laid_out} processors, but the run asks for {procs}: build the workload for the run's count")]
    ProcsMismatch {
        /// The workload's count.
        laid_out: usize,
        /// The configuration's count.
        procs: usize,
    },
    /// The workload's data placement is inconsistent.
    #[error("inconsistent workload data placement: {0}")]
    Placement(String),
}

/// A run that failed.
#[derive(Debug, Error)]
pub enum RunError {
    /// The configuration was rejected before anything ran.
    #[error("invalid configuration: {0}")]
    Config(#[from] ConfigError),
    /// A workload hook broke its contract (see [`crate::Workload`]).
    #[error("workload error at {at}: {message}")]
    Workload {
        /// Where it was detected.
        at: Addr,
        /// What happened.
        message: String,
    },
    /// An actor panicked (a panic inside a workload hook).
    #[error("actor {at} panicked: {message}")]
    Panicked {
        /// Which actor.
        at: Addr,
        /// Panic message.
        message: String,
    },
    /// The run exceeded its time limit (see [`crate::Config::time_limit`]).
    #[error("the run did not finish within {limit:?}")]
    TimedOut {
        /// The limit.
        limit: Duration,
    },
    /// The runtime itself failed (could not start threads, a channel closed).
    #[error("runtime failure: {0}")]
    Runtime(String),
}
