//! The scene's non-empty leaves with their accounted bytes: what every
//! processor knows of each cell, held once per process. The framework asks
//! it where a cell lives ([`hybrid_sched::Workload::locate`]: the owner
//! from the partition, the bytes from here) instead of every processor
//! keeping a directory of its own. Two arrays, 12 bytes a leaf: a list of
//! (leaf, object count, bytes) and the framework's directory beside it
//! took 32.

use crate::accel::NodeId;

/// See the module documentation. Ascending by leaf.
#[derive(Debug, Default)]
pub struct CellTable {
    leaves: Vec<NodeId>,
    bytes: Vec<u64>,
}

impl CellTable {
    /// The table of `cells` (leaf, bytes), in any order; a leaf listed
    /// twice keeps its first entry.
    pub fn new(cells: impl IntoIterator<Item = (NodeId, u64)>) -> Self {
        let (mut leaves, mut bytes): (Vec<NodeId>, Vec<u64>) = cells.into_iter().unzip();
        if !leaves.is_sorted_by(|a, b| a < b) {
            let mut pairs: Vec<(NodeId, u64)> = leaves.into_iter().zip(bytes).collect();
            pairs.sort_by_key(|p| p.0);
            pairs.dedup_by_key(|p| p.0);
            (leaves, bytes) = pairs.into_iter().unzip();
        }
        leaves.shrink_to_fit();
        bytes.shrink_to_fit();
        CellTable { leaves, bytes }
    }

    /// How many cells.
    pub fn len(&self) -> usize {
        self.leaves.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.leaves.is_empty()
    }

    /// `leaf`'s accounted bytes, `None` for a leaf that is not a cell.
    #[inline]
    pub fn bytes_of(&self, leaf: NodeId) -> Option<u64> {
        self.leaves.binary_search(&leaf).ok().map(|k| self.bytes[k])
    }

    /// Every cell with its bytes, ascending by leaf.
    pub fn iter(&self) -> impl Iterator<Item = (NodeId, u64)> + '_ {
        self.leaves.iter().copied().zip(self.bytes.iter().copied())
    }

    /// Bytes of all cells.
    pub fn total_bytes(&self) -> u64 {
        self.bytes.iter().sum()
    }

    /// Bytes of the largest cell (0 for none).
    pub fn largest_bytes(&self) -> u64 {
        self.bytes.iter().copied().max().unwrap_or(0)
    }

    /// Bytes the table occupies.
    pub fn memory_bytes(&self) -> usize {
        self.leaves.capacity() * size_of::<NodeId>() + self.bytes.capacity() * size_of::<u64>()
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
        assert_eq!((t.len(), t.total_bytes(), t.largest_bytes()), (3, 170, 90));
        let sorted = CellTable::new([(1, 10), (2, 20)]);
        assert_eq!(sorted.bytes_of(2), Some(20));
        assert!(CellTable::new([]).is_empty());
        assert_eq!(CellTable::default().largest_bytes(), 0);
    }
}
