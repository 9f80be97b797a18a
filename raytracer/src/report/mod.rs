//! Reports: SVG charts ([`plot`]) and markdown tables ([`table`]) for
//! experiments and sweeps (the accuracy sweep itself is
//! [`crate::experiment::sweep`]).

pub mod plot;
pub mod table;

/// The process's peak resident set as the operating system measured it
/// (`VmHWM` in `/proc/self/status`), in bytes; `None` where there is none.
pub fn peak_resident_bytes() -> Option<usize> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The process's resident set now (`VmRSS`), in bytes.
pub fn resident_bytes() -> Option<usize> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: usize = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}
