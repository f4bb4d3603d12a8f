//! The embedded connection manager of one participant: it carries out what the connection table decides.
//!
//! What is delivered when is decided by [`radar_semantics::connection::ConnectionTable`]; this module moves the
//! messages. For every source the table needs it keeps one relay (a pooled raw reader and the task that feeds
//! each signal to the table), and for every slot one outlet; connections on the same topic, type and QoS
//! depth share them. Messages are forwarded as serialized bodies ([`RawMessage`]), so the manager needs no
//! Rust type for them. A slot of type `std_msgs/msg/Empty` (interrupt, exit, or an Empty start) accepts a
//! source of any type: the signal counts, its payload is dropped. Any other slot needs the source's type.
//!
//! Every delivery keeps the time its source signal was emitted, and a start carries its statement's cause
//! (rules R11-R13, C6; [`crate::wire::cause`]), whichever way it goes.
//!
//! **How a slot is reached.** An outlet hands a signal to the response of this process that reads the slot
//! (see [`crate::wire::local`]: no DDS hop), and otherwise writes it on the slot's topic with a pooled DDS writer.
//! The way is chosen at each delivery, so it follows the response: when the response of this process stops
//! and one of the same name runs in another process, the outlet makes its DDS writer and delivers there; when
//! one of this process comes back, it is handed the signals again.
//!
//! A statement ([`crate::ConnectionRequest`]) is armed when its relay readers have matched the sources'
//! writers and its slots are reached (a response of this process reads them, or the outlet's writer has
//! matched the slots' readers); only signals emitted after that are delivered (by source timestamp against
//! this host's clock: hosts of one ROS graph are assumed to be in time sync).
//!
//! Each relay and outlet also watches its peers: when the last publisher of a source, or the last reader of
//! a slot, has been gone for [`GONE_AFTER`], the table is told (rule C5) and the connections it changes record
//! the [`Departure`]; when one comes back, the table is told again.
//!
//! Files: this one holds the manager's state and what it does with each signal (dispatch, departures);
//! `arm.rs` arms a statement, `relay.rs` holds relays, outlets and their peer watch, `list.rs` lists the
//! connections, `guard.rs` is the user's handle, `anon.rs` the queue behind an anonymous slot.

mod anon;
mod arm;
mod faults;
mod guard;
mod instances;
mod list;
mod outlet;
mod presence;
mod relay;

use std::{
    collections::HashMap,
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_semantics::{
    connection::{ConnId, ConnectionTable, Kind, Link, Via},
    response::Sent,
};

use crate::{
    departure::Departure,
    node::participant::Participant,
    node::pool::Key,
    wire::raw::RawMessage,
    wire::refs::{Signal, Slot},
};
use anon::AnonQueue;
use faults::Faults;
pub use guard::ConnectionGuard;
use outlet::Outlet;
use presence::Change;
use relay::Relay;

/// An anonymous slot: called with each delivered payload, in its own task.
pub(crate) type AnonFn = Box<dyn FnMut(RawMessage) + Send>;
/// A connection's filter: whether to deliver a payload.
pub(crate) type FilterFn = Arc<dyn Fn(&RawMessage) -> bool + Send + Sync>;
/// A connection's transform: what to deliver instead of a payload (`None`: nothing, and no delivery: C2).
pub(crate) type MapFn = Arc<dyn Fn(&RawMessage) -> Option<RawMessage> + Send + Sync>;

/// Where a connection delivers.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Target {
    Slot(Key),
    Anon(u64),
}

/// One end of connections whose peers come and go.
enum End {
    Source(Key),
    Target(Target),
}

/// A statement's target, as given.
pub(crate) enum TargetSpec {
    Slot(Slot),
    Anon(AnonFn),
}

/// The `until` part of a statement: U's signals interrupt R within runs this statement started.
pub(crate) struct UntilSpec {
    pub(crate) source: Signal,
    pub(crate) started: Signal,
    pub(crate) exited: Signal,
    /// R's `dropped` (a RADAR response's; an rclpy response has none).
    pub(crate) dropped: Signal,
    pub(crate) interrupt: Slot,
    /// R's `state` topic: a response that publishes a `radar_msgs/msg/ResponseState` there keeps causes (C6).
    pub(crate) state: String,
}

/// A statement ready to arm.
pub(crate) struct Spec {
    pub(crate) owner: String,
    pub(crate) filter: Option<FilterFn>,
    pub(crate) map: Option<MapFn>,
    /// The payload type after `map`, if any.
    pub(crate) mapped_type: Option<String>,
    pub(crate) kind: Kind,
    pub(crate) source: Signal,
    pub(crate) target: TargetSpec,
    /// The target is a response's `start` slot: each delivery carries the statement's cause (R13).
    pub(crate) starts: bool,
    pub(crate) until: Option<UntilSpec>,
    pub(crate) timeout: Duration,
    /// History depth of the relay's endpoints.
    pub(crate) depth: usize,
    /// Re-arm when the target comes back after leaving.
    pub(crate) rearm: bool,
}

/// How long a source or slot must have no peer before it counts as gone. A sender that emits and exits at
/// once announces its leaving on another socket than its data, and the announcement can be read first: the
/// relay reads what is already there before it believes the source is gone.
pub(crate) const GONE_AFTER: Duration = Duration::from_millis(100);

/// What a live connection carries besides what the table knows.
struct Record {
    owner: String,
    /// Panics of its filter, map or anonymous slot, caught (shared with the anonymous slot's task).
    faults: Arc<Faults>,
    filter: Option<FilterFn>,
    map: Option<MapFn>,
    /// Its deliveries carry the statement's cause (a start target).
    starts: bool,
    /// Whether a payload is a whole message of its start target's type, when that is known and no transform
    /// makes the payload (C2: a payload its target cannot read is no delivery).
    reads: Option<crate::wire::readers::Reads>,
    /// The target's topic and type, for the report of a payload it cannot read.
    target: (String, String),
    /// The component whose leaving put the connection out of `Armed`, while it is out.
    departure: Option<Departure>,
    /// Why it delivers nothing for now though armed (its owner is silent), while it does not.
    suspended: Option<String>,
}

#[derive(Default)]
struct State {
    table: ConnectionTable<Key, Target>,
    records: HashMap<ConnId, Record>,
    /// One per source the table reads, each holding the pooled reader once.
    relays: HashMap<Key, Relay>,
    /// One per slot the table writes, each holding its pooled writer (if it has one) once.
    outlets: HashMap<Key, Outlet>,
    anon: HashMap<u64, Arc<AnonQueue>>,
    next_anon: u64,
    /// Per component the manager's relays and outlets reach, the process its connections were made with
    /// (`instances.rs`): a response's signals from another live process of that name carry no cause to the
    /// table (they close no `until` window of this program's statements, C5).
    following: HashMap<String, crate::node::transport::EndpointId>,
    /// Per process that sends to the relays, how far its clock runs ahead of this host's (T1).
    leads: HashMap<crate::node::transport::EndpointId, radar_semantics::time::Lead>,
    /// Connections that are over because a component of theirs left (a spent `once ... until` whose response
    /// went, C3), with who left, until their guard is dropped: `departed()` still says who.
    over_by: HashMap<ConnId, Departure>,
}

/// The embedded connection manager of one [`Radar`](crate::Radar).
pub(crate) struct Manager {
    participant: Arc<Participant>,
    /// Deliver to this process's responses directly (one DDS hop), not through a DDS writer (two).
    local: bool,
    state: Mutex<State>,
    /// Bumped whenever the table itself may have changed (connections made, ended, waiting, back), not when only
    /// its counts did (see `counted`).
    changed: tokio::sync::watch::Sender<u64>,
    /// Bumped when a signal changed the counts a listing shows (delivered, panics) since a listing last read
    /// them: once per listing read, not once per signal, so a signal wakes no task that only lists.
    counted: tokio::sync::watch::Sender<u64>,
    /// Whether a signal was dispatched since a listing last read the counts ([`Manager::listing`]).
    unlisted: std::sync::atomic::AtomicBool,
    /// Whether the task that tells component instances apart runs (`instances.rs`).
    instances_watched: std::sync::atomic::AtomicBool,
}

use crate::wire::local::now_ns;

impl State {
    /// `sent` as the table takes it from the writer `from`: a response's signals (`started`, `exited`, ...)
    /// speak of the runs of the process the connections follow only; another live process of that name gives
    /// them without their cause.
    fn as_followed(
        &self,
        source: &Key,
        sent: Sent,
        from: crate::node::transport::EndpointId,
    ) -> Sent {
        let Some((component, e)) = crate::endpoint::Endpoint::of_topic(&source.topic) else {
            return sent;
        };
        let followed = match self.following.get(component) {
            Some(p) => p.prefix == from.prefix,
            None => true,
        };
        if !followed && e.is_signal() && e != crate::endpoint::Endpoint::Triggered {
            Sent { by: None, ..sent }
        } else {
            sent
        }
    }
}

impl Manager {
    /// A manager on `participant`; `local`: it hands signals to this process's responses directly.
    pub(crate) fn new(participant: Arc<Participant>, local: bool) -> Manager {
        let base = crate::wire::cause::statement_base(participant.guid());
        Manager {
            participant,
            local,
            state: Mutex::new(State {
                table: ConnectionTable::with_statement_base(base),
                ..State::default()
            }),
            changed: tokio::sync::watch::channel(0).0,
            counted: tokio::sync::watch::channel(0).0,
            unlisted: Default::default(),
            instances_watched: Default::default(),
        }
    }

    /// The table and what goes with it. A panic while it is held (none is expected: user closures are caught,
    /// see `faults.rs`) does not make every later statement fail: the state is used as it is.
    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The participant's match graph (and its count of messages that did not decode).
    pub(crate) fn graph(&self) -> &crate::graph::Graph {
        self.participant.graph()
    }

    /// Connection `id` delivers nothing while `why` is given (its owner is silent), and again once it is not.
    pub(crate) fn suspend(&self, id: ConnId, why: Option<String>) {
        if let Some(r) = self.state().records.get_mut(&id) {
            r.suspended = why;
        }
        self.changed.send_modify(|g| *g += 1);
    }

    /// Panics caught in connection `id`'s own code (0 once it is gone).
    pub(crate) fn panics(&self, id: ConnId) -> u64 {
        self.state()
            .records
            .get(&id)
            .map_or(0, |r| r.faults.count())
    }

    /// Resolves at the next change of the table itself; a change of its counts alone does not tell it (see
    /// [`Manager::count_changes`]).
    pub(crate) fn changes(&self) -> tokio::sync::watch::Receiver<u64> {
        self.changed.subscribe()
    }

    /// Resolves when signals changed the counts of the table since a listing last read them
    /// ([`Manager::listing`]): what a task that publishes the list waits for besides [`Manager::changes`].
    pub(crate) fn count_changes(&self) -> tokio::sync::watch::Receiver<u64> {
        self.counted.subscribe()
    }

    /// The list with its counts as they are now, for a task that publishes it: the next signal dispatched
    /// tells [`Manager::count_changes`] again.
    pub(crate) fn listing(&self) -> Vec<crate::wire::msg::Connection> {
        self.unlisted
            .store(false, std::sync::atomic::Ordering::SeqCst);
        self.list()
    }

    /// One signal read on `source`, sent as `sent`: deliver it. Publishing happens under the lock, so a
    /// connection removed before this takes the lock gets nothing, and one removed after got this signal
    /// already.
    /// `stamp`: the sample's source time as its writer stamped it (0: none), for a signal that came over the
    /// wire from another process: dated by that process's lead (T1).
    fn dispatch(
        &self,
        source: &Key,
        raw: RawMessage,
        mut sent: Sent,
        from: crate::node::transport::EndpointId,
        stamp: i64,
    ) {
        let mut guard = self.state();
        if stamp > 0 && from.prefix != self.participant.guid().prefix {
            let process = crate::node::transport::EndpointId::new(
                from.prefix,
                crate::node::transport::EndpointId::new_participant_guid().entity_id,
            );
            sent.at = guard
                .leads
                .entry(process)
                .or_default()
                .date(stamp, now_ns());
        }
        let sent = guard.as_followed(source, sent, from);
        let changed_table = self.dispatch_held(&mut guard, source, raw, sent);
        drop(guard);
        self.signal_told(changed_table);
    }

    /// [`Manager::dispatch`] with the table held; whether the table itself changed.
    fn dispatch_held(&self, st: &mut State, source: &Key, raw: RawMessage, sent: Sent) -> bool {
        let records = &st.records;
        // C2: a signal a filter refuses, or a transform turns into nothing, is not a delivery
        let mut mapped: Vec<(ConnId, RawMessage)> = Vec::new();
        // a program told to stop starts nothing more (its exit slots may take seconds; a start it relayed then
        // would set a robot moving as the program that drives it goes): interrupts and calls still go
        let stopping = self.participant.components().stopping();
        // T2: this host's clock may have stepped back
        let out = st.table.signal(source, sent, now_ns(), |id| {
            let Some(r) = records.get(&id) else {
                return true;
            };
            if (stopping && r.starts) || r.suspended.is_some() {
                return false;
            }
            // C2: a payload the target cannot read (a peer of another definition, a truncated sample) is no
            // delivery: it does not use up a `once`; it is counted and reported as malformed
            if let Some(reads) = r.reads {
                if !reads(raw.as_bytes()) {
                    self.graph().malformed().note(
                        &source.topic,
                        &r.target.1,
                        None,
                        &format!(
                            "{} bytes that are not a whole {}, not delivered to {}",
                            raw.len(),
                            r.target.1,
                            r.target.0
                        ),
                    );
                    return false;
                }
            }
            // a filter or map that panics refuses the signal (caught and reported on the connection)
            if let Some(f) = &r.filter {
                if r.faults.run("filter", || f(&raw)) != Some(true) {
                    return false;
                }
            }
            match &r.map {
                Some(map) => match r.faults.run("map", || map(&raw)).flatten() {
                    Some(p) => {
                        mapped.push((id, p));
                        true
                    }
                    None => false, // the transform warned, or panicked
                },
                None => true,
            }
        });
        for d in out.sends {
            let payload = match d.via {
                Via::Signal { .. } => match mapped.iter().position(|(id, _)| *id == d.id) {
                    Some(i) => mapped.swap_remove(i).1,
                    None => raw.clone(),
                },
                // an until's interrupt: the slot takes std_msgs/msg/Empty
                Via::Until { .. } => RawMessage::from_bytes(vec![0]),
            };
            match &d.target {
                Target::Slot(k) => {
                    if let Some(o) = st.outlets.get(k) {
                        o.deliver(payload, d.sent);
                    }
                }
                Target::Anon(k) => {
                    if let Some(q) = st.anon.get(k) {
                        q.push(payload);
                    }
                }
            }
        }
        // a `once` that fired, or whose until is over, is gone: forget what it carried
        for id in &out.ended {
            st.records.remove(id);
        }
        let ended = out.ended;
        let released = self.release(st, out.released);
        !ended.is_empty() || released
    }

    /// After a signal: tells everyone who waits for the table if it changed (`changed_table`: a connection
    /// ended, something was released); and, since the counts changed, the listings if this is the first signal
    /// since one read them (later ones tell nobody: the listing reads the counts when it publishes).
    fn signal_told(&self, changed_table: bool) {
        if changed_table {
            self.changed.send_modify(|g| *g += 1);
        }
        if !self
            .unlisted
            .swap(true, std::sync::atomic::Ordering::SeqCst)
        {
            self.counted.send_modify(|g| *g += 1);
        }
    }

    /// Lets go of the relays, outlets and anonymous queues the table no longer needs: an event whose only
    /// listener was a fired `once` deactivates. Looks only at what the table released, so its cost does not
    /// grow with the number of connections. Whether the table released anything.
    fn prune(&self, st: &mut State) -> bool {
        let released = st.table.take_released();
        self.release(st, released)
    }

    /// Lets go of the relays, outlets and anonymous queues of `released` (the table's own words for them).
    fn release(&self, st: &mut State, (sources, targets): (Vec<Key>, Vec<Target>)) -> bool {
        let released = !sources.is_empty() || !targets.is_empty();
        for s in sources {
            if st.relays.remove(&s).is_some() {
                self.participant.release(&s);
            }
        }
        for t in targets {
            match t {
                Target::Slot(k) => {
                    if let Some(o) = st.outlets.remove(&k) {
                        if o.dds.is_some() {
                            self.participant.release(&k);
                        }
                        if o.inlet.is_some() {
                            drop(o);
                            self.participant.inlets().release(&k.topic);
                        }
                    }
                }
                // closing the queue lets a delivery already queued (a `once` that just fired) still run; the queue
                // stays reachable until the statement's scope ends, which cancels a call not begun (C4)
                Target::Anon(k) => {
                    if let Some(q) = st.anon.get(&k) {
                        q.close();
                    }
                }
            }
        }
        released
    }

    fn peers_changed(&self, end: &End, change: Change, departure: impl FnOnce() -> Departure) {
        match change {
            Change::Gone => self.peers_gone(end, departure()),
            Change::Back => self.peers_back(end),
        }
    }

    /// Every peer of a source (its publishers) or of a target (its subscribers) has gone: tell the table, and
    /// record who left on the connections it changed.
    fn peers_gone(&self, end: &End, d: Departure) {
        let mut st = self.state();
        let ids = match end {
            End::Source(k) => st.table.source_lost(k),
            End::Target(t) => st.table.target_lost(t),
        };
        self.note_departure(&mut st, &ids, &d);
        // a spent `once ... until` whose response left is over (C3, C5): its guard's `closed()` resolves
        for id in st.table.take_ended() {
            st.records.remove(&id);
            st.over_by.insert(id, d.clone());
            tracing::info!(connection = id, %d, "connection {id} is over: its response left with the run it started");
        }
        self.prune(&mut st);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }

    /// A peer of a source or target that had gone is back.
    fn peers_back(&self, end: &End) {
        let mut st = self.state();
        let (ids, topic) = match end {
            End::Source(k) => (st.table.source_back(k), k.topic.clone()),
            End::Target(t) => (
                st.table.target_back(t, now_ns()),
                match t {
                    Target::Slot(k) => k.topic.clone(),
                    Target::Anon(_) => String::new(),
                },
            ),
        };
        self.note_return(&mut st, &ids, &topic);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }

    fn note_departure(&self, st: &mut State, ids: &[ConnId], d: &Departure) {
        for id in ids {
            let link = st.table.link(*id).unwrap_or_default();
            if let Some(r) = st.records.get_mut(id) {
                r.departure = Some(d.clone());
            }
            match link {
                Link::TargetLost => tracing::warn!(
                    connection = id, %d,
                    "connection {id} delivers nothing more: its target left; make the statement again once it \
                     is back, or ask for .rearm()"
                ),
                Link::Armed => tracing::info!(
                    connection = id, %d, "connection {id}: the until window closed: its response left"
                ),
                other => tracing::info!(connection = id, %d, "connection {id}: {}", other.label()),
            }
        }
    }

    fn note_return(&self, st: &mut State, ids: &[ConnId], topic: &str) {
        for id in ids {
            if let Some(r) = st.records.get_mut(id) {
                r.departure = None;
            }
            tracing::info!(connection = id, %topic, "connection {id} is armed again: {topic} is back");
        }
    }

    /// The guard dropped: remove the connection, and cancel anonymous-slot calls it has not begun.
    fn remove(&self, id: ConnId) {
        let mut st = self.state();
        // the anonymous slot of a live connection, or of a `once` that fired and whose call may still wait in
        // its queue: no further call begins (C4)
        if let Some(Target::Anon(k)) = st.table.forget(id) {
            if let Some(q) = st.anon.remove(&k) {
                q.cancel();
            }
        }
        st.records.remove(&id);
        st.over_by.remove(&id);
        self.prune(&mut st);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }

    fn contains(&self, id: ConnId) -> bool {
        self.state().table.contains(id)
    }

    /// The connection's link and the departure that put it out of `Armed`, if it is live.
    /// Who left, if connection `id` is over because a component of it left.
    fn over_by(&self, id: ConnId) -> Option<Departure> {
        self.state().over_by.get(&id).cloned()
    }

    fn link(&self, id: ConnId) -> Option<(Link, Option<Departure>)> {
        let st = self.state();
        let link = st.table.link(id)?;
        let d = st.records.get(&id).and_then(|r| r.departure.clone());
        Some((link, d))
    }

    fn delivered(&self, id: ConnId) -> u64 {
        let st = self.state();
        st.table
            .list()
            .into_iter()
            .find(|c| c.id == id)
            .map(|c| c.delivered)
            .unwrap_or(0)
    }
}
