//! Figures measured by `scripts/device-scaling.sh`: on the 16-core device
//! machine (`experiments/device/`) and, for a scene of several GiB, on this
//! project's 2-core machines (`experiments/large-scene/`). They take too
//! long or too many cores to measure again in a test, but what the book
//! shows of them is what the raw outputs say. Each folder's `tables.md` must be what
//! `scripts/device-tables.sh` makes of the folder's raw files, every run
//! in them must have succeeded with the sequential picture, and the book
//! must include the tables rather than copy them.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Folders holding a run's outputs (a `machine.txt`).
fn runs() -> Vec<PathBuf> {
    fn walk(dir: &Path, found: &mut Vec<PathBuf>) {
        if !dir.is_dir() {
            return;
        }
        if dir.join("machine.txt").is_file() {
            found.push(dir.to_path_buf());
        }
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir())
            .collect();
        entries.sort();
        for e in entries {
            walk(&e, found);
        }
    }
    let mut found = Vec::new();
    walk(&workspace().join("experiments/device"), &mut found);
    walk(&workspace().join("experiments/large-scene"), &mut found);
    found
}

#[test]
fn device_tables_are_what_the_raw_outputs_say() {
    let runs = runs();
    assert!(!runs.is_empty(), "no device run under experiments/device");
    for dir in runs {
        let out = Command::new("bash")
            .arg(workspace().join("scripts/device-tables.sh"))
            .arg(&dir)
            .output()
            .expect("bash runs");
        assert!(
            out.status.success(),
            "device-tables.sh {}: {}",
            dir.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        let committed = std::fs::read(dir.join("tables.md")).unwrap();
        assert!(
            out.stdout == committed,
            "{}/tables.md is not what scripts/device-tables.sh makes of the raw files: \
             rerun `bash scripts/device-tables.sh {0} > {0}/tables.md`",
            dir.display()
        );
    }
}

#[test]
fn every_device_run_succeeded_with_the_sequential_picture() {
    for dir in runs() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if !name.ends_with(".txt") || name == "machine.txt" {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            if name.starts_with("threads-") {
                assert!(
                    text.contains("every picture equals the sequential one bit for bit"),
                    "{}: the bench did not finish",
                    path.display()
                );
            }
            for line in text.lines().filter(|l| l.contains(" | -np ")) {
                if name.starts_with("mpi-studio-2cores") {
                    assert!(line.contains("(render "), "{}: {line}", path.display());
                } else {
                    // "what | -np N | rc R | wall | render | peak | equal"
                    // and, in later runs, " | bound MiB ...".
                    let fields: Vec<&str> = line.split(" | ").collect();
                    assert!(
                        fields.get(2) == Some(&"rc 0") && fields.get(6) == Some(&"equal"),
                        "{}: {line}",
                        path.display()
                    );
                }
            }
        }
    }
}

#[test]
fn the_book_includes_the_device_tables() {
    let book = workspace().join("book/src");
    let mut chapters = String::new();
    for entry in std::fs::read_dir(&book).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            chapters += &std::fs::read_to_string(path).unwrap();
        }
    }
    for dir in runs() {
        let rel = dir.strip_prefix(workspace()).unwrap().display().to_string();
        let include = format!("{{{{#include ../../{rel}/tables.md}}}}");
        assert!(chapters.contains(&include), "no chapter has {include}");
    }
}
