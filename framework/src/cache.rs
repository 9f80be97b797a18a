//! A byte-budgeted LRU cache with pinning and reservations.
//!
//! Unpinned items live in an `lru::LruCache` (evicted least recently used
//! first); pinned items, which a waiting or running task needs, are moved out
//! of it into a plain map so that eviction can never touch them and stays O(1).
//! Space for items that have been requested but have not arrived yet is
//! *reserved*, so the invariant `pinned + unpinned + reserved <= budget` holds
//! at all times: the budget is never exceeded, not even transiently.

use std::collections::HashMap;
use std::hash::Hash;

use lru::LruCache;
use serde::{Deserialize, Serialize};

/// Cache counters (also part of the processor statistics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheCounters {
    /// Lookups answered from the cache.
    pub hits: u64,
    /// Lookups that had to fetch (or migrate).
    pub misses: u64,
    /// Items evicted to make room.
    pub evictions: u64,
    /// Items inserted.
    pub insertions: u64,
}

#[derive(Debug)]
struct PinnedEntry<V> {
    value: V,
    bytes: u64,
    pins: u32,
}

/// Byte-budgeted LRU cache. See the module documentation.
#[derive(Debug)]
pub struct ByteLru<K: Hash + Eq, V> {
    budget: u64,
    lru: LruCache<K, (V, u64)>,
    pinned: HashMap<K, PinnedEntry<V>>,
    unpinned_bytes: u64,
    pinned_bytes: u64,
    reserved: u64,
    high_water: u64,
    counters: CacheCounters,
}

impl<K: Hash + Eq + Clone, V> ByteLru<K, V> {
    /// A cache holding at most `budget` bytes (`None`: unlimited).
    pub fn new(budget: Option<u64>) -> Self {
        ByteLru {
            budget: budget.unwrap_or(u64::MAX),
            lru: LruCache::unbounded(),
            pinned: HashMap::new(),
            unpinned_bytes: 0,
            pinned_bytes: 0,
            reserved: 0,
            high_water: 0,
            counters: CacheCounters::default(),
        }
    }

    /// The byte budget (`u64::MAX` when unlimited).
    pub fn budget(&self) -> u64 {
        self.budget
    }

    /// Bytes held (pinned and unpinned).
    pub fn used(&self) -> u64 {
        self.pinned_bytes + self.unpinned_bytes
    }

    /// Bytes held by pinned items.
    pub fn pinned_bytes(&self) -> u64 {
        self.pinned_bytes
    }

    /// Bytes reserved for items on their way.
    pub fn reserved(&self) -> u64 {
        self.reserved
    }

    /// Highest `used()` ever seen.
    pub fn high_water(&self) -> u64 {
        self.high_water
    }

    /// Number of items held.
    pub fn len(&self) -> usize {
        self.lru.len() + self.pinned.len()
    }

    /// Whether the cache holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The counters.
    pub fn counters(&self) -> CacheCounters {
        self.counters
    }

    /// Whether `key` is held.
    pub fn contains(&self, key: &K) -> bool {
        self.pinned.contains_key(key) || self.lru.contains(key)
    }

    /// Whether `key` is held and pinned.
    pub fn is_pinned(&self, key: &K) -> bool {
        self.pinned.contains_key(key)
    }

    /// Bytes of `key` if held.
    pub fn bytes_of(&self, key: &K) -> Option<u64> {
        self.pinned
            .get(key)
            .map(|e| e.bytes)
            .or_else(|| self.lru.peek(key).map(|(_, b)| *b))
    }

    /// The value without touching recency or counters.
    pub fn peek(&self, key: &K) -> Option<&V> {
        self.pinned
            .get(key)
            .map(|e| &e.value)
            .or_else(|| self.lru.peek(key).map(|(v, _)| v))
    }

    /// A counted lookup: refreshes recency and counts a hit or a miss.
    pub fn get(&mut self, key: &K) -> Option<&V> {
        if self.contains(key) {
            self.counters.hits += 1;
            if let Some(e) = self.pinned.get(key) {
                return Some(&e.value);
            }
            return self.lru.get(key).map(|(v, _)| v);
        }
        self.counters.misses += 1;
        None
    }

    /// Refreshes recency of `key` (if held and unpinned) and counts a hit.
    pub fn touch(&mut self, key: &K) {
        if self.contains(key) {
            self.counters.hits += 1;
            self.lru.promote(key);
        }
    }

    /// Counts a hit that was resolved elsewhere (e.g. by selection).
    pub fn record_hit(&mut self) {
        self.counters.hits += 1;
    }

    /// Counts a miss that was resolved elsewhere (e.g. by a fetch).
    pub fn record_miss(&mut self) {
        self.counters.misses += 1;
    }

    /// Whether `extra` more bytes could be pinned or reserved right now,
    /// counting everything that is already pinned or reserved as immovable.
    pub fn can_pin_more(&self, extra: u64) -> bool {
        self.pinned_bytes
            .saturating_add(self.reserved)
            .saturating_add(extra)
            <= self.budget
    }

    /// Pins a held item (nested pins are counted). Returns false when the item
    /// is not held.
    pub fn pin(&mut self, key: &K) -> bool {
        if let Some(e) = self.pinned.get_mut(key) {
            e.pins += 1;
            return true;
        }
        match self.lru.pop(key) {
            Some((value, bytes)) => {
                self.unpinned_bytes -= bytes;
                self.pinned_bytes += bytes;
                self.pinned.insert(
                    key.clone(),
                    PinnedEntry {
                        value,
                        bytes,
                        pins: 1,
                    },
                );
                true
            }
            None => false,
        }
    }

    /// Drops one pin; the last one makes the item evictable again (as the most
    /// recently used item, since a task has just used it).
    pub fn unpin(&mut self, key: &K) {
        let Some(e) = self.pinned.get_mut(key) else {
            return;
        };
        e.pins -= 1;
        if e.pins == 0 {
            if let Some((k, e)) = self.pinned.remove_entry(key) {
                self.pinned_bytes -= e.bytes;
                self.unpinned_bytes += e.bytes;
                self.lru.put(k, (e.value, e.bytes));
            }
        }
    }

    /// Reserves `bytes` for an item on its way, evicting unpinned items as
    /// needed. Returns false (and changes nothing) if pinned and reserved
    /// bytes leave no room.
    pub fn reserve(&mut self, bytes: u64) -> bool {
        if !self.can_pin_more(bytes) {
            return false;
        }
        self.reserved += bytes;
        self.evict_to_budget();
        true
    }

    /// Inserts an item whose space was reserved with [`ByteLru::reserve`],
    /// pinned `pins` times (0: unpinned).
    pub fn insert_reserved(&mut self, key: K, value: V, reserved: u64, bytes: u64, pins: u32) {
        self.reserved -= reserved.min(self.reserved);
        self.remove(&key);
        self.counters.insertions += 1;
        if pins > 0 {
            self.pinned_bytes += bytes;
            self.pinned.insert(key, PinnedEntry { value, bytes, pins });
        } else {
            self.unpinned_bytes += bytes;
            self.lru.put(key, (value, bytes));
        }
        self.evict_to_budget();
        self.high_water = self.high_water.max(self.used());
    }

    /// Inserts an unpinned item, evicting least recently used items to make
    /// room. Returns false (and stores nothing) if it cannot fit.
    pub fn insert(&mut self, key: K, value: V, bytes: u64) -> bool {
        self.remove(&key);
        if !self.reserve(bytes) {
            return false;
        }
        self.insert_reserved(key, value, bytes, bytes, 0);
        true
    }

    /// Removes an item (pinned or not) without counting an eviction.
    pub fn remove(&mut self, key: &K) -> Option<V> {
        if let Some(e) = self.pinned.remove(key) {
            self.pinned_bytes -= e.bytes;
            return Some(e.value);
        }
        let (v, b) = self.lru.pop(key)?;
        self.unpinned_bytes -= b;
        Some(v)
    }

    fn evict_to_budget(&mut self) {
        while self.used().saturating_add(self.reserved) > self.budget {
            match self.lru.pop_lru() {
                Some((_, (_, bytes))) => {
                    self.unpinned_bytes -= bytes;
                    self.counters.evictions += 1;
                }
                // Only pinned items and reservations are left; callers never
                // let those exceed the budget (see `can_pin_more`).
                None => break,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lru_respects_byte_budget() {
        let mut c: ByteLru<u32, &str> = ByteLru::new(Some(100));
        assert!(c.insert(1, "a", 40));
        assert!(c.insert(2, "b", 40));
        assert_eq!(c.used(), 80);
        assert!(c.insert(3, "c", 40)); // evicts 1
        assert!(c.used() <= 100);
        assert!(!c.contains(&1));
        assert!(c.contains(&2) && c.contains(&3));
        assert_eq!(c.counters().evictions, 1);
        assert!(!c.insert(4, "d", 101), "bigger than the budget");
        assert!(!c.contains(&4));
        assert!(c.high_water() <= 100);
    }

    #[test]
    fn lru_evicts_least_recently_used_first() {
        let mut c: ByteLru<u32, u32> = ByteLru::new(Some(30));
        for k in 0..3 {
            assert!(c.insert(k, k, 10));
        }
        assert_eq!(c.get(&0), Some(&0)); // 0 is now most recent; 1 is LRU
        assert!(c.insert(3, 3, 10));
        assert!(!c.contains(&1));
        assert!(c.contains(&0) && c.contains(&2) && c.contains(&3));
        c.touch(&2); // order now (LRU..MRU): 0, 3, 2
        assert!(c.insert(4, 4, 20));
        assert!(!c.contains(&0) && !c.contains(&3));
        assert!(c.contains(&2) && c.contains(&4));
        assert_eq!(c.counters().evictions, 3);
    }

    #[test]
    fn pinned_items_are_never_evicted() {
        let mut c: ByteLru<u32, u32> = ByteLru::new(Some(30));
        for k in 0..3 {
            assert!(c.insert(k, k, 10));
        }
        assert!(c.pin(&0));
        assert!(c.pin(&0)); // nested
        assert!(c.insert(3, 3, 20)); // must evict 1 and 2, not 0
        assert!(c.contains(&0) && c.contains(&3));
        assert!(!c.contains(&1) && !c.contains(&2));
        // Everything else pinned too: no room for more.
        assert!(c.pin(&3));
        assert!(!c.reserve(1));
        assert!(!c.insert(9, 9, 1));
        c.unpin(&0);
        assert!(c.is_pinned(&0), "still pinned once");
        c.unpin(&0);
        assert!(!c.is_pinned(&0));
        assert!(c.insert(9, 9, 10)); // now 0 can go
        assert!(!c.contains(&0));
        assert!(c.used() <= 30);
    }

    #[test]
    fn reservations_count_against_the_budget() {
        let mut c: ByteLru<u32, u32> = ByteLru::new(Some(50));
        assert!(c.insert(1, 1, 30));
        assert!(c.reserve(40)); // evicts 1
        assert!(!c.contains(&1));
        assert!(!c.reserve(20));
        assert!(c.reserve(10));
        c.insert_reserved(2, 2, 40, 40, 1);
        c.insert_reserved(3, 3, 10, 10, 2);
        assert_eq!(c.reserved(), 0);
        assert_eq!(c.pinned_bytes(), 50);
        assert_eq!(c.used(), 50);
    }

    #[test]
    fn hit_and_miss_counters() {
        let mut c: ByteLru<u32, u32> = ByteLru::new(None);
        assert!(c.insert(1, 10, 8));
        assert_eq!(c.get(&1), Some(&10));
        assert_eq!(c.get(&2), None);
        c.touch(&1);
        c.touch(&7); // not held: nothing counted
        let k = c.counters();
        assert_eq!((k.hits, k.misses, k.insertions, k.evictions), (2, 1, 1, 0));
    }
}
