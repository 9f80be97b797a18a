//! `hybrid-rt render`.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::args::RenderArgs;
use super::common::{options_from, print_scene_warnings, usage};
use super::console::{summary_line, Progress, Rays};
use super::view::{build_view, default_view};
use crate::image::Film;
use crate::image::{
    encode_image, write_image, Exposure, HdrInfo, ImageFormat, Reinhard, ToneMap, ToneOperator,
    Transfer,
};
use crate::parallel::{render_parallel_with_progress, ParallelOptions};
use crate::render::{check_resolution, RenderOptions, Renderer};
use crate::scene::{self, View};
use crate::{Error, Result};

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

/// True when the picture goes to standard output (no `-o`, or `-o -`).
fn to_stdout(a: &RenderArgs) -> bool {
    a.output.as_deref().is_none_or(|p| p == Path::new("-"))
}

/// The output's name for messages.
fn output_name(a: &RenderArgs) -> String {
    match &a.output {
        Some(p) if !to_stdout(a) => p.display().to_string(),
        _ => "<standard output>".into(),
    }
}

/// `-e FILE`: standard error (every diagnostic: warnings, errors, log
/// output) appended to `path` from now on, as rpict's `-e`.
#[cfg(unix)]
fn redirect_stderr(path: &Path) -> Result<()> {
    use std::os::unix::io::AsRawFd;
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| Error::io(path, e))?;
    // SAFETY: dup2 on two open descriptors; `file` stays open until dup2
    // has returned, and descriptor 2 then refers to the file by itself.
    if unsafe { libc::dup2(file.as_raw_fd(), 2) } < 0 {
        return Err(Error::io(path, std::io::Error::last_os_error()));
    }
    Ok(())
}

#[cfg(not(unix))]
fn redirect_stderr(path: &Path) -> Result<()> {
    Err(usage(format!(
        "-e {}: an error file is supported on Unix only; redirect standard error instead",
        path.display()
    )))
}

/// Whether a view is given on the command line (`-vf`, `--view`, `-v...`).
fn view_given(a: &RenderArgs) -> bool {
    a.view_file.is_some() || !a.view.is_empty() || !a.view_words.is_empty()
}

/// The checks [`run`] makes before it loads the scene (output type,
/// Radiance options, exposure, tone, gamma, resolution, a given view,
/// parallel options); also [`super::check_command_line`]'s.
pub(super) fn check(a: &RenderArgs) -> Result<()> {
    if let Some(path) = a.output.as_deref().filter(|_| !to_stdout(a)) {
        ImageFormat::from_path(path)?;
    }
    options_from(&a.radiance, a.seed)?;
    let exposure = a.exposure.as_deref().map(parse_exposure).transpose()?;
    if let Some(g) = a.gamma {
        if !(g.is_finite() && g > 0.0) {
            return Err(usage(format!("--gamma {g}: must be a positive number")));
        }
    }
    tone_map(a, exposure)?;
    check_resolution(a.width as usize, a.height as usize)?;
    if view_given(a) {
        let view = build_view(a.view_file.as_deref(), &a.view, &a.view_words)?;
        let (_, width, height) = view.fit_aspect(a.width, a.height);
        check_resolution(width as usize, height as usize)?;
    }
    super::parallel::resolve(&a.parallel)?;
    Ok(())
}

pub(super) fn run(a: &RenderArgs) -> Result<()> {
    let r = render(a);
    if a.parallel.peak_memory {
        print_peak_memory(a);
    }
    r
}

/// This process's peak resident memory, as `--peak-memory` prints it.
fn print_peak_memory(a: &RenderArgs) {
    #[cfg(feature = "mpi")]
    let rank = match a.parallel.runtime {
        super::args::RuntimeArg::Mpi => hybrid_sched::runtime::mpi::last_world()
            .map(|w| format!("rank {}: ", w.rank))
            .unwrap_or_default(),
        _ => String::new(),
    };
    #[cfg(not(feature = "mpi"))]
    let rank = {
        let _ = a;
        String::new()
    };
    let line = match crate::report::peak_resident_bytes() {
        Some(b) => format!("{rank}peak resident memory: {} KiB\n", b / 1024),
        None => format!("{rank}peak resident memory: not measured on this system\n"),
    };
    // One write for the whole line: `eprintln!` writes its pieces one by
    // one to the unbuffered stderr, and under `mpirun` another rank's line
    // could land between them ("rank 2: rank 3: peak ...").
    use std::io::Write;
    let _ = std::io::stderr().lock().write_all(line.as_bytes());
}

fn render(a: &RenderArgs) -> Result<()> {
    let start = Instant::now();
    if let Some(path) = &a.error_file {
        redirect_stderr(path)?;
    }
    if to_stdout(a) && std::io::IsTerminal::is_terminal(&std::io::stdout()) {
        return Err(usage(
            "standard output is a terminal: give -o FILE, or redirect the picture (hybrid-rt render ... > picture.hdr)",
        ));
    }
    // Everything cheap is checked before the expensive work.
    check(a)?;
    let options = options_from(&a.radiance, a.seed)?;
    let exposure = a.exposure.as_deref().map(parse_exposure).transpose()?;
    let view = if view_given(a) {
        Some(build_view(a.view_file.as_deref(), &a.view, &a.view_words)?)
    } else {
        default_view(&a.scenes)?
    };

    let mut popts = super::parallel::resolve(&a.parallel)?;
    if let Some(p) = popts.as_mut().filter(|_| a.parallel.tile.is_none()) {
        p.workload.tile = crate::parallel::hemisphere_tile(&options, p.workload.tile);
    }
    let ambient_file = ambient_file(a, &options)?;
    if let (Some(p), Some(f)) = (popts.as_mut(), &ambient_file) {
        p.ambient_records = Arc::new(f.records.clone());
    }
    if let Some(popts) = popts.as_ref().filter(|p| distributes(a, p, &options)) {
        let Some(view) = view else {
            return Err(usage(
                "a distributed render of a compiled scene needs a view: give one (-vf, -vp ...) or compile the scene with one",
            ));
        };
        let file = ambient_file.as_ref();
        return run_held(a, options, view, popts, exposure, start, file);
    }
    let t0 = std::time::Instant::now();
    let scene = Arc::new(crate::compiled::load(&a.scenes)?);
    print_scene_warnings(&scene);
    let view = match view {
        Some(v) => v,
        None => {
            let b = scene.bounds();
            let v = View::framing(b.min, b.max, a.up.vector());
            eprintln!(
                "view: framing the scene's bounds, up {}: {}",
                super::args::value_name(&a.up),
                v.to_options()
            );
            v
        }
    };
    let (view, width, height) = view.fit_aspect(a.width, a.height);
    let (width, height) = (width as usize, height as usize);
    check_resolution(width, height)?;
    let bounds = scene.bounds();
    tracing::info!(
        objects = scene.stats.objects,
        primitives = scene.stats.primitives,
        instances = scene.stats.instances,
        materials = scene.stats.materials,
        lights = scene.lights.len(),
        bounds = ?(bounds.min.to_array(), bounds.max.to_array()),
        seconds = t0.elapsed().as_secs_f64(),
        "scene loaded"
    );
    tracing::debug!(?options, width, height, view = %view.to_options(), "render options");
    if let Some(popts) = popts {
        tracing::debug!(?popts, "parallel options");
        let file = ambient_file.as_ref();
        return run_parallel(
            a,
            scene,
            options,
            &view,
            (width, height),
            &popts,
            exposure,
            start,
            file,
        );
    }
    let renderer = Renderer::new(&scene, options)?.with_effect_times(a.stats.is_some());
    for w in renderer.warnings() {
        eprintln!("warning: {w}");
    }
    tracing::info!(effects = ?renderer.effects(), "effects");

    let cache = match &ambient_file {
        Some(f) => renderer.ambient_cache(&f.records),
        None => Default::default(),
    };
    let loaded = cache.len();
    let progress = Progress::start(height as u64, "rows", a.report, width * height >= 64 * 64);
    let (film, stats, cache) = renderer.render_with_cache(
        &view,
        width,
        height,
        &mut |rows| progress.set(rows as u64),
        cache,
    )?;
    progress.finish();
    if let Some(f) = &ambient_file {
        f.append(renderer.options(), &cache.records_since(loaded))?;
    }

    write_film(a, &film, &view, exposure)?;
    eprintln!(
        "{}",
        summary_line(
            width,
            height,
            start.elapsed().as_secs_f64(),
            stats.time.render_s,
            Rays::from(&stats.rays),
            &stats.effects.enabled_names(),
        )
    );
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
        output_name(a)
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

/// The tone map of `--tone`, `--tone-white`, `--exposure` and `--gamma`:
/// Reinhard's operator unless `--exposure` is given or `--tone exposure`
/// asked for (then a fixed or, without `--exposure`, automatic exposure).
pub(super) fn tone_map(a: &RenderArgs, exposure: Option<f64>) -> Result<ToneMap> {
    let op = a.tone.unwrap_or(if exposure.is_some() {
        ToneOperator::Exposure
    } else {
        ToneOperator::Reinhard
    });
    if let Some(p) = a.tone_white {
        if !(p.is_finite() && p > 0.0 && p <= 100.0) {
            return Err(usage(format!(
                "--tone-white {p}: expected a percentile above 0 and at most 100"
            )));
        }
        if op != ToneOperator::Reinhard {
            return Err(usage("--tone-white applies to --tone reinhard"));
        }
    }
    let exposure = match op {
        ToneOperator::Reinhard => {
            if exposure.is_some() {
                return Err(usage(
                    "--exposure applies to --tone exposure (Reinhard's operator chooses its own scale)",
                ));
            }
            Exposure::Reinhard(Reinhard {
                white_percentile: a.tone_white.unwrap_or(100.0),
                ..Reinhard::default()
            })
        }
        ToneOperator::Exposure => exposure.map_or(Exposure::Auto, Exposure::Fixed),
    };
    Ok(ToneMap {
        exposure,
        transfer: a.gamma.map_or(Transfer::Srgb, Transfer::Gamma),
    })
}

fn write_film(a: &RenderArgs, film: &Film, view: &View, exposure: Option<f64>) -> Result<()> {
    let tone = tone_map(a, exposure)?;
    if exposure.is_some()
        && matches!(
            a.output.as_deref().map(ImageFormat::from_path),
            Some(Ok(ImageFormat::Exr | ImageFormat::Pfm))
        )
    {
        eprintln!("warning: --exposure does not apply to EXR and PFM output (written unscaled)");
    }
    let info = HdrInfo {
        view: Some(view.to_options()),
        software: Some(format!("hybrid-rt {}", env!("CARGO_PKG_VERSION"))),
    };
    match &a.output {
        Some(path) if !to_stdout(a) => write_image(film, path, &tone, &info),
        // A Radiance picture on standard output, as rpict writes it.
        _ => {
            use std::io::Write;
            let name = Path::new("<standard output>");
            let mut w = std::io::BufWriter::new(std::io::stdout().lock());
            encode_image(film, ImageFormat::Hdr, &tone, &info, &mut w)
                .and_then(|()| w.flush())
                .map_err(|e| Error::io(name, e))
        }
    }
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_string_pretty(value)
        .map_err(|e| Error::Other(format!("statistics: {e}")))?;
    std::fs::write(path, json + "\n").map_err(|e| Error::io(path, e))
}

/// Whether this render reads a compiled scene processor by processor: a
/// compiled scene, rendered in parallel with a distribution that gives
/// each processor its own cells (`octree`, `worst`, and `predicted` by the
/// work predicted when the scene was compiled), without `-ab` or with the
/// diffuse inter-reflection the hybrid workload computes (no cache:
/// [`crate::parallel::hybrid_interreflection`]).
fn distributes(a: &RenderArgs, popts: &ParallelOptions, options: &RenderOptions) -> bool {
    would_distribute(a, popts)
        && (options.ab == 0 || crate::parallel::hybrid_interreflection(options))
}

/// A compiled scene with a distribution that gives each processor its
/// own cells: read processor by processor unless `-ab` asks for diffuse
/// inter-reflection with a cache, which runs on the
/// scene loaded whole.
fn would_distribute(a: &RenderArgs, popts: &ParallelOptions) -> bool {
    use crate::parallel::Distribution;
    matches!(a.scenes.as_slice(), [one] if crate::compiled::is_compiled(one))
        && matches!(
            popts.workload.distribution,
            Distribution::Octree | Distribution::Worst | Distribution::Predicted
        )
}

/// A parallel render of a compiled scene in which every processor holds
/// the replicated part and reads only its own cells.
fn run_held(
    a: &RenderArgs,
    options: RenderOptions,
    view: View,
    popts: &ParallelOptions,
    exposure: Option<f64>,
    start: Instant,
    ambient_file: Option<&AmbientFileUse>,
) -> Result<()> {
    let file = ambient_file.map(|f| (f, options.clone()));
    let compiled = crate::compiled::CompiledScene::open(&a.scenes[0])?;
    let part = compiled.held_part(&crate::scene::LoadOptions::from_env())?;
    print_scene_warnings(&part.scene);
    let (view, width, height) = view.fit_aspect(a.width, a.height);
    let (width, height) = (width as usize, height as usize);
    check_resolution(width, height)?;
    let progress = Progress::start((width * height) as u64, "pixels", a.report, true);
    let out = crate::parallel::render_parallel_held(
        part,
        options,
        &view,
        width,
        height,
        popts,
        Some(progress.counter()),
    );
    progress.finish();
    let done = Finish {
        view: &view,
        size: (width, height),
        exposure,
        start,
        ambient_file: file,
    };
    finish_parallel(a, out?, done)
}

/// The `--procs` path: the hybrid-scheduled renderer.
#[allow(clippy::too_many_arguments)]
fn run_parallel(
    a: &RenderArgs,
    scene: Arc<scene::Scene>,
    options: RenderOptions,
    view: &View,
    (width, height): (usize, usize),
    popts: &ParallelOptions,
    exposure: Option<f64>,
    start: Instant,
    ambient_file: Option<&AmbientFileUse>,
) -> Result<()> {
    let file = ambient_file.map(|f| (f, options.clone()));
    let progress = Progress::start((width * height) as u64, "pixels", a.report, true);
    let out = render_parallel_with_progress(
        scene,
        options,
        view,
        width,
        height,
        popts,
        Some(progress.counter()),
    );
    progress.finish();
    let done = Finish {
        view,
        size: (width, height),
        exposure,
        start,
        ambient_file: file,
    };
    finish_parallel(a, out?, done)
}

/// What writing a parallel render's picture needs besides the render.
struct Finish<'a> {
    view: &'a View,
    size: (usize, usize),
    exposure: Option<f64>,
    start: Instant,
    /// `-af`: the file and the options to write its header with.
    ambient_file: Option<(&'a AmbientFileUse, RenderOptions)>,
}

/// Writes a parallel render's picture and reports (rank 0 only), and
/// appends the records the render made to the ambient file (`-af`).
fn finish_parallel(
    a: &RenderArgs,
    out: Option<crate::parallel::ParallelRender>,
    done: Finish<'_>,
) -> Result<()> {
    let Some(out) = out else {
        // An MPI rank other than 0: rank 0 writes the picture and reports.
        return Ok(());
    };
    let Finish {
        view,
        size: (width, height),
        exposure,
        start,
        ambient_file,
    } = done;
    eprint!("{}", super::parallel::summary(&out));
    if let Some(s) = &out.ambient {
        if let Some((f, o)) = &ambient_file {
            f.append(o, &s.new_records)?;
        }
    }
    write_film(a, &out.film, view, exposure)?;
    {
        use crate::parallel::Work;
        let rays = Rays {
            primary: out.work(Work::RaysPrimary),
            shadow: out.work(Work::ShadowTested) + out.work(Work::ShadowSegments),
            other: out.work(Work::RaysReflection)
                + out.work(Work::RaysRefraction)
                + out.work(Work::RaysPassThrough)
                + out.work(Work::RaysAmbient),
        };
        eprintln!(
            "{}",
            summary_line(
                width,
                height,
                start.elapsed().as_secs_f64(),
                out.render_s,
                rays,
                &out.effects.enabled_names(),
            )
        );
    }
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

/// Radiance's `-af FILE` for one render: the records it held when the
/// render started, and where the new ones go.
#[derive(Debug)]
struct AmbientFileUse {
    path: std::path::PathBuf,
    records: Vec<crate::render::ambient::AmbientRecord>,
}

impl AmbientFileUse {
    /// Appends the render's new records (creating the file if needed) and
    /// says how many.
    fn append(
        &self,
        options: &RenderOptions,
        records: &[crate::render::ambient::AmbientRecord],
    ) -> Result<()> {
        crate::render::ambient::append_ambient_file(&self.path, options, records)?;
        eprintln!(
            "ambient file {}: {} records read, {} added",
            self.path.display(),
            self.records.len(),
            records.len()
        );
        Ok(())
    }
}

/// `-af FILE`: its records if it exists (read as Radiance does: a damaged
/// record ends the reading with a warning). Nothing where the render keeps
/// no cache (`-ab 0` or `-aa 0`, where Radiance does not open the file
/// either), with a warning.
fn ambient_file(a: &RenderArgs, options: &RenderOptions) -> Result<Option<AmbientFileUse>> {
    let Some(name) = &a.radiance.af else {
        return Ok(None);
    };
    if options.ab == 0 || options.aa <= 0.0 {
        eprintln!(
            "warning: -af {name}: not opened (no irradiance cache with -ab {} -aa {})",
            options.ab, options.aa
        );
        return Ok(None);
    }
    let path = std::path::PathBuf::from(name);
    let records = if path.exists() {
        let file = crate::render::ambient::read_ambient_file(&path)?;
        for w in &file.warnings {
            eprintln!("warning: {w}");
        }
        file.records
    } else {
        Vec::new()
    };
    Ok(Some(AmbientFileUse { path, records }))
}
