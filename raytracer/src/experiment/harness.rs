//! What the experiments share: the [`Setup`], the per-run runner (one
//! simulated run per [`RunSpec`], memoised across experiments), the
//! sequential baseline, output writing and the time-line helpers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use hybrid_sched::Runtime;
use hybrid_sched::{Class, Network, Policy, Sequential, State, Timeline};
use serde_json::Value;

use crate::accel::OctreeParams;
use crate::parallel::cost;
use crate::parallel::{
    render_parallel, CacheSize, Distribution, ParallelOptions, ParallelRender, RtWorkload,
    RuntimeKind, WorkloadOptions,
};
use crate::render::{RenderOptions, Renderer};
use crate::report::plot::{Bars, Chart};
use crate::report::table::Table;
use crate::scene::{Scene, View};
use crate::{Error, Result};

/// What the experiments run on.
#[derive(Clone)]
pub struct Setup {
    /// Scene name for titles (`studio`, a file stem, ...).
    pub name: String,
    pub scene: Arc<Scene>,
    pub view: View,
    pub options: RenderOptions,
    /// The render options as given on the command line (`-ds 0.05 -dt 0`;
    /// empty for the defaults), named in every table's setup line.
    pub options_words: String,
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

pub(super) struct Ctx<'a> {
    pub(super) s: &'a Setup,
    pub(super) out: &'a Path,
    pub(super) written: Vec<Output>,
    /// Runs shared between experiments (the 16-processor run feeds six).
    pub(super) memo: BTreeMap<String, Arc<ParallelRender>>,
    pub(super) seq_s: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct RunSpec {
    pub(super) procs: usize,
    pub(super) policy: Policy,
    pub(super) cache: CacheSize,
    pub(super) distribution: Distribution,
    pub(super) credits: usize,
    /// [`hybrid_sched::Config::flight_bytes`].
    pub(super) flight_bytes: usize,
    pub(super) small: bool,
    pub(super) clip_cache: bool,
    /// [`WorkloadOptions::inline_local_shadows`] (the paper has every
    /// shadow bundle a task of its own).
    pub(super) inline_shadows: bool,
    /// Side of the screen tiles ([`WorkloadOptions::tile`]).
    pub(super) tile: usize,
}

impl RunSpec {
    pub(super) fn paper(procs: usize) -> Self {
        RunSpec {
            procs,
            policy: Policy::Local,
            cache: CacheSize::Unlimited,
            distribution: Distribution::Octree,
            credits: 64,
            flight_bytes: hybrid_sched::config::DEFAULT_FLIGHT_BYTES,
            small: false,
            clip_cache: false,
            inline_shadows: false,
            tile: WorkloadOptions::default().tile,
        }
    }

    /// Coarse shadow tasks: bundles start in the step that shaded their
    /// point where they can, the rest of a point's travel as one task.
    pub(super) fn coarse(procs: usize) -> Self {
        RunSpec {
            inline_shadows: true,
            ..Self::paper(procs)
        }
    }

    pub(super) fn clip_cache(procs: usize) -> Self {
        RunSpec {
            clip_cache: true,
            ..Self::coarse(procs)
        }
    }

    pub(super) fn predicted(procs: usize) -> Self {
        RunSpec {
            distribution: Distribution::Predicted,
            ..Self::clip_cache(procs)
        }
    }

    pub(super) fn ours(procs: usize) -> Self {
        RunSpec {
            policy: Policy::LoadAware,
            ..Self::predicted(procs)
        }
    }

    pub(super) fn key(&self) -> String {
        format!("{self:?}")
    }
}

/// Virtual seconds.
pub(super) fn secs(ns: u64) -> f64 {
    ns as f64 * 1e-9
}

/// What a simulated run moved and held, as the diffuse inter-reflection
/// experiments tabulate it: data-parallel migrations, cells fetched,
/// bytes of tasks (migrating and demand-driven, the master's hand-outs
/// included), of cells and of results sent, and the most any processor
/// held (resident cells and cache), queued (tasks, parked ones included)
/// and had in flight.
pub(super) struct Traffic {
    pub(super) migrations: u64,
    pub(super) fetched: u64,
    pub(super) tasks: u64,
    pub(super) cells: u64,
    pub(super) results: u64,
    pub(super) most_held: u64,
    pub(super) most_queued: u64,
    pub(super) most_in_flight: u64,
}

impl Traffic {
    pub(super) fn of(st: &hybrid_sched::RunStats) -> Self {
        let most =
            |f: &dyn Fn(&hybrid_sched::ProcStats) -> u64| st.procs.iter().map(f).max().unwrap_or(0);
        Traffic {
            migrations: st.sum(|q| q.tasks.migrations),
            fetched: st.sum(|q| q.data_items_requested),
            tasks: st.sum(|q| q.sent.data_parallel.bytes + q.sent.demand_driven.bytes)
                + st.master.sent.demand_driven.bytes,
            cells: st.sum(|q| q.sent.data.bytes),
            results: st.sum(|q| q.sent.result.bytes),
            most_held: most(&|q| q.memory.resident_bytes + q.memory.cached_bytes),
            most_queued: most(&|q| q.memory.queued_tasks as u64),
            most_in_flight: most(&|q| q.memory.in_flight_bytes as u64),
        }
    }
}

/// 1, 2, 4, ... up to `max` processors: the speed-up curves' counts.
pub(super) fn doubling(max: usize) -> Vec<usize> {
    std::iter::successors(Some(1usize), |&p| Some(p * 2))
        .take_while(|&p| p == 1 || p <= max)
        .collect()
}

/// Checks that every run of an experiment renders the first run's picture
/// (`what` names the run): the first is kept in `first`.
pub(super) fn same_picture(
    first: &mut Option<Vec<crate::scene::Color>>,
    film: &crate::image::Film,
    what: &str,
) -> Result<()> {
    match first {
        None => *first = Some(film.pixels().to_vec()),
        Some(f) if f.as_slice() != film.pixels() => {
            return Err(Error::Other(format!(
                "{what} rendered another picture than 1"
            )))
        }
        Some(_) => {}
    }
    Ok(())
}

pub(super) fn f3(x: f64) -> String {
    format!("{x:.3}")
}

impl Ctx<'_> {
    pub(super) fn run(&mut self, spec: RunSpec) -> Result<Arc<ParallelRender>> {
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
        // The paper's cache: it fetches only what tasks select.
        p.complete_cache = None;
        // And the paper's service: a request waits for its owner's step.
        p.data_service = hybrid_sched::DataService::BetweenSteps;
        p.workload = WorkloadOptions {
            distribution: spec.distribution,
            clip_cache: spec.clip_cache,
            inline_local_shadows: spec.inline_shadows,
            tile: spec.tile,
            // The simulated machine walks the octree (the cost model
            // prices the walk).
            local_kernel: false,
            // Whole tiles to the end, as the paper's: `render` splits the
            // last ones (EXPERIMENTS.md's record at the paper's size).
            tail_tiles: false,
            ..WorkloadOptions::default()
        };
        p.network = s.network.clone();
        p.sim_seed = s.seed;
        p.credits = spec.credits;
        p.flight_bytes = spec.flight_bytes;
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
    pub(super) fn sequential_s(&mut self) -> Result<f64> {
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
            WorkloadOptions {
                local_kernel: false,
                tail_tiles: false,
                ..WorkloadOptions::default()
            },
        );
        let report = Sequential
            .run_blocking(Arc::new(wl), &hybrid_sched::Config::new(1))
            .map_err(|e| Error::Other(format!("sequential run failed: {e}")))?;
        let ns = cost::predict_ns(&cost::model(), &report.stats.procs[0].work, 0);
        let t = ns * s.network.cpu_scale * 1e-9;
        self.seq_s = Some(t);
        Ok(t)
    }

    pub(super) fn write(&mut self, file: &str, data: &[u8]) -> Result<()> {
        let path = self.out.join(file);
        std::fs::write(&path, data).map_err(|e| Error::io(&path, e))?;
        self.written.push(Output { path });
        Ok(())
    }

    pub(super) fn chart(&mut self, file: &str, chart: &Chart) -> Result<()> {
        let svg = chart.to_svg()?;
        self.write(file, svg.as_bytes())
    }

    pub(super) fn bars(&mut self, file: &str, bars: &Bars) -> Result<()> {
        let svg = bars.to_svg()?;
        self.write(file, svg.as_bytes())
    }

    pub(super) fn finish(
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

    pub(super) fn setup_line(&self) -> String {
        let s = self.s;
        let model = cost::committed();
        format!(
            "Scene `{}`, {}x{} pixels, simulated `{}` network (compute {}x slower than the calibration machine), seed {}. Compute priced by `{}` (fitted {} on {}).\n",
            s.name,
            s.width,
            s.height,
            s.network.name,
            s.network.cpu_scale,
            s.seed,
            cost::MODEL_PATH,
            model.date,
            model.machine
        ) + &if s.options_words.is_empty() {
            String::new()
        } else {
            format!("Render options: `{}`.\n", s.options_words)
        }
    }

    pub(super) fn detail(&mut self) -> Result<Arc<ParallelRender>> {
        let p = self.s.detail_procs;
        self.run(RunSpec::paper(p))
    }
}

/// A run's time line, re-binned to about `points` buckets: per bucket, the
/// average number of processors in any of `states`.
pub(super) fn over_time(r: &ParallelRender, states: &[State], points: usize) -> Vec<(f64, f64)> {
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
pub(super) fn traffic_over_time(
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

pub(super) fn per_proc(
    r: &ParallelRender,
    f: impl Fn(&hybrid_sched::ProcStats) -> f64,
) -> Vec<f64> {
    r.stats.procs.iter().map(f).collect()
}

pub(super) fn proc_names(r: &ParallelRender) -> Vec<String> {
    (0..r.options.procs).map(|p| p.to_string()).collect()
}
