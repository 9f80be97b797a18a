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

// ---------------------------------------------------------------------------
// Helpers

/// A fresh temporary directory for file-based tests.
fn tempdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-scene-{tag}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Asserts that `r` is a parse error at `file:line` whose reason contains `needle`.
#[track_caller]
fn assert_parse_err(r: crate::Result<Scene>, file: &Path, line: usize, needle: &str) {
    match r {
        Err(crate::Error::Parse { loc, reason }) => {
            assert_eq!(loc.file, file, "file of error '{reason}'");
            assert_eq!(loc.line, line, "line of error '{reason}'");
            assert!(
                reason.contains(needle),
                "reason '{reason}' lacks '{needle}'"
            );
        }
        Err(e) => panic!("expected a parse error, got {e:?}"),
        Ok(_) => panic!("expected an error containing '{needle}', loaded fine"),
    }
}

const MATS: &str = "void plastic red\n0\n0\n5 .7 .2 .2 0 0\n";
const QUAD: &str = "red polygon q\n0\n0\n12 0 0 0  1 0 0  1 1 0  0 1 0\n";

fn poly_normal(s: &Scene, name: &str) -> Vec3 {
    match &s
        .objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| panic!("no object {name}"))
        .shape
    {
        Shape::Polygon(p) => p.normal,
        other => panic!("{other:?}"),
    }
}

// ---------------------------------------------------------------------------
// Error paths: each names file, line and reason.

#[test]
fn truncated_record_reports_where_input_ended() {
    let f = Path::new("t.rad");
    assert_parse_err(
        load_rad_str("void plastic red\n0\n0\n5 .7 .2", f),
        f,
        4,
        "declares 5 real arguments but only 2 follow",
    );
    assert_parse_err(
        load_rad_str("\n\nvoid plastic", f),
        f,
        3,
        "expected an identifier",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n0\n", f),
        f,
        2,
        "missing its integer argument count",
    );
    assert_parse_err(load_rad_str("void", f), f, 1, "expected a primitive type");
}

#[test]
fn wrong_argument_counts_are_errors() {
    let f = Path::new("c.rad");
    assert_parse_err(
        load_rad_str("\nvoid plastic red\n0\n0\n4 .7 .2 .2 0\n", f),
        f,
        2,
        "expected 5 real arguments",
    );
    assert_parse_err(
        load_rad_str("void glass g\n0\n0\n5 1 1 1 1.5 0\n", f),
        f,
        1,
        "expected 3 or 4 real arguments",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n1 x\n0\n5 .7 .2 .2 0 0\n", f),
        f,
        1,
        "expected 0 string arguments",
    );
    assert_parse_err(
        load_rad_str("void metal m\n0\n1 3\n5 .7 .2 .2 0 0\n", f),
        f,
        1,
        "expected 0 integer arguments",
    );
    let poly = format!("{MATS}\n# comment\nred polygon p\n0\n0\n10 0 0 0 1 0 0 1 1 0 0\n");
    assert_parse_err(load_rad_str(&poly, f), f, 7, "multiple of 3");
    let sph = format!("{MATS}red sphere s\n0\n0\n3 0 0 0\n");
    assert_parse_err(load_rad_str(&sph, f), f, 5, "expected 4 real arguments");
    let cyl = format!("{MATS}red cylinder c\n0\n0\n8 0 0 0 0 0 1 1 1\n");
    assert_parse_err(load_rad_str(&cyl, f), f, 5, "expected 7 real arguments");
    let ring = format!("{MATS}red ring r\n0\n0\n7 0 0 0 0 0 1 1\n");
    assert_parse_err(load_rad_str(&ring, f), f, 5, "expected 8 real arguments");
}

#[test]
fn bad_numbers_name_the_token_and_its_line() {
    let f = Path::new("n.rad");
    assert_parse_err(
        load_rad_str("void plastic red\n0\n0\n5 .7 .2\n  0.x 0 0\n", f),
        f,
        5,
        "bad real argument '0.x'",
    );
    assert_parse_err(
        load_rad_str("void plastic red\nzero\n0\n5 .7 .2 .2 0 0\n", f),
        f,
        2,
        "expected the number of string arguments, found 'zero'",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n0\n1 x\n5 .7 .2 .2 0 0\n", f),
        f,
        3,
        "bad integer argument 'x'",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n0\n0\n5 .7 inf .2 0 0\n", f),
        f,
        4,
        "bad real argument 'inf'",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n0\n0\n5 .7 1e999 .2 0 0\n", f),
        f,
        4,
        "out of range",
    );
    assert_parse_err(
        load_rad_str("void plastic red\n0\n0\n-5 .7\n", f),
        f,
        4,
        "expected the number of real arguments",
    );
}

#[test]
fn unknown_modifiers_and_types_are_errors() {
    let f = Path::new("u.rad");
    assert_parse_err(
        load_rad_str(
            &format!("{MATS}\nnosuch polygon p\n0\n0\n9 0 0 0 1 0 0 0 1 0\n"),
            f,
        ),
        f,
        6,
        "undefined modifier 'nosuch'",
    );
    assert_parse_err(
        load_rad_str(&format!("{MATS}red blob b\n0\n0\n0\n"), f),
        f,
        5,
        "unknown primitive type 'blob'",
    );
    // A modifier must be defined before it is used.
    assert_parse_err(
        load_rad_str(&format!("{QUAD}{MATS}"), f),
        f,
        1,
        "undefined modifier 'red'",
    );
    assert_parse_err(
        load_rad_str("void illum i\n1 nomat\n0\n3 1 1 1\n", f),
        f,
        1,
        "undefined modifier 'nomat'",
    );
    assert_parse_err(
        load_rad_str("void alias a nomat\n", f),
        f,
        1,
        "undefined modifier 'nomat'",
    );
}

#[test]
fn invalid_geometry_is_an_error_with_location() {
    let text = format!("{MATS}red sphere s\n0\n0\n4 0 0 0 -1\n");
    match load_rad_str(&text, "g.rad") {
        Err(crate::Error::Geometry { loc, reason }) => {
            assert_eq!((loc.file.as_path(), loc.line), (Path::new("g.rad"), 5));
            assert!(
                reason.contains("sphere 's'") && reason.contains("radius"),
                "{reason}"
            );
        }
        other => panic!("{other:?}"),
    }
    let text = format!("{MATS}red polygon flat\n0\n0\n9 0 0 0 1 0 0 2 0 0\n");
    assert!(matches!(
        load_rad_str(&text, "g.rad"),
        Err(crate::Error::Geometry { .. })
    ));
}

#[test]
fn shell_commands_are_refused() {
    let f = Path::new("cmd.rad");
    for (cmd, needle) in [
        ("!cat other.rad", "never run shell commands"),
        ("!gensurf m s 'sin(t)' 0 0 4 4", "never run shell commands"),
        ("!rm -rf /", "never run shell commands"),
        ("!genbox red b 1 1 1 > out.rad", "shell syntax"),
        ("!xform -t 1 0 0 a.rad; rm x", "shell syntax"),
        (
            "!genbox red b 1 1 1 | sed s/a/b/",
            "never run shell commands",
        ),
        ("!xform -t 1 0 0", "standard input"),
    ] {
        assert_parse_err(load_rad_str(&format!("{MATS}\n{cmd}\n"), f), f, 6, needle);
    }
}

#[test]
fn missing_include_names_the_including_line() {
    let d = tempdir("missing");
    let main = d.join("main.rad");
    std::fs::write(&main, format!("{MATS}\n\n!xform -t 1 0 0 nothere.rad\n")).unwrap();
    assert_parse_err(load(&[&main]), &main, 7, "cannot read scene file");
    // And a missing top-level file is an I/O error naming it.
    let e = load(&[d.join("absent.rad")]).unwrap_err();
    assert!(
        matches!(e, crate::Error::Io { .. }) && e.to_string().contains("absent.rad"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn include_cycles_are_detected() {
    let d = tempdir("cycle");
    std::fs::write(d.join("a.rad"), format!("{MATS}!xform b.rad\n")).unwrap();
    std::fs::write(d.join("b.rad"), "# b\n\n!xform -t 0 0 1 a.rad\n").unwrap();
    assert_parse_err(
        load(&[d.join("a.rad")]),
        &d.join("b.rad"),
        3,
        "include cycle",
    );
    // Instances that instance themselves too.
    std::fs::write(d.join("self.rad"), "void instance me\n1 self.oct\n0\n0\n").unwrap();
    assert_parse_err(
        load(&[d.join("self.rad")]),
        &d.join("self.rad"),
        1,
        "instance cycle",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn errors_inside_included_files_name_that_file() {
    let d = tempdir("inner");
    std::fs::write(
        d.join("main.rad"),
        format!("{MATS}!xform -rz 90 sub/inner.rad\n"),
    )
    .unwrap();
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(d.join("sub/inner.rad"), "\nred sphere s\n0\n0\n4 0 0 0 x\n").unwrap();
    assert_parse_err(
        load(&[d.join("main.rad")]),
        &d.join("sub/inner.rad"),
        5,
        "bad real argument 'x'",
    );
    std::fs::write(d.join("sub/inner.rad"), "\n\n!make all\n").unwrap();
    assert_parse_err(
        load(&[d.join("main.rad")]),
        &d.join("sub/inner.rad"),
        3,
        "never run shell commands",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn octree_instances_need_a_source_file() {
    let d = tempdir("oct");
    let main = d.join("main.rad");
    std::fs::write(&main, "\nvoid instance thing\n3 thing.oct -t 1\n0\n0\n").unwrap();
    assert_parse_err(load(&[&main]), &main, 2, "cannot read an octree");
    std::fs::write(d.join("thing.rad"), format!("{MATS}{QUAD}")).unwrap();
    // Now the source is there but the transform is malformed.
    assert_parse_err(load(&[&main]), &main, 2, "-t: missing number");
    std::fs::write(&main, "\nvoid instance thing\n1 thing.oct\n0\n0\n").unwrap();
    assert!(load(&[&main]).is_ok());
    let mesh = d.join("mesh.rad");
    std::fs::write(&mesh, format!("{MATS}red mesh m\n1 part.rtm\n0\n0\n")).unwrap();
    assert_parse_err(load(&[&mesh]), &mesh, 5, "cannot read a compiled mesh");
    std::fs::remove_dir_all(&d).ok();
}

// ---------------------------------------------------------------------------
// Commands: xform and genbox geometry.

#[test]
fn genbox_matches_radiance_output() {
    // The Radiance Cornell box's walls are `genbox mat.wall obj.box 1 1 1 -i | xform -t -.5 -.5 -.5`
    // (its comment says so): regenerate and compare vertex for vertex.
    let ours = load_rad_str(
        &format!("{MATS}!genbox red obj.box 1 1 1 -i | xform -t -0.5 -0.5 -0.5\n"),
        "g.rad",
    )
    .unwrap();
    let theirs = load(&[radiance_cornell()]).unwrap();
    for o in &ours.objects {
        let t = theirs
            .objects
            .iter()
            .find(|x| x.name == o.name)
            .unwrap_or_else(|| panic!("{}", o.name));
        match (&o.shape, &t.shape) {
            (Shape::Polygon(a), Shape::Polygon(b)) => {
                assert_eq!(a.vertices, b.vertices, "{}", o.name)
            }
            _ => panic!(),
        }
    }
    assert_eq!(ours.objects.len(), 6);
    // Outward without -i: the bottom face looks down.
    let out = load_rad_str(&format!("{MATS}!genbox red b 2 3 4\n"), "g.rad").unwrap();
    assert_eq!(poly_normal(&out, "b.2310"), -Vec3::Z);
    assert_eq!(poly_normal(&out, "b.6457"), Vec3::Z);
    let b = out.bounds();
    assert_eq!((b.min, b.max), (Vec3::ZERO, Vec3::new(2.0, 3.0, 4.0)));
    let f = Path::new("g.rad");
    assert_parse_err(
        load_rad_str(&format!("{MATS}!genbox red b 1 1 1 -r 0.1\n"), f),
        f,
        5,
        "rounded and bevelled boxes are not implemented",
    );
    assert_parse_err(
        load_rad_str(&format!("{MATS}!genbox red b 1 1\n"), f),
        f,
        5,
        "too few arguments",
    );
    assert_parse_err(
        load_rad_str(&format!("{MATS}!genbox red b 1 0 1\n"), f),
        f,
        5,
        "must be positive",
    );
}

#[test]
fn xform_transforms_in_order() {
    let d = tempdir("xf");
    std::fs::write(d.join("quad.rad"), QUAD).unwrap();
    std::fs::write(d.join("ball.rad"), "red sphere s\n0\n0\n4 1 0 0 0.5\n").unwrap();
    let main = d.join("main.rad");
    // Rotate 90 degrees about z, then translate.
    std::fs::write(
        &main,
        format!("{MATS}!xform -n a -rz 90 -t 10 0 0 quad.rad\n!xform -s 2 -t 0 0 1 ball.rad\n"),
    )
    .unwrap();
    let s = load(&[&main]).unwrap();
    let q = s
        .objects
        .iter()
        .find(|o| o.name == "a.q")
        .unwrap()
        .shape
        .bounds();
    assert!(
        (q.min - Vec3::new(9.0, 0.0, 0.0)).abs().max_element() < 1e-12,
        "{q:?}"
    );
    assert!(
        (q.max - Vec3::new(10.0, 1.0, 0.0)).abs().max_element() < 1e-12,
        "{q:?}"
    );
    match s.objects.iter().find(|o| o.name == "s").unwrap().shape {
        Shape::Sphere {
            center,
            radius,
            inward,
        } => {
            assert_eq!(
                (center, radius, inward),
                (Vec3::new(2.0, 0.0, 1.0), 1.0, false)
            );
        }
        ref o => panic!("{o:?}"),
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn xform_arrays_iterations_mirrors_and_renaming() {
    let d = tempdir("arr");
    std::fs::write(d.join("quad.rad"), QUAD).unwrap();
    std::fs::write(d.join("mats.rad"), "void metal shiny\n0\n0\n5 1 1 1 1 0\n").unwrap();
    let main = d.join("main.rad");
    std::fs::write(
        &main,
        format!("{MATS}!xform mats.rad\n!xform -m shiny -a 3 -t 2 0 0 -a 2 -t 0 5 0 -i 2 -t 0 0 1 quad.rad\n!xform -mx quad.rad\n!xform -I -t 0 0 -7 quad.rad\n"),
    )
    .unwrap();
    let s = load(&[&main]).unwrap();
    // 3 x 2 array copies, named with their indices, all given the new material.
    let arr: Vec<_> = s
        .objects
        .iter()
        .filter(|o| o.name.starts_with("q."))
        .collect();
    assert_eq!(arr.len(), 6);
    assert!(arr.iter().any(|o| o.name == "q.2.1"));
    let shiny = s.material_names.iter().position(|n| n == "shiny").unwrap() as u32;
    assert!(arr.iter().all(|o| o.material == shiny));
    let b = arr.iter().fold(crate::geometry::Aabb::EMPTY, |b, o| {
        b.union(o.shape.bounds())
    });
    // x: 0..1 + 2*2; y: 0..1 + 5; z: lifted by the final -i 2 -t 0 0 1.
    assert_eq!(
        (b.min, b.max),
        (Vec3::new(0.0, 0.0, 2.0), Vec3::new(5.0, 6.0, 2.0))
    );
    // The mirrored quad keeps facing +z (xform reverses its vertex order).
    let plain: Vec<_> = s.objects.iter().filter(|o| o.name == "q").collect();
    assert_eq!(plain.len(), 2);
    let mirrored = plain
        .iter()
        .find(|o| o.shape.bounds().min.x < -0.5)
        .unwrap();
    match &mirrored.shape {
        Shape::Polygon(p) => assert_eq!(p.normal, Vec3::Z),
        _ => panic!(),
    }
    // -I inverts the surface: it now faces -z.
    let inverted = plain
        .iter()
        .find(|o| o.shape.bounds().min.z < -6.0)
        .unwrap();
    match &inverted.shape {
        Shape::Polygon(p) => assert_eq!(p.normal, -Vec3::Z),
        _ => panic!(),
    }
    let f = Path::new("x.rad");
    assert_parse_err(
        load_rad_str(&format!("{MATS}!xform -q 1 a.rad\n"), f),
        f,
        5,
        "unknown option '-q'",
    );
    assert_parse_err(
        load_rad_str(&format!("{MATS}!xform -a x a.rad\n"), f),
        f,
        5,
        "bad count 'x'",
    );
    assert_parse_err(
        load_rad_str(
            &format!("{MATS}!genbox red b 1 1 1 | xform -a 1000000 -a 1000000 -t 1 0 0\n"),
            f,
        ),
        f,
        5,
        "more than",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn instances_share_geometry_and_nest() {
    let d = tempdir("inst");
    std::fs::write(
        d.join("leg.rad"),
        "void plastic wood\n0\n0\n5 .5 .4 .3 0 0\nwood cylinder l\n0\n0\n7 0 0 0 0 0 1 0.1\n",
    )
    .unwrap();
    let mut stool = String::from(
        "void plastic seat\n0\n0\n5 .2 .2 .2 0 0\nseat ring top\n0\n0\n8 0 0 1 0 0 1 0 0.5\n",
    );
    for k in 0..3 {
        stool += &format!("void instance leg{k}\n3 leg.oct -rz {}\n0\n0\n", k * 120);
    }
    std::fs::write(d.join("stool.rad"), stool).unwrap();
    std::fs::write(
        d.join("pair.rad"),
        "void instance a\n1 stool.oct\n0\n0\nvoid instance b\n5 stool.rad -t 3 0 0\n0\n0\n",
    )
    .unwrap();
    let main = d.join("main.rad");
    std::fs::write(&main, "!xform -t 0 0 5 pair.rad\n").unwrap();
    let s = load(&[&main]).unwrap();
    assert_eq!(s.stats.objects, 2);
    // 2 stools, each with 3 legs.
    assert_eq!(s.stats.instances, 2 + 2 * 3);
    // The ring and the cylinder, each counted once.
    assert_eq!(s.stats.primitives, 2);
    assert_eq!(s.stats.materials, 2);
    let (a, b) = match (&s.objects[0].shape, &s.objects[1].shape) {
        (Shape::Instance(a), Shape::Instance(b)) => (a, b),
        other => panic!("{other:?}"),
    };
    assert!(
        std::sync::Arc::ptr_eq(&a.geometry, &b.geometry),
        "one shared stool"
    );
    // Instance transform first, then the enclosing xform.
    assert_eq!(b.transform.point(Vec3::ZERO), Vec3::new(3.0, 0.0, 5.0));
    assert_eq!(a.transform.point(Vec3::ZERO), Vec3::new(0.0, 0.0, 5.0));
    // Inner objects keep their own materials, defined in their own files.
    let leg = match &a.geometry.objects[1].shape {
        Shape::Instance(l) => l,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        s.material_names[leg.geometry.objects[0].material as usize],
        "wood"
    );
    // And a hit on a leg, an instance inside an instance, is shaded with
    // it (it was the inner instance's `void`, which let every ray through:
    // the conference room's chairs had no casters).
    let ray = crate::geometry::Ray::new(Vec3::new(-5.0, 0.0, 5.5), Vec3::X);
    let h = s.objects[0]
        .shape
        .intersect(&ray, 1e-9, f64::INFINITY)
        .unwrap();
    assert!((h.t - 4.9).abs() < 1e-9, "{}", h.t);
    let hit = crate::geometry::Hit::on(&s.objects[0], 0, &ray, h.t, &h);
    assert_eq!(s.material_names[hit.material() as usize], "wood");
    assert!(!hit.flat());
    // The seat, one level down, as before.
    let down = crate::geometry::Ray::new(Vec3::new(0.3, 0.0, 9.0), -Vec3::Z);
    let h = s.objects[0]
        .shape
        .intersect(&down, 1e-9, f64::INFINITY)
        .unwrap();
    let hit = crate::geometry::Hit::on(&s.objects[0], 0, &down, h.t, &h);
    assert_eq!(s.material_names[hit.material() as usize], "seat");
    assert!(hit.flat());
    // A modifier on an instance shades everything inside it, nested
    // instances included (Radiance's o_instance), and one on a nested
    // instance everything inside that.
    std::fs::write(
        d.join("painted.rad"),
        "void plastic steel\n0\n0\n5 .6 .6 .6 0 0\n\
         steel instance leg\n1 leg.oct\n0\n0\n",
    )
    .unwrap();
    let over = d.join("over.rad");
    std::fs::write(
        &over,
        "void plastic paint\n0\n0\n5 .8 .1 .1 0 0\n\
         paint instance p\n1 stool.oct\n0\n0\n\
         void instance q\n5 painted.oct -t 0 5 0\n0\n0\n",
    )
    .unwrap();
    let s = load(&[&over]).unwrap();
    let shade = |o: usize, ray: crate::geometry::Ray| {
        let h = s.objects[o]
            .shape
            .intersect(&ray, 1e-9, f64::INFINITY)
            .unwrap();
        let hit = crate::geometry::Hit::on(&s.objects[o], o as u32, &ray, h.t, &h);
        s.material_names[hit.material() as usize].clone()
    };
    let across = |y: f64| crate::geometry::Ray::new(Vec3::new(-5.0, y, 0.5), Vec3::X);
    assert_eq!(shade(0, across(0.0)), "paint", "a leg of the painted stool");
    let down = crate::geometry::Ray::new(Vec3::new(0.3, 0.0, 9.0), -Vec3::Z);
    assert_eq!(shade(0, down), "paint", "the painted stool's seat");
    assert_eq!(
        shade(1, across(5.0)),
        "steel",
        "a leg placed with its own modifier"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn meshes_load_from_a_sibling_obj() {
    let d = tempdir("mesh");
    std::fs::write(
        d.join("part.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 3 2\n",
    )
    .unwrap();
    let main = d.join("main.rad");
    std::fs::write(&main, format!("{MATS}red mesh m\n3 part.rtm -s 2\n0\n0\n")).unwrap();
    let s = load(&[&main]).unwrap();
    assert_eq!(
        (s.stats.objects, s.stats.instances, s.stats.primitives),
        (1, 1, 2)
    );
    let Shape::Instance(i) = &s.objects[0].shape else {
        panic!()
    };
    // Faces without an OBJ material take the mesh's modifier.
    assert!(i
        .geometry
        .objects
        .iter()
        .all(|o| s.material_names[o.material as usize] == "red"));
    assert_eq!(i.transform.scale, 2.0);
    std::fs::remove_dir_all(&d).ok();
}

// ---------------------------------------------------------------------------
// Materials, patterns, lights.

/// A scratch folder for files a test writes.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn patterns_attach_to_materials_in_radiance_order() {
    let d = scratch("patterns");
    std::fs::write(
        d.join("dirt.cal"),
        "dirt = .5 + .25*A1;\n{ a comment }\nbump = .1;\n",
    )
    .unwrap();
    let text = "void brightfunc dirt\n2 dirt dirt.cal\n0\n1 2\n\
                dirt colorfunc tint\n4 1 .5 .25 .\n0\n0\n\
                tint plastic floor\n0\n0\n5 .5 .5 .5 0 0\n\
                floor polygon f\n0\n0\n9 0 0 0 1 0 0 0 1 0\n\
                void texfunc bump\n4 bump 0 0 dirt.cal\n0\n0\n\
                bump plastic wall\n0\n0\n5 .5 .5 .5 0 0\n\
                wall polygon g\n0\n0\n9 0 0 1 1 0 1 0 1 1\n";
    let s = load_rad_str(text, d.join("pat.rad")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.objects.len(), 2);
    assert_eq!(s.stats.materials, 5);
    let floor = s.objects[0].material;
    // The material's own modifier first, then that pattern's modifier.
    let names: Vec<&str> = s
        .mods(floor)
        .iter()
        .map(|&m| s.patterns.modifiers[m as usize].name.as_str())
        .collect();
    assert_eq!(names, ["tint", "dirt"]);
    let vars = crate::modifier::RayVars {
        dir: -Vec3::Z,
        normal: Vec3::Z,
        point: Vec3::ZERO,
        t: 1.0,
        ts: 0.0,
        uv: [0.0; 2],
    };
    let mut a = crate::modifier::Applied::NONE;
    s.patterns.apply(s.mods(floor), &vars, &mut a);
    // dirt = .5 + .25*2 = 1, tint = (1, .5, .25).
    assert_eq!(a.color, Vec3::new(1.0, 0.5, 0.25));
    let mut a = crate::modifier::Applied::NONE;
    s.patterns
        .apply(s.mods(s.objects[1].material), &vars, &mut a);
    assert_eq!(a.pert, Vec3::new(0.1, 0.0, 0.0));
    // A surface whose modifier is a pattern leading to no material is an error.
    let f = d.join("p.rad");
    assert_parse_err(
        load_rad_str(
            "void brightfunc d\n2 1 .\n0\n0\nd sphere s\n0\n0\n4 0 0 0 1\n",
            &f,
        ),
        &f,
        5,
        "leads to no material",
    );
    // A missing function file names the scene line and where it looked.
    assert_parse_err(
        load_rad_str("void brightfunc d\n2 x nowhere.cal\n0\n0\n", &f),
        &f,
        1,
        "nowhere.cal",
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn texfunc_perturbation_is_turned_but_not_scaled_by_its_transform() {
    // t_func()/t_data(): the displacement goes through the transform's
    // matrix and is divided by its scale, so a scaled object (genrev's
    // smoothed torus scaled by .2) keeps its normals' perturbation.
    let d = scratch("texfunc-xf");
    std::fs::write(d.join("b.cal"), "bx = .1;\nby = 0;\nbz = .05;\n").unwrap();
    let vars = crate::modifier::RayVars {
        dir: -Vec3::Z,
        normal: Vec3::Z,
        point: Vec3::ZERO,
        t: 1.0,
        ts: 0.0,
        uv: [0.0; 2],
    };
    let mut perts = Vec::new();
    for xf in ["", " -s 5", " -rz 90 -s .2", " -rz 90 -s .2 -t 1 2 3"] {
        let n = 4 + xf.split_whitespace().count();
        let text = format!(
            "void texfunc bump\n{n} bx by bz b.cal{xf}\n0\n0\n\
             bump plastic wall\n0\n0\n5 .5 .5 .5 0 0\n\
             wall polygon g\n0\n0\n9 0 0 1 1 0 1 0 1 1\n"
        );
        let s = load_rad_str(&text, d.join("t.rad")).unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let mut a = crate::modifier::Applied::NONE;
        s.patterns
            .apply(s.mods(s.objects[0].material), &vars, &mut a);
        perts.push(a.pert);
    }
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-12;
    assert!(close(perts[0], Vec3::new(0.1, 0.0, 0.05)), "{:?}", perts[0]);
    assert!(close(perts[1], perts[0]), "scaled by 5: {:?}", perts[1]);
    assert!(close(perts[2], Vec3::new(0.0, 0.1, 0.05)), "{:?}", perts[2]);
    assert!(close(perts[3], perts[2]), "translated: {:?}", perts[3]);
}

#[test]
fn colordata_calls_functions_as_radiance_does() {
    // rayinit's red(r,g,b), green(r,g,b), blue(r,g,b): three arguments, so
    // each gets all three data values (p_cdata); noop(v): one, its own.
    let d = scratch("colordata");
    std::fs::write(d.join("r.dat"), "1\n0 1 2\n0.1 0.3\n").unwrap();
    std::fs::write(d.join("g.dat"), "1\n0 1 2\n0.2 0.4\n").unwrap();
    std::fs::write(d.join("b.dat"), "1\n0 1 2\n0.5 0.7\n").unwrap();
    let text = "void colordata rgb\n8 red green blue r.dat g.dat b.dat . Px\n0\n0\n\
                void colordata own\n8 noop noop noop r.dat g.dat b.dat . Px\n0\n0\n\
                rgb plastic m1\n0\n0\n5 1 1 1 0 0\n\
                own plastic m2\n0\n0\n5 1 1 1 0 0\n\
                m1 sphere a\n0\n0\n4 0 0 0 1\nm2 sphere b\n0\n0\n4 0 0 3 1\n";
    let s = load_rad_str(text, d.join("c.rad")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let vars = crate::modifier::RayVars {
        dir: -Vec3::Z,
        normal: Vec3::Z,
        point: Vec3::new(0.5, 0.0, 0.0),
        t: 1.0,
        ts: 0.0,
        uv: [0.0; 2],
    };
    for k in 0..2 {
        let mut a = crate::modifier::Applied::NONE;
        s.patterns
            .apply(s.mods(s.objects[k].material), &vars, &mut a);
        assert!(
            (a.color - Vec3::new(0.2, 0.3, 0.6)).abs().max_element() < 1e-6,
            "{k}: {:?}",
            a.color
        );
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn aliases_copy_with_their_new_modifier() {
    // patterns.mat's forms: `inherit` keeps the pattern, `void` drops it,
    // a pattern replaces it; a later definition does not change earlier aliases.
    let text = "void brightfunc half\n2 .5 .\n0\n0\n\
                void brightfunc third\n2 1/3 .\n0\n0\n\
                half plastic base\n0\n0\n5 .8 .8 .8 0 0\n\
                inherit alias keeps base\n\
                void alias bare base\n\
                third alias swapped base\n\
                void plastic base\n0\n0\n5 .1 .1 .1 0 0\n\
                keeps sphere a\n0\n0\n4 0 0 0 1\n\
                bare sphere b\n0\n0\n4 0 0 3 1\n\
                swapped sphere c\n0\n0\n4 0 0 6 1\n\
                base sphere d\n0\n0\n4 0 0 9 1\n";
    let s = load_rad_str(text, "a.rad").unwrap();
    let chain = |k: usize| -> Vec<String> {
        s.mods(s.objects[k].material)
            .iter()
            .map(|&m| s.patterns.modifiers[m as usize].name.clone())
            .collect()
    };
    assert_eq!(chain(0), ["half"]);
    assert!(chain(1).is_empty());
    assert_eq!(chain(2), ["third"]);
    assert!(chain(3).is_empty());
    for k in 0..3 {
        assert!(
            matches!(s.material(s.objects[k].material), Material::Plastic { color, .. } if color.x == 0.8)
        );
    }
    assert!(
        matches!(s.material(s.objects[3].material), Material::Plastic { color, .. } if color.x == 0.1)
    );
}

#[test]
fn file_forms_radiance_reads() {
    let d = scratch("forms");
    // Quoted names and arguments with spaces; Latin-1 bytes in a comment
    // and a name; a file with no extension and one named .mat.
    let mut bytes = b"# caf\xe9 au lait\nvoid plastic 'm #1'\n0\n0\n5 .5 .5 .5 0 0\n".to_vec();
    bytes.extend_from_slice(b"'m #1' sphere \"ball \xe9\"\n0\n0\n4 0 0 0 1\n");
    std::fs::write(d.join("scene"), &bytes).unwrap();
    let s = load(&[d.join("scene")]).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].name, "ball \u{fffd}");
    assert_eq!(s.material_names.last().unwrap(), "m #1");
    // .mat and .norm files are Radiance text too.
    std::fs::write(d.join("a.mat"), "void plastic red\n0\n0\n5 .7 .2 .2 0 0\n").unwrap();
    std::fs::write(d.join("b.norm"), "red sphere s\n0\n0\n4 0 0 0 1\n").unwrap();
    let s = load(&[d.join("a.mat"), d.join("b.norm")]).unwrap();
    assert_eq!(s.objects.len(), 1);
    // An unclosed quote reads to the end of the file and then reports it.
    let f = d.join("q.rad");
    std::fs::write(&f, "void plastic 'open\n0\n0\n5 .5 .5 .5 0 0\n").unwrap();
    assert!(load(&[&f]).is_err());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn unsupported_types_are_named_once_with_their_count() {
    let mut text = String::new();
    for k in 0..50 {
        text += &format!("void WGMDfunc w{k}\n13 .1 .1 .1 . 0 .1 .1 .1 . 0 .1 .1 .1\n0\n0\n");
    }
    let s = load_rad_str(&text, "many.rad").unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    // An ignored spectral pattern can still be aliased and used.
    let spec = load_rad_str(
        "void specfunc sp\n2 1 .\n0\n0\nvoid brightfunc b\n2 .5 .\n0\n0\n\
         b alias sp2 sp\nsp2 plastic m\n0\n0\n5 .5 .5 .5 0 0\nm sphere s\n0\n0\n4 0 0 0 1\n",
        "spec.rad",
    )
    .unwrap();
    assert_eq!(spec.objects.len(), 1);
    assert_eq!(spec.warnings.len(), 1, "{:?}", spec.warnings);
    assert!(
        s.warnings[0].1.contains("50 primitives"),
        "{}",
        s.warnings[0].1
    );
}

#[test]
fn unsupported_materials_are_substituted_with_a_warning() {
    let s = load_rad_str("void plastic2 aniso\n4 0 0 1 .\n0\n6 .5 .5 .5 .05 .04 .09\nvoid WGMDfunc b\n6 0 f.xml 0 0 1 .\n0\n0\n", "m.rad").unwrap();
    // plastic2 and BSDF are simulated now: only WGMDfunc is substituted.
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].1.contains("WGMDfunc"));
    assert!(
        matches!(s.materials[0], Material::Aniso { u_rough, v_rough, .. } if u_rough == 0.04 && v_rough == 0.09)
    );
    assert_eq!(s.warnings[0].0.line, 5);
}

#[test]
fn aliases_chains_and_light_materials() {
    let text = "void plastic base\n0\n0\n5 .5 .5 .5 0 0\n\
                void alias copy base\n\
                inherit alias copy2 copy\n\
                void light lamp\n0\n0\n3 10 10 10\n\
                void glow dim\n0\n0\n4 1 1 1 0\n\
                void glow bright\n0\n0\n4 1 1 1 2.5\n\
                void illum window\n1 base\n0\n3 5 5 5\n\
                void spotlight spot\n0\n0\n7 9 9 9 40 0 0 -1\n\
                void mirror m\n0\n0\n3 .9 .9 .9\n\
                void trans t\n0\n0\n7 .5 .5 .5 0 0 .5 .2\n\
                copy2 sphere a\n0\n0\n4 0 0 0 1\n\
                lamp sphere b\n0\n0\n4 0 0 3 1\n\
                dim sphere c\n0\n0\n4 0 0 6 1\n\
                bright sphere d\n0\n0\n4 0 0 9 1\n\
                window polygon e\n0\n0\n9 0 0 0 1 0 0 0 1 0\n\
                spot ring f\n0\n0\n8 0 0 12 0 0 -1 0 1\n\
                lamp source sun\n0\n0\n4 0 0 1 0.5\n";
    let s = load_rad_str(text, "l.rad").unwrap();
    assert_eq!(s.stats.materials, 8, "aliases define no new material");
    let base = s.material_names.iter().position(|n| n == "base").unwrap() as u32;
    assert_eq!(s.objects[0].material, base);
    let win = s.material_names.iter().position(|n| n == "window").unwrap();
    assert_eq!(
        s.materials[win],
        Material::Illum {
            radiance: Vec3::splat(5.0),
            alternate: Some(base)
        }
    );
    // lamp, bright glow, illum, spotlight surfaces + the distant source; not the zero-radius glow.
    let names: Vec<String> = s
        .lights
        .iter()
        .filter_map(|l| match l.kind {
            LightKind::Area { object } => Some(s.objects[object as usize].name.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(names, ["b", "d", "e", "f"]);
    let sun = s.lights.iter().find_map(|l| match &l.kind {
        LightKind::Distant {
            dir,
            solid_angle,
            name,
        } => {
            assert_eq!(name, "sun");
            Some((*dir, *solid_angle))
        }
        _ => None,
    });
    let (dir, omega) = sun.unwrap();
    assert_eq!(dir, Vec3::Z);
    let expect = 2.0 * std::f64::consts::PI * (1.0 - 0.25f64.to_radians().cos());
    assert!((omega - expect).abs() < 1e-15);
    assert_eq!(s.objects.len(), 6, "a source is a light, not an object");
    let f = Path::new("l.rad");
    assert_parse_err(
        load_rad_str(
            "void plastic p\n0\n0\n5 1 1 1 0 0\np source s\n0\n0\n4 0 0 1 1\n",
            f,
        ),
        f,
        5,
        "not a light",
    );
}

#[test]
fn several_files_form_one_scene() {
    let d = tempdir("multi");
    std::fs::write(d.join("materials.rad"), MATS).unwrap();
    std::fs::write(d.join("geometry.rad"), QUAD).unwrap();
    std::fs::write(d.join("box.obj"), "mtllib box.mtl\nusemtl shiny\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nusemtl lamp\nv 0 0 1\nv 1 0 1\nv 1 1 1\nf 4 5 6\n").unwrap();
    std::fs::write(
        d.join("box.mtl"),
        "newmtl shiny\nKd 0.8 0.1 0.1\nKs 0.5 0.5 0.5\nNs 98\nillum 2\nnewmtl lamp\nKe 5 5 4\n",
    )
    .unwrap();
    let s = load(&[
        d.join("materials.rad"),
        d.join("geometry.rad"),
        d.join("box.obj"),
    ])
    .unwrap();
    assert_eq!(s.objects.len(), 3);
    let shiny = s.material_names.iter().position(|n| n == "shiny").unwrap();
    match s.materials[shiny] {
        Material::Plastic {
            color,
            specularity,
            roughness,
        } => {
            assert!((color - Vec3::new(0.8, 0.1, 0.1)).abs().max_element() < 1e-6);
            assert!((specularity - 0.5).abs() < 1e-6 && (roughness - 0.02f64.sqrt()).abs() < 1e-6);
        }
        ref m => panic!("{m:?}"),
    }
    assert_eq!(s.lights.len(), 1, "the Ke face is an area light");
    // Without its MTL the OBJ still loads, with a warning and grey plastic.
    std::fs::remove_file(d.join("box.mtl")).unwrap();
    let s = load(&[d.join("box.obj")]).unwrap();
    assert_eq!(s.objects.len(), 2);
    assert!(
        s.warnings
            .iter()
            .any(|(_, w)| w.contains("material library")),
        "{:?}",
        s.warnings
    );
    assert!(matches!(
        s.materials[s.objects[0].material as usize],
        Material::Plastic { .. }
    ));
    // Any other name is Radiance text, as Radiance reads it.
    let e = load(&[d.join("scene.txt")]).unwrap_err().to_string();
    assert!(e.contains("scene.txt"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

// ---------------------------------------------------------------------------
// Robustness: the parser never panics (stable-Rust stand-in for cargo-fuzz).

mod fuzz {
    use proptest::prelude::*;

    const WORDS: &[&str] = &[
        "void",
        "plastic",
        "metal",
        "glass",
        "dielectric",
        "light",
        "glow",
        "illum",
        "mirror",
        "trans",
        "spotlight",
        "polygon",
        "sphere",
        "bubble",
        "cone",
        "cup",
        "cylinder",
        "tube",
        "ring",
        "source",
        "instance",
        "mesh",
        "alias",
        "inherit",
        "brightfunc",
        "BSDF",
        "antimatter",
        "mist",
        "m",
        "p",
        "0",
        "1",
        "2",
        "3",
        "4",
        "5",
        "7",
        "8",
        "9",
        "12",
        "-1",
        ".5",
        "1e308",
        "1e-320",
        "nan",
        "x",
        "#",
        "\n",
        "!xform",
        "!genbox",
        "-t",
        "-a",
        "-i",
        "-rz",
        "-s",
        "-mx",
        "|",
        "xform",
        "genbox",
        "a.oct",
        "b.rtm",
        "-r",
        "\\\n",
        "\t",
        "!",
        "'",
        "\"",
        "\"a b\"",
        "'x #1'",
        "colorfunc",
        "texfunc",
        "mixfunc",
        "brightdata",
        "colortext",
        "a.cal",
        ".",
    ];

    fn any_text() -> impl Strategy<Value = String> {
        prop::collection::vec(prop::sample::select(WORDS), 0..60).prop_map(|w| w.join(" "))
    }

    /// Well-formed records with random types, modifiers and argument counts,
    /// so that fuzzing reaches the builder and the geometry constructors.
    fn records() -> impl Strategy<Value = String> {
        const TYPES: &[&str] = &[
            "plastic",
            "metal",
            "glass",
            "dielectric",
            "light",
            "glow",
            "illum",
            "mirror",
            "trans",
            "spotlight",
            "polygon",
            "sphere",
            "bubble",
            "cone",
            "cup",
            "cylinder",
            "tube",
            "ring",
            "source",
            "instance",
            "mesh",
            "brightfunc",
            "colorfunc",
            "texfunc",
            "mixfunc",
            "brightdata",
            "colorpict",
            "brighttext",
            "mixtext",
            "specfunc",
            "plastic2",
            "BSDF",
            "antimatter",
            "mist",
            "interface",
        ];
        const NAMES: &[&str] = &["void", "a", "b", "c", "inherit"];
        const STRS: &[&str] = &[
            "a", "b", "x.oct", "y.rtm", "-t", "-rz", "1", "-s", "-1", "-i", "2", ".", "Px",
            "'1 + Dx'", "f.cal", "x.dat",
        ];
        const NUMS: &[&str] = &[
            "0", "1", "-1", ".5", "2", "1e-300", "1e300", "180", "360", "0.0001",
        ];
        let record = (
            prop::sample::select(NAMES),
            prop::sample::select(TYPES),
            prop::sample::select(NAMES),
            prop::collection::vec(prop::sample::select(STRS), 0..4).prop_map(|v| {
                if v.len() == 3 {
                    Vec::new()
                } else {
                    v
                }
            }),
            prop::collection::vec(prop::sample::select(NUMS), 0..13),
            0u8..8,
        )
            .prop_map(|(m, t, id, strs, reals, alias)| {
                if alias == 0 {
                    format!("{m} alias {id} {}\n", strs.first().copied().unwrap_or("a"))
                } else {
                    format!(
                        "{m} {t} {id}\n{} {}\n0\n{} {}\n",
                        strs.len(),
                        strs.join(" "),
                        reals.len(),
                        reals.join(" ")
                    )
                }
            });
        prop::collection::vec(record, 0..12).prop_map(|r| r.concat())
    }

    /// `base` with up to `most` random byte replacements, insertions and cuts.
    fn mutated(base: String, most: usize) -> impl Strategy<Value = String> {
        let n = base.len().max(1);
        (prop::collection::vec((0..n, any::<u8>(), 0u8..3), 1..most)).prop_map(move |edits| {
            let mut b = base.clone().into_bytes();
            for (at, byte, op) in edits {
                let at = at.min(b.len());
                match op {
                    0 if at < b.len() => b[at] = byte,
                    1 => b.insert(at, byte),
                    _ => b.truncate(at),
                }
            }
            String::from_utf8_lossy(&b).into_owned()
        })
    }

    fn mutated_cornell() -> impl Strategy<Value = String> {
        mutated(
            std::fs::read_to_string(super::radiance_cornell()).unwrap_or_default(),
            8,
        )
    }

    /// Words of the function language, for random `.cal` files.
    const CAL: &[&str] = &[
        "a", "b", "f", "g", "x", "=", ":", ";", "(", ")", ",", "+", "-", "*", "/", "^", "{", "}",
        "$1", "$27", "Px", "Dx", "A1", "arg(0)", "1", ".5", "1e308", "if", "select", "noise3",
        "fnoise3", "rand", "sqrt", "f(x)", "g(a,b)", "f(f(1))", "\n", "`", "c`P.",
    ];

    fn cal_text() -> impl Strategy<Value = String> {
        prop::collection::vec(prop::sample::select(CAL), 0..40).prop_map(|w| w.join(" "))
    }

    /// The suite's pattern scene with random byte edits.
    fn mutated_patterns() -> impl Strategy<Value = String> {
        let dir = super::shared("scenes/radiance-tests");
        let base = std::fs::read_to_string(dir.join("patterns.mat")).unwrap_or_default()
            + &std::fs::read_to_string(dir.join("rect_fixture.rad")).unwrap_or_default()
            + "mat1 sphere s1\n0\n0\n4 0 0 0 1\nmat7 sphere s2\n0\n0\n4 0 0 3 1\n";
        mutated(base, 6)
    }

    /// Loads `text` with the suite on the search path and evaluates every
    /// material's patterns for a few rays.
    fn load_and_shade(text: &str, dir: &std::path::Path) -> bool {
        let suite = super::shared("scenes/radiance-tests");
        let opts = super::LoadOptions {
            search_path: vec![dir.to_path_buf(), suite.clone(), suite.join("lib")],
        };
        let file = dir.join("fuzz.rad");
        if std::fs::write(&file, text).is_err() {
            return false;
        }
        let Ok(s) = super::load_with(&[&file], &opts) else {
            return false;
        };
        for m in 0..s.materials.len() as u32 {
            for k in 0..3 {
                let d = crate::geometry::Vec3::new(0.3 * k as f64 - 0.4, 0.5, -0.7).normalize();
                let vars = crate::modifier::RayVars {
                    dir: d,
                    normal: crate::geometry::Vec3::Z,
                    point: crate::geometry::Vec3::new(k as f64 * 1.7 - 5.0, 2.5, 0.5),
                    t: 1.0 + k as f64,
                    ts: 0.0,
                    uv: [0.25, 0.75],
                };
                let mut a = crate::modifier::Applied::NONE;
                s.patterns.apply(s.mods(m), &vars, &mut a);
            }
        }
        true
    }

    #[test]
    fn the_unmutated_pattern_scene_loads_and_shades() {
        if !super::shared("scenes/radiance-tests").is_dir() {
            return;
        }
        let dir = std::env::temp_dir().join(format!("hybrid-rt-patbase-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let suite = super::shared("scenes/radiance-tests");
        let base = std::fs::read_to_string(suite.join("patterns.mat")).unwrap()
            + &std::fs::read_to_string(suite.join("rect_fixture.rad")).unwrap()
            + "mat1 sphere s1\n0\n0\n4 0 0 0 1\n";
        assert!(load_and_shade(&base, &dir));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, rng_seed: proptest::test_runner::RngSeed::Fixed(0xca1), failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn random_cal_files_never_panic(cal in cal_text(), expr in cal_text()) {
            let dir = std::env::temp_dir().join(format!("hybrid-rt-calfuzz-{}", std::process::id()));
            let _ = std::fs::create_dir_all(&dir);
            let _ = std::fs::write(dir.join("f.cal"), &cal);
            let text = format!(
                "void brightfunc p\n2 '{}' f.cal\n0\n2 1 2\nvoid colorfunc q\n4 a b '{}' f.cal\n0\n0\n\
                 p plastic m\n0\n0\n5 .5 .5 .5 0 0\nq plastic n\n0\n0\n5 .5 .5 .5 0 0\n",
                expr.replace('\'', ""), expr.replace('\'', "")
            );
            let _ = load_and_shade(&text, &dir);
        }

        #[test]
        fn mutated_pattern_scene_never_panics(text in mutated_patterns()) {
            let dir = std::env::temp_dir().join(format!("hybrid-rt-patfuzz-{}", std::process::id()));
            let _ = std::fs::create_dir_all(&dir);
            let _ = load_and_shade(&text, &dir);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed), failure_persistence: None, ..ProptestConfig::default() })]

        #[test]
        fn random_token_soup_never_panics(text in any_text()) {
            let _ = super::load_rad_str(&text, "/nonexistent-fuzz-dir/fuzz.rad");
        }

        #[test]
        fn random_records_never_panic(text in records()) {
            let _ = super::load_rad_str(&text, "/nonexistent-fuzz-dir/fuzz.rad");
        }

        #[test]
        fn mutated_real_scene_never_panics(text in mutated_cornell()) {
            let _ = super::load_rad_str(&text, "/nonexistent-fuzz-dir/fuzz.rad");
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
            let _ = super::load_rad_str(&String::from_utf8_lossy(&bytes), "/nonexistent-fuzz-dir/fuzz.rad");
        }

        #[test]
        fn view_options_never_panic(text in any_text()) {
            if let Ok(v) = crate::scene::View::from_options(&text.replace(['m', 'p'], "-vp")) {
                let _ = v.ray(0.3, 0.7);
            }
        }
    }
}

// ---------------------------------------------------------------------------
// OBJ/MTL errors name file:line; devices and directories are refused.

#[test]
fn obj_and_mtl_errors_name_file_and_line() {
    use crate::scene::load_obj_str;
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: &[(&str, Option<&str>, &str)] = &[
        ("v 1 2\n", None, "m.obj:1: v takes x y z"),
        (
            "v 0 0 0\nv 1 x 0\n",
            None,
            "m.obj:2: v: 'x' is not a number",
        ),
        ("v 0 0 0 0\n", None, "m.obj:1: v: weight w is 0"),
        (
            "v 1e39 0 0\n",
            None,
            "m.obj:1: v: '1e39' is not a finite number",
        ),
        (
            "v 0 0 0\nf 1 2 3\n",
            None,
            "m.obj:2: face vertex '2': vertex 2 does not exist (1 defined so far)",
        ),
        (
            "v 0 0 0\nf 0 1 1\n",
            None,
            "m.obj:2: face vertex '0': vertex 0 does not exist",
        ),
        (
            "v 0 0 0\nf -9223372036854775808 1 1\n",
            None,
            "vertex -9223372036854775808 does not exist",
        ),
        (
            "v 0 0 0\nf 1/1 1/1 1/1\n",
            None,
            "m.obj:2: face vertex '1/1': texture coordinate 1 does not exist",
        ),
        (
            "v 0 0 0\nf 1/2/3/4 1 1\n",
            None,
            "m.obj:2: face vertex '1/2/3/4': expected",
        ),
        ("usemtl\n", None, "m.obj:1: usemtl needs a material name"),
        ("mtllib\n", None, "m.obj:1: mtllib needs a file name"),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nKd 1 2\n"),
            "m.mtl:2: Kd takes one or three numbers (r g b), found 2",
        ),
        (
            "mtllib m.mtl\n",
            Some("Kd 1 1 1\n"),
            "m.mtl:1: 'Kd' before any 'newmtl'",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\n\nNi 0\n"),
            "m.mtl:3: Ni: index of refraction 0 must be positive",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nNi -1\n"),
            "m.mtl:2: Ni: index of refraction -1 must be positive",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nKs -1 0 0\n"),
            "m.mtl:2: Ks: negative colour",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nd 2\n"),
            "m.mtl:2: d: 2 is outside 0..1",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nillum x\n"),
            "m.mtl:2: illum takes one illumination model",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl a\nNs nan\n"),
            "m.mtl:2: Ns: 'nan' is not a finite number",
        ),
        (
            "mtllib m.mtl\n",
            Some("newmtl\n"),
            "m.mtl:1: newmtl needs a material name",
        ),
    ];
    for (obj, mtl, want) in cases {
        let e = load_obj_str(obj, *mtl, "m.obj")
            .err()
            .unwrap_or_else(|| panic!("{obj:?} {mtl:?} loaded"))
            .to_string();
        assert!(e.contains(want), "{obj:?} {mtl:?}: {e}");
    }
    // `Kd 1` (grey, as MTL allows) once made tobj panic; relative and
    // slashed indices, w and vertex colours load.
    let s = load_obj_str(
        &format!("mtllib m.mtl\nusemtl a\n{tri}v 0 0 1 2\nv 1 1 1 .5 .5 .5\nvt 0 0\nvn 0 0 1\nf -3/1/1 -4//1 -5/1\nf 1 2 3\n"),
        Some("newmtl a\nKd 0.25\nTr 0.25 # comment\nmap_Kd x.png\n"),
        "m.obj",
    )
    .unwrap();
    assert_eq!(s.objects.len(), 2);
    match s.materials[s.objects[0].material as usize] {
        Material::Glass { transmission, .. } => assert!((transmission.x - 0.25).abs() < 1e-6),
        ref m => panic!("{m:?}"),
    }
}

#[test]
fn devices_fifos_and_directories_are_refused() {
    let d = tempdir("devices");
    std::fs::write(d.join("m.obj"), "mtllib /dev/zero\n").unwrap();
    std::fs::write(d.join("x.rad"), "!xform /dev/zero\n").unwrap();
    std::fs::write(d.join("dir.rad"), "!xform .\n").unwrap();
    let e = load(&[d.join("m.obj")]).unwrap_err().to_string();
    assert!(
        e.contains("m.obj:1: cannot read material library '/dev/zero': not a regular file"),
        "{e}"
    );
    let e = load(&[d.join("x.rad")]).unwrap_err().to_string();
    assert!(
        e.contains("x.rad:1:") && e.contains("not a regular file"),
        "{e}"
    );
    let e = load(&[d.join("dir.rad")]).unwrap_err().to_string();
    assert!(e.contains("dir.rad:1:") && e.contains("directory"), "{e}");
    for p in ["/dev/zero", "/dev/null/x"] {
        assert!(load(&[p]).is_err());
    }
    let e = load(&[Path::new("/dev/zero.obj")]).unwrap_err().to_string();
    assert!(e.contains("/dev/zero.obj"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}
