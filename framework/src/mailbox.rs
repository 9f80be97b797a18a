//! The receiving side of a processor: a priority mailbox.
//!
//! One FIFO queue per [`Class`]; [`Mailbox::pop`] always returns an item of
//! the highest non-empty class, and items of one class in arrival order. The
//! processor reads its mailbox this way, so a data request that arrives while
//! a hundred tasks are queued is served before any of them.

use std::collections::VecDeque;

use crate::protocol::Class;

/// Priority mailbox holding items of type `T` (the processor stores incoming
/// messages with their sender; tests use plain values).
///
/// (Example: the unit test `mailbox_order`.)
#[derive(Debug)]
pub(crate) struct Mailbox<T> {
    queues: [VecDeque<T>; 5],
    len: usize,
    high_water: usize,
}

impl<T> Default for Mailbox<T> {
    fn default() -> Self {
        Mailbox {
            queues: Default::default(),
            len: 0,
            high_water: 0,
        }
    }
}

impl<T> Mailbox<T> {
    /// An empty mailbox.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Queues `item` in `class`.
    pub(crate) fn push(&mut self, class: Class, item: T) {
        self.queues[class.index()].push_back(item);
        self.len += 1;
        self.high_water = self.high_water.max(self.len);
    }

    /// Takes the oldest item of the highest-priority non-empty class.
    pub(crate) fn pop(&mut self) -> Option<(Class, T)> {
        let class = self.peek_class()?;
        self.pop_class(class).map(|t| (class, t))
    }

    /// Takes the oldest item of `class`.
    pub(crate) fn pop_class(&mut self, class: Class) -> Option<T> {
        let item = self.queues[class.index()].pop_front()?;
        self.len -= 1;
        Some(item)
    }

    /// Takes the newest item of `class`.
    pub(crate) fn pop_class_newest(&mut self, class: Class) -> Option<T> {
        let item = self.queues[class.index()].pop_back()?;
        self.len -= 1;
        Some(item)
    }

    /// Takes the newest item of `class` for which `pick` holds.
    /// Scans from the newest; meant for rare exceptions (a processor's
    /// one or two root tasks among its children).
    pub(crate) fn pop_class_newest_where(
        &mut self,
        class: Class,
        pick: impl Fn(&T) -> bool,
    ) -> Option<T> {
        let queue = &mut self.queues[class.index()];
        let i = queue.iter().rposition(pick)?;
        let item = queue.remove(i)?;
        self.len -= 1;
        Some(item)
    }

    /// Every item queued in `class`, to change in place.
    pub(crate) fn class_mut(&mut self, class: Class) -> impl Iterator<Item = &mut T> {
        self.queues[class.index()].iter_mut()
    }

    /// Takes a data-parallel task: the oldest, or the `newest`
    /// ([`crate::Workload::data_parallel_newest_first`]).
    pub(crate) fn pop_data_parallel(&mut self, newest: bool) -> Option<T> {
        if newest {
            self.pop_class_newest(Class::DataParallel)
        } else {
            self.pop_class(Class::DataParallel)
        }
    }

    /// The class [`Mailbox::pop`] would return from.
    pub(crate) fn peek_class(&self) -> Option<Class> {
        Class::ALL
            .into_iter()
            .find(|c| !self.queues[c.index()].is_empty())
    }

    /// Items queued in `class`.
    pub(crate) fn len_of(&self, class: Class) -> usize {
        self.queues[class.index()].len()
    }

    /// Items queued in total.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing is queued.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Most items ever queued at once.
    pub(crate) fn high_water(&self) -> usize {
        self.high_water
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn higher_class_always_first_fifo_within_class() {
        let mut m = Mailbox::new();
        m.push(Class::DemandDriven, "dd1");
        m.push(Class::DataParallel, "dp1");
        m.push(Class::DemandDriven, "dd2");
        m.push(Class::Result, "r1");
        m.push(Class::Data, "data1");
        m.push(Class::Control, "ctl");
        m.push(Class::Data, "data2");
        let order: Vec<&str> = std::iter::from_fn(|| m.pop().map(|(_, t)| t)).collect();
        assert_eq!(
            order,
            vec!["ctl", "data1", "data2", "r1", "dp1", "dd1", "dd2"]
        );
        assert!(m.is_empty());
        assert_eq!(m.high_water(), 7);
    }

    #[test]
    fn newest_first_takes_the_class_backwards_and_leaves_the_others() {
        let mut m = Mailbox::new();
        for t in ["dp1", "dp2", "dp3"] {
            m.push(Class::DataParallel, t);
        }
        m.push(Class::DemandDriven, "dd1");
        assert_eq!(m.pop_class_newest(Class::DataParallel), Some("dp3"));
        m.push(Class::DataParallel, "dp4");
        assert_eq!(m.pop_class_newest(Class::DataParallel), Some("dp4"));
        assert_eq!(m.pop_class(Class::DataParallel), Some("dp1"));
        assert_eq!(m.pop_class_newest(Class::DataParallel), Some("dp2"));
        assert_eq!(m.pop_class_newest(Class::DataParallel), None);
        assert_eq!(m.pop(), Some((Class::DemandDriven, "dd1")));
        assert!(m.is_empty());
    }

    #[test]
    fn newest_where_skips_what_is_not_picked() {
        let mut m = Mailbox::new();
        for t in ["root1", "dd1", "dd2", "root2"] {
            m.push(Class::DemandDriven, t);
        }
        let child = |t: &&str| t.starts_with("dd");
        assert_eq!(
            m.pop_class_newest_where(Class::DemandDriven, child),
            Some("dd2")
        );
        assert_eq!(
            m.pop_class_newest_where(Class::DemandDriven, child),
            Some("dd1")
        );
        assert_eq!(m.pop_class_newest_where(Class::DemandDriven, child), None);
        assert_eq!(m.len(), 2);
        assert_eq!(m.pop(), Some((Class::DemandDriven, "root1")));
        assert_eq!(m.pop(), Some((Class::DemandDriven, "root2")));
        assert!(m.is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        /// Interleaved pushes and pops: every pop returns an item of the
        /// highest class present, in FIFO order within the class.
        #[test]
        fn priority_order_holds_under_interleaving(ops in proptest::collection::vec((0usize..6, any::<u16>()), 1..200)) {
            let mut m = Mailbox::new();
            let mut model: Vec<VecDeque<u16>> = vec![VecDeque::new(); 5];
            for (op, v) in ops {
                if op < 5 {
                    m.push(Class::ALL[op], v);
                    model[op].push_back(v);
                } else {
                    let expect = model.iter_mut().enumerate().find(|(_, q)| !q.is_empty())
                        .map(|(i, q)| (Class::ALL[i], q.pop_front().unwrap()));
                    prop_assert_eq!(m.pop(), expect);
                }
                prop_assert_eq!(m.len(), model.iter().map(|q| q.len()).sum::<usize>());
            }
        }
    }
}

#[cfg(test)]
mod example {
    use super::*;

    /// Formerly the type's documentation example.
    #[test]
    fn mailbox_order() {
        let mut mailbox = Mailbox::new();
        mailbox.push(Class::DemandDriven, "tile 1");
        mailbox.push(Class::DemandDriven, "tile 2");
        mailbox.push(Class::Result, "pixels");
        mailbox.push(Class::Data, "data request");
        assert_eq!(mailbox.peek_class(), Some(Class::Data));

        // The highest class first, arrival order within a class.
        let order: Vec<&str> = std::iter::from_fn(|| mailbox.pop().map(|(_, m)| m)).collect();
        assert_eq!(order, ["data request", "pixels", "tile 1", "tile 2"]);
        assert_eq!(mailbox.high_water(), 4);
    }
}
