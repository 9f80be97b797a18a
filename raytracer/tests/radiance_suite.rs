//! Radiance's own regression scenes (`../shared/scenes/radiance-tests`,
//! copied unchanged from Radiance 5.4a) rendered from their files as they
//! are, and compared with Radiance's reference pictures.
//!
//! The references were rendered at 2048 pixels and reduced to 128, last
//! by `pfilt -1 -r 1` (a Gaussian); we render at a multiple of the
//! reference's size (4 for patterns, mesh and `glass_up`, as the README's
//! own 512-pixel runs; 2 for `glass_fish`) and reduce the same
//! way ([`pfilt_reduce`]). Mist is rendered at 512 too (6 minutes of one
//! core: its hemispheres are 1521 rays, each scattering light from both
//! spotlights along its way through the mist); at the reference's own 128
//! pixels its one sample at each pixel's centre (`-ps 1 -pj 0`, its
//! settings) aliases against the reference's 256 (2.7% nRMSE).
//! The figures are those of the folder's README: the ratio of mean
//! luminances, and the RMS of the per-pixel luminance difference over the
//! reference's mean after both pictures are smoothed with a 3x3 box
//! (different sampling noise, same structure). Each test writes the
//! render and a difference picture to `target/tmp/radiance-suite/` when it
//! fails (also when `RADIANCE_SUITE_KEEP` is set), and prints its figures
//! either way (`--nocapture`).
//!
//! Tolerances, against the README's measurements between Radiance's own
//! runs: mean luminance within 1% (patterns, mist) and 2% (mesh: 18 chrome
//! and clothed figures whose highlights are smaller than a pixel; without
//! rpict's pixel jitter `mesh_cyl`, a 128 x 26 panorama, came out 1.027);
//! per pixel, Radiance's renders at 512 differ from the references by
//! 1.8-3.0% nRMSE on patterns, 1.5% on mist, 19-35% on the mesh views and
//! 11-18% on the glass views; ours are held to 5%, 2%, 20-35% and 15-20%,
//! and the glass views' means to 2%.
//!
//! `glass_up` (the torus from below, its sun highlight, the ceiling lit
//! only indirectly) and `glass_fish` (the room, the sun's streak on the
//! wall) were 3% and 8% too dark until adaptive shadow testing stopped
//! counting a sun the point cannot see as light already found (every
//! other source's full potential was in a bundle's threshold, so the
//! window went untested at most points ambient rays reach; see
//! `render::direct`), and 5.5% and 8% before the irradiance cache
//! followed Radiance 5 (Hessian radii, gradients; Radiance 3's cache
//! blotched `glass_up`'s ceiling 25-50% dark near the window). The
//! reference's ambient file (`-af glass.amb`) was shared with the other
//! views' renders.
//! Scenes that need files the suite lacks (`sunset.hdr`, `vase.rtm`,
//! `blinds20c.xml`) are loaded by unit tests, not compared.
//!
//! Rendering settings: rpict's defaults where ours differ (`-pj .67`),
//! then the suite's own (from the references' headers) where this
//! renderer has the option, `-ps`/`-pt` (adaptive pixel
//! sampling) included, as written (the patterns' `-ps 3 -pt .08 -ps 1`
//! ends at `-ps 1`; the mesh views sample with `-ps 3 -pt .08`); `-dp`
//! (the pretest of virtual sources, which only drops relays that are
//! blocked anyway) is left out.

use std::path::{Path, PathBuf};

use hybrid_rt::image::compare::{compare, pfilt_reduce, write_difference, Reference};
use hybrid_rt::image::{write_image, Exposure, HdrInfo, ToneMap, Transfer};
use hybrid_rt::render::{RenderOptions, Renderer};
use hybrid_rt::scene::{load_with, LoadOptions, View};

fn suite() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/radiance-tests");
    p.is_dir().then_some(p)
}

/// The suite's common settings (the `rad` QUAL=Med, IND=1 main pass) with
/// the scene's `-av`.
fn options(av: f64, extra: &str) -> RenderOptions {
    let mut o = RenderOptions::default();
    o.apply_words(&format!(
        "-pj .67 -ds .2 -dj .9 -dt .1 -dc .5 -ab 1 -aa .1 -ar 49 -ad 1536 -as 392 -av {av} {av} {av} -lr 8 -lw 1e-4 -st .02 -ss 32 {extra}"
    ))
    .unwrap();
    o.validate().unwrap();
    o
}

struct Case<'a> {
    name: &'a str,
    files: &'a [&'a str],
    av: f64,
    /// The scene's own settings where they differ from the common ones.
    extra: &'a str,
    /// Render at this multiple of the compared size, then reduce.
    scale: usize,
    /// Compare at the reference's size divided by this (the reference
    /// reduced the same way, `pfilt -1 -r 1`): 1 for the reference's own
    /// size.
    shrink: usize,
    /// The one warning the scene may load with (a file the suite lacks
    /// that no ray of the view reaches).
    allowed_warning: Option<&'a str>,
    /// Largest |1 - mean ratio| accepted.
    mean_tol: f64,
    /// Largest smoothed nRMSE accepted.
    rms_tol: f64,
}

fn run(c: &Case) {
    let Some(dir) = suite() else {
        eprintln!("skipped: ../shared/scenes/radiance-tests is not there");
        return;
    };
    let reference = Reference::load(&dir.join("ref").join(format!("{}.hdr", c.name))).unwrap();
    let view_text = reference.view.clone().expect("reference has a VIEW line");
    let view = View::from_options(&view_text).unwrap();
    let files: Vec<PathBuf> = c
        .files
        .iter()
        .map(|f| match f.strip_prefix('!') {
            // A rif's in-line scene command: written into a file of its
            // own (the command's file names made absolute).
            Some(cmd) => {
                let tmp = Path::new(env!("CARGO_TARGET_TMPDIR")).join("radiance-suite");
                std::fs::create_dir_all(&tmp).unwrap();
                let name = tmp.join(format!("{}-{}.rad", c.name, cmd.len()));
                let cmd = cmd.replace("./", &format!("{}/", dir.display()));
                std::fs::write(&name, format!("!{cmd}\n")).unwrap();
                name
            }
            None => dir.join(f),
        })
        .collect();
    let scene = load_with(
        &files,
        &LoadOptions {
            search_path: vec![dir.clone(), dir.join("lib")],
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", c.name));
    assert!(
        scene
            .warnings
            .iter()
            .all(|(_, w)| c.allowed_warning.is_some_and(|a| w.contains(a))),
        "{}: loads with warnings: {:?}",
        c.name,
        scene.warnings
    );
    let reference_film = match c.shrink {
        0 | 1 => reference.film.clone(),
        k => pfilt_reduce(&reference.film, k, 1.0),
    };
    let (w, h) = (reference_film.width(), reference_film.height());
    let renderer = Renderer::new(&scene, options(c.av, c.extra)).unwrap();
    let start = std::time::Instant::now();
    let (film, _) = renderer.render(&view, w * c.scale, h * c.scale).unwrap();
    let secs = start.elapsed().as_secs_f64();
    assert_eq!((film.width(), film.height()), (w * c.scale, h * c.scale));
    // The references' last step: `pfilt -1 -r 1 -x 128 -y 128`.
    let film = pfilt_reduce(&film, c.scale, 1.0);
    let cmp = compare(&film, &reference_film, 1).unwrap();
    println!(
        "{}: mean ratio {:.4}, smoothed nRMSE {:.4}, reference mean {:.3} cd/m2, {}x{} rendered in {:.1} s",
        c.name,
        cmp.mean_ratio,
        cmp.nrmse,
        cmp.reference_mean,
        w * c.scale,
        h * c.scale,
        secs
    );
    let ok = (1.0 - cmp.mean_ratio).abs() <= c.mean_tol && cmp.nrmse <= c.rms_tol;
    if !ok || std::env::var_os("RADIANCE_SUITE_KEEP").is_some() {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("radiance-suite");
        std::fs::create_dir_all(&out).unwrap();
        let diff = out.join(format!("{}-diff.hdr", c.name));
        write_difference(&film, &reference_film, &diff).unwrap();
        let mut f = std::io::BufWriter::new(
            std::fs::File::create(out.join(format!("{}.hdr", c.name))).unwrap(),
        );
        hybrid_rt::image::hdr::write_hdr(&mut f, &film, 1.0, &Default::default()).unwrap();
        // The same exposure for both, for looking at them side by side.
        let tone = ToneMap {
            exposure: Exposure::Fixed(reference.exposure),
            transfer: Transfer::Srgb,
        };
        let info = HdrInfo::default();
        write_image(&film, &out.join(format!("{}.png", c.name)), &tone, &info).unwrap();
        write_image(
            &reference_film,
            &out.join(format!("{}-ref.png", c.name)),
            &tone,
            &info,
        )
        .unwrap();
    }
    if !ok {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("radiance-suite");
        panic!(
            "{}: mean ratio {:.4} (tolerance ±{}), smoothed nRMSE {:.4} (tolerance {}); render and difference in {}",
            c.name,
            cmp.mean_ratio,
            c.mean_tol,
            cmp.nrmse,
            c.rms_tol,
            out.display()
        );
    }
}

const PATTERNS: &[&str] = &[
    "basic.mat",
    "patterns.mat",
    "diorama_walls.rad",
    "closed_end.rad",
    "front_cap.rad",
    "disks.rad",
    "rect_fixture.rad",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn patterns_def() {
    run(&Case {
        name: "patterns_def",
        files: PATTERNS,
        av: 0.12,
        extra: "-ps 3 -pt .08 -ps 1",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        mean_tol: 0.01,
        rms_tol: 0.05,
    });
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn patterns_plan() {
    run(&Case {
        name: "patterns_plan",
        files: PATTERNS,
        av: 0.12,
        extra: "-ps 3 -pt .08 -ps 1",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        mean_tol: 0.01,
        rms_tol: 0.05,
    });
}

const MESH: &[&str] = &[
    "basic.mat",
    "chrome.mat",
    "diorama_walls.rad",
    "closed_end.rad",
    "front_cap.rad",
    "!xform -n plainclothes -s 1.5 -rx 90 -rz -80 -t 1 0 0 -a 9 -rz 40 -i 1 -t -5 2.5 0 ./woman.rad",
    "!xform -m chrome -n shiny -s 1.5 -rx 90 -rz -105 -t 1 0 0 -rz 20 -a 9 -rz 40 -i 1 -t -5 2.5 0 ./woman.rad",
    "rect_fixture.rad",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn mesh_def() {
    run(&Case {
        name: "mesh_def",
        files: MESH,
        av: 0.12,
        extra: "-ps 3 -pt .08",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        mean_tol: 0.02,
        rms_tol: 0.2,
    });
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn mesh_cyl() {
    run(&Case {
        name: "mesh_cyl",
        files: MESH,
        av: 0.12,
        extra: "-ps 3 -pt .08",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        mean_tol: 0.02,
        rms_tol: 0.35,
    });
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn mesh_cyl2() {
    run(&Case {
        name: "mesh_cyl2",
        files: MESH,
        av: 0.12,
        extra: "-ps 3 -pt .08",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        mean_tol: 0.02,
        rms_tol: 0.3,
    });
}

/// The glass scene from its rif's files (its generators `genprism` and
/// `genrev` run built in); the sky picture is missing, and these two views
/// never see it. The window is an illum with a measured distribution
/// (`glass_ill.rad`, mkillum's output), the sun shines through it, and
/// the torus is a mixture of metal and glowing stripes.
const GLASS: &[&str] = &[
    "basic.mat",
    "diorama_walls.rad",
    "rect_opening.rad",
    "front_cap.rad",
    "torus.rad",
    "sunset_sky.rad",
    "glass_ill.rad",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for minutes unoptimised: scripts/test.sh runs it with --release"
)]
fn glass_fish() {
    run(&Case {
        name: "glass_fish",
        files: GLASS,
        av: 0.022,
        extra: "-ar 24",
        allowed_warning: Some("sunset.hdr"),
        scale: 2,
        shrink: 1,
        mean_tol: 0.02,
        rms_tol: 0.2,
    });
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for a minute unoptimised: scripts/test.sh runs it with --release"
)]
fn glass_up() {
    run(&Case {
        name: "glass_up",
        files: GLASS,
        av: 0.022,
        extra: "-ar 24",
        allowed_warning: Some("sunset.hdr"),
        scale: 4,
        shrink: 1,
        mean_tol: 0.02,
        rms_tol: 0.15,
    });
}

/// Mist (a participating medium) lit by two spotlights whose beams are mist
/// cones naming them (spotlights.rad, spotcones.rad), in a bluish mist box
/// filling the diorama; the camera looks through the front cap's back
/// (`-bv-`). The reference's own settings: `-ar 25 -ds .3` (no `-dj`),
/// `-ms 0.27`, `-av .011`. Radiance repeats itself to 0.02 % in mean and
/// 0.7 % nRMSE at 512; we sample the in-scattering and the ambient with
/// other random numbers, at 512 pixels reduced to 128, as the README's
/// Radiance runs (1.5 % against the reference).
/// The mist box lies 0.01 inside the walls, so every hemisphere ray from a
/// wall crosses its boundary first: a sample's distance is that of the
/// surface beyond (Radiance's `raytrans()`), or every record would shrink
/// to `-ar`'s smallest (the render took 1.8 times as long at 64 pixels).
const MIST: &[&str] = &[
    "basic.mat",
    "diorama_walls.rad",
    "closed_end.rad",
    "front_cap.rad",
    "gymbal.rad",
    "mist.rad",
    "spotlights.rad",
    "spotcones.rad",
];

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "renders for minutes unoptimised: scripts/test.sh runs it with --release"
)]
fn mist_def() {
    run(&Case {
        name: "mist_def",
        files: MIST,
        av: 0.011,
        extra: "-ar 25 -ds .3 -dj 0 -bv- -ms 0.27 -pj 0",
        allowed_warning: None,
        scale: 4,
        shrink: 1,
        // Measured 0.9996 and 0.95% (rendered at 128, one sample a pixel:
        // 0.9995 and 2.7%; at 64: 0.996 and 5.1%).
        mean_tol: 0.01,
        rms_tol: 0.02,
    });
}
