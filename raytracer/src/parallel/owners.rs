//! A processor number per octree node, for every node of the whole tree on
//! every processor (the partition's owner of each node, the one owner of
//! each subtree): 2 bytes a node where every number fits, as it does for
//! up to 65,534 processors, else 4. On a 1.5-million-triangle city's
//! 1,957,753 nodes each table took 7.8 MB on every rank.

/// See the module documentation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NodeOwners {
    /// Numbers below `u16::MAX - 1`; `u16::MAX - 1` and `u16::MAX` stand
    /// for `u32::MAX - 1` and `u32::MAX` (the tables' markers).
    Narrow(Box<[u16]>),
    /// Any numbers.
    Wide(Box<[u32]>),
}

impl Default for NodeOwners {
    fn default() -> Self {
        NodeOwners::Narrow(Box::default())
    }
}

/// The two largest `u32`s, kept as the two largest `u16`s.
const MARKS: u32 = 2;

impl NodeOwners {
    /// The table of `v`, narrow where every entry is below
    /// `u16::MAX - 1` or is one of the two largest `u32`s.
    pub fn new(v: Vec<u32>) -> Self {
        let narrow = |o: u32| match o {
            o if o >= u32::MAX - (MARKS - 1) => Some(u16::MAX - (u32::MAX - o) as u16),
            o if o < u32::from(u16::MAX) - (MARKS - 1) => Some(o as u16),
            _ => None,
        };
        match v.iter().map(|&o| narrow(o)).collect::<Option<Box<[u16]>>>() {
            Some(n) => NodeOwners::Narrow(n),
            None => NodeOwners::Wide(v.into_boxed_slice()),
        }
    }

    /// Entry `i`.
    #[inline]
    pub fn get(&self, i: usize) -> u32 {
        match self {
            NodeOwners::Narrow(n) => {
                let o = n[i];
                if o >= u16::MAX - (MARKS as u16 - 1) {
                    u32::MAX - u32::from(u16::MAX - o)
                } else {
                    u32::from(o)
                }
            }
            NodeOwners::Wide(w) => w[i],
        }
    }

    /// The first entry (the root's), if any.
    pub fn first(&self) -> Option<u32> {
        (!self.is_empty()).then(|| self.get(0))
    }

    /// Entries.
    pub fn len(&self) -> usize {
        match self {
            NodeOwners::Narrow(n) => n.len(),
            NodeOwners::Wide(w) => w.len(),
        }
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes the table occupies.
    pub fn memory_bytes(&self) -> usize {
        match self {
            NodeOwners::Narrow(n) => size_of_val(&**n),
            NodeOwners::Wide(w) => size_of_val(&**w),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::NodeOwners;

    #[test]
    fn narrow_where_every_number_fits_and_the_same_numbers_read_back() {
        let cases: [Vec<u32>; 5] = [
            vec![0, 1, 65532, u32::MAX, u32::MAX - 1, 7],
            vec![65533, 0],
            vec![65534, 0],
            vec![3, 70_000, u32::MAX],
            vec![],
        ];
        for v in cases {
            let t = NodeOwners::new(v.clone());
            let narrow = v.iter().all(|o| !(65534..u32::MAX - 1).contains(o));
            assert_eq!(matches!(t, NodeOwners::Narrow(_)), narrow, "{v:?}");
            assert_eq!((0..t.len()).map(|i| t.get(i)).collect::<Vec<_>>(), v);
            assert_eq!(t.memory_bytes(), v.len() * if narrow { 2 } else { 4 });
        }
    }
}
