//! hybrid-sched (in progress)
