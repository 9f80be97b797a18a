//! Two triangles side by side, structure of arrays: the unit of the
//! watertight test's packed arithmetic (the compact data of `prims`), and
//! what a processor's copy of a polygon keeps.

use super::Vec3;

/// Two triangles: `v[vertex][axis][lane]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriPair {
    pub(crate) v: [[[f64; 2]; 3]; 3],
}

impl TriPair {
    /// Vertex `corner` (0 to 2) of triangle `lane` (0 or 1), exactly as
    /// it was given.
    #[inline]
    pub(crate) fn vertex(&self, lane: usize, corner: usize) -> Vec3 {
        let c = &self.v[corner];
        Vec3::new(c[0][lane], c[1][lane], c[2][lane])
    }

    /// The pair of one or two triangles (a lone triangle fills both
    /// lanes), each vertex's coordinates side by side.
    #[inline]
    pub(crate) fn of(two: &[[Vec3; 3]]) -> TriPair {
        let (t0, t1) = (two[0], *two.last().unwrap_or(&two[0]));
        let mut v = [[[0.0; 2]; 3]; 3];
        for (vert, out) in v.iter_mut().enumerate() {
            let (a, b) = (t0[vert].to_array(), t1[vert].to_array());
            for axis in 0..3 {
                out[axis] = [a[axis], b[axis]];
            }
        }
        TriPair { v }
    }
}

/// A polygon's triangle pairs as an object set gives them
/// (`ObjectSet::polygon_pairs`): opaque outside this crate.
#[derive(Debug, Clone, Copy, Default)]
pub struct PolygonPairs<'a>(pub(crate) &'a [TriPair]);
