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
use hybrid_sched::ByteSize;

use crate::scene::Color;

/// Names one node of a pixel's ray tree: the pixel (row-major index) and
/// the request indices leading to it from the primary ray.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct NodeKey {
    pub pixel: u32,
    pub path: Vec<u16>,
}

impl NodeKey {
    /// The primary ray of `pixel`.
    pub fn root(pixel: u32) -> Self {
        NodeKey {
            pixel,
            path: Vec::new(),
        }
    }

    /// The node of request `i` of this node.
    pub fn child(&self, i: usize) -> Self {
        let mut path = Vec::with_capacity(self.path.len() + 1);
        path.extend_from_slice(&self.path);
        path.push(u16::try_from(i).unwrap_or(u16::MAX));
        NodeKey {
            pixel: self.pixel,
            path,
        }
    }

    fn bytes(&self) -> usize {
        std::mem::size_of::<Self>() + 2 * self.path.len()
    }
}

/// How a request's value enters its parent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Child {
    /// A traced ray: `coef` times its radiance.
    Trace(Color),
    /// A shadow bundle: its (already weighted) result.
    Shadow,
    /// An in-scattering shadow bundle: its result, added after the
    /// attenuation (these come last).
    Scatter,
    /// A shadow bundle run in the step that shaded its point: its result,
    /// carried in the record (no result of its own travels).
    Known(Color),
    /// An in-scattering bundle run there: as [`Child::Scatter`], carried.
    KnownScatter(Color),
    /// A hemisphere sampled for diffuse inter-reflection (without an
    /// irradiance cache): `coef` times its value, added before the other
    /// requests' (the sequential renderer's order).
    Ambient(Color),
    /// A sample ray of a hemisphere node ([`Record::Hemisphere`]): its
    /// value enters the mean of its stratum.
    Stratum,
    /// Where no hemisphere is sampled (its rays would exceed `-lr` or fall
    /// below `-lw`): the term, `coef` times the value taken instead
    /// (`-av`), carried (one colour, as every other child: a record's
    /// bytes are priced by its children).
    AmbientKnown(Color),
}

// A record's bytes are priced by its children (the simulated runs').
#[cfg(target_pointer_width = "64")]
const _: () = assert!(std::mem::size_of::<Child>() == 32);

impl Child {
    /// Whether its value arrives as a result of its own.
    pub(super) fn awaited(&self) -> bool {
        !matches!(
            self,
            Child::Known(_) | Child::KnownScatter(_) | Child::AmbientKnown(_)
        )
    }
}

/// A medium's effect on a ray's value: the factor it is multiplied by,
/// then the ambient in-scattering added.
pub type Attenuation = (Color, Color);

/// What one node contributes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub enum Record {
    /// A ray that hit a surface: the local part, the requests in order, and
    /// the medium's attenuation over the ray's length (if any): the factor
    /// and the ambient in-scattering then added.
    Shaded {
        base: Color,
        children: Vec<Child>,
        attenuation: Option<Attenuation>,
    },
    /// A final value: a ray that left the scene, or a shadow bundle's result.
    Value(Color),
    /// A hemisphere of `strata` sample rays, one per stratum (children
    /// `0..strata`), whose value is the mean over the strata
    /// ([`crate::render::ambient::strata_mean_of_first_pass`]).
    Hemisphere { strata: u16 },
}

/// A result message: one node's record, sent to the pixel's owner.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct RtResult {
    pub key: NodeKey,
    pub record: Record,
}

impl ByteSize for RtResult {
    fn byte_size(&self) -> usize {
        let extra = match &self.record {
            Record::Shaded { children, .. } => children.len() * std::mem::size_of::<Child>(),
            Record::Value(_) | Record::Hemisphere { .. } => 0,
        };
        self.key.bytes() + std::mem::size_of::<Record>() + extra
    }
}

/// A node waiting for its record or for some of its children.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
struct Pending {
    record: Option<(Color, Vec<Child>, Option<Attenuation>)>,
    /// Children whose values arrive as results (known once the record is).
    awaited: usize,
    /// Child values by request index (may arrive before the record).
    values: Vec<(u16, Color)>,
}

/// The per-processor accumulator: finished pixels and the trees in flight.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(crate = "hybrid_sched::serde")]
pub struct PixelTrees {
    /// Finished pixels: (row-major index, radiance).
    pub pixels: Vec<(u32, Color)>,
    /// Nodes in flight, per pixel (a pixel's tree is small: linear search).
    pending: hybrid_sched::IdMap<u32, Vec<(Vec<u16>, Pending)>>,
    /// Number of nodes in `pending`.
    nodes: usize,
    /// Most nodes held at once (memory high-water of the assembly).
    pub peak_pending: usize,
    /// Records merged.
    pub records: u64,
}

impl PixelTrees {
    /// Nodes still waiting: zero after a complete run (anything else means a
    /// result was lost).
    pub fn pending(&self) -> usize {
        self.nodes
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
        }
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
    fn deliver(&mut self, key: NodeKey, value: Color) {
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
    let mut sum = base;
    for (child, &v) in children.iter().zip(&values) {
        match child {
            Child::Ambient(coef) => sum += *coef * v,
            Child::AmbientKnown(term) => sum += *term,
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
            | Child::Stratum => {}
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
mod tests {
    use super::*;

    fn c(v: f64) -> Color {
        Color::splat(v)
    }

    #[test]
    fn out_of_order_results_give_the_in_order_value() {
        // root: base 0.1, children [Trace(0.5), Shadow]; child 0: base 0.2,
        // children [Shadow]; attenuation at the root.
        let root = RtResult {
            key: NodeKey::root(7),
            record: Record::Shaded {
                base: c(0.1),
                children: vec![Child::Trace(c(0.5)), Child::Shadow],
                attenuation: Some((c(0.9), Color::ZERO)),
            },
        };
        let k0 = NodeKey::root(7).child(0);
        let child = RtResult {
            key: k0.clone(),
            record: Record::Shaded {
                base: c(0.2),
                children: vec![Child::Shadow],
                attenuation: None,
            },
        };
        let grandchild = RtResult {
            key: k0.child(0),
            record: Record::Value(c(0.3)),
        };
        let shadow = RtResult {
            key: NodeKey::root(7).child(1),
            record: Record::Value(c(0.4)),
        };
        let expected = (c(0.1) + c(0.5) * (c(0.2) + c(0.3)) + c(0.4)) * c(0.9);
        let all = [root, child, grandchild, shadow];
        // Every arrival order.
        let mut orders = vec![vec![0, 1, 2, 3]];
        for _ in 0..23 {
            let mut next = orders.last().unwrap().clone();
            // next permutation
            let mut i = 3;
            while i > 0 && next[i - 1] >= next[i] {
                i -= 1;
            }
            if i == 0 {
                break;
            }
            let mut j = 3;
            while next[j] <= next[i - 1] {
                j -= 1;
            }
            next.swap(i - 1, j);
            next[i..].reverse();
            orders.push(next);
        }
        assert_eq!(orders.len(), 24);
        for order in orders {
            let mut t = PixelTrees::default();
            for &i in &order {
                t.merge(all[i].clone());
            }
            assert_eq!(t.pixels, vec![(7, expected)], "order {order:?}");
            assert_eq!(t.pending(), 0);
        }
    }

    /// A point with a reflection and a shadow bundle, a hemisphere of
    /// three strata (one sample not finite) and a hemisphere not sampled:
    /// the hemispheres' terms come before the requests', as the sequential
    /// renderer adds them, in every order the results arrive in.
    #[test]
    fn hemispheres_are_added_first_whatever_the_order() {
        let root = NodeKey::root(3);
        let hemi = root.child(2);
        let mut all = vec![
            RtResult {
                key: root.clone(),
                record: Record::Shaded {
                    base: c(0.1),
                    children: vec![
                        Child::Trace(c(0.5)),
                        Child::Shadow,
                        Child::Ambient(c(0.7)),
                        Child::AmbientKnown(c(0.3) * c(0.2)),
                    ],
                    attenuation: None,
                },
            },
            RtResult {
                key: hemi.clone(),
                record: Record::Hemisphere { strata: 3 },
            },
            RtResult {
                key: root.child(0),
                record: Record::Value(c(0.25)),
            },
            RtResult {
                key: root.child(1),
                record: Record::Value(c(0.125)),
            },
        ];
        for (k, v) in [(0, c(0.4)), (1, Color::splat(f64::NAN)), (2, c(0.9))] {
            all.push(RtResult {
                key: hemi.child(k),
                record: Record::Value(v),
            });
        }
        let mean = (c(0.4) / 1.0 + Color::ZERO / 1.0 + c(0.9) / 1.0) / 3.0;
        let mut expected = c(0.1);
        expected += c(0.7) * mean;
        expected += c(0.3) * c(0.2);
        expected += c(0.5) * c(0.25);
        expected += c(0.125);
        // Every rotation of the list, forwards and backwards.
        for shift in 0..all.len() {
            let mut order: Vec<&RtResult> =
                all.iter().cycle().skip(shift).take(all.len()).collect();
            for _ in 0..2 {
                let mut t = PixelTrees::default();
                for r in &order {
                    t.merge((*r).clone());
                }
                assert_eq!(t.pixels, vec![(3, expected)], "shift {shift}");
                assert_eq!(t.pending(), 0);
                order.reverse();
            }
        }
    }

    #[test]
    fn a_missing_child_leaves_the_pixel_pending() {
        let mut t = PixelTrees::default();
        t.merge(RtResult {
            key: NodeKey::root(1),
            record: Record::Shaded {
                base: c(0.1),
                children: vec![Child::Shadow, Child::Shadow],
                attenuation: None,
            },
        });
        t.merge(RtResult {
            key: NodeKey::root(1).child(1),
            record: Record::Value(c(0.2)),
        });
        assert!(t.pixels.is_empty());
        assert_eq!(t.pending(), 1);
    }

    /// A bundle run where its point was shaded carries its value in the
    /// record: the pixel equals the one whose every bundle sent a result,
    /// bit for bit, with scattering added after the attenuation either way,
    /// and a record awaiting nothing is never held.
    #[test]
    fn carried_values_give_the_value_of_results_sent() {
        let key = NodeKey::root(3);
        let record = |children| RtResult {
            key: key.clone(),
            record: Record::Shaded {
                base: c(0.1),
                children,
                attenuation: Some((c(0.7), c(0.01))),
            },
        };
        let value = |i: usize, v: f64| RtResult {
            key: key.child(i),
            record: Record::Value(c(v)),
        };
        let mut sent = PixelTrees::default();
        sent.merge(value(2, 0.3));
        sent.merge(record(vec![Child::Shadow, Child::Shadow, Child::Scatter]));
        sent.merge(value(0, 0.123));
        sent.merge(value(1, 0.456));
        let mut mixed = PixelTrees::default();
        mixed.merge(record(vec![
            Child::Known(c(0.123)),
            Child::Shadow,
            Child::KnownScatter(c(0.3)),
        ]));
        assert!(mixed.pixels.is_empty());
        assert_eq!(mixed.pending(), 1);
        mixed.merge(value(1, 0.456));
        let mut carried = PixelTrees::default();
        carried.merge(record(vec![
            Child::Known(c(0.123)),
            Child::Known(c(0.456)),
            Child::KnownScatter(c(0.3)),
        ]));
        assert_eq!(carried.peak_pending, 0, "nothing awaited, nothing held");
        let expected = (c(0.1) + c(0.123) + c(0.456)) * c(0.7) + c(0.01) + c(0.3);
        for t in [&sent, &mixed, &carried] {
            assert_eq!(t.pixels, vec![(3, expected)]);
            assert_eq!(t.pending(), 0);
        }
    }
}
