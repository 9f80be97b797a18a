//! Placement policies for demand-driven child tasks (the paper's section 5:
//! shadow tasks spawned by workers).
//!
//! A policy is chosen at run time ([`Policy`] implements `FromStr`). The
//! per-processor `Placer` turns it into a decision for each child.
//!
//! `LoadAware` goes beyond the paper (its first open problem: scheduling with
//! global load information that scales). Every packet carries its sender's
//! load (queued tasks), so each processor keeps a slightly stale view of the
//! others' loads at no extra message cost, and no central actor is involved.
//! A child stays local unless this processor holds more than `LOAD_SLACK`
//! queued tasks and another processor was last seen with at most
//! `LOAD_IDLE`: then it goes to that processor, whose estimate is raised by
//! one so that a burst of children spreads over several idle processors
//! instead of herding onto one. Shedding only to (nearly) idle processors
//! matters: a moved shadow task must fetch its cells again at the receiver,
//! so moving work between busy processors costs more than it balances (in
//! the simulated experiments, shedding to any less-loaded processor was as
//! slow as round robin).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// How demand-driven tasks spawned by workers are placed.
///
/// # Example
///
/// ```rust
/// use hybrid_sched::Policy;
///
/// assert_eq!("load-aware".parse::<Policy>(), Ok(Policy::LoadAware));
/// assert_eq!("RR".parse::<Policy>(), Ok(Policy::RoundRobin));
/// for p in Policy::ALL {
///     assert_eq!(p.to_string().parse::<Policy>(), Ok(p));
/// }
/// let err = "fastest".parse::<Policy>().unwrap_err();
/// assert!(err.to_string().contains("'fastest'"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Policy {
    /// Run on the processor that spawned it: no task traffic, but a hot spot
    /// cannot shed work.
    Local,
    /// Send to the master, which gives it to the first processor asking for
    /// work: global balance, but the master becomes a bottleneck.
    ViaMaster,
    /// Send to the processor that ran the root task it descends from.
    ToOrigin,
    /// Deal out to all processors in turn, starting with the next one.
    RoundRobin,
    /// Keep local unless this processor is busy and another one is known to
    /// be idle (see the module documentation).
    LoadAware,
}

/// `LoadAware` sends children away only while it holds more than this many
/// queued tasks itself ...
pub(crate) const LOAD_SLACK: u32 = 32;
/// ... and only to a processor last known to hold at most this many.
pub(crate) const LOAD_IDLE: u32 = 1;

impl Policy {
    /// Every policy, in documentation order.
    pub const ALL: [Policy; 5] = [
        Policy::Local,
        Policy::ViaMaster,
        Policy::ToOrigin,
        Policy::RoundRobin,
        Policy::LoadAware,
    ];

    /// The paper's four policies (Figure 12).
    pub const PAPER: [Policy; 4] = [
        Policy::Local,
        Policy::ViaMaster,
        Policy::ToOrigin,
        Policy::RoundRobin,
    ];

    /// The canonical command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Policy::Local => "local",
            Policy::ViaMaster => "via-master",
            Policy::ToOrigin => "to-origin",
            Policy::RoundRobin => "round-robin",
            Policy::LoadAware => "load-aware",
        }
    }
}

impl fmt::Display for Policy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Policy {
    type Err = ConfigError;

    /// Accepts the canonical names and a few spellings (`master`, `origin`,
    /// `rr`, underscores), case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let norm = s.trim().to_ascii_lowercase().replace('_', "-");
        match norm.as_str() {
            "local" => Ok(Policy::Local),
            "via-master" | "viamaster" | "master" => Ok(Policy::ViaMaster),
            "to-origin" | "toorigin" | "origin" => Ok(Policy::ToOrigin),
            "round-robin" | "roundrobin" | "rr" => Ok(Policy::RoundRobin),
            "load-aware" | "loadaware" | "load" => Ok(Policy::LoadAware),
            _ => Err(ConfigError::UnknownPolicy(s.to_string())),
        }
    }
}

/// Where a child task goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Target {
    /// This processor's own queue.
    Local,
    /// The master's pool.
    Master,
    /// Another processor (never this one: that is `Local`).
    Proc(usize),
}

/// What a processor knows when it places a child task.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaceCtx {
    /// The origin of the task's root (see [`crate::protocol::message::DdEnvelope`]).
    pub origin: Option<usize>,
    /// This processor's load now (queued tasks).
    pub load: u32,
}

/// A processor's placement state for its policy.
///
/// (Example: the unit test `placer_decisions`.)
#[derive(Clone, Debug)]
pub(crate) struct Placer {
    policy: Policy,
    me: usize,
    procs: usize,
    next: usize,
    /// Last known load of every processor (`LoadAware`).
    loads: Vec<u32>,
}

impl Placer {
    /// Placement for processor `me` of `procs`.
    pub(crate) fn new(policy: Policy, me: usize, procs: usize) -> Self {
        Placer {
            policy,
            me,
            procs,
            next: (me + 1) % procs.max(1),
            loads: vec![0; procs],
        }
    }

    /// Load information about processor `p` arrived (piggybacked).
    pub(crate) fn observe(&mut self, p: usize, load: u32) {
        if let Some(l) = self.loads.get_mut(p) {
            *l = load;
        }
    }

    /// The loads this placer believes in.
    #[cfg(test)]
    pub(crate) fn loads(&self) -> &[u32] {
        &self.loads
    }

    /// Decides where one child task goes.
    pub(crate) fn place(&mut self, ctx: PlaceCtx) -> Target {
        let to = |p: usize, me: usize| {
            if p == me {
                Target::Local
            } else {
                Target::Proc(p)
            }
        };
        match self.policy {
            Policy::Local => Target::Local,
            Policy::ViaMaster => Target::Master,
            Policy::ToOrigin => match ctx.origin {
                Some(o) => to(o, self.me),
                None => Target::Local,
            },
            Policy::RoundRobin => {
                let p = self.next;
                self.next = (self.next + 1) % self.procs;
                to(p, self.me)
            }
            Policy::LoadAware => {
                // Least loaded other processor, ties broken round robin.
                let mut best: Option<(u32, usize)> = None;
                for k in 0..self.procs {
                    let p = (self.next + k) % self.procs;
                    if p != self.me && best.is_none_or(|(l, _)| self.loads[p] < l) {
                        best = Some((self.loads[p], p));
                    }
                }
                match best {
                    Some((l, p)) if l <= LOAD_IDLE && ctx.load > LOAD_SLACK => {
                        self.loads[p] = self.loads[p].saturating_add(1);
                        self.next = (p + 1) % self.procs;
                        Target::Proc(p)
                    }
                    _ => Target::Local,
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_names_and_aliases() {
        for p in Policy::ALL {
            assert_eq!(p.name().parse::<Policy>(), Ok(p));
            assert_eq!(p.to_string().to_uppercase().parse::<Policy>(), Ok(p));
        }
        assert_eq!("rr".parse::<Policy>(), Ok(Policy::RoundRobin));
        assert_eq!("via_master".parse::<Policy>(), Ok(Policy::ViaMaster));
        let err = "fastest".parse::<Policy>().unwrap_err();
        assert!(err.to_string().contains("fastest"));
        assert!(err.to_string().contains("round-robin"));
    }

    #[test]
    fn placement_decisions() {
        let ctx = PlaceCtx {
            origin: Some(2),
            load: 0,
        };
        assert_eq!(Placer::new(Policy::Local, 1, 4).place(ctx), Target::Local);
        assert_eq!(
            Placer::new(Policy::ViaMaster, 1, 4).place(ctx),
            Target::Master
        );
        assert_eq!(
            Placer::new(Policy::ToOrigin, 1, 4).place(ctx),
            Target::Proc(2)
        );
        assert_eq!(
            Placer::new(Policy::ToOrigin, 2, 4).place(ctx),
            Target::Local
        );
        let mut rr = Placer::new(Policy::RoundRobin, 1, 3);
        let got: Vec<Target> = (0..4).map(|_| rr.place(ctx)).collect();
        assert_eq!(
            got,
            vec![
                Target::Proc(2),
                Target::Proc(0),
                Target::Local,
                Target::Proc(2)
            ]
        );
    }

    #[test]
    fn load_aware_sheds_only_to_idle_processors_and_spreads_bursts() {
        let mut la = Placer::new(Policy::LoadAware, 0, 4);
        let at = |load| PlaceCtx { origin: None, load };
        la.observe(1, 5);
        la.observe(2, 5);
        la.observe(3, 5);
        // Nobody is known to be idle: keep the work, however much there is.
        assert_eq!(la.place(at(1000)), Target::Local);
        la.observe(2, 0);
        // A processor with little queued keeps its children.
        assert_eq!(la.place(at(LOAD_SLACK)), Target::Local);
        // A busy one sends to the idle one until its estimate says it is
        // no longer idle, then keeps the rest.
        let burst: Vec<Target> = (0..4).map(|_| la.place(at(LOAD_SLACK + 10))).collect();
        assert_eq!(
            burst,
            vec![
                Target::Proc(2),
                Target::Proc(2),
                Target::Local,
                Target::Local
            ]
        );
        assert_eq!(la.loads()[2], LOAD_IDLE + 1);
        // One processor: always local.
        assert_eq!(
            Placer::new(Policy::LoadAware, 0, 1).place(at(99)),
            Target::Local
        );
    }
}

#[cfg(test)]
mod example {
    use super::*;

    /// Formerly the type's documentation example.
    #[test]
    fn placer_decisions() {
        // Processor 1 of 4 places a child whose root ran on processor 3.
        let ctx = PlaceCtx {
            origin: Some(3),
            load: 0,
        };
        assert_eq!(Placer::new(Policy::Local, 1, 4).place(ctx), Target::Local);
        assert_eq!(
            Placer::new(Policy::ViaMaster, 1, 4).place(ctx),
            Target::Master
        );
        assert_eq!(
            Placer::new(Policy::ToOrigin, 1, 4).place(ctx),
            Target::Proc(3)
        );
        let mut rr = Placer::new(Policy::RoundRobin, 1, 4);
        let dealt: Vec<Target> = (0..4).map(|_| rr.place(ctx)).collect();
        assert_eq!(
            dealt,
            [
                Target::Proc(2),
                Target::Proc(3),
                Target::Proc(0),
                Target::Local
            ]
        );

        // Load-aware sheds work only while busy, and only to an idle processor.
        let mut la = Placer::new(Policy::LoadAware, 1, 4);
        for p in [0, 2, 3] {
            la.observe(p, 10);
        }
        let busy = PlaceCtx {
            origin: None,
            load: 100,
        };
        assert_eq!(la.place(busy), Target::Local); // nobody is idle
        la.observe(3, 0);
        assert_eq!(la.place(PlaceCtx { load: 5, ..busy }), Target::Local); // not busy
        assert_eq!(la.place(busy), Target::Proc(3));
    }
}
