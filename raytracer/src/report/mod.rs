//! Reports: SVG charts ([`plot`]) and markdown tables ([`table`]) for
//! experiments and sweeps, and the accuracy sweep itself ([`sweep`]).

pub mod plot;
pub mod sweep;
pub mod table;
