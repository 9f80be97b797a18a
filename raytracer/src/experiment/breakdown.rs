//! Figure 13: time breakdown per processor.

use std::collections::BTreeMap;

use hybrid_sched::{Policy, State};
use serde_json::json;

use super::harness::{per_proc, proc_names, secs, Ctx, RunSpec};
use crate::parallel::CacheSize;
use crate::report::plot::Bars;
use crate::report::table::Table;
use crate::Result;

pub(super) fn breakdown(cx: &mut Ctx) -> Result<()> {
    // The paper's: 8 processors, 128x128, shadow tasks via the master, a
    // cache too small for most demand-driven shadow tasks.
    let procs = cx.s.cache_procs;
    let r = cx.run(RunSpec {
        policy: Policy::ViaMaster,
        cache: CacheSize::Percent(5.0),
        small: true,
        ..RunSpec::paper(procs)
    })?;
    let parts: Vec<(String, Vec<f64>)> = State::ALL
        .iter()
        .map(|&s| {
            (
                format!("{s:?}"),
                per_proc(&r, |p| p.time_ns.get(s) as f64 * 1e-9),
            )
        })
        .collect();
    cx.bars(
        "breakdown.svg",
        &Bars {
            title: format!(
                "Figure 13: time per processor, via-master, cache 5% ({procs} processors)"
            ),
            y_label: "seconds".into(),
            categories: proc_names(&r),
            parts: parts.clone(),
        },
    )?;
    let mut t = Table::new(
        std::iter::once("processor".to_string())
            .chain(State::ALL.iter().map(|s| format!("{s:?} s"))),
    );
    for (i, _) in r.stats.procs.iter().enumerate() {
        t.row(
            std::iter::once(i.to_string()).chain(parts.iter().map(|(_, v)| format!("{:.4}", v[i]))),
        );
    }
    let json_parts: BTreeMap<String, Vec<f64>> = parts.into_iter().collect();
    cx.finish(
        "breakdown",
        "Figure 13: time breakdown per processor",
        &format!(
            "{} processors at {}x{}, shadow tasks routed via the master, object cache 5% of the scene data.",
            cx.s.cache_procs, cx.s.small.0, cx.s.small.1
        ),
        &[t],
        json!({"seconds": json_parts, "elapsed_s": secs(r.stats.elapsed_ns)}),
    )
}
