//! What `hybrid-rt render` says on stderr, and the picture formats it
//! writes: the summary line, `-t` reports, no escape codes on pipes,
//! debug events; EXR and PFM against HDR, PNG colour-space chunks, the
//! tone operators.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const CORNELL: &str = include_str!("data/radiance-cornell.rad");
const CORNELL_VF: &str = include_str!("data/radiance-cornell.vf");

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hybrid-rt-console-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs `hybrid-rt render` on the Cornell box in `dir` with `args` after
/// the scene and view; stderr is a pipe.
fn render(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let rad = dir.join("cornell.rad");
    let vf = dir.join("cornell.vf");
    if !rad.exists() {
        std::fs::write(&rad, CORNELL).unwrap();
        std::fs::write(&vf, CORNELL_VF).unwrap();
    }
    let mut c = Command::new(env!("CARGO_BIN_EXE_hybrid-rt"));
    c.arg("render")
        .arg(&rad)
        .arg("--view-file")
        .arg(&vf)
        .args(args)
        .env_remove("RUST_LOG")
        .env_remove("NO_COLOR");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("run hybrid-rt")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output) -> String {
    let e = stderr(o);
    assert!(o.status.success(), "{e}");
    e
}

/// The summary line's figures.
#[derive(Debug)]
struct Summary {
    width: usize,
    height: usize,
    wall_s: f64,
    render_s: f64,
    rays: u64,
    primary: u64,
    shadow: u64,
    other: u64,
    mrays: f64,
    effects: Vec<String>,
}

/// Parses `rendered WxH in S s (render S s): N rays (P primary, S shadow,
/// O other), M Mrays/s; effects: a, b`; panics naming what is missing.
fn summary(err: &str) -> Summary {
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("rendered ")).collect();
    assert_eq!(lines.len(), 1, "one summary line in {err:?}");
    let l = lines[0];
    let words: Vec<&str> = l.split([' ', '(', ')', ',', ':', ';']).collect();
    let num = |after: &str| -> &str {
        let i = words
            .iter()
            .position(|w| *w == after)
            .unwrap_or_else(|| panic!("{after:?} in {l:?}"));
        words[i + 1..]
            .iter()
            .find(|w| !w.is_empty())
            .unwrap_or_else(|| panic!("value after {after:?} in {l:?}"))
    };
    let before = |word: &str| -> &str {
        let i = words
            .iter()
            .position(|w| *w == word)
            .unwrap_or_else(|| panic!("{word:?} in {l:?}"));
        words[..i].iter().rev().find(|w| !w.is_empty()).unwrap()
    };
    let (w, h) = num("rendered").split_once('x').expect("WxH");
    Summary {
        width: w.parse().unwrap(),
        height: h.parse().unwrap(),
        wall_s: num("in").parse().unwrap(),
        render_s: num("render").parse().unwrap(),
        rays: before("rays").parse().unwrap(),
        primary: before("primary").parse().unwrap(),
        shadow: before("shadow").parse().unwrap(),
        other: before("other").parse().unwrap(),
        mrays: before("Mrays/s").parse().unwrap(),
        effects: l
            .split_once("effects: ")
            .expect("effects")
            .1
            .split(", ")
            .map(String::from)
            .collect(),
    }
}

#[test]
fn summary_line_after_sequential_and_parallel_renders_and_no_escapes_on_pipes() {
    let d = tmpdir("summary");
    let png = d.join("a.png").to_string_lossy().into_owned();
    for extra in [
        &[][..],
        &["--procs", "2"][..],
        &[
            "--procs", "2", "-ab", "1", "-ad", "16", "-as", "0", "-aa", "0.3",
        ][..],
    ] {
        let mut args = vec!["--width", "24", "--height", "24", "-o", &png];
        args.extend_from_slice(extra);
        let o = render(&d, &args, &[]);
        let err = ok(&o);
        assert!(!err.contains('\x1b'), "escape code on a pipe: {err:?}");
        assert!(
            !err.contains('\r'),
            "a progress bar drawn on a pipe: {err:?}"
        );
        let s = summary(&err);
        assert_eq!((s.width, s.height), (24, 24), "{extra:?}");
        if extra.contains(&"-ab") {
            // Pixels waiting for a hemisphere are traced again.
            assert!(s.primary >= 24 * 24, "{s:?}");
        } else {
            assert_eq!(s.primary, 24 * 24, "{extra:?}: {s:?}");
        }
        assert_eq!(s.rays, s.primary + s.shadow + s.other, "{s:?}");
        assert!(s.shadow > 0, "{s:?}");
        assert!(s.wall_s >= s.render_s, "{s:?}");
        // Both rounded to 3 decimals in the line.
        let lo = s.rays as f64 / (s.render_s + 5e-4) / 1e6 - 5e-4;
        assert!(s.mrays >= lo, "{s:?}");
        if s.render_s > 5e-4 {
            assert!(
                s.mrays <= s.rays as f64 / (s.render_s - 5e-4) / 1e6 + 5e-4,
                "{s:?}"
            );
        }
        assert!(s.effects.iter().any(|e| e == "area shadows"), "{s:?}");
        assert!(s.effects.iter().any(|e| e == "refraction"), "{s:?}");
        let ambient = s.effects.iter().any(|e| e == "diffuse inter-reflection");
        assert_eq!(ambient, extra.contains(&"-ab"), "{s:?}");
    }
}

#[test]
fn debug_events_say_what_was_built() {
    let d = tmpdir("debug");
    let hdr = d.join("a.hdr").to_string_lossy().into_owned();
    let args = [
        "--width", "16", "--height", "16", "-o", &hdr, "--procs", "2",
    ];
    let quiet = ok(&render(&d, &args, &[]));
    // At the default level: the summary and the parallel table only.
    assert!(
        !quiet.contains("DEBUG") && !quiet.contains("INFO"),
        "{quiet}"
    );
    let err = ok(&render(&d, &args, &[("RUST_LOG", "debug")]));
    assert!(!err.contains('\x1b'), "escape code on a pipe");
    for event in [
        "scene loaded",
        "bounds=",
        "render options",
        "acceleration structures built",
        "octree_depth=",
        "lights prepared",
        "hit_ratios=",
        "processor starting",
        "processor finished",
    ] {
        assert!(err.contains(event), "{event:?} missing from {err}");
    }
    summary(&err);
}

/// Reads a PFM: (width, height, RGB rows from the top).
fn read_pfm(bytes: &[u8]) -> (usize, usize, Vec<[f32; 3]>) {
    let mut fields = Vec::new();
    let mut i = 0;
    // Three whitespace-separated header tokens after "PF", then one byte.
    while fields.len() < 4 {
        while bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let s = i;
        while !bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        fields.push(std::str::from_utf8(&bytes[s..i]).unwrap().to_string());
    }
    i += 1;
    assert_eq!(fields[0], "PF");
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let scale: f32 = fields[3].parse().unwrap();
    assert!(scale < 0.0, "little-endian");
    let data = &bytes[i..];
    assert_eq!(data.len(), w * h * 12);
    let f = |k: usize| f32::from_le_bytes(data[4 * k..4 * k + 4].try_into().unwrap());
    let mut px = vec![[0f32; 3]; w * h];
    for row in 0..h {
        // Stored bottom row first.
        let y = h - 1 - row;
        for x in 0..w {
            let k = 3 * (row * w + x);
            px[y * w + x] = [f(k), f(k + 1), f(k + 2)];
        }
    }
    (w, h, px)
}

/// Reads an RGB EXR with the `exr` crate: (width, height, pixels from the
/// top, the `radianceView` attribute).
fn read_exr(path: &Path) -> (usize, usize, Vec<[f32; 3]>, Option<String>) {
    use exr::prelude::*;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .collect_pixels(
            |size: Vec2<usize>, _| (size.width(), vec![[0f32; 3]; size.area()]),
            |px: &mut (usize, Vec<[f32; 3]>), p: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                px.1[p.y() * px.0 + p.x()] = [r, g, b]
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .expect("readable EXR");
    let layer = img.layer_data;
    let view = match layer.attributes.other.get(&Text::from("radianceView")) {
        Some(AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    };
    (
        layer.size.width(),
        layer.size.height(),
        layer.channel_data.pixels.1,
        view,
    )
}

#[test]
fn exr_and_pfm_hold_the_hdr_pixels() {
    let d = tmpdir("formats");
    let path = |n: &str| d.join(n).to_string_lossy().into_owned();
    let common = ["--width", "20", "--height", "12", "-ds", "0.3"];
    for name in ["a.hdr", "a.exr", "a.pfm", "p.pfm"] {
        let mut args = common.to_vec();
        let out = path(name);
        args.extend(["-o", &out]);
        if name.starts_with('p') {
            args.extend(["--procs", "2"]);
        }
        ok(&render(&d, &args, &[]));
    }
    let bytes = std::fs::read(path("a.hdr")).unwrap();
    let hdr = hybrid_rt::image::hdr::read_hdr(&mut &bytes[..]).unwrap();
    let (w, h) = (hdr.film.width(), hdr.film.height());
    let (ew, eh, exr, view) = read_exr(Path::new(&path("a.exr")));
    let (pw, ph, pfm) = read_pfm(&std::fs::read(path("a.pfm")).unwrap());
    assert_eq!((ew, eh), (w, h));
    assert_eq!((pw, ph), (w, h));
    // Both hold the same f32 values of the film; the parallel render's
    // are bit for bit the sequential one's.
    assert_eq!(exr, pfm);
    assert_eq!(read_pfm(&std::fs::read(path("p.pfm")).unwrap()).2, pfm);
    let view_line = hdr
        .header
        .iter()
        .find_map(|l| l.strip_prefix("VIEW="))
        .expect("VIEW= line");
    assert_eq!(view.as_deref().map(str::trim), Some(view_line.trim()));
    // RGBE keeps 8 bits of mantissa per pixel: within 1/128 of the
    // pixel's largest component.
    let mut bright = 0;
    for y in 0..h {
        for x in 0..w {
            let c = hdr.film.get(x, y);
            let f = exr[y * w + x];
            let m = f[0].max(f[1]).max(f[2]) as f64;
            for (a, b) in [(c.x, f[0]), (c.y, f[1]), (c.z, f[2])] {
                assert!(
                    (a - b as f64).abs() <= m / 128.0 + 1e-30,
                    "({x}, {y}): {c} vs {f:?}"
                );
            }
            if m > 1.0 {
                bright += 1;
            }
        }
    }
    assert!(bright > 0, "the light is in view");
}

#[test]
fn unknown_extension_lists_the_supported_ones() {
    let d = tmpdir("ext");
    let out = path_str(&d, "a.tiff");
    let o = render(&d, &["--width", "4", "--height", "4", "-o", &out], &[]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    for ext in [".png", ".hdr", ".exr", ".pfm"] {
        assert!(err.contains(ext), "{ext} in {err}");
    }
    assert!(!Path::new(&out).exists());
}

fn path_str(d: &Path, n: &str) -> String {
    d.join(n).to_string_lossy().into_owned()
}

#[test]
fn png_tone_operators_and_colour_chunks() {
    let d = tmpdir("tone");
    let png = |n: &str, extra: &[&str]| -> (png::Info<'static>, Vec<u8>) {
        let out = path_str(&d, n);
        let mut args = vec!["--width", "24", "--height", "24", "-o", &out];
        args.extend_from_slice(extra);
        ok(&render(&d, &args, &[]));
        let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
        let mut r = dec.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        r.next_frame(&mut buf).unwrap();
        (r.info().clone(), buf)
    };
    let (info, default) = png("d.png", &[]);
    assert!(info.srgb.is_some(), "sRGB chunk");
    assert_eq!(info.gama_chunk.map(|g| g.into_scaled()), Some(45455));
    assert!(info.chrm_chunk.is_some());
    let (_, reinhard) = png("r.png", &["--tone", "reinhard"]);
    assert_eq!(default, reinhard, "Reinhard is the default");
    let (_, exposure) = png("e.png", &["--tone", "exposure"]);
    assert_ne!(default, exposure);
    // An explicit --exposure selects the exposure operator.
    let (_, e1) = png("e1.png", &["--exposure", "1"]);
    let (_, te1) = png("te1.png", &["--tone", "exposure", "--exposure", "1"]);
    assert_eq!(e1, te1);
    assert_ne!(e1, default);
    // Reinhard's white is the brightest pixel: the light shows as white.
    assert!(default.chunks(3).any(|p| p == [255, 255, 255]));
    let (_, p50) = png("w.png", &["--tone-white", "50"]);
    let white = |v: &[u8]| v.chunks(3).filter(|p| *p == [255, 255, 255]).count();
    assert!(white(&p50) > white(&default));

    let (info, _) = png("g.png", &["--gamma", "1.8"]);
    assert!(info.srgb.is_none() && info.chrm_chunk.is_none());
    assert_eq!(info.gama_chunk.map(|g| g.into_scaled()), Some(55556));

    for bad in [
        &["--tone", "reinhard", "--exposure", "2"][..],
        &["--tone", "exposure", "--tone-white", "90"][..],
        &["--tone-white", "0"][..],
        &["--tone", "filmic"][..],
    ] {
        let out = path_str(&d, "bad.png");
        let mut args = vec!["--width", "4", "--height", "4", "-o", &out];
        args.extend_from_slice(bad);
        let o = render(&d, &args, &[]);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
    }
    let o = render(&d, &["--tone", "filmic", "-o", "x.png"], &[]);
    let err = stderr(&o);
    assert!(
        err.contains("reinhard") && err.contains("exposure"),
        "{err}"
    );
}

/// Renders with `-t 1` (and `extra`), growing the picture until the render
/// takes at least 1.5 s (sized from the previous attempt's time); returns
/// stderr and the summary.
fn reported(d: &Path, extra: &[&str]) -> (String, Summary) {
    let out = path_str(d, "t.hdr");
    let mut side = 96.0f64;
    for _ in 0..5 {
        let n = (side.round() as u32).to_string();
        let mut args = vec![
            "--width", &n, "--height", &n, "-ds", "0.02", "-dt", "0", "-t", "1", "-o", &out,
        ];
        args.extend_from_slice(extra);
        let err = ok(&render(d, &args, &[]));
        let s = summary(&err);
        if s.render_s >= 1.5 {
            return (err, s);
        }
        // Aim at 2 s: time grows with the number of pixels.
        side *= (2.0 / s.render_s.max(0.01)).min(64.0).sqrt();
    }
    panic!("no render took 1.5 s");
}

#[test]
fn rpict_t_reports_progress_every_n_seconds() {
    let d = tmpdir("report");
    for extra in [&[][..], &["--procs", "2"][..]] {
        let (err, s) = reported(&d, extra);
        let reports: Vec<f64> = err
            .lines()
            .filter_map(|l| l.strip_prefix("progress: "))
            .map(|l| {
                let (pct, rest) = l.split_once("% done after ").expect(l);
                let pct: f64 = pct.parse().unwrap();
                assert!((0.0..=100.0).contains(&pct), "{l}");
                rest.strip_suffix(" s").expect(l).parse().unwrap()
            })
            .collect();
        assert!(!reports.is_empty(), "{extra:?}: no report in {err}");
        // At most one a second, the first after a second.
        assert!(reports[0] >= 1.0, "{reports:?}");
        assert!(
            reports.windows(2).all(|w| w[1] - w[0] >= 0.95),
            "{reports:?}"
        );
        assert!(reports.len() as f64 <= s.wall_s + 1.0, "{reports:?} {s:?}");
        assert!(!err.contains('\r') && !err.contains('\x1b'), "{err:?}");
    }
}
