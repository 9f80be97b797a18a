//! `hybrid-rt render`.

use std::io::IsTerminal;
use std::path::Path;
use std::sync::Arc;

use indicatif::{ProgressBar, ProgressStyle};

use super::args::RenderArgs;
use super::{options_from, print_scene_warnings, usage};
use crate::image::Film;
use crate::image::{write_image, Exposure, HdrInfo, ImageFormat, ToneMap, Transfer};
use crate::parallel::{render_parallel_ranked, ParallelOptions};
use crate::render::{check_resolution, RenderOptions, Renderer};
use crate::scene::{self, View};
use crate::{Error, Result, SourceLoc};

/// The view from `--view-file`, then `--view`, then Radiance-style words.
pub(super) fn build_view(
    file: Option<&Path>,
    options: &[String],
    words: &[String],
) -> Result<View> {
    let mut view = match file {
        Some(f) => View::from_file(f)?,
        None => View::default(),
    };
    let mut given = file.is_some();
    let mut apply = |text: &str, what: &str| -> Result<()> {
        let loc = SourceLoc::new(what, 1);
        view.apply_options(text, &loc)?;
        view.validate().map_err(|r| Error::parse(loc, r))
    };
    for o in options {
        apply(o, "<--view>")?;
        given = true;
    }
    if !words.is_empty() {
        apply(&words.join(" "), "<command line>")?;
        given = true;
    }
    if !given {
        return Err(usage(
            "no view given: use --view-file FILE or --view \"-vtv -vp ... -vd ...\"",
        ));
    }
    Ok(view)
}

/// Exposure from `--exposure`: a plain multiplier or signed stops.
pub(super) fn parse_exposure(s: &str) -> Result<f64> {
    let bad = || {
        usage(format!(
            "--exposure {s:?}: expected a positive multiplier or signed stops like +1"
        ))
    };
    let t = s.trim();
    let v = if t.starts_with('+') || t.starts_with('-') {
        let stops: f64 = t.parse().map_err(|_| bad())?;
        2f64.powf(stops)
    } else {
        t.parse::<f64>().map_err(|_| bad())?
    };
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(bad())
    }
}

/// The checks [`run`] makes before it loads the scene (output type,
/// Radiance options, exposure, gamma, resolution, view, parallel
/// options), for [`super::check_command_line`].
pub(super) fn check(a: &RenderArgs) -> Result<()> {
    ImageFormat::from_path(&a.output)?;
    options_from(&a.radiance, a.seed)?;
    a.exposure.as_deref().map(parse_exposure).transpose()?;
    if let Some(g) = a.gamma {
        if !(g.is_finite() && g > 0.0) {
            return Err(usage(format!("--gamma {g}: must be a positive number")));
        }
    }
    check_resolution(a.width as usize, a.height as usize)?;
    let view = build_view(a.view_file.as_deref(), &a.view, &a.view_words)?;
    let (_, width, height) = view.fit_aspect(a.width, a.height);
    check_resolution(width as usize, height as usize)?;
    super::parallel::resolve(&a.parallel)?;
    Ok(())
}

pub(super) fn run(a: &RenderArgs) -> Result<()> {
    // Check everything cheap before the expensive work.
    ImageFormat::from_path(&a.output)?;
    let options = options_from(&a.radiance, a.seed)?;
    let exposure = a.exposure.as_deref().map(parse_exposure).transpose()?;
    if let Some(g) = a.gamma {
        if !(g.is_finite() && g > 0.0) {
            return Err(usage(format!("--gamma {g}: must be a positive number")));
        }
    }
    check_resolution(a.width as usize, a.height as usize)?;
    let view = build_view(a.view_file.as_deref(), &a.view, &a.view_words)?;
    let (view, width, height) = view.fit_aspect(a.width, a.height);
    let (width, height) = (width as usize, height as usize);
    check_resolution(width, height)?;

    let popts = super::parallel::resolve(&a.parallel)?;
    let t0 = std::time::Instant::now();
    let scene = Arc::new(scene::load(&a.scenes)?);
    print_scene_warnings(&scene);
    tracing::info!(
        objects = scene.stats.objects,
        lights = scene.lights.len(),
        seconds = t0.elapsed().as_secs_f64(),
        "scene loaded"
    );
    if let Some(popts) = popts {
        if options.ab > 0 {
            return run_ambient_parallel(
                a, &scene, options, &view, width, height, &popts, exposure,
            );
        }
        return run_parallel(a, scene, options, &view, width, height, &popts, exposure);
    }
    let renderer = Renderer::new(&scene, options)?;
    for w in renderer.warnings() {
        eprintln!("warning: {w}");
    }
    tracing::info!(effects = ?renderer.effects(), "effects");

    let bar = if std::io::stderr().is_terminal() && width * height >= 64 * 64 {
        let b = ProgressBar::new(height as u64);
        if let Ok(style) = ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {pos}/{len} rows {elapsed_precise} (eta {eta})",
        ) {
            b.set_style(style.progress_chars("=> "));
        }
        b
    } else {
        ProgressBar::hidden()
    };
    let (film, stats) = renderer.render_with_progress(&view, width, height, &mut |rows| {
        bar.set_position(rows as u64)
    })?;
    bar.finish_and_clear();

    write_film(a, &film, &view, exposure)?;
    if let Some(path) = &a.stats {
        write_json(path, &stats)?;
    }
    print_pattern_errors(&stats.pattern_errors);
    tracing::info!(
        width,
        height,
        seconds = stats.time.render_s,
        primary = stats.rays.primary,
        shadow = stats.rays.shadow.tested,
        "rendered {}",
        a.output.display()
    );
    Ok(())
}

/// One line for pattern evaluations that went wrong (Radiance prints a
/// "compute error" per ray; a real scene would print millions).
pub(super) fn print_pattern_errors(e: &crate::render::stats::PatternErrors) {
    if e.is_empty() {
        return;
    }
    eprintln!(
        "warning: pattern functions: {} math errors (read as 0), {} NaN results and {} failed evaluations (pattern ignored){}",
        e.math_errors,
        e.nans,
        e.failures,
        e.first
            .as_deref()
            .map(|f| format!("; first: {f}"))
            .unwrap_or_default()
    );
}

fn write_film(a: &RenderArgs, film: &Film, view: &View, exposure: Option<f64>) -> Result<()> {
    let tone = ToneMap {
        exposure: exposure.map_or(Exposure::Auto, Exposure::Fixed),
        transfer: a.gamma.map_or(Transfer::Srgb, Transfer::Gamma),
    };
    let info = HdrInfo {
        view: Some(view.to_options()),
        software: Some(format!("hybrid-rt {}", env!("CARGO_PKG_VERSION"))),
    };
    write_image(film, &a.output, &tone, &info)
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_string_pretty(value)
        .map_err(|e| Error::Other(format!("statistics: {e}")))?;
    std::fs::write(path, json + "\n").map_err(|e| Error::io(path, e))
}

/// The `--procs` path: the hybrid-scheduled renderer.
#[allow(clippy::too_many_arguments)]
fn run_parallel(
    a: &RenderArgs,
    scene: Arc<scene::Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
    exposure: Option<f64>,
) -> Result<()> {
    let Some(out) = render_parallel_ranked(scene, options, view, width, height, popts)? else {
        // An MPI rank other than 0: rank 0 writes the picture and reports.
        return Ok(());
    };
    eprint!("{}", super::parallel::summary(&out));
    write_film(a, &out.film, view, exposure)?;
    if let Some(path) = &a.parallel.parallel_stats {
        write_json(path, &out)?;
    }
    if a.stats.is_some() {
        eprintln!(
            "warning: --stats describes sequential renders; use --parallel-stats with --procs"
        );
    }
    Ok(())
}

/// `--procs` with `-ab`: the threaded irradiance-cache renderer.
#[allow(clippy::too_many_arguments)]
fn run_ambient_parallel(
    a: &RenderArgs,
    scene: &scene::Scene,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
    popts: &ParallelOptions,
    exposure: Option<f64>,
) -> Result<()> {
    use crate::parallel::ambient::{render_ambient_parallel, AmbientParallelOptions};
    let mode = a.parallel.hemispheres.parse().map_err(usage)?;
    let opts = AmbientParallelOptions {
        procs: popts.procs,
        mode,
        tile: a.parallel.tile,
    };
    let out = render_ambient_parallel(scene, options, view, width, height, &opts)?;
    eprintln!(
        "parallel inter-reflection: {} processors, hemispheres {}: {:.3} s; {} hemispheres ({} redundant), {} hemisphere rays, {} pixels retraced, {} waits, {:.3} s idle, {} records",
        opts.procs,
        opts.mode,
        out.render_s,
        out.hemispheres,
        out.redundant,
        out.hemisphere_tasks,
        out.retraced_pixels,
        out.waits,
        out.idle_s,
        out.records
    );
    write_film(a, &out.film, view, exposure)?;
    if let Some(path) = a.parallel.parallel_stats.as_ref().or(a.stats.as_ref()) {
        write_json(path, &out)?;
    }
    Ok(())
}
