//! Figure 5: speed-up against processors, the paper's algorithm and ours
//! one step at a time.

use serde_json::{json, Value};

use super::harness::{doubling, f3, secs, Ctx, RunSpec};
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

/// The speed-up curve's variants: the paper's algorithm and ours.
type Variant = (&'static str, fn(usize) -> RunSpec);

/// The speed-up curve's variants: the paper's algorithm, then ours one
/// step at a time.
fn variants() -> [Variant; 5] {
    [
        ("paper", RunSpec::paper),
        ("+ coarse tasks", RunSpec::coarse),
        ("+ clip cache", RunSpec::clip_cache),
        ("+ predicted", RunSpec::predicted),
        ("+ load-aware", RunSpec::ours),
    ]
}

pub(super) fn speedup(cx: &mut Ctx) -> Result<()> {
    let seq = cx.sequential_s()?;
    let counts = doubling(cx.s.max_procs);
    let vs = variants();
    let mut header = vec!["processors".to_string()];
    for (name, _) in &vs {
        header.push(format!("{name}: time (s)"));
        header.push(format!("{name}: relative"));
        header.push(format!("{name}: fair"));
        header.push(format!("{name}: fair efficiency"));
    }
    let mut t = Table::new(header);
    let mut series: Vec<Series> = Vec::new();
    for (name, _) in &vs {
        series.push(Series::new(
            format!("{name}, relative"),
            Vec::new(),
            Mark::LinePoints,
        ));
        series.push(Series::new(
            format!("{name}, fair"),
            Vec::new(),
            Mark::LinePoints,
        ));
    }
    let mut rows = Vec::new();
    let mut base = vec![0.0; vs.len()];
    for &p in &counts {
        let mut cells = vec![p.to_string()];
        let mut row = serde_json::Map::new();
        row.insert("procs".into(), json!(p));
        for (k, (name, spec)) in vs.iter().enumerate() {
            let r = cx.run(spec(p))?;
            let tp = secs(r.stats.elapsed_ns);
            if p == 1 {
                base[k] = tp;
            }
            let x = p as f64;
            series[2 * k].points.push((x, base[k] / tp));
            series[2 * k + 1].points.push((x, seq / tp));
            cells.push(f3(tp));
            cells.push(format!("{:.2}", base[k] / tp));
            cells.push(format!("{:.2}", seq / tp));
            cells.push(format!("{:.1}%", 100.0 * seq / tp / x));
            row.insert(format!("{name}_s"), json!(tp));
            row.insert(format!("{name}_fair_efficiency"), json!(seq / tp / x));
        }
        t.row(cells);
        rows.push(Value::Object(row));
    }
    let max = *counts.last().unwrap_or(&1) as f64;
    let mut chart = Chart {
        title: format!("Figure 5: speed-up ({}, {})", cx.s.name, cx.s.network.name),
        x_label: "processors".into(),
        y_label: "speed-up".into(),
        series: vec![Series::new(
            "ideal",
            vec![(1.0, 1.0), (max, max)],
            Mark::Reference,
        )],
        ..Chart::default()
    };
    chart.series.extend(series);
    cx.chart("speedup.svg", &chart)?;
    cx.finish(
        "speedup",
        "Figure 5: speed-up",
        &format!(
            "Relative: against the same algorithm on one processor. Fair: against the sequential renderer on one node ({seq:.3} s simulated). \
             Paper: octree distribution (equal memory), shadow tasks local, every shadow bundle clipped. \
             Ours, one step at a time: + coarse tasks (shadow bundles start in the step that shaded their point where their cells are resident, the others of a point travel as one task), + clip cache (one clip per cell and light), + predicted (the octree cut by predicted work), + load-aware (busy processors shed shadow tasks to idle ones)."
        ),
        &[t],
        json!({"sequential_s": seq, "runs": rows}),
    )
}
