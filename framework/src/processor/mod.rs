//! The worker processor: a plain state machine.
//!
//! A runtime drives it with three calls: [`Processor::deliver`] (a packet
//! arrived), [`Processor::step`] (do one unit of work) and
//! [`Processor::take_packets`] (what to transmit). The processor never blocks,
//! never reads a clock and never touches a channel, so a thread pool, a
//! discrete-event simulator and an MPI rank can all run it unchanged.
//!
//! Each step does exactly one thing, in this order of preference:
//! 1. the highest-priority message among control, data and results (serve a
//!    data request, store a data reply, merge a result);
//! 2. a demand-driven task whose data has just arrived (its cache items are
//!    pinned, so it should release them soon);
//! 3. a data-parallel task (bound to local data, preferred to coherent work);
//! 4. a demand-driven task: data selection, then either run it (all data
//!    local), wait for data, wait for cache space, or fall back to
//!    data-parallel work when its data can never fit the cache;
//! 5. nothing runnable: flush bundles and credits, ask the master for work if
//!    there is room for more, answer a termination probe if passive.
//!
//! Back-pressure: while its send backlog holds more than
//! [`Config::backlog_budget_bytes`], a processor asks the master for pooled
//! children only (no new root task), keeps the demand-driven children it
//! spawns instead of sending them away and sends every lane with credit at
//! once; while, besides, its work in flight (input buffer and backlog)
//! exceeds three quarters of [`Config::flight_bytes`] with results among
//! its backlog, it runs nothing until they leave (results have a reserve
//! of credits tasks cannot use, and every receiver merges them whatever
//! its state, so the wait always ends). Otherwise everything it already
//! holds still runs, so no cycle of waiting processors can form
//! (SEMANTICS.md, 5 and 6).

use std::collections::VecDeque;
use std::sync::Arc;

use tracing::{debug, trace};

use crate::bundle::Outbox;
use crate::clock::Time;
use crate::config::Config;
use crate::error::RunError;
use crate::mailbox::Mailbox;
use crate::policy::Placer;
use crate::protocol::message::{DdEnvelope, DpEnvelope, Incoming, Msg, Packet};
use crate::protocol::workload::{Ctx, Workload};
use crate::protocol::{Addr, Class, DpOutcome, Pool};
use crate::server::DataServer;
use crate::stats::{ProcStats, State};

mod dispatch;
mod outputs;
mod pressure;
use crate::store::{Admission, DataStore, Directory, ReadyTask};

/// What one [`Processor::step`] (or [`crate::master::Master::step`]) did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Did some work, accounted to this state.
    Worked(State),
    /// Nothing to do until a packet arrives.
    Idle,
    /// The run is over for this actor.
    Finished,
}

/// A worker processor. See the module documentation.
pub(crate) struct Processor<W: Workload> {
    id: usize,
    addr: Addr,
    procs: usize,
    workload: Arc<W>,
    mailbox: Mailbox<Incoming<W>>,
    ready: VecDeque<ReadyTask<W>>,
    deferred: VecDeque<(DdEnvelope<W>, Vec<W::DataId>)>,
    store: DataStore<W>,
    /// Answers data requests for `store`'s resident items (here between
    /// steps, or by the runtime on arrival: [`crate::DataService`]).
    server: Arc<DataServer<W>>,
    outbox: Outbox<W>,
    placer: Placer,
    acc: W::Accumulator,
    stats: ProcStats,
    max_waiting: usize,
    prefetch_work: bool,
    /// [`crate::Workload::data_parallel_newest_first`].
    dp_newest_first: bool,
    /// Tasks arriving are parked ([`Processor::held_for_tasks`]).
    parking: bool,
    /// The work request outstanding at the master, if any: whether it
    /// allowed a root task.
    requested: Option<bool>,
    backlog_budget: usize,
    /// Three quarters of [`Config::flight_bytes`]: with more work in flight
    /// here and results waiting to leave, the processor runs nothing (the
    /// last quarter is for what the step in progress emits).
    hold_at: usize,
    probe: Option<u64>,
    terminated: bool,
    basic_sent: u64,
    basic_received: u64,
    last_charges: Vec<(W::Work, u64)>,
    /// Work charged since the last flush into `stats.work` (kept by kind:
    /// no string look-ups on the hot path).
    pending_work: Vec<(W::Work, u64)>,
    /// A drained hook context whose buffers are reused by the next hook (a
    /// tile emits thousands of tasks; fresh vectors grew into fresh pages
    /// every time).
    spare_ctx: Option<Ctx<W>>,
    queued_high_water: usize,
    /// Bytes of root tasks held from hand-out to execution, and their
    /// high-water mark.
    roots_held: (usize, usize),
    /// Bytes of the largest data selection one clipping returned.
    largest_selection: usize,
}

impl<W: Workload> Processor<W> {
    /// Worker `id` of `config.procs`, loading its partition from the workload.
    /// The configuration must already be valid.
    #[cfg(any(test, feature = "mpi"))]
    pub(crate) fn new(id: usize, workload: Arc<W>, config: &Config) -> Result<Self, RunError> {
        let dir = Directory::shared(&workload, config.procs)?;
        Self::with_directory(id, workload, config, dir)
    }

    /// [`Processor::new`] with the run's directory ([`Directory::shared`]).
    pub(crate) fn with_directory(
        id: usize,
        workload: Arc<W>,
        config: &Config,
        dir: Arc<Directory<W>>,
    ) -> Result<Self, RunError> {
        let procs = config.procs;
        let placement_err = |m: String| RunError::Config(crate::ConfigError::Placement(m));
        let resident = workload.load_partition(id, procs);
        let store = DataStore::new(
            id,
            resident,
            dir,
            config.cache_bytes,
            config.fetch_limit,
            config.complete_cache,
        )
        .map_err(placement_err)?;
        let addr = Addr::Proc(id);
        let credits = config.credits_per_link as u32;
        let server = Arc::new(DataServer::new(id, store.resident_items()));
        let mut outbox = Outbox::new(
            addr,
            procs,
            config.bundle.clone(),
            credits,
            config.link_window_bytes(),
        );
        outbox.send_dp_newest_first(workload.data_parallel_newest_first());
        Ok(Processor {
            server,
            id,
            addr,
            procs,
            mailbox: Mailbox::new(),
            ready: VecDeque::new(),
            deferred: VecDeque::new(),
            store,
            outbox,
            placer: Placer::new(config.policy, id, procs),
            acc: W::Accumulator::default(),
            stats: ProcStats::new(addr),
            max_waiting: config.max_waiting_tasks,
            prefetch_work: config.prefetch_work,
            dp_newest_first: workload.data_parallel_newest_first(),
            parking: false,
            requested: None,
            backlog_budget: config.backlog_budget_bytes(),
            hold_at: config.flight_bytes - config.flight_bytes / 4,
            probe: None,
            terminated: false,
            basic_sent: 0,
            basic_received: 0,
            last_charges: Vec::new(),
            pending_work: Vec::new(),
            spare_ctx: None,
            queued_high_water: 0,
            roots_held: (0, 0),
            largest_selection: 0,
            workload,
        })
    }

    /// This processor's address.
    pub(crate) fn addr(&self) -> Addr {
        self.addr
    }

    /// Its data server ([`crate::DataService::OnArrival`]).
    pub(crate) fn server(&self) -> &Arc<DataServer<W>> {
        &self.server
    }

    fn flush_work(&mut self) {
        self.stats.charge(&self.pending_work);
        self.pending_work.clear();
    }

    /// Work charged during the last step (the simulator's cost model input).
    pub(crate) fn last_charges(&self) -> &[(W::Work, u64)] {
        &self.last_charges
    }

    /// Adds `ns` to the time spent in `state` (the runtime measures).
    pub(crate) fn account(&mut self, state: State, ns: Time) {
        self.stats.time_ns.add(state, ns);
    }

    /// The state to account time to while blocked waiting for a packet.
    pub(crate) fn blocked_state(&self) -> State {
        if self.store.waiting_len() > 0 || !self.deferred.is_empty() {
            State::WaitingData
        } else {
            State::Idle
        }
    }

    /// Passive: holds no work at all, so it can only become active again by
    /// receiving a basic message (the termination-detection premise).
    pub(crate) fn is_passive(&self) -> bool {
        self.mailbox.is_empty()
            && self.ready.is_empty()
            && self.deferred.is_empty()
            && self.store.waiting_len() == 0
            && self.outbox.backlog() == 0
    }

    /// A packet arrived.
    pub(crate) fn deliver(&mut self, packet: Packet<W>, now: Time) {
        self.stats
            .received
            .record(packet.class, packet.items.len(), packet.bytes);
        let from = packet.from;
        if let Addr::Proc(q) = from {
            self.placer.observe(q, packet.load);
        }
        for msg in packet.items {
            if msg.is_basic() {
                self.basic_received += 1;
            }
            match msg {
                Msg::Credit(returned) => self.outbox.grant(from, returned, now),
                Msg::Probe(wave) => self.probe = Some(wave),
                Msg::Terminate => {
                    debug!(proc = self.id, passive = self.is_passive(), "terminate");
                    self.terminated = true;
                }
                msg => {
                    let class = msg.class();
                    let bytes = msg.byte_size();
                    let mut credited = self.outbox.arrived(from, class, bytes);
                    if credited && self.parking && class.pool() == Pool::Tasks {
                        // Parked: its credit goes back now.
                        self.outbox.consumed(from, Pool::Tasks, bytes, now);
                        self.stats.tasks.parked += 1;
                        credited = false;
                    }
                    if let Msg::Dd(env) = &msg {
                        if env.root {
                            self.roots_held.0 += bytes;
                            self.roots_held.1 = self.roots_held.1.max(self.roots_held.0);
                        }
                        if env.handout {
                            self.requested = None;
                            if env.origin.is_none() {
                                self.stats.tasks.roots += 1;
                            }
                        }
                    }
                    self.mailbox.push(
                        class,
                        Incoming {
                            from,
                            msg,
                            bytes,
                            credited,
                        },
                    );
                }
            }
        }
        self.note_queues();
    }

    /// Does one unit of work (see the module documentation).
    pub(crate) fn step(&mut self, now: Time) -> Result<Step, RunError> {
        if self.terminated {
            return Ok(Step::Finished);
        }
        self.last_charges.clear();
        let result = self.step_inner(now);
        if self.over_budget() {
            // Over budget, nothing waits for a fuller bundle: what has
            // credit goes now, so the backlog holds only what lacks it.
            self.outbox.pump(now, true);
        }
        self.note_queues();
        result.map_err(|message| RunError::Workload {
            at: self.addr,
            message,
        })
    }

    fn step_inner(&mut self, now: Time) -> Result<Step, String> {
        if let Some(Class::Control | Class::Data | Class::Result) = self.mailbox.peek_class() {
            let (_, inc) = self.mailbox.pop().expect("peeked");
            return self.handle(inc, now).map(Step::Worked);
        }
        if self.held_for_results() {
            // Running more work would only add results to a backlog that
            // cannot leave yet: wait for the receivers' credits.
            self.stats.tasks.held_for_results += 1;
            self.on_idle(now);
            return Ok(Step::Idle);
        }
        if self.held_for_tasks() {
            self.stats.tasks.held_for_tasks += 1;
            if !self.parking {
                // From now on tasks are parked as they arrive.
                self.park_received(now);
                self.parking = true;
            }
            self.on_idle(now);
            return Ok(Step::Idle);
        }
        self.parking = false;
        if let Some(task) = self.ready.pop_front() {
            self.execute_dd(task, now)?;
            return Ok(Step::Worked(State::Executing));
        }
        // Depth first (`Workload::data_parallel_newest_first`): the newest
        // child demand-driven task runs before any data-parallel one, so
        // that the children of the tasks now running do not wait behind a
        // stream of incoming tasks (their trees open meanwhile). Root
        // tasks still wait for the data-parallel work (below).
        if self.dp_newest_first && self.room_for_more_waiting() {
            let child = |inc: &Incoming<W>| !matches!(&inc.msg, Msg::Dd(env) if env.handout);
            if let Some(inc) = self
                .mailbox
                .pop_class_newest_where(Class::DemandDriven, child)
            {
                return self.start_dd(inc, now).map(Step::Worked);
            }
        }
        if let Some(inc) = self.mailbox.pop_data_parallel(self.dp_newest_first) {
            return self.handle(inc, now).map(Step::Worked);
        }
        // New demand-driven work only while there is room to wait for its
        // data: this keeps the waiting table bounded and leaves further tasks
        // in the (credit-bounded) input buffer.
        if self.room_for_more_waiting() {
            if let Some(inc) = self.mailbox.pop_class(Class::DemandDriven) {
                return self.start_dd(inc, now).map(Step::Worked);
            }
        }
        self.on_idle(now);
        Ok(Step::Idle)
    }

    /// A root task leaves the processor's hold (it runs, or turns
    /// data-parallel).
    fn root_done(&mut self, env: &DdEnvelope<W>) {
        if env.root {
            let bytes = Msg::<W>::dd_bytes(&env.task);
            self.roots_held.0 = self.roots_held.0.saturating_sub(bytes);
        }
    }

    fn room_for_more_waiting(&self) -> bool {
        self.deferred.is_empty() && self.store.waiting_len() < self.max_waiting
    }

    fn handle(&mut self, inc: Incoming<W>, now: Time) -> Result<State, String> {
        if inc.credited {
            let pool = inc.msg.class().pool();
            self.outbox.consumed(inc.from, pool, inc.bytes, now);
        }
        match inc.msg {
            Msg::DataRequest(ids) => {
                let items = self.server.copies(&ids)?;
                self.stats.data_requests_served += 1;
                self.stats.data_items_served += items.len() as u64;
                trace!(proc = self.id, to = %inc.from, n = items.len(), "serve data");
                self.send(inc.from, Msg::DataReply(items), now);
                Ok(State::ServingData)
            }
            Msg::DataReply(items) => {
                let woken = self.store.on_reply(items)?;
                self.ready.extend(woken);
                Ok(State::Receiving)
            }
            Msg::Result(r) => {
                self.merge_result(r, now)?;
                Ok(State::Receiving)
            }
            Msg::Dp(env) => {
                self.execute_dp(env, now)?;
                Ok(State::Executing)
            }
            Msg::Dd(env) => {
                self.select(env, now)?;
                Ok(State::Selecting)
            }
            Msg::Broadcast { epoch, items } => {
                trace!(proc = self.id, epoch, n = items.len(), "hold broadcast");
                self.store.hold_broadcast(items)?;
                self.send(Addr::Master, Msg::BroadcastHeld(epoch), now);
                Ok(State::Receiving)
            }
            other => Err(format!("unexpected message {other:?} from {}", inc.from)),
        }
    }

    fn send(&mut self, to: Addr, msg: Msg<W>, now: Time) {
        // Basic messages are counted when handed to the outbox: a message in
        // the backlog is "sent" for termination detection, which can only
        // make detection more conservative.
        if msg.is_basic() {
            self.basic_sent += 1;
        }
        self.outbox.push(to, msg, now);
    }

    fn push_local(&mut self, msg: Msg<W>) {
        let class = msg.class();
        let bytes = msg.byte_size();
        self.mailbox.push(
            class,
            Incoming {
                from: self.addr,
                msg,
                bytes,
                credited: false,
            },
        );
    }

    fn select(&mut self, mut env: DdEnvelope<W>, now: Time) -> Result<(), String> {
        // The processor that runs a root task is the origin of its family.
        let origin = *env.origin.get_or_insert(self.id);
        let mut ctx = self.new_ctx(Some(origin));
        let ids = {
            let local = self.store.view();
            self.workload.select_data_in(&env.task, &local, &mut ctx)
        };
        self.stats.tasks.selections += 1;
        self.largest_selection = self
            .largest_selection
            .max(ids.len() * std::mem::size_of::<W::DataId>());
        self.dispatch(ctx, Some(origin), now)?;
        self.admit(env, ids, now)
    }

    fn admit(&mut self, env: DdEnvelope<W>, ids: Vec<W::DataId>, now: Time) -> Result<(), String> {
        let admission = self.store.admit(env, ids)?;
        if let Admission::Deferred(..) = admission {
            self.stats.tasks.deferred += 1;
        }
        self.apply_admission(admission, now)
    }

    fn execute_dd(&mut self, task: ReadyTask<W>, now: Time) -> Result<(), String> {
        let ReadyTask { env, pinned } = task;
        self.root_done(&env);
        let origin = env.origin;
        let mut ctx = self.new_ctx(origin);
        {
            let view = self.store.view();
            self.workload.execute_dd(env.task, &view, &mut ctx);
            // Recency of the pinned items is refreshed by the release below.
        }
        self.store.release(&pinned);
        self.stats.tasks.demand_driven += 1;
        self.dispatch(ctx, origin, now)?;
        // Releasing pins may have made room for deferred tasks.
        while let Some((env, ids)) = self.deferred.pop_front() {
            match self.store.admit(env, ids)? {
                Admission::Deferred(env, ids) => {
                    self.deferred.push_front((env, ids));
                    break;
                }
                other => self.apply_admission(other, now)?,
            }
        }
        Ok(())
    }

    fn apply_admission(&mut self, adm: Admission<W>, now: Time) -> Result<(), String> {
        match adm {
            Admission::Ready(task) => self.ready.push_back(task),
            Admission::Waiting(requests) => {
                // One request per owner, sent once selection is complete.
                for (owner, ids) in requests {
                    self.request_data(owner, ids, now);
                }
                let rest = self.store.complete();
                self.request_rest(rest, false, now);
            }
            Admission::Deferred(env, ids) => self.deferred.push_back((env, ids)),
            Admission::TooBig(env) => {
                self.root_done(&env);
                self.stats.tasks.fallbacks += 1;
                debug!(proc = self.id, task = ?env.task, "data exceeds the cache budget or the fetch limit: data-parallel fallback");
                let mut ctx = self.new_ctx(env.origin);
                self.workload.to_data_parallel(env.task, &mut ctx);
                self.dispatch(ctx, env.origin, now)?;
            }
        }
        Ok(())
    }

    /// Sends the requests completing the cache, if there are any
    /// (`asked`: the workload asked for it, [`crate::Ctx::complete_cache`]).
    pub(super) fn request_rest(
        &mut self,
        rest: Option<Vec<(usize, Vec<W::DataId>)>>,
        asked: bool,
        now: Time,
    ) {
        let Some(rest) = rest else {
            return;
        };
        debug!(
            proc = self.id,
            owners = rest.len(),
            asked,
            "completing the cache"
        );
        self.stats.cache_completed = true;
        for (owner, ids) in rest {
            self.request_data(owner, ids, now);
        }
    }

    fn request_data(&mut self, owner: usize, ids: Vec<W::DataId>, now: Time) {
        self.stats.data_requests_sent += 1;
        self.stats.data_items_requested += ids.len() as u64;
        trace!(proc = self.id, owner, n = ids.len(), "request data");
        self.send(Addr::Proc(owner), Msg::DataRequest(ids), now);
    }

    fn execute_dp(&mut self, env: DpEnvelope<W>, now: Time) -> Result<(), String> {
        let origin = env.origin;
        let mut ctx = self.new_ctx(origin);
        let (outcome, touched) = {
            let view = self.store.view();
            let outcome = self.workload.execute_dp(env.task, &view, &mut ctx);
            (outcome, view.into_touched())
        };
        self.store.touch(&touched);
        self.stats.tasks.data_parallel_steps += 1;
        match outcome {
            DpOutcome::Finished => self.stats.tasks.data_parallel_finished += 1,
            DpOutcome::Migrate(task) => {
                let id = self.workload.route_dp(&task).ok_or_else(|| {
                    format!(
                        "data-parallel task {task:?} asked to migrate but route_dp needs no data"
                    )
                })?;
                if self.store.is_local(&id) {
                    return Err(format!(
                        "data-parallel task {task:?} asked to migrate towards {id:?}, which is local"
                    ));
                }
                let owner = self
                    .store
                    .directory()
                    .owner(&id)
                    .ok_or_else(|| format!("data-parallel task needs unknown data {id:?}"))?;
                self.store.record_miss();
                self.stats.tasks.migrations += 1;
                self.send(Addr::Proc(owner), Msg::Dp(DpEnvelope { task, origin }), now);
            }
        }
        self.dispatch(ctx, origin, now)
    }

    /// A context for the next hook of a task descending from `origin`'s
    /// root (this processor's when unknown): the spare one's buffers, or
    /// new ones.
    fn new_ctx(&mut self, origin: Option<usize>) -> Ctx<W> {
        let mut ctx = self
            .spare_ctx
            .take()
            .unwrap_or_else(|| Ctx::new(self.id, self.procs));
        ctx.origin = origin.unwrap_or(self.id);
        ctx
    }
}
