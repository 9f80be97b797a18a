//! State-machine tests driven by a deterministic, seeded lockstep scheduler
//! (no tokio): packets are delivered in random order (FIFO per link, like
//! channels and MPI) with random delays, which explores interleavings that a
//! thread pool rarely produces. This is also a small proof that the processor
//! logic is runtime independent.
//!
//! `mod.rs` holds the test workload ([`Mini`]) and the checks; the tests
//! are grouped by topic: whole runs ([`runs`]), messages and the outbox
//! ([`messages`]), the simulator ([`sim`]), the runtime interface
//! ([`runtime_api`]) and the data store's completion ([`store`]).

mod epochs;
mod merges;
mod messages;
mod runs;
mod runtime_api;
mod semantics;
mod sim;
mod store;

use std::collections::BTreeMap;
use std::sync::Arc;

use proptest::prelude::*;
use serde::{Deserialize, Serialize};

use crate::bundle::Outbox;
use crate::protocol::message::{DdEnvelope, Msg, Packet};
use crate::protocol::{Addr, Class, Pool};
use crate::runtime::RunReport;
use crate::{
    run_sequential, run_threads, BundleConfig, ByteSize, Config, Ctx, DataService, DataView,
    DpOutcome, Placement, Policy, RunError, Workload,
};

use crate::rng::mix;

/// A miniature workload: `items` data items of `words` u64 each, root tasks
/// reading `sel` items, children to `depth`, walks of `hops` items.
#[derive(Clone, Debug)]
pub(crate) struct Mini {
    pub items: u32,
    pub words: usize,
    pub roots: u32,
    pub sel: u32,
    pub depth: u8,
    pub hops: usize,
    pub hotspot: bool,
    pub seed: u64,
    /// [`Workload::laid_out_for`].
    pub laid_out: Option<usize>,
    /// A walk that must migrate asks for its processor's cache to be
    /// completed ([`Ctx::complete_cache`]).
    pub complete_on_migrate: bool,
    /// How it answers [`Workload::locate`].
    pub locating: Locating,
    /// What caches charge for an item, in times its bytes
    /// ([`Workload::cache_charge`]).
    pub charge: u64,
    /// [`Workload::data_parallel_newest_first`].
    pub newest_first: bool,
    /// Merging some results at a processor starts a follow-up task
    /// ([`Workload::merge_in`]).
    pub merge_spawns: bool,
}

/// The key bit of a follow-up task started by a merge, and of its results.
pub(crate) const FOLLOW_UP: u64 = 1 << 62;

/// How [`Mini`] answers [`Workload::locate`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) enum Locating {
    /// It does not: processors keep their own directory.
    #[default]
    No,
    /// As its placement says.
    Right,
    /// Its last item on another processor than the placement's.
    Wrong,
}

impl Mini {
    /// Item `id`'s owner and bytes on `procs` processors, as placed.
    fn home(&self, id: u32, procs: usize) -> (usize, u64) {
        let owner = if self.hotspot { 0 } else { id as usize % procs };
        (owner, (24 + 8 * self.words) as u64)
    }
}

impl Default for Mini {
    fn default() -> Self {
        Mini {
            items: 24,
            words: 4,
            roots: 12,
            sel: 4,
            depth: 2,
            hops: 3,
            hotspot: false,
            seed: 7,
            laid_out: None,
            complete_on_migrate: false,
            locating: Locating::No,
            charge: 1,
            newest_first: false,
            merge_spawns: false,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Item(pub(crate) Vec<u64>);
impl ByteSize for Item {
    fn byte_size(&self) -> usize {
        24 + 8 * self.0.len()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Task {
    key: u64,
    depth: u8,
}
impl ByteSize for Task {
    fn byte_size(&self) -> usize {
        16
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Walk {
    key: u64,
    path: Vec<u32>,
    pos: usize,
    acc: u64,
    /// Set for the data-parallel fallback of a demand-driven task.
    finish: Option<Task>,
}
impl ByteSize for Walk {
    fn byte_size(&self) -> usize {
        40 + 4 * self.path.len()
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct Res {
    pub(crate) key: u64,
    pub(crate) value: u64,
}
impl ByteSize for Res {
    fn byte_size(&self) -> usize {
        16
    }
}

/// key -> (times merged, value)
pub(crate) type Acc = BTreeMap<u64, (u32, u64)>;

impl Mini {
    fn ids(&self, key: u64, salt: u64, n: u64) -> Vec<u32> {
        (0..n)
            .map(|i| (mix(key ^ mix(self.seed ^ salt ^ (i << 40))) % u64::from(self.items)) as u32)
            .collect()
    }
    fn selection(&self, t: &Task) -> Vec<u32> {
        let mut v = self.ids(t.key, 1, u64::from(self.sel));
        v.sort_unstable();
        v.dedup();
        v
    }
    fn fold(acc: u64, id: u32, item: &Item) -> u64 {
        item.0
            .iter()
            .fold(acc.rotate_left(5) ^ u64::from(id), |a, &w| mix(a ^ w))
    }
    fn dest(&self, key: u64, procs: usize) -> Addr {
        let h = mix(key ^ 99);
        if h % 4 == 0 {
            Addr::Master
        } else {
            Addr::Proc((h / 4) as usize % procs)
        }
    }
    fn finish_dd(&self, t: &Task, acc: u64, ctx: &mut Ctx<Self>) {
        ctx.emit_result(
            self.dest(t.key, ctx.procs()),
            Res {
                key: t.key,
                value: acc,
            },
        );
        if t.depth < self.depth {
            for i in 0..(mix(t.key ^ 5) % 3) {
                ctx.spawn_dd(Task {
                    key: (t.key << 2) | (i + 1),
                    depth: t.depth + 1,
                });
            }
        }
        // A follow-up starts no walk (whose key a follow-up of a walk's
        // result may take).
        if self.hops > 0 && t.key & FOLLOW_UP == 0 && mix(t.key ^ 6) % 2 == 0 {
            ctx.spawn_dp(Walk {
                key: t.key | (1 << 63),
                path: self.ids(t.key, 2, self.hops as u64),
                pos: 0,
                acc,
                finish: None,
            });
        }
    }
}

crate::work_kinds! {
    /// What the test workloads count.
    pub(crate) enum MiniWork {
        Select = "select",
        Work = "work",
    }
}

impl Workload for Mini {
    type DataId = u32;
    type DataItem = Item;
    type DdTask = Task;
    type DpTask = Walk;
    type Result = Res;
    type Accumulator = Acc;
    type Work = MiniWork;

    fn laid_out_for(&self) -> Option<usize> {
        self.laid_out
    }

    fn data_parallel_newest_first(&self) -> bool {
        self.newest_first
    }

    fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
        (0..self.items)
            .map(|i| {
                let (owner, bytes) = self.home(i, procs);
                Placement {
                    id: i,
                    owner,
                    bytes,
                }
            })
            .collect()
    }
    fn locates(&self) -> bool {
        self.locating != Locating::No
    }
    fn locate(&self, id: &u32, procs: usize) -> Option<(usize, u64)> {
        let (owner, bytes) = self.home(*id, procs);
        let owner = match self.locating {
            Locating::Wrong if *id + 1 == self.items => (owner + 1) % procs,
            _ => owner,
        };
        (*id < self.items).then_some((owner, bytes))
    }
    fn cache_charge(&self, _id: &u32, bytes: u64) -> u64 {
        bytes * self.charge
    }
    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Item)> {
        self.placement(procs)
            .into_iter()
            .filter(|p| p.owner == proc)
            .map(|p| {
                let v = (0..self.words as u64)
                    .map(|w| mix(u64::from(p.id) * 1000 + w))
                    .collect();
                (p.id, Item(v))
            })
            .collect()
    }
    fn root_tasks(&self, _procs: usize) -> Vec<Task> {
        (0..self.roots)
            .map(|r| Task {
                key: u64::from(r + 1) << 20,
                depth: 0,
            })
            .collect()
    }
    fn select_data(&self, t: &Task, ctx: &mut Ctx<Self>) -> Vec<u32> {
        ctx.charge(MiniWork::Select, 1);
        self.selection(t)
    }
    fn execute_dd(&self, t: Task, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let mut acc = t.key;
        for id in self.selection(&t) {
            acc = Self::fold(acc, id, data.get(&id).expect("selected data is present"));
        }
        ctx.charge(MiniWork::Work, 1);
        self.finish_dd(&t, acc, ctx);
    }
    fn to_data_parallel(&self, t: Task, ctx: &mut Ctx<Self>) {
        ctx.spawn_dp(Walk {
            key: t.key,
            path: self.selection(&t),
            pos: 0,
            acc: t.key,
            finish: Some(t),
        });
    }
    fn route_dp(&self, w: &Walk) -> Option<u32> {
        w.path.get(w.pos).copied()
    }
    fn execute_dp(
        &self,
        mut w: Walk,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<Walk> {
        while let Some(&id) = w.path.get(w.pos) {
            match data.get(&id) {
                Some(item) => {
                    w.acc = Self::fold(w.acc, id, item);
                    w.pos += 1;
                }
                None => {
                    if self.complete_on_migrate {
                        ctx.complete_cache();
                    }
                    return DpOutcome::Migrate(w);
                }
            }
        }
        match w.finish {
            Some(t) => self.finish_dd(&t, w.acc, ctx),
            None => ctx.emit_result(
                self.dest(w.key, ctx.procs()),
                Res {
                    key: w.key,
                    value: w.acc,
                },
            ),
        }
        DpOutcome::Finished
    }
    fn merge(&self, acc: &mut Acc, r: Res) {
        let e = acc.entry(r.key).or_insert((0, r.value));
        e.0 += 1;
    }
    /// With `merge_spawns`, half the results merged at a processor start a
    /// follow-up (a demand-driven task or a walk, by the key) whose result
    /// starts none: what it starts depends on the result alone, so the
    /// accumulators do not depend on the order of the merges.
    fn merge_in(&self, acc: &mut Acc, r: Res, _data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        let follow = self.merge_spawns && r.key & FOLLOW_UP == 0 && mix(r.key ^ 11) % 2 == 0;
        let (key, value) = (r.key | FOLLOW_UP, r.value);
        self.merge(acc, r);
        if !follow {
            return;
        }
        ctx.charge(MiniWork::Work, 1);
        if mix(key ^ 12) % 2 == 0 {
            ctx.spawn_dd(Task {
                key,
                depth: self.depth,
            });
        } else {
            ctx.spawn_dp(Walk {
                key,
                path: self.ids(key, 3, self.hops.max(1) as u64),
                pos: 0,
                acc: value,
                finish: None,
            });
        }
    }
}

fn run_lockstep<W: Workload>(w: Arc<W>, cfg: &Config, seed: u64) -> Result<RunReport<W>, RunError> {
    crate::runtime::lockstep::run_lockstep(w, cfg, seed, 200_000)
}

fn all_keys(r: &RunReport<Mini>) -> BTreeMap<u64, (u32, u64)> {
    let mut out = BTreeMap::new();
    for acc in r.procs.iter().chain([&r.master]) {
        for (k, v) in acc {
            assert!(out.insert(*k, *v).is_none(), "key {k} merged at two places");
        }
    }
    out
}

fn check_against_sequential(w: &Mini, r: &RunReport<Mini>) {
    let seq = run_sequential(w, r.procs.len()).expect("sequential run");
    assert_eq!(r.procs, seq.procs, "per-processor results differ");
    assert_eq!(r.master, seq.master, "master results differ");
    for (k, (n, _)) in all_keys(r) {
        assert_eq!(n, 1, "task {k:#x} reported {n} times");
    }
    let dd: u64 = r.stats.sum(|p| p.tasks.demand_driven + p.tasks.fallbacks);
    assert_eq!(
        dd, seq.stats.procs[0].tasks.demand_driven,
        "demand-driven task count"
    );
}
