//! The octree's build over the root's eight subtrees side by side: the
//! serial build's tree, node for node.
//!
//! The serial recursion numbers nodes depth first, a node's eight children
//! as one block, so the descendants of the root's child `k` take one
//! contiguous range of ids after those of children `0..k`, and their leaf
//! lists one range of `leaf_objects`. Each child's subtree is built by a
//! builder of its own (ids from 0, the child itself), then its ids and
//! list offsets are shifted into place. The one thing a subtree cannot
//! know is the serial build's node budget, which it checks against the
//! nodes made before, in every subtree to its left: the subtrees are built
//! without it, and a tree that ends up over the budget is built again
//! serially. Under the budget nothing differs, since each split the serial
//! build checks has fewer nodes before it than the finished tree.

use super::{Builder, Cell, NodeId, ObjectId, Octree, TravNode};

/// Objects from which the root's subtrees are built on several threads.
const SIDE_BY_SIDE_FROM: usize = 2048;

impl Builder<'_> {
    /// Builds the tree from the root (`self.tree` holds the root alone)
    /// with its subtrees side by side; the candidates back where that is
    /// not worth it (few objects, one core, a root that stays a leaf) or
    /// the budget would have cut the tree.
    pub(super) fn split_root(
        &mut self,
        root: Cell,
        cands: Vec<ObjectId>,
    ) -> Result<(), Vec<ObjectId>> {
        let p = &self.params;
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        if cands.len() < SIDE_BY_SIDE_FROM
            || cores < 2
            || cands.len() <= p.max_objects
            || p.max_depth == 0
            || p.max_stall == 0
            || 9 > self.node_budget
        {
            return Err(cands);
        }
        // One thread a subtree: eight, whatever the cores. Each picks its
        // child's objects out of the root's candidates itself.
        let build = |i: usize| {
            let c = root.child(i);
            let sub = self.candidates_in(&cands, &c);
            let stall = u32::from(sub.len() == cands.len());
            let mut b = Builder {
                objects: self.objects,
                bounds: self.bounds,
                params: self.params.clone(),
                margin: self.margin,
                tree: Octree {
                    half_at: self.tree.half_at,
                    nodes: vec![TravNode::EMPTY_LEAF],
                    parents: vec![NodeId::MAX],
                    depths: vec![1],
                    ..Default::default()
                },
                node_budget: usize::MAX,
            };
            b.node(0, c, sub, 1, stall);
            b.tree
        };
        let parts: Vec<Octree> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8).map(|i| s.spawn(move || build(i))).collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
                .collect()
        });
        let total: usize = 9 + parts.iter().map(|t| t.nodes.len() - 1).sum::<usize>();
        if total > self.node_budget {
            return Err(cands);
        }
        let t = &mut self.tree;
        t.nodes[0] = TravNode {
            w: root.center.to_array().map(f64::to_bits),
            first: 1,
            meta: 0,
        };
        t.nodes.reserve_exact(total - 1);
        t.parents.reserve_exact(total - 1);
        t.depths.reserve_exact(total - 1);
        t.nodes.extend(parts.iter().map(|p| p.nodes[0]));
        t.parents.extend([0; 8]);
        t.depths.extend([1; 8]);
        // Where each part's descendants and leaf lists begin.
        let mut base = 9u32;
        let mut lists = 0u32;
        for (k, part) in parts.iter().enumerate() {
            let id = |local: u32| {
                if local == 0 {
                    1 + k as u32
                } else {
                    base + local - 1
                }
            };
            let shift = |n: &TravNode| {
                let mut n = *n;
                n.first = if n.is_leaf() {
                    lists + n.first
                } else {
                    id(n.first)
                };
                n
            };
            // The part's root is the root's child `k`; the rest follows.
            let mut shifted = part.nodes.iter().map(shift);
            if let Some(child) = shifted.next() {
                t.nodes[1 + k] = child;
            }
            t.nodes.extend(shifted);
            t.parents.extend(part.parents[1..].iter().map(|&p| id(p)));
            t.depths.extend_from_slice(&part.depths[1..]);
            t.leaf_objects.extend_from_slice(&part.leaf_objects);
            base += part.nodes.len() as u32 - 1;
            lists += part.leaf_objects.len() as u32;
        }
        debug_assert_eq!(t.nodes.len(), total);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::{node_budget, Octree, OctreeParams};
    use crate::geometry::Object;

    /// Node for node, list for list.
    fn assert_same(a: &Octree, b: &Octree, what: &str) {
        let nodes = |t: &Octree| -> Vec<([u64; 3], u32, u32)> {
            t.nodes.iter().map(|n| (n.w, n.first, n.meta)).collect()
        };
        assert_eq!(nodes(a), nodes(b), "{what}: nodes");
        assert_eq!(a.parents, b.parents, "{what}: parents");
        assert_eq!(a.depths, b.depths, "{what}: depths");
        assert_eq!(a.leaf_objects, b.leaf_objects, "{what}: leaf lists");
        assert_eq!(a.stats, b.stats, "{what}: statistics");
    }

    fn both(objects: &[Object], budget: usize, what: &str) -> usize {
        let p = OctreeParams::default();
        let side = Octree::build_with(objects, &p, true, budget);
        let serial = Octree::build_with(objects, &p, false, budget);
        assert_same(&side, &serial, what);
        side.nodes.len()
    }

    /// Random scenes of every kind of surface at three scales, and a
    /// generated city, each larger than the side-by-side threshold.
    #[test]
    fn subtrees_side_by_side_build_the_serial_tree() {
        for (seed, size) in [(1u64, 10.0), (2, 1e-4), (3, 1e5)] {
            let objects = crate::accel::tests::random_scene(seed, 3000, size);
            both(
                &objects,
                node_budget(objects.len()),
                &format!("random {seed}"),
            );
        }
        let city =
            crate::scene::load_rad_str(&crate::scene::generate::city(1998, 4000), "city.rad")
                .unwrap();
        both(&city.objects, node_budget(city.objects.len()), "city");
        // Coincident spheres, which every child of the root keeps all of
        // (the stall count starts at the root's children).
        let coincident: Vec<Object> = (0..2100)
            .map(|_| {
                let s = crate::geometry::Shape::sphere(crate::geometry::Vec3::ZERO, 0.3, false);
                crate::accel::tests::obj(s.unwrap())
            })
            .collect();
        both(
            &coincident,
            node_budget(coincident.len()),
            "coincident spheres",
        );
    }

    /// A tree over its budget is built serially, which stops splitting at
    /// the budget; at exactly its size the subtrees are built side by side.
    #[test]
    fn the_node_budget_cuts_the_tree_as_the_serial_build_does() {
        let objects = crate::accel::tests::random_scene(4, 2500, 10.0);
        let full = both(&objects, usize::MAX, "unlimited");
        assert_eq!(both(&objects, full, "at the budget"), full);
        let cut = both(&objects, full - 1, "one node short");
        assert!(cut < full, "{cut} of {full}");
        both(&objects, full / 3, "a third");
    }
}
