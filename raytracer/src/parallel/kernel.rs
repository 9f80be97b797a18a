//! The processor's own hierarchy ([`LocalKernel`]): fresh queries whose
//! answer the processor's resident objects decide are answered through it
//! instead of the leaf-by-leaf octree walk that migrating rays need (see
//! [`crate::accel::LocalKernel`] for why the answers are the same); and
//! [`CellMemo`], the walk's memo of resident leaves.

use hybrid_sched::DataView;

use super::caster::LocalQueries;
use super::distribution::EMPTY;
use super::tasks::CellData;
use super::workload::RtWorkload;
use crate::accel::{Hierarchy, Hit, LeafObjects, LocalKernel, NodeId, ProcessorKernel as Kernel};
use crate::geometry::Ray;
use crate::scene::ObjectId;

/// What one step's queries read to try the processor's hierarchy first.
#[derive(Clone, Copy)]
pub struct LocalPath<'a> {
    hierarchy: Hierarchy<'a>,
    wl: &'a RtWorkload,
    proc: u32,
}

impl LocalQueries for LocalPath<'_> {
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Option<Hit>> {
        LocalPath::intersect(self, ray, tmin, tmax)
    }

    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> Option<bool> {
        LocalPath::occluded(self, ray, tmin, tmax, ignore)
    }
}

impl LocalPath<'_> {
    /// Subtrees whose every non-empty leaf is resident here.
    #[inline]
    fn owned(&self, node: NodeId) -> bool {
        let o = self.wl.subtree_owner[node as usize];
        o == EMPTY || o == self.proc
    }

    #[inline]
    fn resident(&self, leaf: NodeId) -> bool {
        self.wl.partition.owner(leaf) == self.proc
    }

    /// The octree's nearest hit, if the resident objects decide it.
    pub fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Option<Hit>> {
        self.hierarchy.intersect(
            self.wl.renderer.octree(),
            ray,
            tmin,
            tmax,
            &|n| self.owned(n),
            &|l| self.resident(l),
        )
    }

    /// The octree's any-hit answer, if the resident objects decide it.
    pub fn occluded(
        &self,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> Option<bool> {
        self.hierarchy.occluded(
            self.wl.renderer.octree(),
            ray,
            tmin,
            tmax,
            ignore,
            &|n| self.owned(n),
            &|l| self.resident(l),
        )
    }
}

impl RtWorkload {
    /// Builds processor `proc`'s hierarchy over `cells`, its resident
    /// leaves (option `local_kernel`; once: a later run of the workload
    /// has the same partition).
    pub(super) fn make_kernel(&self, proc: usize, cells: &[(NodeId, CellData)]) {
        if !self.opts.local_kernel || self.replicated() {
            return;
        }
        let Some(slot) = self.kernels.get(proc) else {
            return;
        };
        slot.get_or_init(|| {
            let t0 = std::time::Instant::now();
            let k = if cells.is_empty() {
                Kernel::Nothing
            } else if self.held.is_none() && cells.len() == self.cells.len() {
                self.renderer.bvh();
                Kernel::Whole
            } else {
                let shared = self.renderer.scene().table();
                Kernel::Own(Box::new(LocalKernel::build(
                    cells.iter().map(|c| &c.1.cell),
                    shared,
                )))
            };
            tracing::debug!(
                proc,
                objects = match &k {
                    Kernel::Own(k) => k.len(),
                    Kernel::Whole => self.renderer.scene().objects.len(),
                    Kernel::Nothing => 0,
                },
                bytes = match &k {
                    Kernel::Own(k) => k.memory_bytes(),
                    _ => 0,
                },
                seconds = t0.elapsed().as_secs_f64(),
                "processor's hierarchy built"
            );
            k
        });
    }

    /// Processor `proc`'s hierarchy, if it has one.
    #[inline]
    pub(super) fn local_path(&self, proc: usize) -> Option<LocalPath<'_>> {
        let hierarchy = match self.kernels.get(proc)?.get()? {
            Kernel::Nothing => return None,
            Kernel::Whole => Hierarchy {
                bvh: self.renderer.bvh(),
                objects: &self.renderer.scene().objects,
                ids: None,
            },
            Kernel::Own(k) => k.hierarchy(),
        };
        Some(LocalPath {
            hierarchy,
            wl: self,
            proc: proc as u32,
        })
    }
}

/// [`RtWorkload::cell`] with the last resident leaves found remembered: a
/// shadow bundle's rays cross the same few leaves again and again, and a
/// lookup in the processor's store is a hash lookup. Cached leaves are
/// looked up every time, so the cache sees every use (its recency order,
/// and so what it evicts, is what it would be without the memo).
pub(super) struct CellMemo<'a, 'v> {
    view: &'a DataView<'v, RtWorkload>,
    wl: &'a RtWorkload,
    proc: usize,
    slots: [std::cell::Cell<(NodeId, Option<&'v LeafObjects>)>; 8],
}

impl<'a, 'v> CellMemo<'a, 'v> {
    pub(super) fn new(view: &'a DataView<'v, RtWorkload>, wl: &'a RtWorkload, proc: usize) -> Self {
        CellMemo {
            view,
            wl,
            proc,
            slots: std::array::from_fn(|_| std::cell::Cell::new((NodeId::MAX, None))),
        }
    }

    #[inline]
    pub(super) fn get(&self, leaf: NodeId) -> Option<&'v LeafObjects> {
        let slot = &self.slots[leaf as usize & 7];
        match slot.get() {
            (l, Some(c)) if l == leaf => Some(c),
            _ => {
                let c = RtWorkload::cell(self.view, leaf);
                if c.is_some() && self.wl.owned(self.proc, leaf) {
                    slot.set((leaf, c));
                }
                c
            }
        }
    }
}
