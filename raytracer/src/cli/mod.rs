//! cli (in progress)

/// Entry point of the `hybrid-rt` binary; returns the process exit code.
pub fn main() -> i32 {
    0
}
