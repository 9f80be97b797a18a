//! Figure 9: task and data communication.

use hybrid_sched::Class;
use serde_json::json;

use super::harness::{per_proc, proc_names, traffic_over_time, Ctx};
use crate::report::plot::{Bars, Chart, Mark, Series};
use crate::report::table::Table;
use crate::Result;

pub(super) fn communication(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let procs = r.options.procs;
    let tl = r.timeline.clone().unwrap_or_default();
    let tasks = traffic_over_time(
        &tl,
        procs,
        &[Class::DataParallel, Class::DemandDriven, Class::Result],
        100,
    );
    let data = traffic_over_time(&tl, procs, &[Class::Data], 100);
    cx.chart(
        "communication-time.svg",
        &Chart {
            title: format!("Figure 9: communication over time ({procs} processors)"),
            x_label: "time (s)".into(),
            y_label: "KiB/s sent".into(),
            series: vec![
                Series::new("tasks and results", tasks.clone(), Mark::Line),
                Series::new("object data", data.clone(), Mark::Line),
            ],
            ..Chart::default()
        },
    )?;
    let kib = |c: Class| per_proc(&r, move |p| p.sent.get(c).bytes as f64 / 1024.0);
    let task_kib: Vec<f64> = (0..procs)
        .map(|i| kib(Class::DataParallel)[i] + kib(Class::DemandDriven)[i] + kib(Class::Result)[i])
        .collect();
    let data_kib = kib(Class::Data);
    cx.bars(
        "communication-procs.svg",
        &Bars {
            title: "Figure 9: communication per processor".into(),
            y_label: "KiB sent".into(),
            categories: proc_names(&r),
            parts: vec![
                ("tasks and results".into(), task_kib.clone()),
                ("object data".into(), data_kib.clone()),
            ],
        },
    )?;
    let mut t = Table::new([
        "processor",
        "task+result KiB",
        "data KiB",
        "control KiB",
        "packets",
        "messages",
    ]);
    for (i, p) in r.stats.procs.iter().enumerate() {
        t.row([
            i.to_string(),
            format!("{:.1}", task_kib[i]),
            format!("{:.1}", data_kib[i]),
            format!("{:.1}", p.sent.get(Class::Control).bytes as f64 / 1024.0),
            p.sent.total().packets.to_string(),
            p.sent.total().messages.to_string(),
        ]);
    }
    cx.finish(
        "communication",
        "Figure 9: task and data communication",
        "Bytes sent, by kind: task and result messages (demand-driven, data-parallel, results) against object data replies and requests.",
        &[t],
        json!({"tasks_over_time": tasks, "data_over_time": data, "task_kib": task_kib, "data_kib": data_kib}),
    )
}
