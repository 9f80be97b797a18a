//! The replicated ownership directory: data id -> (owner, bytes), what
//! every processor knows of the placement.
//!
//! By default a sorted copy of [`Workload::placement`] is searched by
//! halving, one per process, shared by its processors: an entry per data
//! item of the whole run (an octree leaf of the renderer's scene), so its
//! size is part of what each rank pays for the scene whatever its share.
//! As a hash map it took 6.5 MB on every processor for a
//! 300,000-triangle city's 166,000 leaves (valgrind's massif); as a list,
//! 16 bytes an entry (2.7 MB). A workload that holds that index anyway
//! ([`Workload::locates`]) is asked instead, and the processors keep
//! nothing. Either way the directory is built and checked once per
//! process ([`Directory::shared`]), not once per processor, and each
//! processor's count of items and bytes is tallied in that one pass.

use std::borrow::Cow;
use std::sync::Arc;

use crate::protocol::workload::Workload;
use crate::protocol::Placement;

/// One entry: (id, owner, bytes).
pub(crate) type Entry<Id> = (Id, u32, u64);

/// See the module documentation.
pub(crate) struct Directory<W: Workload> {
    index: Index<W>,
    /// Per processor: how many items it owns and their bytes.
    tally: Vec<(usize, u64)>,
    /// The bytes of every item.
    total_bytes: u64,
    /// The workload, for what caches charge ([`Workload::cache_charge`]);
    /// `None` charges the placement's bytes.
    charges: Option<Arc<W>>,
}

/// Where the directory's answers come from.
enum Index<W: Workload> {
    /// A sorted copy of the placement.
    Listed(Vec<Entry<W::DataId>>),
    /// The workload answers ([`Workload::locate`]).
    Asked { workload: Arc<W>, procs: usize },
}

impl<W: Workload> std::fmt::Debug for Directory<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.index {
            Index::Listed(e) => write!(f, "Directory::Listed({} entries)", e.len()),
            Index::Asked { procs, .. } => write!(f, "Directory::Asked({procs} processors)"),
        }
    }
}

/// Per processor of `procs`, the count and bytes of the items `owners`
/// (owner, bytes) places on it, and the bytes of all (owners already
/// checked to be in range).
fn tally(procs: usize, owners: impl Iterator<Item = (u32, u64)>) -> (Vec<(usize, u64)>, u64) {
    let mut t = vec![(0usize, 0u64); procs];
    let mut total = 0u64;
    for (owner, bytes) in owners {
        let e = &mut t[owner as usize];
        e.0 += 1;
        e.1 += bytes;
        total += bytes;
    }
    (t, total)
}

/// An owner as an entry stores it (never more than `u32::MAX` processors
/// run), rejecting one out of range.
fn owner_u32<Id: std::fmt::Debug>(id: &Id, owner: usize, procs: usize) -> Result<u32, String> {
    if owner >= procs {
        return Err(format!(
            "data {id:?} is placed on processor {owner} but there are only {procs}"
        ));
    }
    u32::try_from(owner).map_err(|_| format!("data {id:?} is placed on processor {owner}"))
}

/// The first id listed twice in `items` (sorted by `id`), as an error.
fn no_duplicates<T, Id: Eq + std::fmt::Debug>(
    items: &[T],
    id: impl Fn(&T) -> &Id,
) -> Result<(), String> {
    match items.windows(2).find(|w| id(&w[0]) == id(&w[1])) {
        Some(w) => Err(format!("data {:?} is placed twice", id(&w[0]))),
        None => Ok(()),
    }
}

impl<W: Workload> Directory<W> {
    /// The directory of `workload` on `procs` processors: the workload
    /// itself where it [`Workload::locates`] (each entry of its placement
    /// checked against its answer), else a sorted copy of its placement.
    /// Duplicate ids and owners out of range are refused either way.
    pub(crate) fn new(workload: &Arc<W>, procs: usize) -> Result<Self, String> {
        let placement = workload.placement(procs);
        if !workload.locates() {
            let mut d = Self::build(placement, procs)?;
            d.charges = Some(Arc::clone(workload));
            return Ok(d);
        }
        let mut ids = Vec::with_capacity(placement.len());
        for p in &placement {
            owner_u32(&p.id, p.owner, procs)?;
            match workload.locate(&p.id, procs) {
                Some(at) if at == (p.owner, p.bytes) => {}
                got => {
                    return Err(format!(
                        "data {:?} is placed on processor {} with {} bytes but the workload locates it at {got:?}",
                        p.id, p.owner, p.bytes
                    ))
                }
            }
            ids.push(p.id.clone());
        }
        ids.sort_unstable();
        no_duplicates(&ids, |i| i)?;
        // Owners checked above.
        let (tally, total_bytes) =
            tally(procs, placement.iter().map(|p| (p.owner as u32, p.bytes)));
        Ok(Directory {
            index: Index::Asked {
                workload: Arc::clone(workload),
                procs,
            },
            tally,
            total_bytes,
            charges: Some(Arc::clone(workload)),
        })
    }

    /// [`Directory::new`], built and checked once for the processors of a
    /// process and shared by them.
    pub(crate) fn shared(workload: &Arc<W>, procs: usize) -> Result<Arc<Self>, crate::RunError> {
        Self::new(workload, procs)
            .map(Arc::new)
            .map_err(|m| crate::RunError::Config(crate::ConfigError::Placement(m)))
    }

    /// A sorted copy of `placement`.
    pub(crate) fn build(
        placement: Vec<Placement<W::DataId>>,
        procs: usize,
    ) -> Result<Self, String> {
        let mut entries = Vec::with_capacity(placement.len());
        for p in placement {
            let owner = owner_u32(&p.id, p.owner, procs)?;
            entries.push((p.id, owner, p.bytes));
        }
        entries.sort_unstable_by(|a, b| a.0.cmp(&b.0));
        no_duplicates(&entries, |e| &e.0)?;
        let (tally, total_bytes) = tally(procs, entries.iter().map(|e| (e.1, e.2)));
        Ok(Directory {
            index: Index::Listed(entries),
            tally,
            total_bytes,
            charges: None,
        })
    }

    /// Owner and bytes of `id`.
    #[inline]
    pub(crate) fn locate(&self, id: &W::DataId) -> Option<(usize, u64)> {
        match &self.index {
            Index::Listed(entries) => entries
                .binary_search_by(|e| e.0.cmp(id))
                .ok()
                .map(|k| (entries[k].1 as usize, entries[k].2)),
            Index::Asked { workload, procs } => workload.locate(id, *procs),
        }
    }

    /// Whether `id` is placed.
    pub(crate) fn contains(&self, id: &W::DataId) -> bool {
        self.locate(id).is_some()
    }

    /// Owner of `id`.
    pub(crate) fn owner(&self, id: &W::DataId) -> Option<usize> {
        self.locate(id).map(|l| l.0)
    }

    /// Size of `id` in bytes.
    pub(crate) fn bytes(&self, id: &W::DataId) -> Option<u64> {
        self.locate(id).map(|l| l.1)
    }

    /// What a cache charges for `id`, of `bytes` in the placement
    /// ([`Workload::cache_charge`]).
    #[inline]
    pub(crate) fn charge(&self, id: &W::DataId, bytes: u64) -> u64 {
        self.charges
            .as_ref()
            .map_or(bytes, |w| w.cache_charge(id, bytes))
    }

    /// Every entry, ascending by id: the list, or one made for the call
    /// from the workload's placement (a start-up or once-a-run question).
    pub(crate) fn entries(&self) -> Cow<'_, [Entry<W::DataId>]> {
        match &self.index {
            Index::Listed(entries) => Cow::Borrowed(entries),
            Index::Asked { workload, procs } => {
                let mut entries: Vec<_> = workload
                    .placement(*procs)
                    .into_iter()
                    // Checked when the directory was made.
                    .map(|p| (p.id, p.owner as u32, p.bytes))
                    .collect();
                entries.sort_unstable_by(|a, b| a.0.cmp(&b.0));
                Cow::Owned(entries)
            }
        }
    }

    /// How many items are placed on `proc`, and the bytes of those placed
    /// elsewhere: tallied when the directory was made.
    pub(crate) fn count_on_and_bytes_elsewhere(&self, proc: usize) -> (usize, u64) {
        let (count, bytes) = self.tally.get(proc).copied().unwrap_or((0, 0));
        (count, self.total_bytes - bytes)
    }
}
