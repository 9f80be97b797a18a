//! Diffuse inter-reflection in the hybrid workload, without an irradiance
//! cache (the only kind it is given, [`super::runtime::check_hybrid`]): a
//! shaded point's hemispheres are nodes of the pixel's ray tree whose
//! sample rays are data-parallel tasks of their own, migrating to the
//! cells they need like any other ray; the pixel's owner evaluates a
//! hemisphere once every sample's value is in
//! ([`super::tree::Record::Hemisphere`]), with the sequential renderer's
//! operations, and adds it to its point's value before the point's other
//! requests. A hemisphere that may take super-samples (`-as`, which go
//! where the first samples differ most) is handed to the workload when
//! the last of its first samples is merged at the pixel's owner
//! ([`super::tree::Record::SuperHemisphere`],
//! [`hybrid_sched::Workload::merge_in`]): the owner makes it again from
//! its seed, adds the first samples' values as the sequential renderer
//! does, and spawns the super-samples from there, which migrate like the
//! first; once they are in, it finishes the hemisphere the same way. The
//! book's parallel renderer chapter, "Hemisphere rays".
//!
//! A hemisphere spawns 16 to thousands of tasks, each of which may spawn
//! as many: oldest first, a processor held a whole level of those trees
//! (the Cornell box at 48 x 48, `-ab 2 -ad 64`, three processors: 798 MB
//! at the peak against 54 MB newest first and 8 MB for the sequential
//! renderer), so the workload asks for depth first
//! ([`hybrid_sched::Workload::data_parallel_newest_first`]). Where nearly
//! every sample ray migrates (a cache of 10%), newest first alone left
//! the points' shadow bundles (demand-driven) queued behind the arriving
//! rays and sent the oldest waiting rays first: 2.1 GB on two processors,
//! against 64 to 68 MB now that those run and leave first (the book's
//! parallel chapter).

use hybrid_sched::{Addr, Ctx};

use super::tasks::{DpTask, RayJob};
use super::tree::{Child, HemisphereSeed, NodeKey, PixelTrees, Record, RtResult, SuperState};
use super::work::Work;
use super::workload::RtWorkload;
use crate::accel::TraceCursor;
use crate::render::ambient::{AmbientRequest, AmbientStore, Hemisphere};
use crate::render::shading::Shaded;
use crate::render::RayTask;
use crate::scene::Color;

impl RtWorkload {
    /// Adds the ambient requests of the point `key` (at the hit of
    /// `task`) to its `children`, after its `requests` others: each
    /// hemisphere a node (key: the point's, then `requests` + its index)
    /// whose record goes to the pixel's owner and whose samples are
    /// spawned, one per stratum; where no hemisphere is sampled (its rays
    /// would exceed `-lr` or fall below `-lw`), its term with `-av`,
    /// carried.
    pub(super) fn spawn_hemispheres(
        &self,
        key: &NodeKey,
        task: &RayTask,
        ambient: &[Option<AmbientRequest>],
        requests: usize,
        children: &mut Vec<Child>,
        ctx: &mut Ctx<Self>,
    ) {
        let o = self.renderer.options();
        let settings = self.renderer.ambient_settings();
        for (j, req) in ambient.iter().flatten().enumerate() {
            let node = key.child(requests + j);
            let Some(h) = Hemisphere::new(settings, o, task, req) else {
                // `-av`, moved to the average of the cache (of no records).
                let av = AmbientStore::default().ambient_value(o.av, o.aw);
                children.push(Child::AmbientKnown(req.coef * av));
                continue;
            };
            let samples = h.first_pass();
            children.push(Child::Ambient(req.coef));
            let strata = u16::try_from(samples.len()).unwrap_or(u16::MAX);
            let record = if h.most_super_samples(settings.super_samples) > 0 {
                let seed = HemisphereSeed {
                    task: *task,
                    req: *req,
                };
                Record::SuperHemisphere {
                    strata,
                    seed: Box::new(seed),
                }
            } else {
                Record::Hemisphere { strata }
            };
            let key = node.clone();
            ctx.emit_result(Addr::Proc(ctx.origin()), RtResult { key, record });
            spawn_samples(&node, 0, samples, ctx);
        }
    }

    /// After a merge: makes the super-samples of the hemispheres whose
    /// first samples are all in (spawned from here, the pixel's owner), and
    /// the value of those whose samples are all in, as the sequential
    /// renderer does (`Renderer::ambient_value`: the first pass added
    /// stratum by stratum, the second pass sample by sample, then
    /// [`Hemisphere::finish`]).
    pub(super) fn super_sample(&self, acc: &mut PixelTrees, ctx: &mut Ctx<Self>) {
        let o = self.renderer.options();
        let settings = self.renderer.ambient_settings();
        while let Some(w) = acc.wanted.pop() {
            let seed = &w.state.seed;
            let Some(mut h) = Hemisphere::new(settings, o, &seed.task, &seed.req) else {
                debug_assert!(false, "a hemisphere made once is made again");
                continue;
            };
            let n = h.divisions();
            // Distances serve only records, which a render without a cache
            // makes none of.
            for (k, &v) in w.values.iter().take(n).enumerate() {
                h.add(k, v, f64::INFINITY);
            }
            match &w.state.second {
                None => {
                    let more = h.second_pass(settings.super_samples);
                    if more.is_empty() {
                        acc.deliver(w.key, h.finish(settings).0);
                        continue;
                    }
                    let strata = more.iter().map(|&(k, _)| k as u16).collect();
                    let state = SuperState {
                        seed: w.state.seed.clone(),
                        second: Some(strata),
                    };
                    acc.await_second(&w.key, state, &w.values[..n]);
                    spawn_samples(&w.key, n, more, ctx);
                }
                Some(strata) => {
                    for (&k, &v) in strata.iter().zip(&w.values[n..]) {
                        h.add(usize::from(k), v, f64::INFINITY);
                    }
                    acc.deliver(w.key, h.finish(settings).0);
                }
            }
        }
    }

    /// The point's local part: with `-aw`, its `-av` term moved to the
    /// cache's average (of no records here), with the sequential
    /// renderer's operations.
    pub(super) fn ambient_base(&self, shaded: &Shaded) -> Color {
        let o = self.renderer.options();
        let mut base = shaded.base;
        if o.aw > 0
            && shaded.constant != Color::ZERO
            && self.renderer.effects().diffuse_interreflection.enabled
        {
            let av = AmbientStore::default().ambient_value(o.av, o.aw);
            base += shaded.constant * (av - o.av);
        }
        base
    }
}

/// Spawns a hemisphere's `samples` (stratum, ray) as data-parallel tasks,
/// children `first..` of its node `node`.
pub(super) fn spawn_samples(
    node: &NodeKey,
    first: usize,
    samples: Vec<(usize, RayTask)>,
    ctx: &mut Ctx<RtWorkload>,
) {
    ctx.charge(Work::RaysSpawned, samples.len() as u64);
    for (i, (_, sample)) in samples.into_iter().enumerate() {
        ctx.spawn_dp(DpTask::Ray(RayJob {
            key: node.child(first + i),
            task: sample,
            cursor: TraceCursor::default(),
            next: None,
        }));
    }
}
