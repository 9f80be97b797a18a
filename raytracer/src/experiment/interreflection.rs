//! Diffuse inter-reflection on the simulated cluster, which the paper
//! could not run (its processors lacked the memory for the irradiance
//! cache): the cache in waves ([`crate::parallel::ambient`]), 1 to
//! `max_procs` processors. Speed-up, efficiency, what travels (tasks,
//! results, the waves' records broadcast to every processor) and what each
//! processor holds (the broadcast records).

use serde_json::json;

use super::harness::{doubling, f3, same_picture, secs, Ctx};
use crate::parallel::ambient::render_ambient_parallel;
use crate::parallel::{ParallelOptions, RuntimeKind};
use crate::render::ambient::AmbientRecord;
use crate::report::plot::{Chart, Mark, Series};
use crate::report::table::Table;
use crate::{Error, Result};

pub(super) fn interreflection(cx: &mut Ctx) -> Result<()> {
    let s = cx.s;
    if s.options.ab == 0 {
        return Err(Error::Usage(
            "experiment interreflection needs diffuse inter-reflection: give -ab 1 or more".into(),
        ));
    }
    let counts = doubling(s.max_procs);
    let mut t = Table::new([
        "processors",
        "time (s)",
        "speed-up",
        "efficiency",
        "waves",
        "hemispheres",
        "records",
        "broadcast KiB (all processors)",
        "tasks and results KiB",
        "held per processor KiB",
    ]);
    let (mut speedup, mut efficiency) = (Vec::new(), Vec::new());
    let mut rows = Vec::new();
    let mut base = None;
    let mut picture = None;
    for &p in &counts {
        let mut popts = ParallelOptions::new(p);
        popts.runtime = RuntimeKind::Sim;
        popts.network = s.network.clone();
        popts.sim_seed = s.seed;
        let r = render_ambient_parallel(
            s.scene.clone(),
            s.options.clone(),
            &s.view,
            s.width,
            s.height,
            &popts,
            &[],
            None,
        )?
        .ok_or_else(|| Error::Other("a simulated run has no MPI ranks".into()))?;
        // Every run's picture is the first's (and the sequential one's).
        same_picture(&mut picture, &r.film, &format!("{p} processors"))?;
        let tp = secs(r.stats.elapsed_ns);
        let t1 = *base.get_or_insert(tp);
        let st = &r.stats;
        // The master sends the broadcasts (data class) and hands out
        // tasks; processors send results.
        let broadcast = st.master.sent.data.bytes;
        let work = st.master.sent.demand_driven.bytes + st.sum(|q| q.sent.result.bytes);
        let held = r.records * std::mem::size_of::<AmbientRecord>();
        let (sp, eff) = (t1 / tp, t1 / tp / p as f64);
        speedup.push((p as f64, sp));
        efficiency.push((p as f64, eff));
        t.row([
            p.to_string(),
            f3(tp),
            format!("{sp:.2}"),
            format!("{:.1}%", 100.0 * eff),
            r.waves.to_string(),
            r.hemispheres.to_string(),
            r.records.to_string(),
            format!("{:.1}", broadcast as f64 / 1024.0),
            format!("{:.1}", work as f64 / 1024.0),
            format!("{:.1}", held as f64 / 1024.0),
        ]);
        rows.push(json!({
            "procs": p,
            "time_s": tp,
            "speedup": sp,
            "efficiency": eff,
            "waves": r.waves,
            "hemispheres": r.hemispheres,
            "records": r.records,
            "broadcast_bytes": broadcast,
            "task_and_result_bytes": work,
            "held_bytes_per_processor": held,
        }));
    }
    let max = *counts.last().unwrap_or(&1) as f64;
    cx.chart(
        "interreflection.svg",
        &Chart {
            title: format!(
                "Diffuse inter-reflection: speed-up ({}, {})",
                s.name, s.network.name
            ),
            x_label: "processors".into(),
            y_label: "speed-up".into(),
            series: vec![
                Series::new("ideal", vec![(1.0, 1.0), (max, max)], Mark::Reference),
                Series::new("irradiance cache in waves", speedup, Mark::LinePoints),
            ],
            ..Chart::default()
        },
    )?;
    cx.finish(
        "interreflection",
        "Diffuse inter-reflection on the simulated cluster",
        "The irradiance cache in waves (parallel::ambient): each wave of pixels is one epoch of the framework, its pixels handed out in chunks (at most 16 pixels, about four chunks per processor) to whichever processor asks, their values and records sent to the master, and the wave's records broadcast to every processor before the next wave. The scene is replicated (every processor traces whole ray trees); every run's picture is the sequential renderer's. Speed-up and efficiency against the same renderer on one simulated processor. Compute is priced per shaded point, spawned ray and shadow bundle at the prices the model fitted on the hybrid workload (tracing through the replicated hierarchy counts nothing of its own); see EXPERIMENTS.md for how that compares with the measured time. Held per processor: the broadcast records, which every processor keeps.",
        &[t],
        json!({"runs": rows, "efficiency": efficiency}),
    )
}
