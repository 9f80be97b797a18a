//! `hybrid-rt experiment NAME`: the paper's experiments (see
//! [`crate::experiment`]) and the cost model's calibration.

use std::sync::Arc;

use super::args::{ExperimentArgs, ExperimentName};
use super::common::{options_from, usage};
use super::view::resolve_scene_view;
use crate::experiment::{self, calibrate, Setup};
use crate::render::check_resolution;
use crate::scene;
use crate::Result;

pub(super) fn run(a: &ExperimentArgs) -> Result<()> {
    check_resolution(a.width as usize, a.height as usize)?;
    check_resolution(a.cache_size as usize, a.cache_size as usize)?;
    if a.max_procs == 0 || a.detail_procs == 0 || a.cache_procs == 0 {
        return Err(usage("processor counts must be at least 1"));
    }
    if a.max_procs > 4096 || a.detail_procs > 4096 || a.cache_procs > 4096 {
        return Err(usage("processor counts above 4096 are not supported"));
    }
    let experiment_name = super::args::value_name(&a.name);
    let network = a.network.into();
    let options = options_from(&a.radiance, 0)?;
    let (path, view) = resolve_scene_view(&a.scene, a.view_file.as_deref())?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let (cview, cw, ch) = view.fit_aspect(a.cache_size, a.cache_size);
    let _ = cview;
    let scene = Arc::new(scene::load(&[&path])?);
    if a.name == ExperimentName::Calibrate {
        let c = calibrate::calibrate(scene, options, &view, w as usize, h as usize)?;
        let text =
            serde_json::to_string_pretty(&c).map_err(|e| crate::Error::Other(e.to_string()))?;
        outln!("{text}");
        eprintln!(
            "fitted {} steps: R^2 {:.3}; sequential steps {:.3} s measured, {:.3} s fitted; threads (1 proc) {:.3} s measured, built-in model {:.3} s",
            c.steps, c.r_squared, c.measured_s, c.predicted_s, c.threads_s, c.builtin_predicted_s
        );
        return Ok(());
    }
    let name = match a.scene.as_str() {
        "cornell" | "studio" | "conference" => a.scene.clone(),
        _ => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into()),
    };
    let setup = Setup {
        name,
        scene,
        view,
        options,
        width: w as usize,
        height: h as usize,
        small: (cw as usize, ch as usize),
        network,
        max_procs: a.max_procs,
        detail_procs: a.detail_procs,
        cache_procs: a.cache_procs,
        seed: a.seed,
    };
    let written = experiment::run(&experiment_name, &setup, &a.out)?;
    for o in written {
        outln!("{}", o.path.display());
    }
    Ok(())
}
