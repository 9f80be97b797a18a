//! Figure 6: efficiency over time and per processor.

use hybrid_sched::State;
use serde_json::json;

use super::harness::{over_time, per_proc, proc_names, secs, Ctx, RunSpec};
use crate::report::plot::{Bars, Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

pub(super) fn efficiency(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let seq = cx.sequential_s()?;
    let curve = over_time(&r, &[State::Executing], 100);
    let procs = r.options.procs as f64;
    let eff: Vec<(f64, f64)> = curve.iter().map(|&(t, v)| (t, v / procs)).collect();
    let ours = cx.run(RunSpec::ours(r.options.procs))?;
    let eff_ours: Vec<(f64, f64)> = over_time(&ours, &[State::Executing], 100)
        .iter()
        .map(|&(t, v)| (t, v / procs))
        .collect();
    let fair_ours = seq / secs(ours.stats.elapsed_ns) / procs;
    cx.chart(
        "efficiency-time.svg",
        &Chart {
            title: format!(
                "Figure 6: efficiency over time ({} processors)",
                r.options.procs
            ),
            x_label: "time (s)".into(),
            y_label: "fraction of processors executing".into(),
            series: vec![
                Series::new("paper", eff.clone(), Mark::Line),
                Series::new("ours", eff_ours.clone(), Mark::Line),
            ],
            y_range: Some((0.0, 1.05)),
            ..Chart::default()
        },
    )?;
    let el = r.stats.elapsed_ns.max(1) as f64;
    let per = per_proc(&r, |p| p.time_ns.executing as f64 / el);
    cx.bars(
        "efficiency-procs.svg",
        &Bars {
            title: "Figure 6: efficiency per processor".into(),
            y_label: "fraction of run time executing".into(),
            categories: proc_names(&r),
            parts: vec![("executing".into(), per.clone())],
        },
    )?;
    let mut t = Table::new([
        "processor",
        "executing %",
        "selecting %",
        "waiting %",
        "idle %",
        "communication %",
    ]);
    for p in &r.stats.procs {
        let pc = |v: u64| format!("{:.1}", 100.0 * v as f64 / el);
        let tm = &p.time_ns;
        t.row([
            p.addr.to_string(),
            pc(tm.executing),
            pc(tm.selecting),
            pc(tm.waiting_data),
            pc(tm.idle),
            pc(tm.sending + tm.receiving + tm.serving_data),
        ]);
    }
    let mean = per.iter().sum::<f64>() / per.len().max(1) as f64;
    let fair = seq / secs(r.stats.elapsed_ns) / procs;
    cx.finish(
        "efficiency",
        "Figure 6: efficiency over time and per processor",
        &format!(
            "Efficiency = share of time spent executing tasks (not clipping, waiting, idling or communicating). \
             Mean over processors {:.1}%; fair efficiency (sequential time / (p x parallel time)) {:.1}%; ours {:.1}%.",
            100.0 * mean,
            100.0 * fair,
            100.0 * fair_ours
        ),
        &[t],
        json!({"over_time": eff, "per_processor": per, "fair_efficiency": fair,
            "ours_over_time": eff_ours, "ours_fair_efficiency": fair_ours}),
    )
}
