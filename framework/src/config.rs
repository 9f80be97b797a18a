//! Run configuration and its validation.

use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;
use crate::policy::Policy;

/// Largest number of worker processors accepted.
pub const MAX_PROCS: usize = 4096;
/// Largest cache budget accepted (2^60 bytes): keeps all byte arithmetic far
/// from overflow.
pub const MAX_CACHE_BYTES: u64 = 1 << 60;
/// Largest credit count per link accepted.
pub const MAX_CREDITS: usize = 1 << 20;

/// Bundling of low-priority messages per destination.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct BundleConfig {
    /// Whether results and tasks are bundled at all. When off, every message
    /// travels alone (useful to measure what bundling saves).
    pub enabled: bool,
    /// Send a bundle once it holds this many messages.
    pub max_items: usize,
    /// Send a bundle once it holds this many bytes.
    pub max_bytes: usize,
    /// Send a bundle once its oldest message has waited this long (in the
    /// runtime's time: wall clock for threads, virtual for the simulator).
    /// A processor with nothing to do flushes all bundles at once anyway.
    pub max_age: Duration,
}

impl Default for BundleConfig {
    fn default() -> Self {
        BundleConfig {
            enabled: true,
            max_items: 32,
            max_bytes: 64 * 1024,
            max_age: Duration::from_millis(2),
        }
    }
}

/// When a processor answers the data requests for the items it owns.
///
/// The results are the same either way (SEMANTICS.md section 6); what
/// changes is how long a requesting task waits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum DataService {
    /// Between two of its steps, as any other message (the paper's: a
    /// request waits for the owner's current task to end).
    #[default]
    BetweenSteps,
    /// When the request arrives, by the processor's data server, while the
    /// processor computes: the simulator serves at arrival on the owner's
    /// CPU (delaying its current step by the time it takes), the threads
    /// runtime in the requesting processor's step (a one-sided read of the
    /// owner's items), the MPI runtime on the owner's MPI thread. Runtimes
    /// that run one step at a time (sequential, lockstep) serve between
    /// steps.
    OnArrival,
}

/// Everything a run needs besides the workload.
///
/// # Example
///
/// ```rust
/// use hybrid_sched::{Config, ConfigError, Policy};
///
/// let config = Config::new(8)
///     .with_policy(Policy::ViaMaster)
///     .with_cache_bytes(Some(1 << 20))
///     .with_credits(16);
/// assert_eq!(config.validate(), Ok(()));
/// // Flow control bounds every input buffer: 8 senders with 16 credits
/// // each, and 4 more for results.
/// assert_eq!(config.input_buffer_bound(), 160);
///
/// assert_eq!(Config::new(0).validate(), Err(ConfigError::NoProcessors));
/// assert_eq!(Config::new(2).with_credits(0).validate(), Err(ConfigError::ZeroCredits));
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Config {
    /// Number of worker processors (the master is an extra actor).
    pub procs: usize,
    /// Placement of demand-driven child tasks.
    pub policy: Policy,
    /// Cache budget in bytes per processor (`None`: unlimited).
    pub cache_bytes: Option<u64>,
    /// Most bytes one demand-driven task may have fetched for it (`None`:
    /// as much as the cache holds). A task whose data held elsewhere and
    /// not yet cached or on its way exceeds this takes the data-parallel
    /// fallback instead ([`crate::Workload::to_data_parallel`]: its work
    /// migrates to the data), as a task whose data cannot fit the cache
    /// does. The results are the same either way (SEMANTICS.md sections 1
    /// and 6); what it trades is bytes fetched against work migrated.
    #[serde(default)]
    pub fetch_limit: Option<u64>,
    /// Completing the cache (beyond the paper): with a cache that never
    /// evicts (`cache_bytes` `None`) and no `fetch_limit`, once a
    /// processor has fetched (or asked for) this percentage of the bytes
    /// placed on other processors, it asks for the rest in one request per
    /// owner, and from then on holds every item. `None`: never (the
    /// paper's cache). At 50 the bytes fetched are at most twice what
    /// the tasks asked for: it stops paying for each task's fetches once
    /// it has paid for half of what is held elsewhere. A workload may ask
    /// for it sooner ([`crate::Ctx::complete_cache`]); with `None` it is
    /// never done. What changes is only where data is, never a result
    /// (SEMANTICS.md section 6).
    #[serde(default)]
    pub complete_cache: Option<u8>,
    /// When data requests are answered ([`DataService`]).
    #[serde(default)]
    pub data_service: DataService,
    /// Bundling of low-priority traffic.
    pub bundle: BundleConfig,
    /// Flow control: how many credit-limited messages (tasks and results)
    /// one worker may have unconsumed at one receiver; results may use a
    /// quarter as many again beyond them ([`crate::Pool::reserve`]). Bounds
    /// every input buffer by [`Config::input_buffer_bound`] messages.
    pub credits_per_link: usize,
    /// Flow control in bytes: the work in flight at one actor, credit-limited
    /// messages received and not consumed (its input buffer) plus messages
    /// waiting in its outbox (its send backlog). Five eighths of it bound the
    /// input buffer (a byte window per sending link of half the budget over
    /// the processors, and results' reserve a quarter as large),
    /// three eighths the backlog (a processor whose backlog holds more
    /// takes no new root task and keeps the children it spawns; past three
    /// quarters in flight, with results waiting in its backlog, it runs
    /// nothing until they leave). See
    /// SEMANTICS.md section 5 for what is guaranteed.
    #[serde(default = "default_flight_bytes")]
    pub flight_bytes: usize,
    /// A processor asks for new demand-driven work while fewer than this many
    /// of its tasks wait for data (latency hiding versus memory).
    pub max_waiting_tasks: usize,
    /// A processor asks the master for its next root task as soon as it
    /// starts one (one in reserve) instead of when it runs dry, so the
    /// reply's round trip overlaps work. `false`: the paper's ask-when-idle.
    #[serde(default = "yes")]
    pub prefetch_work: bool,
    /// Threads for the threads runtime (`None`: available parallelism).
    pub threads: Option<usize>,
    /// Abort the run with [`crate::RunError::TimedOut`] after this long.
    pub time_limit: Option<Duration>,
}

fn yes() -> bool {
    true
}

/// The default of [`Config::flight_bytes`]: 1 MiB.
pub const DEFAULT_FLIGHT_BYTES: usize = 1 << 20;

fn default_flight_bytes() -> usize {
    DEFAULT_FLIGHT_BYTES
}

impl Config {
    /// Defaults for `procs` workers: `Local` policy, unlimited cache,
    /// bundling on, 64 credits per link.
    pub fn new(procs: usize) -> Self {
        Config {
            procs,
            policy: Policy::Local,
            cache_bytes: None,
            fetch_limit: None,
            complete_cache: None,
            data_service: DataService::BetweenSteps,
            bundle: BundleConfig::default(),
            credits_per_link: 64,
            flight_bytes: DEFAULT_FLIGHT_BYTES,
            max_waiting_tasks: 2,
            prefetch_work: true,
            threads: None,
            time_limit: None,
        }
    }

    /// Sets the policy.
    pub fn with_policy(mut self, policy: Policy) -> Self {
        self.policy = policy;
        self
    }

    /// Sets the cache budget.
    pub fn with_cache_bytes(mut self, bytes: Option<u64>) -> Self {
        self.cache_bytes = bytes;
        self
    }

    /// Sets the most bytes one demand-driven task may have fetched.
    pub fn with_fetch_limit(mut self, bytes: Option<u64>) -> Self {
        self.fetch_limit = bytes;
        self
    }

    /// Sets the percentage of the data placed elsewhere after which a
    /// processor completes its cache ([`Config::complete_cache`]).
    pub fn with_complete_cache(mut self, percent: Option<u8>) -> Self {
        self.complete_cache = percent;
        self
    }

    /// Sets when data requests are answered ([`Config::data_service`]).
    pub fn with_data_service(mut self, service: DataService) -> Self {
        self.data_service = service;
        self
    }

    /// Turns bundling on or off.
    pub fn with_bundling(mut self, enabled: bool) -> Self {
        self.bundle.enabled = enabled;
        self
    }

    /// Sets the credits per link.
    pub fn with_credits(mut self, credits: usize) -> Self {
        self.credits_per_link = credits;
        self
    }

    /// Sets the work-in-flight budget per actor ([`Config::flight_bytes`]).
    pub fn with_flight_bytes(mut self, bytes: usize) -> Self {
        self.flight_bytes = bytes;
        self
    }

    /// Sets the time limit.
    pub fn with_time_limit(mut self, limit: Duration) -> Self {
        self.time_limit = Some(limit);
        self
    }

    /// [`Config::validate`], then the configuration against `workload`:
    /// the processor count it was laid out for, if any
    /// ([`crate::Workload::laid_out_for`]). Every runtime calls this before
    /// any hook runs.
    pub fn validate_for<W: crate::Workload>(&self, workload: &W) -> Result<(), ConfigError> {
        self.validate()?;
        check_laid_out(workload, self.procs)
    }

    /// Checks every field; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.procs == 0 {
            return Err(ConfigError::NoProcessors);
        }
        if self.procs > MAX_PROCS {
            return Err(ConfigError::TooManyProcessors {
                procs: self.procs,
                max: MAX_PROCS,
            });
        }
        match self.cache_bytes {
            Some(0) => return Err(ConfigError::ZeroCache),
            Some(b) if b > MAX_CACHE_BYTES => {
                return Err(ConfigError::CacheTooLarge {
                    bytes: b,
                    max: MAX_CACHE_BYTES,
                })
            }
            _ => {}
        }
        if self.bundle.max_items == 0 {
            return Err(ConfigError::ZeroBundleItems);
        }
        if self.bundle.max_bytes == 0 {
            return Err(ConfigError::ZeroBundleBytes);
        }
        if self.credits_per_link == 0 {
            return Err(ConfigError::ZeroCredits);
        }
        if self.credits_per_link > MAX_CREDITS {
            return Err(ConfigError::TooManyCredits {
                credits: self.credits_per_link,
                max: MAX_CREDITS,
            });
        }
        if self.flight_bytes / 2 < self.procs {
            return Err(ConfigError::FlightBudgetTooSmall {
                bytes: self.flight_bytes,
                procs: self.procs,
            });
        }
        if let Some(p) = self.complete_cache.filter(|&p| p > 100) {
            return Err(ConfigError::CompletionPercent(p));
        }
        if self.max_waiting_tasks == 0 {
            return Err(ConfigError::ZeroWaitingTasks);
        }
        if self.threads == Some(0) {
            return Err(ConfigError::ZeroThreads);
        }
        if self.time_limit == Some(Duration::ZERO) {
            return Err(ConfigError::ZeroTimeLimit);
        }
        Ok(())
    }

    /// The most credit-limited messages any one actor can hold unconsumed:
    /// every worker (including, for the master, all of them) may have
    /// `credits_per_link` outstanding towards it, and results' reserve.
    /// Input buffer high-water marks never exceed this (checked by the
    /// flow-control tests).
    pub fn input_buffer_bound(&self) -> usize {
        self.procs * (self.credits_per_link + crate::Pool::reserve(self.credits_per_link))
    }

    /// The byte window of one link: a worker may have at most this many
    /// bytes of credit-limited messages unconsumed at one receiver (or a
    /// single message of any size when it has none there), and results a
    /// quarter as much again beyond it ([`crate::Pool::reserve`]). Half
    /// the [`Config::flight_bytes`] budget shared by the `procs` senders;
    /// with results' reserve, five eighths of it bound an input buffer.
    pub fn link_window_bytes(&self) -> usize {
        (self.flight_bytes / 2 / self.procs.max(1)).max(1)
    }

    /// A processor whose send backlog holds more bytes than this takes no
    /// new root task and keeps its spawned children: the three eighths of
    /// [`Config::flight_bytes`] that the windows leave.
    pub fn backlog_budget_bytes(&self) -> usize {
        self.flight_bytes - self.flight_bytes / 2 - self.flight_bytes / 8
    }
}

/// A run of `workload` on `procs` processors against the count its data
/// was laid out for, if any ([`crate::Workload::laid_out_for`]).
pub(crate) fn check_laid_out<W: crate::Workload>(
    workload: &W,
    procs: usize,
) -> Result<(), ConfigError> {
    match workload.laid_out_for() {
        Some(n) if n != procs => Err(ConfigError::ProcsMismatch { laid_out: n, procs }),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Config::new(4).validate(), Ok(()));
    }

    #[test]
    fn bad_configs_give_clear_errors() {
        let cases: Vec<(Config, &str)> = vec![
            (Config::new(0), "at least 1"),
            (Config::new(MAX_PROCS + 1), "maximum"),
            (Config::new(2).with_cache_bytes(Some(0)), "cache budget"),
            (Config::new(2).with_cache_bytes(Some(u64::MAX)), "absurd"),
            (Config::new(2).with_credits(0), "credit"),
            (
                Config {
                    bundle: BundleConfig {
                        max_items: 0,
                        ..BundleConfig::default()
                    },
                    ..Config::new(2)
                },
                "bundle size",
            ),
            (
                Config {
                    bundle: BundleConfig {
                        max_bytes: 0,
                        ..BundleConfig::default()
                    },
                    ..Config::new(2)
                },
                "bundle byte",
            ),
            (
                Config {
                    max_waiting_tasks: 0,
                    ..Config::new(2)
                },
                "max_waiting_tasks",
            ),
            (
                Config {
                    threads: Some(0),
                    ..Config::new(2)
                },
                "threads",
            ),
            (Config::new(2).with_time_limit(Duration::ZERO), "time limit"),
            (Config::new(4).with_flight_bytes(7), "in-flight budget"),
        ];
        for (cfg, needle) in cases {
            let err = cfg.validate().expect_err("must be rejected");
            let text = err.to_string();
            assert!(text.contains(needle), "{text:?} should mention {needle:?}");
        }
    }
}
