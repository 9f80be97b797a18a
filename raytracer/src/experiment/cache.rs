//! Figure 12: cache size against shadow-task policy.

use hybrid_sched::Policy;
use serde_json::json;

use super::harness::{f3, secs, Ctx, RunSpec};
use crate::parallel::CacheSize;
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

const CACHE_PERCENTS: [f64; 7] = [1.0, 2.5, 5.0, 10.0, 25.0, 50.0, 100.0];

pub(super) fn cache(cx: &mut Ctx) -> Result<()> {
    let procs = cx.s.cache_procs;
    // The five policies with the paper's other choices, then ours whole.
    let mut lines: Vec<(String, RunSpec)> = Policy::ALL
        .iter()
        .map(|&policy| {
            (
                policy.name().to_string(),
                RunSpec {
                    policy,
                    small: true,
                    ..RunSpec::paper(procs)
                },
            )
        })
        .collect();
    lines.push((
        "ours (load-aware, clip cache, predicted)".to_string(),
        RunSpec {
            small: true,
            ..RunSpec::ours(procs)
        },
    ));
    let mut t = Table::new(
        std::iter::once("cache % of scene".to_string())
            .chain(lines.iter().map(|(name, _)| format!("{name} (s)"))),
    );
    let mut series: Vec<Series> = lines
        .iter()
        .map(|(name, _)| Series::new(name.clone(), Vec::new(), Mark::LinePoints))
        .collect();
    let mut rows = Vec::new();
    for &pc in &CACHE_PERCENTS {
        let mut cells = vec![format!("{pc}")];
        for (k, (name, spec)) in lines.iter().enumerate() {
            let r = cx.run(RunSpec {
                cache: CacheSize::Percent(pc),
                ..*spec
            })?;
            let el = secs(r.stats.elapsed_ns);
            series[k].points.push((pc, el));
            cells.push(f3(el));
            rows.push(json!({"cache_percent": pc, "variant": name, "seconds": el,
                "bottleneck_input_buffer_bytes": r.stats.procs.iter().map(|p| p.memory.input_buffer_bytes).max()}));
        }
        t.row(cells);
    }
    cx.chart(
        "cache.svg",
        &Chart {
            title: format!(
                "Figure 12: render time on {procs} processors, {}x{}",
                cx.s.small.0, cx.s.small.1
            ),
            x_label: "object cache (% of scene data, log)".into(),
            y_label: "simulated seconds".into(),
            series,
            x_log: true,
            ..Chart::default()
        },
    )?;
    cx.finish(
        "cache",
        "Figure 12: cache size against shadow-task policy",
        &format!(
            "{procs} processors at {}x{}; the paper's four policies and load-aware with the paper's other choices, then ours whole (load-aware, clip cache, predicted distribution).",
            cx.s.small.0, cx.s.small.1
        ),
        &[t],
        json!({"runs": rows}),
    )
}
