//! Data distribution: splitting the octree over processors (the paper's
//! data-parallel part).
//!
//! Cost of a leaf = the number of objects listed in it; cost of an internal
//! node = the sum over its children ([`Octree::subtree_refs`]). The tree is
//! cut as near the root as possible into subtrees ("pieces"): starting from
//! the root, the most expensive splittable piece is repeatedly replaced by
//! its eight children until there are at least `procs` pieces and none costs
//! more than `total / procs` (or no piece that could still help can be
//! split). The pieces are then taken in depth-first (spatially coherent)
//! order and handed out as contiguous runs, each piece going to the
//! processor whose share of the prefix sum contains the piece's midpoint, so
//! each processor gets about `total / procs`.
//!
//! Residency: objects are stored per cell, as in the paper, so an object is
//! resident on every processor owning a leaf that lists it (objects spanning
//! cells owned by several processors are replicated).

use std::collections::BTreeSet;

use crate::scene::{Object, ObjectId};

use crate::accel::{NodeId, Octree};

/// An assignment of the octree's leaves to processors.
#[derive(Debug, Clone, PartialEq)]
pub struct Partition {
    procs: u32,
    /// Owner per node id (leaves and internal nodes alike; an internal node
    /// inside one piece has that piece's owner, one above the cut has the
    /// owner of its first leaf in depth-first order).
    owner_of_node: super::owners::NodeOwners,
    /// The subtree roots the tree was cut into, depth first, with their owner.
    pieces: Vec<(NodeId, u32)>,
    /// Object references per processor (sum of its leaves' object counts).
    cost: Vec<u64>,
    /// Objects resident per processor (each once).
    resident_objects: Vec<usize>,
    /// Estimated bytes per processor: its resident objects plus its leaves'
    /// object lists.
    resident_bytes: Vec<usize>,
    /// Per processor: the bytes of its copies of its resident objects
    /// ([`crate::accel::copy_bytes`]; objects `assemble` was not given
    /// count 0).
    copy_bytes: Vec<u64>,
}

pub use crate::accel::object_bytes;

impl Partition {
    /// The balanced partition of `octree` (built over `objects`) over
    /// `procs` processors (`procs == 0` is treated as 1).
    pub fn new(octree: &Octree, objects: &[Object], procs: u32) -> Partition {
        Self::by_cost(octree, objects, procs, &octree.subtree_refs())
    }

    /// The same cut as [`Partition::new`] under another cost function:
    /// `subtree_cost[node]` for every node id (a subtree's cost must be the
    /// sum of its children's). Used with predicted work per cell to
    /// equalise work instead of memory.
    pub fn by_cost(
        octree: &Octree,
        objects: &[Object],
        procs: u32,
        subtree_cost: &[u64],
    ) -> Partition {
        let procs = procs.max(1);
        let Some(root) = octree.root() else {
            return Self::assemble(octree, objects, procs, Vec::new());
        };
        let cost = |id: NodeId| subtree_cost.get(id as usize).copied().unwrap_or(0);
        let total = cost(root);
        let target = total as f64 / procs as f64;
        let mut pieces = vec![root];
        loop {
            let max_cost = pieces.iter().map(|&p| cost(p)).max().unwrap_or(0);
            if pieces.len() >= procs as usize && max_cost as f64 <= target {
                break;
            }
            // The most expensive piece that can be split (ties: lowest id).
            let pick = pieces
                .iter()
                .enumerate()
                .filter(|(_, &p)| !octree.is_leaf(p))
                .max_by(|(_, &a), (_, &b)| cost(a).cmp(&cost(b)).then(b.cmp(&a)));
            let Some((i, &p)) = pick else { break };
            // Enough pieces already and the worst one is an unsplittable leaf:
            // splitting others cannot lower the maximum.
            if pieces.len() >= procs as usize && cost(p) < max_cost {
                break;
            }
            pieces.swap_remove(i);
            pieces.extend(octree.children(p).expect("internal node"));
        }
        // Depth-first order of the pieces.
        let set: BTreeSet<NodeId> = pieces.iter().copied().collect();
        let mut ordered = Vec::with_capacity(pieces.len());
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            if set.contains(&id) {
                ordered.push(id);
            } else if let Some(ch) = octree.children(id) {
                stack.extend(ch.iter().rev());
            }
        }
        let n = ordered.len() as u64;
        let mut before = 0u64;
        let assigned = ordered
            .iter()
            .enumerate()
            .map(|(k, &id)| {
                let c = cost(id);
                let owner = if total == 0 {
                    (k as u64 * procs as u64 / n.max(1)) as u32
                } else {
                    // Midpoint of the piece in the prefix sum, in units of total/procs.
                    let mid = (2 * before + c) as f64 / 2.0;
                    ((mid * procs as f64 / total as f64) as u32).min(procs - 1)
                };
                before += c;
                (id, owner)
            })
            .collect();
        Self::assemble(octree, objects, procs, assigned)
    }

    /// The worst case: processor 0 owns everything (the others nothing).
    pub fn worst_case(octree: &Octree, objects: &[Object], procs: u32) -> Partition {
        let procs = procs.max(1);
        let pieces = octree.root().map(|r| vec![(r, 0)]).unwrap_or_default();
        Self::assemble(octree, objects, procs, pieces)
    }

    fn assemble(
        octree: &Octree,
        objects: &[Object],
        procs: u32,
        pieces: Vec<(NodeId, u32)>,
    ) -> Partition {
        let nodes = octree.node_count();
        let mut owner_of_node = vec![u32::MAX; nodes];
        for &(p, owner) in &pieces {
            let mut stack = vec![p];
            while let Some(id) = stack.pop() {
                owner_of_node[id as usize] = owner;
                if let Some(ch) = octree.children(id) {
                    stack.extend(ch);
                }
            }
        }
        // Nodes above the cut: the owner of their first child (children have
        // larger ids than their parent, so go from the back).
        for id in (0..nodes).rev() {
            if owner_of_node[id] == u32::MAX {
                let ch = octree.children(id as NodeId).expect("above the cut");
                owner_of_node[id] = owner_of_node[ch[0] as usize];
            }
        }
        // Each processor's objects counted once, processor by processor,
        // through one bitset over the object ids. The processors' lists of
        // them were gathered from every listing (3,078,818 ids of 4 bytes
        // on the 1.5M-triangle city, on every rank), sorted, deduplicated
        // and kept for the run, only to be counted and summed.
        let p_count = procs as usize;
        let mut cost = vec![0u64; p_count];
        let mut resident_objects = vec![0usize; p_count];
        let mut resident_bytes = vec![0usize; p_count];
        let mut copy_bytes = vec![0u64; p_count];
        let mut by_owner: Vec<Vec<NodeId>> = vec![Vec::new(); p_count];
        for &(root, owner) in &pieces {
            by_owner[owner as usize].push(root);
        }
        let mut seen = Bitset::default();
        for (o, roots) in by_owner.iter().enumerate() {
            for_leaves(octree, roots, |objs| {
                cost[o] += objs.len() as u64;
                resident_bytes[o] += std::mem::size_of_val(objs);
                for &id in objs {
                    if seen.insert(id) {
                        resident_objects[o] += 1;
                        if let Some(obj) = objects.get(id as usize) {
                            resident_bytes[o] += object_bytes(obj);
                            copy_bytes[o] += crate::accel::copy_bytes(obj) as u64;
                        }
                    }
                }
            });
            for_leaves(octree, roots, |objs| {
                objs.iter().for_each(|&id| seen.clear(id))
            });
        }
        Partition {
            procs,
            owner_of_node: super::owners::NodeOwners::new(owner_of_node),
            pieces,
            cost,
            resident_objects,
            resident_bytes,
            copy_bytes,
        }
    }

    /// Number of processors.
    pub fn procs(&self) -> u32 {
        self.procs
    }

    /// The processor owning `node` (for a leaf: the one storing its objects).
    pub fn owner(&self, node: NodeId) -> u32 {
        self.owner_of_node.get(node as usize)
    }

    /// The subtree roots the tree was cut into, depth first, with their owners.
    pub fn pieces(&self) -> &[(NodeId, u32)] {
        &self.pieces
    }

    /// Object references per processor.
    pub fn cost(&self) -> &[u64] {
        &self.cost
    }

    /// Objects resident on processor `p`, ascending: those its leaves of
    /// `octree` (the tree it was made from) list, each once. Gathered on
    /// each call; [`Partition::resident_objects`] has their counts.
    pub fn resident(&self, octree: &Octree, p: u32) -> Vec<ObjectId> {
        let roots: Vec<NodeId> = (self.pieces.iter())
            .filter(|&&(_, o)| o == p)
            .map(|&(r, _)| r)
            .collect();
        let mut ids = Vec::new();
        for_leaves(octree, &roots, |objs| ids.extend_from_slice(objs));
        ids.sort_unstable();
        ids.dedup();
        ids
    }

    /// Bytes the partition occupies (its owner per node, mostly).
    pub fn memory_bytes(&self) -> usize {
        self.owner_of_node.memory_bytes()
            + std::mem::size_of_val(&self.pieces[..])
            + 32 * self.cost.len()
    }

    /// Objects resident per processor (each counted once).
    pub fn resident_objects(&self) -> &[usize] {
        &self.resident_objects
    }

    /// Per processor: the bytes of its copies of its resident objects, of
    /// those in the object list the partition was made with.
    pub fn copy_bytes(&self) -> &[u64] {
        &self.copy_bytes
    }

    /// Estimated bytes stored per processor.
    pub fn resident_bytes(&self) -> &[usize] {
        &self.resident_bytes
    }

    /// Largest processor cost over the mean (1 = perfect; `procs` = all on one).
    pub fn imbalance(&self) -> f64 {
        let total: u64 = self.cost.iter().sum();
        if total == 0 {
            return 1.0;
        }
        let max = *self.cost.iter().max().unwrap_or(&0) as f64;
        max / (total as f64 / self.procs as f64)
    }
}

/// Calls `f` with the object list of every leaf under `roots`.
fn for_leaves(octree: &Octree, roots: &[NodeId], mut f: impl FnMut(&[ObjectId])) {
    let mut stack: Vec<NodeId> = roots.to_vec();
    while let Some(id) = stack.pop() {
        match octree.children(id) {
            Some(ch) => stack.extend(ch),
            None => f(octree.leaf_objects(id)),
        }
    }
}

/// A set of object ids, one bit each, grown as ids come.
#[derive(Default)]
struct Bitset(Vec<u64>);

impl Bitset {
    /// Adds `id`; whether it was not there.
    fn insert(&mut self, id: ObjectId) -> bool {
        let (w, b) = ((id / 64) as usize, id % 64);
        if w >= self.0.len() {
            self.0.resize(w + 1, 0);
        }
        let was = self.0[w] >> b & 1 != 0;
        self.0[w] |= 1 << b;
        !was
    }

    fn clear(&mut self, id: ObjectId) {
        if let Some(word) = self.0.get_mut((id / 64) as usize) {
            *word &= !(1u64 << (id % 64));
        }
    }
}
