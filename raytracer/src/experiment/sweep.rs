//! What accuracy costs: a converged reference render, then the quality
//! knobs one at a time and in combinations, each render's error against
//! the reference and its time, and the Pareto front of (time, error).
//!
//! Error measures, over all pixels of the image, on *displayed* values:
//! both images are scaled by the exposure that maps the reference's mean
//! luminance to 0.5 (as the PNG writer's automatic exposure does) and
//! clipped to [0, 1] per channel, so a visible light source, thousands of
//! times brighter than the walls, counts as white and not as the whole
//! error.
//! - **RMSE**: root mean square difference of the RGB channels, reported
//!   relative to the mean displayed reference luminance (`rel_rmse`) so
//!   that scenes compare;
//! - **mean relative luminance error**: the mean of `|L - L_ref| /
//!   max(L_ref, 0.01)` (the floor keeps black pixels from dominating).
//!
//! Times are the CPU time of the thread running the sequential renderer
//! (render and octree build; wall-clock time where the platform has no
//! thread clock): other work on a shared machine, or a paused sweep, does
//! not count. Wall-clock seconds are kept beside them. Either is only
//! comparable within one sweep on one machine.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::image::{brightness, Film};
use crate::render::{RenderOptions, Renderer};
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::scene::{Scene, View};
use crate::Result;

/// One configuration of the sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepConfig {
    pub name: String,
    pub options: RenderOptions,
}

/// One measured configuration.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepPoint {
    pub name: String,
    pub options: RenderOptions,
    /// CPU seconds of the rendering thread (see the module documentation).
    pub time_s: f64,
    /// Wall-clock seconds of the same render.
    #[serde(default)]
    pub wall_s: f64,
    /// Rays cast (all kinds).
    pub rays: u64,
    pub rmse: f64,
    pub rel_rmse: f64,
    pub mean_rel_lum_err: f64,
    pub pareto: bool,
}

/// A whole sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SweepReport {
    pub scene: String,
    pub width: usize,
    pub height: usize,
    pub reference: RenderOptions,
    pub reference_s: f64,
    pub points: Vec<SweepPoint>,
}

/// Options of the reference: fine source subdivision, every shadow ray
/// traced, jittered sources and 16 jittered pixel samples, two ambient
/// bounces with twice rpict's hemisphere rays and a tighter cache. (What
/// two shared cores can afford for the built-in scenes at 64x64: it is
/// converged in everything but the ambient, whose error is a few
/// percent; see the book.)
pub fn reference_options(seed: u64) -> RenderOptions {
    RenderOptions {
        ds: 0.05,
        dj: 0.7,
        dt: 0.0,
        dc: 1.0,
        pn: 16,
        pj: 1.0,
        ab: 2,
        aa: 0.07,
        ar: 256,
        ad: 1024,
        as_: 256,
        lw: 0.0005,
        seed,
        ..RenderOptions::default()
    }
}

fn with(name: &str, f: impl FnOnce(&mut RenderOptions), seed: u64) -> SweepConfig {
    let mut o = RenderOptions {
        seed: seed.wrapping_add(1), // never the reference's own streams
        ..RenderOptions::default()
    };
    f(&mut o);
    SweepConfig {
        name: name.into(),
        options: o,
    }
}

/// A quality preset ([`RenderOptions::preset`]) as a configuration.
fn preset(name: &str, seed: u64) -> SweepConfig {
    let options = RenderOptions::preset(name).expect("a preset of QUALITY_PRESETS");
    with(
        &format!("preset {name}"),
        |o| {
            *o = RenderOptions {
                seed: o.seed,
                ..options
            }
        },
        seed,
    )
}

/// The configurations: rpict's defaults, each knob varied alone, the
/// ambient settings from coarse to fine, and the quality presets.
pub fn configurations(seed: u64) -> Vec<SweepConfig> {
    let amb = |o: &mut RenderOptions, ab, aa, ad, as_| {
        o.ab = ab;
        o.aa = aa;
        o.ad = ad;
        o.as_ = as_;
    };
    let pix = |o: &mut RenderOptions, n| {
        o.pn = n;
        o.pj = 1.0;
    };
    vec![
        with("defaults", |_| {}, seed),
        with("ds 0.5", |o| o.ds = 0.5, seed),
        with("ds 0.1", |o| o.ds = 0.1, seed),
        with("ds 0.05", |o| o.ds = 0.05, seed),
        with("dt 0.3", |o| o.dt = 0.3, seed),
        with("dt 0", |o| o.dt = 0.0, seed),
        with("dc 0.25", |o| o.dc = 0.25, seed),
        with("dc 1", |o| o.dc = 1.0, seed),
        with("dj 0.5", |o| o.dj = 0.5, seed),
        with("dj 1", |o| o.dj = 1.0, seed),
        with("pn 4", |o| pix(o, 4), seed),
        with("pn 9", |o| pix(o, 9), seed),
        with("ab 1 aa .3 ad 64", |o| amb(o, 1, 0.3, 64, 16), seed),
        with("ab 1 aa .2 ad 128", |o| amb(o, 1, 0.2, 128, 32), seed),
        with("ab 1 aa .1 ad 256", |o| amb(o, 1, 0.1, 256, 64), seed),
        with("ab 1 (rpict)", |o| amb(o, 1, 0.1, 512, 128), seed),
        with("ab 1 aa .05 ad 512", |o| amb(o, 1, 0.05, 512, 128), seed),
        with("ab 2 aa .1 ad 256", |o| amb(o, 2, 0.1, 256, 64), seed),
        preset("draft", seed),
        preset("normal", seed),
        preset("high", seed),
    ]
}

/// (RMSE, RMSE relative to mean reference luminance, mean relative
/// luminance error) of `film` against `reference`, on displayed values
/// (see the module documentation).
pub fn image_error(film: &Film, reference: &Film) -> (f64, f64, f64) {
    let n = reference.pixels().len().max(1) as f64;
    let mean_raw = reference
        .pixels()
        .iter()
        .map(|c| brightness(*c))
        .sum::<f64>()
        / n;
    let k = if mean_raw > 0.0 && mean_raw.is_finite() {
        0.5 / mean_raw
    } else {
        1.0
    };
    let shown = |c: crate::scene::Color| {
        let c = c * k;
        if c.is_finite() {
            c.clamp(crate::scene::Color::ZERO, crate::scene::Color::ONE)
        } else {
            crate::scene::Color::ONE
        }
    };
    let mean_l = reference
        .pixels()
        .iter()
        .map(|c| brightness(shown(*c)))
        .sum::<f64>()
        / n;
    let mut se = 0.0;
    let mut rel = 0.0;
    for (p, q) in film.pixels().iter().zip(reference.pixels()) {
        let (p, q) = (shown(*p), shown(*q));
        let d = p - q;
        se += d.dot(d) / 3.0;
        let (lp, lq) = (brightness(p), brightness(q));
        rel += (lp - lq).abs() / lq.max(0.01);
    }
    let rmse = (se / n).sqrt();
    (rmse, rmse / mean_l.max(1e-300), rel / n)
}

/// Marks the points no other point beats in both time and error
/// (`rel_rmse`), ties broken towards the earlier point.
pub fn mark_pareto(points: &mut [SweepPoint]) {
    let keys: Vec<(f64, f64)> = points.iter().map(|p| (p.time_s, p.rel_rmse)).collect();
    for (i, p) in points.iter_mut().enumerate() {
        let (t, e) = keys[i];
        p.pareto = !keys
            .iter()
            .enumerate()
            .any(|(j, &(tj, ej))| j != i && tj <= t && ej <= e && (tj < t || ej < e || j < i));
    }
}

/// Renders the reference and every configuration of `configs`, calling
/// `progress` with a line per render.
#[allow(clippy::too_many_arguments)]
pub fn run(
    name: &str,
    scene: &Scene,
    view: &View,
    width: usize,
    height: usize,
    reference: RenderOptions,
    configs: &[SweepConfig],
    progress: &mut dyn FnMut(&str),
) -> Result<(SweepReport, Film)> {
    let ((ref_film, _), reference_s, ref_wall) =
        timed(|| Renderer::new(scene, reference.clone())?.render(view, width, height))?;
    progress(&format!(
        "reference: {reference_s:.2} s CPU ({ref_wall:.2} s wall)"
    ));
    let mut points = Vec::with_capacity(configs.len());
    for c in configs {
        let ((film, stats), cpu_s, wall_s) =
            timed(|| Renderer::new(scene, c.options.clone())?.render(view, width, height))?;
        let (rmse, rel_rmse, mrle) = image_error(&film, &ref_film);
        progress(&format!(
            "{:<22} {:>8.3} s CPU {:>8.3} s wall  rel. RMSE {:.4}  mean rel. lum. error {:.4}",
            c.name, cpu_s, wall_s, rel_rmse, mrle
        ));
        points.push(SweepPoint {
            name: c.name.clone(),
            options: c.options.clone(),
            time_s: cpu_s,
            wall_s,
            rays: stats.rays.traced(),
            rmse,
            rel_rmse,
            mean_rel_lum_err: mrle,
            pareto: false,
        });
    }
    mark_pareto(&mut points);
    Ok((
        SweepReport {
            scene: name.into(),
            width,
            height,
            reference,
            reference_s,
            points,
        },
        ref_film,
    ))
}

/// Runs `f` on this thread: its result, CPU seconds and wall seconds.
fn timed<T>(f: impl FnOnce() -> Result<T>) -> Result<(T, f64, f64)> {
    let (c0, w0) = (thread_cpu_s(), Instant::now());
    let out = f()?;
    let wall = w0.elapsed().as_secs_f64();
    let cpu = match (c0, thread_cpu_s()) {
        (Some(a), Some(b)) => b - a,
        _ => wall,
    };
    Ok((out, cpu, wall))
}

/// CPU time consumed by the calling thread, in seconds.
#[cfg(unix)]
pub fn thread_cpu_s() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time consumed by the calling thread (not available here).
#[cfg(not(unix))]
pub fn thread_cpu_s() -> Option<f64> {
    None
}

/// The options that differ from rpict's defaults, Radiance style.
pub fn option_words(o: &RenderOptions) -> String {
    let d = RenderOptions::default();
    let mut w = Vec::new();
    let mut f = |name: &str, v: f64, dv: f64| {
        if v != dv {
            w.push(format!("-{name} {v}"));
        }
    };
    f("ds", o.ds, d.ds);
    f("dt", o.dt, d.dt);
    f("dc", o.dc, d.dc);
    f("dj", o.dj, d.dj);
    f("pn", o.pn as f64, d.pn as f64);
    f("pj", o.pj, d.pj);
    f("ab", o.ab as f64, d.ab as f64);
    if o.ab > 0 {
        f("aa", o.aa, d.aa);
        f("ar", o.ar as f64, d.ar as f64);
        f("ad", o.ad as f64, d.ad as f64);
        f("as", o.as_ as f64, d.as_ as f64);
    }
    f("lw", o.lw, d.lw);
    if w.is_empty() {
        "(rpict defaults)".into()
    } else {
        w.join(" ")
    }
}

impl SweepReport {
    pub fn to_csv(&self) -> String {
        let mut s = String::from(
            "name,ds,dt,dc,dj,pn,pj,ab,aa,ar,ad,as,time_s,wall_s,rays,rmse,rel_rmse,mean_rel_lum_err,pareto\n",
        );
        for p in &self.points {
            let o = &p.options;
            s += &format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{:.6},{:.6},{},{:.6e},{:.6},{:.6},{}\n",
                p.name.replace(',', ";"),
                o.ds,
                o.dt,
                o.dc,
                o.dj,
                o.pn,
                o.pj,
                o.ab,
                o.aa,
                o.ar,
                o.ad,
                o.as_,
                p.time_s,
                p.wall_s,
                p.rays,
                p.rmse,
                p.rel_rmse,
                p.mean_rel_lum_err,
                p.pareto
            );
        }
        s
    }

    /// `sweep.md`: a line naming the scene, size and reference, then
    /// [`SweepReport::to_markdown`].
    pub fn markdown_file(&self) -> String {
        format!(
            "Sweep of `{}` at {}x{}; reference ({:.1} s): `{}`.\n\n{}",
            self.scene,
            self.width,
            self.height,
            self.reference_s,
            option_words(&self.reference),
            self.to_markdown()
        )
    }

    /// The points as a markdown table, sorted by time; front points in bold.
    pub fn to_markdown(&self) -> String {
        let mut t = Table::new([
            "configuration",
            "options",
            "CPU time (s)",
            "rays",
            "rel. RMSE",
            "mean rel. lum. error",
            "front",
        ]);
        let mut idx: Vec<usize> = (0..self.points.len()).collect();
        idx.sort_by(|&a, &b| self.points[a].time_s.total_cmp(&self.points[b].time_s));
        for i in idx {
            let p = &self.points[i];
            t.row([
                p.name.clone(),
                option_words(&p.options),
                format!("{:.3}", p.time_s),
                p.rays.to_string(),
                format!("{:.4}", p.rel_rmse),
                format!("{:.4}", p.mean_rel_lum_err),
                if p.pareto {
                    "**yes**".into()
                } else {
                    String::new()
                },
            ]);
        }
        t.to_markdown()
    }

    /// Error against time: every configuration, and the front joined.
    pub fn chart(&self) -> Chart {
        let all = self
            .points
            .iter()
            .map(|p| (p.time_s.max(1e-6), p.rel_rmse))
            .collect();
        let mut front: Vec<(f64, f64)> = self
            .points
            .iter()
            .filter(|p| p.pareto)
            .map(|p| (p.time_s.max(1e-6), p.rel_rmse))
            .collect();
        front.sort_by(|a, b| a.0.total_cmp(&b.0));
        Chart {
            title: format!(
                "{}: error against time ({}x{})",
                self.scene, self.width, self.height
            ),
            x_label: "CPU time (s, log scale)".into(),
            y_label: "RMSE / mean reference luminance".into(),
            series: vec![
                Series::new("configurations", all, Mark::Points),
                Series::new("Pareto front", front, Mark::LinePoints),
            ],
            y_range: None,
            x_log: true,
        }
    }

    /// Front points ordered by time.
    pub fn front(&self) -> Vec<&SweepPoint> {
        let mut f: Vec<&SweepPoint> = self.points.iter().filter(|p| p.pareto).collect();
        f.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(t: f64, e: f64) -> SweepPoint {
        SweepPoint {
            name: format!("{t}/{e}"),
            options: RenderOptions::default(),
            time_s: t,
            wall_s: t,
            rays: 0,
            rmse: e,
            rel_rmse: e,
            mean_rel_lum_err: e,
            pareto: false,
        }
    }

    #[test]
    fn pareto_front_is_the_undominated_set() {
        let mut p = vec![
            pt(1.0, 0.5),
            pt(2.0, 0.2),
            pt(3.0, 0.3),
            pt(4.0, 0.1),
            pt(4.0, 0.1),
        ];
        mark_pareto(&mut p);
        let f: Vec<bool> = p.iter().map(|p| p.pareto).collect();
        assert_eq!(f, [true, true, false, true, false]);
    }

    #[test]
    fn error_measures() {
        let mut a = Film::new(2, 1);
        let mut b = Film::new(2, 1);
        a.set(0, 0, crate::scene::Color::splat(1.0));
        a.set(1, 0, crate::scene::Color::splat(1.0));
        b.set(0, 0, crate::scene::Color::splat(1.0));
        b.set(1, 0, crate::scene::Color::splat(2.0));
        // Reference mean luminance 1.5 -> exposure 1/3: shown 1/3 and 2/3.
        let (rmse, rel, mrle) = image_error(&a, &b);
        assert!((rmse - (1.0f64 / 18.0).sqrt()).abs() < 1e-9, "{rmse}");
        assert!((rel - (1.0f64 / 18.0).sqrt() / 0.5).abs() < 1e-9, "{rel}");
        assert!((mrle - 0.25).abs() < 1e-9, "{mrle}");
        // A source far brighter than the rest counts as white.
        let mut c = Film::new(10, 1);
        for x in 0..9 {
            c.set(x, 0, crate::scene::Color::ONE);
        }
        let mut d = c.clone();
        c.set(9, 0, crate::scene::Color::splat(1e6));
        d.set(9, 0, crate::scene::Color::splat(2e6));
        assert!(image_error(&c, &d).0 < 1e-9);
        assert_eq!(image_error(&b, &b).0, 0.0);
    }

    #[test]
    fn configurations_are_valid_and_named_once() {
        let c = configurations(0);
        for x in &c {
            x.options.validate().unwrap();
        }
        reference_options(0).validate().unwrap();
        let mut names: Vec<&str> = c.iter().map(|x| x.name.as_str()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), c.len());
    }
}
