//! The protocol: between the framework and a workload (the [`Workload`]
//! contract and its hook context, in [`workload`]) and between actors
//! (addresses, priority classes, data placement, and every message and
//! envelope processors exchange).
//!
//! Everything sent is `serde`-serialisable so that a transport other than
//! in-process channels (MPI, a file for replay) can carry it unchanged.
//!
//! This file holds the types that do not depend on a workload (and that the
//! [`Workload`] trait names); [`message`] holds the messages, which
//! carry a workload's tasks, data and results. Nothing here uses the
//! actors, stores or runtimes: they all build on it.
//!
//! [`Workload`]: workload::Workload

pub mod message;
pub mod work_kind;
pub mod workload;

use std::fmt;

use serde::{Deserialize, Serialize};

/// Address of an actor: the master or worker processor `i` (`0..procs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Addr {
    /// The master: hands out root tasks, detects termination, gathers results.
    Master,
    /// Worker processor `i`.
    Proc(usize),
}

impl Addr {
    /// Dense index: workers `0..procs`, the master `procs`.
    pub fn slot(self, procs: usize) -> usize {
        match self {
            Addr::Proc(i) => i,
            Addr::Master => procs,
        }
    }

    /// Inverse of [`Addr::slot`].
    pub fn from_slot(slot: usize, procs: usize) -> Addr {
        if slot == procs {
            Addr::Master
        } else {
            Addr::Proc(slot)
        }
    }
}

impl fmt::Display for Addr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Addr::Master => write!(f, "master"),
            Addr::Proc(i) => write!(f, "p{i}"),
        }
    }
}

/// Message priority classes, highest first (the derive order is the priority
/// order). Control traffic is tiny and unblocks others (credits, probes), data
/// requests/replies are what waiting tasks wait for, results free memory at the
/// sender, and data-parallel work is preferred over demand-driven work because
/// it is bound to its data while demand-driven work can go anywhere.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Class {
    /// Credits, work requests, termination probes, termination.
    Control,
    /// Data requests and replies.
    Data,
    /// Results travelling to their destination.
    Result,
    /// Migrating data-parallel tasks.
    DataParallel,
    /// Demand-driven tasks (root hand-outs and policy-placed children).
    DemandDriven,
}

impl Class {
    /// All classes, highest priority first.
    pub const ALL: [Class; 5] = [
        Class::Control,
        Class::Data,
        Class::Result,
        Class::DataParallel,
        Class::DemandDriven,
    ];

    /// Position in [`Class::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// Urgent classes are sent at once, unbundled, and are never held back by
    /// flow control (data traffic must never wait for task traffic, or a
    /// waiting task could deadlock against a full input buffer).
    pub fn is_urgent(self) -> bool {
        matches!(self, Class::Control | Class::Data)
    }

    /// The credit pool a credit-limited message of this class draws on.
    pub fn pool(self) -> Pool {
        if self == Class::Result {
            Pool::Results
        } else {
            Pool::Tasks
        }
    }
}

/// The two credit pools of a link (SEMANTICS.md, section 5). Both share the
/// link's credits and byte window, and results have a reserve beyond them:
/// every receiver merges results whatever its own state, so a result
/// always leaves a sender's backlog in the end, and a sender over its
/// budget may wait for that without waiting on any task.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Pool {
    /// Data-parallel and demand-driven tasks.
    Tasks,
    /// Results.
    Results,
}

impl Pool {
    /// Position in a pair indexed by pool.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Both pools.
    pub const ALL: [Pool; 2] = [Pool::Tasks, Pool::Results];

    /// Results' reserve beyond a link's `shared` credits or byte window: a
    /// quarter as much again, at least one.
    pub fn reserve(shared: usize) -> usize {
        (shared / 4).max(1)
    }
}

/// Where one data item lives: the replicated ownership directory is built from
/// a list of these (see [`crate::Workload::placement`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Placement<Id> {
    /// The data id.
    pub id: Id,
    /// The processor that holds the item permanently (its "resident" copy).
    pub owner: usize,
    /// The item's size in bytes; the directory knows sizes before an item is
    /// fetched so that a processor can decide whether a task's data fits its
    /// cache before asking for it.
    pub bytes: u64,
}

/// What happened to a data-parallel task after [`crate::Workload::execute_dp`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DpOutcome<T> {
    /// The task is complete (it may have emitted results and new tasks).
    Finished,
    /// The task needs data that is not local; it is sent to the owner of
    /// [`crate::Workload::route_dp`]'s answer for this (updated) task.
    Migrate(T),
}
