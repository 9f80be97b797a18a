//! Diffuse inter-reflection with an irradiance cache on a distributed
//! scene, on the simulated cluster, which the paper could not run (its
//! processors lacked the memory for the cache): the hybrid workload with
//! the cache in waves, each wave an epoch whose records are broadcast to
//! every processor, hemisphere rays and leak tests migrating to the cells
//! they need, each pixel's owner deciding its lookups in the sequential
//! renderer's order (`parallel/irradiance.rs`, `parallel/cursor.rs`); 1 to
//! `max_procs` processors, with an unlimited cache and with caches of 10%
//! of the cell data. Speed-up, efficiency, what travels (tasks, cells,
//! results, the broadcast records) and what the busiest processor holds.

use serde_json::json;

use super::harness::{doubling, f3, same_picture, secs, Ctx, RunSpec, Traffic};
use crate::parallel::{CacheSize, Work};
use crate::render::ambient::AmbientRecord;
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::{Error, Result};

/// The runs' caches: unlimited, and 10% of the cell data.
const CACHES: [(&str, CacheSize); 2] = [
    ("unlimited cache", CacheSize::Unlimited),
    ("cache 10%", CacheSize::Percent(10.0)),
];

pub(super) fn interreflection(cx: &mut Ctx) -> Result<()> {
    let s = cx.s;
    if s.options.ab == 0 || s.options.aa <= 0.0 {
        return Err(Error::Usage(
            "experiment interreflection needs diffuse inter-reflection with an irradiance cache: \
             give -ab 1 or more (and -aa above 0)"
                .into(),
        ));
    }
    let counts = doubling(s.max_procs);
    let kib = |b: u64| format!("{:.1}", b as f64 / 1024.0);
    let mut t = Table::new([
        "cache",
        "processors",
        "time (s)",
        "speed-up",
        "efficiency",
        "waves",
        "hemispheres",
        "migrations",
        "leak tests sent",
        "cells fetched",
        "tasks KiB",
        "cells KiB",
        "results KiB",
        "broadcast KiB (all processors)",
        "most held KiB (cells, cache, records received)",
        "records KiB per processor",
        "most queued tasks",
    ]);
    let mut picture = None;
    let mut series = Vec::new();
    let mut rows = Vec::new();
    for (name, cache) in CACHES {
        let mut speedup = Vec::new();
        let mut base = None;
        for &p in &counts {
            let r = cx.run(RunSpec {
                cache,
                ..RunSpec::ours(p)
            })?;
            // Every run's picture is the first's (each is the sequential
            // renderer's: tests/parallel_irradiance.rs).
            same_picture(&mut picture, &r.film, &format!("{p} processors ({name})"))?;
            let a = r
                .ambient
                .as_ref()
                .ok_or_else(|| Error::Other("a render with a cache ran without waves".into()))?;
            let st = &r.stats;
            let tp = secs(st.elapsed_ns);
            let t1 = *base.get_or_insert(tp);
            let (sp, eff) = (t1 / tp, t1 / tp / p as f64);
            speedup.push((p as f64, sp));
            let tr = Traffic::of(st);
            // The master sends the broadcasts (its only data).
            let broadcast = st.master.sent.data.bytes;
            let records = (a.records * std::mem::size_of::<AmbientRecord>()) as u64;
            let leaks = r.work(Work::LeakJobs);
            t.row([
                name.to_string(),
                p.to_string(),
                f3(tp),
                format!("{sp:.2}"),
                format!("{:.1}%", 100.0 * eff),
                a.waves.to_string(),
                a.counts.hemispheres.to_string(),
                tr.migrations.to_string(),
                leaks.to_string(),
                tr.fetched.to_string(),
                kib(tr.tasks),
                kib(tr.cells),
                kib(tr.results),
                kib(broadcast),
                kib(tr.most_held),
                kib(records),
                tr.most_queued.to_string(),
            ]);
            rows.push(json!({
                "cache": name,
                "procs": p,
                "time_s": tp,
                "speedup": sp,
                "efficiency": eff,
                "waves": a.waves,
                "hemispheres": a.counts.hemispheres,
                "records": a.records,
                "migrations": tr.migrations,
                "leak_tests_sent": leaks,
                "cells_fetched": tr.fetched,
                "task_bytes": tr.tasks,
                "cell_bytes": tr.cells,
                "result_bytes": tr.results,
                "broadcast_bytes": broadcast,
                "most_held_bytes": tr.most_held,
                "record_bytes_per_processor": records,
                "most_queued_tasks": tr.most_queued,
            }));
        }
        series.push(Series::new(name, speedup, Mark::LinePoints));
    }
    let max = *counts.last().unwrap_or(&1) as f64;
    let mut all = vec![Series::new(
        "ideal",
        vec![(1.0, 1.0), (max, max)],
        Mark::Reference,
    )];
    all.extend(series);
    cx.chart(
        "interreflection.svg",
        &Chart {
            title: format!(
                "Irradiance cache on a distributed scene: speed-up ({}, {})",
                s.name, s.network.name
            ),
            x_label: "processors".into(),
            y_label: "speed-up".into(),
            series: all,
            ..Chart::default()
        },
    )?;
    cx.finish(
        "interreflection",
        "Diffuse inter-reflection with an irradiance cache on a distributed scene, simulated",
        "The hybrid workload (ours: the predicted distribution, the load-aware policy, the clip cache) with the irradiance cache: pixels are shaded in waves, each wave an epoch of the framework whose pixels are handed out in chunks (at most 16 pixels, about four chunks per processor) and whose records are broadcast to every processor before the next wave; hemisphere rays and leak tests are data-parallel tasks that migrate to the processors holding the cells they cross; each pixel's owner decides its lookups and samples its hemispheres in the sequential renderer's order as the records of its ray tree arrive. Every run's picture is the first's, which is the sequential renderer's. Speed-up and efficiency against the same cache on one simulated processor. Tasks: migrating rays and leak tests, and demand-driven tasks (chunks of pixels, shadow bundles); cells: fetched cell data; broadcast: the waves' records, sent to every processor; most held and queued: the processor with the most (its resident cells, its cache and the records broadcast to it; tasks queued to run, parked ones included); records: the whole cache at the end (the last wave's records are never broadcast: no wave follows). The budget of work in flight is the framework's default, 1 MiB.",
        &[t],
        json!({"runs": rows}),
    )
}
