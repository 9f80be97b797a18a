//! `hybrid-rt experiment NAME`: the paper's experiments (see
//! [`crate::experiment`]) and the cost model's calibration.

use std::sync::Arc;

use crate::render::RenderOptions;
use crate::scene::{Scene, View};

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
    let name = match a.scene.as_str() {
        "cornell" | "studio" | "conference" => a.scene.clone(),
        _ => path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into()),
    };
    if a.name == ExperimentName::Calibrate {
        return calibrate_to(a, scene, options, &view, (w, h), name);
    }
    let setup = Setup {
        name,
        scene,
        view,
        options,
        options_words: options_words(&a.radiance),
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

/// The render options given, as Radiance writes them (`-ds 0.05 -dt 0`),
/// after the quality preset if one is named.
fn options_words(r: &super::args::RadianceArgs) -> String {
    let mut words: Vec<String> = r
        .quality
        .iter()
        .map(|q| format!("--quality {}", super::args::value_name(q)))
        .collect();
    for (name, values) in r.given() {
        words.push(
            std::iter::once(format!("-{name}"))
                .chain(values.iter().map(|v| v.to_string()))
                .collect::<Vec<_>>()
                .join(" "),
        );
    }
    words.join(" ")
}

/// `experiment calibrate`: fits the model on this machine, writes it to
/// `OUT/cost-model.json` and says how far the committed model is off.
fn calibrate_to(
    a: &ExperimentArgs,
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    (w, h): (u32, u32),
    name: String,
) -> Result<()> {
    let mut c = calibrate::calibrate(scene, options, view, w as usize, h as usize)?;
    c.file.scene = name;
    let args: Vec<String> = std::env::args().skip(1).collect();
    c.file.command = format!("hybrid-rt {}", args.join(" "));
    let text = serde_json::to_string_pretty(&c.file)
        .map_err(|e| crate::Error::Other(e.to_string()))?
        + "\n";
    std::fs::create_dir_all(&a.out).map_err(|e| crate::Error::io(&a.out, e))?;
    let path = a.out.join("cost-model.json");
    std::fs::write(&path, text).map_err(|e| crate::Error::io(&path, e))?;
    let f = &c.file.fit;
    eprintln!(
        "fitted {} steps: R^2 {:.3}; sequential steps {:.3} s measured, {:.3} s fitted; step cost {:.0} ns",
        f.steps, f.r_squared, f.sequential_measured_s, f.sequential_fitted_s, c.file.model.step_ns
    );
    eprintln!(
        "threads, 1 processor: {:.3} CPU s measured ({:.3} s wall; least of {}); the committed model ({}) predicts {:.3} s: {:+.1}%{}",
        c.threads_s,
        c.file.fit.threads_wall_s,
        calibrate::THREADS_RUNS,
        crate::parallel::cost::MODEL_PATH,
        c.committed_predicted_s,
        100.0 * c.committed_error,
        if c.needs_refit() {
            format!(
                ", past {:.0}%: refit (commit {} as {} and regenerate experiments/ with EXPERIMENTS.md's commands)",
                100.0 * calibrate::REFIT_ABOVE,
                path.display(),
                crate::parallel::cost::MODEL_PATH
            )
        } else {
            String::new()
        }
    );
    outln!("{}", path.display());
    Ok(())
}
