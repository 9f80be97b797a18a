//! A processor's resident items: the data it owns for the whole run.

use std::hash::Hash;

use crate::cache::IdMap;

/// A processor's resident items by id: the items in one list, in the order
/// they were inserted, and a hash index from id to place.
///
/// A hash map of the items themselves keeps every slot item-sized, and a
/// table's slots are a power of two at most 7/8 full: a renderer's
/// processor of a 300,000-triangle city (two processors) held its leaves,
/// 56 bytes each, in a 7.5 MB table (valgrind's massif). Here the items
/// take their own size (4.4 MB) and the index 8 bytes a slot (1.2 MB).
///
/// ```rust
/// use hybrid_sched::Resident;
///
/// let mut r: Resident<u32, &str> = [(4, "four"), (2, "two")].into_iter().collect();
/// assert_eq!(r.get(&2), Some(&"two"));
/// assert_eq!(r.insert(2, "deux"), Some("two"));
/// assert!(r.contains_key(&4) && !r.contains_key(&3));
/// assert_eq!(r.iter().map(|(k, _)| *k).collect::<Vec<_>>(), [4, 2]);
/// ```
#[derive(Clone, Debug)]
pub struct Resident<K, V> {
    items: Vec<(K, V)>,
    index: IdMap<K, u32>,
}

impl<K, V> Default for Resident<K, V> {
    fn default() -> Self {
        Resident {
            items: Vec::new(),
            index: IdMap::default(),
        }
    }
}

impl<K: Hash + Eq + Clone, V> Resident<K, V> {
    /// Room for `n` items.
    pub fn with_capacity(n: usize) -> Self {
        Resident {
            items: Vec::with_capacity(n),
            index: IdMap::with_capacity_and_hasher(n, Default::default()),
        }
    }

    /// The items of `items`, kept in that list (not copied); the first
    /// repeated id is an error.
    pub fn from_vec(items: Vec<(K, V)>) -> Result<Self, K> {
        let mut index = IdMap::with_capacity_and_hasher(items.len(), Default::default());
        for (k, (id, _)) in items.iter().enumerate() {
            let k = u32::try_from(k).expect("at most u32::MAX resident items");
            if index.insert(id.clone(), k).is_some() {
                return Err(id.clone());
            }
        }
        Ok(Resident { items, index })
    }

    /// The item `id`.
    #[inline]
    pub fn get(&self, id: &K) -> Option<&V> {
        self.index.get(id).map(|&k| &self.items[k as usize].1)
    }

    /// Whether `id` is held.
    #[inline]
    pub fn contains_key(&self, id: &K) -> bool {
        self.index.contains_key(id)
    }

    /// Holds `item` as `id`; the item it replaces, if any.
    ///
    /// # Panics
    /// If more than `u32::MAX` items would be held.
    pub fn insert(&mut self, id: K, item: V) -> Option<V> {
        if let Some(&k) = self.index.get(&id) {
            return Some(std::mem::replace(&mut self.items[k as usize].1, item));
        }
        let k = u32::try_from(self.items.len()).expect("at most u32::MAX resident items");
        self.index.insert(id.clone(), k);
        self.items.push((id, item));
        None
    }

    /// How many items.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// The items with their ids, in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.items.iter().map(|(k, v)| (k, v))
    }

    /// The ids, in insertion order.
    pub fn keys(&self) -> impl Iterator<Item = &K> {
        self.items.iter().map(|(k, _)| k)
    }

    /// The items, in insertion order.
    pub fn values(&self) -> impl Iterator<Item = &V> {
        self.items.iter().map(|(_, v)| v)
    }
}

impl<K: Hash + Eq + Clone, V> Extend<(K, V)> for Resident<K, V> {
    fn extend<I: IntoIterator<Item = (K, V)>>(&mut self, iter: I) {
        for (k, v) in iter {
            self.insert(k, v);
        }
    }
}

impl<K: Hash + Eq + Clone, V> FromIterator<(K, V)> for Resident<K, V> {
    fn from_iter<I: IntoIterator<Item = (K, V)>>(iter: I) -> Self {
        let mut r = Resident::default();
        r.extend(iter);
        r
    }
}
