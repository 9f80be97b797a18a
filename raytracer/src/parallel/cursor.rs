//! The irradiance cache in the hybrid workload: where a pixel's owner is
//! in the sequential renderer's order of decisions.
//!
//! With a cache, what a shaded point's ambient request gets depends on the
//! records that exist when it is asked: those of the waves before (held by
//! every processor, `irradiance.rs`) and those the pixel's own trace made
//! before it, in the order the sequential renderer traces
//! (`Renderer::radiance`): at each point its `-aw` term, then its ambient
//! requests in order, each either interpolated from the records (after the
//! leak tests of the records that need them, Radiance's `plugaleak`), or
//! `-av` where no hemisphere may be sampled, or a hemisphere whose sample
//! rays are traced one after another, each whole, its super-samples
//! (`-as`) after them, and its record stored; then the point's traced
//! children in order, each whole.
//!
//! Rays are traced and points shaded anywhere, in any order, as without a
//! cache: only the decisions wait. The pixel's owner walks the pixel's
//! tree depth first in that order as the nodes' records arrive
//! ([`super::tree::Record::Traced`]), deciding each request when it gets
//! there: a hemisphere's samples become data-parallel tasks, and the walk
//! goes into each of their trees in turn; the hemisphere's record is made
//! when all its samples' values and distances are in. Leak tests travel
//! as data-parallel tasks ([`super::tasks::LeakDp`]) where the owner does
//! not hold what they cross. So a pixel's value and records are the
//! sequential renderer's, bit for bit; the parallelism is the wave's
//! pixels' and their rays'.

use hybrid_sched::{Addr, Ctx, DataView};

use super::caster::{LocalQueries, PartialCaster, Recording, Replay};
use super::hemispheres::spawn_samples;
use super::kernel::CellMemo;
use super::tasks::{DpTask, LeakDp};
use super::tree::{HemisphereSeed, NodeKey, PixelTrees, RtResult, SuperState};
use super::walk::{node_frame, pass_leaf, Frame, PixelCursor};
use super::work::Work;
use super::workload::RtWorkload;
use crate::geometry::Vec3;
use crate::render::ambient::Hemisphere;

/// What a step of the walk found to do.
enum Step {
    Wait,
    Done,
    Continue,
}

impl RtWorkload {
    /// Walks pixel `pixel`'s tree as far as its records allow, deciding
    /// what is to be decided (see the module documentation).
    pub(super) fn advance_cursor(
        &self,
        acc: &mut PixelTrees,
        pixel: u32,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) {
        let Some(mut cur) = acc.cursors.remove(&pixel) else {
            return;
        };
        if cur.store.is_none() {
            let base = self.wave_cache(ctx.proc_id(), None, data);
            cur.store = Some(crate::render::Renderer::frozen_state(&base));
            cur.stack.push(Frame::Node {
                path: Vec::new(),
                info: None,
                aw_done: false,
                next_request: 0,
                next_trace: 0,
                first_dist: f64::INFINITY,
            });
        }
        loop {
            self.take_wanted(acc, pixel, &mut cur);
            match self.step(acc, pixel, &mut cur, data, ctx) {
                Step::Continue => {}
                Step::Wait | Step::Done => break,
            }
        }
        acc.cursors.insert(pixel, cur);
    }

    /// Hands the hemispheres whose samples are all in to their frames.
    fn take_wanted(&self, acc: &mut PixelTrees, pixel: u32, cur: &mut PixelCursor) {
        let mut i = 0;
        while i < acc.wanted.len() {
            if acc.wanted[i].key.pixel != pixel {
                i += 1;
                continue;
            }
            let w = acc.wanted.swap_remove(i);
            let frame = cur
                .stack
                .iter_mut()
                .rev()
                .find(|f| matches!(f, Frame::Hemisphere { path, .. } if *path == w.key.path));
            match frame {
                Some(Frame::Hemisphere { values, .. }) => *values = Some(w.values),
                _ => debug_assert!(false, "hemisphere {:?} is not being sampled", w.key),
            }
        }
    }

    fn step(
        &self,
        acc: &mut PixelTrees,
        pixel: u32,
        cur: &mut PixelCursor,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Step {
        let o = self.renderer.options();
        let key = |path: &[u16]| NodeKey {
            pixel,
            path: path.to_vec(),
        };
        let Some(top) = cur.stack.last_mut() else {
            return Step::Done;
        };
        match top {
            Frame::Node {
                path,
                info: info @ None,
                ..
            } => match cur.arrived.remove(path) {
                Some(i) => *info = Some(i),
                None => return Step::Wait,
            },
            Frame::Node {
                path,
                info: Some(info),
                aw_done,
                next_request,
                next_trace,
                first_dist,
            } => {
                let store = cur.store.as_ref().expect("the walk has started");
                if !*aw_done {
                    *aw_done = true;
                    if let Some((child, constant)) = info.aw {
                        let av = store.ambient_value(o.av, o.aw);
                        acc.deliver(key(path).child(child), constant * (av - o.av));
                    }
                } else if *next_request < info.requests.len() {
                    let (child, seed) = info.requests[*next_request].clone();
                    let at = key(path).child(child);
                    match self.decide(acc, cur, at, seed, data, ctx) {
                        Some(frame) => {
                            if let Some(Frame::Node { next_request, .. }) = cur.stack.last_mut() {
                                *next_request += 1;
                            }
                            if let Some(f) = frame {
                                cur.stack.push(f);
                            }
                        }
                        None => return Step::Wait,
                    }
                } else if *next_trace < info.traces.len() {
                    let c = info.traces[*next_trace];
                    let mut child = path.clone();
                    child.push(c as u16);
                    *next_trace += 1;
                    match pass_leaf(&mut cur.arrived, &child) {
                        Some(d) if c == 0 => *first_dist = d,
                        Some(_) => {}
                        None => cur.stack.push(node_frame(child)),
                    }
                } else {
                    // Radiance's `raytrans()`: a surface that only passes
                    // the ray on measures the surface beyond.
                    let dist = if info.passes_on {
                        info.t + *first_dist
                    } else {
                        info.t
                    };
                    let last = path.last().copied();
                    cur.stack.pop();
                    match cur.stack.last_mut() {
                        Some(Frame::Node { first_dist, .. }) if last == Some(0) => {
                            *first_dist = dist
                        }
                        Some(Frame::Hemisphere { dists, .. }) => dists.push(dist),
                        _ => {}
                    }
                }
            }
            Frame::Hemisphere {
                path,
                h,
                seed,
                divs,
                first,
                second,
                entered,
                dists,
                values,
            } => {
                if *entered < divs.len() {
                    let mut child = path.clone();
                    child.push(*entered as u16);
                    *entered += 1;
                    match pass_leaf(&mut cur.arrived, &child) {
                        Some(d) => dists.push(d),
                        None => cur.stack.push(node_frame(child)),
                    }
                    return Step::Continue;
                }
                let Some(v) = values.take() else {
                    return Step::Wait;
                };
                let s = self.renderer.ambient_settings();
                if !*second {
                    for i in 0..*first {
                        h.add(divs[i], v[i], dists[i]);
                    }
                    let more = h.second_pass(s.super_samples);
                    if !more.is_empty() {
                        *second = true;
                        divs.extend(more.iter().map(|m| m.0));
                        let at = key(path);
                        let state = SuperState {
                            seed: (**seed).clone(),
                            second: None,
                        };
                        acc.await_samples(&at, state, &v[..*first], more.len());
                        spawn_samples(&at, *first, more, ctx);
                        return Step::Continue;
                    }
                } else {
                    for i in *first..divs.len() {
                        h.add(divs[i], v[i], dists[i]);
                    }
                }
                let (value, record) = h.finish(s);
                let at = key(path);
                cur.stack.pop();
                if let (Some(r), Some(store)) = (record, cur.store.as_mut()) {
                    store.insert(s, r);
                }
                acc.deliver(at, value);
            }
        }
        Step::Continue
    }

    /// Decides the ambient request whose value is child `at`: `None` to
    /// wait for its leak tests' answers, else the frame of the hemisphere
    /// to sample, if one is.
    fn decide(
        &self,
        acc: &mut PixelTrees,
        cur: &mut PixelCursor,
        at: NodeKey,
        seed: HemisphereSeed,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<Option<Frame>> {
        let o = self.renderer.options();
        let s = self.renderer.ambient_settings();
        let store = cur.store.as_ref().expect("the walk has started");
        let (task, req) = (&seed.task, &seed.req);
        let mut tests: Vec<(Vec3, Vec3, f64)> = Vec::new();
        let lookup = |answer: &mut dyn FnMut(Vec3, Vec3, f64) -> bool| {
            store.lookup(s, req.point, req.normal, task.ambient, task.weight, answer)
        };
        let mut found = lookup(&mut |p, d, l| {
            tests.push((p, d, l));
            false
        });
        if !tests.is_empty() {
            if cur.leaks.is_none() && !cur.leak_sent {
                match self.try_leaks(req, &tests, Replay::default(), data, ctx) {
                    LeakRun::Done(answers) => cur.leaks = Some(answers),
                    LeakRun::Blocked(replay, leaf) => {
                        ctx.charge(Work::LeakJobs, 1);
                        cur.leak_sent = true;
                        ctx.spawn_dp(DpTask::Leak(LeakDp {
                            key: at.clone(),
                            req: *req,
                            tests,
                            replay,
                            next: Some(leaf),
                        }));
                    }
                }
            }
            let answers = cur.leaks.take()?;
            cur.leak_sent = false;
            let mut given = answers.into_iter();
            found = lookup(&mut |_, _, _| given.next().unwrap_or(false));
        }
        acc.ambient.lookups += 1;
        ctx.charge(Work::AmbientLookups, 1);
        if let Some(v) = found {
            acc.ambient.hits += 1;
            acc.deliver(at, v);
            return Some(None);
        }
        let Some(h) = Hemisphere::new(s, o, task, req) else {
            acc.ambient.fallbacks += 1;
            acc.deliver(at, store.ambient_value(o.av, o.aw));
            return Some(None);
        };
        acc.ambient.hemispheres += 1;
        let samples = h.first_pass();
        let divs: Vec<usize> = samples.iter().map(|s| s.0).collect();
        let state = SuperState {
            seed: seed.clone(),
            second: None,
        };
        acc.await_samples(&at, state, &[], samples.len());
        spawn_samples(&at, 0, samples, ctx);
        Some(Some(Frame::Hemisphere {
            path: at.path,
            h: Box::new(h),
            seed: Box::new(seed),
            first: divs.len(),
            divs,
            second: false,
            entered: 0,
            dists: Vec::new(),
            values: None,
        }))
    }

    /// Runs the leak tests of a lookup that could not run them all where
    /// it was decided, as far as this processor's cells allow: the answers
    /// go to the pixel's owner, or the job migrates on.
    pub(super) fn advance_leaks(
        &self,
        mut job: LeakDp,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> Option<LeakDp> {
        let replay = std::mem::take(&mut job.replay);
        match self.try_leaks(&job.req, &job.tests, replay, data, ctx) {
            LeakRun::Done(answers) => {
                let record = super::tree::Record::Leaks(answers);
                let key = job.key;
                ctx.emit_result(Addr::Proc(ctx.origin()), RtResult { key, record });
                None
            }
            LeakRun::Blocked(replay, leaf) => {
                job.replay = replay;
                job.next = Some(leaf);
                Some(job)
            }
        }
    }
}

/// What running leak tests here came to.
pub(super) enum LeakRun {
    /// All answered: whether an opaque surface crosses each segment.
    Done(Vec<bool>),
    /// A test needs a leaf held elsewhere: the answers so far, the leaf.
    Blocked(Replay, crate::accel::NodeId),
}

impl RtWorkload {
    /// Runs the leak `tests` of a lookup for `req` on what this processor
    /// holds (as a shadow bundle runs: restartable, its answers replayed),
    /// with the sequential renderer's test (`Renderer::leak_occluded`).
    pub(super) fn try_leaks(
        &self,
        req: &crate::render::ambient::AmbientRequest,
        tests: &[(Vec3, Vec3, f64)],
        replay: Replay,
        data: &DataView<'_, Self>,
        ctx: &mut Ctx<Self>,
    ) -> LeakRun {
        let run = |caster: &dyn crate::render::RayCaster| -> Vec<bool> {
            tests
                .iter()
                .map(|&(p, dir, len)| self.renderer.leak_occluded(caster, req, p, dir, len))
                .collect()
        };
        let fresh = replay.answers.is_empty() && replay.cursor == Default::default();
        ctx.charge(Work::LeakTests, tests.len() as u64);
        if let Some(caster) = self.whole_caster(ctx.proc_id()).filter(|_| fresh) {
            let answers = run(&caster);
            ctx.charge(Work::TraceLocal, caster.queries.get());
            return LeakRun::Done(answers);
        }
        let octree = self.renderer.octree();
        let visits = std::cell::Cell::new((0u64, 0u64));
        let memo = CellMemo::new(data, self, ctx.proc_id());
        let local = self.local_path(ctx.proc_id(), data);
        let caster = PartialCaster::new(
            octree,
            self.renderer.scene().table(),
            |l| {
                let (a, b) = visits.get();
                visits.set((a + 1, b + octree.leaf_objects(l).len() as u64));
                memo.get(l)
            },
            replay,
            local.as_ref().map(|l| l as &dyn LocalQueries),
        )
        .recording(Recording::On);
        let answers = run(&caster);
        let (leaves, objects) = visits.get();
        ctx.charge(Work::TraceLeaves, leaves);
        ctx.charge(Work::TraceObjects, objects);
        match caster.blocked() {
            Some(leaf) => LeakRun::Blocked(caster.into_replay(), leaf),
            None => LeakRun::Done(answers),
        }
    }
}
