//! The paper's experiments on the simulated cluster (`hybrid-rt
//! experiment`).
//!
//! Every experiment runs the hybrid renderer on the deterministic simulator
//! ([`hybrid_sched::Sim`] with [`crate::parallel::cost::model`] and a
//! [`Network`] preset) and writes, into the output directory, `NAME.md` (a
//! markdown table), `NAME.json` (every figure plotted) and one or more
//! `NAME*.svg` plots. Nothing is measured on the wall clock, so the same
//! arguments give the same files, byte for byte.
//!
//! "The paper's algorithm" is the system as published: the octree
//! distribution with equal memory, shadow tasks kept where they are spawned
//! (`local`), every shadow bundle clipped. "Ours" adds, one step at a time:
//! the clip cache (one clip per cell and light), the cost-predicted
//! distribution and the `load-aware` policy. Flow control is on in both; the
//! `flow` experiment shows what it bounds.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use hybrid_sched::Runtime;
use hybrid_sched::{Class, Network, Policy, Sequential, State, Timeline};
use serde::Serialize;
use serde_json::{json, Value};

use crate::accel::OctreeParams;
use crate::parallel::cost;
use crate::parallel::{
    render_parallel, CacheSize, Distribution, ParallelOptions, ParallelRender, RtWorkload,
    RuntimeKind, WorkloadOptions,
};
use crate::render::{RenderOptions, Renderer};
use crate::report::plot::{Bars, Chart, Mark, Series};
use crate::report::table::Table;
use crate::scene::{Scene, View};
use crate::{Error, Result};

/// Experiment names in `all` order.
pub const NAMES: [&str; 11] = [
    "table1",
    "speedup",
    "efficiency",
    "clipping",
    "idle",
    "communication",
    "data",
    "cache",
    "breakdown",
    "memory",
    "flow",
];

/// What the experiments run on.
#[derive(Clone)]
pub struct Setup {
    /// Scene name for titles (`studio`, a file stem, ...).
    pub name: String,
    pub scene: Arc<Scene>,
    pub view: View,
    pub options: RenderOptions,
    /// Image size of the speed-up and per-processor experiments.
    pub width: usize,
    pub height: usize,
    /// Image size of the cache-size experiment (the paper's 128x128).
    pub small: (usize, usize),
    pub network: Network,
    /// Largest processor count of the speed-up curve.
    pub max_procs: usize,
    /// Processor count of the per-processor figures (the paper's 16) and of
    /// the cache experiment (the paper's 8).
    pub detail_procs: usize,
    pub cache_procs: usize,
    pub seed: u64,
}

/// One written file.
#[derive(Clone, Debug)]
pub struct Output {
    pub path: PathBuf,
}

struct Ctx<'a> {
    s: &'a Setup,
    out: &'a Path,
    written: Vec<Output>,
    /// Runs shared between experiments (the 16-processor run feeds six).
    memo: BTreeMap<String, Arc<ParallelRender>>,
    seq_s: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct RunSpec {
    procs: usize,
    policy: Policy,
    cache: CacheSize,
    distribution: Distribution,
    credits: usize,
    small: bool,
    clip_cache: bool,
}

impl RunSpec {
    fn paper(procs: usize) -> Self {
        RunSpec {
            procs,
            policy: Policy::Local,
            cache: CacheSize::Unlimited,
            distribution: Distribution::Octree,
            credits: 64,
            small: false,
            clip_cache: false,
        }
    }

    fn clip_cache(procs: usize) -> Self {
        RunSpec {
            clip_cache: true,
            ..Self::paper(procs)
        }
    }

    fn predicted(procs: usize) -> Self {
        RunSpec {
            distribution: Distribution::Predicted,
            ..Self::clip_cache(procs)
        }
    }

    fn ours(procs: usize) -> Self {
        RunSpec {
            policy: Policy::LoadAware,
            ..Self::predicted(procs)
        }
    }

    fn key(&self) -> String {
        format!("{self:?}")
    }
}

/// Virtual seconds.
fn secs(ns: u64) -> f64 {
    ns as f64 * 1e-9
}

fn f3(x: f64) -> String {
    format!("{x:.3}")
}

impl Ctx<'_> {
    fn run(&mut self, spec: RunSpec) -> Result<Arc<ParallelRender>> {
        let key = spec.key();
        if let Some(r) = self.memo.get(&key) {
            return Ok(r.clone());
        }
        let s = self.s;
        let (w, h) = if spec.small {
            s.small
        } else {
            (s.width, s.height)
        };
        let mut p = ParallelOptions::new(spec.procs);
        p.runtime = RuntimeKind::Sim;
        p.policy = spec.policy;
        p.cache = spec.cache;
        p.workload = WorkloadOptions {
            distribution: spec.distribution,
            clip_cache: spec.clip_cache,
            ..WorkloadOptions::default()
        };
        p.network = s.network.clone();
        p.sim_seed = s.seed;
        p.credits = spec.credits;
        // The paper's processors ask for a tile when they run dry.
        p.prefetch_work = false;
        let r = Arc::new(render_parallel(
            s.scene.clone(),
            s.options.clone(),
            &s.view,
            w,
            h,
            &p,
        )?);
        self.memo.insert(key, r.clone());
        Ok(r)
    }

    /// The sequential renderer's time on one simulated node: the work the
    /// framework's sequential runtime charges, at the cost model's prices,
    /// without any scheduling overhead.
    fn sequential_s(&mut self) -> Result<f64> {
        if let Some(t) = self.seq_s {
            return Ok(t);
        }
        let s = self.s;
        let renderer =
            Renderer::shared(s.scene.clone(), s.options.clone(), &OctreeParams::default())?;
        let wl = RtWorkload::new(
            renderer,
            s.view.clone(),
            s.width,
            s.height,
            1,
            WorkloadOptions::default(),
        );
        let report = Sequential
            .run_blocking(Arc::new(wl), &hybrid_sched::Config::new(1))
            .map_err(|e| Error::Other(format!("sequential run failed: {e}")))?;
        let model = cost::model();
        let ns: f64 = report.stats.procs[0]
            .work
            .iter()
            .map(|(k, &v)| {
                v as f64
                    * model
                        .unit_ns
                        .get(k)
                        .copied()
                        .unwrap_or(model.default_unit_ns)
            })
            .sum();
        let t = ns * s.network.cpu_scale * 1e-9;
        self.seq_s = Some(t);
        Ok(t)
    }

    fn write(&mut self, file: &str, data: &[u8]) -> Result<()> {
        let path = self.out.join(file);
        std::fs::write(&path, data).map_err(|e| Error::io(&path, e))?;
        self.written.push(Output { path });
        Ok(())
    }

    fn chart(&mut self, file: &str, chart: &Chart) -> Result<()> {
        let svg = chart.to_svg()?;
        self.write(file, svg.as_bytes())
    }

    fn bars(&mut self, file: &str, bars: &Bars) -> Result<()> {
        let svg = bars.to_svg()?;
        self.write(file, svg.as_bytes())
    }

    fn finish(
        &mut self,
        name: &str,
        title: &str,
        intro: &str,
        tables: &[Table],
        json: Value,
    ) -> Result<()> {
        let mut md = format!("# {title}\n\n{intro}\n\n");
        md += &self.setup_line();
        for t in tables {
            md += "\n";
            md += &t.to_markdown();
        }
        self.write(&format!("{name}.md"), md.as_bytes())?;
        let text =
            serde_json::to_string_pretty(&json).map_err(|e| Error::Other(format!("json: {e}")))?;
        self.write(&format!("{name}.json"), text.as_bytes())
    }

    fn setup_line(&self) -> String {
        let s = self.s;
        format!(
            "Scene `{}`, {}x{} pixels, simulated `{}` network (compute {}x slower than the calibration machine), seed {}.\n",
            s.name, s.width, s.height, s.network.name, s.network.cpu_scale, s.seed
        )
    }

    fn detail(&mut self) -> Result<Arc<ParallelRender>> {
        let p = self.s.detail_procs;
        self.run(RunSpec::paper(p))
    }
}

/// A run's time line, re-binned to about `points` buckets: per bucket, the
/// average number of processors in any of `states`.
fn over_time(r: &ParallelRender, states: &[State], points: usize) -> Vec<(f64, f64)> {
    let Some(tl) = &r.timeline else {
        return Vec::new();
    };
    let procs = r.options.procs;
    let n = tl.buckets();
    let group = n.div_ceil(points.max(1)).max(1);
    let mut out = Vec::new();
    for g in (0..n).step_by(group) {
        let mut busy = 0u64;
        let mut width = 0u64;
        for k in g..(g + group).min(n) {
            width += tl.bucket_ns;
            for p in 0..procs {
                busy += states.iter().map(|&st| tl.get(p, k, st)).sum::<u64>();
            }
        }
        let t_mid = (g as f64 + (group as f64) / 2.0) * tl.bucket_ns as f64 * 1e-9;
        out.push((t_mid, busy as f64 / width.max(1) as f64));
    }
    out
}

/// Bytes sent per second over time, summed over workers, for `classes`.
fn traffic_over_time(
    tl: &Timeline,
    procs: usize,
    classes: &[Class],
    points: usize,
) -> Vec<(f64, f64)> {
    let n = tl.sent_bytes.iter().map(Vec::len).max().unwrap_or(0);
    let group = n.div_ceil(points.max(1)).max(1);
    let mut out = Vec::new();
    for g in (0..n).step_by(group) {
        let mut bytes = 0u64;
        for p in 0..=procs {
            for k in g..(g + group).min(n) {
                if let Some(row) = tl.sent_bytes[p].get(k) {
                    bytes += classes.iter().map(|c| row[c.index()]).sum::<u64>();
                }
            }
        }
        let w = (group as u64 * tl.bucket_ns) as f64 * 1e-9;
        out.push((
            (g as f64 + group as f64 / 2.0) * tl.bucket_ns as f64 * 1e-9,
            bytes as f64 / w / 1024.0,
        ));
    }
    out
}

fn per_proc(r: &ParallelRender, f: impl Fn(&hybrid_sched::ProcStats) -> f64) -> Vec<f64> {
    r.stats.procs.iter().map(f).collect()
}

fn proc_names(r: &ParallelRender) -> Vec<String> {
    (0..r.options.procs).map(|p| p.to_string()).collect()
}

/// Runs experiment `name` (or every one for `all`), writing into `out`.
pub fn run(name: &str, setup: &Setup, out: &Path) -> Result<Vec<Output>> {
    let names: Vec<&str> = if name == "all" {
        NAMES.to_vec()
    } else if NAMES.contains(&name) {
        vec![name]
    } else {
        return Err(Error::Usage(format!(
            "unknown experiment {name:?}: expected all or one of {}",
            NAMES.join(", ")
        )));
    };
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let mut cx = Ctx {
        s: setup,
        out,
        written: Vec::new(),
        memo: BTreeMap::new(),
        seq_s: None,
    };
    for n in names {
        match n {
            "table1" => table1(&mut cx)?,
            "speedup" => speedup(&mut cx)?,
            "efficiency" => efficiency(&mut cx)?,
            "clipping" => state_figure(
                &mut cx,
                "clipping",
                "Figure 7: pyramid clipping",
                &[State::Selecting],
                "processors clipping",
            )?,
            "idle" => state_figure(
                &mut cx,
                "idle",
                "Figure 8: idle time",
                &[State::Idle, State::WaitingData],
                "processors idle",
            )?,
            "communication" => communication(&mut cx)?,
            "data" => data(&mut cx)?,
            "cache" => cache(&mut cx)?,
            "breakdown" => breakdown(&mut cx)?,
            "memory" => memory(&mut cx)?,
            "flow" => flow(&mut cx)?,
            _ => unreachable!("names are checked above"),
        }
    }
    Ok(cx.written)
}

fn table1(cx: &mut Ctx) -> Result<()> {
    let s = cx.s;
    let renderer = Renderer::shared(s.scene.clone(), s.options.clone(), &OctreeParams::default())?;
    let st = &s.scene.stats;
    let os = renderer.octree().stats().clone();
    // The paper's Table 1 for its two models.
    let paper = match s.name.as_str() {
        "studio" => Some(["5311", "4606", "-", "705", "25733", "3676", "51925"]),
        "conference" => Some(["3951", "-", "6151", "-", "8667", "-", "29569"]),
        _ => None,
    };
    let ours = [
        (st.objects + st.materials).to_string(),
        st.primitives.to_string(),
        st.instances.to_string(),
        st.materials.to_string(),
        os.leaf_nodes.to_string(),
        os.internal_nodes.to_string(),
        os.object_refs.to_string(),
    ];
    let rows = [
        "objects (top-level objects + materials, the paper's count)",
        "primitives",
        "instances",
        "materials, patterns, textures",
        "octree leaves",
        "octree internal nodes",
        "object references",
    ];
    let mut t = Table::new(["", "ours", "paper"]);
    for (i, r) in rows.iter().enumerate() {
        t.row([
            r.to_string(),
            ours[i].clone(),
            paper.map_or("-".to_string(), |p| p[i].to_string()),
        ]);
    }
    let json = json!({
        "scene": s.name,
        "objects": st.objects, "primitives": st.primitives, "instances": st.instances,
        "materials": st.materials, "leaves": os.leaf_nodes, "internal_nodes": os.internal_nodes,
        "object_refs": os.object_refs, "max_depth": os.max_depth,
    });
    cx.finish(
        "table1",
        "Table 1: scene and octree statistics",
        "The paper counts materials, patterns and textures among its objects.",
        &[t],
        json,
    )
}

/// The speed-up curve's variants: the paper's algorithm and ours.
type Variant = (&'static str, fn(usize) -> RunSpec);

/// The speed-up curve's variants: the paper's algorithm, then ours one
/// step at a time.
fn variants() -> [Variant; 4] {
    [
        ("paper", RunSpec::paper),
        ("+ clip cache", RunSpec::clip_cache),
        ("+ predicted", RunSpec::predicted),
        ("+ load-aware", RunSpec::ours),
    ]
}

fn speedup(cx: &mut Ctx) -> Result<()> {
    let seq = cx.sequential_s()?;
    let mut counts = vec![1usize];
    while counts.last().copied().unwrap_or(1) * 2 <= cx.s.max_procs {
        counts.push(counts.last().copied().unwrap_or(1) * 2);
    }
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
             Ours, one step at a time: + clip cache (one clip per cell and light), + predicted (the octree cut by predicted work), + load-aware (busy processors shed shadow tasks to idle ones)."
        ),
        &[t],
        json!({"sequential_s": seq, "runs": rows}),
    )
}

fn efficiency(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let seq = cx.sequential_s()?;
    let curve = over_time(&r, &[State::Executing], 100);
    let procs = r.options.procs as f64;
    let eff: Vec<(f64, f64)> = curve.iter().map(|&(t, v)| (t, v / procs)).collect();
    let ours = cx.run(RunSpec::ours(r.options.procs))?;
    let eff_ours: Vec<(f64, f64)> = over_time(&ours, &[State::Executing], 100)
        .iter()
        .map(|&(t, v)| (t, v / procs))
        .collect();
    let fair_ours = seq / secs(ours.stats.elapsed_ns) / procs;
    cx.chart(
        "efficiency-time.svg",
        &Chart {
            title: format!(
                "Figure 6: efficiency over time ({} processors)",
                r.options.procs
            ),
            x_label: "time (s)".into(),
            y_label: "fraction of processors executing".into(),
            series: vec![
                Series::new("paper", eff.clone(), Mark::Line),
                Series::new("ours", eff_ours.clone(), Mark::Line),
            ],
            y_range: Some((0.0, 1.05)),
            ..Chart::default()
        },
    )?;
    let el = r.stats.elapsed_ns.max(1) as f64;
    let per = per_proc(&r, |p| p.time_ns.executing as f64 / el);
    cx.bars(
        "efficiency-procs.svg",
        &Bars {
            title: "Figure 6: efficiency per processor".into(),
            y_label: "fraction of run time executing".into(),
            categories: proc_names(&r),
            parts: vec![("executing".into(), per.clone())],
        },
    )?;
    let mut t = Table::new([
        "processor",
        "executing %",
        "selecting %",
        "waiting %",
        "idle %",
        "communication %",
    ]);
    for p in &r.stats.procs {
        let pc = |v: u64| format!("{:.1}", 100.0 * v as f64 / el);
        let tm = &p.time_ns;
        t.row([
            p.addr.to_string(),
            pc(tm.executing),
            pc(tm.selecting),
            pc(tm.waiting_data),
            pc(tm.idle),
            pc(tm.sending + tm.receiving + tm.serving_data),
        ]);
    }
    let mean = per.iter().sum::<f64>() / per.len().max(1) as f64;
    let fair = seq / secs(r.stats.elapsed_ns) / procs;
    cx.finish(
        "efficiency",
        "Figure 6: efficiency over time and per processor",
        &format!(
            "Efficiency = share of time spent executing tasks (not clipping, waiting, idling or communicating). \
             Mean over processors {:.1}%; fair efficiency (sequential time / (p x parallel time)) {:.1}%; ours {:.1}%.",
            100.0 * mean,
            100.0 * fair,
            100.0 * fair_ours
        ),
        &[t],
        json!({"over_time": eff, "per_processor": per, "fair_efficiency": fair,
            "ours_over_time": eff_ours, "ours_fair_efficiency": fair_ours}),
    )
}

fn state_figure(cx: &mut Ctx, name: &str, title: &str, states: &[State], what: &str) -> Result<()> {
    let r = cx.detail()?;
    let curve = over_time(&r, states, 100);
    let ours = cx.run(RunSpec::ours(r.options.procs))?;
    let curve_ours = over_time(&ours, states, 100);
    cx.chart(
        &format!("{name}-time.svg"),
        &Chart {
            title: format!("{title} over time ({} processors)", r.options.procs),
            x_label: "time (s)".into(),
            y_label: what.into(),
            series: vec![
                Series::new(format!("{what} (paper)"), curve.clone(), Mark::Line),
                Series::new(format!("{what} (ours)"), curve_ours.clone(), Mark::Line),
            ],
            ..Chart::default()
        },
    )?;
    let per_ours = per_proc(&ours, |p| {
        states.iter().map(|&s| p.time_ns.get(s)).sum::<u64>() as f64 * 1e-9
    });
    let per = per_proc(&r, |p| {
        states.iter().map(|&s| p.time_ns.get(s)).sum::<u64>() as f64 * 1e-9
    });
    cx.bars(
        &format!("{name}-procs.svg"),
        &Bars {
            title: format!("{title} per processor"),
            y_label: "seconds".into(),
            categories: proc_names(&r),
            parts: states
                .iter()
                .map(|&s| {
                    (
                        format!("{s:?}"),
                        per_proc(&r, |p| p.time_ns.get(s) as f64 * 1e-9),
                    )
                })
                .collect(),
        },
    )?;
    let mut t = Table::new([
        "processor",
        "paper: seconds",
        "paper: % of run",
        "ours: seconds",
        "ours: % of run",
    ]);
    let el = secs(r.stats.elapsed_ns).max(1e-12);
    let el_ours = secs(ours.stats.elapsed_ns).max(1e-12);
    for (p, v) in per.iter().enumerate() {
        let o = per_ours.get(p).copied().unwrap_or(0.0);
        t.row([
            p.to_string(),
            format!("{v:.4}"),
            format!("{:.1}", 100.0 * v / el),
            format!("{o:.4}"),
            format!("{:.1}", 100.0 * o / el_ours),
        ]);
    }
    cx.finish(
        name,
        &format!("{title} over time and per processor"),
        &format!(
            "States counted: {states:?}. Run time {el:.3} s (paper) and {el_ours:.3} s (ours) on {} processors.",
            r.options.procs
        ),
        &[t],
        json!({"over_time": curve, "per_processor_s": per,
            "ours_over_time": curve_ours, "ours_per_processor_s": per_ours}),
    )
}

fn communication(cx: &mut Ctx) -> Result<()> {
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

fn data(cx: &mut Ctx) -> Result<()> {
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

const CACHE_PERCENTS: [f64; 7] = [1.0, 2.5, 5.0, 10.0, 25.0, 50.0, 100.0];

fn cache(cx: &mut Ctx) -> Result<()> {
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

fn breakdown(cx: &mut Ctx) -> Result<()> {
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

#[derive(Serialize)]
struct MemoryRow {
    processor: usize,
    resident: u64,
    cache: u64,
    waiting_tasks: u64,
    input_buffer: u64,
    pixel_trees_nodes: usize,
    send_backlog_messages: u64,
}

fn memory(cx: &mut Ctx) -> Result<()> {
    let r = cx.detail()?;
    let rows: Vec<MemoryRow> = r
        .stats
        .procs
        .iter()
        .enumerate()
        .map(|(i, p)| MemoryRow {
            processor: i,
            resident: p.memory.resident_bytes,
            cache: p.memory.cached_bytes,
            waiting_tasks: p.memory.waiting_task_bytes as u64,
            input_buffer: p.memory.input_buffer_bytes as u64,
            pixel_trees_nodes: r.procs.get(i).map_or(0, |s| s.peak_tree_nodes),
            send_backlog_messages: p.memory.send_backlog as u64,
        })
        .collect();
    // The paper reports one of its 16 processors: the one with the most.
    let worst = rows
        .iter()
        .max_by_key(|m| m.resident + m.cache + m.waiting_tasks + m.input_buffer)
        .map_or(0, |m| m.processor);
    let m = &rows[worst];
    let kib = |b: u64| format!("{:.1}", b as f64 / 1024.0);
    let mut t = Table::new(["category", "high-water (KiB)"]);
    t.row([
        "resident objects (its partition)".to_string(),
        kib(m.resident),
    ]);
    t.row(["object cache".to_string(), kib(m.cache)]);
    t.row(["tasks waiting for data".to_string(), kib(m.waiting_tasks)]);
    t.row([
        "input buffer (credit-limited messages)".to_string(),
        kib(m.input_buffer),
    ]);
    t.row([
        "pixel ray-tree nodes held".to_string(),
        m.pixel_trees_nodes.to_string(),
    ]);
    t.row([
        "send backlog (messages)".to_string(),
        m.send_backlog_messages.to_string(),
    ]);
    let mut all = Table::new([
        "processor",
        "resident KiB",
        "cache KiB",
        "waiting KiB",
        "input buffer KiB",
    ]);
    for m in &rows {
        all.row([
            m.processor.to_string(),
            kib(m.resident),
            kib(m.cache),
            kib(m.waiting_tasks),
            kib(m.input_buffer),
        ]);
    }
    cx.finish(
        "memory",
        "Table 2: memory high-water by category",
        &format!(
            "Processor {worst} of {} (the one with the largest total), then all processors.",
            r.options.procs
        ),
        &[t, all],
        serde_json::to_value(&rows).map_err(|e| Error::Other(format!("json: {e}")))?,
    )
}

/// Beyond the paper: the bottleneck processor's input buffer with and
/// without flow control (the paper's 617 kB -> 16 MB growth).
fn flow(cx: &mut Ctx) -> Result<()> {
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
