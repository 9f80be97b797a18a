//! Pyramid clipping: the octree leaves (and objects) a bundle of rays from
//! one apex may visit, in front-to-back order.
//!
//! A [`Pyramid`] bounds a bundle of rays sharing an apex (the eye and the
//! corners of a screen tile, or a hit point and the corners of a light's
//! patches). Its side planes pass through the apex and bound the bounding
//! rectangle of the ray directions projected onto the plane at unit distance
//! along the bundle's mean direction; a near plane (at the apex unless a near
//! limit is given) and an optional far plane close it. The pyramid is
//! conservative: every point `apex + t * dir` of every bundle ray with
//! `near <= t <= far` lies inside it (with a small relative margin outward).
//!
//! [`Octree::clip`] descends from the root, prunes nodes whose cells
//! (enlarged by the octree's margin) lie entirely outside one plane, and
//! visits children in octant order seen from the apex (the half containing
//! the apex first along each axis). For any ray starting at the apex this
//! order is a linear extension of the order in which the ray crosses the
//! leaves, so the leaves along every bundle ray appear in the result in the
//! order the ray meets them.

use crate::geometry::robust::orthonormal_basis;
use crate::geometry::{Aabb, Vec3};
use crate::scene::ObjectId;

use super::{NodeId, NodeView, Octree};

/// Relative slack added outward to the side planes (in units of the
/// projected extent, plus an absolute floor) so rounding never excludes a
/// bundle ray.
const REL_EPS: f64 = 1e-7;

/// A half-space `normal . p <= offset` (normal of unit length).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub normal: Vec3,
    pub offset: f64,
}

impl Plane {
    /// True if the whole box lies strictly outside (beyond `tol`).
    #[inline]
    fn excludes(&self, b: &Aabb, tol: f64) -> bool {
        // The box corner minimising normal . p (the "n-vertex"; the box is
        // outside iff even that corner is outside).
        let n = self.normal;
        let p = Vec3::new(
            if n.x >= 0.0 { b.min.x } else { b.max.x },
            if n.y >= 0.0 { b.min.y } else { b.max.y },
            if n.z >= 0.0 { b.min.z } else { b.max.z },
        );
        n.dot(p) - self.offset > tol
    }
}

/// A convex bounding pyramid (frustum) around a bundle of rays from one apex.
#[derive(Debug, Clone, PartialEq)]
pub struct Pyramid {
    apex: Vec3,
    /// Unit mean direction of the bundle.
    axis: Vec3,
    /// Unit ray directions of the bundle.
    dirs: Vec<Vec3>,
    /// Bounding planes (side planes, near plane, far plane if any).
    planes: Vec<Plane>,
    /// Ray-parameter limits the pyramid was built for.
    near: f64,
    far: f64,
}

impl Pyramid {
    /// The convex hull of `points` as a clipping volume (its faces, pushed
    /// outwards by a relative margin), with `apex` the point leaves are
    /// ordered from. The hull of a cell's corners and a light's box corners
    /// holds every shadow ray from any point of the cell to any point of the
    /// light: one clip serves every bundle shaded in that cell. `None` when
    /// the points do not span a volume.
    pub fn hull(points: &[Vec3], apex: Vec3) -> Option<Pyramid> {
        let pts: Vec<Vec3> = points.iter().copied().filter(|p| p.is_finite()).collect();
        let scale = pts
            .iter()
            .fold(0.0f64, |m, p| m.max(p.abs().max_element()))
            .max(1e-300);
        let lo = pts
            .iter()
            .fold(Vec3::splat(f64::INFINITY), |m, &p| m.min(p));
        let hi = pts
            .iter()
            .fold(Vec3::splat(f64::NEG_INFINITY), |m, &p| m.max(p));
        let size = (hi - lo).max_element();
        if size.is_nan() || size <= 0.0 {
            return None;
        }
        let eps = 1e-9 * (size + scale);
        let pad = REL_EPS * (size + scale);
        let mut planes: Vec<Plane> = Vec::new();
        let n = pts.len();
        // The side test below stops at the first points found on both
        // sides of a candidate plane; trying far-apart points first (each
        // box corner and its opposite, the boxes alternating, when the
        // points are two boxes' corners) finds them sooner. The answer
        // does not depend on the order.
        let probe: Vec<Vec3> = if n == 16 {
            const ORDER: [usize; 16] = [0, 15, 7, 8, 3, 12, 4, 11, 1, 14, 6, 9, 2, 13, 5, 10];
            ORDER.iter().map(|&i| pts[i]).collect()
        } else {
            pts.clone()
        };
        for i in 0..n {
            for j in i + 1..n {
                for k in j + 1..n {
                    let raw = (pts[j] - pts[i]).cross(pts[k] - pts[i]);
                    let len2 = raw.length_squared();
                    if len2.is_nan() || len2 <= (1e-12 * size * size).powi(2) {
                        continue;
                    }
                    // Most triples are not faces: decide that on the
                    // unnormalised normal (|s| > eps |n| as s^2 > eps^2 |n|^2,
                    // no square root or division) and normalise faces only.
                    let d_raw = raw.dot(pts[i]);
                    let lim2 = eps * eps * len2;
                    let (mut above, mut below) = (false, false);
                    for p in &probe {
                        let s = raw.dot(*p) - d_raw;
                        let far = s * s > lim2;
                        above |= far && s > 0.0;
                        below |= far && s < 0.0;
                        if above && below {
                            break; // not a face
                        }
                    }
                    let nrm = raw / len2.sqrt();
                    let face = match (above, below) {
                        (false, _) => Some(nrm),
                        (true, false) => Some(-nrm),
                        _ => None,
                    };
                    if let Some(f) = face {
                        let off = f.dot(pts[i]) + pad;
                        if !planes
                            .iter()
                            .any(|q| q.normal.dot(f) > 1.0 - 1e-12 && (q.offset - off).abs() <= pad)
                        {
                            planes.push(Plane {
                                normal: f,
                                offset: off,
                            });
                        }
                    }
                }
            }
        }
        if planes.len() < 4 {
            return None;
        }
        let centre = (lo + hi) * 0.5;
        let axis = (centre - apex).try_normalize().unwrap_or(Vec3::Z);
        Some(Pyramid {
            apex,
            axis,
            dirs: Vec::new(),
            planes,
            near: 0.0,
            far: f64::INFINITY,
        })
    }

    /// The pyramid around the rays from `apex` through each of `targets`
    /// (unbounded beyond the targets; see [`Pyramid::to_targets`] for
    /// segments ending at them). Targets equal to the apex are ignored.
    pub fn from_apex_and_targets(apex: Vec3, targets: &[Vec3]) -> Pyramid {
        let dirs: Vec<Vec3> = targets.iter().map(|&t| t - apex).collect();
        Self::from_rays(apex, &dirs)
    }

    /// The pyramid around the segments from `apex` to each of `targets`
    /// (a shadow bundle: the far limit is the largest target distance).
    pub fn to_targets(apex: Vec3, targets: &[Vec3]) -> Pyramid {
        let far = targets
            .iter()
            .map(|&t| (t - apex).length())
            .fold(0.0, f64::max);
        Self::from_apex_and_targets(apex, targets).with_far(far)
    }

    /// The pyramid around the rays from `apex` along `dirs` (need not be
    /// normalised; zero or non-finite directions are ignored). With no usable
    /// direction, or directions not all within an open half-space around
    /// their mean, the pyramid has no side planes (it bounds everything in
    /// front of, or around, the apex).
    pub fn from_rays(apex: Vec3, dirs: &[Vec3]) -> Pyramid {
        let dirs: Vec<Vec3> = dirs
            .iter()
            .filter(|d| d.is_finite() && d.length_squared() > 0.0)
            .map(|d| d.normalize())
            .collect();
        let sum: Vec3 = dirs.iter().copied().sum();
        let axis = if sum.length_squared() > 0.0 {
            sum.normalize()
        } else {
            Vec3::Z
        };
        let mut p = Pyramid {
            apex,
            axis,
            dirs,
            planes: Vec::new(),
            near: 0.0,
            far: f64::INFINITY,
        };
        p.rebuild();
        p
    }

    /// Limits the bundle rays to `t >= near` (distance from the apex).
    pub fn with_near(mut self, near: f64) -> Pyramid {
        self.near = near.max(0.0);
        self.rebuild();
        self
    }

    /// Limits the bundle rays to `t <= far` (distance from the apex).
    pub fn with_far(mut self, far: f64) -> Pyramid {
        self.far = far;
        self.rebuild();
        self
    }

    pub fn apex(&self) -> Vec3 {
        self.apex
    }

    /// Unit mean direction of the bundle.
    pub fn axis(&self) -> Vec3 {
        self.axis
    }

    /// The unit ray directions of the bundle.
    pub fn dirs(&self) -> &[Vec3] {
        &self.dirs
    }

    pub fn near(&self) -> f64 {
        self.near
    }

    pub fn far(&self) -> f64 {
        self.far
    }

    /// The bounding half-spaces; a point is inside if it satisfies all.
    pub fn planes(&self) -> &[Plane] {
        &self.planes
    }

    /// True if `p` satisfies every plane within `tol`.
    pub fn contains(&self, p: Vec3, tol: f64) -> bool {
        self.planes
            .iter()
            .all(|pl| pl.normal.dot(p) - pl.offset <= tol)
    }

    fn rebuild(&mut self) {
        let (apex, a) = (self.apex, self.axis);
        let mut planes = Vec::new();
        let cos_min = self.dirs.iter().map(|d| d.dot(a)).fold(1.0, f64::min);
        let cos_max = self.dirs.iter().map(|d| d.dot(a)).fold(-1.0, f64::max);
        // Side planes only when every direction is clearly in front of the
        // apex along the axis (the gnomonic projection is then bounded).
        if !self.dirs.is_empty() && cos_min > 1e-3 {
            let (t, b) = orthonormal_basis(a);
            let (mut umin, mut umax, mut vmin, mut vmax) = (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            );
            for d in &self.dirs {
                let c = d.dot(a);
                let (u, v) = (d.dot(t) / c, d.dot(b) / c);
                umin = umin.min(u);
                umax = umax.max(u);
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            }
            let pad = |lo: f64, hi: f64| REL_EPS * (1.0 + (hi - lo) + lo.abs().max(hi.abs()));
            let (pu, pv) = (pad(umin, umax), pad(vmin, vmax));
            let (umin, umax, vmin, vmax) = (umin - pu, umax + pu, vmin - pv, vmax + pv);
            // Inside: (p - apex) . (e - k a) <= 0 for each side.
            for n in [t - a * umax, a * umin - t, b - a * vmax, a * vmin - b] {
                let n = n.normalize();
                planes.push(Plane {
                    normal: n,
                    offset: n.dot(apex),
                });
            }
        }
        // Near plane: (p - apex) . a >= near * min cos (only when every
        // direction points forwards along the axis).
        if !self.dirs.is_empty() {
            if cos_min > 0.0 {
                let lim = self.near * cos_min;
                let lim = lim - REL_EPS * (1.0 + lim.abs());
                planes.push(Plane {
                    normal: -a,
                    offset: -(a.dot(apex) + lim),
                });
            }
            if self.far.is_finite() {
                let lim = self.far * cos_max.max(0.0);
                let lim = lim + REL_EPS * (1.0 + lim.abs());
                planes.push(Plane {
                    normal: a,
                    offset: a.dot(apex) + lim,
                });
            }
        }
        self.planes = planes;
    }
}

/// What [`Octree::clip`] selected.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ClipResult {
    /// Leaves meeting the pyramid, front to back from the apex.
    pub leaves: Vec<NodeId>,
    /// Objects listed in those leaves, each once, in first-seen order.
    pub objects: Vec<ObjectId>,
    /// Nodes visited (tested against the planes): the work units charged.
    pub node_visits: u64,
}

impl Octree {
    /// The leaves (and their objects) that the rays bounded by `pyramid` may
    /// pass through, front to back from the apex. Conservative: every leaf a
    /// bundle ray passes through within the pyramid's limits is selected.
    pub fn clip(&self, pyramid: &Pyramid) -> ClipResult {
        let mut out = ClipResult::default();
        let mut seen = rustc_hash::FxHashSet::default();
        let mut leaves = Vec::new();
        out.node_visits = self.clip_leaves(pyramid, |id| leaves.push(id));
        for &id in &leaves {
            if let NodeView::Leaf { objects } = self.node(id) {
                for &o in objects {
                    if seen.insert(o) {
                        out.objects.push(o);
                    }
                }
            }
        }
        out.leaves = leaves;
        out
    }

    /// The leaf-only form of [`Octree::clip`]: calls `leaf` for every leaf
    /// meeting the pyramid, front to back, and returns the number of nodes
    /// visited. Allocates nothing but the traversal stack.
    pub fn clip_leaves<F: FnMut(NodeId)>(&self, pyramid: &Pyramid, leaf: F) -> u64 {
        self.clip_leaves_where(pyramid, |_| true, leaf)
    }

    /// [`Octree::clip_leaves`] restricted to the subtrees for which `wanted`
    /// is true (checked before a node is tested against the pyramid): a
    /// caller that already has some subtrees skips them.
    pub fn clip_leaves_where<W, F>(&self, pyramid: &Pyramid, mut wanted: W, mut leaf: F) -> u64
    where
        W: FnMut(NodeId) -> bool,
        F: FnMut(NodeId),
    {
        let mut visits = 0u64;
        let Some(root) = self.root() else {
            return 0;
        };
        let rb = self.root_bounds();
        let scale = rb.extent().max_element() + pyramid.apex.abs().max_element();
        let tol = 1e-9 * scale;
        let margin = self.margin();
        // Each node's cell comes with it, made from its parent's as the
        // build made it (the same bits as `node_bounds`).
        let mut stack = Vec::with_capacity(64);
        stack.push((root, self.cell(root)));
        while let Some((id, cell)) = stack.pop() {
            if !wanted(id) {
                continue;
            }
            visits += 1;
            let b = cell.bounds();
            debug_assert_eq!(b, self.node_bounds(id), "node {id}");
            let b = Aabb::new(b.min - margin, b.max + margin);
            if pyramid.planes.iter().any(|pl| pl.excludes(&b, tol)) {
                continue;
            }
            match self.node(id) {
                NodeView::Leaf { .. } => leaf(id),
                NodeView::Internal { children } => {
                    let c = b.center();
                    let a = pyramid.apex;
                    let mask = (a.x >= c.x) as usize
                        | ((a.y >= c.y) as usize) << 1
                        | ((a.z >= c.z) as usize) << 2;
                    // Push far children first so the nearest pops first.
                    for j in (0..8).rev() {
                        stack.push((children[j ^ mask], cell.child(j ^ mask)));
                    }
                }
            }
        }
        visits
    }
}

/// Free-function form of [`Octree::clip`].
pub fn clip(octree: &Octree, pyramid: &Pyramid) -> ClipResult {
    octree.clip(pyramid)
}
