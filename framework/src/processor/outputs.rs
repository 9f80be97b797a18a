//! What a processor hands its runtime: the packets to transmit, the load
//! they carry, and at the end its accumulator and statistics.

use super::Processor;
use crate::clock::Time;
use crate::protocol::message::Packet;
use crate::protocol::workload::Workload;
use crate::protocol::Class;
use crate::stats::ProcStats;

impl<W: Workload> Processor<W> {
    /// Packets to transmit now (bundles that became due by age included).
    pub(crate) fn take_packets(&mut self, now: Time) -> Vec<Packet<W>> {
        self.outbox.pump(now, false);
        let mut packets = self.outbox.take_ready();
        let load = self.load();
        self.server.note_load(load);
        for p in &mut packets {
            p.load = load;
            self.stats.sent.record(p.class, p.items.len(), p.bytes);
            if p.items.len() > 1 {
                self.stats.bundles_sent += 1;
            }
        }
        packets
    }

    /// Tasks queued here: the load piggybacked on every packet.
    pub(crate) fn load(&self) -> u32 {
        (self.mailbox.len_of(Class::DataParallel)
            + self.mailbox.len_of(Class::DemandDriven)
            + self.ready.len()
            + self.deferred.len()
            + self.store.waiting_len()) as u32
    }

    pub(super) fn note_queues(&mut self) {
        let queued = self.mailbox.len_of(Class::DataParallel)
            + self.mailbox.len_of(Class::DemandDriven)
            + self.ready.len()
            + self.deferred.len();
        self.queued_high_water = self.queued_high_water.max(queued);
    }

    /// Ends the run for this processor: its accumulator and statistics.
    pub(crate) fn finish(mut self) -> (W::Accumulator, ProcStats) {
        self.flush_work();
        let m = &mut self.stats.memory;
        m.resident_bytes = self.store.resident_bytes();
        m.cached_bytes = self.store.cache().high_water();
        (m.waiting_tasks, m.waiting_task_bytes) = self.store.waiting_high_water();
        (m.input_buffer_items, m.input_buffer_bytes) = self.outbox.input_high_water();
        m.mailbox_items = self.mailbox.high_water();
        m.queued_tasks = self.queued_high_water;
        m.send_backlog = self.outbox.backlog_high_water();
        m.send_backlog_bytes = self.outbox.backlog_bytes_high_water();
        m.in_flight_bytes = self.outbox.in_flight_high_water();
        m.root_task_bytes = self.roots_held.1;
        m.selection_bytes = self.largest_selection;
        self.stats.cache = self.store.cache().counters();
        self.server.merge_into(&mut self.stats);
        (self.acc, self.stats)
    }
}
