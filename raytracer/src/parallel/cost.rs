//! The simulator's cost model for the ray tracer. Its calibration lives
//! with the experiments, in [`crate::experiment::calibrate`].
//!
//! A simulated step costs `step_ns` plus, for each work unit the step
//! charged (see [`Work`]), its cost in [`model`]. The
//! constants were fitted on the development machine (one core of a shared
//! 2-core x86-64 VM, release build) by
//!
//! ```text
//! hybrid-rt experiment calibrate --scene studio --width 256 --height 192
//! ```
//!
//! which times every task step of a one-processor run of the framework's
//! sequential runtime, fits the per-unit costs by non-negative least squares
//! over all steps, and then takes the framework's own per-step overhead
//! (mailboxes, selection bookkeeping, result merging) from a one-processor
//! run of the threads runtime: (measured time - fitted work) / steps.
//! Re-running it on another machine prints the constants for that machine;
//! the built-in ones stay fixed so that simulated figures are reproducible
//! everywhere.
//!
//! The built-in constants come from two such fits on the studio scene
//! (R^2 over 256-step batches 0.46 and 0.77, on a machine shared with other
//! builds). Kinds that always occur together cannot be told apart by a
//! regression (each shaded ray is also a spawned ray; each tested shadow ray
//! also enters leaves and tests objects), so the fit gives one of them the
//! whole cost and the others zero; the constants keep that split. Objects
//! inside instances are not counted (the conference scene's instanced
//! furniture), so a fit on that scene puts their cost on the leaf steps.

use hybrid_sched::CostModel;

use super::work::Work;

/// The fitted kinds and their built-in costs (ns of the development
/// machine per unit).
pub const UNIT_NS: [(Work, f64); 8] = [
    (Work::TraceLeaves, 20.0),
    (Work::TraceObjects, 31.0),
    (Work::ClipNodes, 28.0),
    (Work::Shade, 1400.0),
    (Work::ShadowPatches, 0.0),
    (Work::ShadowTested, 0.0),
    (Work::RaysSpawned, 0.0),
    (Work::ShadowBundles, 300.0),
];

/// The built-in cost of one unit of `kind` (0 for kinds that are not
/// fitted: counters that are not work).
pub fn unit_ns(kind: Work) -> f64 {
    UNIT_NS
        .iter()
        .find(|&&(k, _)| k == kind)
        .map_or(0.0, |&(_, v)| v)
}

/// The framework's per-step overhead on the development machine (ns).
pub const STEP_NS: f64 = 1100.0;

/// The built-in cost model (see the module documentation).
pub fn model() -> CostModel {
    CostModel {
        unit_ns: UNIT_NS
            .iter()
            .map(|&(k, v)| (k.name().to_string(), v))
            .collect(),
        // Counters that are not work (rays.retired, shadow.spawned, ...).
        default_unit_ns: 0.0,
        step_ns: STEP_NS,
        master_step_ns: 1500.0,
        cache_byte_ns: 0.05,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_model_prices_each_fitted_kind_once_and_only_renderer_kinds() {
        let m = model();
        assert_eq!(m.unit_ns.len(), UNIT_NS.len(), "a kind fitted twice");
        m.check::<Work>()
            .expect("the model names only the renderer's kinds");
        for (k, v) in UNIT_NS {
            assert_eq!(m.unit_ns[k.name()], v);
            assert_eq!(unit_ns(k), v);
        }
        assert_eq!(unit_ns(Work::RaysRetired), 0.0);
    }
}
