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
//! process ([`Directory::shared`]), not once per processor.

use std::borrow::Cow;
use std::sync::Arc;

use crate::protocol::workload::Workload;
use crate::protocol::Placement;

/// One entry: (id, owner, bytes).
pub(crate) type Entry<Id> = (Id, u32, u64);

/// See the module documentation.
pub(crate) enum Directory<W: Workload> {
    /// A sorted copy of the placement.
    Listed(Vec<Entry<W::DataId>>),
    /// The workload answers ([`Workload::locate`]).
    Asked { workload: Arc<W>, procs: usize },
}

impl<W: Workload> std::fmt::Debug for Directory<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Directory::Listed(e) => write!(f, "Directory::Listed({} entries)", e.len()),
            Directory::Asked { procs, .. } => write!(f, "Directory::Asked({procs} processors)"),
        }
    }
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
            return Self::build(placement, procs);
        }
        let mut ids = Vec::with_capacity(placement.len());
        for p in placement {
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
            ids.push(p.id);
        }
        ids.sort_unstable();
        no_duplicates(&ids, |i| i)?;
        Ok(Directory::Asked {
            workload: Arc::clone(workload),
            procs,
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
        Ok(Directory::Listed(entries))
    }

    /// Owner and bytes of `id`.
    #[inline]
    pub(crate) fn locate(&self, id: &W::DataId) -> Option<(usize, u64)> {
        match self {
            Directory::Listed(entries) => entries
                .binary_search_by(|e| e.0.cmp(id))
                .ok()
                .map(|k| (entries[k].1 as usize, entries[k].2)),
            Directory::Asked { workload, procs } => workload.locate(id, *procs),
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

    /// Every entry, ascending by id: the list, or one made for the call
    /// from the workload's placement (a start-up or once-a-run question).
    pub(crate) fn entries(&self) -> Cow<'_, [Entry<W::DataId>]> {
        match self {
            Directory::Listed(entries) => Cow::Borrowed(entries),
            Directory::Asked { workload, procs } => {
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
    /// elsewhere (in any order: nothing sorted for it).
    pub(crate) fn count_on_and_bytes_elsewhere(&self, proc: usize) -> (usize, u64) {
        let count = |(n, b): (usize, u64), (owner, bytes): (usize, u64)| match owner == proc {
            true => (n + 1, b),
            false => (n, b + bytes),
        };
        match self {
            Directory::Listed(entries) => entries
                .iter()
                .map(|e| (e.1 as usize, e.2))
                .fold((0, 0), count),
            Directory::Asked { workload, procs } => workload
                .placement(*procs)
                .iter()
                .map(|p| (p.owner, p.bytes))
                .fold((0, 0), count),
        }
    }
}
