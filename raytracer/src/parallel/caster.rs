//! A ray caster over the cells one processor holds, for running shadow
//! bundles (and their transparent-shadow segments) where data may be
//! missing.
//!
//! A shadow bundle's algorithm (adaptive shadow testing) decides which
//! shadow ray to trace next from the answers to the previous ones, so it
//! cannot be split into independent rays. Instead it is made restartable:
//! every answered query is recorded, and when a query needs a cell that is
//! not local the caster records where its traversal stopped and makes every
//! further query return a dummy answer; the bundle's result is then thrown
//! away and the bundle migrates towards the missing cell. On the next
//! processor the bundle is run again from the start with the recorded
//! answers replayed, the interrupted traversal resumed, and so on until it
//! completes. The bundle is deterministic given its answers, so the final
//! run is exactly the sequential one.

use std::cell::{Cell, RefCell};

use hybrid_sched::serde::{Deserialize, Serialize};

use crate::accel::{Hit, Judged, LeafObjects, NodeId, Octree, Partial, TraceCursor};
use crate::geometry::{Aabb, ObjectTable, Ray};
use crate::render::RayCaster;
use crate::scene::ObjectId;

/// One recorded query answer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Answer {
    Occluded(bool),
    Nearest(Option<Hit>),
}

/// Answers recorded so far and the state of the interrupted query.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct Replay {
    pub answers: Vec<Answer>,
    /// Progress of the first unanswered query (if it was interrupted).
    pub cursor: TraceCursor,
}

/// Queries a processor may answer without walking the octree (its own
/// hierarchy, see [`crate::accel::Hierarchy`]): the octree's answer where
/// its objects decide it, else theirs alone, for the walk to finish
/// passing the leaves [`LocalQueries::holds`] vouches for.
pub trait LocalQueries {
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Judged<Option<Hit>>;
    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> Judged<bool>;
    /// Leaves whose every object the hierarchy holds.
    fn holds(&self, leaf: NodeId) -> bool;
    /// See [`RayCaster::begin_bundle`].
    fn begin_bundle(&self, region: Option<&Aabb>);
}

/// See the module documentation. `cell(leaf)` gives a non-empty leaf's
/// objects where they are held here (`None` elsewhere); `shared` are the
/// objects every processor holds (see [`Octree::intersect_partial`]).
pub struct PartialCaster<'a, 'c, F: Fn(NodeId) -> Option<&'c LeafObjects>> {
    octree: &'a Octree,
    shared: ObjectTable<'a>,
    cell: F,
    replay: RefCell<Replay>,
    next: Cell<usize>,
    blocked: Cell<Option<NodeId>>,
    /// Octree leaves visited by new (not replayed) queries.
    pub queries: Cell<u64>,
    /// The processor's own hierarchy, tried first by fresh queries.
    local: Option<&'a dyn LocalQueries>,
    /// Queries it answered.
    pub local_answers: Cell<u64>,
    /// Whether answers are recorded for a replay.
    recording: Recording,
}

/// Whether a [`PartialCaster`] records its answers for a replay.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recording {
    /// Every answer: a blocked bundle's replay is complete.
    On,
    /// None, and no query may block (every leaf is held here).
    Off,
    /// None: a blocked bundle must be run again with [`Recording::On`] for
    /// its replay. For fresh bundles, which seldom block, the recording
    /// (an allocation and a copy of every answer) costs more than the
    /// rare second run.
    Deferred,
}

impl<'a, 'c, F: Fn(NodeId) -> Option<&'c LeafObjects>> PartialCaster<'a, 'c, F> {
    pub fn new(
        octree: &'a Octree,
        shared: ObjectTable<'a>,
        cell: F,
        replay: Replay,
        local: Option<&'a dyn LocalQueries>,
    ) -> Self {
        PartialCaster {
            local,
            local_answers: Cell::new(0),
            octree,
            shared,
            cell,
            replay: RefCell::new(replay),
            next: Cell::new(0),
            blocked: Cell::new(None),
            queries: Cell::new(0),
            recording: Recording::On,
        }
    }

    /// How answers are recorded ([`Recording::On`] unless told):
    /// [`Recording::Off`] only where every leaf is held here (one
    /// processor, or the `worst` distribution's), so no query can block.
    pub fn recording(mut self, recording: Recording) -> Self {
        self.recording = recording;
        self
    }

    /// Whether a blocked bundle's replay ([`Self::into_replay`]) holds
    /// every answer before the block.
    pub fn replayable(&self) -> bool {
        self.recording == Recording::On
    }

    /// The leaf a query was blocked on, if any.
    pub fn blocked(&self) -> Option<NodeId> {
        self.blocked.get()
    }

    /// The recorded state, to travel with the migrating bundle.
    pub fn into_replay(self) -> Replay {
        self.replay.into_inner()
    }

    /// The next query's recorded answer, or `None` if it must be computed
    /// (with the cursor to resume from).
    fn recorded(&self) -> Result<Answer, TraceCursor> {
        let i = self.next.get();
        self.next.set(i + 1);
        let r = self.replay.borrow();
        match r.answers.get(i) {
            Some(a) => Ok(*a),
            None if i == r.answers.len() => Err(r.cursor),
            None => Err(TraceCursor::default()),
        }
    }

    fn record(&self, a: Answer) {
        if self.recording != Recording::On {
            debug_assert!(self.blocked.get().is_none());
            return;
        }
        let mut r = self.replay.borrow_mut();
        r.answers.push(a);
        r.cursor = TraceCursor::default();
    }

    fn block(&self, leaf: NodeId, cursor: TraceCursor) {
        assert!(
            self.recording != Recording::Off,
            "a query blocked on leaf {leaf} where every leaf was said to be held"
        );
        self.blocked.set(Some(leaf));
        self.replay.borrow_mut().cursor = cursor;
    }
}

impl<'c, F: Fn(NodeId) -> Option<&'c LeafObjects>> RayCaster for PartialCaster<'_, 'c, F> {
    fn intersect(&self, ray: &Ray, tmin: f64, tmax: f64) -> Option<Hit> {
        if self.blocked.get().is_some() {
            return None;
        }
        let mut cursor = match self.recorded() {
            Ok(Answer::Nearest(h)) => return h,
            Ok(Answer::Occluded(_)) => {
                debug_assert!(false, "replayed answer of the wrong kind");
                TraceCursor::default()
            }
            Err(c) => c,
        };
        // Where the hierarchy was asked and left it undecided, the walk
        // starts from its nearest hit and tests only the other leaves.
        let mut asked = None;
        if cursor == TraceCursor::default() {
            if let Some(l) = self.local {
                match l.intersect(ray, tmin, tmax) {
                    Judged::Decided(h) => {
                        self.local_answers.set(self.local_answers.get() + 1);
                        self.record(Answer::Nearest(h));
                        return h;
                    }
                    Judged::Partly(h) => cursor.best = h,
                }
                asked = Some(l);
            }
        }
        let tested = |leaf| asked.is_some_and(|l| l.holds(leaf));
        self.queries.set(self.queries.get() + 1);
        match self.octree.intersect_partial_past(
            self.shared,
            ray,
            tmin,
            tmax,
            &mut cursor,
            &self.cell,
            &tested,
        ) {
            Partial::Done(h) => {
                self.record(Answer::Nearest(h));
                h
            }
            Partial::Blocked(leaf) => {
                self.block(leaf, cursor);
                None
            }
        }
    }

    fn occluded(&self, ray: &Ray, tmin: f64, tmax: f64, ignore: Option<ObjectId>) -> bool {
        if self.blocked.get().is_some() {
            return true;
        }
        let mut cursor = match self.recorded() {
            Ok(Answer::Occluded(b)) => return b,
            Ok(Answer::Nearest(_)) => {
                debug_assert!(false, "replayed answer of the wrong kind");
                TraceCursor::default()
            }
            Err(c) => c,
        };
        // Where the hierarchy was asked and left it undecided, its leaves
        // are known not to block: the walk tests only the others.
        let mut asked = None;
        if cursor == TraceCursor::default() {
            if let Some(l) = self.local {
                if let Judged::Decided(b) = l.occluded(ray, tmin, tmax, ignore) {
                    self.local_answers.set(self.local_answers.get() + 1);
                    self.record(Answer::Occluded(b));
                    return b;
                }
                asked = Some(l);
            }
        }
        let tested = |leaf| asked.is_some_and(|l| l.holds(leaf));
        self.queries.set(self.queries.get() + 1);
        match self.octree.occluded_partial_past(
            self.shared,
            ray,
            tmin,
            tmax,
            ignore,
            &mut cursor,
            &self.cell,
            &tested,
        ) {
            Partial::Done(b) => {
                self.record(Answer::Occluded(b));
                b
            }
            Partial::Blocked(leaf) => {
                self.block(leaf, cursor);
                true
            }
        }
    }

    fn begin_bundle(&self, region: Option<&Aabb>) {
        if let Some(l) = self.local {
            l.begin_bundle(region);
        }
    }
}
