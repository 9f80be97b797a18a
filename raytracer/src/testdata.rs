//! Where unit tests find Radiance's regression scenes
//! (`../shared/scenes/radiance-tests`, beside the checkout). Tests that
//! need them skip, with a line saying so, when they are absent.

use std::path::PathBuf;

/// The suite's folder, whether or not it is there.
pub(crate) fn radiance_tests_dir() -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/scenes/radiance-tests"
    ))
}

/// The suite's folder, or `None` (and a line saying the test is skipped).
pub(crate) fn radiance_tests() -> Option<PathBuf> {
    let d = radiance_tests_dir();
    if d.is_dir() {
        Some(d)
    } else {
        eprintln!("skipped: {} is absent", d.display());
        None
    }
}

/// A file of the suite, or `None` (and a line saying the test is skipped).
pub(crate) fn radiance_test_file(name: &str) -> Option<PathBuf> {
    let p = radiance_tests_dir().join(name);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: {} not present", p.display());
        None
    }
}
