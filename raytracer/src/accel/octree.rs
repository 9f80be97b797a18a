//! Adaptive octree over scene objects, after Radiance's `oconv`, with
//! front-to-back traversal.
//!
//! Layout: all nodes (internal and leaves) live in one array and are named by
//! a stable [`NodeId`] (the build order is deterministic: depth first,
//! children in octant order). The root is node 0. An internal node's eight
//! children are contiguous; child `i` covers the upper half of the parent's
//! cell along x if `i & 1`, along y if `i & 2`, along z if `i & 4`. A leaf
//! owns a contiguous slice of object ids (ascending) in one shared array. An
//! object is listed in every leaf whose cell (enlarged by a small margin) its
//! surface may overlap, so the traversal can stop at the first leaf that
//! contains the nearest hit found so far.

use serde::{Deserialize, Serialize};

use super::cells::LeafObjects;
use crate::geometry::prims::{Prims, Tester};
use crate::geometry::robust::next_up;
use crate::geometry::{Aabb, Hit, Object, ObjectId, ObjectTable, PreparedRay, Ray, ShapeHit, Vec3};

/// Index of an octree node (internal or leaf).
pub type NodeId = u32;

/// Hard limit on the octree depth (the root has depth 0).
pub const MAX_DEPTH: u32 = 20;

/// Build parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OctreeParams {
    /// A cell with more objects than this is subdivided (Radiance `oconv -n`, default 6).
    pub max_objects: usize,
    /// Maximum depth of a leaf (root = 0; clamped to [`MAX_DEPTH`]). Depth 14
    /// corresponds to `oconv`'s default resolution of 16384.
    pub max_depth: u32,
    /// Relative enlargement of the root cube beyond the scene's largest extent.
    pub enlarge: f64,
    /// Subdivision stops on a path after this many consecutive levels in
    /// which a child kept all of its parent's objects (coincident or
    /// mutually enclosing surfaces would otherwise subdivide to the maximum
    /// depth everywhere).
    pub max_stall: u32,
}

impl Default for OctreeParams {
    fn default() -> Self {
        Self {
            max_objects: 6,
            max_depth: 14,
            enlarge: 1e-3,
            max_stall: 3,
        }
    }
}

/// Counts like the paper's Table 1.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct OctreeStats {
    /// Objects the octree was built over.
    pub objects: usize,
    pub leaf_nodes: usize,
    pub internal_nodes: usize,
    /// Leaves with no objects.
    pub empty_leaves: usize,
    /// Sum over leaves of the number of objects listed (the paper's "object references").
    pub object_refs: usize,
    /// Deepest leaf (root = 0).
    pub max_depth: u32,
    /// Largest number of objects in one leaf.
    pub max_leaf_objects: usize,
}

/// Progress of a resumable traversal ([`Octree::intersect_partial`],
/// [`Octree::occluded_partial`]): it travels with a migrating ray.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TraceCursor {
    /// Leaves (in traversal order, empty ones included) already handled.
    pub leaves_done: u32,
    /// The nearest hit found so far (nearest-hit traversals only).
    pub best: Option<Hit>,
}

/// The outcome of a resumable traversal step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Partial<T> {
    /// The query is answered.
    Done(T),
    /// The traversal needs this leaf's objects, which are not local; the
    /// cursor says where to resume.
    Blocked(NodeId),
}

/// One leaf a ray passes through, with the ray's entry and exit distances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeafSpan {
    pub leaf: NodeId,
    pub t_enter: f64,
    pub t_exit: f64,
}

/// A node as seen from outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NodeView<'a> {
    /// Eight children in octant order (see the module documentation).
    Internal { children: [NodeId; 8] },
    /// Object ids in ascending order.
    Leaf { objects: &'a [ObjectId] },
}

/// A node as [`Octree::from_skeleton`] takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SkeletonNode<'a> {
    /// An internal node whose eight children start at `first_child`.
    Internal { first_child: NodeId },
    /// A leaf and the ids of its objects, in the octree's order.
    Leaf(&'a [ObjectId]),
}

#[derive(Debug, Clone, Copy)]
enum Node {
    Internal { first_child: u32 },
    Leaf { start: u32, len: u32 },
}

/// Marks a leaf in [`TravNode::len`].
const LEAF: u32 = 1 << 31;

/// Per-ray constants of the traversal: origin, inverse direction, the axes
/// the ray does not move along, and the sign of each direction component.
struct RayTrav {
    o: [f64; 3],
    inv: [f64; 3],
    flat: [bool; 3],
    pos: [bool; 3],
}

/// How a traversal treats subtrees without objects: visit every leaf
/// (traversals that count leaves), skip them (any-hit: the answer does not
/// depend on them), or hand each to `visit` once as an empty leaf spanning
/// the subtree (nearest hit: the stop test at an empty leaf can decide a tie).
const ALL: u8 = 0;
const SKIP: u8 = 1;
const ONCE: u8 = 2;

/// Object ids a leaf keeps in its node (where an internal node keeps its
/// cell centre): the octree's build limit, so nearly every leaf has them.
const INLINE: usize = 6;

/// A test of octree nodes (which subtrees or leaves a processor holds),
/// as the judgement of a hierarchy's answers asks it at every node a
/// segment crosses ([`Octree::leaves_along_all`]): any `Fn(NodeId) ->
/// bool`, compiled into the judgement where its type is known.
pub trait NodeTest: Fn(NodeId) -> bool {}

impl<T: Fn(NodeId) -> bool + ?Sized> NodeTest for T {}

/// A node as the traversal reads it, in 32 bytes (half a cache line).
///
/// Internal node: `w` holds the bits of the cell centre, `first` is the
/// first child, `meta` has bit `i` set if child `i`'s subtree lists any
/// object. Leaf: `meta` is `LEAF | len`, `first` the start of its objects in
/// `leaf_objects`; a leaf with at most [`INLINE`] objects also has their ids
/// in `w` (two per word), so visiting it reads no other memory.
#[derive(Debug, Clone, Copy)]
struct TravNode {
    w: [u64; 3],
    first: u32,
    meta: u32,
}

impl TravNode {
    const EMPTY_LEAF: TravNode = TravNode {
        w: [0; 3],
        first: 0,
        meta: LEAF,
    };

    #[inline]
    fn is_leaf(&self) -> bool {
        self.meta & LEAF != 0
    }

    #[inline]
    fn center(&self) -> [f64; 3] {
        self.w.map(f64::from_bits)
    }

    #[inline]
    fn kind(&self) -> Node {
        if self.is_leaf() {
            Node::Leaf {
                start: self.first,
                len: self.meta & !LEAF,
            }
        } else {
            Node::Internal {
                first_child: self.first,
            }
        }
    }
}

#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Cell {
    center: Vec3,
    half: f64,
}

impl Cell {
    pub(super) fn bounds(&self) -> Aabb {
        Aabb::new(self.center - self.half, self.center + self.half)
    }

    #[inline]
    pub(super) fn child(&self, i: usize) -> Cell {
        let q = self.half * 0.5;
        let s = |bit: usize| if i & bit != 0 { q } else { -q };
        Cell {
            center: self.center + Vec3::new(s(1), s(2), s(4)),
            half: q,
        }
    }
}

/// Remembers the last few objects tested along one ray, so an object listed
/// in several leaves is tested once (skipping a re-test never changes the
/// result: the bound only shrinks).
struct Mailbox {
    ids: [ObjectId; 8],
    next: usize,
}

impl Mailbox {
    #[inline]
    fn new() -> Self {
        Self {
            ids: [ObjectId::MAX; 8],
            next: 0,
        }
    }

    /// True if `id` was tested already; records it otherwise.
    #[inline]
    fn seen(&mut self, id: ObjectId) -> bool {
        if self.ids.contains(&id) {
            return true;
        }
        self.ids[self.next & 7] = id;
        self.next = self.next.wrapping_add(1);
        false
    }
}

/// Half the side of a cell at each depth below a root of half side `root`:
/// halved one depth at a time, as [`Cell::child`] halves.
fn halves_from(root: f64) -> [f64; MAX_DEPTH as usize + 1] {
    let mut h = [root; MAX_DEPTH as usize + 1];
    for d in 1..h.len() {
        h[d] = h[d - 1] * 0.5;
    }
    h
}

/// The octree. `Default` is the empty tree (no nodes; every query misses).
#[derive(Debug, Clone, Default)]
pub struct Octree {
    /// Kind, contents and cell centre of every node.
    nodes: Vec<TravNode>,
    /// Half the side of a cell at each depth (`half_at[0]` is the root's),
    /// halved from the root's as the build halves it, so equal to it bit
    /// for bit: eight bytes per depth rather than per node.
    half_at: [f64; MAX_DEPTH as usize + 1],
    /// The root's cell (leaves keep no centre; theirs is derived from the
    /// parent's exactly as the build derived it).
    root_cell: Cell,
    parents: Vec<NodeId>,
    depths: Vec<u8>,
    leaf_objects: Vec<ObjectId>,
    /// The objects' intersection data in a compact layout.
    prims: Prims,
    stats: OctreeStats,
    /// Absolute margin by which cells are enlarged for the overlap tests.
    margin: f64,
}

struct Builder<'a> {
    objects: &'a [Object],
    bounds: &'a [Aabb],
    params: OctreeParams,
    margin: f64,
    tree: Octree,
    /// Most nodes the tree may have: past it, cells stay leaves. Surfaces
    /// whose overlap test is conservative (cones test their bounding box)
    /// and that crowd one region would otherwise subdivide every cell to
    /// the maximum depth (8^14 cells: Radiance's genrev torus in its glass
    /// regression scene). Real scenes stay far below it.
    node_budget: usize,
}

mod split;

/// The node budget: generous per object, never below a few million.
fn node_budget(objects: usize) -> usize {
    objects.saturating_mul(256).max(1 << 20)
}

impl Builder<'_> {
    fn overlaps(&self, id: ObjectId, cell: &Cell) -> bool {
        let h = cell.half + self.margin;
        let b = Aabb::new(cell.center - h, cell.center + h);
        self.bounds[id as usize].overlaps(&b)
            && self.objects[id as usize]
                .shape
                .overlaps_box_within_bounds(&b)
    }

    /// The candidates among `cands` that overlap `cell`, in their order.
    fn candidates_in(&self, cands: &[ObjectId], cell: &Cell) -> Vec<ObjectId> {
        cands
            .iter()
            .copied()
            .filter(|&o| self.overlaps(o, cell))
            .collect()
    }

    fn node(&mut self, id: NodeId, cell: Cell, cands: Vec<ObjectId>, depth: u32, stall: u32) {
        let t = &mut self.tree;
        debug_assert_eq!(cell.half, t.half_at[depth as usize]);
        t.depths[id as usize] = depth as u8;
        if cands.len() <= self.params.max_objects
            || depth >= self.params.max_depth
            || stall >= self.params.max_stall
            || t.nodes.len() + 8 > self.node_budget
        {
            let start = t.leaf_objects.len() as u32;
            t.leaf_objects.extend_from_slice(&cands);
            let mut w = [0u64; 3];
            if cands.len() <= INLINE {
                for (k, &o) in cands.iter().enumerate() {
                    w[k / 2] |= (o as u64) << (32 * (k % 2));
                }
            }
            t.nodes[id as usize] = TravNode {
                w,
                first: start,
                meta: LEAF | cands.len() as u32,
            };
            return;
        }
        let first = t.nodes.len() as u32;
        t.nodes[id as usize] = TravNode {
            w: cell.center.to_array().map(f64::to_bits),
            first,
            meta: 0,
        };
        for _ in 0..8 {
            t.nodes.push(TravNode::EMPTY_LEAF);
            t.parents.push(id);
            t.depths.push(0);
        }
        for i in 0..8 {
            let c = cell.child(i);
            let sub = self.candidates_in(&cands, &c);
            let s = if sub.len() == cands.len() {
                stall + 1
            } else {
                0
            };
            self.node(first + i as u32, c, sub, depth + 1, s);
        }
    }
}

impl Octree {
    /// Builds the octree over `objects` (ids are indices into `objects`).
    /// Objects with empty bounds are left out. Deterministic.
    pub fn build(objects: &[Object], params: &OctreeParams) -> Octree {
        Self::build_with(objects, params, true, node_budget(objects.len()))
    }

    /// [`Octree::build`] with its root's subtrees built side by side where
    /// that pays (`side_by_side`; the same tree either way) and a node
    /// budget.
    fn build_with(
        objects: &[Object],
        params: &OctreeParams,
        side_by_side: bool,
        node_budget: usize,
    ) -> Octree {
        let mut params = params.clone();
        params.max_depth = params.max_depth.min(MAX_DEPTH);
        let bounds: Vec<Aabb> = objects.iter().map(|o| o.shape.bounds()).collect();
        let root = Self::root_of(bounds.iter().copied(), &params);
        let margin = 1e-9 * (2.0 * root.half + root.center.abs().max_element());
        let cands: Vec<ObjectId> = (0..objects.len() as u32)
            .filter(|&i| !bounds[i as usize].is_empty())
            .collect();
        let tree = Octree {
            root_cell: root,
            half_at: halves_from(root.half),
            nodes: vec![TravNode::EMPTY_LEAF],
            parents: vec![NodeId::MAX],
            depths: vec![0],
            margin,
            ..Default::default()
        };
        let mut b = Builder {
            node_budget,
            objects,
            bounds: &bounds,
            params,
            margin,
            tree,
        };
        let serial = if side_by_side {
            b.split_root(root, cands).err()
        } else {
            Some(cands)
        };
        if let Some(cands) = serial {
            b.node(0, root, cands, 0, 0);
        }
        let mut t = b.tree;
        t.finish(objects.len());
        t.prims = Prims::build(objects);
        t
    }

    /// [`Octree::root_bounds`] of the octree [`Octree::build`] would make
    /// over `objects`, without building it.
    pub fn root_bounds_of(objects: &[Object], params: &OctreeParams) -> Aabb {
        Self::root_of(objects.iter().map(|o| o.shape.bounds()), params).bounds()
    }

    /// The root cell over objects of `bounds` (in object order): a cube
    /// around the non-empty ones, enlarged by `params.enlarge`. Folded as
    /// they come: the sequential renderer asks without building the tree,
    /// and a list of every object's box (48 bytes each) is not kept for it.
    fn root_of(bounds: impl Iterator<Item = Aabb>, params: &OctreeParams) -> Cell {
        let scene = bounds.fold(
            Aabb::EMPTY,
            |a, b| if b.is_empty() { a } else { a.union(b) },
        );
        let (center, half) = if scene.is_empty() {
            (Vec3::ZERO, 0.5)
        } else {
            let ext = scene.extent().max_element();
            let mag = scene.magnitude();
            // Never a zero-size cube (a single point or an axis-aligned flat scene).
            let side = (ext * (1.0 + params.enlarge.max(0.0)))
                .max(mag * 1e-9)
                .max(f64::MIN_POSITIVE * 1e20);
            (scene.center(), side * 0.5)
        };
        Cell { center, half }
    }

    /// The octree of a scene whose objects this process does not all hold,
    /// from its skeleton: the root cell (`None`: a tree with one empty
    /// leaf), and per node in the octree's node order its first child or
    /// its leaf's object ids, as [`Octree::build`] made them. Every cell,
    /// list and statistic equals the built tree's; there is no
    /// intersection data, so objects are tested through their shapes or,
    /// in the partial traversals, through the leaf copies a processor
    /// holds. `objects` is the scene's object count; `node(i)` is node `i`
    /// of `n` (read as the tree is built, so no second copy of the
    /// skeleton's nodes is made). An inconsistent skeleton (a child outside
    /// the node list, a node reached twice or never, an error from `node`)
    /// is an error.
    pub fn from_skeleton<'a>(
        root: Option<(Vec3, f64)>,
        objects: usize,
        n: usize,
        node: impl Fn(usize) -> std::result::Result<SkeletonNode<'a>, String>,
    ) -> std::result::Result<Octree, String> {
        let Some((center, half)) = root else {
            return Ok(Octree::build(&[], &OctreeParams::default()));
        };
        if n == 0 {
            return Err("the skeleton has a root cell but no nodes".into());
        }
        let margin = 1e-9 * (2.0 * half + center.abs().max_element());
        let mut t = Octree {
            root_cell: Cell { center, half },
            half_at: halves_from(half),
            nodes: vec![TravNode::EMPTY_LEAF; n],
            parents: vec![NodeId::MAX; n],
            depths: vec![0; n],
            margin,
            ..Default::default()
        };
        // Every listing, reserved exactly: grown by doubling, the lists
        // took up to twice their size, and three times while moving
        // (5.6 MB at the peak of a rank of a 300,000-triangle city).
        let listings: usize = (0..n)
            .filter_map(|i| match node(i) {
                Ok(SkeletonNode::Leaf(ids)) => Some(ids.len()),
                _ => None,
            })
            .sum();
        t.leaf_objects.reserve_exact(listings);
        // The build's recursion, so leaves' lists lie in the order it
        // appended them.
        let mut seen = vec![false; n];
        let mut stack = vec![(0 as NodeId, t.root_cell, 0u32)];
        while let Some((id, cell, depth)) = stack.pop() {
            let i = id as usize;
            if std::mem::replace(&mut seen[i], true) {
                return Err(format!("node {id} is reached twice"));
            }
            if depth > MAX_DEPTH {
                return Err(format!("node {id} lies deeper than {MAX_DEPTH}"));
            }
            t.depths[i] = depth as u8;
            match node(i)? {
                SkeletonNode::Leaf(ids) => {
                    if ids.iter().any(|&o| o as usize >= objects) {
                        return Err(format!("leaf {id} lists an object beyond the {objects}"));
                    }
                    let start = t.leaf_objects.len() as u32;
                    t.leaf_objects.extend_from_slice(ids);
                    let mut w = [0u64; 3];
                    if ids.len() <= INLINE {
                        for (k, &o) in ids.iter().enumerate() {
                            w[k / 2] |= (o as u64) << (32 * (k % 2));
                        }
                    }
                    t.nodes[i] = TravNode {
                        w,
                        first: start,
                        meta: LEAF | ids.len() as u32,
                    };
                }
                SkeletonNode::Internal { first_child } => {
                    let first = first_child as usize;
                    if first <= i || first.checked_add(8).is_none_or(|e| e > n) {
                        return Err(format!("node {id}: children at {first} of {n} nodes"));
                    }
                    t.nodes[i] = TravNode {
                        w: cell.center.to_array().map(f64::to_bits),
                        first: first_child,
                        meta: 0,
                    };
                    for k in (0..8).rev() {
                        t.parents[first + k] = id;
                        stack.push((first_child + k as u32, cell.child(k), depth + 1));
                    }
                }
            }
        }
        if let Some(lost) = seen.iter().position(|s| !s) {
            return Err(format!("node {lost} is not reached from the root"));
        }
        t.finish(objects);
        Ok(t)
    }

    fn finish(&mut self, objects: usize) {
        let n = self.nodes.len();
        let mut s = OctreeStats {
            objects,
            ..Default::default()
        };
        // Which subtrees list objects: a byte per node (the subtrees'
        // reference counts, eight bytes a node, were 15 MB at the peak of
        // loading a 1.5-million-triangle city's skeleton). Children always
        // have larger ids than their parent, so one pass from the end
        // marks every subtree before its parent is read.
        let mut listing = vec![false; n];
        for id in (0..n).rev() {
            match self.nodes[id].kind() {
                Node::Leaf { len, .. } => {
                    s.leaf_nodes += 1;
                    s.object_refs += len as usize;
                    s.max_leaf_objects = s.max_leaf_objects.max(len as usize);
                    if len == 0 {
                        s.empty_leaves += 1;
                    } else {
                        listing[id] = true;
                    }
                    s.max_depth = s.max_depth.max(self.depths[id] as u32);
                }
                Node::Internal { .. } => s.internal_nodes += 1,
            }
            if listing[id] && id > 0 {
                listing[self.parents[id] as usize] = true;
            }
        }
        self.stats = s;
        for id in 0..n {
            if let Node::Internal { first_child } = self.nodes[id].kind() {
                let mut mask = 0;
                for i in 0..8 {
                    if listing[first_child as usize + i] {
                        mask |= 1 << i;
                    }
                }
                self.nodes[id].meta = mask;
            }
        }
    }

    /// A node's cell, exactly as the build computed it.
    pub(super) fn cell(&self, id: NodeId) -> Cell {
        if id == 0 {
            return self.root_cell;
        }
        let n = &self.nodes[id as usize];
        if !n.is_leaf() {
            return Cell {
                center: Vec3::from_array(n.center()),
                half: self.half_at[self.depths[id as usize] as usize],
            };
        }
        let p = self.parents[id as usize];
        let first = self.nodes[p as usize].first;
        self.cell(p).child((id - first) as usize)
    }

    /// Table 1 statistics.
    pub fn stats(&self) -> &OctreeStats {
        &self.stats
    }

    /// The root node (0), or `None` for the empty (default) tree.
    pub fn root(&self) -> Option<NodeId> {
        if self.nodes.is_empty() {
            None
        } else {
            Some(0)
        }
    }

    /// The root cube (empty box for the empty tree).
    pub fn root_bounds(&self) -> Aabb {
        if self.nodes.is_empty() {
            Aabb::EMPTY
        } else {
            self.root_cell.bounds()
        }
    }

    /// Number of nodes; node ids are `0..node_count()`.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Kind and contents of a node.
    pub fn node(&self, id: NodeId) -> NodeView<'_> {
        match self.nodes[id as usize].kind() {
            Node::Internal { first_child } => NodeView::Internal {
                children: std::array::from_fn(|i| first_child + i as u32),
            },
            Node::Leaf { start, len } => NodeView::Leaf {
                objects: &self.leaf_objects[start as usize..(start + len) as usize],
            },
        }
    }

    pub fn is_leaf(&self, id: NodeId) -> bool {
        self.nodes[id as usize].is_leaf()
    }

    /// Children of an internal node (`None` for a leaf).
    pub fn children(&self, id: NodeId) -> Option<[NodeId; 8]> {
        match self.node(id) {
            NodeView::Internal { children } => Some(children),
            NodeView::Leaf { .. } => None,
        }
    }

    /// Objects of a leaf, ascending (empty for internal nodes).
    #[inline]
    pub fn leaf_objects(&self, id: NodeId) -> &[ObjectId] {
        match self.nodes[id as usize].kind() {
            Node::Leaf { start, len } => &self.leaf_objects[start as usize..(start + len) as usize],
            Node::Internal { .. } => &[],
        }
    }

    /// The root cell's centre and half size (`None` for the empty tree):
    /// a child's cell has half the half size and its centre moved by that
    /// along each axis, down for a clear octant bit, up for a set one.
    pub fn root_cell(&self) -> Option<(Vec3, f64)> {
        self.root()
            .map(|_| (self.root_cell.center, self.root_cell.half))
    }

    /// The node's cell (a cube).
    pub fn node_bounds(&self, id: NodeId) -> Aabb {
        self.cell(id).bounds()
    }

    /// Depth of a node (root = 0).
    pub fn depth(&self, id: NodeId) -> u32 {
        self.depths[id as usize] as u32
    }

    /// Parent of a node (`None` for the root).
    pub fn parent(&self, id: NodeId) -> Option<NodeId> {
        let p = self.parents[id as usize];
        (p != NodeId::MAX).then_some(p)
    }

    /// Per node, the object references in the leaves below (and
    /// including) it: the paper's cost function "objects per leaf, summed
    /// upwards". Computed when asked (eight bytes per node the octree does
    /// not keep).
    pub fn subtree_refs(&self) -> Vec<u64> {
        let mut refs: Vec<u64> = (0..self.nodes.len())
            .map(|id| match self.nodes[id].kind() {
                Node::Leaf { len, .. } => len as u64,
                _ => 0,
            })
            .collect();
        self.sum_subtrees(&mut refs);
        refs
    }

    /// Makes `costs` (one per node, the leaves' filled in) a cost per
    /// subtree: every internal node's becomes the sum of its children's.
    pub fn sum_subtrees(&self, costs: &mut [u64]) {
        for id in 0..costs.len().min(self.nodes.len()) {
            if !matches!(self.nodes[id].kind(), Node::Leaf { .. }) {
                costs[id] = 0;
            }
        }
        // Children always have larger ids than their parent.
        for id in (1..costs.len().min(self.nodes.len())).rev() {
            costs[self.parents[id] as usize] += costs[id];
        }
    }

    /// All leaf ids, ascending.
    pub fn leaves(&self) -> impl Iterator<Item = NodeId> + '_ {
        (0..self.nodes.len() as u32).filter(|&i| self.is_leaf(i))
    }

    /// The leaf whose cell contains `p` (points on a boundary go to the upper
    /// side), or `None` outside the root.
    pub fn find_leaf(&self, p: Vec3) -> Option<NodeId> {
        if self.nodes.is_empty() || !self.root_bounds().contains(p) {
            return None;
        }
        let mut id = 0u32;
        while let Node::Internal { first_child } = self.nodes[id as usize].kind() {
            let c = Vec3::from_array(self.nodes[id as usize].center());
            let i = (p.x >= c.x) as u32 | ((p.y >= c.y) as u32) << 1 | ((p.z >= c.z) as u32) << 2;
            id = first_child + i;
        }
        Some(id)
    }

    /// Absolute margin by which cells were enlarged when objects were
    /// assigned to leaves (an object may be listed in a leaf it only comes
    /// within this distance of).
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// Approximate heap memory of the structure in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<TravNode>()
            + std::mem::size_of_val(&self.half_at)
            + self.parents.len() * 4
            + self.depths.len()
            + self.leaf_objects.len() * 4
            + self.prims.memory_bytes()
    }

    /// How rays test objects: through the compact data where it was built
    /// for `objects`, else through the shapes.
    #[inline]
    fn tester<'a>(&'a self, objects: &'a [Object], pre: &'a PreparedRay) -> Tester<'a> {
        Tester::new(&self.prims, objects, pre)
    }

    /// Parametric interval of the ray inside the root cube, clipped to `[tmin, tmax]`.
    #[inline]
    fn root_interval(&self, ray: &Ray, inv: Vec3, tmin: f64, tmax: f64) -> Option<(f64, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let cell = self.root_cell;
        let (lo, hi) = (cell.center - cell.half, cell.center + cell.half);
        let (mut t0, mut t1) = (tmin, tmax);
        for a in 0..3 {
            let (o, d) = (ray.origin[a], ray.dir[a]);
            if d == 0.0 {
                if o < lo[a] || o > hi[a] {
                    return None;
                }
            } else {
                let ta = (lo[a] - o) * inv[a];
                let tb = (hi[a] - o) * inv[a];
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        (t0 <= t1).then_some((t0, t1))
    }

    /// Visits the leaves the ray passes through in front-to-back order with
    /// their objects and `[t_enter, t_exit]`. `visit` gets a mutable cut-off
    /// distance: leaves entered beyond it are not visited. `visit` returns
    /// true to stop. `EMPTY` says how subtrees without objects are treated
    /// ([`ALL`], [`SKIP`], [`ONCE`]).
    #[inline]
    fn traverse<const EMPTY: u8, F>(
        &self,
        ray: &Ray,
        inv: Vec3,
        tmin: f64,
        tmax: f64,
        visit: &mut F,
    ) where
        F: FnMut(NodeId, &[ObjectId], f64, f64, &mut f64) -> bool,
    {
        self.traverse_from::<EMPTY, F>(ray, inv, tmin, tmax, tmax, visit);
    }

    /// [`Octree::traverse`] with the cut-off distance starting at `cut`
    /// (a resumed traversal starts it at the best hit found so far).
    #[inline]
    fn traverse_from<const EMPTY: u8, F>(
        &self,
        ray: &Ray,
        inv: Vec3,
        tmin: f64,
        tmax: f64,
        cut: f64,
        visit: &mut F,
    ) where
        F: FnMut(NodeId, &[ObjectId], f64, f64, &mut f64) -> bool,
    {
        let Some((t0, t1)) = self.root_interval(ray, inv, tmin, tmax) else {
            return;
        };
        let d = ray.dir.to_array();
        let r = RayTrav {
            o: ray.origin.to_array(),
            inv: inv.to_array(),
            flat: [d[0] == 0.0, d[1] == 0.0, d[2] == 0.0],
            pos: [d[0] > 0.0, d[1] > 0.0, d[2] > 0.0],
        };
        let mut cut = cut;
        self.visit_node::<EMPTY, F>(&r, 0, t0, t1, &mut cut, visit);
    }

    /// Visits node `id`, which the ray passes through over `[t0, t1]`:
    /// a leaf is handed to `visit`; an internal node's children are visited
    /// in the order the ray enters them (the order of its crossings of the
    /// node's three mid-planes). Returns true to stop the traversal.
    /// (Recursion measured faster than an explicit stack here.)
    #[allow(clippy::too_many_arguments)]
    fn visit_node<const EMPTY: u8, F>(
        &self,
        r: &RayTrav,
        id: NodeId,
        t0: f64,
        t1: f64,
        cut: &mut f64,
        visit: &mut F,
    ) -> bool
    where
        F: FnMut(NodeId, &[ObjectId], f64, f64, &mut f64) -> bool,
    {
        if t0 > *cut {
            return true;
        }
        let node = &self.nodes[id as usize];
        if node.is_leaf() {
            let len = (node.meta & !LEAF) as usize;
            return if len <= INLINE {
                let mut ids = [0; INLINE];
                for (k, x) in ids.iter_mut().enumerate() {
                    *x = (node.w[k / 2] >> (32 * (k % 2))) as ObjectId;
                }
                visit(id, &ids[..len], t0, t1, cut)
            } else {
                let start = node.first as usize;
                visit(id, &self.leaf_objects[start..start + len], t0, t1, cut)
            };
        }
        let (first, c) = (node.first, node.center());
        let (o, inv) = (r.o, r.inv);
        let mut tm = [f64::INFINITY; 3];
        let mut child = 0u32;
        for a in 0..3 {
            let t = (c[a] - o[a]) * inv[a];
            let bit = if r.flat[a] || t.is_nan() {
                o[a] >= c[a]
            } else {
                tm[a] = t;
                (t <= t0) == r.pos[a]
            };
            child |= (bit as u32) << a;
        }
        let mut order = [0usize, 1, 2];
        if tm[order[0]] > tm[order[1]] {
            order.swap(0, 1);
        }
        if tm[order[1]] > tm[order[2]] {
            order.swap(1, 2);
        }
        if tm[order[0]] > tm[order[1]] {
            order.swap(0, 1);
        }
        let mask = if EMPTY == ALL { 0xff } else { node.meta };
        let mut t = t0;
        for a in order {
            let ta = tm[a];
            if ta > t0 && ta < t1 {
                if self.enter::<EMPTY, F>(
                    r,
                    first + child,
                    mask & (1 << child) == 0,
                    t,
                    ta,
                    cut,
                    visit,
                ) {
                    return true;
                }
                child ^= 1 << a;
                t = ta;
            }
        }
        self.enter::<EMPTY, F>(
            r,
            first + child,
            mask & (1 << child) == 0,
            t,
            t1,
            cut,
            visit,
        )
    }

    /// Visits child `id` over `[t0, t1]`; `empty`: no objects below it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn enter<const EMPTY: u8, F>(
        &self,
        r: &RayTrav,
        id: NodeId,
        empty: bool,
        t0: f64,
        t1: f64,
        cut: &mut f64,
        visit: &mut F,
    ) -> bool
    where
        F: FnMut(NodeId, &[ObjectId], f64, f64, &mut f64) -> bool,
    {
        if empty && EMPTY == SKIP {
            return false;
        }
        if empty && EMPTY == ONCE {
            // What visiting its leaves one by one would decide: the cut-off
            // does not change in them, the stop test is monotonic in t_exit,
            // and the last leaf's t_exit is the subtree's.
            return t0 > *cut || visit(id, &[], t0, t1, cut);
        }
        self.visit_node::<EMPTY, F>(r, id, t0, t1, cut, visit)
    }

    /// Nearest hit with `tmin < t < tmax` among `objects` (the slice the tree
    /// was built over). Equal distances resolve to the smaller object id, like
    /// [`intersect_brute_force`].
    pub fn intersect(&self, objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        let pre = PreparedRay::new(ray);
        let test = self.tester(objects, &pre);
        let mut best: Option<(f64, ObjectId, ShapeHit)> = None;
        let mut mailbox = Mailbox::new();
        let mut visit = |_leaf: NodeId, ids: &[ObjectId], _t0: f64, t1: f64, cut: &mut f64| {
            for &id in ids {
                if mailbox.seen(id) {
                    continue;
                }
                let bound = if best.is_some() { next_up(*cut) } else { *cut };
                if let Some(h) = test.intersect(id, tmin, bound) {
                    if best.is_none_or(|(bt, bid, _)| h.t < bt || (h.t == bt && id < bid)) {
                        best = Some((h.t, id, h));
                        *cut = h.t;
                    }
                }
            }
            best.is_some_and(|(bt, _, _)| bt <= t1)
        };
        self.traverse::<ONCE, _>(ray, pre.inv_dir, tmin, tmax, &mut visit);
        best.map(|(t, id, h)| Hit::on(&objects[id as usize], id, ray, t, &h))
    }

    /// True if any object other than `ignore` is hit with `tmin < t < tmax`.
    pub fn occluded(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        let pre = PreparedRay::new(ray);
        let test = self.tester(objects, &pre);
        let mut found = false;
        let mut mailbox = Mailbox::new();
        let mut visit = |_leaf: NodeId, ids: &[ObjectId], _t0: f64, _t1: f64, _cut: &mut f64| {
            for &id in ids {
                if Some(id) != ignore && !mailbox.seen(id) && test.occludes(id, tmin, tmax) {
                    found = true;
                    return true;
                }
            }
            false
        };
        self.traverse::<SKIP, _>(ray, pre.inv_dir, tmin, tmax, &mut visit);
        found
    }

    /// [`Octree::intersect`] over the leaves whose objects `cell` gives (the
    /// leaves held here; `None` for the others), as a traversal that can
    /// stop and resume elsewhere (a migrating ray). Objects are tested from
    /// the leaf's own copies ([`LeafObjects`]); the ones it shares
    /// (instances) from `shared`, the objects every processor holds.
    ///
    /// Visits the same leaves in the same order as [`Octree::intersect`],
    /// skipping the `cursor.leaves_done` leaves already handled; at the first
    /// non-empty leaf that is not held it records its progress in `cursor`
    /// and returns [`Partial::Blocked`]. Resumed (anywhere, any
    /// number of times) until [`Partial::Done`], it returns exactly what
    /// [`Octree::intersect`] returns: same leaves, same tests, same bounds,
    /// same tie rule.
    pub fn intersect_partial<'c, F>(
        &self,
        shared: ObjectTable<'_>,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        cursor: &mut TraceCursor,
        cell: F,
    ) -> Partial<Option<Hit>>
    where
        F: FnMut(NodeId) -> Option<&'c LeafObjects>,
    {
        self.intersect_partial_past(shared, ray, tmin, tmax, cursor, cell, &|_| false)
    }

    /// [`Octree::intersect_partial`] where the objects of the leaves
    /// `tested` vouches for have been tested already, and the nearest of
    /// their hits (if any) is in `cursor.best` (a processor's hierarchy
    /// over them answered it): the walk passes those leaves without
    /// testing their objects again, and tests the others, or stops at the
    /// first one held elsewhere, as before. The answer is the same: the
    /// nearest hit of all, the smaller id on equal distances.
    #[allow(clippy::too_many_arguments)]
    pub fn intersect_partial_past<'c, F>(
        &self,
        shared: ObjectTable<'_>,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        cursor: &mut TraceCursor,
        mut cell: F,
        tested: &dyn Fn(NodeId) -> bool,
    ) -> Partial<Option<Hit>>
    where
        F: FnMut(NodeId) -> Option<&'c LeafObjects>,
    {
        let pre = PreparedRay::new(ray);
        let test = self.tester(&[], &pre);
        let mut best: Option<Hit> = cursor.best;
        let skip = cursor.leaves_done;
        let mut pos = 0u32;
        let mut blocked = None;
        let mut mailbox = Mailbox::new();
        let cut = best.map_or(tmax, |h| h.t);
        let mut visit = |leaf: NodeId, ids: &[ObjectId], _t0: f64, t1: f64, cut: &mut f64| {
            let k = pos;
            pos += 1;
            if k < skip {
                return false;
            }
            if !ids.is_empty() && !tested(leaf) {
                let Some(c) = cell(leaf) else {
                    blocked = Some((leaf, k));
                    return true;
                };
                debug_assert_eq!(c.ids(), ids, "a leaf's objects differ from the octree's");
                for (j, &id) in c.ids().iter().enumerate() {
                    if mailbox.seen(id) {
                        continue;
                    }
                    let bound = if best.is_some() { next_up(*cut) } else { *cut };
                    let (h, held) = match c.own(j) {
                        Some(held) => (
                            test.intersect_one(held.prim(), held.shape(), tmin, bound),
                            Ok(held),
                        ),
                        // An instance, tested through its shape as the
                        // octree's own data would (they hold none for it).
                        None => match shared.get(id) {
                            Some(o) => (o.shape.intersect_prepared(&pre, tmin, bound), Err(o)),
                            None => {
                                debug_assert!(false, "object {id} is neither copied nor shared");
                                continue;
                            }
                        },
                    };
                    if let Some(h) = h {
                        if best.is_none_or(|b| h.t < b.t || (h.t == b.t && id < b.object)) {
                            best = Some(match held {
                                Ok(c) => Hit::on_surface(|i| c.surface_at(i), id, ray, h.t, &h),
                                Err(o) => Hit::on(o, id, ray, h.t, &h),
                            });
                            *cut = h.t;
                        }
                    }
                }
            }
            best.is_some_and(|b| b.t <= t1)
        };
        self.traverse_from::<ALL, _>(ray, pre.inv_dir, tmin, tmax, cut, &mut visit);
        match blocked {
            Some((leaf, k)) => {
                cursor.leaves_done = k;
                cursor.best = best;
                Partial::Blocked(leaf)
            }
            None => {
                cursor.leaves_done = pos;
                cursor.best = best;
                Partial::Done(best)
            }
        }
    }

    /// [`Octree::occluded`] over the leaves `cell` gives, resumable like
    /// [`Octree::intersect_partial`] (only `cursor.leaves_done` is used).
    #[allow(clippy::too_many_arguments)]
    pub fn occluded_partial<'c, F>(
        &self,
        shared: ObjectTable<'_>,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
        cursor: &mut TraceCursor,
        cell: F,
    ) -> Partial<bool>
    where
        F: FnMut(NodeId) -> Option<&'c LeafObjects>,
    {
        self.occluded_partial_past(shared, ray, tmin, tmax, ignore, cursor, cell, &|_| false)
    }

    /// [`Octree::occluded_partial`] where the objects of the leaves
    /// `tested` vouches for are known not to block the segment (a
    /// processor's hierarchy over them said so): the walk passes those
    /// leaves without testing their objects, and tests the others, or
    /// stops at the first one held elsewhere, as before. The answer is the
    /// same.
    #[allow(clippy::too_many_arguments)]
    pub fn occluded_partial_past<'c, F>(
        &self,
        shared: ObjectTable<'_>,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
        cursor: &mut TraceCursor,
        mut cell: F,
        tested: &dyn Fn(NodeId) -> bool,
    ) -> Partial<bool>
    where
        F: FnMut(NodeId) -> Option<&'c LeafObjects>,
    {
        let pre = PreparedRay::new(ray);
        let test = self.tester(&[], &pre);
        let skip = cursor.leaves_done;
        let mut pos = 0u32;
        let mut blocked = None;
        let mut found = false;
        let mut mailbox = Mailbox::new();
        let mut visit = |leaf: NodeId, ids: &[ObjectId], _t0: f64, _t1: f64, _cut: &mut f64| {
            let k = pos;
            pos += 1;
            if k < skip || ids.is_empty() || tested(leaf) {
                return false;
            }
            let Some(c) = cell(leaf) else {
                blocked = Some((leaf, k));
                return true;
            };
            for (j, &id) in c.ids().iter().enumerate() {
                if Some(id) == ignore || mailbox.seen(id) {
                    continue;
                }
                let hit = match c.own(j) {
                    Some(held) => test.occludes_one(held.prim(), held.shape(), tmin, tmax),
                    None => shared.get(id).is_some_and(|o| {
                        debug_assert!(matches!(o.shape, crate::geometry::Shape::Instance(_)));
                        o.shape.occludes_prepared(&pre, tmin, tmax)
                    }),
                };
                if hit {
                    found = true;
                    return true;
                }
            }
            false
        };
        self.traverse::<ALL, _>(ray, pre.inv_dir, tmin, tmax, &mut visit);
        match blocked {
            Some((leaf, k)) => {
                cursor.leaves_done = k;
                Partial::Blocked(leaf)
            }
            None => {
                cursor.leaves_done = pos;
                Partial::Done(found)
            }
        }
    }

    /// Calls `f(leaf, t_enter, t_exit)` for every leaf (empty ones included)
    /// the ray passes through within `[tmin, tmax]`, front to back; `f`
    /// returns true to stop.
    pub fn for_each_leaf_along_ray<F>(&self, ray: &Ray, tmin: f64, tmax: f64, mut f: F)
    where
        F: FnMut(NodeId, f64, f64) -> bool,
    {
        let inv = Vec3::ONE / ray.dir;
        let mut visit =
            |leaf: NodeId, _ids: &[ObjectId], t0: f64, t1: f64, _cut: &mut f64| f(leaf, t0, t1);
        self.traverse::<ALL, _>(ray, inv, tmin, tmax, &mut visit);
    }

    /// True if `ok(leaf)` holds for every non-empty leaf that a traversal
    /// of `[tmin, tmax]` with cut-off distance `cut` visits (those the ray
    /// enters at or before `cut`), without visiting the subtrees `skip`
    /// vouches for. The same intervals as [`Octree::intersect_partial`]'s
    /// traversal, computed the same way, so the leaves judged are exactly
    /// the ones it would visit up to `cut` (a leaf entered exactly at `cut`
    /// included). Used to decide that a query answered from the objects
    /// of some leaves is the octree's answer (see [`crate::accel::LocalKernel`]).
    pub fn leaves_along_all<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        cut: f64,
        skip: &S,
        ok: &K,
    ) -> bool {
        if self.nodes.is_empty() || skip(0) {
            return true;
        }
        let inv = Vec3::ONE / ray.dir;
        let Some((t0, t1)) = self.root_interval(ray, inv, tmin, tmax) else {
            return true;
        };
        let d = ray.dir.to_array();
        let r = RayTrav {
            o: ray.origin.to_array(),
            inv: inv.to_array(),
            flat: [d[0] == 0.0, d[1] == 0.0, d[2] == 0.0],
            pos: [d[0] > 0.0, d[1] > 0.0, d[2] > 0.0],
        };
        self.judge_node(&r, 0, t0, t1, cut, skip, ok)
    }

    /// [`Octree::leaves_along_all`] below node `id`, entered over `[t0,
    /// t1]`: [`Octree::visit_node`]'s child order and intervals.
    #[allow(clippy::too_many_arguments)]
    fn judge_node<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        r: &RayTrav,
        id: NodeId,
        t0: f64,
        t1: f64,
        cut: f64,
        skip: &S,
        ok: &K,
    ) -> bool {
        if t0 > cut || skip(id) {
            return true;
        }
        let node = &self.nodes[id as usize];
        if node.is_leaf() {
            return node.meta & !LEAF == 0 || ok(id);
        }
        let (first, c) = (node.first, node.center());
        let (o, inv) = (r.o, r.inv);
        let mut tm = [f64::INFINITY; 3];
        let mut child = 0u32;
        for a in 0..3 {
            let t = (c[a] - o[a]) * inv[a];
            let bit = if r.flat[a] || t.is_nan() {
                o[a] >= c[a]
            } else {
                tm[a] = t;
                (t <= t0) == r.pos[a]
            };
            child |= (bit as u32) << a;
        }
        let mut order = [0usize, 1, 2];
        if tm[order[0]] > tm[order[1]] {
            order.swap(0, 1);
        }
        if tm[order[1]] > tm[order[2]] {
            order.swap(1, 2);
        }
        if tm[order[0]] > tm[order[1]] {
            order.swap(0, 1);
        }
        // Children without objects hold no leaf to judge.
        let full = node.meta;
        let mut t = t0;
        for a in order {
            let ta = tm[a];
            if ta > t0 && ta < t1 {
                if full & (1 << child) != 0
                    && !self.judge_node(r, first + child, t, ta, cut, skip, ok)
                {
                    return false;
                }
                child ^= 1 << a;
                t = ta;
            }
        }
        full & (1 << child) == 0 || self.judge_node(r, first + child, t, t1, cut, skip, ok)
    }

    /// True if `ok(leaf)` holds for every non-empty leaf whose cell meets
    /// the closed box `[lo, hi]`, without visiting the subtrees `skip`
    /// vouches for; false as soon as one does not, or once `budget`
    /// internal nodes have been opened (the answer is then unknown, and
    /// false is the safe one). Every leaf a traversal of a segment inside
    /// the box visits meets the box (up to the traversal's rounding, which
    /// a box enlarged by [`Octree::box_slack`] covers), so a true answer
    /// stands for [`Octree::leaves_along_all`]'s of every such segment: the
    /// judgement of a bundle of rays at once.
    pub fn leaves_in_box_all<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        lo: Vec3,
        hi: Vec3,
        skip: &S,
        ok: &K,
        budget: &mut u32,
    ) -> bool {
        if self.nodes.is_empty() || skip(0) {
            return true;
        }
        let (lo, hi) = (lo.to_array(), hi.to_array());
        self.box_node(0, 0, &lo, &hi, skip, ok, budget)
    }

    /// How much to enlarge a segment's bounding box (its endpoints' box)
    /// so that it holds every leaf a traversal of the segment visits:
    /// the traversal's plane crossings are rounded within a few units in
    /// the last place of the coordinates and of the segment's length, far
    /// below a billionth of the larger of the root cell and the endpoints'
    /// coordinates.
    pub fn box_slack(&self, lo: Vec3, hi: Vec3) -> f64 {
        let far = lo.abs().max(hi.abs()).max_element();
        (self.root_cell.half + far) * 1e-9
    }

    #[allow(clippy::too_many_arguments)]
    fn box_node<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        id: NodeId,
        depth: usize,
        lo: &[f64; 3],
        hi: &[f64; 3],
        skip: &S,
        ok: &K,
        budget: &mut u32,
    ) -> bool {
        let node = &self.nodes[id as usize];
        if node.is_leaf() {
            return node.meta & !LEAF == 0 || ok(id);
        }
        if *budget == 0 {
            return false;
        }
        *budget -= 1;
        let (c, h) = (node.center(), self.half_at[depth]);
        // Per axis, which halves the box meets: bit 0 the lower, bit 1
        // the upper.
        let mut halves = [0u8; 3];
        for a in 0..3 {
            halves[a] = (lo[a] <= c[a] && hi[a] >= c[a] - h) as u8
                | (((hi[a] >= c[a] && lo[a] <= c[a] + h) as u8) << 1);
        }
        for child in 0..8u32 {
            let met = (0..3).all(|a| halves[a] & (1 << ((child >> a) & 1)) != 0);
            if met && node.meta & (1 << child) != 0 {
                let id = node.first + child;
                if !skip(id) && !self.box_node(id, depth + 1, lo, hi, skip, ok, budget) {
                    return false;
                }
            }
        }
        true
    }

    /// The leaves a ray passes through, in order along the ray (the cells a
    /// migrating ray visits). Zero-length spans appear where the ray passes
    /// exactly through a cell edge or corner.
    pub fn leaves_along_ray(&self, ray: &Ray, tmin: f64, tmax: f64) -> Vec<LeafSpan> {
        let mut out = Vec::new();
        self.for_each_leaf_along_ray(ray, tmin, tmax, |leaf, t_enter, t_exit| {
            out.push(LeafSpan {
                leaf,
                t_enter,
                t_exit,
            });
            false
        });
        out
    }
}

/// Reference nearest-hit over all objects (same tie rule as the octree).
pub fn intersect_brute_force(objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
    let pre = PreparedRay::new(ray);
    let mut best: Option<Hit> = None;
    for (id, o) in objects.iter().enumerate() {
        let bound = best.map_or(tmax, |b| next_up(b.t));
        if let Some(h) = o.shape.intersect_prepared(&pre, tmin, bound) {
            if best.is_none_or(|b| h.t < b.t) {
                best = Some(Hit::on(o, id as u32, ray, h.t, &h));
            }
        }
    }
    best
}

/// Reference any-hit over all objects.
pub fn occluded_brute_force(
    objects: &[Object],
    ray: &Ray,
    tmin: f64,
    tmax: f64,
    ignore: Option<ObjectId>,
) -> bool {
    let pre = PreparedRay::new(ray);
    objects
        .iter()
        .enumerate()
        .any(|(id, o)| Some(id as u32) != ignore && o.shape.occludes_prepared(&pre, tmin, tmax))
}
