//! Where unit tests find Radiance's regression scenes
//! (`../shared/scenes/radiance-tests`, beside the checkout). Tests that
//! need them skip, with a line saying so, when they are absent.

use std::path::PathBuf;

use crate::geometry::{Object, Shape, Vec3};

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

// Small random scenes for the octree, clipping and partition tests.

pub(crate) fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}

pub(crate) fn obj(shape: Shape) -> Object {
    Object {
        name: String::new(),
        shape,
        material: 0,
    }
}

/// Deterministic generator in [0, 1).
pub(crate) fn lcg(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((s >> 11) as f64) / ((1u64 << 53) as f64)
    }
}

/// `n` random small triangles and spheres in the box `[0, size]^3`.
pub(crate) fn random_scene(seed: u64, n: usize, size: f64) -> Vec<Object> {
    let mut rnd = lcg(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let c = v(rnd(), rnd(), rnd()) * size;
        let r = (0.005 + 0.04 * rnd()) * size;
        let shape = if rnd() < 0.7 {
            let mut p = || c + v(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * r * 4.0;
            let (a, b, d) = (p(), p(), p());
            Shape::polygon(vec![a, b, d])
        } else {
            Shape::sphere(c, r, false)
        };
        if let Ok(s) = shape {
            out.push(obj(s));
        }
    }
    out
}
