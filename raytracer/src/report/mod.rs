//! Reports: SVG charts ([`plot`]) and markdown tables ([`table`]) for
//! experiments and sweeps.

pub mod plot;
pub mod table;
