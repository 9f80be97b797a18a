//! A processor's data: resident items, the byte-budgeted cache of fetched
//! items, the replicated ownership directory, and the table of tasks waiting
//! for data.
//!
//! The protocol for a demand-driven task (see [`DataStore::admit`]):
//! 1. after data selection, the non-resident ids are checked against the
//!    budget: if they can never fit, the task is handed back for the
//!    data-parallel fallback; if they do not fit *now* (other tasks have pinned
//!    the space), the task is deferred until pins are released;
//! 2. otherwise cached ids are pinned, space for the missing ones is reserved,
//!    and one request per owner is produced listing the ids nobody has asked
//!    for yet (ids already in flight for another task are shared, not asked
//!    for twice);
//! 3. replies fill the cache (pinned) and wake the tasks whose last missing id
//!    arrived; after execution the task's pins are released.

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::cache::{ByteLru, IdMap};
pub(crate) use crate::directory::Directory;
use crate::protocol::message::DdEnvelope;
use crate::protocol::workload::{ByteSize, DataView, Workload};
use crate::resident::Resident;

/// Most accounted bytes asked for in one request when a cache completes
/// itself ([`DataStore::complete`]): the rest of a large scene comes in
/// replies of about this size, not one that a transport cannot carry (MPI
/// counts a message's bytes in an `int`) or that doubles the owner's
/// memory while it is encoded.
const COMPLETION_REPLY_BYTES: u64 = 8 << 20;

/// One owner's completion requests, and the bytes of the last.
type Chunks<Id> = (Vec<Vec<Id>>, u64);

/// Data items with their ids, as carried by a data reply.
pub(crate) type Items<W> = Vec<(<W as Workload>::DataId, <W as Workload>::DataItem)>;

/// Key of a task in the waiting table.
pub(crate) type TaskKey = u64;

struct WaitingTask<W: Workload> {
    env: DdEnvelope<W>,
    pinned: Vec<W::DataId>,
    missing: usize,
    bytes: usize,
}

struct InFlight {
    /// What the cache reserved for it: its charge
    /// ([`crate::Workload::cache_charge`]).
    bytes: u64,
    waiters: Vec<TaskKey>,
}

/// A demand-driven task whose data is all local (its cached items pinned).
pub(crate) struct ReadyTask<W: Workload> {
    /// The task.
    pub env: DdEnvelope<W>,
    /// Non-resident ids pinned for it; release them after execution.
    pub pinned: Vec<W::DataId>,
}

/// Outcome of [`DataStore::admit`].
pub(crate) enum Admission<W: Workload> {
    /// All data is local; run it.
    Ready(ReadyTask<W>),
    /// Registered as waiting; send these requests (owner, ids).
    Waiting(Vec<(usize, Vec<W::DataId>)>),
    /// Fits the budget, but not while other tasks hold their pins: try again
    /// (with these non-resident ids) after a release.
    Deferred(DdEnvelope<W>, Vec<W::DataId>),
    /// Its non-resident data exceeds the whole budget, or it has more to
    /// fetch than [`crate::Config::fetch_limit`]: use the data-parallel
    /// fallback.
    TooBig(DdEnvelope<W>),
}

/// The data store of one processor. See the module documentation.
pub(crate) struct DataStore<W: Workload> {
    me: usize,
    /// The items placed here, shared with the processor's data server
    /// (read-only for the whole run).
    resident: Arc<Resident<W::DataId, W::DataItem>>,
    /// Write-once broadcast items ([`crate::Epoch::broadcast`]), held as
    /// resident but never served.
    broadcast: Resident<W::DataId, W::DataItem>,
    resident_bytes: u64,
    cache: ByteLru<W::DataId, W::DataItem>,
    /// [`crate::Config::fetch_limit`].
    fetch_limit: Option<u64>,
    /// [`crate::Config::complete_cache`]: the bytes asked for after which
    /// the rest is asked for (`None`: never, or done).
    complete_at: Option<u64>,
    /// Bytes asked for from other processors so far.
    asked_bytes: u64,
    /// Shared by a process's processors (built and checked once).
    dir: Arc<Directory<W>>,
    in_flight: IdMap<W::DataId, InFlight>,
    waiting: IdMap<TaskKey, WaitingTask<W>>,
    next_key: TaskKey,
    waiting_bytes: usize,
    waiting_high_water: usize,
    waiting_bytes_high_water: usize,
}

impl<W: Workload> DataStore<W> {
    /// A store for processor `me` holding `resident`, checked against `dir`
    /// (`complete_cache`: [`crate::Config::complete_cache`]).
    pub(crate) fn new(
        me: usize,
        resident: Vec<(W::DataId, W::DataItem)>,
        dir: Arc<Directory<W>>,
        cache_bytes: Option<u64>,
        fetch_limit: Option<u64>,
        complete_cache: Option<u8>,
    ) -> Result<Self, String> {
        let mut resident_bytes = 0u64;
        for (id, item) in &resident {
            match dir.locate(id) {
                Some((owner, _)) if owner != me => {
                    return Err(format!(
                        "processor {me} loaded data {id:?}, which the directory places on {owner}"
                    ))
                }
                None => {
                    return Err(format!(
                        "processor {me} loaded data {id:?}, which the directory does not know"
                    ))
                }
                Some((_, bytes)) if bytes != item.byte_size() as u64 => {
                    return Err(format!(
                        "data {id:?} is {} bytes but the directory says {bytes}",
                        item.byte_size()
                    ))
                }
                _ => {}
            }
            resident_bytes += item.byte_size() as u64;
        }
        // The loaded list becomes the store's, not copied.
        let map = Resident::from_vec(resident)
            .map_err(|id| format!("processor {me} loaded data {id:?} twice"))?;
        let (expected, elsewhere) = dir.count_on_and_bytes_elsewhere(me);
        if expected != map.len() {
            return Err(format!(
                "processor {me} loaded {} items but the directory places {expected} on it",
                map.len()
            ));
        }
        // Only a cache that never evicts can hold the rest, and a fetch
        // limit says that large fetches cost more than migrating work.
        let complete_at = complete_cache
            .filter(|_| cache_bytes.is_none() && fetch_limit.is_none())
            .map(|p| (u128::from(elsewhere) * u128::from(p) / 100) as u64);
        Ok(DataStore {
            me,
            resident: Arc::new(map),
            broadcast: Resident::default(),
            resident_bytes,
            cache: ByteLru::new(cache_bytes),
            fetch_limit,
            complete_at,
            asked_bytes: 0,
            dir,
            in_flight: IdMap::default(),
            waiting: IdMap::default(),
            next_key: 0,
            waiting_bytes: 0,
            waiting_high_water: 0,
            waiting_bytes_high_water: 0,
        })
    }

    /// Holds write-once items broadcast to every processor
    /// ([`crate::Epoch::broadcast`]) as resident. An id the directory
    /// places, or one already held, is refused.
    pub(crate) fn hold_broadcast(&mut self, items: Items<W>) -> Result<(), String> {
        for (id, item) in items {
            if self.dir.contains(&id) {
                return Err(format!(
                    "broadcast data {id:?} is placed data (broadcast ids must be new)"
                ));
            }
            let bytes = item.byte_size() as u64;
            if self.broadcast.insert(id.clone(), item).is_some() {
                return Err(format!(
                    "broadcast data {id:?} is already held (broadcast data is written once)"
                ));
            }
            self.resident_bytes += bytes;
        }
        Ok(())
    }

    /// The directory.
    pub(crate) fn directory(&self) -> &Directory<W> {
        &self.dir
    }

    /// The cache.
    pub(crate) fn cache(&self) -> &ByteLru<W::DataId, W::DataItem> {
        &self.cache
    }

    /// Bytes of resident data.
    pub(crate) fn resident_bytes(&self) -> u64 {
        self.resident_bytes
    }

    /// Whether `id` is resident or cached.
    pub(crate) fn is_local(&self, id: &W::DataId) -> bool {
        self.holds(id) || self.cache.contains(id)
    }

    /// A read-only view of local data for a hook.
    pub(crate) fn view(&self) -> DataView<'_, W> {
        DataView::new(&self.resident, Some(&self.cache)).with_broadcast(&self.broadcast)
    }

    /// Refreshes LRU recency of cached items a hook used (counted as hits).
    pub(crate) fn touch(&mut self, ids: &[W::DataId]) {
        for id in ids {
            self.cache.touch(id);
        }
    }

    /// Counts a cache miss (a data-parallel task leaving for missing data).
    pub(crate) fn record_miss(&mut self) {
        self.cache.record_miss();
    }

    /// Tasks waiting for data.
    pub(crate) fn waiting_len(&self) -> usize {
        self.waiting.len()
    }

    /// (count, bytes) high-water marks of waiting tasks.
    pub(crate) fn waiting_high_water(&self) -> (usize, usize) {
        (self.waiting_high_water, self.waiting_bytes_high_water)
    }

    /// Whether `id` is resident (placed here, or broadcast).
    fn holds(&self, id: &W::DataId) -> bool {
        self.resident.contains_key(id) || self.broadcast.contains_key(id)
    }

    /// The items placed here, for the processor's data server.
    pub(crate) fn resident_items(&self) -> Arc<Resident<W::DataId, W::DataItem>> {
        Arc::clone(&self.resident)
    }

    /// Admits a demand-driven task whose selection returned `ids`.
    pub(crate) fn admit(
        &mut self,
        env: DdEnvelope<W>,
        mut ids: Vec<W::DataId>,
    ) -> Result<Admission<W>, String> {
        // Stability means nothing for equal ids, which dedup drops.
        ids.sort_unstable();
        ids.dedup();
        let mut remote = Vec::new();
        let (mut total, mut to_pin, mut new_bytes, mut new_charge) = (0u64, 0u64, 0u64, 0u64);
        for id in ids {
            if self.holds(&id) {
                continue;
            }
            let bytes = self
                .dir
                .bytes(&id)
                .ok_or_else(|| format!("data selection named unknown data {id:?}"))?;
            // The cache counts charges; the fetch limit, bytes that travel.
            let charge = self.dir.charge(&id, bytes);
            total = total.saturating_add(charge);
            if self.cache.contains(&id) {
                if !self.cache.is_pinned(&id) {
                    to_pin += charge;
                }
            } else if !self.in_flight.contains_key(&id) {
                new_bytes += bytes;
                new_charge += charge;
            }
            remote.push(id);
        }
        // Data that can never fit, or more to fetch than one task may
        // have fetched: the data-parallel fallback.
        if total > self.cache.budget() || self.fetch_limit.is_some_and(|l| new_bytes > l) {
            return Ok(Admission::TooBig(env));
        }
        if !self.cache.can_pin_more(to_pin.saturating_add(new_charge)) {
            return Ok(Admission::Deferred(env, remote));
        }
        // Admitted. Pin what is cached first so that the reservation below
        // cannot evict it.
        for id in &remote {
            if self.cache.pin(id) {
                self.cache.record_hit();
            } else {
                self.cache.record_miss();
            }
        }
        let reserved = self.cache.reserve(new_charge);
        debug_assert!(reserved, "admission checked the budget");
        let key = self.next_key;
        self.next_key += 1;
        let mut missing = 0;
        let mut requests: BTreeMap<usize, Vec<W::DataId>> = BTreeMap::new();
        for id in &remote {
            if self.cache.is_pinned(id) {
                continue;
            }
            missing += 1;
            match self.in_flight.get_mut(id) {
                Some(f) => f.waiters.push(key),
                None => {
                    let bytes = self.dir.bytes(id).unwrap_or(0);
                    self.asked_bytes += bytes;
                    self.in_flight.insert(
                        id.clone(),
                        InFlight {
                            bytes: self.dir.charge(id, bytes),
                            waiters: vec![key],
                        },
                    );
                    let owner = self.dir.owner(id).unwrap_or(self.me);
                    requests.entry(owner).or_default().push(id.clone());
                }
            }
        }
        if missing == 0 {
            return Ok(Admission::Ready(ReadyTask {
                env,
                pinned: remote,
            }));
        }
        let bytes = env.task.byte_size();
        self.waiting.insert(
            key,
            WaitingTask {
                env,
                pinned: remote,
                missing,
                bytes,
            },
        );
        self.waiting_bytes += bytes;
        self.waiting_high_water = self.waiting_high_water.max(self.waiting.len());
        self.waiting_bytes_high_water = self.waiting_bytes_high_water.max(self.waiting_bytes);
        Ok(Admission::Waiting(requests.into_iter().collect()))
    }

    /// [`DataStore::complete`] whatever has been asked for, where
    /// completion is configured and has not happened yet (the workload
    /// asked: [`crate::Ctx::complete_cache`]).
    pub(crate) fn complete_now(&mut self) -> Option<Vec<(usize, Vec<W::DataId>)>> {
        if self.complete_at.is_some() {
            self.complete_at = Some(0);
        }
        self.complete()
    }

    /// Completing the cache ([`crate::Config::complete_cache`]): once the
    /// bytes asked for reach the threshold, every item placed elsewhere
    /// and neither cached nor on its way, as requests (owner, ids; about
    /// [`COMPLETION_REPLY_BYTES`] each at most; none where everything is
    /// asked for already), once: `None` before and after. No task waits
    /// for them; they join the cache unpinned.
    pub(crate) fn complete(&mut self) -> Option<Vec<(usize, Vec<W::DataId>)>> {
        if self.complete_at.is_none_or(|at| self.asked_bytes < at) {
            return None;
        }
        self.complete_at = None;
        // Per owner: the requests so far, the last one's bytes.
        let mut requests: BTreeMap<usize, Chunks<W::DataId>> = BTreeMap::new();
        let (mut bytes, mut charges) = (0u64, 0u64);
        let entries = self.dir.entries();
        for (id, owner, b) in entries.iter() {
            let owner = *owner as usize;
            if owner == self.me || self.cache.contains(id) || self.in_flight.contains_key(id) {
                continue;
            }
            let charge = self.dir.charge(id, *b);
            self.in_flight.insert(
                id.clone(),
                InFlight {
                    bytes: charge,
                    waiters: Vec::new(),
                },
            );
            bytes += b;
            charges += charge;
            let (chunks, last) = requests.entry(owner).or_default();
            if chunks.is_empty() || *last + b > COMPLETION_REPLY_BYTES {
                chunks.push(Vec::new());
                *last = 0;
            }
            *last += b;
            chunks.last_mut().expect("pushed").push(id.clone());
        }
        self.asked_bytes += bytes;
        // Never refused: the cache has no budget.
        let reserved = self.cache.reserve(charges);
        debug_assert!(reserved, "completion needs a cache without a budget");
        Some(
            requests
                .into_iter()
                .flat_map(|(owner, (chunks, _))| chunks.into_iter().map(move |ids| (owner, ids)))
                .collect(),
        )
    }

    /// Stores the items of a data reply and returns the tasks it completed,
    /// in the order they were admitted.
    pub(crate) fn on_reply(&mut self, items: Items<W>) -> Result<Vec<ReadyTask<W>>, String> {
        let mut woken = Vec::new();
        for (id, item) in items {
            let Some(f) = self.in_flight.remove(&id) else {
                return Err(format!("received data {id:?} that was not requested"));
            };
            let pins = f.waiters.len() as u32;
            self.cache.insert_reserved(id, item, f.bytes, f.bytes, pins);
            for key in f.waiters {
                let Some(t) = self.waiting.get_mut(&key) else {
                    continue;
                };
                t.missing -= 1;
                if t.missing == 0 {
                    woken.push(key);
                }
            }
        }
        woken.sort_unstable();
        Ok(woken
            .into_iter()
            .filter_map(|key| self.waiting.remove(&key))
            .map(|t| {
                self.waiting_bytes -= t.bytes;
                ReadyTask {
                    env: t.env,
                    pinned: t.pinned,
                }
            })
            .collect())
    }

    /// Releases the pins of a task that has run.
    pub(crate) fn release(&mut self, pinned: &[W::DataId]) {
        for id in pinned {
            self.cache.unpin(id);
        }
    }
}
