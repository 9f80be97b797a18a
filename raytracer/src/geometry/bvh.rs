//! A bounding volume hierarchy over a set of objects.
//!
//! The octree stays what the paper made it: the division of the scene into
//! cells, and the structure a resumable query's progress is counted in. For
//! rays whose whole path is in one set of objects (the sequential renderer,
//! a whole scene, the shared geometry of instances), this hierarchy answers the same queries with fewer steps: a
//! binary tree built with the surface area heuristic, then collapsed into
//! four-wide nodes (Embree's layout), each holding its four children's
//! boxes so that all are tested at once, four double-precision lanes side
//! by side; the nearest child entered is visited first. Measured
//! (`hybrid-rt bench --embree`, the studio as 48,684 triangles, one core):
//! the wide nodes trace primary rays about twice as fast as the binary
//! ones, shadow rays about 1.3 times.
//!
//! **Same answers as the octree.** A node is only a filter: the objects it
//! lets through are tested with the same code ([`Tester`]), and the answer
//! (the nearest hit, the smaller id of equal ones; any hit) does not depend
//! on the order objects are tested in. Every box is enlarged by the
//! octree's margin (`1e-9` of the scene's size), far beyond the rounding of
//! the slab test, so no object a ray hits is ever filtered out: rays on box
//! faces, grazing rays and rays along an axis included (a zero direction
//! component gives an infinite inverse; the `0 * inf` NaN of a ray exactly
//! on a box plane leaves that axis unconstrained).

use super::prims::{Prims, Tester};
use super::robust::next_up;
use super::shape::{Hit, InstanceGeometry, Object, ObjectId, ObjectIndex, ShapeHit};
use super::{Aabb, PreparedRay, Ray, Vec3};

/// Largest number of objects in a leaf.
const MAX_LEAF: usize = 8;
/// Bins per axis of the binned surface area heuristic.
const BINS: usize = 16;
/// Cost of visiting a node (two box tests) relative to testing one
/// object. Measured (`hybrid-rt bench`, studio and Cornell box, 512x512):
/// 1.0 gave 1.38x and 0.88x the octree's rate, 0.5 1.64x and 1.08x, 0.25
/// no better than 0.5.
const NODE_COST: f64 = 0.5;
/// Depth below which the build splits by count (halving, so at most 32
/// levels more).
const SAH_DEPTH: u32 = 48;
/// Size of the traversal stack: at least the tree's depth.
const STACK: usize = 96;
/// Trees at most this deep are traversed with a smaller stack (a
/// traversal's stack is zeroed for every ray: 4.6 kB for [`STACK`], 1.9 kB
/// for this). Each wide level leaves at most three children pending.
const SHALLOW: usize = 40;

/// Two children: `b[axis][0]` the lower corner, `b[axis][1]` the upper,
/// each `[child 0, child 1]`. `count[i] == 0`: child `i` is the node
/// `link[i]`; else it is a leaf of `count[i]` objects from `ids[link[i]..]`.
/// An unused child has an empty box (lower corner `+inf`), which no ray
/// enters.
#[derive(Debug, Clone, Copy)]
struct Node {
    b: [[[f64; 2]; 2]; 3],
    link: [u32; 2],
    count: [u32; 2],
}

impl Node {
    const UNUSED: Node = Node {
        b: [[[f64::INFINITY; 2], [f64::NEG_INFINITY; 2]]; 3],
        link: [0; 2],
        count: [0; 2],
    };

    fn set(&mut self, lane: usize, bounds: Aabb, link: u32, count: u32) {
        for a in 0..3 {
            self.b[a][0][lane] = bounds.min[a];
            self.b[a][1][lane] = bounds.max[a];
        }
        self.link[lane] = link;
        self.count[lane] = count;
    }
}

/// Four children, the traversal's node: [`Node`]'s layout four lanes wide
/// (`b[axis][0]` the lower corners, `b[axis][1]` the upper, each
/// `[child 0, .., child 3]`). Built by collapsing the binary tree: each
/// wide node takes a binary node's children and opens the largest internal
/// one until it has four (Embree's "wide nodes": half the levels, the four
/// box tests side by side). Unused children have empty boxes.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Wide {
    b: [[[f64; 4]; 2]; 3],
    link: [u32; 4],
    count: [u32; 4],
}

impl Wide {
    const UNUSED: Wide = Wide {
        b: [[[f64::INFINITY; 4], [f64::NEG_INFINITY; 4]]; 3],
        link: [0; 4],
        count: [0; 4],
    };
}

/// A child of a binary node: `(node, lane)`.
type Lane = (u32, usize);

fn lane_box(bin: &[Node], (n, l): Lane) -> Aabb {
    let b = &bin[n as usize].b;
    Aabb::new(
        Vec3::new(b[0][0][l], b[1][0][l], b[2][0][l]),
        Vec3::new(b[0][1][l], b[1][1][l], b[2][1][l]),
    )
}

/// The wide node over binary node `node`'s subtree (appended to `out`
/// with its descendants); returns its index. Deterministic: the largest
/// internal child is opened, the first of equal ones.
fn widen(bin: &[Node], out: &mut Vec<Wide>, node: u32) -> u32 {
    let mut kids: Vec<Lane> = (0..2)
        .map(|l| (node, l))
        .filter(|&k| !lane_box(bin, k).is_empty())
        .collect();
    while kids.len() < 4 {
        let open = kids
            .iter()
            .enumerate()
            .filter(|(_, &(n, l))| bin[n as usize].count[l] == 0)
            .map(|(i, &k)| (i, area(&lane_box(bin, k))))
            .fold(None, |best: Option<(usize, f64)>, (i, a)| match best {
                Some((_, ba)) if ba >= a => best,
                _ => Some((i, a)),
            });
        let Some((i, _)) = open else { break };
        let (n, l) = kids[i];
        let child = bin[n as usize].link[l];
        let grand: Vec<Lane> = (0..2)
            .map(|g| (child, g))
            .filter(|&k| !lane_box(bin, k).is_empty())
            .collect();
        kids.splice(i..=i, grand);
    }
    let id = out.len() as u32;
    out.push(Wide::UNUSED);
    for (j, &(n, l)) in kids.iter().enumerate() {
        let b = lane_box(bin, (n, l));
        let src = &bin[n as usize];
        let (link, count) = if src.count[l] > 0 {
            (src.link[l], src.count[l])
        } else {
            (widen(bin, out, src.link[l]), 0)
        };
        let w = &mut out[id as usize];
        for a in 0..3 {
            w.b[a][0][j] = b.min[a];
            w.b[a][1][j] = b.max[a];
        }
        w.link[j] = link;
        w.count[j] = count;
    }
    id
}

/// Per-ray constants of the slab test.
struct Slab {
    o: [f64; 3],
    inv: [f64; 3],
    /// Index (0 lower, 1 upper) of the plane the ray enters by on each axis.
    near: [usize; 3],
}

impl Slab {
    #[inline(always)]
    fn new(ray: &Ray, inv: Vec3) -> Self {
        let inv = inv.to_array();
        Slab {
            o: ray.origin.to_array(),
            inv,
            near: inv.map(|x| x.is_sign_negative() as usize),
        }
    }

    /// Entry and exit distances of a wide node's four children's boxes
    /// within `[tmin, tmax]` (the ray enters child `i` if `t0[i] <= t1[i]`).
    #[inline(always)]
    fn test4(&self, n: &Wide, tmin: f64, tmax: f64) -> ([f64; 4], [f64; 4]) {
        let mut t0 = [tmin; 4];
        let mut t1 = [tmax; 4];
        for a in 0..3 {
            let (o, inv) = (self.o[a], self.inv[a]);
            let lo = n.b[a][self.near[a]];
            let hi = n.b[a][1 - self.near[a]];
            for l in 0..4 {
                let e = (lo[l] - o) * inv;
                let x = (hi[l] - o) * inv;
                // Written so a NaN (0 * inf) keeps the bound: `maxpd`/`minpd`.
                t0[l] = if e > t0[l] { e } else { t0[l] };
                t1[l] = if x < t1[l] { x } else { t1[l] };
            }
        }
        (t0, t1)
    }
}

/// The hierarchy. `Default` is the empty one (every query misses).
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    /// Node 0 holds the root's children.
    nodes: Vec<Wide>,
    /// Object ids in leaf order.
    ids: Vec<ObjectId>,
    /// Objects without finite bounds: tested by every ray.
    unbounded: Vec<ObjectId>,
    prims: Prims,
    /// Deepest leaf (the root's children have depth 1).
    depth: u32,
}

/// Statistics of a built hierarchy.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BvhStats {
    pub nodes: usize,
    pub leaves: usize,
    pub depth: u32,
    pub objects: usize,
}

#[derive(Debug, Clone, Copy)]
struct Item {
    bounds: Aabb,
    center: Vec3,
    id: ObjectId,
}

struct Builder {
    nodes: Vec<Node>,
    /// Object ids of the leaves built so far, in leaf order.
    ids: Vec<ObjectId>,
    depth: u32,
}

fn area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let e = b.extent();
    e.x * e.y + e.y * e.z + e.z * e.x
}

fn bounds_of(items: &[Item]) -> Aabb {
    items.iter().fold(Aabb::EMPTY, |a, it| a.union(it.bounds))
}

/// Sweeps bin boundaries: the cheapest `(cost, boundary)` given each bin's
/// box and object count.
fn sweep(bin_box: &[Aabb; BINS], bin_n: &[usize; BINS], parent_area: f64) -> Option<(f64, usize)> {
    let mut right_area = [0.0; BINS];
    let mut right_n = [0usize; BINS];
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    for b in (1..BINS).rev() {
        acc = acc.union(bin_box[b]);
        cnt += bin_n[b];
        right_area[b] = area(&acc);
        right_n[b] = cnt;
    }
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    let mut best: Option<(f64, usize)> = None;
    for b in 1..BINS {
        acc = acc.union(bin_box[b - 1]);
        cnt += bin_n[b - 1];
        if cnt == 0 || right_n[b] == 0 {
            continue;
        }
        let cost = NODE_COST
            + (area(&acc) * cnt as f64 + right_area[b] * right_n[b] as f64)
                / parent_area.max(f64::MIN_POSITIVE);
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, b));
        }
    }
    best
}

impl Builder {
    /// Builds the subtree over `items` and returns its box, link and count
    /// (see [`Node`]).
    fn subtree(&mut self, items: &mut [Item], depth: u32) -> (Aabb, u32, u32) {
        let bounds = bounds_of(items);
        match self.split(items, &bounds, depth) {
            None => {
                self.depth = self.depth.max(depth);
                let start = self.ids.len() as u32;
                self.ids.extend(items.iter().map(|it| it.id));
                (bounds, start, items.len() as u32)
            }
            Some(mid) => (bounds, self.node(items, mid, depth), 0),
        }
    }

    /// A node with children over `items[..mid]` and `items[mid..]`.
    fn node(&mut self, items: &mut [Item], mid: usize, depth: u32) -> u32 {
        let id = self.nodes.len() as u32;
        self.nodes.push(Node::UNUSED);
        let (left, right) = items.split_at_mut(mid);
        let (b0, l0, c0) = self.subtree(left, depth + 1);
        let (b1, l1, c1) = self.subtree(right, depth + 1);
        let n = &mut self.nodes[id as usize];
        n.set(0, b0, l0, c0);
        n.set(1, b1, l1, c1);
        id
    }

    /// How to split `items`: the binned surface area heuristic over the
    /// three axes (objects binned by box centre); a split by count where
    /// centres coincide or the tree would grow too deep for the traversal
    /// stack.
    fn split(&self, items: &mut [Item], bounds: &Aabb, depth: u32) -> Option<usize> {
        let n = items.len();
        if n <= 1 {
            return None;
        }
        let cb = items.iter().fold(Aabb::EMPTY, |a, it| a.grow(it.center));
        let axis_ext = cb.extent();
        let widest = axis_ext.max_position();
        let by_count = |items: &mut [Item]| {
            if n <= MAX_LEAF {
                return None;
            }
            items.sort_unstable_by(|a, b| {
                a.center[widest]
                    .total_cmp(&b.center[widest])
                    .then(a.id.cmp(&b.id))
            });
            Some(n / 2)
        };
        if depth >= SAH_DEPTH || axis_ext.max_element() <= 0.0 || !axis_ext.is_finite() {
            return by_count(items);
        }
        let parent_area = area(bounds);
        let bin = |it: &Item, axis: usize| {
            let scale = BINS as f64 / axis_ext[axis];
            (((it.center[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1)
        };
        let mut object: Option<(f64, usize, usize)> = None;
        for axis in 0..3 {
            if axis_ext[axis] <= 0.0 {
                continue;
            }
            let mut bin_box = [Aabb::EMPTY; BINS];
            let mut bin_n = [0usize; BINS];
            for it in items.iter() {
                let b = bin(it, axis);
                bin_box[b] = bin_box[b].union(it.bounds);
                bin_n[b] += 1;
            }
            if let Some((cost, b)) = sweep(&bin_box, &bin_n, parent_area) {
                if object.is_none_or(|(c, _, _)| cost < c) {
                    object = Some((cost, axis, b));
                }
            }
        }
        let Some((cost, axis, b)) = object else {
            return by_count(items);
        };
        if n <= MAX_LEAF && cost >= n as f64 {
            return by_count(items);
        }
        // In place, ordered by side and id: deterministic.
        items.sort_unstable_by_key(|it| (bin(it, axis) >= b, it.id));
        Some(items.iter().take_while(|it| bin(it, axis) < b).count())
    }
}

impl Bvh {
    /// Builds the hierarchy over `objects` (ids are indices into
    /// `objects`). Objects with empty bounds are left out, like the
    /// octree's. Deterministic.
    pub fn build(objects: &[Object]) -> Bvh {
        let mut unbounded = Vec::new();
        let mut items = Vec::with_capacity(objects.len());
        let mut scene = Aabb::EMPTY;
        for (i, o) in objects.iter().enumerate() {
            let b = o.shape.bounds();
            if b.is_empty() {
                continue;
            }
            if !(b.min.is_finite() && b.max.is_finite()) {
                unbounded.push(i as ObjectId);
                continue;
            }
            scene = scene.union(b);
            items.push(Item {
                bounds: b,
                center: b.center(),
                id: i as ObjectId,
            });
        }
        let mut bvh = Bvh {
            unbounded,
            prims: Prims::build(objects),
            ..Default::default()
        };
        if items.is_empty() {
            return bvh;
        }
        // The octree's margin: far beyond the slab test's rounding.
        let margin = 1e-9 * (scene.extent().max_element() + scene.magnitude());
        let pad = Vec3::splat(margin);
        for it in &mut items {
            it.bounds = Aabb::new(it.bounds.min - pad, it.bounds.max + pad);
        }
        let all = bounds_of(&items);
        let mut b = Builder {
            nodes: Vec::with_capacity(items.len()),
            ids: Vec::with_capacity(items.len()),
            depth: 0,
        };
        match b.split(&mut items, &all, 0) {
            None => {
                b.nodes.push(Node::UNUSED);
                b.nodes[0].set(0, all, 0, items.len() as u32);
                b.ids.extend(items.iter().map(|it| it.id));
                b.depth = 1;
            }
            Some(mid) => {
                b.node(&mut items, mid, 1);
            }
        }
        let mut wide = Vec::with_capacity(b.nodes.len() / 2 + 1);
        widen(&b.nodes, &mut wide, 0);
        bvh.nodes = wide;
        bvh.ids = b.ids;
        bvh.depth = b.depth;
        bvh
    }

    pub fn stats(&self) -> BvhStats {
        BvhStats {
            nodes: self.nodes.len(),
            leaves: self
                .nodes
                .iter()
                .flat_map(|n| n.count)
                .filter(|&c| c > 0)
                .count(),
            depth: self.depth,
            objects: self.ids.len() + self.unbounded.len(),
        }
    }

    /// Heap bytes (nodes, ids and the compact object data).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.capacity() * std::mem::size_of::<Wide>()
            + (self.ids.capacity() + self.unbounded.capacity()) * std::mem::size_of::<ObjectId>()
            + self.prims.memory_bytes()
    }

    /// Nearest hit with `tmin < t < tmax` among `objects` (the slice the
    /// hierarchy was built over). Equal distances resolve to the smaller
    /// object id, like [`crate::accel::intersect_brute_force`] and
    /// [`crate::accel::Octree::intersect`].
    pub fn intersect(&self, objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.intersect_avx2(objects, ray, tmin, tmax) };
        }
        if self.depth as usize <= SHALLOW {
            self.intersect_impl::<{ 3 * SHALLOW + 1 }>(objects, ray, tmin, tmax)
        } else {
            self.intersect_impl::<{ 3 * STACK + 1 }>(objects, ray, tmin, tmax)
        }
    }

    /// [`Bvh::intersect`] compiled for AVX2 (the four lanes of a slab test
    /// in one instruction). The same IEEE operations in the same order (no
    /// fused multiply-add): the same answers, bit for bit. Measured
    /// (`hybrid-rt bench --embree`, three runs side by side): about 6%
    /// faster, primary and shadow rays.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn intersect_avx2(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        if self.depth as usize <= SHALLOW {
            self.intersect_impl::<{ 3 * SHALLOW + 1 }>(objects, ray, tmin, tmax)
        } else {
            self.intersect_impl::<{ 3 * STACK + 1 }>(objects, ray, tmin, tmax)
        }
    }

    #[inline(always)]
    fn intersect_impl<const N: usize>(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
    ) -> Option<Hit> {
        let pre = PreparedRay::new(ray);
        let test = Tester::new(&self.prims, objects, &pre);
        let mut best: Option<(f64, ObjectId, ShapeHit)> = None;
        let mut cut = tmax;
        let mut consider = |id: ObjectId, cut: &mut f64| {
            let bound = if best.is_some() { next_up(*cut) } else { *cut };
            if let Some(h) = test.intersect(id, tmin, bound) {
                if best.is_none_or(|(bt, bid, _)| h.t < bt || (h.t == bt && id < bid)) {
                    best = Some((h.t, id, h));
                    *cut = h.t;
                }
            }
        };
        for &id in &self.unbounded {
            consider(id, &mut cut);
        }
        if !self.nodes.is_empty() {
            let slab = Slab::new(ray, pre.inv_dir);
            // Pending children, nearest on top: (link, count, entry distance).
            let mut stack = [(0u32, 0u32, 0.0f64); N];
            let mut sp = 0usize;
            let (mut link, mut count) = (0u32, 0u32);
            loop {
                if count > 0 {
                    let s = link as usize;
                    for &id in &self.ids[s..s + count as usize] {
                        consider(id, &mut cut);
                    }
                } else {
                    let n = &self.nodes[link as usize];
                    let (t0, t1) = slab.test4(n, tmin, cut);
                    // The children entered, farthest pushed first (ties
                    // by lane: deterministic).
                    let base = sp;
                    for lane in 0..4 {
                        if t0[lane] <= t1[lane] {
                            let e = (n.link[lane], n.count[lane], t0[lane]);
                            let mut j = sp;
                            while j > base && stack[j - 1].2 < e.2 {
                                stack[j] = stack[j - 1];
                                j -= 1;
                            }
                            stack[j] = e;
                            sp += 1;
                        }
                    }
                }
                // The nearest pending child still in front of the cut.
                let mut next = None;
                while sp > 0 {
                    sp -= 1;
                    let (l, c, t) = stack[sp];
                    if t <= cut {
                        next = Some((l, c));
                        break;
                    }
                }
                match next {
                    Some(lc) => (link, count) = lc,
                    None => break,
                }
            }
        }
        best.map(|(t, id, h)| Hit::on(&objects[id as usize], id, ray, t, h.normal, h.inner))
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
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2.
            return unsafe { self.occluded_avx2(objects, ray, tmin, tmax, ignore) };
        }
        if self.depth as usize <= SHALLOW {
            self.occluded_impl::<{ 3 * SHALLOW }>(objects, ray, tmin, tmax, ignore)
        } else {
            self.occluded_impl::<{ 3 * STACK }>(objects, ray, tmin, tmax, ignore)
        }
    }

    /// [`Bvh::occluded`] compiled for AVX2 (see [`Bvh::intersect_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn occluded_avx2(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        if self.depth as usize <= SHALLOW {
            self.occluded_impl::<{ 3 * SHALLOW }>(objects, ray, tmin, tmax, ignore)
        } else {
            self.occluded_impl::<{ 3 * STACK }>(objects, ray, tmin, tmax, ignore)
        }
    }

    #[inline(always)]
    fn occluded_impl<const N: usize>(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        let pre = PreparedRay::new(ray);
        let test = Tester::new(&self.prims, objects, &pre);
        let blocks = |id: ObjectId| Some(id) != ignore && test.occludes(id, tmin, tmax);
        if self.unbounded.iter().any(|&id| blocks(id)) {
            return true;
        }
        if self.nodes.is_empty() {
            return false;
        }
        let slab = Slab::new(ray, pre.inv_dir);
        let mut stack = [0u32; N];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (t0, t1) = slab.test4(n, tmin, tmax);
            let mut next = u32::MAX;
            for lane in 0..4 {
                if t0[lane] > t1[lane] {
                    continue;
                }
                let count = n.count[lane];
                if count > 0 {
                    let s = n.link[lane] as usize;
                    if self.ids[s..s + count as usize].iter().any(|&id| blocks(id)) {
                        return true;
                    }
                } else if next == u32::MAX {
                    next = n.link[lane];
                } else {
                    stack[sp] = n.link[lane];
                    sp += 1;
                }
            }
            if next != u32::MAX {
                node = next;
            } else if sp > 0 {
                sp -= 1;
                node = stack[sp];
            } else {
                return false;
            }
        }
    }
}

impl InstanceGeometry {
    /// Shared geometry with its own hierarchy ([`Bvh`]) in object space.
    pub fn new(name: impl Into<String>, objects: Vec<Object>) -> Self {
        let bounds = objects
            .iter()
            .fold(Aabb::EMPTY, |b, o| b.union(o.shape.bounds()));
        let accel = Box::new(Bvh::build(&objects));
        Self {
            name: name.into(),
            objects,
            accel,
            bounds,
            shading: None,
        }
    }
}

impl ObjectIndex for Bvh {
    fn intersect(&self, objects: &[Object], ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        Bvh::intersect(self, objects, ray, tmin, tmax)
    }

    fn occluded(
        &self,
        objects: &[Object],
        ray: &Ray,
        tmin: f64,
        tmax: f64,
        ignore: Option<ObjectId>,
    ) -> bool {
        Bvh::occluded(self, objects, ray, tmin, tmax, ignore)
    }

    fn memory_bytes(&self) -> usize {
        Bvh::memory_bytes(self)
    }
}
