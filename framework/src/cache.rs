//! A byte-budgeted LRU cache with pinning and reservations.
//!
//! Every item lives in one `lru::LruCache` with a pin count. A pinned item
//! (one a waiting or running task needs) is never evicted: eviction takes
//! the least recently used *unpinned* item, moving any pinned item it meets
//! at the old end to the recent end (its place does not matter while it is
//! pinned: its last unpin makes it the most recently used item anyway).
//! Pinning and unpinning change a counter in place, so the hot path of a
//! task (pin its cells, run, unpin them) allocates nothing and does one
//! lookup per item. Space for items that have been requested but have not
//! arrived yet is *reserved*, so the invariant `pinned + unpinned +
//! reserved <= budget` holds at all times: the budget is never exceeded,
//! not even transiently.

use std::collections::HashMap;
use std::hash::Hash;

use lru::LruCache;
use serde::{Deserialize, Serialize};

/// Maps keyed by data id, looked up on every cell a task touches: a fast
/// non-cryptographic hash (the one `lru` uses) instead of SipHash.
pub type IdMap<K, V> = HashMap<K, V, lru::DefaultHasher>;

/// Cache counters (also part of the processor statistics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CacheCounters {
    /// Lookups answered from the cache (a hook's consecutive lookups of one
    /// item count once; see [`crate::DataView::get`]).
    pub hits: u64,
    /// Lookups that had to fetch (or migrate).
    pub misses: u64,
    /// Items evicted to make room.
    pub evictions: u64,
    /// Items inserted.
    pub insertions: u64,
}

#[derive(Debug)]
struct Entry<V> {
    value: V,
    bytes: u64,
    pins: u32,
}

/// Byte-budgeted LRU cache. See the module documentation.
///
/// # Example
///
/// ```rust
/// use hybrid_sched::ByteLru;
///
/// let mut cache: ByteLru<&str, Vec<u8>> = ByteLru::new(Some(100)); // 100 bytes
/// assert!(cache.insert("a", vec![1; 40], 40));
/// assert!(cache.insert("b", vec![2; 40], 40));
/// assert!(cache.get(&"a").is_some()); // "a" is now the most recently used
/// assert!(cache.insert("c", vec![3; 40], 40)); // no room: evicts "b"
/// assert!(cache.contains(&"a") && !cache.contains(&"b") && cache.contains(&"c"));
/// assert_eq!(cache.used(), 80);
///
/// // A pinned item (one a waiting task needs) is never evicted: "d" evicts
/// // "c", although "a" is the least recently used.
/// assert!(cache.pin(&"a"));
/// assert!(cache.insert("d", vec![4; 60], 60));
/// assert!(cache.contains(&"a") && !cache.contains(&"c") && cache.contains(&"d"));
/// // An item that cannot fit beside the pinned ones is refused.
/// assert!(!cache.insert("e", vec![5; 70], 70));
///
/// assert_eq!(cache.counters().evictions, 2);
/// assert_eq!(cache.counters().hits, 1);
/// assert_eq!(cache.high_water(), 100); // the budget was never exceeded
/// ```
#[derive(Debug)]
pub struct ByteLru<K: Hash + Eq, V> {
    budget: u64,
    lru: LruCache<K, Entry<V>>,
    pinned_items: usize,
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
            pinned_items: 0,
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
        self.lru.len()
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
        self.lru.contains(key)
    }

    /// Whether `key` is held and pinned.
    pub fn is_pinned(&self, key: &K) -> bool {
        self.lru.peek(key).is_some_and(|e| e.pins > 0)
    }

    /// Bytes of `key` if held.
    pub fn bytes_of(&self, key: &K) -> Option<u64> {
        self.lru.peek(key).map(|e| e.bytes)
    }

    /// The value without touching recency or counters.
    pub fn peek(&self, key: &K) -> Option<&V> {
        self.lru.peek(key).map(|e| &e.value)
    }

    /// Every held item, most recently used first, without touching recency
    /// or counters.
    pub fn iter(&self) -> impl Iterator<Item = (&K, &V)> {
        self.lru.iter().map(|(k, e)| (k, &e.value))
    }

    /// A counted lookup: refreshes recency and counts a hit or a miss.
    pub fn get(&mut self, key: &K) -> Option<&V> {
        match self.lru.get(key) {
            Some(e) => {
                self.counters.hits += 1;
                Some(&e.value)
            }
            None => {
                self.counters.misses += 1;
                None
            }
        }
    }

    /// Refreshes recency of `key` (if held) and counts a hit.
    pub fn touch(&mut self, key: &K) {
        if self.lru.promote(key) {
            self.counters.hits += 1;
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
        let Some(e) = self.lru.peek_mut(key) else {
            return false;
        };
        e.pins += 1;
        if e.pins == 1 {
            let bytes = e.bytes;
            self.unpinned_bytes -= bytes;
            self.pinned_bytes += bytes;
            self.pinned_items += 1;
        }
        true
    }

    /// Drops one pin; the last one makes the item evictable again (as the most
    /// recently used item, since a task has just used it).
    pub fn unpin(&mut self, key: &K) {
        let Some(e) = self.lru.peek_mut(key) else {
            return;
        };
        if e.pins == 0 {
            return;
        }
        e.pins -= 1;
        if e.pins == 0 {
            let bytes = e.bytes;
            self.pinned_bytes -= bytes;
            self.unpinned_bytes += bytes;
            self.pinned_items -= 1;
            self.lru.promote(key);
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
            self.pinned_items += 1;
        } else {
            self.unpinned_bytes += bytes;
        }
        self.lru.put(key, Entry { value, bytes, pins });
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
        let e = self.lru.pop(key)?;
        if e.pins > 0 {
            self.pinned_bytes -= e.bytes;
            self.pinned_items -= 1;
        } else {
            self.unpinned_bytes -= e.bytes;
        }
        Some(e.value)
    }

    fn evict_to_budget(&mut self) {
        // Each pinned item is passed over (moved to the recent end) at most
        // once per call, so the loop ends.
        let mut passes = self.pinned_items;
        while self.used().saturating_add(self.reserved) > self.budget && self.unpinned_bytes > 0 {
            let Some((key, pinned)) = self.lru.peek_lru().map(|(k, e)| (k.clone(), e.pins > 0))
            else {
                break;
            };
            if pinned {
                if passes == 0 {
                    break;
                }
                passes -= 1;
                self.lru.promote(&key);
                continue;
            }
            if let Some((_, e)) = self.lru.pop_lru() {
                self.unpinned_bytes -= e.bytes;
                self.counters.evictions += 1;
            }
        }
        // Otherwise only pinned items and reservations are left; callers
        // never let those exceed the budget (see `can_pin_more`).
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

    /// The old two-structure design, written plainly: unpinned items in
    /// recency order (least recent first), pinned items aside. The cache
    /// must evict exactly what it evicts.
    #[derive(Default)]
    struct Model {
        budget: u64,
        order: Vec<(u32, u64)>,
        pinned: Vec<(u32, u64, u32)>,
        reserved: u64,
    }

    impl Model {
        fn used(&self) -> u64 {
            self.order.iter().map(|e| e.1).sum::<u64>()
                + self.pinned.iter().map(|e| e.1).sum::<u64>()
        }
        fn pinned_bytes(&self) -> u64 {
            self.pinned.iter().map(|e| e.1).sum()
        }
        fn evict(&mut self) {
            while self.used() + self.reserved > self.budget && !self.order.is_empty() {
                self.order.remove(0);
            }
        }
        fn remove(&mut self, k: u32) {
            self.order.retain(|e| e.0 != k);
            self.pinned.retain(|e| e.0 != k);
        }
        fn insert(&mut self, k: u32, b: u64) -> bool {
            self.remove(k);
            if self.pinned_bytes() + self.reserved + b > self.budget {
                return false;
            }
            self.reserved += b;
            self.evict();
            self.reserved -= b;
            self.order.push((k, b));
            self.evict();
            true
        }
        fn pin(&mut self, k: u32) -> bool {
            if let Some(e) = self.pinned.iter_mut().find(|e| e.0 == k) {
                e.2 += 1;
                return true;
            }
            match self.order.iter().position(|e| e.0 == k) {
                Some(i) => {
                    let (k, b) = self.order.remove(i);
                    self.pinned.push((k, b, 1));
                    true
                }
                None => false,
            }
        }
        fn unpin(&mut self, k: u32) {
            if let Some(i) = self.pinned.iter().position(|e| e.0 == k) {
                self.pinned[i].2 -= 1;
                if self.pinned[i].2 == 0 {
                    let (k, b, _) = self.pinned.remove(i);
                    self.order.push((k, b));
                }
            }
        }
        fn touch(&mut self, k: u32) {
            if let Some(i) = self.order.iter().position(|e| e.0 == k) {
                let e = self.order.remove(i);
                self.order.push(e);
            }
        }
        fn keys(&self) -> Vec<u32> {
            let mut k: Vec<u32> = self.order.iter().map(|e| e.0).collect();
            k.extend(self.pinned.iter().map(|e| e.0));
            k.sort_unstable();
            k
        }
    }

    #[test]
    fn evicts_like_the_plain_model_under_random_operations() {
        for seed in 1..=20u64 {
            let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let mut next = |n: u64| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x % n
            };
            let mut c: ByteLru<u32, u32> = ByteLru::new(Some(100));
            let mut m = Model {
                budget: 100,
                ..Model::default()
            };
            for step in 0..2000 {
                let k = next(24) as u32;
                match next(5) {
                    0 | 1 => {
                        let b = 1 + next(30);
                        assert_eq!(c.insert(k, k, b), m.insert(k, b), "seed {seed} step {step}");
                    }
                    2 => assert_eq!(c.pin(&k), m.pin(k), "seed {seed} step {step}"),
                    3 => {
                        c.unpin(&k);
                        m.unpin(k);
                    }
                    _ => {
                        c.touch(&k);
                        m.touch(k);
                    }
                }
                let mut held: Vec<u32> = (0..24).filter(|k| c.contains(k)).collect();
                held.sort_unstable();
                assert_eq!(held, m.keys(), "seed {seed} step {step}");
                assert_eq!(c.used(), m.used());
                assert_eq!(c.pinned_bytes(), m.pinned_bytes());
                assert!(c.used() <= 100);
            }
        }
    }
}
