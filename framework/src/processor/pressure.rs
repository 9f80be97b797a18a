//! Back-pressure: when a processor is over its budget of work in flight
//! (SEMANTICS.md, section 5), when it waits for its results to leave, and
//! its requests for work (a root task only under budget).

use super::Processor;
use crate::clock::Time;
use crate::protocol::message::Msg;
use crate::protocol::workload::Workload;
use crate::protocol::Addr;

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

    /// Asks the master for work: a root task too unless over budget.
    pub(super) fn request_work(&mut self, now: Time) {
        let roots = !self.over_budget();
        if !roots {
            self.stats.tasks.pooled_only_requests += 1;
        }
        self.requested = Some(roots);
        self.send(Addr::Master, Msg::WorkRequest { roots }, now);
    }
}
