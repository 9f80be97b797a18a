//! Figures 10 and 11: fetching and sending object data.

use hybrid_sched::State;
use serde_json::json;

use super::harness::{over_time, per_proc, proc_names, Ctx};
use crate::report::plot::{Bars, Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

pub(super) fn data(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let fetch = over_time(&r, &[State::WaitingData], 100);
    let send = over_time(&r, &[State::ServingData], 100);
    cx.chart(
        "data-time.svg",
        &Chart {
            title: format!(
                "Figures 10, 11: object data over time ({} processors)",
                r.options.procs
            ),
            x_label: "time (s)".into(),
            y_label: "processors".into(),
            series: vec![
                Series::new(
                    "waiting for fetched data (Fig. 10)",
                    fetch.clone(),
                    Mark::Line,
                ),
                Series::new("sending data (Fig. 11)", send.clone(), Mark::Line),
            ],
            ..Chart::default()
        },
    )?;
    let f = per_proc(&r, |p| p.time_ns.waiting_data as f64 * 1e-9);
    let sd = per_proc(&r, |p| p.time_ns.serving_data as f64 * 1e-9);
    cx.bars(
        "data-procs.svg",
        &Bars {
            title: "Figures 10, 11: object data per processor".into(),
            y_label: "seconds".into(),
            categories: proc_names(&r),
            parts: vec![
                ("fetching (waiting)".into(), f.clone()),
                ("sending".into(), sd.clone()),
            ],
        },
    )?;
    let mut t = Table::new([
        "processor",
        "fetch wait s",
        "send s",
        "requests sent",
        "items fetched",
        "items served",
        "cache hit %",
    ]);
    for (i, p) in r.stats.procs.iter().enumerate() {
        t.row([
            i.to_string(),
            format!("{:.4}", f[i]),
            format!("{:.4}", sd[i]),
            p.data_requests_sent.to_string(),
            p.data_items_requested.to_string(),
            p.data_items_served.to_string(),
            p.cache_hit_rate()
                .map_or("-".into(), |h| format!("{:.1}", 100.0 * h)),
        ]);
    }
    cx.finish(
        "data",
        "Figures 10 and 11: fetching and sending object data",
        "Fetching: time with nothing to run while tasks wait for requested cells. Sending: time answering data requests.",
        &[t],
        json!({"fetch_over_time": fetch, "send_over_time": send, "fetch_s": f, "send_s": sd}),
    )
}
