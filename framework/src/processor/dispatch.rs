//! Scheduling what a hook emitted: demand-driven children placed by the
//! policy (kept while the processor is over its flow budget), data-parallel
//! tasks sent to the owner of the data they need next, results merged here
//! or sent to their destination.

use super::Processor;
use crate::clock::Time;
use crate::policy::{PlaceCtx, Target};
use crate::protocol::message::{DdEnvelope, DpEnvelope, Msg};
use crate::protocol::workload::{Ctx, WorkKind, Workload};
use crate::protocol::Addr;

impl<W: Workload> Processor<W> {
    /// Schedules everything a hook emitted and records its charged work;
    /// the emptied context becomes the spare.
    pub(super) fn dispatch(
        &mut self,
        mut ctx: Ctx<W>,
        origin: Option<usize>,
        now: Time,
    ) -> Result<(), String> {
        let r = self.dispatch_drain(&mut ctx, origin, now);
        ctx.clear();
        self.spare_ctx = Some(ctx);
        r
    }

    fn dispatch_drain(
        &mut self,
        ctx: &mut Ctx<W>,
        origin: Option<usize>,
        now: Time,
    ) -> Result<(), String> {
        let (mut h1, mut h2) = (0, 0);
        for &(kind, units) in &ctx.charges {
            h1 = add_charge(&mut self.pending_work, h1, kind, units);
            h2 = add_charge(&mut self.last_charges, h2, kind, units);
        }
        if std::mem::take(&mut ctx.complete) {
            let rest = self.store.complete_now();
            self.request_rest(rest, true, now);
        }
        if !ctx.has_emissions() {
            return Ok(());
        }
        for task in ctx.dd.drain(..) {
            self.stats.tasks.children_spawned += 1;
            let env = DdEnvelope {
                task,
                origin,
                handout: false,
                root: false,
            };
            let load = self.load();
            // Over budget, children stay: sending them would grow the
            // backlog (placement never changes results, only where work runs).
            let mut target = self.placer.place(PlaceCtx { origin, load });
            if target != Target::Local && self.over_budget() {
                self.stats.tasks.kept_over_budget += 1;
                target = Target::Local;
            }
            match target {
                Target::Local => self.push_local(Msg::Dd(env)),
                Target::Master => self.send(Addr::Master, Msg::Dd(env), now),
                Target::Proc(p) => self.send(Addr::Proc(p), Msg::Dd(env), now),
            }
        }
        for task in ctx.dp.drain(..) {
            let target = match self.workload.route_dp(&task) {
                Some(id) if !self.store.is_local(&id) => Some(
                    self.store
                        .directory()
                        .owner(&id)
                        .ok_or_else(|| format!("data-parallel task needs unknown data {id:?}"))?,
                ),
                _ => None,
            };
            let msg = Msg::Dp(DpEnvelope { task, origin });
            match target {
                Some(owner) => self.send(Addr::Proc(owner), msg, now),
                None => self.push_local(msg),
            }
        }
        for (dest, result) in ctx.results.drain(..) {
            match dest {
                d if d == self.addr => self.merge_result(result, now)?,
                Addr::Proc(p) if p >= self.procs => {
                    return Err(format!(
                        "result sent to processor {p} but there are only {}",
                        self.procs
                    ))
                }
                d => self.send(d, Msg::Result(result), now),
            }
        }
        Ok(())
    }
}

impl<W: Workload> Processor<W> {
    /// Merges a result sent here ([`Workload::merge_in`]) and schedules
    /// what the merge emitted, with this processor as its origin.
    pub(super) fn merge_result(&mut self, result: W::Result, now: Time) -> Result<(), String> {
        self.stats.tasks.results_merged += 1;
        let origin = Some(self.id);
        let mut ctx = self.new_ctx(origin);
        let data = self.store.view();
        self.workload
            .merge_in(&mut self.acc, result, &data, &mut ctx);
        self.dispatch(ctx, origin, now)
    }
}

/// Adds `units` of `kind` to `acc`. Hooks charge their kinds in much the
/// same order every time, so the search starts after the entry `hint`
/// found last (usually a hit at once); the returned index is the next hint.
#[inline]
fn add_charge<K: WorkKind>(acc: &mut Vec<(K, u64)>, hint: usize, kind: K, units: u64) -> usize {
    let n = acc.len();
    let i = (0..n).map(|d| (hint + d) % n).find(|&j| acc[j].0 == kind);
    match i {
        Some(i) => {
            acc[i].1 = acc[i].1.saturating_add(units);
            i + 1
        }
        None => {
            acc.push((kind, units));
            n + 1
        }
    }
}
