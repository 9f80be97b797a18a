//! The cost model's calibration (`hybrid-rt experiment calibrate`): fits
//! the per-unit costs of [`crate::parallel::cost::UNIT_NS`] and the
//! framework's per-step overhead on this machine (see
//! [`crate::parallel::cost`] for the method and the built-in constants).

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use hybrid_sched::{run_sequential_observed, Config, Runtime, Threads};
use serde::Serialize;

use crate::accel::OctreeParams;
use crate::parallel::cost::{model, UNIT_NS};
use crate::parallel::Work;
use crate::parallel::{RtWorkload, WorkloadOptions};
use crate::render::{RenderOptions, Renderer};
use crate::scene::{Scene, View};
use crate::{Error, Result};

/// What [`calibrate`] found.
#[derive(Clone, Debug, Serialize)]
pub struct Calibration {
    /// Fitted ns per unit (kinds of [`UNIT_NS`]).
    pub unit_ns: BTreeMap<String, f64>,
    /// Fitted fixed cost per task step of the workload itself.
    pub intercept_ns: f64,
    /// Framework overhead per step from the threads run.
    pub step_ns: f64,
    /// Steps sampled.
    pub steps: u64,
    /// Measured time of the sequential runtime's steps, and the fit's
    /// prediction of it.
    pub measured_s: f64,
    pub predicted_s: f64,
    /// Coefficient of determination of the fit (over batches of 256
    /// consecutive steps).
    pub r_squared: f64,
    /// One-processor threads run: measured seconds.
    pub threads_s: f64,
    /// The built-in model's prediction for that run (no network costs).
    pub builtin_predicted_s: f64,
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
    let renderer = Renderer::shared(scene.clone(), options.clone(), &OctreeParams::default())?;
    // Two processors' partition in the sequential runtime: every cell is
    // local, but tiles and bundles are clipped as a processor of two would
    // clip them, so clipping is sampled too.
    let wl2 = RtWorkload::new(
        renderer,
        view.clone(),
        width,
        height,
        2,
        WorkloadOptions::default(),
    );
    // Variables: the unit kinds, then the intercept. Steps are summed in
    // batches of BATCH consecutive steps (single steps last microseconds,
    // below the timer's and the caches' noise), and the pass is repeated
    // RUNS times keeping each batch's fastest time: the work is identical
    // in every pass, so the minimum strips preemption by other processes.
    const BATCH: u64 = 256;
    const RUNS: usize = 3;
    let n = UNIT_NS.len() + 1;
    let mut samples: Vec<(Vec<f64>, f64)> = Vec::new();
    let mut steps = 0u64;
    for run in 0..RUNS {
        let mut x = vec![0.0; n];
        let mut y = 0.0;
        let mut in_batch = 0u64;
        let mut k = 0usize;
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
        steps = 0;
        run_sequential_observed(&wl2, 2, &mut |charges, ns| {
            for &(kind, units) in charges {
                if let Some(i) = UNIT_NS.iter().position(|&(k, _)| k == kind) {
                    x[i] += units as f64;
                }
            }
            x[n - 1] += 1.0;
            y += ns as f64;
            steps += 1;
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
        WorkloadOptions::default(),
    ));
    let coef = nnls(&ata, &atb);
    let predict = |x: &[f64]| x.iter().zip(&coef).map(|(a, b)| a * b).sum::<f64>();
    let mean = sum_y / batches;
    let ss_tot = sum_yy - batches * mean * mean;
    let ss_res: f64 = samples.iter().map(|(x, y)| (y - predict(x)).powi(2)).sum();
    let predicted: f64 = samples.iter().map(|(x, _)| predict(x)).sum();

    // Framework overhead per step from a one-processor threads run.
    let config = Config::new(1);
    let t0 = Instant::now();
    let report = Threads
        .run_blocking(wl.clone(), &config)
        .map_err(|e| Error::Other(format!("calibration run failed: {e}")))?;
    let threads_s = t0.elapsed().as_secs_f64();
    let st = &report.stats.procs[0];
    let units = |k: Work| st.work.get(k.name()).copied().unwrap_or(0) as f64;
    let work_ns: f64 = UNIT_NS
        .iter()
        .enumerate()
        .map(|(i, &(k, _))| units(k) * coef[i])
        .sum();
    let tsteps =
        (st.tasks.selections + st.tasks.demand_driven + st.tasks.data_parallel_steps).max(1) as f64;
    let step_ns = ((threads_s * 1e9 - work_ns) / tsteps).max(0.0);
    let builtin = model();
    let builtin_ns: f64 = UNIT_NS
        .iter()
        .map(|&(k, _)| units(k) * builtin.unit_ns[k.name()])
        .sum::<f64>()
        + tsteps * builtin.step_ns;
    Ok(Calibration {
        unit_ns: UNIT_NS
            .iter()
            .enumerate()
            .map(|(i, (k, _))| (k.name().to_string(), coef[i]))
            .collect(),
        intercept_ns: coef[n - 1],
        step_ns,
        steps,
        measured_s: sum_y * 1e-9,
        predicted_s: predicted * 1e-9,
        r_squared: if ss_tot > 0.0 {
            1.0 - ss_res / ss_tot
        } else {
            1.0
        },
        threads_s,
        builtin_predicted_s: builtin_ns * 1e-9,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

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
