//! Back-pressure: when a processor is over its budget of work in flight
//! (SEMANTICS.md, section 5) and when it waits for its results to leave;
//! its requests for work (a root task only under budget); what it does
//! when it has nothing to run.

use super::Processor;
use crate::clock::Time;
use crate::protocol::message::{Incoming, Msg};
use crate::protocol::workload::Workload;
use crate::protocol::{Addr, Class};
use crate::stats::State;

impl<W: Workload> Processor<W> {
    /// Back-pressure: the send backlog holds more than its budget.
    pub(super) fn over_budget(&self) -> bool {
        self.outbox.backlog_bytes() > self.backlog_budget
    }

    /// Back-pressure on execution: over the backlog budget, the work in
    /// flight here (input buffer and backlog) past three quarters of the
    /// whole budget, and results in the backlog.
    /// Every receiver consumes results whatever its own state, so these
    /// lanes always drain and the hold always ends (no cycle of waiting
    /// processors); tasks in the backlog do not hold execution, as their
    /// receivers may themselves be held.
    pub(super) fn held_for_results(&self) -> bool {
        self.over_budget()
            && self.outbox.in_flight_bytes() > self.hold_at
            && self.outbox.result_backlog_bytes() > 0
    }

    /// Back-pressure, depth first only
    /// ([`Workload::data_parallel_newest_first`]): the send backlog holds
    /// more tasks than the budget. The processor then runs nothing (what it
    /// would run spawns more for receivers that do not keep up) and parks
    /// the tasks it receives: their credit goes back at once, so its
    /// senders' backlogs always drain, whether they hold too or not, and
    /// so does its own (SEMANTICS.md section 5).
    pub(super) fn held_for_tasks(&self) -> bool {
        self.dp_newest_first
            && self.outbox.backlog_bytes() - self.outbox.result_backlog_bytes()
                > self.backlog_budget
    }

    /// While [`Self::held_for_tasks`], gives the credit of every task
    /// received and queued here back (once: it is then no longer
    /// credited).
    pub(super) fn park_received(&mut self, now: Time) {
        for class in [Class::DataParallel, Class::DemandDriven] {
            for inc in self.mailbox.class_mut(class) {
                if inc.credited {
                    inc.credited = false;
                    self.outbox.consumed(inc.from, class.pool(), inc.bytes, now);
                    self.stats.tasks.parked += 1;
                }
            }
        }
    }

    /// Asks the master for work: a root task too unless over budget.
    pub(super) fn request_work(&mut self, now: Time) {
        let roots = !self.over_budget();
        if !roots {
            self.stats.tasks.pooled_only_requests += 1;
        }
        self.requested = Some(roots);
        self.send(Addr::Master, Msg::WorkRequest { roots }, now);
    }

    /// Starts a demand-driven task from the mailbox; after a root, asks
    /// for the next one.
    pub(super) fn start_dd(&mut self, inc: Incoming<W>, now: Time) -> Result<State, String> {
        let root = matches!(&inc.msg, Msg::Dd(env) if env.handout);
        let state = self.handle(inc, now)?;
        if root && self.prefetch_work && self.requested.is_none() {
            // One root in reserve: ask now, work while it comes.
            self.request_work(now);
        }
        Ok(state)
    }

    pub(super) fn on_idle(&mut self, now: Time) {
        // Nothing else to do: waiting for fuller bundles would only add
        // latency, so everything with credit goes now, and all owed credits
        // go back.
        self.outbox.pump(now, true);
        self.outbox.return_credits(true, now);
        if self.room_for_more_waiting() {
            match self.requested {
                None => self.request_work(now),
                // Back under budget with a request for pooled work only
                // parked: ask again, allowing a root (it replaces the other).
                Some(false) if !self.over_budget() => self.request_work(now),
                Some(_) => {}
            }
        }
        if let Some(wave) = self.probe {
            if self.is_passive() {
                self.probe = None;
                // With the requests and replies its data server handled.
                let (sent, received) = self.server.basic();
                let reply = Msg::ProbeReply {
                    wave,
                    sent: self.basic_sent + sent,
                    received: self.basic_received + received,
                };
                self.send(Addr::Master, reply, now);
            }
        }
    }
}
