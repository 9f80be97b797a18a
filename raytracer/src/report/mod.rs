//! Reports: SVG charts ([`plot`]) and markdown tables ([`table`]) for
//! experiments and sweeps (the accuracy sweep itself is
//! [`crate::experiment::sweep`]).

pub mod plot;
pub mod table;
