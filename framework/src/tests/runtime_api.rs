//! The runtime interface: every runtime behind `dyn Runtime`, awaiting a
//! run from tokio applications, `Ctx::origin`, and cost models checked
//! against the workload's work kinds.

use super::*;
use crate::runtime::sim::{run_sim, CostModel, Network, Sim};
use crate::{ConfigError, Lockstep, Runtime, Sequential, Threads};

fn all_runtimes() -> Vec<Box<dyn Runtime<Mini>>> {
    let mut cost = CostModel::default();
    cost.unit_ns.insert("work".into(), 50_000.0);
    vec![
        Box::new(Threads),
        Box::new(Sequential),
        Box::new(Lockstep::new(11)),
        Box::new(Sim::new(cost, Network::ten_gbe())),
    ]
}

#[test]
fn every_runtime_behind_one_interface_matches_sequential() {
    let w = Mini::default();
    let cfg = Config::new(3).with_cache_bytes(Some(200));
    for rt in all_runtimes() {
        let r = rt.run_blocking(Arc::new(w.clone()), &cfg).unwrap();
        assert_eq!(r.stats.runtime, rt.name());
        check_against_sequential(&w, &r);
        // Only the simulator has a timeline; nobody here is an MPI rank.
        assert_eq!(r.timeline().is_some(), rt.name() == "sim", "{}", rt.name());
        assert!(r.is_root() && r.ranks().is_none());
    }
}

/// A tokio application awaits a run (the threads runtime starts its own
/// tokio runtime on a thread of its own), and may also call the blocking
/// forms from inside its runtime.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn runs_are_awaitable_inside_a_multi_thread_tokio_runtime() {
    let w = Mini::default();
    let cfg = Config::new(3).with_cache_bytes(Some(200));
    for rt in all_runtimes() {
        let r = rt.run(Arc::new(w.clone()), &cfg).await.unwrap();
        check_against_sequential(&w, &r);
    }
    let r = Threads.run_blocking(Arc::new(w.clone()), &cfg).unwrap();
    check_against_sequential(&w, &r);
    let r = run_threads(Arc::new(w.clone()), &cfg).unwrap();
    check_against_sequential(&w, &r);
}

#[tokio::test(flavor = "current_thread")]
async fn runs_are_awaitable_inside_a_current_thread_tokio_runtime() {
    let w = Mini::default();
    let cfg = Config::new(2);
    let rt: Box<dyn Runtime<Mini>> = Box::new(Threads);
    let r = rt.run(Arc::new(w.clone()), &cfg).await.unwrap();
    check_against_sequential(&w, &r);
    let r = run_threads(Arc::new(w.clone()), &cfg).unwrap();
    check_against_sequential(&w, &r);
}

/// A workload laid out for one processor count is refused, before any
/// hook runs, by every runtime asked for another; the same count runs.
#[test]
fn every_runtime_refuses_a_workload_laid_out_for_another_count() {
    let w = Mini {
        laid_out: Some(3),
        ..Mini::default()
    };
    for rt in all_runtimes() {
        let err = rt
            .run_blocking(Arc::new(w.clone()), &Config::new(2))
            .unwrap_err();
        match err {
            RunError::Config(ConfigError::ProcsMismatch { laid_out, procs }) => {
                assert_eq!((laid_out, procs), (3, 2), "{}", rt.name())
            }
            other => panic!("{}: expected a count mismatch, got {other}", rt.name()),
        }
        let r = rt
            .run_blocking(Arc::new(w.clone()), &Config::new(3))
            .unwrap();
        check_against_sequential(&w, &r);
    }
    assert!(matches!(
        run_sequential(&w, 4),
        Err(RunError::Config(ConfigError::ProcsMismatch { .. }))
    ));
}

#[test]
fn a_cost_model_naming_an_unknown_work_kind_is_an_error() {
    let mut cost = CostModel::default();
    cost.unit_ns.insert("wrok".into(), 1.0);
    let err = run_sim(
        Arc::new(Mini::default()),
        &Config::new(2),
        &Sim::new(cost, Network::ten_gbe()),
    )
    .unwrap_err();
    match err {
        RunError::Config(ConfigError::UnknownWorkKind { name, known }) => {
            assert_eq!(name, "wrok");
            assert_eq!(known, "select, work");
        }
        other => panic!("expected an unknown work kind, got {other}"),
    }
    // The typed way cannot misspell.
    let cost = CostModel::default().with_unit(MiniWork::Work, 1.0);
    assert!(cost.check::<MiniWork>().is_ok());
}

/// Root tasks spawn children (placed elsewhere by round-robin) and
/// data-parallel tasks; each reports the processor it sees as its origin,
/// roots report where they ran.
#[derive(Clone, Debug)]
struct Families;

#[derive(Clone, Debug, Serialize, Deserialize)]
enum FamTask {
    Root(u64),
    Child(u64),
}
impl ByteSize for FamTask {
    fn byte_size(&self) -> usize {
        16
    }
}

/// (root, what, processor): 0 = the root ran there, 1 = a child or walk
/// saw it as its origin, 2 = a child ran there.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Seen(u64, u8, usize);
impl ByteSize for Seen {
    fn byte_size(&self) -> usize {
        24
    }
}

impl Workload for Families {
    type DataId = u32;
    type DataItem = Item;
    type DdTask = FamTask;
    type DpTask = FamTask;
    type Result = Seen;
    type Accumulator = BTreeMap<(u64, u8), Vec<usize>>;
    type Work = crate::NoWork;

    fn placement(&self, _procs: usize) -> Vec<Placement<u32>> {
        Vec::new()
    }
    fn load_partition(&self, _proc: usize, _procs: usize) -> Vec<(u32, Item)> {
        Vec::new()
    }
    fn root_tasks(&self, _procs: usize) -> Vec<FamTask> {
        (0..12).map(FamTask::Root).collect()
    }
    fn select_data(&self, _t: &FamTask, _ctx: &mut Ctx<Self>) -> Vec<u32> {
        Vec::new()
    }
    fn execute_dd(&self, t: FamTask, _d: &DataView<'_, Self>, ctx: &mut Ctx<Self>) {
        match t {
            FamTask::Root(r) => {
                assert_eq!(ctx.origin(), ctx.proc_id(), "a root is its own origin");
                ctx.emit_result(Addr::Master, Seen(r, 0, ctx.proc_id()));
                for _ in 0..3 {
                    ctx.spawn_dd(FamTask::Child(r));
                }
                ctx.spawn_dp(FamTask::Child(r));
            }
            FamTask::Child(r) => {
                ctx.emit_result(Addr::Master, Seen(r, 1, ctx.origin()));
                ctx.emit_result(Addr::Master, Seen(r, 2, ctx.proc_id()));
            }
        }
    }
    fn to_data_parallel(&self, _t: FamTask, _ctx: &mut Ctx<Self>) {
        unreachable!("no data, nothing to fall back from")
    }
    fn route_dp(&self, _w: &FamTask) -> Option<u32> {
        None
    }
    fn execute_dp(
        &self,
        w: FamTask,
        _d: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> DpOutcome<FamTask> {
        let (FamTask::Root(r) | FamTask::Child(r)) = w;
        ctx.emit_result(Addr::Master, Seen(r, 1, ctx.origin()));
        DpOutcome::Finished
    }
    fn merge(&self, acc: &mut Self::Accumulator, s: Seen) {
        let v = acc.entry((s.0, s.1)).or_default();
        v.push(s.2);
        v.sort_unstable();
    }
}

#[test]
fn ctx_origin_is_the_processor_that_ran_the_root() {
    for policy in [Policy::RoundRobin, Policy::ViaMaster, Policy::ToOrigin] {
        for seed in 0..4 {
            let cfg = Config::new(3).with_policy(policy);
            let r = run_lockstep(Arc::new(Families), &cfg, seed).unwrap();
            let mut elsewhere = 0;
            for root in 0..12 {
                let ran = &r.master[&(root, 0)];
                assert_eq!(ran.len(), 1);
                let seen = &r.master[&(root, 1)];
                assert_eq!(seen.len(), 4, "three children and a walk");
                assert!(
                    seen.iter().all(|p| p == &ran[0]),
                    "{policy}: {seen:?} vs {ran:?}"
                );
                let ran_at = &r.master[&(root, 2)];
                elsewhere += ran_at.iter().filter(|p| *p != &ran[0]).count();
            }
            // Children did run away from their origin (else the check
            // above would be trivial), except where the policy sends them
            // home.
            assert_eq!(
                elsewhere > 0,
                policy != Policy::ToOrigin,
                "{policy}, seed {seed}"
            );
        }
    }
}
