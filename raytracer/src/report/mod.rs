//! Reports: SVG charts ([`plot`]) and markdown tables ([`table`]) for
//! experiments and sweeps (the accuracy sweep itself is
//! [`crate::experiment::sweep`]).

pub mod plot;
pub mod table;

/// The process's peak resident memory as the operating system measured it
/// (`VmHWM`), in bytes; `None` where there is none.
pub fn peak_resident_bytes() -> Option<usize> {
    hybrid_sched::stats::peak_resident_bytes().map(|b| b as usize)
}

/// The process's resident memory now (`VmRSS`), in bytes.
pub fn resident_bytes() -> Option<usize> {
    hybrid_sched::stats::resident_bytes().map(|b| b as usize)
}
