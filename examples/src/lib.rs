//! Example workloads.
