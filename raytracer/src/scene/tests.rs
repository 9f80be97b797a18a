//! Loader tests: real Radiance input, commands, and every error path naming
//! file, line and reason.

use std::path::{Path, PathBuf};

use super::*;
use crate::geometry::{Shape, Vec3};

fn shared(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared")
        .join(p)
}

fn radiance_cornell() -> PathBuf {
    // /work/shared relative to /work/main/raytracer.
    let p = shared("scenes/radiance-cornell/cornell.rad");
    if p.exists() {
        p
    } else {
        PathBuf::from("/work/shared/scenes/radiance-cornell/cornell.rad")
    }
}

#[test]
fn radiance_cornell_box_loads_as_is() {
    let s = load(&[radiance_cornell()]).unwrap();
    // 1 light polygon, 1 sphere, 6 walls.
    assert_eq!(s.objects.len(), 8);
    assert_eq!(s.stats.objects, 8);
    assert_eq!(s.stats.primitives, 8);
    assert_eq!(s.stats.instances, 0);
    // light, dielectric, glass (unused), 3 plastics.
    assert_eq!(s.stats.materials, 6);
    assert!(s.material_names.iter().any(|n| n == "mat.sphere2"));
    let glass = s
        .material_names
        .iter()
        .position(|n| n == "mat.sphere2")
        .unwrap();
    assert!(matches!(s.materials[glass], Material::Glass { index, .. } if index == 1.52));
    assert!(
        s.objects.iter().all(|o| o.material as usize != glass),
        "glass is defined but unused"
    );
    let sphere = s.objects.iter().find(|o| o.name == "obj.sphere").unwrap();
    assert!(matches!(sphere.shape, Shape::Sphere { radius, .. } if radius == 0.1));
    assert!(matches!(
        s.material(sphere.material),
        Material::Dielectric { index, hartmann, .. } if *index == 1.5 && *hartmann == 0.0
    ));
    assert_eq!(s.lights.len(), 1);
    match s.lights[0].kind {
        LightKind::Area { object } => assert_eq!(s.objects[object as usize].name, "obj.source"),
        ref k => panic!("unexpected light {k:?}"),
    }
    let b = s.bounds();
    assert!((b.min - Vec3::splat(-0.5)).abs().max_element() < 1e-12);
    assert!((b.max - Vec3::splat(0.5)).abs().max_element() < 1e-12);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}
