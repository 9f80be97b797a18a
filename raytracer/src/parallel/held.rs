//! The processors of a distributed compiled scene: each holds the
//! replicated part and reads its own cells (see [`crate::compiled`]).

use rustc_hash::FxHashSet;
use std::sync::{Mutex, RwLock};

use super::distribution::Distribution;
use super::partition::object_bytes;
use super::tasks::CellData;
use super::workload::{Held, RtWorkload, WorkloadOptions};
use crate::accel::{HeldObject, LeafObjects, NodeId, ObjectCopies};
use crate::compiled::CellSource;
use crate::render::Renderer;
use crate::scene::View;

impl RtWorkload {
    /// A workload over a distributed compiled scene: `renderer` holds the
    /// replicated part ([`crate::compiled::HeldPart`]), and processors read
    /// their cells from `source` (before the run, [`RtWorkload::read_part`],
    /// else when they start). With the `octree` and `worst` distributions
    /// the partition is the one of the scene loaded whole; the `predicted`
    /// one cuts by `predicted`, the work predicted per node when the scene
    /// was compiled ([`crate::compiled::HeldPart::predicted_costs`]: a
    /// processor holding part of the scene cannot predict it). The picture
    /// is the scene's loaded whole. Not for the `replicated` distribution,
    /// which needs every object.
    #[allow(clippy::too_many_arguments)]
    pub fn distributed(
        renderer: Renderer<'static>,
        view: View,
        width: usize,
        height: usize,
        procs: usize,
        opts: WorkloadOptions,
        source: CellSource,
        predicted: Option<Vec<u64>>,
    ) -> crate::Result<Self> {
        if opts.distribution == Distribution::Replicated {
            return Err(crate::Error::Usage(format!(
                "distribution {} needs every object on every processor; a processor of a distributed scene holds only its cells (use octree, predicted or worst, or render the scene whole)",
                opts.distribution
            )));
        }
        let predicted = match (opts.distribution, predicted) {
            (Distribution::Predicted, Some(p)) if p.len() == renderer.octree().node_count() => p,
            (Distribution::Predicted, _) => {
                return Err(crate::Error::Usage(
                    "the predicted distribution of a distributed scene needs the work predicted when it was compiled".into(),
                ))
            }
            _ => Vec::new(),
        };
        let cells = source.cells().clone();
        let procs = procs.max(1);
        let held = Held {
            source: RwLock::new(Some(source)),
            parts: (0..procs).map(|_| Mutex::new(None)).collect(),
            figures: (0..procs).map(|_| Mutex::new(None)).collect(),
            per_copy: std::sync::OnceLock::new(),
        };
        Ok(Self::assemble(
            renderer,
            view,
            width,
            height,
            procs,
            opts,
            cells,
            Some(held),
            Some(predicted),
        ))
    }

    /// Reads processor `proc`'s cells of a distributed scene (nothing for
    /// a scene loaded whole), keeping them for the processor: errors name
    /// the processor, the file and what could not be read.
    pub fn read_part(&self, proc: usize) -> crate::Result<()> {
        let Some(h) = &self.held else {
            return Ok(());
        };
        let cells = self.read_cells(h, proc)?;
        if let Some(slot) = h.parts.get(proc) {
            *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some(cells);
        }
        Ok(())
    }

    /// [`RtWorkload::read_part`] for processors `0..procs`, side by side
    /// on up to one thread per core (each reads only its own cells): on
    /// two cores, four processors of a 1.5M-triangle city read theirs in
    /// 2.6-2.7 s instead of 3.9-4.2. An error is the lowest-numbered
    /// processor's.
    pub fn read_parts(&self, procs: usize) -> crate::Result<()> {
        hybrid_sched::par::map_indices(procs, |p| self.read_part(p))
            .into_iter()
            .collect()
    }

    /// Every processor of this process has read its part: the source (the
    /// file's cell index reader) is let go, and what a copy takes on
    /// average is worked out for the caches' charges
    /// (`Workload::cache_charge`).
    pub fn parts_read(&self) {
        if let Some(h) = &self.held {
            *h.source.write().unwrap_or_else(|e| e.into_inner()) = None;
            let (mut bytes, mut copies) = (0u64, 0u64);
            for f in &h.figures {
                if let Some((_, b, n)) = *f.lock().unwrap_or_else(|e| e.into_inner()) {
                    (bytes, copies) = (bytes + b, copies + n);
                }
            }
            if copies > 0 {
                let _ = h.per_copy.set(bytes.div_ceil(copies));
                tracing::debug!(copies, bytes, "copies read, for the caches' charges");
            }
        }
    }

    /// What a processor's cache charges for a cell of a distributed scene
    /// (of `bytes` in the placement): what its copies take, estimated as
    /// every object of the leaf's list a copy of the average size this
    /// process read, and 12 bytes a listing for the leaf's lists. A cell
    /// of the octree's accounting counts each object's share of the leaves
    /// listing it; a cached cell holds whole copies of them, which took
    /// 2.3 to 3 times the cells' bytes on the ranks of the 1.5M-triangle
    /// city. Its placement bytes where nothing was read (a scene loaded
    /// whole), and never less.
    pub(super) fn held_charge(&self, leaf: NodeId, bytes: u64) -> u64 {
        let Some(&per) = self.held.as_ref().and_then(|h| h.per_copy.get()) else {
            return bytes;
        };
        let listings = self.renderer.octree().leaf_objects(leaf).len() as u64;
        bytes.max(listings * (per + 12))
    }

    pub(super) fn read_cells(
        &self,
        h: &Held,
        proc: usize,
    ) -> crate::Result<Vec<(NodeId, CellData)>> {
        let owned: Vec<(NodeId, u64)> = self
            .owner_table()
            .filter(|&(_, owner, _)| owner == proc)
            .map(|(leaf, _, bytes)| (leaf, bytes))
            .collect();
        let leaves: Vec<NodeId> = owned.iter().map(|c| c.0).collect();
        let scene = self.renderer.scene();
        let octree = self.renderer.octree();
        let failed = |e: &dyn std::fmt::Display| {
            crate::Error::Other(format!(
                "processor {proc} cannot read its part of the scene: {e}"
            ))
        };
        let source = h.source.read().unwrap_or_else(|e| e.into_inner());
        let source = source
            .as_ref()
            .ok_or_else(|| failed(&"the scene's cells were read already"))?;
        // Each surface read becomes its processor's copy at once (moved,
        // not copied again): the part is never held twice.
        let maker = source.maker();
        let mut copies = ObjectCopies::default();
        // The bytes of the objects read, as the partition counts a whole
        // scene's (a copy keeps less of a polygon than the scene does).
        let mut read_bytes = 0usize;
        source
            .read_objects(scene, octree, &leaves, |id, s| {
                let o = maker.make(id, s)?;
                read_bytes += object_bytes(&o);
                copies.insert(id, HeldObject::new(o));
                Ok(())
            })
            .map_err(|e| failed(&e))?;
        let mut resident = FxHashSet::default();
        let mut cells: Vec<(NodeId, CellData)> = Vec::with_capacity(owned.len());
        for (leaf, bytes) in owned {
            let ids = octree.leaf_objects(leaf);
            resident.extend(ids.iter().copied());
            // Every object read has its copy: the rest are the objects
            // every processor holds.
            let cell =
                LeafObjects::copy_held(ids, scene.table(), &mut copies).map_err(|e| failed(&e))?;
            cells.push((leaf, CellData { leaf, bytes, cell }));
        }
        let lists: usize = leaves
            .iter()
            .map(|&l| std::mem::size_of_val(octree.leaf_objects(l)))
            .sum();
        let resident_bytes = lists
            + read_bytes
            + resident
                .iter()
                .filter_map(|&id| scene.object(id))
                .map(object_bytes)
                .sum::<usize>();
        let copy_bytes: usize = copies.values().map(|c| c.bytes()).sum();
        if let Some(f) = h.figures.get(proc) {
            *f.lock().unwrap_or_else(|e| e.into_inner()) = Some((
                resident_bytes as u64,
                copy_bytes as u64,
                copies.len() as u64,
            ));
        }
        if self.share_in_process {
            crate::accel::share_copies_in_process(&copies);
        }
        Ok(cells)
    }

    /// The accounted bytes of the cells processor `proc` owns (its share
    /// of the scene as the partition counts it).
    pub fn accounted_share(&self, proc: usize) -> u64 {
        self.owner_table()
            .filter(|&(_, owner, _)| owner == proc)
            .map(|(_, _, bytes)| bytes)
            .sum()
    }

    /// Per processor of a distributed scene: the bytes of its resident
    /// objects and of its copies, once it has read its cells (`None` for a
    /// scene loaded whole, or a processor of another MPI rank).
    pub fn held_figures(&self, proc: usize) -> Option<(u64, u64)> {
        let f = self.held.as_ref()?.figures.get(proc)?;
        f.lock()
            .unwrap_or_else(|e| e.into_inner())
            .map(|(resident, copies, _)| (resident, copies))
    }
}
