//! The data store's completion ([`crate::Config::complete_cache`]), driven
//! directly.

use super::Mini;
use crate::protocol::Placement;
use crate::store::{DataStore, Directory};

const MIB: u64 = 1 << 20;

fn directory() -> Directory<u32> {
    // Processor 0 holds nothing; 1 and 2 hold items of these accounted
    // sizes, one of them larger than a completion request's bound.
    let items = [(1, 1, 5), (2, 1, 5), (3, 1, 1), (4, 2, 20), (5, 2, 1)];
    let placement = items
        .iter()
        .map(|&(id, owner, mib)| Placement {
            id,
            owner,
            bytes: mib * MIB,
        })
        .collect();
    Directory::build(placement, 3).unwrap()
}

/// Every item held elsewhere is asked for once, from its owner, in
/// requests of at most 8 MiB each (an item larger than that alone), and
/// only once.
#[test]
fn completion_asks_for_everything_held_elsewhere_in_bounded_requests() {
    let mut s = DataStore::<Mini>::new(0, Vec::new(), directory(), None, None, Some(0)).unwrap();
    let requests = s.complete().expect("at 0 a store completes at once");
    assert_eq!(
        requests,
        vec![(1, vec![1]), (1, vec![2, 3]), (2, vec![4]), (2, vec![5])]
    );
    assert!(s.complete().is_none(), "a store completes once");
}

/// A cache with a budget, a fetch limit or no percentage: never.
#[test]
fn completion_needs_a_cache_without_budget_and_no_fetch_limit() {
    for (cache, limit, percent) in [
        (Some(64 * MIB), None, Some(0)),
        (None, Some(MIB), Some(0)),
        (None, None, None),
    ] {
        let mut s =
            DataStore::<Mini>::new(0, Vec::new(), directory(), cache, limit, percent).unwrap();
        assert!(s.complete().is_none(), "{cache:?} {limit:?} {percent:?}");
    }
}
