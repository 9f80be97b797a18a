//! Tests of the Klems-matrix `BSDF` material: the basis, the XML reader
//! on the suite's `sawtooth.xml`, energy (furnace) from the coefficient
//! function and the sampled rays against the file's own hemispherical
//! sums, errors naming the file, a small render.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use super::bsdf::*;
use crate::accel::Hit;
use crate::geometry::{Ray, Vec3};
use crate::render::effects::EffectsReport;
use crate::render::material::{shade, RayKind, RayTask, Request, ShadeContext, Surface};
use crate::render::options::RenderOptions;
use crate::scene::{load_with, Color, LoadOptions, Scene};

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-bsdf-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Loads `text` as `scene.rad` in `dir` beside `files`, the suite on the
/// search path.
fn load(dir: &Path, text: &str, files: &[(&str, &str)]) -> crate::Result<Scene> {
    for (name, body) in files {
        std::fs::write(dir.join(name), body).unwrap();
    }
    let file = dir.join("scene.rad");
    std::fs::write(&file, text).unwrap();
    let suite = crate::testdata::radiance_tests_dir();
    let opts = LoadOptions {
        search_path: vec![dir.to_path_buf(), suite.clone(), suite.join("lib")],
    };
    load_with(&[&file], &opts)
}

/// The raw values of the first ScatteringData block, read without XML
/// (an independent reading of the file).
fn raw_values(xml: &str) -> Vec<f64> {
    let a = xml.find("<ScatteringData>").unwrap() + "<ScatteringData>".len();
    let b = xml.find("</ScatteringData>").unwrap();
    xml[a..b]
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|t| !t.is_empty())
        .map(|t| t.parse().unwrap())
        .collect()
}

const SAW_SCENE: &str = "void BSDF saw\n6 0 sawtooth.xml 0 1 0 .\n0\n0\n\
    void light sun\n0\n0\n3 1e6 1e6 1e6\n\
    sun source s\n0\n0\n4 .3 .2 1 .5\n\
    saw polygon floor\n0\n0\n12 -2 -2 0  2 -2 0  2 2 0  -2 2 0\n";

#[test]
fn the_klems_full_basis_has_145_patches_covering_the_projected_hemisphere() {
    let b = KlemsBasis::full();
    assert_eq!(b.n, 145);
    let total: f64 = (0..b.n).map(|i| b.ohm(i)).sum();
    assert!((total - PI).abs() < 1e-12, "{total}");
    for i in 0..b.n {
        assert!(b.ohm(i) > 0.0);
        // Patch centres and corners (inside) map back to their patch.
        for (r0, r1) in [(0.5, 0.5), (0.01, 0.01), (0.99, 0.99)] {
            let v = b.vec(i, r0, r1);
            assert!((v.length() - 1.0).abs() < 1e-12);
            assert_eq!(b.index(v), Some(i), "patch {i} at {r0},{r1}");
        }
    }
    assert_eq!(b.index(Vec3::new(0.0, 0.0, -1.0)), None);
    assert_eq!(
        b.index(Vec3::new(1.0, 0.0, 0.0)),
        None,
        "the horizon is outside"
    );
    assert_eq!(b.index(Vec3::Z), Some(0));
}

#[test]
fn sawtooth_xml_parses_into_one_front_reflection_matrix() {
    let Some(path) = crate::testdata::radiance_test_file("sawtooth.xml") else {
        return;
    };
    let d = KlemsData::load(&path).unwrap();
    assert_eq!(d.basis, KlemsBasis::full());
    // "Reflection Back" is Radiance's front (+z) reflection; nothing else.
    let m = d.parts[Part::ReflFront as usize].as_ref().unwrap();
    assert!(d.parts[1..].iter().all(Option::is_none));
    assert_eq!(m.values.len(), 145 * 145);
    let raw = raw_values(&std::fs::read_to_string(&path).unwrap());
    assert_eq!(raw.len(), 145 * 145);
    let min = raw.iter().copied().fold(f64::INFINITY, f64::min);
    assert!((d.lamb(Part::ReflFront) - min * PI).abs() < 1e-9);
    assert!((raw[0] - 0.06997).abs() < 1e-12 && (raw[29] - 0.01438).abs() < 1e-12);
    // Columns: row o holds the outgoing patch o for every incident one.
    for k in [0usize, 29, 145, 9 * 145 + 9, 145 * 145 - 1] {
        assert!(
            (m.values[k] as f64 + min - raw[k]).abs() < 1e-6,
            "value {k}: {} + {min} vs {}",
            m.values[k],
            raw[k]
        );
    }
    let (i, o) = (9, 9);
    let v = d.value(
        Part::ReflFront,
        d.basis.vec(i, 0.5, 0.5),
        d.basis.vec(o, 0.5, 0.5),
    );
    assert!((v + min - raw[o * 145 + i]).abs() < 1e-6);
    // No transmission: light from below gives nothing.
    assert_eq!(d.part_for(-Vec3::Z, Vec3::Z), None);
}

/// What `shade()` leaves for a ray along `dir` hitting the floor (normal
/// +Z) at the origin: requests, the BSDF's shadow data, the constant
/// (ambient) part with `-av 1 1 1`.
fn shaded(s: &Scene, dir: Vec3) -> (Vec<Request>, Option<KlemsSurface>, Color) {
    let options = RenderOptions {
        av: Color::splat(1.0),
        ..Default::default()
    };
    let lights = crate::render::light::prepare_lights(s).0;
    let effects = EffectsReport::analyse(s, &options, &lights);
    let media = crate::render::medium::Media::default();
    let ctx = ShadeContext {
        scene: s,
        options: &options,
        lights: &lights,
        effects: &effects,
        media: &media,
    };
    let dir = dir.normalize();
    let task = RayTask::primary(Ray { origin: -dir, dir }, 0.0, f64::INFINITY, 11);
    let hit = Hit {
        t: 1.0,
        point: Vec3::ZERO,
        normal: Vec3::Z,
        object: 0,
        inner: None,
        surface: {
            let (m, f) = ctx.scene.objects[0].surface_at(None);
            Hit::surface_word(m, f)
        },
    };
    let mut out = Vec::new();
    let sh = shade(&ctx, &task, &hit, &mut out);
    let surf = out.iter().find_map(|r| match r {
        Request::Shadow(b) => match b.surface {
            Surface::Klems(k) => Some(k),
            _ => None,
        },
        _ => None,
    });
    (out, surf, sh.base)
}

fn incidences() -> Vec<Vec3> {
    [1.0f64, 0.8, 0.5, 0.2, 0.05]
        .iter()
        .map(|&c| {
            let s = (1.0 - c * c).sqrt();
            Vec3::new(s * 0.6, s * 0.8, -c)
        })
        .collect()
}

/// Integral of the coefficient over light directions of the upper
/// hemisphere by a cosine-weighted quadrature stratified in each of the
/// basis's theta bands (`m` steps in sin²θ) and in 480 azimuths (a
/// multiple of every band's patch count, so no patch is aliased); each
/// sample's `omega` is chosen so it carries its projected solid angle.
/// Also the largest coefficient from the mirrored lower directions.
fn integrate(s: &Scene, k: &KlemsSurface, m: usize) -> (f64, f64) {
    let lats = &s.bsdfs[k.data as usize].basis.lats;
    let nphi = 480;
    let mut sum = 0.0;
    let mut below: f64 = 0.0;
    for w in lats.windows(2) {
        let sin2 = |deg: f64| deg.max(0.0).to_radians().sin().powi(2);
        let (u0, u1) = (sin2(w[0].0), sin2(w[1].0));
        for a in 0..m {
            let u = u0 + (u1 - u0) * (a as f64 + 0.5) / m as f64;
            for b in 0..nphi {
                let phi = 2.0 * PI * (b as f64 + 0.5) / nphi as f64;
                let r = u.sqrt();
                let z = (1.0 - u).sqrt();
                let l = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                let omega = PI * (u1 - u0) / ((m * nphi) as f64 * z);
                sum += k.coefficient(s, l, omega).y;
                below = below.max(
                    k.coefficient(s, Vec3::new(l.x, l.y, -z), omega)
                        .max_element(),
                );
            }
        }
    }
    (sum, below)
}

#[test]
fn furnace_direct_and_sampled_energy_match_the_files_sums() {
    if crate::testdata::radiance_test_file("sawtooth.xml").is_none() {
        return;
    }
    let dir = temp_dir("furnace");
    let s = load(&dir, SAW_SCENE, &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let d = s.bsdfs[0].clone();
    let raw = raw_values(
        &std::fs::read_to_string(crate::testdata::radiance_tests_dir().join("sawtooth.xml"))
            .unwrap(),
    );
    let n = 145;
    let b = &d.basis;
    for view in incidences() {
        let (out, k, base) = shaded(&s, view);
        let k = k.expect("the floor asks for direct light");
        // Light over the hemisphere into the fixed view: the file's row
        // sum (value times incident projected solid angle).
        let o = b.index(-view).unwrap();
        let row: f64 = (0..n).map(|i| raw[o * n + i] * b.ohm(i)).sum();
        let (got, below) = integrate(&s, &k, 20);
        assert!(got <= 1.0 + 1e-3, "view {view}: {got}");
        eprintln!("view {view}: direct {got:.5} file row {row:.5}");
        assert!(
            (got - row).abs() < 0.01 * row,
            "view {view}: {got} vs file {row}"
        );
        assert_eq!(below, 0.0, "no transmission in the file");
        // The sampled ray and the Lambertian (ambient) part carry the
        // column sum for the view as incident direction.
        let i = b.index(-view).unwrap();
        let col: f64 = (0..n).map(|o| raw[o * n + i] * b.ohm(o)).sum();
        let traced: Color = out
            .iter()
            .filter_map(|r| match r {
                Request::Trace { task, coef } if task.kind == RayKind::Reflection => Some(*coef),
                _ => None,
            })
            .sum();
        assert!(out.iter().all(
            |r| !matches!(r, Request::Trace { task, .. } if task.kind == RayKind::Refraction)
        ));
        let total = traced.y + base.y;
        assert!(total <= 1.0 + 1e-6, "view {view}: {total}");
        assert!(
            (total - col).abs() < 1e-4,
            "view {view}: {total} vs file {col}"
        );
        assert!((base.y - d.lamb(Part::ReflFront)).abs() < 1e-6);
    }
    // From below (the back): no back reflection in the file, none given:
    // black, and no direct light asked for beyond zero.
    let (out, k, base) = shaded(&s, Vec3::new(0.1, 0.2, 1.0));
    assert_eq!(base, Color::ZERO);
    assert!(!out.iter().any(|r| matches!(r, Request::Trace { .. })));
    if let Some(k) = k {
        let (got, _) = integrate(&s, &k, 4);
        assert_eq!(got, 0.0);
    }
}

#[test]
fn the_sawtooth_data_is_not_reciprocal_so_no_reciprocity_is_claimed() {
    // genBSDF's Monte Carlo matrix: f(i, o) and f(o, i) differ by ~24% on
    // average. The material evaluates the file as Radiance does (light
    // as incident) and this checks that the lookup is not symmetrised.
    let Some(path) = crate::testdata::radiance_test_file("sawtooth.xml") else {
        return;
    };
    let d = KlemsData::load(&path).unwrap();
    let b = &d.basis;
    let mut differ = 0;
    for i in 0..b.n {
        for o in 0..b.n {
            let f = d.value(Part::ReflFront, b.vec(i, 0.5, 0.5), b.vec(o, 0.5, 0.5));
            let r = d.value(Part::ReflFront, b.vec(o, 0.5, 0.5), b.vec(i, 0.5, 0.5));
            if (f - r).abs() > 1e-3 {
                differ += 1;
            }
        }
    }
    assert!(differ > b.n * b.n / 4, "{differ}");
}

#[test]
fn bad_and_missing_files_are_errors_naming_them() {
    let dir = temp_dir("errors");
    let rec = |file: &str| format!("\n\nvoid BSDF b\n6 0 {file} 0 1 0 .\n0\n0\n");
    let cases: [(&str, &str, &str); 5] = [
        ("broken.xml", "<WindowElement><Optical>", "not XML"),
        ("other.xml", "<Something/>", "WindowElement"),
        (
            "nodata.xml",
            "<WindowElement><Optical><Layer><DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure><AngleBasis><AngleBasisName>LBNL/Klems Full</AngleBasisName><AngleBasisBlock><Theta>0</Theta><nPhis>1</nPhis><ThetaBounds><LowerTheta>0</LowerTheta><UpperTheta>90</UpperTheta></ThetaBounds></AngleBasisBlock></AngleBasis></DataDefinition></Layer></Optical></WindowElement>",
            "no visible scattering data",
        ),
        (
            "short.xml",
            "<WindowElement><Optical><Layer><DataDefinition><IncidentDataStructure>Columns</IncidentDataStructure><AngleBasis><AngleBasisName>B</AngleBasisName><AngleBasisBlock><nPhis>1</nPhis><ThetaBounds><LowerTheta>0</LowerTheta><UpperTheta>90</UpperTheta></ThetaBounds></AngleBasisBlock></AngleBasis></DataDefinition><WavelengthData><Wavelength>Visible</Wavelength><WavelengthDataBlock><WavelengthDataDirection>Reflection Back</WavelengthDataDirection><ColumnAngleBasis>B</ColumnAngleBasis><RowAngleBasis>B</RowAngleBasis><ScatteringData>1 2</ScatteringData></WavelengthDataBlock></WavelengthData></Layer></Optical></WindowElement>",
            "has 2 values, expected 1",
        ),
        (
            "rows.xml",
            "<WindowElement><Optical><Layer><DataDefinition><IncidentDataStructure>Diagonal</IncidentDataStructure></DataDefinition></Layer></Optical></WindowElement>",
            "unsupported IncidentDataStructure",
        ),
    ];
    for (file, body, why) in cases {
        let e = load(&dir, &rec(file), &[(file, body)])
            .unwrap_err()
            .to_string();
        assert!(e.contains(file) && e.contains(why), "{file}: {e}");
        assert!(e.contains("scene.rad:3"), "{file}: {e}");
    }
    let e = load(&dir, &rec("absent.xml"), &[]).unwrap_err().to_string();
    assert!(e.contains("absent.xml") && e.contains("cannot find"), "{e}");
    let e = load(&dir, "void BSDF b\n6 2 x.xml 0 1 0 .\n0\n0\n", &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("thickness"), "{e}");
    let e = load(&dir, "void BSDF b\n6 0 x.xml 0 1 0 .\n0\n4 1 1 1 1\n", &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("scene.rad:1"), "{e}");
    // The suite's mixtex.mat: its aBSDF names blinds20c.xml, which the
    // suite does not have (Radiance's makefile builds it with genBSDF).
    if let Some(suite) = crate::testdata::radiance_tests() {
        let opts = LoadOptions {
            search_path: vec![suite.clone(), suite.join("lib")],
        };
        let e = load_with(&[suite.join("mixtex.mat")], &opts)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("blinds20c.xml") && e.contains("mixtex.mat"),
            "{e}"
        );
    }
}

#[test]
fn a_sawtooth_floor_renders_without_warnings() {
    if crate::testdata::radiance_test_file("sawtooth.xml").is_none() {
        return;
    }
    let dir = temp_dir("render");
    let s = load(&dir, SAW_SCENE, &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let options = RenderOptions {
        av: Color::splat(0.05),
        ..Default::default()
    };
    let view =
        crate::scene::View::from_options("-vp 0 -3 3 -vd 0 1 -1 -vu 0 0 1 -vh 40 -vv 40").unwrap();
    let r = crate::render::Renderer::new(&s, options).unwrap();
    assert!(r.warnings().is_empty(), "{:?}", r.warnings());
    let w = 16;
    let (film, _) = r.render(&view, w, w).unwrap();
    let px: Vec<Color> = (0..w)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| film.get(x, y))
        .collect();
    assert!(px.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
    let lit = px.iter().filter(|c| c.y > 0.1).count();
    let max = px.iter().map(|c| c.y).fold(0.0, f64::max);
    assert!(lit > px.len() / 2, "only {lit} lit pixels (max {max})");
    assert_eq!(s.patterns.failures.errors(), 0);
}

/// A small file: a 5-patch basis (a cap and 4 azimuths), one block.
fn small_xml(structure: &str, direction: &str, data: &str) -> String {
    format!(
        "<WindowElement><Optical><Layer><DataDefinition>\
         <IncidentDataStructure>{structure}</IncidentDataStructure>\
         <AngleBasis><AngleBasisName>Five</AngleBasisName>\
         <AngleBasisBlock><nPhis>1</nPhis><ThetaBounds><LowerTheta>0</LowerTheta><UpperTheta>30</UpperTheta></ThetaBounds></AngleBasisBlock>\
         <AngleBasisBlock><nPhis>4</nPhis><ThetaBounds><LowerTheta>30</LowerTheta><UpperTheta>90</UpperTheta></ThetaBounds></AngleBasisBlock>\
         </AngleBasis></DataDefinition>\
         <WavelengthData><Wavelength>Solar</Wavelength><WavelengthDataBlock><WavelengthDataDirection>Reflection Back</WavelengthDataDirection>\
         <ColumnAngleBasis>Five</ColumnAngleBasis><RowAngleBasis>Five</RowAngleBasis><ScatteringData>9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9 9</ScatteringData></WavelengthDataBlock></WavelengthData>\
         <WavelengthData><Wavelength>Visible</Wavelength><WavelengthDataBlock><WavelengthDataDirection>{direction}</WavelengthDataDirection>\
         <ColumnAngleBasis>Five</ColumnAngleBasis><RowAngleBasis>Five</RowAngleBasis><ScatteringData>{data}</ScatteringData></WavelengthDataBlock></WavelengthData>\
         </Layer></Optical></WindowElement>"
    )
}

#[test]
fn rows_are_the_transpose_of_columns_and_only_visible_data_counts() {
    let data: String = (0..25).map(|k| format!("{} ", 0.01 * k as f64)).collect();
    let c = KlemsData::parse(&small_xml("Columns", "Reflection Back", &data), "c.xml").unwrap();
    let r = KlemsData::parse(&small_xml("Rows", "Reflection Back", &data), "r.xml").unwrap();
    assert_eq!(c.basis.n, 5);
    let total: f64 = (0..5).map(|i| c.basis.ohm(i)).sum();
    assert!((total - PI).abs() < 1e-12);
    let (mc, mr) = (c.parts[0].as_ref().unwrap(), r.parts[0].as_ref().unwrap());
    for i in 0..5 {
        for o in 0..5 {
            assert_eq!(mc.values[o * 5 + i], mr.values[i * 5 + o]);
        }
    }
    // The solar block's 9s are ignored: the minimum is the visible 0.
    assert_eq!(c.lamb(Part::ReflFront), 0.0);
    assert!((mc.values[24] - 0.24).abs() < 1e-6);
    // Transmission Front: light from +z seen from -z.
    let t = KlemsData::parse(&small_xml("Columns", "Transmission Front", &data), "t.xml").unwrap();
    assert_eq!(t.part_for(Vec3::Z, -Vec3::Z), Some(Part::TransFront));
    // Reversed outgoing: out -z indexes as +z (patch 0), incident patch 0.
    assert!((t.value(Part::TransFront, Vec3::Z, -Vec3::Z) - 0.0).abs() < 1e-9);
    let side = t.basis.vec(1, 0.5, 0.5);
    assert!((t.value(Part::TransFront, Vec3::Z, -side) - 0.05).abs() < 1e-6);
    // Reciprocity fallback: the reverse query finds the same entry.
    assert!((t.value(Part::TransFront, -side, Vec3::Z) - 0.05).abs() < 1e-6);
}

#[test]
fn absdf_shares_the_material_and_warns_about_its_through_component() {
    let dir = temp_dir("absdf");
    let data: String = (0..25).map(|_| "0.02 ").collect();
    let t = small_xml("Columns", "Transmission Front", &data);
    let s = load(
        &dir,
        "void aBSDF a\n5 t.xml 0 1 0 .\n0\n3 .1 .1 .1\n",
        &[("t.xml", &t)],
    )
    .unwrap();
    assert!(matches!(
        s.materials[0],
        crate::scene::Material::Bsdf { .. }
    ));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].1.contains("through"));
    if crate::testdata::radiance_test_file("sawtooth.xml").is_some() {
        let s = load(&dir, "void aBSDF a\n5 sawtooth.xml 0 1 0 .\n0\n0\n", &[]).unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    }
}
