//! Beyond the paper: flow control bounds the bottleneck's input buffer.

use hybrid_sched::Policy;
use serde_json::json;

use super::harness::{f3, secs, Ctx, RunSpec};
use crate::parallel::CacheSize;
use crate::report::table::Table;
use crate::Result;

/// Beyond the paper: the bottleneck processor's input buffer with and
/// without flow control (the paper's 617 kB -> 16 MB growth).
pub(super) fn flow(cx: &mut Ctx) -> Result<()> {
    // The paper's measurement: 8 processors, 128x128 (its figures 12, 13).
    let procs = cx.s.cache_procs;
    let mut t = Table::new([
        "flow control",
        "cache",
        "policy",
        "bottleneck input buffer (KiB)",
        "time (s)",
    ]);
    let mut rows = Vec::new();
    for (label, credits) in [
        ("credits 64 per link", 64usize),
        ("off (unbounded)", hybrid_sched::config::MAX_CREDITS),
    ] {
        for (cache_label, cache) in [
            ("unlimited", CacheSize::Unlimited),
            ("5%", CacheSize::Percent(5.0)),
        ] {
            for policy in [Policy::Local, Policy::ViaMaster, Policy::LoadAware] {
                let r = cx.run(RunSpec {
                    policy,
                    cache,
                    credits,
                    small: true,
                    ..RunSpec::paper(procs)
                })?;
                let worst = r
                    .stats
                    .procs
                    .iter()
                    .chain([&r.stats.master])
                    .map(|p| p.memory.input_buffer_bytes)
                    .max()
                    .unwrap_or(0);
                t.row([
                    label.to_string(),
                    cache_label.to_string(),
                    policy.name().to_string(),
                    format!("{:.1}", worst as f64 / 1024.0),
                    f3(secs(r.stats.elapsed_ns)),
                ]);
                rows.push(json!({"credits": credits, "cache": cache_label, "policy": policy.name(), "input_buffer_bytes": worst, "seconds": secs(r.stats.elapsed_ns)}));
            }
        }
    }
    cx.finish(
        "flow",
        "Beyond the paper: flow control bounds the bottleneck's input buffer",
        &format!(
            "{procs} processors at {}x{}. With credits, no processor can have more than credits x processors messages unconsumed from others; \
             the paper (without flow control) saw the bottleneck's input buffer grow from 617 kB (unlimited cache) to 16 MB (a 600 kB cache).",
            cx.s.small.0, cx.s.small.1
        ),
        &[t],
        json!({"runs": rows}),
    )
}
