//! `hybrid-rt sweep`: what accuracy costs (see [`crate::experiment::sweep`]).

use std::io::Write;

use super::args::SweepArgs;
use super::common::usage;
use super::view::resolve_scene_view;
use crate::experiment::sweep::{configurations, option_words, reference_options, run as sweep};
use crate::image::{write_image, Exposure, HdrInfo, ToneMap, Transfer};
use crate::render::check_resolution;
use crate::scene;
use crate::{Error, Result};

pub(super) fn run(a: &SweepArgs) -> Result<()> {
    check_resolution(a.width as usize, a.height as usize)?;
    if a.out.exists() && !a.out.is_dir() {
        return Err(usage(format!(
            "--out {}: exists and is not a directory",
            a.out.display()
        )));
    }
    let (path, view) = resolve_scene_view(&a.scene, a.view_file.as_deref())?;
    let (view, w, h) = view.fit_aspect(a.width, a.height);
    let scene = scene::load(&[&path])?;
    std::fs::create_dir_all(&a.out).map_err(|e| Error::io(&a.out, e))?;
    let mut reference = reference_options(a.seed);
    if a.quick_reference {
        reference.pn = 4;
        reference.aa = 0.1;
        reference.ar = 256;
        reference.ad = 256;
        reference.as_ = 64;
    }
    if let Some(words) = &a.reference {
        reference.apply_words(words).map_err(|e| match e {
            Error::Usage(m) => usage(format!("--reference: {m}")),
            other => other,
        })?;
    }
    let name = path
        .file_stem()
        .map_or_else(|| a.scene.clone(), |s| s.to_string_lossy().into_owned());
    eprintln!(
        "sweep {name} at {w}x{h}; reference: {}",
        option_words(&reference)
    );
    let mut progress = |line: &str| {
        eprintln!("  {line}");
        let _ = std::io::stderr().flush();
    };
    let (report, ref_film) = sweep(
        &name,
        &scene,
        &view,
        w as usize,
        h as usize,
        reference,
        &configurations(a.seed),
        &mut progress,
    )?;
    let write = |file: &str, text: &str| -> Result<()> {
        let p = a.out.join(file);
        std::fs::write(&p, text).map_err(|e| Error::io(&p, e))
    };
    write("sweep.csv", &report.to_csv())?;
    let md = report.markdown_file();
    write("sweep.md", &md)?;
    report.chart().write_svg(&a.out.join("sweep.svg"))?;
    let json = serde_json::to_string_pretty(&report)
        .map_err(|e| Error::Other(format!("sweep report: {e}")))?;
    write("sweep.json", &(json + "\n"))?;
    write_image(
        &ref_film,
        &a.out.join("reference.hdr"),
        &ToneMap {
            exposure: Exposure::Auto,
            transfer: Transfer::Srgb,
        },
        &HdrInfo {
            view: Some(view.to_options()),
            software: Some(format!(
                "hybrid-rt {} sweep reference",
                env!("CARGO_PKG_VERSION")
            )),
        },
    )?;
    outln!("{md}");
    outln!("Pareto front (fastest first):");
    for p in report.front() {
        outln!(
            "  {:<22} {:>8.3} s  rel. RMSE {:.4}  {}",
            p.name,
            p.time_s,
            p.rel_rmse,
            option_words(&p.options)
        );
    }
    outln!("written to {}", a.out.display());
    Ok(())
}
