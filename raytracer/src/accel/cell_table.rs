//! The scene's non-empty leaves with their accounted bytes: what every
//! processor knows of each cell, held once per process. The framework asks
//! it where a cell lives ([`hybrid_sched::Workload::locate`]: the owner
//! from the partition, the bytes from here) instead of every processor
//! keeping a directory of its own, at every data selection of every task.
//!
//! Which leaves are cells is a [`RankedSet`] over the node ids, whose
//! rank of a leaf is its place in the list of bytes: one lookup instead of
//! a binary search of every leaf (which took 5 to 9% of the instructions
//! of four processors rendering a 300,000-triangle city, `valgrind
//! --tool=callgrind`), and 0.19 bytes a node instead of 4 bytes a cell for
//! the ids. The bytes are kept in 4 bytes a cell where every cell's fit (a
//! cell of 4 GiB would hold some 30 million objects), else in 8.

use super::{NodeId, RankedSet};

/// See the module documentation.
#[derive(Debug, Default)]
pub struct CellTable {
    /// The cells' leaves.
    leaves: RankedSet,
    /// Per cell, ascending by leaf: its accounted bytes.
    bytes: Bytes,
}

/// Each cell's bytes, as narrow as they all fit.
#[derive(Debug)]
enum Bytes {
    Narrow(Vec<u32>),
    Wide(Vec<u64>),
}

impl Default for Bytes {
    fn default() -> Self {
        Bytes::Narrow(Vec::new())
    }
}

impl Bytes {
    fn new(bytes: Vec<u64>) -> Self {
        // Reserved exactly: collected from fallible conversions the list
        // grew by doubling (1.8 MB at a rank's peak where 0.7 MB do).
        let mut narrow = Vec::with_capacity(bytes.len());
        for &b in &bytes {
            match u32::try_from(b) {
                Ok(b) => narrow.push(b),
                Err(_) => return Bytes::Wide(bytes),
            }
        }
        Bytes::Narrow(narrow)
    }

    fn len(&self) -> usize {
        match self {
            Bytes::Narrow(v) => v.len(),
            Bytes::Wide(v) => v.len(),
        }
    }

    #[inline]
    fn get(&self, k: usize) -> u64 {
        match self {
            Bytes::Narrow(v) => u64::from(v[k]),
            Bytes::Wide(v) => v[k],
        }
    }

    fn iter(&self) -> impl Iterator<Item = u64> + '_ {
        (0..self.len()).map(|k| self.get(k))
    }

    fn memory_bytes(&self) -> usize {
        match self {
            Bytes::Narrow(v) => v.capacity() * size_of::<u32>(),
            Bytes::Wide(v) => v.capacity() * size_of::<u64>(),
        }
    }
}

impl CellTable {
    /// The table of `cells` (leaf, bytes), in any order; a leaf listed
    /// twice keeps its first entry.
    pub fn new(cells: impl IntoIterator<Item = (NodeId, u64)>) -> Self {
        let mut pairs: Vec<(NodeId, u64)> = cells.into_iter().collect();
        if !pairs.is_sorted_by(|a, b| a.0 < b.0) {
            // Stable: of a leaf listed twice the first stays first.
            pairs.sort_by_key(|p| p.0);
            pairs.dedup_by_key(|p| p.0);
        }
        let leaves = RankedSet::new(pairs.iter().map(|p| p.0));
        let bytes = Bytes::new(pairs.into_iter().map(|p| p.1).collect());
        CellTable { leaves, bytes }
    }

    /// How many cells.
    pub fn len(&self) -> usize {
        self.bytes.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.bytes.len() == 0
    }

    /// `leaf`'s place among the cells (ascending by leaf), `None` for a
    /// leaf that is not a cell.
    #[inline]
    pub fn index_of(&self, leaf: NodeId) -> Option<usize> {
        self.leaves.rank(leaf)
    }

    /// `leaf`'s accounted bytes, `None` for a leaf that is not a cell.
    #[inline]
    pub fn bytes_of(&self, leaf: NodeId) -> Option<u64> {
        self.leaves.rank(leaf).map(|k| self.bytes.get(k))
    }

    /// Every cell with its bytes, ascending by leaf.
    pub fn iter(&self) -> impl Iterator<Item = (NodeId, u64)> + '_ {
        self.leaves.iter().zip(self.bytes.iter())
    }

    /// Bytes of all cells.
    pub fn total_bytes(&self) -> u64 {
        self.bytes.iter().sum()
    }

    /// Bytes of the largest cell (0 for none).
    pub fn largest_bytes(&self) -> u64 {
        self.bytes.iter().max().unwrap_or(0)
    }

    /// Bytes the table occupies.
    pub fn memory_bytes(&self) -> usize {
        self.leaves.memory_bytes() + self.bytes.memory_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::CellTable;

    #[test]
    fn any_order_in_ascending_out_and_looked_up() {
        let t = CellTable::new([(9, 90), (3, 30), (5, 50), (3, 31)]);
        assert_eq!(
            t.iter().collect::<Vec<_>>(),
            vec![(3, 30), (5, 50), (9, 90)]
        );
        assert_eq!(t.bytes_of(5), Some(50));
        assert_eq!(t.bytes_of(4), None);
        assert_eq!(t.bytes_of(10_000), None);
        assert_eq!((t.len(), t.total_bytes(), t.largest_bytes()), (3, 170, 90));
        let sorted = CellTable::new([(1, 10), (2, 20)]);
        assert_eq!(sorted.bytes_of(2), Some(20));
        assert!(CellTable::new([]).is_empty());
        assert_eq!(CellTable::new([]).bytes_of(0), None);
        assert_eq!(CellTable::default().largest_bytes(), 0);
    }

    /// Leaves at the edges of the bitmap's words (0, 63, 64, 127, ...)
    /// and far apart, against a plain map, every id up to past the last.
    #[test]
    fn every_leaf_found_across_word_edges() {
        let leaves: Vec<u32> = [0, 1, 62, 63, 64, 65, 127, 128, 191, 1000, 4095, 4096]
            .into_iter()
            .chain((5000..5200).step_by(3))
            .collect();
        let cells: Vec<(u32, u64)> = leaves
            .iter()
            .rev()
            .map(|&l| (l, 7 * l as u64 + 1))
            .collect();
        let t = CellTable::new(cells.iter().copied());
        let map: std::collections::BTreeMap<u32, u64> = cells.iter().copied().collect();
        for leaf in 0..5300 {
            assert_eq!(t.bytes_of(leaf), map.get(&leaf).copied(), "leaf {leaf}");
        }
        assert_eq!(
            t.iter().collect::<Vec<_>>(),
            map.into_iter().collect::<Vec<_>>()
        );
        assert_eq!(t.len(), leaves.len());
    }

    /// Bytes past 32 bits keep every cell's bytes in 64.
    #[test]
    fn cells_past_four_gib_are_kept_wide() {
        let big = u64::from(u32::MAX) + 5;
        let t = CellTable::new([(7, 3), (70, big), (700, 9)]);
        assert_eq!(t.bytes_of(70), Some(big));
        assert_eq!(t.bytes_of(7), Some(3));
        assert_eq!(t.total_bytes(), big + 12);
        assert_eq!(t.largest_bytes(), big);
        let narrow = CellTable::new([(7, 3), (70, u64::from(u32::MAX)), (700, 9)]);
        assert_eq!(narrow.bytes_of(70), Some(u64::from(u32::MAX)));
        assert!(narrow.memory_bytes() < t.memory_bytes());
    }
}
