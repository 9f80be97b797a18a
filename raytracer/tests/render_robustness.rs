//! Robustness: scale invariance, watertight closed boxes, no shadow acne.

mod common;

use common::*;
use hybrid_rt::render::RenderOptions;

/// A Cornell-like box (walls, a light, a glass sphere and a block) with
/// every coordinate multiplied by `s`.
fn cornell_scaled(s: f64) -> String {
    let p = |x: f64, y: f64, z: f64| format!("{} {} {}", x * s, y * s, z * s);
    let quad = |mat: &str, name: &str, v: [(f64, f64, f64); 4]| {
        format!(
            "{mat} polygon {name} 0 0 12 {} {} {} {}\n",
            p(v[0].0, v[0].1, v[0].2),
            p(v[1].0, v[1].1, v[1].2),
            p(v[2].0, v[2].1, v[2].2),
            p(v[3].0, v[3].1, v[3].2)
        )
    };
    let mut t = String::from(
        "void light lamp 0 0 3 20 20 20\n\
         void plastic white 0 0 5 .7 .7 .7 0 .1\n\
         void plastic red 0 0 5 .7 .2 .2 0 .1\n\
         void plastic blue 0 0 5 .2 .2 .7 0 .1\n\
         void glass clear 0 0 3 .9 .9 .9\n\
         void plastic box 0 0 5 .5 .6 .5 0.05 0\n",
    );
    t += &quad(
        "lamp",
        "light",
        [
            (-0.1, -0.1, 0.45),
            (-0.1, 0.1, 0.45),
            (0.1, 0.1, 0.45),
            (0.1, -0.1, 0.45),
        ],
    );
    t += &quad(
        "red",
        "left",
        [
            (-0.5, -0.5, -0.5),
            (-0.5, -0.5, 0.5),
            (0.5, -0.5, 0.5),
            (0.5, -0.5, -0.5),
        ],
    );
    t += &quad(
        "white",
        "back",
        [
            (-0.5, -0.5, -0.5),
            (-0.5, 0.5, -0.5),
            (-0.5, 0.5, 0.5),
            (-0.5, -0.5, 0.5),
        ],
    );
    t += &quad(
        "white",
        "floor",
        [
            (-0.5, -0.5, -0.5),
            (0.5, -0.5, -0.5),
            (0.5, 0.5, -0.5),
            (-0.5, 0.5, -0.5),
        ],
    );
    t += &quad(
        "blue",
        "right",
        [
            (0.5, 0.5, 0.5),
            (-0.5, 0.5, 0.5),
            (-0.5, 0.5, -0.5),
            (0.5, 0.5, -0.5),
        ],
    );
    t += &quad(
        "white",
        "ceiling",
        [
            (0.5, 0.5, 0.5),
            (0.5, -0.5, 0.5),
            (-0.5, -0.5, 0.5),
            (-0.5, 0.5, 0.5),
        ],
    );
    // A block standing on the floor (its bottom touches the floor exactly).
    let (x0, x1, y0, y1, z0, z1) = (-0.3, -0.05, 0.05, 0.3, -0.5, -0.15);
    t += &quad(
        "box",
        "b_top",
        [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
    );
    t += &quad(
        "box",
        "b_front",
        [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
    );
    t += &quad(
        "box",
        "b_side",
        [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
    );
    t += &format!(
        "clear sphere ball 0 0 4 {} {}\n",
        p(-0.1, -0.2, -0.35),
        0.15 * s
    );
    t
}

#[test]
fn same_image_at_scales_1e_minus_4_to_1e4() {
    let render_at = |s: f64| {
        let sc = scene(&cornell_scaled(s));
        // Slightly off the symmetric Cornell view, so that no pixel centre
        // lands exactly on an edge where two walls meet (a point on both
        // surfaces at once is shadowed or not by rounding alone, at any scale).
        let v = view(&format!(
            "-vtv -vp {} {} {} -vd -1 0.011 -0.007 -vu 0 0 1 -vh 80 -vv 80",
            0.49 * s,
            0.0123 * s,
            0.0071 * s
        ));
        render(
            &sc,
            &v,
            48,
            48,
            RenderOptions {
                dj: 0.5,
                ..Default::default()
            },
        )
        .0
    };
    let base = render_at(1.0);
    assert!(base.mean_brightness() > 0.01);
    for s in [1e-4, 1e4] {
        let other = render_at(s);
        // Same seeds, same geometry up to rounding: pixels agree closely;
        // a handful may differ where a ray grazes an edge.
        let mean = mean_rel_diff(&base, &other);

        assert!(mean < 1e-3, "scale {s}: mean relative difference {mean}");
        let differing = base
            .pixels()
            .iter()
            .zip(other.pixels())
            .filter(|(a, b)| (**a - **b).abs().max_element() > 1e-6 * a.max_element().max(1e-12))
            .count();
        assert!(
            differing <= base.pixels().len() / 100,
            "scale {s}: {differing} pixels differ"
        );
    }
}

/// A closed box of polygons sharing edges (each face split into two
/// triangles along a diagonal), seen from inside in many directions: every
/// primary ray must hit (ambient makes every hit non-black).
#[test]
fn closed_box_has_no_leaks() {
    let mut t = String::from("void plastic w 0 0 5 .5 .5 .5 0 0\n");
    let c = [
        [-1.0, -1.0, -1.0],
        [1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0],
        [1.0, 1.0, 1.0],
        [-1.0, 1.0, 1.0],
    ];
    let faces = [
        [0, 3, 2, 1],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [1, 2, 6, 5],
        [0, 4, 7, 3],
    ];
    let v = |i: usize| format!("{} {} {}", c[i][0] * 3.7, c[i][1] * 3.7, c[i][2] * 3.7);
    for (k, f) in faces.iter().enumerate() {
        t += &format!(
            "w polygon f{k}a 0 0 9 {} {} {}\n",
            v(f[0]),
            v(f[1]),
            v(f[2])
        );
        t += &format!(
            "w polygon f{k}b 0 0 9 {} {} {}\n",
            v(f[0]),
            v(f[2]),
            v(f[3])
        );
    }
    let s = scene(&t);
    let opts = RenderOptions {
        av: hybrid_rt::scene::Color::ONE,
        ..Default::default()
    };
    let views = [
        "-vtv -vp 0 0 0 -vd 1 1 1 -vu 0 0 1 -vh 150 -vv 150",
        "-vtv -vp 0 0 0 -vd 1 0 0 -vu 0 0 1 -vh 170 -vv 170",
        "-vtv -vp 0.3 -0.2 0.1 -vd -1 1 0 -vu 0 0 1 -vh 120 -vv 120",
        "-vta -vp 0 0 0 -vd 0 0 1 -vu 0 1 0 -vh 360 -vv 360",
        "-vth -vp 3.6 3.6 3.6 -vd -1 -1 -1 -vu 0 0 1 -vh 180 -vv 180",
    ];
    for vs in views {
        let v = view(vs);
        let (film, stats) = render(&s, &v, 64, 64, opts.clone());
        let black = film
            .pixels()
            .iter()
            .filter(|c| c.max_element() <= 0.0)
            .count();
        // Angular and hemispherical views leave the corners outside the image circle.
        let outside = (stats.width * stats.height) as u64 - stats.rays.primary;
        assert_eq!(
            black as u64, outside,
            "{vs}: {black} pixels see through the box"
        );
    }
}

/// A large floor lit by a distant source 2 degrees above the horizon: every
/// floor pixel has the same (Lambertian) radiance, no self-shadowing.
#[test]
fn grazing_light_gives_no_shadow_acne() {
    for scale in [1.0, 1e-3, 1e3] {
        let e = 2f64.to_radians();
        let t = format!(
            "void light sun 0 0 3 1000 1000 1000\n\
             sun source s 0 0 4 {} 0 {} 0.5\n\
             void plastic ground 0 0 5 .5 .5 .5 0 0\n\
             ground polygon floor 0 0 12 {m} {m} 0  {p} {m} 0  {p} {p} 0  {m} {p} 0\n",
            e.cos(),
            e.sin(),
            m = -100.0 * scale,
            p = 100.0 * scale
        );
        let s = scene(&t);
        let v = view(&format!(
            "-vtv -vp 0 0 {} -vd 0.3 1 -0.7 -vu 0 0 1 -vh 60 -vv 40",
            5.0 * scale
        ));
        let (film, stats) = render(&s, &v, 64, 48, RenderOptions::default());
        assert!(stats.rays.shadow.tested > 0);
        let lit: Vec<f64> = film
            .pixels()
            .iter()
            .map(|c| c.y)
            .filter(|&y| y > 0.0)
            .collect();
        // Every pixel looks down at the floor.
        assert_eq!(
            lit.len(),
            64 * 48,
            "scale {scale}: {} pixels in shadow",
            64 * 48 - lit.len()
        );
        let (lo, hi) = lit
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &y| (a.min(y), b.max(y)));
        assert!(
            (hi - lo) / hi < 1e-9,
            "scale {scale}: radiance varies {lo}..{hi}"
        );
        assert_eq!(
            stats.rays.shadow.unoccluded, stats.rays.shadow.tested,
            "scale {scale}"
        );
    }
}

// ---------------------------------------------------------------------------
// No input hangs the program, every write error exits non-zero, and values
// outside physical sense are refused with file:line.

fn run_cli(args: &[&str]) -> (i32, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hybrid-rt"))
        .args(args)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run hybrid-rt");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn scratch(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-robust-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const LIT: &str = "void light l 0 0 3 10 10 10\nl sphere s 0 0 4 0 2 0 .5\n";

#[test]
fn write_errors_exit_non_zero() {
    if !std::path::Path::new("/dev/full").exists() {
        return;
    }
    let d = scratch("full");
    let scene = d.join("s.rad");
    std::fs::write(&scene, LIT).unwrap();
    let scene = scene.to_str().unwrap();
    for ext in ["png", "hdr"] {
        let full = d.join(format!("full.{ext}"));
        let _ = std::fs::remove_file(&full);
        std::os::unix::fs::symlink("/dev/full", &full).unwrap();
        let (code, err) = run_cli(&[
            "render",
            scene,
            "--view",
            "-vp 0 0 0",
            "--width",
            "8",
            "--height",
            "8",
            "-o",
            full.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{ext}: {err}");
        assert!(err.contains("No space left on device"), "{ext}: {err}");
    }
    let stats = d.join("full.json");
    let _ = std::fs::remove_file(&stats);
    std::os::unix::fs::symlink("/dev/full", &stats).unwrap();
    let out = d.join("ok.png");
    let (code, err) = run_cli(&[
        "render",
        scene,
        "--view",
        "-vp 0 0 0",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("full.json"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn devices_and_unphysical_values_are_refused_with_file_and_line() {
    let d = scratch("refuse");
    let png = d.join("x.png");
    let png = png.to_str().unwrap();
    let cases: &[(&str, &str, &str)] = &[
        ("zero.rad", "!xform /dev/zero\n", "zero.rad:1:"),
        (
            "m.obj",
            "mtllib /dev/zero\nv 0 0 0\n",
            "m.obj:1: cannot read material library",
        ),
        (
            "big.rad",
            "void plastic m 0 0 5 .5 .5 .5 0 0\nm sphere s 0 0 4 0 0 0 1e308\n",
            "big.rad:2:",
        ),
        (
            "n0.rad",
            "void dielectric d 0 0 5 1 1 1 0 0\n",
            "n0.rad:1: dielectric 'd': index of refraction 0 must be positive",
        ),
        (
            "neg.rad",
            "void glass g 0 0 4 1 1 1 -1\n",
            "neg.rad:1: glass 'g': index of refraction -1 must be positive",
        ),
        (
            "kd.obj",
            "mtllib kd.mtl\nv 0 0 0\n",
            "kd.mtl:2: Kd takes one or three numbers",
        ),
    ];
    std::fs::write(d.join("kd.mtl"), "newmtl a\nKd 1 2\n").unwrap();
    for (name, text, want) in cases {
        let f = d.join(name);
        std::fs::write(&f, text).unwrap();
        let (code, err) = run_cli(&[
            "render",
            f.to_str().unwrap(),
            "--view",
            "-vp 0 -5 0",
            "-o",
            png,
        ]);
        assert_eq!(code, 1, "{name}: {err}");
        assert!(err.contains(want), "{name}: {err}");
    }
    // A scene that is a device or a directory.
    for bad in ["/dev/zero", "/"] {
        let (code, err) = run_cli(&["render", bad, "--view", "-vp 0 -5 0", "-o", png]);
        assert_eq!(code, 1, "{bad}: {err}");
        assert!(
            err.contains("not a regular file") || err.contains("directory"),
            "{bad}: {err}"
        );
    }
    // Views outside Radiance's limits.
    let scene = d.join("lit.rad");
    std::fs::write(&scene, LIT).unwrap();
    for (view, want) in [
        ("-vtl -vh 1e308", "-vh 1e308"),
        ("-vtv -vh 180", "-vh 180 is out of range"),
        ("-vth -vv 200", "-vv 200 is out of range"),
    ] {
        let (code, err) = run_cli(&["render", scene.to_str().unwrap(), "--view", view, "-o", png]);
        assert_ne!(code, 0, "{view}: {err}");
        assert!(err.contains(want), "{view}: {err}");
    }
    let vf = d.join("bad.vf");
    std::fs::write(&vf, "rview -vtv -vp 0 0 0\n-vh 190\n").unwrap();
    let (code, err) = run_cli(&[
        "render",
        scene.to_str().unwrap(),
        "--view-file",
        vf.to_str().unwrap(),
        "-o",
        png,
    ]);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("bad.vf:2: -vh 190 is out of range"), "{err}");
    std::fs::remove_dir_all(&d).ok();
}
