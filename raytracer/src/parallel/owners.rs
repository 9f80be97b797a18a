//! A processor number per octree node, for every node of the whole tree on
//! every processor (the partition's owner of each node, the one owner of
//! each subtree): 1 byte a node where every number fits, as it does for up
//! to 254 processors, 2 bytes up to 65,534, else 4. On a
//! 1.5-million-triangle city's 1,957,753 nodes each table took 7.8 MB on
//! every rank at 4 bytes, 3.9 MB at 2.

/// See the module documentation.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NodeOwners {
    /// Numbers below `u8::MAX - 1`; `u8::MAX - 1` and `u8::MAX` stand for
    /// `u32::MAX - 1` and `u32::MAX`.
    Tiny(Box<[u8]>),
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
    /// The table of `v`, in the narrowest type every entry fits (`fit`:
    /// below the type's largest value less one, or one of the two largest
    /// `u32`s).
    pub fn new(v: Vec<u32>) -> Self {
        if let Some(t) = v.iter().map(|&o| fit::<u8>(o)).collect() {
            return NodeOwners::Tiny(t);
        }
        match v.iter().map(|&o| fit::<u16>(o)).collect() {
            Some(n) => NodeOwners::Narrow(n),
            None => NodeOwners::Wide(v.into_boxed_slice()),
        }
    }

    /// Entry `i`.
    #[inline]
    pub fn get(&self, i: usize) -> u32 {
        match self {
            NodeOwners::Tiny(t) => widen(t[i]),
            NodeOwners::Narrow(n) => widen(n[i]),
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
            NodeOwners::Tiny(t) => t.len(),
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
            NodeOwners::Tiny(t) => size_of_val(&**t),
            NodeOwners::Narrow(n) => size_of_val(&**n),
            NodeOwners::Wide(w) => size_of_val(&**w),
        }
    }
}

/// `o` in the narrower type `T`, if it fits: below `T::MAX - 1`, or one
/// of the two largest `u32`s (kept as the two largest `T`s).
fn fit<T: TryFrom<u32> + Into<u32> + Copy + Bounded>(o: u32) -> Option<T> {
    let top: u32 = T::MAX.into();
    if o >= u32::MAX - (MARKS - 1) {
        T::try_from(top - (u32::MAX - o)).ok()
    } else if o < top - (MARKS - 1) {
        T::try_from(o).ok()
    } else {
        None
    }
}

/// The `u32` that `x` (made by [`fit`]) stands for.
#[inline]
fn widen<T: Into<u32> + Bounded>(x: T) -> u32 {
    let (x, top): (u32, u32) = (x.into(), T::MAX.into());
    if x >= top - (MARKS - 1) {
        u32::MAX - (top - x)
    } else {
        x
    }
}

/// The narrow types' largest values.
trait Bounded {
    const MAX: Self;
}

impl Bounded for u8 {
    const MAX: u8 = u8::MAX;
}

impl Bounded for u16 {
    const MAX: u16 = u16::MAX;
}

#[cfg(test)]
mod tests {
    use super::NodeOwners;

    #[test]
    fn narrowest_where_every_number_fits_and_the_same_numbers_read_back() {
        let cases: [(Vec<u32>, usize); 9] = [
            (vec![0, 1, 253, u32::MAX, u32::MAX - 1, 7], 1),
            (vec![254, 0], 2),
            (vec![255, u32::MAX], 2),
            (vec![0, 1, 65532, u32::MAX, u32::MAX - 1, 7], 2),
            (vec![65533, 0], 2),
            (vec![65534, 0], 4),
            (vec![3, 70_000, u32::MAX], 4),
            (vec![u32::MAX - 2], 4),
            (vec![], 1),
        ];
        for (v, width) in cases {
            let t = NodeOwners::new(v.clone());
            let got = match t {
                NodeOwners::Tiny(_) => 1,
                NodeOwners::Narrow(_) => 2,
                NodeOwners::Wide(_) => 4,
            };
            assert_eq!(got, width, "{v:?}");
            assert_eq!((0..t.len()).map(|i| t.get(i)).collect::<Vec<_>>(), v);
            assert_eq!(t.memory_bytes(), v.len() * width);
        }
    }
}
