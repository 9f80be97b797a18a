//! The committed accuracy sweeps (`experiments/sweep/*`, shown in the
//! book's "What accuracy costs" chapter) are what the code measures now.
//!
//! A sweep's times are measured on the wall clock of whatever machine ran
//! it, so the files cannot be rewritten byte for byte. What can go stale
//! is checked instead:
//!
//! - the configurations (names and every option) are today's
//!   [`configurations`] and [`reference_options`] (with the command's
//!   overrides): adding, removing or changing one fails here;
//! - `sweep.md`, `sweep.csv` and `sweep.svg` are what the code writes from
//!   the committed `sweep.json`, and the book's figure is that `sweep.svg`;
//! - the pictures: on the Cornell box, two configurations are rendered
//!   again at the sweep's size and their errors against the committed
//!   reference equal the committed ones (to 1e-3: the reference is stored
//!   as RGBE). A renderer change that moves the errors fails here, and the
//!   sweeps are rerun with the commands in the book.

use std::path::{Path, PathBuf};

use hybrid_rt::experiment::sweep::{configurations, image_error, reference_options, SweepReport};
use hybrid_rt::image::compare::Reference;
use hybrid_rt::render::Renderer;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The committed sweeps: directory, the book's figure, and the reference
/// options the command added (`--quick-reference`, `--reference ...`).
const SWEEPS: &[(&str, &str, &str)] = &[
    ("cornell", "sweep-cornell.svg", ""),
    ("studio", "sweep-studio.svg", ""),
    ("conference", "sweep-conference.svg", "-dt 0.01"),
];

fn load(dir: &Path) -> SweepReport {
    let text = std::fs::read_to_string(dir.join("sweep.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
}

fn regenerate(what: &str) -> String {
    format!(
        "{what} is stale: rerun the sweep with the command in book/src/accuracy.md \
         and copy its sweep.svg to book/src/figures"
    )
}

#[test]
fn committed_sweeps_use_todays_configurations() {
    for (name, _, extra) in SWEEPS {
        let dir = repo().join("experiments/sweep").join(name);
        let report = load(&dir);
        let seed = report.reference.seed;
        let configs = configurations(seed);
        let names: Vec<&str> = report.points.iter().map(|p| p.name.as_str()).collect();
        let today: Vec<&str> = configs.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, today, "{}", regenerate(&format!("{name}: the list")));
        for (p, c) in report.points.iter().zip(&configs) {
            assert_eq!(
                p.options,
                c.options,
                "{}",
                regenerate(&format!("{name}: {}", p.name))
            );
        }
        let mut reference = reference_options(seed);
        reference.pn = 4;
        reference.aa = 0.1;
        reference.ar = 256;
        reference.ad = 256;
        reference.as_ = 64;
        if !extra.is_empty() {
            reference.apply_words(extra).unwrap();
        }
        assert_eq!(
            report.reference,
            reference,
            "{}",
            regenerate(&format!("{name}: the reference"))
        );
    }
}

#[test]
fn committed_sweep_files_are_written_from_their_json() {
    for (name, figure, _) in SWEEPS {
        let dir = repo().join("experiments/sweep").join(name);
        let report = load(&dir);
        let read = |f: &str| {
            std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{name}/{f}: {e}"))
        };
        assert_eq!(read("sweep.md"), report.markdown_file(), "{name}/sweep.md");
        assert_eq!(read("sweep.csv"), report.to_csv(), "{name}/sweep.csv");
        let tmp =
            std::env::temp_dir().join(format!("hybrid-rt-sweep-{}-{name}.svg", std::process::id()));
        report.chart().write_svg(&tmp).unwrap();
        let svg = std::fs::read(&tmp).unwrap();
        let _ = std::fs::remove_file(&tmp);
        assert!(
            svg == std::fs::read(dir.join("sweep.svg")).unwrap(),
            "{name}/sweep.svg is not what sweep.json plots"
        );
        let book = repo().join("book/src/figures").join(figure);
        assert!(
            svg == std::fs::read(&book).unwrap(),
            "{}: not {name}/sweep.svg",
            book.display()
        );
        // The chapter includes the table rather than copying it.
        let chapter = std::fs::read_to_string(repo().join("book/src/accuracy.md")).unwrap();
        let include = format!("{{{{#include ../../experiments/sweep/{name}/sweep.md}}}}");
        assert!(chapter.contains(&include), "accuracy.md lacks {include}");
    }
}

#[test]
fn cornell_sweep_errors_are_todays() {
    let dir = repo().join("experiments/sweep/cornell");
    let report = load(&dir);
    let reference = Reference::load(&dir.join("reference.hdr")).unwrap();
    let scene_path = repo().join("examples/scenes/cornell.rad");
    let scene = hybrid_rt::scene::load(&[&scene_path]).unwrap();
    let view_text = reference
        .view
        .clone()
        .expect("the reference names its view");
    let view = hybrid_rt::scene::View::from_options(&view_text).unwrap();
    for name in ["defaults", "preset draft"] {
        let p = report.points.iter().find(|p| p.name == name).unwrap();
        let renderer = Renderer::new(&scene, p.options.clone()).unwrap();
        let (film, _) = renderer.render(&view, report.width, report.height).unwrap();
        let (_, rel_rmse, mrle) = image_error(&film, &reference.film);
        assert!(
            (rel_rmse - p.rel_rmse).abs() < 1e-3 && (mrle - p.mean_rel_lum_err).abs() < 1e-3,
            "{}: now {rel_rmse:.5} and {mrle:.5}, committed {:.5} and {:.5}",
            regenerate(&format!("cornell: {name}")),
            p.rel_rmse,
            p.mean_rel_lum_err
        );
    }
}
