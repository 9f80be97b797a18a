//! Diffuse inter-reflection on a distributed scene, on the simulated
//! cluster: the hybrid workload with hemisphere rays as data-parallel
//! tasks that migrate to the cells they need (`parallel/hemispheres.rs`;
//! `-aa 0`), 1 to `max_procs` processors, with an unlimited cache and
//! with caches of 10% of the cell data. Speed-up, efficiency, what travels
//! (migrating tasks, fetched cells, results) and what the busiest
//! processor holds (its cells and cache, its queued tasks, its work in
//! flight), which the paper could not run for memory reasons.

use serde_json::json;

use super::harness::{doubling, f3, same_picture, secs, Ctx, RunSpec, Traffic};
use crate::parallel::{hybrid_interreflection, CacheSize};
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::{Error, Result};

/// Tiles of 8 pixels: 64 at 64 x 64, two for each of 32 processors (a
/// hemisphere's pixel costs as much as a tile of pixels without one).
const TILE: usize = 8;

/// The runs' caches: unlimited, and 10% of the cell data.
const CACHES: [(&str, CacheSize); 2] = [
    ("unlimited cache", CacheSize::Unlimited),
    ("cache 10%", CacheSize::Percent(10.0)),
];

pub(super) fn hemispheres(cx: &mut Ctx) -> Result<()> {
    let s = cx.s;
    if s.options.ab == 0 || s.options.aa > 0.0 || !hybrid_interreflection(&s.options) {
        return Err(Error::Usage(
            "experiment hemispheres needs diffuse inter-reflection without an irradiance cache: \
             give -ab 1 or more with -aa 0"
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
        "migrations",
        "cells fetched",
        "tasks KiB",
        "cells KiB",
        "results KiB",
        "most held KiB (cells and cache)",
        "most queued tasks",
        "most in flight KiB",
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
                tile: TILE,
                ..RunSpec::ours(p)
            })?;
            // Every run's picture is the first's (each is the sequential
            // renderer's: tests/parallel_render.rs).
            same_picture(&mut picture, &r.film, &format!("{p} processors ({name})"))?;
            let st = &r.stats;
            let tp = secs(st.elapsed_ns);
            let t1 = *base.get_or_insert(tp);
            let (sp, eff) = (t1 / tp, t1 / tp / p as f64);
            speedup.push((p as f64, sp));
            let tr = Traffic::of(st);
            t.row([
                name.to_string(),
                p.to_string(),
                f3(tp),
                format!("{sp:.2}"),
                format!("{:.1}%", 100.0 * eff),
                tr.migrations.to_string(),
                tr.fetched.to_string(),
                kib(tr.tasks),
                kib(tr.cells),
                kib(tr.results),
                kib(tr.most_held),
                tr.most_queued.to_string(),
                kib(tr.most_in_flight),
            ]);
            rows.push(json!({
                "cache": name,
                "procs": p,
                "time_s": tp,
                "speedup": sp,
                "efficiency": eff,
                "migrations": tr.migrations,
                "cells_fetched": tr.fetched,
                "task_bytes": tr.tasks,
                "cell_bytes": tr.cells,
                "result_bytes": tr.results,
                "most_held_bytes": tr.most_held,
                "most_queued_tasks": tr.most_queued,
                "most_in_flight_bytes": tr.most_in_flight,
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
        "hemispheres.svg",
        &Chart {
            title: format!(
                "Migrating hemisphere rays: speed-up ({}, {})",
                s.name, s.network.name
            ),
            x_label: "processors".into(),
            y_label: "speed-up".into(),
            series: all,
            ..Chart::default()
        },
    )?;
    cx.finish(
        "hemispheres",
        "Diffuse inter-reflection on a distributed scene, simulated",
        "The hybrid workload (ours: the predicted distribution, the load-aware policy, the clip cache) with diffuse inter-reflection without an irradiance cache or super-samples: each hemisphere's sample rays are data-parallel tasks that migrate to the processors holding the cells they cross, the hemisphere is evaluated where its pixel is, depth first (framework/SEMANTICS.md sections 3 and 5: among other things, a processor whose send backlog of tasks is over budget runs nothing and parks the tasks it receives). Every run's picture is the first's, which is the sequential renderer's. Tiles of 8 pixels. Speed-up and efficiency against the same cache on one simulated processor. Tasks: migrating rays and demand-driven tasks (tiles, shadow bundles); cells: fetched cell data; most held, queued and in flight: the processor with the most (its resident cells and cache; tasks queued to run, parked ones included; its input buffer and send backlog). The budget of work in flight is the framework's default, 1 MiB.",
        &[t],
        json!({"runs": rows}),
    )
}
