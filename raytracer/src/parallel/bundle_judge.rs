//! The judgement of a shadow bundle's rays on a processor, shared among
//! them.
//!
//! A processor answers a fresh any-hit query from its own hierarchy, and
//! where that finds no blocker, it judges the octree's leaves along the
//! segment ([`crate::accel::Octree::leaves_along_all`]): if every one is
//! held here, "unblocked" is the octree's answer; if not, the segment is
//! walked leaf by leaf from the start ([`super::caster::PartialCaster`]),
//! the judgement's work lost. A shadow bundle's rays leave one point
//! towards one light, so they cross much the same leaves: the judgement
//! of the first rays tells what the others' would say. [`BundleJudge`]
//! keeps what a bundle's rays have found:
//!
//! * once one ray's judgement fails, the bundle's further rays are walked
//!   without one (they would mostly fail too: on four processors with 10%
//!   caches, 81% of all judgements failed, and about 96% of the failures
//!   came after an earlier failure in their bundle; the book's benchmarks
//!   chapter has the counts);
//! * once one ray's judgement passes, the bundle's region (the box of the
//!   point and the light, [`RayCaster::begin_bundle`]) is judged whole,
//!   and where every non-empty leaf it meets is held, every segment inside
//!   it is vouched for by one box test
//!   ([`crate::accel::Octree::leaves_in_box_all`]).
//!
//! Either way each ray's answer is the one its own judgement would have
//! led to: the walk answers as the octree does wherever it completes, and
//! a held region holds every leaf a segment inside it enters. Only the
//! work changes.
//!
//! [`RayCaster::begin_bundle`]: crate::render::RayCaster::begin_bundle

use std::cell::Cell;

use crate::accel::{Judged, NodeId, NodeTest, Octree};
use crate::geometry::{Aabb, Ray, Vec3};

/// Internal nodes a region's judgement may open; past them the region is
/// taken as mixed (a region spanning much of the scene costs more to
/// judge than the rays' own judgements).
const REGION_BUDGET: u32 = 64;

/// See the module documentation.
#[derive(Debug, Default)]
pub(super) struct BundleJudge(Cell<State>);

#[derive(Clone, Copy, Debug, Default)]
enum State {
    /// No bundle, or one whose region is unknown (a distant light's):
    /// each ray judged on its own until one fails.
    #[default]
    Loose,
    /// A bundle in this region (lower and upper corners) whose rays have
    /// not been judged yet.
    Fresh(Vec3, Vec3),
    /// A ray's judgement passed: the region is worth judging whole.
    Passed(Vec3, Vec3),
    /// Every non-empty leaf meeting the region is held here.
    Held(Vec3, Vec3),
    /// Some leaf meeting it is not: rays judged one by one.
    Mixed,
    /// A ray's judgement failed: the bundle's further rays are walked.
    Walking,
}

impl BundleJudge {
    /// A new bundle's rays follow, inside `region` where it is known.
    pub(super) fn begin(&self, region: Option<&Aabb>) {
        self.0.set(match region {
            Some(r) => State::Fresh(r.min, r.max),
            None => State::Loose,
        });
    }

    /// Whether the bundle's rays go to the walk unjudged.
    #[inline]
    pub(super) fn walks(&self) -> bool {
        matches!(self.0.get(), State::Walking)
    }

    /// Takes note of a ray's any-hit answer from the hierarchy: undecided
    /// (its judgement failed), or decided unblocked (it passed; a blocked
    /// one is decided without a judgement).
    #[inline]
    pub(super) fn judged(&self, answer: Judged<bool>) {
        match (answer, self.0.get()) {
            (Judged::Partly(_), _) => self.0.set(State::Walking),
            (Judged::Decided(false), State::Fresh(lo, hi)) => self.0.set(State::Passed(lo, hi)),
            _ => {}
        }
    }

    /// The judgement's test of subtrees for a segment: `skip(node)`, and
    /// at the root (the judgement asks it first) also whether the segment
    /// lies inside a held region, the region judged here the first time a
    /// segment inside it asks after a ray's judgement has passed.
    #[inline]
    pub(super) fn vouches<S: NodeTest + ?Sized, K: NodeTest + ?Sized>(
        &self,
        octree: &Octree,
        node: NodeId,
        segment: (&Ray, f64, f64),
        skip: &S,
        held: &K,
    ) -> bool {
        if node != 0 {
            return skip(node);
        }
        let state = self.0.get();
        let (lo, hi) = match state {
            State::Passed(lo, hi) | State::Held(lo, hi) => (lo, hi),
            _ => return skip(node),
        };
        let (ray, tmin, tmax) = segment;
        let (a, b) = (ray.at(tmin), ray.at(tmax));
        // Comparisons with NaN (an infinite segment) are false: outside.
        if !(a.min(b).cmpge(lo).all() && a.max(b).cmple(hi).all()) {
            return skip(node);
        }
        if let State::Passed(..) = state {
            let slack = Vec3::splat(octree.box_slack(lo, hi));
            let mut budget = REGION_BUDGET;
            if !octree.leaves_in_box_all(lo - slack, hi + slack, skip, held, &mut budget) {
                self.0.set(State::Mixed);
                return skip(node);
            }
            self.0.set(State::Held(lo, hi));
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::OctreeParams;
    use crate::geometry::Shape;
    use crate::scene::Object;

    fn octree() -> Octree {
        let objects: Vec<Object> = (0..40)
            .map(|i| {
                let c = Vec3::new((i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64);
                Object {
                    name: String::new(),
                    shape: Shape::sphere(c, 0.3, false).unwrap(),
                    material: 0,
                }
            })
            .collect();
        Octree::build(
            &objects,
            &OctreeParams {
                max_objects: 2,
                ..OctreeParams::default()
            },
        )
    }

    #[test]
    fn a_failed_judgement_sends_the_rest_of_the_bundle_to_the_walk() {
        let j = BundleJudge::default();
        let region = Aabb::new(Vec3::ZERO, Vec3::ONE);
        j.begin(Some(&region));
        // Blocked here: decided without a judgement, nothing learnt.
        j.judged(Judged::Decided(true));
        assert!(matches!(j.0.get(), State::Fresh(..)));
        j.judged(Judged::Decided(false));
        assert!(matches!(j.0.get(), State::Passed(..)));
        assert!(!j.walks());
        j.judged(Judged::Partly(false));
        assert!(j.walks());
        // The next bundle starts afresh, with or without a region.
        j.begin(None);
        assert!(!j.walks());
        j.judged(Judged::Decided(false));
        assert!(matches!(j.0.get(), State::Loose));
        j.judged(Judged::Partly(false));
        assert!(j.walks());
    }

    #[test]
    fn a_region_is_judged_once_after_a_judgement_passed_and_vouches_for_segments_inside() {
        let tree = octree();
        let region = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.5));
        let inside = Ray::new(
            Vec3::new(0.1, 0.1, 0.1),
            Vec3::new(1.0, 1.0, 0.0).normalize(),
        );
        let outside = Ray::new(Vec3::new(0.1, 0.1, 0.1), Vec3::new(0.0, 0.0, 1.0));
        let (nothing, everything) = (|_| false, |_| true);
        let asked = Cell::new(0);
        let held = |_| {
            asked.set(asked.get() + 1);
            true
        };
        let j = BundleJudge::default();
        j.begin(Some(&region));
        // Fresh: no judgement of the region yet.
        assert!(!j.vouches(&tree, 0, (&inside, 0.0, 1.0), &nothing, &held));
        assert_eq!(asked.get(), 0);
        j.judged(Judged::Decided(false));
        assert!(j.vouches(&tree, 0, (&inside, 0.0, 1.0), &nothing, &held));
        let leaves = asked.get();
        assert!(leaves > 0);
        // Held: segments inside are vouched for without asking again;
        // those leaving the region, and other nodes, as `skip` says.
        assert!(j.vouches(&tree, 0, (&inside, 0.0, 0.5), &nothing, &held));
        assert!(!j.vouches(&tree, 0, (&outside, 0.0, 2.0), &nothing, &held));
        assert!(!j.vouches(&tree, 0, (&inside, 0.0, f64::INFINITY), &nothing, &held));
        assert!(!j.vouches(&tree, 3, (&inside, 0.0, 1.0), &nothing, &held));
        assert!(j.vouches(&tree, 3, (&inside, 0.0, 1.0), &everything, &held));
        assert_eq!(asked.get(), leaves);
        // A leaf held elsewhere makes the region mixed: judged per ray.
        j.begin(Some(&region));
        j.judged(Judged::Decided(false));
        assert!(!j.vouches(&tree, 0, (&inside, 0.0, 1.0), &nothing, &nothing));
        assert!(matches!(j.0.get(), State::Mixed));
    }
}
