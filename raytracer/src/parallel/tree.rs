//! Results of the parallel renderer and their assembly into pixels.
//!
//! A pixel's value is a tree: its primary ray's hit has a locally computed
//! part (emission, ambient) plus, in request order, each secondary ray's
//! value times its coefficient and each shadow bundle's result, all
//! attenuated by the medium the ray crossed (see `render::material`). In
//! the parallel renderer the nodes of that tree are computed on different
//! processors in any order, and floating-point addition is not associative,
//! so results are not summed as they arrive. Each node's record travels to
//! the processor that owns the pixel, keyed by its path in the tree; a node
//! is evaluated, with exactly the sequential renderer's operations in
//! exactly its order, as soon as its record and all its children's values
//! are present, and the value moves up to its parent. A shadow bundle run in
//! the step that shaded its point has its value carried in the point's
//! record ([`Child::Known`]) instead of a result of its own. The pixel is final
//! when its root is. Only the trees of pixels still in flight are held, so
//! memory does not grow with the image beyond the finished pixel values.

use hybrid_sched::serde::{Deserialize, Serialize};

use super::picture::Picture;
pub use super::records::{
    Attenuation, Child, HemisphereSeed, NodeKey, Record, RtResult, SuperState, Traced, Wanted,
    WaveBatch,
};
use crate::render::ambient::{AmbientCounts, AmbientRecord};
use crate::scene::Color;

/// A node waiting for its record or for some of its children.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
struct Pending {
    record: Option<(Color, Vec<Child>, Option<Attenuation>)>,
    /// Children whose values arrive as results (known once the record is).
    awaited: usize,
    /// Child values by request index (may arrive before the record).
    values: Vec<(u16, Color)>,
    /// A hemisphere that may take super-samples.
    #[serde(default)]
    super_state: Option<Box<SuperState>>,
}

/// The per-processor accumulator: finished pixels and the trees in flight.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct PixelTrees {
    /// Finished pixels: (row-major index, radiance), those not yet sent to
    /// the master.
    pub pixels: Vec<(u32, Color)>,
    /// Pixels finished here and sent to the master.
    #[serde(default)]
    pub shipped: usize,
    /// The master's: the pixels processors sent, in place.
    #[serde(default)]
    pub picture: Option<Picture>,
    /// Nodes in flight, per pixel (a pixel's tree is small: linear search).
    pending: hybrid_sched::IdMap<u32, Vec<(Vec<u16>, Pending)>>,
    /// Number of nodes in `pending`.
    nodes: usize,
    /// Most nodes held at once (memory high-water of the assembly).
    pub peak_pending: usize,
    /// Records merged.
    pub records: u64,
    /// Super-sampling hemispheres whose samples so far are all in, for the
    /// workload ([`Wanted`]); empty between merges.
    #[serde(default)]
    pub wanted: Vec<Wanted>,
    /// With an irradiance cache, per pixel in flight: where its owner is in
    /// the sequential renderer's order (`cursor.rs`).
    #[serde(skip)]
    pub(super) cursors: hybrid_sched::IdMap<u32, Box<super::walk::PixelCursor>>,
    /// With an irradiance cache, what it did at this processor.
    #[serde(default)]
    pub ambient: AmbientCounts,
    /// With an irradiance cache, the master's: the pixels of the wave
    /// running, with their records.
    #[serde(default)]
    pub wave: std::collections::BTreeMap<u32, (Color, Vec<AmbientRecord>)>,
    /// Wave pixels the master received twice (none, unless a task ran
    /// twice).
    #[serde(default)]
    pub wave_duplicates: u64,
}

impl PixelTrees {
    /// Nodes still waiting: zero after a complete run (anything else means a
    /// result was lost).
    pub fn pending(&self) -> usize {
        self.nodes
    }

    /// Pixels finished here, sent to the master or not.
    pub fn finished(&self) -> usize {
        self.shipped + self.pixels.len()
    }

    /// The finished pixels held, as a result for the master.
    pub fn ship_pixels(&mut self) -> RtResult {
        let pixels = std::mem::take(&mut self.pixels);
        self.shipped += pixels.len();
        RtResult {
            key: NodeKey::default(),
            record: Record::Pixels(pixels),
        }
    }

    /// The master's merge of a batch: `pixels` placed in its [`Picture`]
    /// of `total` pixels (made at the first batch).
    pub fn place_batch(&mut self, total: usize, pixels: Vec<(u32, Color)>) {
        let picture = self.picture.get_or_insert_with(|| Picture::new(total));
        for (i, c) in pixels {
            picture.place(i, c);
        }
    }

    /// The entry of node (`pixel`, `path`), created if absent.
    fn entry(&mut self, pixel: u32, path: &[u16]) -> &mut Pending {
        let list = self.pending.entry(pixel).or_default();
        let i = match list.iter().position(|(p, _)| same_path(p, path)) {
            Some(i) => i,
            None => {
                list.push((path.to_vec(), Pending::default()));
                self.nodes += 1;
                self.peak_pending = self.peak_pending.max(self.nodes);
                list.len() - 1
            }
        };
        &mut list[i].1
    }

    fn get(&self, pixel: u32, path: &[u16]) -> Option<&Pending> {
        let list = self.pending.get(&pixel)?;
        list.iter()
            .find(|(p, _)| same_path(p, path))
            .map(|(_, e)| e)
    }

    fn remove(&mut self, pixel: u32, path: &[u16]) -> Option<Pending> {
        let list = self.pending.get_mut(&pixel)?;
        let i = list.iter().position(|(p, _)| same_path(p, path))?;
        let (_, e) = list.swap_remove(i);
        if list.is_empty() {
            self.pending.remove(&pixel);
        }
        self.nodes -= 1;
        Some(e)
    }

    /// Adds one result.
    pub fn merge(&mut self, r: RtResult) {
        self.records += 1;
        match r.record {
            Record::Value(c) => self.deliver(r.key, c),
            Record::Leaf(c, t) => {
                let cursor = self.cursors.entry(r.key.pixel).or_default();
                cursor.arrive_leaf(r.key.path.clone(), t);
                self.deliver(r.key, c);
            }
            Record::Shaded {
                base,
                children,
                attenuation,
            } => self.shaded(r.key, base, children, attenuation),
            // A node whose children are its strata.
            Record::Hemisphere { strata } => self.shaded(
                r.key,
                Color::ZERO,
                vec![Child::Stratum; usize::from(strata)],
                None,
            ),
            Record::SuperHemisphere { strata, seed } => {
                let state = SuperState {
                    seed: *seed,
                    second: None,
                };
                self.await_samples(&r.key, state, &[], usize::from(strata));
            }
            // The workload's master places batches (`place_batch`); held
            // here, they are assembled with the processors' own.
            Record::Pixels(pixels) => self.pixels.extend(pixels),
            Record::Traced(t) => {
                let t = *t;
                self.cursors
                    .entry(r.key.pixel)
                    .or_default()
                    .arrive(r.key.path.clone(), &t);
                self.shaded(r.key, t.base, t.children, t.attenuation);
            }
            Record::Leaks(answers) => self.cursors.entry(r.key.pixel).or_default().answer(answers),
            Record::WavePixels(b) => {
                self.ambient.add(&b.counts);
                for (i, c, records) in b.pixels {
                    if self.wave.insert(i, (c, records)).is_some() {
                        self.wave_duplicates += 1;
                    }
                }
            }
        }
    }

    /// Makes node `key` a super-sampling hemisphere in `state` awaiting
    /// `more` samples after those whose values are `known` (children
    /// `0..known.len()`); once they are in, it is [`Wanted`].
    pub(super) fn await_samples(
        &mut self,
        key: &NodeKey,
        state: SuperState,
        known: &[Color],
        more: usize,
    ) {
        let n = known.len() + more;
        let entry = self.entry(key.pixel, &key.path);
        debug_assert!(entry.record.is_none(), "node {key:?} shaded twice");
        entry.record = Some((Color::ZERO, vec![Child::Stratum; n], None));
        entry.awaited = n;
        let first = known.iter().enumerate().map(|(i, &v)| (i as u16, v));
        entry.values.extend(first);
        entry.super_state = Some(Box::new(state));
        let _ = self.complete(key.pixel, &key.path);
    }

    /// Node `key`, a super-sampling hemisphere whose first samples' values
    /// are `first`, awaits the `second` super-samples made (children
    /// `first.len()..`), whose strata `state` holds.
    pub fn await_second(&mut self, key: &NodeKey, state: SuperState, first: &[Color]) {
        let more = state.second.as_ref().map_or(0, Vec::len);
        self.await_samples(key, state, first, more);
    }

    /// Adds node `key`'s record: its local part and its children.
    fn shaded(
        &mut self,
        key: NodeKey,
        base: Color,
        children: Vec<Child>,
        attenuation: Option<Attenuation>,
    ) {
        let awaited = children.iter().filter(|c| c.awaited()).count();
        if awaited == 0 {
            // Nothing to wait for: no entry at all.
            let v = evaluate(base, &children, &[], attenuation);
            self.deliver(key, v);
            return;
        }
        let entry = self.entry(key.pixel, &key.path);
        debug_assert!(entry.record.is_none(), "node {key:?} shaded twice");
        entry.record = Some((base, children, attenuation));
        entry.awaited = awaited;
        if let Some(v) = self.complete(key.pixel, &key.path) {
            self.deliver(key, v);
        }
    }

    /// Hands the value of node `key` to its parent (or finishes the pixel).
    pub fn deliver(&mut self, key: NodeKey, value: Color) {
        let pixel = key.pixel;
        let mut path = key.path;
        let mut value = value;
        while let Some(last) = path.pop() {
            self.entry(pixel, &path).values.push((last, value));
            match self.complete(pixel, &path) {
                Some(v) => value = v,
                None => return,
            }
        }
        self.pixels.push((pixel, value));
    }

    /// If node (`pixel`, `path`) has its record and every child value,
    /// removes it and returns its value.
    fn complete(&mut self, pixel: u32, path: &[u16]) -> Option<Color> {
        let entry = self.get(pixel, path)?;
        entry.record.as_ref()?;
        if entry.values.len() < entry.awaited {
            return None;
        }
        let mut entry = self.remove(pixel, path)?;
        if let Some(state) = entry.super_state.take() {
            // The workload makes its super-samples, or its value.
            let mut values = vec![Color::ZERO; entry.awaited];
            for (i, v) in entry.values {
                if let Some(slot) = values.get_mut(usize::from(i)) {
                    *slot = v;
                }
            }
            self.wanted.push(Wanted {
                key: NodeKey {
                    pixel,
                    path: path.to_vec(),
                },
                state: *state,
                values,
            });
            return None;
        }
        let (base, children, attenuation) = entry.record.take()?;
        Some(evaluate(base, &children, &entry.values, attenuation))
    }
}

/// A node's value from its parts, with the sequential renderer's operations
/// in its order (`Renderer::radiance`).
///
/// `arrived` holds the values of the awaited children by request index, in
/// any order; the others carry theirs.
pub(super) fn evaluate(
    base: Color,
    children: &[Child],
    arrived: &[(u16, Color)],
    attenuation: Option<Attenuation>,
) -> Color {
    let mut values: Vec<Color> = children
        .iter()
        .map(|c| match c {
            Child::Known(v) | Child::KnownScatter(v) => *v,
            _ => Color::ZERO,
        })
        .collect();
    for &(i, v) in arrived {
        if let Some(slot) = values.get_mut(i as usize) {
            *slot = v;
        }
    }
    if matches!(children.first(), Some(Child::Stratum)) {
        return crate::render::ambient::strata_mean_of_first_pass(&values);
    }
    if let Some(&Child::Mean(n)) = children.first() {
        let mut sum = Color::ZERO;
        for &v in &values[1..] {
            sum += v;
        }
        return sum / f64::from(n);
    }
    let mut sum = base;
    for (child, &v) in children.iter().zip(&values) {
        match child {
            Child::Ambient(coef) => sum += *coef * v,
            Child::AmbientKnown(term) => sum += *term,
            Child::AmbientTerm => sum += v,
            _ => {}
        }
    }
    for (child, &v) in children.iter().zip(&values) {
        match child {
            Child::Trace(coef) => sum += *coef * v,
            Child::Shadow | Child::Known(_) => sum += v,
            Child::Scatter
            | Child::KnownScatter(_)
            | Child::Ambient(_)
            | Child::AmbientKnown(_)
            | Child::AmbientTerm
            | Child::Stratum
            | Child::Mean(_) => {}
        }
    }
    if let Some((factor, add)) = attenuation {
        sum *= factor;
        sum += add;
    }
    for (child, &v) in children.iter().zip(&values) {
        if let Child::Scatter | Child::KnownScatter(_) = child {
            sum += v;
        }
    }
    sum
}

/// `a == b` for the short paths of ray-tree nodes, element by element
/// (a slice comparison calls `memcmp`, which cost more than the
/// comparison itself for two or three elements).
#[inline]
fn same_path(a: &[u16], b: &[u16]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y)
}

#[cfg(test)]
#[path = "tree_tests.rs"]
mod tests;
