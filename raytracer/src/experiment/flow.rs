//! Beyond the paper: flow control bounds the work in flight at every
//! processor (input buffer and send backlog).

use hybrid_sched::Policy;
use serde_json::json;

use super::harness::{f3, secs, Ctx, RunSpec};
use crate::parallel::CacheSize;
use crate::report::table::Table;
use crate::Result;

/// Beyond the paper: the bottleneck's input buffer, the largest send
/// backlog and the largest work in flight (both at one moment) with the
/// byte budget, with credits only and without flow control (the paper's
/// 617 kB -> 16 MB growth).
pub(super) fn flow(cx: &mut Ctx) -> Result<()> {
    // The paper's measurement: 8 processors, 128x128 (its figures 12, 13).
    let procs = cx.s.cache_procs;
    let mut t = Table::new([
        "flow control",
        "cache",
        "policy",
        "bottleneck input buffer (KiB)",
        "largest send backlog (KiB)",
        "largest in flight (KiB)",
        "time (s)",
    ]);
    let mut rows = Vec::new();
    let budget = hybrid_sched::config::DEFAULT_FLIGHT_BYTES;
    let unbounded = usize::MAX;
    for (label, credits, flight_bytes) in [
        ("credits 64 per link + 1 MiB in flight", 64usize, budget),
        ("credits 64 per link only", 64, unbounded),
        (
            "off (unbounded)",
            hybrid_sched::config::MAX_CREDITS,
            unbounded,
        ),
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
                    flight_bytes,
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
                let actors = || r.stats.procs.iter().chain([&r.stats.master]);
                let backlog = actors()
                    .map(|p| p.memory.send_backlog_bytes)
                    .max()
                    .unwrap_or(0);
                let in_flight = actors()
                    .map(|p| p.memory.in_flight_bytes)
                    .max()
                    .unwrap_or(0);
                let kib = |b: usize| format!("{:.1}", b as f64 / 1024.0);
                t.row([
                    label.to_string(),
                    cache_label.to_string(),
                    policy.name().to_string(),
                    kib(worst),
                    kib(backlog),
                    kib(in_flight),
                    f3(secs(r.stats.elapsed_ns)),
                ]);
                rows.push(json!({"credits": credits, "flight_bytes": (flight_bytes != unbounded).then_some(flight_bytes), "cache": cache_label, "policy": policy.name(), "input_buffer_bytes": worst, "send_backlog_bytes": backlog, "in_flight_bytes": in_flight, "seconds": secs(r.stats.elapsed_ns)}));
            }
        }
    }
    cx.finish(
        "flow",
        "Beyond the paper: flow control bounds the work in flight",
        &format!(
            "{procs} processors at {}x{}, the largest figure of any actor (the master included) in each column; in flight is input buffer plus send backlog at one moment. \
             With credits, no processor can have more than credits x processors messages unconsumed from others, and results a quarter as many again; \
             with the byte budget, half of it bounds the bytes of those, results an eighth more, and a processor whose send backlog holds more than the remaining three eighths takes no new tile and keeps the shadow tasks it spawns; past three quarters of the budget in flight, with results waiting to leave, it runs nothing until they do. \
             The paper (without flow control) saw the bottleneck's input buffer grow from 617 kB (unlimited cache) to 16 MB (a 600 kB cache).",
            cx.s.small.0, cx.s.small.1
        ),
        &[t],
        json!({"runs": rows}),
    )
}
