//! The kinds of work a workload counts ([`WorkKind`]), the macro that
//! declares them, and [`NoWork`] for workloads that count none.

use std::fmt::Debug;
use std::hash::Hash;

#[cfg(doc)]
use super::workload::Ctx;

/// The kinds of counted work a workload charges ([`Ctx::charge`]): a small
/// enum, usually declared with [`crate::work_kinds!`]. Statistics and the
/// simulator's cost model name each kind by [`WorkKind::name`]; a cost
/// model that names a kind the workload does not declare is rejected when
/// the simulation starts, so a misspelt name cannot silently cost nothing.
pub trait WorkKind: Copy + Eq + Ord + Hash + Debug + Send + Sync + 'static {
    /// Every kind, in declaration order.
    const ALL: &'static [Self];
    /// The name used in statistics, reports and cost models (e.g.
    /// `"trace.leaves"`).
    fn name(self) -> &'static str;

    /// The kind called `name`, if there is one.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// The kind's position in [`WorkKind::ALL`] ([`work_kinds!`](crate::work_kinds) makes it
    /// the discriminant): what [`Ctx::charge`] indexes by.
    fn index(self) -> usize {
        Self::ALL
            .iter()
            .position(|&k| k == self)
            .unwrap_or(usize::MAX)
    }
}

/// Declares an enum of work kinds and implements [`WorkKind`] for it, each
/// variant with its name:
///
/// ```rust
/// hybrid_sched::work_kinds! {
///     /// What the workload counts.
///     pub enum Work {
///         /// Cells visited by data selection.
///         Select = "select",
///         Add = "add",
///     }
/// }
/// use hybrid_sched::WorkKind;
/// assert_eq!(Work::ALL, [Work::Select, Work::Add]);
/// assert_eq!(Work::Add.name(), "add");
/// assert_eq!(Work::from_name("select"), Some(Work::Select));
/// ```
#[macro_export]
macro_rules! work_kinds {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $($(#[$vmeta:meta])* $variant:ident = $label:literal),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        $vis enum $name {
            $($(#[$vmeta])* $variant),*
        }

        impl $name {
            /// The kind's name, as statistics and cost models know it.
            #[allow(dead_code)]
            $vis fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $label),*
                }
            }
        }

        impl $crate::WorkKind for $name {
            const ALL: &'static [Self] = &[$($name::$variant),*];
            fn name(self) -> &'static str {
                $name::name(self)
            }
            #[inline]
            fn index(self) -> usize {
                self as usize
            }
        }
    };
}

work_kinds! {
    /// For workloads that charge no work: no kinds at all.
    pub enum NoWork {}
}
