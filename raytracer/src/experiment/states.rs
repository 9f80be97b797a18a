//! Figures 7 and 8: processors clipping, and processors idle, over time
//! and per processor (one figure shape over different processor states).

use hybrid_sched::State;
use serde_json::json;

use super::harness::{over_time, per_proc, proc_names, secs, Ctx, RunSpec};
use crate::report::plot::{Bars, Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

/// Figure 7: pyramid clipping.
pub(super) fn clipping(cx: &mut Ctx) -> Result<()> {
    state_figure(
        cx,
        "clipping",
        "Figure 7: pyramid clipping",
        &[State::Selecting],
        "processors clipping",
    )
}

/// Figure 8: idle time.
pub(super) fn idle(cx: &mut Ctx) -> Result<()> {
    state_figure(
        cx,
        "idle",
        "Figure 8: idle time",
        &[State::Idle, State::WaitingData],
        "processors idle",
    )
}

fn state_figure(cx: &mut Ctx, name: &str, title: &str, states: &[State], what: &str) -> Result<()> {
    let r = cx.detail()?;
    let curve = over_time(&r, states, 100);
    let ours = cx.run(RunSpec::ours(r.options.procs))?;
    let curve_ours = over_time(&ours, states, 100);
    cx.chart(
        &format!("{name}-time.svg"),
        &Chart {
            title: format!("{title} over time ({} processors)", r.options.procs),
            x_label: "time (s)".into(),
            y_label: what.into(),
            series: vec![
                Series::new(format!("{what} (paper)"), curve.clone(), Mark::Line),
                Series::new(format!("{what} (ours)"), curve_ours.clone(), Mark::Line),
            ],
            ..Chart::default()
        },
    )?;
    let per_ours = per_proc(&ours, |p| {
        states.iter().map(|&s| p.time_ns.get(s)).sum::<u64>() as f64 * 1e-9
    });
    let per = per_proc(&r, |p| {
        states.iter().map(|&s| p.time_ns.get(s)).sum::<u64>() as f64 * 1e-9
    });
    cx.bars(
        &format!("{name}-procs.svg"),
        &Bars {
            title: format!("{title} per processor"),
            y_label: "seconds".into(),
            categories: proc_names(&r),
            parts: states
                .iter()
                .map(|&s| {
                    (
                        format!("{s:?}"),
                        per_proc(&r, |p| p.time_ns.get(s) as f64 * 1e-9),
                    )
                })
                .collect(),
        },
    )?;
    let mut t = Table::new([
        "processor",
        "paper: seconds",
        "paper: % of run",
        "ours: seconds",
        "ours: % of run",
    ]);
    let el = secs(r.stats.elapsed_ns).max(1e-12);
    let el_ours = secs(ours.stats.elapsed_ns).max(1e-12);
    for (p, v) in per.iter().enumerate() {
        let o = per_ours.get(p).copied().unwrap_or(0.0);
        t.row([
            p.to_string(),
            format!("{v:.4}"),
            format!("{:.1}", 100.0 * v / el),
            format!("{o:.4}"),
            format!("{:.1}", 100.0 * o / el_ours),
        ]);
    }
    cx.finish(
        name,
        &format!("{title} over time and per processor"),
        &format!(
            "States counted: {states:?}. Run time {el:.3} s (paper) and {el_ours:.3} s (ours) on {} processors.",
            r.options.procs
        ),
        &[t],
        json!({"over_time": curve, "per_processor_s": per,
            "ours_over_time": curve_ours, "ours_per_processor_s": per_ours}),
    )
}
