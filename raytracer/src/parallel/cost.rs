//! The simulator's cost model for the ray tracer: data, not code. The model
//! is the committed file `experiments/cost-model.json`, compiled in with
//! `include_str!` (one source: the simulator, the sequential baseline of the
//! experiments and the predicted distribution all read it). Its calibration
//! lives with the experiments, in [`crate::experiment::calibrate`].
//!
//! A simulated step costs `step_ns` plus, for each work unit the step
//! charged (see [`Work`]), its cost in [`model`]. The per-unit costs and
//! `step_ns` are fitted on a real machine by
//!
//! ```text
//! hybrid-rt experiment calibrate --scene studio --width 256 --height 192 --out experiments
//! ```
//!
//! which times every task step of the framework's sequential runtime on a
//! one-processor and a two-processor workload (the latter samples
//! clipping), fits the per-unit costs of [`FITTED`] by non-negative least
//! squares over batches of steps, then takes the framework's own per-step
//! overhead (mailboxes, selection bookkeeping, result merging) from
//! one-processor runs of the threads runtime: (CPU time of the process -
//! fitted work) / steps. CPU time, not wall time, so that other work on a
//! shared machine is not charged to the framework; the process's time
//! includes the master's thread, which the simulator prices separately, so
//! `step_ns` errs on the high side. It writes the new file, recording the
//! machine, the command, the date and the fit's quality, and reports how far
//! the *committed* model's prediction of that threads run is from the
//! measured time: past 10%, refit and commit the file (the simulated
//! experiment outputs change with it; `experiments/` is then regenerated).
//!
//! The rest of the model is not fitted: `master_step_ns` (one master step)
//! and `cache_byte_ns` (storing a received byte in the cache) are
//! assumptions, carried over unchanged by every refit; the file's
//! `assumed` table says where each comes from. Kinds that always occur
//! together cannot be told apart by a regression (each shaded ray is also a
//! spawned ray; each tested shadow ray also enters leaves and tests
//! objects), so the fit splits their joint cost between them arbitrarily
//! (often all on one). Objects inside instances are not counted (the
//! conference scene's instanced furniture), so a fit on that scene puts
//! their cost on the leaf steps.

use std::collections::BTreeMap;
use std::sync::OnceLock;

use hybrid_sched::CostModel;
use serde::{Deserialize, Serialize};

use super::work::Work;

/// The committed model file's text (`experiments/cost-model.json`).
pub const MODEL_JSON: &str = include_str!("../../../experiments/cost-model.json");

/// Where the committed model file lives, relative to the repository root.
pub const MODEL_PATH: &str = "experiments/cost-model.json";

/// The kinds whose per-unit cost the calibration fits; every other kind
/// (counters that are not work: `rays.retired`, `shadow.spawned`, ...)
/// costs the model's `default_unit_ns`.
pub const FITTED: [Work; 8] = [
    Work::TraceLeaves,
    Work::TraceObjects,
    Work::ClipNodes,
    Work::Shade,
    Work::ShadowPatches,
    Work::ShadowTested,
    Work::RaysSpawned,
    Work::ShadowBundles,
];

/// How well the model fitted the machine it was measured on (see
/// [`crate::experiment::calibrate::Calibration`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fit {
    /// Task steps sampled in the sequential runtime.
    pub steps: u64,
    /// Coefficient of determination over batches of 256 consecutive steps.
    pub r_squared: f64,
    /// Fitted fixed cost per step of the workload itself (not used by the
    /// simulator: `step_ns` comes from the threads run and includes it).
    pub intercept_ns: f64,
    /// Measured seconds of the sequential runtime's steps, and the fit's
    /// prediction of them.
    pub sequential_measured_s: f64,
    pub sequential_fitted_s: f64,
    /// One-processor threads run: CPU seconds of the whole process (master
    /// included; the least of the repeats), wall seconds (the least of the
    /// repeats), and framework steps.
    pub threads_s: f64,
    pub threads_wall_s: f64,
    pub threads_steps: u64,
}

/// The model file: the model and where it came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelFile {
    /// What the file is.
    pub about: String,
    /// The command that wrote it.
    pub command: String,
    /// The machine it was measured on (CPU, logical CPUs, OS), release build.
    pub machine: String,
    /// The day it was measured (UTC, `YYYY-MM-DD`).
    pub date: String,
    /// Scene and image of the calibration runs.
    pub scene: String,
    pub width: usize,
    pub height: usize,
    pub fit: Fit,
    /// The costs the simulator charges (ns of the machine above).
    pub model: CostModel,
    /// The parts of `model` that are not fitted: field name -> its source.
    pub assumed: BTreeMap<String, String>,
}

impl ModelFile {
    /// Parses a model file and checks it names exactly the fitted kinds
    /// (a misspelt or missing kind would otherwise cost the default,
    /// silently) with finite, non-negative costs.
    pub fn parse(text: &str) -> Result<Self, String> {
        let f: ModelFile = serde_json::from_str(text)
            .map_err(|e| format!("line {}, column {}: {e}", e.line(), e.column()))?;
        f.model.check::<Work>().map_err(|e| e.to_string())?;
        for k in FITTED {
            if !f.model.unit_ns.contains_key(k.name()) {
                return Err(format!("unit_ns lacks the fitted kind {:?}", k.name()));
            }
        }
        if let Some(k) = f
            .model
            .unit_ns
            .keys()
            .find(|k| !FITTED.iter().any(|w| w.name() == k.as_str()))
        {
            return Err(format!(
                "unit_ns prices {k:?}, which the calibration does not fit"
            ));
        }
        let m = &f.model;
        let all = m.unit_ns.values().copied().chain([
            m.default_unit_ns,
            m.step_ns,
            m.master_step_ns,
            m.cache_byte_ns,
        ]);
        if all.clone().any(|v| !(v.is_finite() && v >= 0.0)) {
            return Err("every cost must be finite and non-negative".into());
        }
        Ok(f)
    }
}

/// The committed model file, parsed once.
pub fn committed() -> &'static ModelFile {
    static FILE: OnceLock<ModelFile> = OnceLock::new();
    FILE.get_or_init(|| {
        // The file is compiled in and checked by this module's tests, so a
        // failure here is a build of a broken commit, not bad user input.
        ModelFile::parse(MODEL_JSON).unwrap_or_else(|e| panic!("{MODEL_PATH} (compiled in): {e}"))
    })
}

/// The committed cost of one unit of `kind` (the default for kinds that
/// are not fitted: counters that are not work).
pub fn unit_ns(kind: Work) -> f64 {
    let m = &committed().model;
    m.unit_ns
        .get(kind.name())
        .copied()
        .unwrap_or(m.default_unit_ns)
}

/// The committed cost model (see the module documentation).
pub fn model() -> CostModel {
    committed().model.clone()
}

/// What `model` predicts, in ns of its machine, for a processor's work
/// counts and framework steps (no network costs).
pub fn predict_ns(model: &CostModel, work: &BTreeMap<String, u64>, steps: u64) -> f64 {
    work.iter()
        .map(|(k, &v)| {
            v as f64
                * model
                    .unit_ns
                    .get(k)
                    .copied()
                    .unwrap_or(model.default_unit_ns)
        })
        .sum::<f64>()
        + steps as f64 * model.step_ns
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_committed_file_prices_each_fitted_kind_and_only_those() {
        let f = ModelFile::parse(MODEL_JSON).expect("the committed model parses");
        assert_eq!(f.model.unit_ns.len(), FITTED.len());
        for k in FITTED {
            assert_eq!(unit_ns(k), f.model.unit_ns[k.name()]);
        }
        assert_eq!(unit_ns(Work::RaysRetired), f.model.default_unit_ns);
        // The step cost is a residual and may be 0 (the fitted work can
        // exceed the threads run's time: book/src/simulation.md); the
        // shading is always priced.
        assert!(
            f.model.step_ns.is_finite() && f.model.step_ns >= 0.0,
            "step cost {}",
            f.model.step_ns
        );
        assert!(unit_ns(Work::Shade) > 0.0, "a refit that priced no shading");
        for field in ["master_step_ns", "cache_byte_ns", "default_unit_ns"] {
            assert!(f.assumed.contains_key(field), "{field} has no source");
        }
    }

    #[test]
    fn a_broken_model_file_is_refused_with_the_reason() {
        let good: serde_json::Value = serde_json::from_str(MODEL_JSON).unwrap();
        let mut v = good.clone();
        v["model"]["unit_ns"]["trace.leavs"] = 1.0.into();
        let e = ModelFile::parse(&v.to_string()).unwrap_err();
        assert!(e.contains("trace.leavs"), "{e}");
        let mut v = good.clone();
        v["model"]["unit_ns"]
            .as_object_mut()
            .unwrap()
            .remove("shade");
        let e = ModelFile::parse(&v.to_string()).unwrap_err();
        assert!(e.contains("shade"), "{e}");
        let mut v = good.clone();
        v["model"]["step_ns"] = (-1.0).into();
        assert!(ModelFile::parse(&v.to_string()).is_err());
        let e = ModelFile::parse("{\n  \"about\": 3\n}").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
    }

    #[test]
    fn prediction_is_work_at_unit_prices_plus_steps() {
        let m = CostModel {
            unit_ns: [("shade".to_string(), 10.0)].into_iter().collect(),
            default_unit_ns: 0.0,
            step_ns: 100.0,
            master_step_ns: 0.0,
            cache_byte_ns: 0.0,
        };
        let work: BTreeMap<String, u64> = [("shade".to_string(), 3), ("rays.retired".into(), 7)]
            .into_iter()
            .collect();
        assert_eq!(predict_ns(&m, &work, 2), 230.0);
    }
}
