//! Placement policies for demand-driven child tasks (the paper's section 5:
//! shadow tasks spawned by workers).
//!
//! A policy is chosen at run time ([`Policy`] implements `FromStr`). The
//! per-processor [`Placer`] turns it into a decision for each child; a future
//! `LoadAware` policy fits the same shape: add a variant and give
//! [`PlaceCtx`] whatever load information the processor has gathered
//! (e.g. piggybacked queue lengths), without touching the processor logic.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

/// How demand-driven tasks spawned by workers are placed.
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
}

impl Policy {
    /// Every policy, in documentation order.
    pub const ALL: [Policy; 4] = [
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
            _ => Err(ConfigError::UnknownPolicy(s.to_string())),
        }
    }
}

/// Where a child task goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// This processor's own queue.
    Local,
    /// The master's pool.
    Master,
    /// Another processor (never this one: that is `Local`).
    Proc(usize),
}

/// What a processor knows when it places a child task.
#[derive(Clone, Copy, Debug)]
pub struct PlaceCtx {
    /// The origin of the task's root (see [`crate::message::DdEnvelope`]).
    pub origin: Option<usize>,
}

/// A processor's placement state for its policy.
#[derive(Clone, Debug)]
pub struct Placer {
    policy: Policy,
    me: usize,
    procs: usize,
    next: usize,
}

impl Placer {
    /// Placement for processor `me` of `procs`.
    pub fn new(policy: Policy, me: usize, procs: usize) -> Self {
        Placer {
            policy,
            me,
            procs,
            next: (me + 1) % procs.max(1),
        }
    }

    /// The policy.
    pub fn policy(&self) -> Policy {
        self.policy
    }

    /// Decides where one child task goes.
    pub fn place(&mut self, ctx: PlaceCtx) -> Target {
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
        let ctx = PlaceCtx { origin: Some(2) };
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
}
