//! The cost model's calibration (`hybrid-rt experiment calibrate`): fits
//! the per-unit costs of [`crate::parallel::cost::FITTED`] and the
//! framework's per-step overhead on this machine, writes them as a model
//! file (the committed one is `experiments/cost-model.json`), and reports
//! how far the committed model's prediction of a one-processor threads run
//! is from the measured time (see [`crate::parallel::cost`] for the method).

use std::sync::Arc;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use hybrid_sched::{run_sequential_observed, Config, Runtime, Threads};
use serde::Serialize;

use crate::accel::OctreeParams;
use crate::parallel::cost::{self, Fit, ModelFile, FITTED};
use crate::parallel::{RtWorkload, WorkloadOptions};
use crate::render::{RenderOptions, Renderer};
use crate::scene::{Scene, View};
use crate::{Error, Result};

/// Refit when the committed model's prediction of a one-processor threads
/// run is further than this from the measured time.
pub const REFIT_ABOVE: f64 = 0.10;

/// What [`calibrate`] found.
#[derive(Clone, Debug, Serialize)]
pub struct Calibration {
    /// The new model file (fitted on this machine).
    pub file: ModelFile,
    /// One-processor threads run: measured CPU seconds of the process (the
    /// least of [`THREADS_RUNS`]; wall time where CPU time is not
    /// available).
    pub threads_s: f64,
    /// The committed model's prediction of that run (its work at the
    /// model's prices plus its steps at `step_ns`, no network costs).
    pub committed_predicted_s: f64,
    /// `committed_predicted_s / threads_s - 1`: refit past
    /// [`REFIT_ABOVE`] in magnitude.
    pub committed_error: f64,
}

impl Calibration {
    /// Whether the committed model is off by more than [`REFIT_ABOVE`].
    pub fn needs_refit(&self) -> bool {
        self.committed_error.abs() > REFIT_ABOVE
    }
}

/// Repeats of the one-processor threads run (the fastest is kept: the work
/// is identical, so the minimum strips preemption by other processes).
pub const THREADS_RUNS: usize = 3;

/// What is known of this machine: CPU model, logical CPUs, OS and
/// architecture, and how busy it was (the one-minute load average: on a
/// shared machine other work competes with the timed runs).
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let n = std::thread::available_parallelism().map_or(0, |n| n.get());
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|t| {
            t.split_whitespace()
                .next()
                .map(|l| format!(", load average {l}"))
        })
        .unwrap_or_default();
    format!(
        "{cpu}, {n} logical CPUs, {}-{}, release build{load}",
        std::env::consts::OS,
        std::env::consts::ARCH
    )
}

/// CPU time consumed by this process (all its threads), in seconds: on a
/// machine shared with other work, wall time would charge their time
/// slices to the framework.
#[cfg(unix)]
fn process_cpu_s() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of this process (not available here: wall time is used).
#[cfg(not(unix))]
fn process_cpu_s() -> Option<f64> {
    None
}

/// Today's date (UTC) as `YYYY-MM-DD`.
pub fn today() -> String {
    let days = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    let (y, m, d) = civil_from_days(days);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Days since 1970-01-01 to a proleptic Gregorian (year, month, day)
/// (Howard Hinnant's algorithm).
fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// Non-negative least squares on accumulated normal equations: drops
/// variables whose unconstrained estimate is negative until none is.
fn nnls(ata: &[Vec<f64>], atb: &[f64]) -> Vec<f64> {
    let n = atb.len();
    let mut active: Vec<bool> = vec![true; n];
    loop {
        let idx: Vec<usize> = (0..n).filter(|&i| active[i]).collect();
        let m = idx.len();
        let mut a: Vec<Vec<f64>> = idx
            .iter()
            .map(|&i| {
                let mut row: Vec<f64> = idx.iter().map(|&j| ata[i][j]).collect();
                row.push(atb[i]);
                row
            })
            .collect();
        // Gaussian elimination with partial pivoting and a tiny ridge.
        for (k, row) in a.iter_mut().enumerate() {
            row[k] += 1e-9 * (1.0 + row[k].abs());
        }
        for c in 0..m {
            let p = (c..m)
                .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
                .unwrap_or(c);
            a.swap(c, p);
            let piv = a[c][c];
            if piv.abs() < 1e-300 {
                continue;
            }
            let pivot_row = a[c].clone();
            for (r, row) in a.iter_mut().enumerate() {
                if r != c {
                    let f = row[c] / piv;
                    if f != 0.0 {
                        for (v, p) in row[c..].iter_mut().zip(&pivot_row[c..]) {
                            *v -= f * p;
                        }
                    }
                }
            }
        }
        let sol: Vec<f64> = (0..m)
            .map(|i| {
                if a[i][i].abs() < 1e-300 {
                    0.0
                } else {
                    a[i][m] / a[i][i]
                }
            })
            .collect();
        let mut x = vec![0.0; n];
        let mut negative = false;
        for (k, &i) in idx.iter().enumerate() {
            if sol[k] < 0.0 {
                active[i] = false;
                negative = true;
            } else {
                x[i] = sol[k];
            }
        }
        if !negative {
            return x;
        }
    }
}

/// Fits the cost model on `scene` (see the module documentation).
pub fn calibrate(
    scene: Arc<Scene>,
    options: RenderOptions,
    view: &View,
    width: usize,
    height: usize,
) -> Result<Calibration> {
    // Variables: the unit kinds, then the intercept. Steps are summed in
    // batches of BATCH consecutive steps (single steps last microseconds,
    // below the timer's and the caches' noise), and each pass is repeated
    // RUNS times keeping each batch's fastest time: the work is identical
    // in every pass, so the minimum strips preemption by other processes.
    //
    // Two workloads in the sequential runtime: one processor's (the mix of
    // work the threads run below does, whose time the model must predict)
    // and two processors' partition (every cell is still local, but tiles
    // and bundles are clipped as a processor of two would clip them, so
    // clipping is sampled too).
    const BATCH: u64 = 256;
    const RUNS: usize = 3;
    let n = FITTED.len() + 1;
    let mut samples: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut steps = 0u64;
    for parts in [1, 2] {
        let renderer = Renderer::shared(scene.clone(), options.clone(), &OctreeParams::default())?;
        let wl = RtWorkload::new(
            renderer,
            view.clone(),
            width,
            height,
            parts,
            // Every shadow bundle a step of its own. With coarse tasks (the
            // default) a point's bundles share its shading step in a fixed
            // ratio, and the fit gives `shade` their whole cost, which
            // underprices a scene with many lights per point (the
            // conference room by 94%); fitted here, a bundle's price keeps
            // what a step of its own costs, which overprices coarse runs
            // (the check below says by how much).
            WorkloadOptions {
                inline_local_shadows: false,
                // The model prices the octree walk.
                local_kernel: false,
                ..WorkloadOptions::default()
            },
        );
        let first = samples.len();
        let mut pass_steps = 0u64;
        for run in 0..RUNS {
            let mut x = vec![0.0; n];
            let mut y = 0.0;
            let mut in_batch = 0u64;
            let mut k = first;
            let mut push = |x: &mut Vec<f64>, y: &mut f64, samples: &mut Vec<(Vec<f64>, f64)>| {
                if run == 0 {
                    samples.push((x.clone(), *y));
                } else if let Some(s) = samples.get_mut(k) {
                    s.1 = s.1.min(*y);
                }
                k += 1;
                x.iter_mut().for_each(|v| *v = 0.0);
                *y = 0.0;
            };
            pass_steps = 0;
            run_sequential_observed(&wl, parts, &mut |charges, ns| {
                for &(kind, units) in charges {
                    if let Some(i) = FITTED.iter().position(|&k| k == kind) {
                        x[i] += units as f64;
                    }
                }
                x[n - 1] += 1.0;
                y += ns as f64;
                pass_steps += 1;
                in_batch += 1;
                if in_batch == BATCH {
                    push(&mut x, &mut y, &mut samples);
                    in_batch = 0;
                }
            })
            .map_err(|e| Error::Other(format!("calibration run failed: {e}")))?;
            if in_batch > 0 {
                push(&mut x, &mut y, &mut samples);
            }
        }
        steps += pass_steps;
    }
    if steps == 0 {
        return Err(Error::Other(
            "calibration: the scene produced no work".into(),
        ));
    }
    let mut ata = vec![vec![0.0; n]; n];
    let mut atb = vec![0.0; n];
    let (mut sum_y, mut sum_yy) = (0.0f64, 0.0f64);
    for (x, y) in &samples {
        for i in 0..n {
            atb[i] += x[i] * y;
            for j in 0..n {
                ata[i][j] += x[i] * x[j];
            }
        }
        sum_y += y;
        sum_yy += y * y;
    }
    let batches = samples.len() as f64;
    if std::env::var_os("HYBRID_RT_CALIBRATION_DUMP").is_some() {
        for (x, y) in &samples {
            eprintln!("{x:?} {y}");
        }
    }
    let renderer = Renderer::shared(scene, options, &OctreeParams::default())?;
    let wl = Arc::new(RtWorkload::new(
        renderer,
        view.clone(),
        width,
        height,
        1,
        WorkloadOptions {
            local_kernel: false,
            ..WorkloadOptions::default()
        },
    ));
    let coef = nnls(&ata, &atb);
    let predict = |x: &[f64]| x.iter().zip(&coef).map(|(a, b)| a * b).sum::<f64>();
    let mean = sum_y / batches;
    let ss_tot = sum_yy - batches * mean * mean;
    let ss_res: f64 = samples.iter().map(|(x, y)| (y - predict(x)).powi(2)).sum();
    let predicted: f64 = samples.iter().map(|(x, _)| predict(x)).sum();

    // Framework overhead per step from one-processor threads runs (the
    // fastest of THREADS_RUNS; every run does the same work).
    let config = Config::new(1);
    let (mut threads_s, mut threads_wall_s) = (f64::INFINITY, f64::INFINITY);
    let mut report = None;
    for _ in 0..THREADS_RUNS {
        let (t0, c0) = (Instant::now(), process_cpu_s());
        let r = Threads
            .run_blocking(wl.clone(), &config)
            .map_err(|e| Error::Other(format!("calibration run failed: {e}")))?;
        let wall = t0.elapsed().as_secs_f64();
        let cpu = match (c0, process_cpu_s()) {
            (Some(a), Some(b)) => b - a,
            _ => wall,
        };
        threads_s = threads_s.min(cpu);
        threads_wall_s = threads_wall_s.min(wall);
        report = Some(r);
    }
    let report = report.expect("THREADS_RUNS > 0");
    let st = &report.stats.procs[0];
    let units = |k: crate::parallel::Work| st.work.get(k.name()).copied().unwrap_or(0) as f64;
    let work_ns: f64 = FITTED
        .iter()
        .enumerate()
        .map(|(i, &k)| units(k) * coef[i])
        .sum();
    let tsteps =
        (st.tasks.selections + st.tasks.demand_driven + st.tasks.data_parallel_steps).max(1);
    let step_ns = ((threads_s * 1e9 - work_ns) / tsteps as f64).max(0.0);
    let committed = cost::committed();
    let committed_ns = cost::predict_ns(&committed.model, &st.work, tsteps);
    let mut model = committed.model.clone();
    model.unit_ns = FITTED
        .iter()
        .enumerate()
        .map(|(i, k)| (k.name().to_string(), coef[i]))
        .collect();
    model.step_ns = step_ns;
    let file = ModelFile {
        about: committed.about.clone(),
        command: String::new(),
        machine: machine(),
        date: today(),
        scene: String::new(),
        width,
        height,
        fit: Fit {
            steps,
            r_squared: if ss_tot > 0.0 {
                1.0 - ss_res / ss_tot
            } else {
                1.0
            },
            intercept_ns: coef[n - 1],
            sequential_measured_s: sum_y * 1e-9,
            sequential_fitted_s: predicted * 1e-9,
            threads_s,
            threads_wall_s,
            threads_steps: tsteps,
        },
        model,
        // Not fitted: carried over from the committed file with their sources.
        assumed: committed.assumed.clone(),
    };
    let committed_predicted_s = committed_ns * 1e-9;
    Ok(Calibration {
        file,
        threads_s,
        committed_predicted_s,
        committed_error: committed_predicted_s / threads_s - 1.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn days_become_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(59), (1970, 3, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(20_783), (2026, 11, 26));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
    }

    #[test]
    fn nnls_recovers_costs_and_drops_negative_ones() {
        // y = 2 a + 5 b exactly, over varied samples.
        let mut ata = vec![vec![0.0; 3]; 3];
        let mut atb = vec![0.0; 3];
        for k in 0..50 {
            let x = [(k % 7) as f64, (k % 5) as f64 + 1.0, 1.0];
            let y = 2.0 * x[0] + 5.0 * x[1];
            for i in 0..3 {
                atb[i] += x[i] * y;
                for j in 0..3 {
                    ata[i][j] += x[i] * x[j];
                }
            }
        }
        let c = nnls(&ata, &atb);
        assert!((c[0] - 2.0).abs() < 1e-6 && (c[1] - 5.0).abs() < 1e-6 && c[2].abs() < 1e-6);
        // A variable that would need a negative cost is dropped (zero).
        let mut ata = vec![vec![0.0; 2]; 2];
        let mut atb = vec![0.0; 2];
        for k in 0..20 {
            let x = [k as f64, 1.0];
            let y = 100.0 - k as f64;
            for i in 0..2 {
                atb[i] += x[i] * y;
                for j in 0..2 {
                    ata[i][j] += x[i] * x[j];
                }
            }
        }
        let c = nnls(&ata, &atb);
        assert_eq!(c[0], 0.0);
        assert!(c[1] > 0.0);
    }
}
