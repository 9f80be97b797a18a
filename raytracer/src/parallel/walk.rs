//! Where a pixel's owner is in the sequential renderer's order of
//! decisions with an irradiance cache: the state of its walk over the
//! pixel's ray tree (the walk itself is `cursor.rs`).

use rustc_hash::FxHashMap;

use super::records::{Child, HemisphereSeed, Traced};
use crate::render::ambient::{AmbientStore, Hemisphere};
use crate::scene::Color;

/// What the walk needs of a ray's node.
#[derive(Clone, Debug)]
pub(super) struct NodeInfo {
    pub(super) t: f64,
    pub(super) passes_on: bool,
    /// The `-aw` term's child and the point's constant term.
    pub(super) aw: Option<(usize, Color)>,
    /// Each ambient request's child and seed.
    pub(super) requests: Vec<(usize, HemisphereSeed)>,
    /// The traced children, in order.
    pub(super) traces: Vec<usize>,
}

impl NodeInfo {
    fn of(t: &Traced) -> Self {
        let child = |want: fn(&Child) -> bool| t.children.iter().position(want);
        let aw =
            t.aw.and_then(|c| Some((child(|c| matches!(c, Child::AmbientTerm))?, c)));
        let first = child(|c| matches!(c, Child::Ambient(_))).unwrap_or(t.children.len());
        NodeInfo {
            t: t.t,
            passes_on: t.passes_on,
            aw,
            requests: t
                .requests
                .iter()
                .enumerate()
                .map(|(j, s)| (first + j, s.clone()))
                .collect(),
            traces: (t.children.iter().enumerate())
                .filter(|(_, c)| matches!(c, Child::Trace(_)))
                .map(|(i, _)| i)
                .collect(),
        }
    }
}

/// One level of the walk.
#[derive(Clone, Debug)]
pub(super) enum Frame {
    /// A ray's node: its record (once arrived), the requests decided and
    /// children entered so far, and its first child's distance.
    Node {
        path: Vec<u16>,
        info: Option<NodeInfo>,
        aw_done: bool,
        next_request: usize,
        next_trace: usize,
        first_dist: f64,
    },
    /// A hemisphere being sampled: it (with its first samples added once
    /// they are in), the strata of its samples (first pass, then
    /// super-samples), the samples entered, their distances, and their
    /// values once all are in.
    Hemisphere {
        path: Vec<u16>,
        h: Box<Hemisphere>,
        seed: Box<HemisphereSeed>,
        divs: Vec<usize>,
        first: usize,
        second: bool,
        entered: usize,
        dists: Vec<f64>,
        values: Option<Vec<Color>>,
    },
}

/// A pixel's place in the order of decisions (see the module
/// documentation).
#[derive(Clone, Debug, Default)]
pub struct PixelCursor {
    /// The cache its decisions read: the wave's and the pixel's own
    /// records (`None` until the walk starts).
    pub(super) store: Option<AmbientStore>,
    /// Nodes whose records arrived and which the walk has not reached.
    pub(super) arrived: FxHashMap<Vec<u16>, NodeInfo>,
    pub(super) stack: Vec<Frame>,
    /// The answers to the leak tests of the lookup waiting, in order.
    pub(super) leaks: Option<Vec<bool>>,
    /// Whether that lookup's tests were sent.
    pub(super) leak_sent: bool,
}

impl PixelCursor {
    /// Node `path`'s record is in.
    pub(super) fn arrive(&mut self, path: Vec<u16>, t: &Traced) {
        self.arrived.insert(path, NodeInfo::of(t));
    }

    /// Node `path`, which has nothing to decide nor children to enter, is
    /// in; its hit is `t` away.
    pub(super) fn arrive_leaf(&mut self, path: Vec<u16>, t: f64) {
        let info = NodeInfo {
            t,
            passes_on: false,
            aw: None,
            requests: Vec::new(),
            traces: Vec::new(),
        };
        self.arrived.insert(path, info);
    }

    /// The leak tests of the lookup waiting are answered.
    pub(super) fn answer(&mut self, answers: Vec<bool>) {
        self.leaks = Some(answers);
    }

    /// The records the pixel's trace made, in order (leaving none).
    pub(super) fn take_own(&mut self) -> Vec<crate::render::ambient::AmbientRecord> {
        self.store
            .as_mut()
            .map(|s| s.take_own())
            .unwrap_or_default()
    }
}

/// The distance of node `path` if its record is in `arrived` and it has
/// nothing to decide nor children to enter: the walk passes it without
/// entering it.
pub(super) fn pass_leaf(arrived: &mut FxHashMap<Vec<u16>, NodeInfo>, path: &[u16]) -> Option<f64> {
    let i = arrived.get(path)?;
    if i.aw.is_some() || !i.requests.is_empty() || !i.traces.is_empty() || i.passes_on {
        return None;
    }
    let t = i.t;
    arrived.remove(path);
    Some(t)
}

pub(super) fn node_frame(path: Vec<u16>) -> Frame {
    Frame::Node {
        path,
        info: None,
        aw_done: false,
        next_request: 0,
        next_trace: 0,
        first_dist: f64::INFINITY,
    }
}
