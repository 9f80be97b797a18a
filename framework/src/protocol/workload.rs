//! The `Workload` trait: where an application plugs into the framework.
//!
//! A workload describes its data (ids, items, who owns what), its two kinds of
//! task and its results, and provides the hooks the processors call. Hooks are
//! plain synchronous functions: they never see a runtime, a channel or a clock,
//! which is what lets the same workload run on threads, in a simulation or over
//! MPI. Anything a hook produces (new tasks, results, counted work) goes through
//! the [`Ctx`] it is handed.

use std::cell::RefCell;
use std::fmt::Debug;
use std::hash::Hash;

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::cache::ByteLru;
use crate::protocol::{Addr, DpOutcome, Placement};
use crate::resident::Resident;

pub use super::work_kind::{NoWork, WorkKind};

/// Size of a value in bytes as the framework should account for it (memory
/// high-water marks, cache budget, message sizes). It need not be exact, but it
/// must be deterministic.
pub trait ByteSize {
    /// Approximate size in bytes, including owned heap data.
    fn byte_size(&self) -> usize;
}

/// What every value that travels in a message must be: cloneable, printable,
/// sendable between threads and (for the later MPI runtime) serialisable.
pub trait Payload: Clone + Debug + Send + Sync + Serialize + DeserializeOwned + 'static {}
impl<T: Clone + Debug + Send + Sync + Serialize + DeserializeOwned + 'static> Payload for T {}

/// The application. All associated types travel in messages, hence the serde
/// bounds.
///
/// # Contract
/// * Results must not depend on *where* a task runs, and [`Workload::merge`]
///   must be commutative and associative: merge order differs between runs.
///   (This is what makes "parallel equals sequential" testable.)
/// * [`Workload::execute_dp`] must return [`DpOutcome::Migrate`] only when the
///   data named by [`Workload::route_dp`] is not available in the view; a task
///   that asks to migrate towards data it already has is reported as an error.
/// * [`Workload::load_partition`] for processor `p` must return exactly the
///   items that [`Workload::placement`] assigns to `p` (checked at start-up).
///
/// # Example
///
/// The hooks of both kinds of task, called by hand on the workload of the
/// crate-level example (a runtime makes these calls).
///
/// ```rust
/// # use std::sync::Arc;
/// # use hybrid_sched::serde::{Deserialize, Serialize};
/// # use hybrid_sched::{Addr, ByteSize, Ctx, DataView, DpOutcome, Placement, Workload};
/// # // The crate-level example's workload: six numbers 1..=6 over the processors;
/// # // demand-driven task `Pair(i)` adds items i and i + 1, data-parallel `Walk`
/// # // adds items `next..end` by migrating to their owners.
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Num(u64);
/// # impl ByteSize for Num { fn byte_size(&self) -> usize { 8 } }
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Pair(u32);
/// # impl ByteSize for Pair { fn byte_size(&self) -> usize { 4 } }
/// # #[derive(Clone, Debug, Serialize, Deserialize)]
/// # #[serde(crate = "hybrid_sched::serde")]
/// # struct Walk { next: u32, end: u32, acc: u64 }
/// # impl ByteSize for Walk { fn byte_size(&self) -> usize { 16 } }
/// # hybrid_sched::work_kinds! { enum PairsWork { Select = "select" } }
/// # struct Pairs;
/// # impl Workload for Pairs {
/// #     type DataId = u32;
/// #     type DataItem = Num;
/// #     type DdTask = Pair;
/// #     type DpTask = Walk;
/// #     type Result = Num;
/// #     type Accumulator = u64;
/// #     type Work = PairsWork;
/// #     fn placement(&self, procs: usize) -> Vec<Placement<u32>> {
/// #         (0..6).map(|id| Placement { id, owner: id as usize % procs, bytes: 8 }).collect()
/// #     }
/// #     fn load_partition(&self, proc: usize, procs: usize) -> Vec<(u32, Num)> {
/// #         (0..6u32).filter(|&i| i as usize % procs == proc).map(|i| (i, Num(u64::from(i) + 1))).collect()
/// #     }
/// #     fn root_tasks(&self, _procs: usize) -> Vec<Pair> { (0..5).map(Pair).collect() }
/// #     fn select_data(&self, t: &Pair, ctx: &mut Ctx<Self>) -> Vec<u32> {
/// #         ctx.charge(PairsWork::Select, 1);
/// #         vec![t.0, t.0 + 1]
/// #     }
/// #     fn execute_dd(&self, t: Pair, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
/// #         let sum = data.get(&t.0).unwrap().0 + data.get(&(t.0 + 1)).unwrap().0;
/// #         ctx.emit_result(Addr::Master, Num(sum));
/// #     }
/// #     fn to_data_parallel(&self, t: Pair, ctx: &mut Ctx<Self>) {
/// #         ctx.spawn_dp(Walk { next: t.0, end: t.0 + 2, acc: 0 });
/// #     }
/// #     fn route_dp(&self, w: &Walk) -> Option<u32> { (w.next < w.end).then_some(w.next) }
/// #     fn execute_dp(&self, mut w: Walk, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>) -> DpOutcome<Walk> {
/// #         while w.next < w.end {
/// #             let Some(item) = data.get(&w.next) else { return DpOutcome::Migrate(w) };
/// #             w.acc += item.0;
/// #             w.next += 1;
/// #         }
/// #         ctx.emit_result(Addr::Master, Num(w.acc));
/// #         DpOutcome::Finished
/// #     }
/// #     fn merge(&self, acc: &mut u64, r: Num) { *acc += r.0; }
/// # }
/// use hybrid_sched::{ByteLru, Resident};
///
/// // Processor 0 of 2 owns the even items 0, 2 and 4 (values 1, 3 and 5).
/// let resident: Resident<u32, Num> = Pairs.load_partition(0, 2).into_iter().collect();
/// assert_eq!(resident.len(), 3);
/// let mut ctx = Ctx::new(0, 2);
///
/// // Demand-driven: data selection names everything the task will read (the
/// // processor fetches what is not local before it calls `execute_dd`).
/// assert_eq!(Pairs.select_data(&Pair(2), &mut ctx), [2, 3]);
/// assert_eq!(ctx.charges(), [(PairsWork::Select, 1)]);
///
/// // Data-parallel: a walk over items 2 and 3 runs as far as the local data
/// // allows, then asks to migrate towards the owner of the item it needs next.
/// let view = DataView::new(&resident, None);
/// let walk = Walk { next: 2, end: 4, acc: 0 };
/// let DpOutcome::Migrate(walk) = Pairs.execute_dp(walk, &view, &mut ctx) else {
///     panic!("item 3 is not local");
/// };
/// assert_eq!((walk.next, walk.acc), (3, 3));
/// assert_eq!(Pairs.route_dp(&walk), Some(3));
/// assert_eq!(Pairs.placement(2)[3].owner, 1);
///
/// // With item 3 in the cache (fetched for an earlier task) it finishes here.
/// let mut cache = ByteLru::new(Some(64));
/// assert!(cache.insert(3, Num(4), 8));
/// let view = DataView::new(&resident, Some(&cache));
/// assert!(view.is_local(&3) && !view.is_resident(&3));
/// assert!(matches!(Pairs.execute_dp(walk, &view, &mut ctx), DpOutcome::Finished));
/// ```
pub trait Workload: Send + Sync + Sized + 'static {
    /// Identifies one unit of data (an octree cell, an object, a block).
    type DataId: Payload + Hash + Eq + Ord;
    /// One unit of data. Its [`ByteSize`] is what the cache budget counts.
    type DataItem: Payload + ByteSize;
    /// A demand-driven task: coherent work whose (small) data set is known
    /// after data selection; it can run on any processor.
    type DdTask: Payload + ByteSize;
    /// A data-parallel task: incoherent work that migrates to its data.
    type DpTask: Payload + ByteSize;
    /// A result, merged at a destination processor (or the master).
    type Result: Payload + ByteSize;
    /// The per-processor merge target for results (e.g. a processor's pixels).
    type Accumulator: Clone + Debug + Default + Send + Serialize + DeserializeOwned + 'static;
    /// The kinds of work hooks charge ([`Ctx::charge`]); [`NoWork`] for
    /// none.
    type Work: WorkKind;

    /// The processor count this workload's data layout was made for, if it
    /// was made for one (a renderer that balances its partition for a
    /// count when it is built). Every runtime compares it with
    /// [`crate::Config::procs`] before any other hook runs and refuses a
    /// mismatch with [`crate::ConfigError::ProcsMismatch`], so the count has
    /// one source and the start-up hooks below always receive it. The
    /// default, `None`, lays data out for whatever count a run asks.
    fn laid_out_for(&self) -> Option<usize> {
        None
    }

    /// Whether processors go depth first through the trees of tasks that
    /// tasks spawn rather than oldest first (the default): a processor
    /// runs the data-parallel tasks it holds newest first, the
    /// demand-driven children of recent steps before them, and sends the
    /// newest of its data-parallel tasks that wait for credit first
    /// (SEMANTICS.md section 3). For tasks that each spawn many children
    /// (a hemisphere's sample rays, each of which may sample a hemisphere
    /// of its own), oldest first holds a whole level of the tree at once.
    /// The order changes only when tasks run, never a result
    /// (SEMANTICS.md section 1).
    fn data_parallel_newest_first(&self) -> bool {
        false
    }
    /// The replicated ownership directory for a run on `procs` processors.
    fn placement(&self, procs: usize) -> Vec<Placement<Self::DataId>>;

    /// Whether [`Workload::locate`] answers (then processors ask it instead
    /// of a sorted copy of the placement; every entry is checked at start).
    fn locates(&self) -> bool {
        false
    }

    /// `id`'s owner and bytes as [`Workload::placement`] has them; `None` if not placed.
    fn locate(&self, _id: &Self::DataId, _procs: usize) -> Option<(usize, u64)> {
        None
    }

    /// What a processor's cache charges for a copy of `id`, whose bytes in
    /// the placement are `bytes`: by default those bytes. A workload whose
    /// copies take more memory where they are cached than the placement
    /// accounts for them says so here, so that the cache's budget bounds
    /// that memory. Asked when a task's data are selected, before they are
    /// fetched (the charge is reserved then, and kept); must not change
    /// while the item is cached or on its way. The fetch limit
    /// ([`crate::Config::fetch_limit`]) stays in placement bytes: it
    /// bounds what travels.
    fn cache_charge(&self, _id: &Self::DataId, bytes: u64) -> u64 {
        bytes
    }

    /// The resident items of processor `proc` (of `procs`); called for
    /// the processors of one process side by side, on several threads.
    fn load_partition(&self, proc: usize, procs: usize) -> Vec<(Self::DataId, Self::DataItem)>;

    /// The root demand-driven tasks the master hands out on request (e.g. screen
    /// tiles), in hand-out order.
    fn root_tasks(&self, procs: usize) -> Vec<Self::DdTask>;

    /// Data selection: every data id `task` will read. Selection may be costly
    /// (pyramid clipping); charge its work to `ctx`. Resident ids may be
    /// included; duplicates are ignored.
    fn select_data(&self, task: &Self::DdTask, ctx: &mut Ctx<Self>) -> Vec<Self::DataId>;

    /// Data selection that can see what is local already (resident or
    /// cached, in `local`): what the processor calls. The default ignores
    /// `local` and calls [`Workload::select_data`].
    ///
    /// A selection may leave out cached items (for example when a workload
    /// remembers that a region is all local and skips its clipping), at a
    /// price: only selected items are pinned, so a left-out cached item may
    /// be evicted before the task runs, and the task must cope (a
    /// demand-driven task can emit data-parallel work for what it finds
    /// missing). [`DataView::keeps_everything`] tells when nothing can leave.
    fn select_data_in(
        &self,
        task: &Self::DdTask,
        local: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Vec<Self::DataId> {
        let _ = local;
        self.select_data(task, ctx)
    }

    /// Executes a demand-driven task. Every id returned by
    /// [`Workload::select_data`] is present in `data`. May emit results,
    /// data-parallel tasks and child demand-driven tasks through `ctx`.
    fn execute_dd(&self, task: Self::DdTask, data: &DataView<'_, Self>, ctx: &mut Ctx<Self>);

    /// Fallback for a demand-driven task whose selected non-resident data does
    /// not fit in the cache budget at all: turn it into data-parallel work
    /// (emitted through `ctx`) that computes the same results. The framework
    /// never lets such a task wait for data that can never be held.
    fn to_data_parallel(&self, task: Self::DdTask, ctx: &mut Ctx<Self>);

    /// The data id a data-parallel task needs next, or `None` when it needs no
    /// further data and can finish wherever it is.
    fn route_dp(&self, task: &Self::DpTask) -> Option<Self::DataId>;

    /// Runs a data-parallel task as far as local (resident or cached) data
    /// allows.
    fn execute_dp(
        &self,
        task: Self::DpTask,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<Self::DpTask>;

    /// Merges a result into the accumulator of the processor it was sent to.
    fn merge(&self, acc: &mut Self::Accumulator, result: Self::Result);

    /// Merges a result sent to a processor, where the merge may start work
    /// that only the whole of what has arrived decides (say, more samples
    /// of a hemisphere whose first ones are all in): the tasks and results
    /// it emits through `ctx` are scheduled as a step's are, with this
    /// processor as their origin ([`Ctx::origin`]). Work it charges is
    /// counted. `data` is what the processor holds, as a step sees it
    /// (its broadcast data included; reading it touches no cache recency).
    /// The default calls [`Workload::merge`] and emits nothing. Results
    /// sent to the master are merged with [`Workload::merge`]: the master
    /// runs no tasks. See `SEMANTICS.md`, section 11.
    fn merge_in(
        &self,
        acc: &mut Self::Accumulator,
        result: Self::Result,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) {
        let _ = (data, ctx);
        self.merge(acc, result)
    }

    /// Called on the master when epoch `ended` (0 the first, whose tasks are
    /// [`Workload::root_tasks`]) is over: every task of it and every task
    /// they spawned has finished, and every result sent to any actor is
    /// merged. `master` is the master's accumulator. Returns the next
    /// epoch (its root tasks, and write-once data that every processor
    /// holds before any of them runs), or `None` to end the run (the
    /// default: one epoch). See `SEMANTICS.md`, section 10.
    ///
    /// For work in rounds where a round reads what the rounds before it
    /// made: an irradiance cache grown in waves of pixels, a frontier
    /// expanded level by level. For the same results on every runtime the
    /// answer must depend only on what `master` holds, not on the order in
    /// which results were merged.
    fn next_epoch(&self, ended: usize, master: &mut Self::Accumulator) -> Option<Epoch<Self>> {
        let _ = (ended, master);
        None
    }
}

/// What [`Workload::next_epoch`] starts: root tasks, and data broadcast to
/// every processor before they run.
#[derive(Debug)]
pub struct Epoch<W: Workload> {
    /// The epoch's root tasks, handed out like [`Workload::root_tasks`].
    pub roots: Vec<W::DdTask>,
    /// Write-once data: every processor holds these items (read-only, as
    /// if resident: [`DataView::get`] finds them, data selection may name
    /// them and never fetches them) from before it receives any task of
    /// this epoch to the end of the run. An id must be new: not placed by
    /// [`Workload::placement`] nor broadcast before (else the run fails).
    /// They are not counted in the cache budget.
    pub broadcast: Vec<(W::DataId, W::DataItem)>,
}

/// The hook context: everything a hook may do besides reading data.
///
/// Emitted work is collected here and scheduled by the framework after the
/// hook returns (demand-driven children by the [`crate::Policy`], data-parallel
/// tasks by [`Workload::route_dp`], results to their destination).
#[derive(Debug)]
pub struct Ctx<W: Workload> {
    proc: usize,
    procs: usize,
    pub(crate) origin: usize,
    pub(crate) charges: Vec<(W::Work, u64)>,
    /// Per kind ([`WorkKind::index`]): 1 + its entry in `charges`, 0 for
    /// none yet (kinds beyond 255 entries are searched for).
    slots: Vec<u8>,
    pub(crate) dd: Vec<W::DdTask>,
    pub(crate) dp: Vec<W::DpTask>,
    pub(crate) results: Vec<(Addr, W::Result)>,
    /// The hook asked for the processor's cache to be completed
    /// ([`Ctx::complete_cache`]).
    pub(crate) complete: bool,
}

impl<W: Workload> Ctx<W> {
    /// A context for processor `proc` of `procs`, for a root task (the
    /// origin is `proc`).
    pub fn new(proc: usize, procs: usize) -> Self {
        Ctx {
            proc,
            procs,
            origin: proc,
            charges: Vec::new(),
            slots: vec![0; <W::Work as WorkKind>::ALL.len()],
            dd: Vec::new(),
            dp: Vec::new(),
            results: Vec::new(),
            complete: false,
        }
    }

    /// Empties the context for reuse (keeping its buffers).
    pub(crate) fn clear(&mut self) {
        for &(k, _) in &self.charges {
            if let Some(s) = self.slots.get_mut(k.index()) {
                *s = 0;
            }
        }
        self.charges.clear();
        self.dd.clear();
        self.dp.clear();
        self.results.clear();
        self.complete = false;
    }

    /// Asks for the running processor's cache to be completed now
    /// ([`crate::Config::complete_cache`]) instead of when its tasks have
    /// asked for the configured share: the workload judges that reaching
    /// the data it lacks (walking past it, migrating towards it) has come
    /// to cost more than holding it would. Honoured after the hook returns
    /// where completion is configured (a cache without budget and no
    /// fetch limit) and has not happened yet; ignored otherwise. Like the
    /// threshold, it changes where data is, never a result (SEMANTICS.md
    /// section 6).
    pub fn complete_cache(&mut self) {
        self.complete = true;
    }

    /// The processor running the hook. Informational only: results must not
    /// depend on it (see the [`Workload`] contract).
    pub fn proc_id(&self) -> usize {
        self.proc
    }

    /// The processor that ran the root task this task descends from (its
    /// data selection): where a family of tasks started, for instance the
    /// owner of a tile's pixels. For a root task, the running processor.
    /// Tracked by the framework, so tasks need not carry it.
    pub fn origin(&self) -> usize {
        self.origin
    }

    /// The same context, for a task descending from `origin`'s root (for
    /// calling hooks by hand; runtimes set it themselves).
    pub fn with_origin(mut self, origin: usize) -> Self {
        self.origin = origin;
        self
    }

    /// Number of worker processors in the run.
    pub fn procs(&self) -> usize {
        self.procs
    }

    /// Records `units` of counted work of kind `kind` (e.g. intersections,
    /// clipped nodes). The simulator turns these into virtual time with a
    /// cost model; all runtimes report them in the statistics, by
    /// [`WorkKind::name`].
    #[inline]
    pub fn charge(&mut self, kind: W::Work, units: u64) {
        // Kinds keep the order they were first charged in (what the
        // simulator sums in), found by index rather than by search.
        let slot = self.slots.get(kind.index()).copied().unwrap_or(0);
        if slot != 0 {
            let entry = &mut self.charges[slot as usize - 1];
            entry.1 = entry.1.saturating_add(units);
        } else if let Some(entry) = self.charges.iter_mut().find(|(k, _)| *k == kind) {
            entry.1 = entry.1.saturating_add(units);
        } else {
            self.charges.push((kind, units));
            let n = self.charges.len();
            if let (Some(s), Ok(n)) = (self.slots.get_mut(kind.index()), u8::try_from(n)) {
                *s = n;
            }
        }
    }

    /// Emits a child demand-driven task (placed by the scheduling policy).
    pub fn spawn_dd(&mut self, task: W::DdTask) {
        self.dd.push(task);
    }

    /// Emits a data-parallel task (sent towards its next data).
    pub fn spawn_dp(&mut self, task: W::DpTask) {
        self.dp.push(task);
    }

    /// Emits a result to be merged at `dest`.
    pub fn emit_result(&mut self, dest: Addr, result: W::Result) {
        self.results.push((dest, result));
    }

    /// The work charged since the context was created or last drained.
    pub fn charges(&self) -> &[(W::Work, u64)] {
        &self.charges
    }

    pub(crate) fn has_emissions(&self) -> bool {
        !(self.dd.is_empty() && self.dp.is_empty() && self.results.is_empty())
    }
}

/// Read-only access to the data local to a processor: its resident items and
/// whatever its cache holds. Lookups of cached items are remembered so that the
/// processor can refresh their LRU recency after the hook returns.
pub struct DataView<'a, W: Workload> {
    resident: &'a Resident<W::DataId, W::DataItem>,
    /// Broadcast items, resident too (`None`: none).
    broadcast: Option<&'a Resident<W::DataId, W::DataItem>>,
    cache: Option<&'a ByteLru<W::DataId, W::DataItem>>,
    touched: RefCell<Vec<W::DataId>>,
}

impl<'a, W: Workload> DataView<'a, W> {
    /// A view over resident items and an optional cache.
    pub fn new(
        resident: &'a Resident<W::DataId, W::DataItem>,
        cache: Option<&'a ByteLru<W::DataId, W::DataItem>>,
    ) -> Self {
        DataView {
            resident,
            broadcast: None,
            cache,
            touched: RefCell::new(Vec::new()),
        }
    }

    /// The same view with broadcast items besides the resident ones (none
    /// are looked at when it is empty).
    pub(crate) fn with_broadcast(mut self, items: &'a Resident<W::DataId, W::DataItem>) -> Self {
        self.broadcast = (!items.is_empty()).then_some(items);
        self
    }

    /// A resident or broadcast item.
    #[inline]
    fn held(&self, id: &W::DataId) -> Option<&'a W::DataItem> {
        self.resident
            .get(id)
            .or_else(|| self.broadcast.and_then(|b| b.get(id)))
    }

    /// The item, if it is resident or cached here.
    pub fn get(&self, id: &W::DataId) -> Option<&'a W::DataItem> {
        if let Some(item) = self.held(id) {
            return Some(item);
        }
        let item = self.cache?.peek(id)?;
        // A task visits the same cell many times in a row (every ray of a
        // bundle); its recency is refreshed once per run of visits.
        let mut touched = self.touched.borrow_mut();
        if touched.last() != Some(id) {
            touched.push(id.clone());
        }
        Some(item)
    }

    /// [`DataView::get`] without refreshing the item's recency or counting
    /// a use: for a task that reads again, in the same step, what it has
    /// read already (its uses are counted once).
    pub fn peek(&self, id: &W::DataId) -> Option<&'a W::DataItem> {
        self.held(id)
            .or_else(|| self.cache.and_then(|c| c.peek(id)))
    }

    /// Whether the item is resident or cached here.
    pub fn is_local(&self, id: &W::DataId) -> bool {
        self.held(id).is_some() || self.cache.is_some_and(|c| c.contains(id))
    }

    /// Whether the item is resident (owned, or broadcast) here.
    pub fn is_resident(&self, id: &W::DataId) -> bool {
        self.held(id).is_some()
    }

    /// Whether the cache has no budget: nothing cached is ever evicted, so
    /// whatever is local now stays local for the whole run.
    pub fn keeps_everything(&self) -> bool {
        self.cache.is_none_or(|c| c.budget() == u64::MAX)
    }

    /// Items in the cache (resident ones not counted).
    pub fn cached_len(&self) -> usize {
        self.cache.map_or(0, |c| c.len())
    }

    /// Every item held here, resident then cached, without touching the
    /// cache's recency (a workload indexing what it holds, not using it).
    pub fn local_items(&self) -> impl Iterator<Item = (&'a W::DataId, &'a W::DataItem)> {
        self.resident
            .iter()
            .chain(self.broadcast.into_iter().flat_map(|b| b.iter()))
            .chain(self.cache.into_iter().flat_map(|c| c.iter()))
    }

    pub(crate) fn into_touched(self) -> Vec<W::DataId> {
        self.touched.into_inner()
    }
}
