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
//! (rules R11-R13, C6; [`crate::cause`]), whichever way it goes.
//!
//! **How a slot is reached.** An outlet hands a signal to the response of this process that reads the slot
//! (see [`crate::local`]: no DDS hop), and otherwise writes it on the slot's topic with a pooled DDS writer.
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

mod anon;

use std::{
    collections::HashMap,
    sync::{Arc, Mutex},
    time::Duration,
};

use futures::StreamExt;
use radar_semantics::{
    connection::{ConnId, ConnectionTable, Kind, Link, Until, Via},
    response::Sent,
};

use crate::{
    departure::Departure,
    error::{Error, Result},
    local::Inlet,
    msg::{Empty, ResponseState, RosMessage, TypeName},
    participant::Participant,
    pool::{Dir, Key},
    raw::RawMessage,
    refs::{Signal, Slot},
    topics::{RawPublisher, RawSubscription},
};
use anon::AnonQueue;

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
    filter: Option<FilterFn>,
    map: Option<MapFn>,
    /// Its deliveries carry the statement's cause (a start target).
    starts: bool,
    /// The component whose leaving put the connection out of `Armed`, while it is out.
    departure: Option<Departure>,
}

/// A source the table reads: the task that feeds its reader's signals to the table (stopped on drop), and
/// its listening to this process's emitters of the source (ends on drop).
struct Relay {
    _stop: tokio::sync::oneshot::Sender<()>,
    _tap: Option<Arc<()>>,
}

/// A slot the table writes: to the response of this process that reads it, or on its topic.
struct Outlet {
    key: Key,
    /// The slot in this process (with local delivery): a response of this process reads it, or may.
    inlet: Option<Arc<Inlet>>,
    /// A DDS writer on the slot's topic (held in the participant's pool), once one is needed: when no response
    /// of this process reads the slot.
    dds: Option<Arc<RawPublisher>>,
    /// The slot takes `std_msgs/msg/Empty`: the payload is dropped.
    empty: bool,
    /// Tells the watcher of the slot's readers about a DDS writer made later (its match count).
    more: tokio::sync::mpsc::UnboundedSender<tokio::sync::watch::Receiver<usize>>,
    /// Stops the task that watches the slot's readers.
    _stop: tokio::sync::oneshot::Sender<()>,
}

impl Outlet {
    /// Whether a response of this process reads the slot now.
    fn local(&self) -> bool {
        self.inlet
            .as_ref()
            .is_some_and(|i| i.reads(&self.key.ros_type))
    }

    fn deliver(&self, m: RawMessage, sent: Sent) {
        let m = if self.empty { RawMessage(vec![0]) } else { m };
        if let Some(inlet) = &self.inlet {
            if inlet.reads(&self.key.ros_type) {
                inlet.deliver(&self.key.ros_type, m, sent);
                return;
            }
        }
        // (no writer: the response of this process has just left and none is made yet; as over DDS with no
        // reader, nothing is delivered)
        if let Some(p) = &self.dds {
            if let Err(e) = p.publish_sent(m, sent) {
                tracing::warn!(slot = %self.key.topic, error = %e, "could not deliver a signal");
            }
        }
    }
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
}

/// The embedded connection manager of one [`Radar`](crate::Radar).
pub(crate) struct Manager {
    participant: Arc<Participant>,
    /// Deliver to this process's responses directly (one DDS hop), not through a DDS writer (two).
    local: bool,
    state: Mutex<State>,
    /// Bumped whenever the table may have changed.
    changed: tokio::sync::watch::Sender<u64>,
}

use crate::local::now_ns;

fn key(topic: &str, ros_type: &str, depth: usize, dir: Dir) -> Key {
    Key {
        topic: topic.to_owned(),
        ros_type: ros_type.to_owned(),
        depth,
        dir,
    }
}

fn check_types(source: &Signal, slot: &Slot) -> Result<()> {
    if slot.ros_type() == Empty::ros_type_name() || slot.ros_type() == source.ros_type() {
        Ok(())
    } else {
        Err(Error::TypeMismatch {
            source_topic: source.topic().to_owned(),
            source_type: source.ros_type().to_owned(),
            slot_topic: slot.topic().to_owned(),
            slot_type: slot.ros_type().to_owned(),
        })
    }
}

impl Manager {
    /// A manager on `participant`; `local`: it hands signals to this process's responses directly.
    pub(crate) fn new(participant: Arc<Participant>, local: bool) -> Manager {
        let base = crate::cause::statement_base(participant.guid());
        Manager {
            participant,
            local,
            state: Mutex::new(State {
                table: ConnectionTable::with_statement_base(base),
                ..State::default()
            }),
            changed: tokio::sync::watch::channel(0).0,
        }
    }

    /// The participant's match graph (and its count of messages that did not decode).
    pub(crate) fn graph(&self) -> &crate::graph::Graph {
        self.participant.graph()
    }

    /// Resolves at the next change of the table.
    pub(crate) fn changes(&self) -> tokio::sync::watch::Receiver<u64> {
        self.changed.subscribe()
    }

    /// One signal read on `source`, sent as `sent`: deliver it. Publishing happens under the lock, so a
    /// connection removed before this takes the lock gets nothing, and one removed after got this signal
    /// already.
    fn dispatch(&self, source: &Key, raw: RawMessage, sent: Sent) {
        let mut guard = self.state.lock().unwrap();
        let st = &mut *guard;
        let records = &st.records;
        // C2: a signal a filter refuses, or a transform turns into nothing, is not a delivery
        let mut mapped: Vec<(ConnId, RawMessage)> = Vec::new();
        let deliveries = st.table.on_signal_with(source, sent.at, sent.by, |id| {
            let Some(r) = records.get(&id) else {
                return true;
            };
            if r.filter.as_ref().is_some_and(|f| !f(&raw)) {
                return false;
            }
            match &r.map {
                Some(map) => match map(&raw) {
                    Some(p) => {
                        mapped.push((id, p));
                        true
                    }
                    None => false, // the transform warned
                },
                None => true,
            }
        });
        for d in &deliveries {
            let (payload, slot_sent) = match d.via {
                Via::Signal { n } => {
                    let payload = match mapped.iter().position(|(id, _)| *id == d.id) {
                        Some(i) => mapped.swap_remove(i).1,
                        None => raw.clone(),
                    };
                    let starts = st.records.get(&d.id).is_some_and(|r| r.starts);
                    let by = starts.then(|| st.table.cause(d.id, n));
                    (payload, Sent { at: sent.at, by })
                }
                // an until's interrupt names the statement, with the time of U's signal (R13, C7)
                Via::Until { at } => (RawMessage(vec![0]), Sent::by(at, st.table.cause(d.id, 0))),
            };
            match &d.target {
                Target::Slot(k) => {
                    if let Some(o) = st.outlets.get(k) {
                        o.deliver(payload, slot_sent);
                    }
                }
                Target::Anon(k) => {
                    if let Some(q) = st.anon.get(k) {
                        q.push(payload);
                    }
                }
            }
        }
        // a `once` that fired is gone: forget what it carried
        for d in &deliveries {
            if !st.table.contains(d.id) {
                st.records.remove(&d.id);
            }
        }
        self.prune(st);
        drop(guard);
        self.changed.send_modify(|g| *g += 1);
    }

    /// Every live connection, as `radar_msgs/msg/Connection`.
    pub(crate) fn list(&self) -> Vec<crate::msg::Connection> {
        use crate::msg::Connection as C;
        let st = self.state.lock().unwrap();
        st.table
            .list()
            .into_iter()
            .map(|c| {
                let hops = {
                    let source_local = self.local
                        && self
                            .participant
                            .taps()
                            .find(&c.source.topic, &c.source.ros_type)
                            .is_some_and(|t| t.has_emitters());
                    let target_local = match &c.target {
                        Target::Anon(_) => true,
                        Target::Slot(k) => st.outlets.get(k).is_some_and(Outlet::local),
                    };
                    u8::from(!source_local) + u8::from(!target_local)
                };
                C {
                    id: c.id,
                    kind: match c.kind {
                        Kind::Once => C::ONCE,
                        Kind::Whenever => C::WHENEVER,
                    },
                    kind_label: match c.kind {
                        Kind::Once => "once".into(),
                        Kind::Whenever => "whenever".into(),
                    },
                    source_type: c.source.ros_type.clone(),
                    depth: c.source.depth.min(u32::MAX as usize) as u32,
                    source: c.source.topic,
                    target: match c.target {
                        Target::Slot(t) => t.topic,
                        Target::Anon(_) => "(anonymous)".into(),
                    },
                    until: c.until.map(|u| u.topic).unwrap_or_default(),
                    owner: st
                        .records
                        .get(&c.id)
                        .map(|r| r.owner.clone())
                        .unwrap_or_default(),
                    delivered: c.delivered,
                    state: C::state_of(c.link),
                    state_label: c.link.label().into(),
                    departure: st
                        .records
                        .get(&c.id)
                        .and_then(|r| r.departure.as_ref())
                        .map(|d| d.to_string())
                        .unwrap_or_default(),
                    hops,
                }
            })
            .collect()
    }

    /// Lets go of the relays, outlets and anonymous queues the table no longer needs: an event whose only
    /// listener was a fired `once` deactivates. Looks only at what the table released, so its cost does not
    /// grow with the number of connections.
    fn prune(&self, st: &mut State) {
        let (sources, targets) = st.table.take_released();
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
                // closing the queue lets a delivery already queued (a `once` that just fired) still run
                Target::Anon(k) => {
                    if let Some(q) = st.anon.remove(&k) {
                        q.close();
                    }
                }
            }
        }
    }

    /// A relay for `k`, whose reader `sub` is held once more for it; its task feeds the table, and tells it
    /// when the source's publishers have all gone (and when one is back). With local delivery it takes what
    /// this process's components emit on `k` from their tap, and skips their samples on DDS.
    fn relay(self: &Arc<Self>, k: &Key, sub: Arc<RawSubscription>) -> Relay {
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let me = Arc::downgrade(self);
        let source = k.clone();
        let end = End::Source(k.clone());
        let mut presence = Presence::new(vec![sub.matched_watch()]);
        let tap = self
            .local
            .then(|| self.participant.taps().get(&k.topic, &k.ros_type));
        let token = tap.as_ref().map(|t| {
            let (me, source) = (me.clone(), source.clone());
            t.listen(Arc::new(move |raw: &RawMessage, at, by| {
                if let Some(m) = me.upgrade() {
                    m.dispatch(&source, raw.clone(), Sent { at, by });
                }
            }))
        });
        tokio::spawn(async move {
            let mut samples = std::pin::pin!(sub.stream_from());
            loop {
                tokio::select! {
                    biased;
                    _ = &mut stop_rx => break,
                    r = samples.next() => match (r, me.upgrade()) {
                        // already taken from the tap
                        (Some((_, _, gid)), Some(_)) if tap.as_ref().is_some_and(|t| t.is_local(gid)) => {}
                        (Some((raw, sent, _)), Some(m)) => m.dispatch(&source, raw, sent),
                        _ => break,
                    },
                    change = presence.next() => match (change, me.upgrade()) {
                        (Some(c), Some(m)) => m.peers_changed(&end, c, || sub.departure()),
                        _ => break,
                    },
                }
            }
        });
        Relay {
            _stop: stop,
            _tap: token,
        }
    }

    /// An outlet for the slot `k`, reached through `inlet` (a slot of this process) and/or `dds` (a writer held
    /// once more for it); its task tells the table when the slot's readers have all gone, and when one is back.
    /// When the response of this process that read the slot goes and the outlet has no DDS writer, the task
    /// makes one, so that a response of that name in another process is reached.
    fn outlet(
        self: &Arc<Self>,
        k: &Key,
        inlet: Option<Arc<Inlet>>,
        dds: Option<Arc<RawPublisher>>,
    ) -> Outlet {
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let (more, mut more_rx) = tokio::sync::mpsc::unbounded_channel();
        let me = Arc::downgrade(self);
        let end = End::Target(Target::Slot(k.clone()));
        let mut counts = Vec::new();
        let mut inlet_presence = None;
        if let Some(i) = &inlet {
            let p = i.presence();
            inlet_presence = Some(p.clone());
            counts.push(p);
        }
        if let Some(d) = &dds {
            counts.push(d.matched_watch());
        }
        let needs_writer = dds.is_none();
        let mut presence = Presence::new(counts);
        let key = k.clone();
        let departure = {
            let (me, key) = (me.clone(), key.clone());
            move || {
                let writer = me.upgrade().and_then(|m| {
                    m.state
                        .lock()
                        .unwrap()
                        .outlets
                        .get(&key)
                        .and_then(|o| o.dds.clone())
                });
                match writer {
                    Some(p) => p.departure(),
                    None => Departure::of_subscriber(&key.topic, crate::departure::LossCause::Left),
                }
            }
        };
        tokio::spawn(async move {
            let mut needs_writer = needs_writer;
            let mut inlet_presence = inlet_presence;
            loop {
                // B1: the response of this process left: reach the slot over DDS from now on
                if needs_writer
                    && inlet_presence
                        .as_mut()
                        .is_some_and(|p| *p.borrow_and_update() == 0)
                {
                    match me.upgrade() {
                        Some(m) => {
                            if let Some(w) = m.add_writer(&key) {
                                presence.add(w);
                            }
                            needs_writer = false;
                        }
                        None => break,
                    }
                }
                tokio::select! {
                    biased;
                    _ = &mut stop_rx => break,
                    Some(w) = more_rx.recv() => presence.add(w),
                    _ = async {
                        match inlet_presence.as_mut() {
                            Some(p) if needs_writer => { let _ = p.changed().await; }
                            _ => std::future::pending::<()>().await,
                        }
                    } => {}
                    change = presence.next() => match (change, me.upgrade()) {
                        (Some(c), Some(m)) => m.peers_changed(&end, c, &departure),
                        _ => break,
                    },
                }
            }
        });
        Outlet {
            key: k.clone(),
            empty: k.ros_type == Empty::ros_type_name(),
            inlet,
            dds,
            more,
            _stop: stop,
        }
    }

    /// Gives the outlet of `k` a DDS writer, if it has none: the writer's match count, for its watcher.
    fn add_writer(&self, k: &Key) -> Option<tokio::sync::watch::Receiver<usize>> {
        let mut st = self.state.lock().unwrap();
        let o = st.outlets.get_mut(k)?;
        if o.dds.is_some() {
            return None;
        }
        match self.participant.pooled_writer(k) {
            Ok(w) => {
                let matched = w.matched_watch();
                o.dds = Some(w);
                tracing::debug!(slot = %k.topic, "the slot's response of this process left: reaching it over DDS");
                Some(matched)
            }
            Err(e) => {
                tracing::warn!(slot = %k.topic, error = %e, "no DDS writer for a slot whose response left this process");
                None
            }
        }
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
        let mut st = self.state.lock().unwrap();
        let ids = match end {
            End::Source(k) => st.table.source_lost(k),
            End::Target(t) => st.table.target_lost(t),
        };
        self.note_departure(&mut st, &ids, &d);
        self.prune(&mut st);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }

    /// A peer of a source or target that had gone is back.
    fn peers_back(&self, end: &End) {
        let mut st = self.state.lock().unwrap();
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

    /// Whether the response whose `state` topic is `state_topic` keeps causes (C6): one of this process (its
    /// slot is read here), or one that publishes a `radar_msgs/msg/ResponseState` (a RADAR response; its state
    /// writer is announced before its signal writers, which arming has waited for). An rclpy response does not.
    fn keeps_causes(&self, state_topic: &str, interrupt: &Slot) -> bool {
        if self.local
            && self
                .participant
                .inlets()
                .find(interrupt.topic(), interrupt.ros_type())
                .is_some()
        {
            return true;
        }
        let state_t = TypeName::of::<ResponseState>().dds;
        self.graph().types_on(true, state_topic).contains(&state_t)
    }

    /// Arms a statement: holds its endpoints while discovery matches them, then enters it in the table.
    pub(crate) async fn arm(self: &Arc<Self>, spec: Spec) -> Result<ConnectionGuard> {
        if let TargetSpec::Slot(slot) = &spec.target {
            let delivered = match &spec.mapped_type {
                Some(t) => Signal::new(spec.source.topic(), t.clone()),
                None => spec.source.clone(),
            };
            check_types(&delivered, slot)?;
        }
        let depth = spec.depth;
        let source_key = key(
            spec.source.topic(),
            spec.source.ros_type(),
            depth,
            Dir::Reader,
        );
        let mut sources = vec![(source_key.clone(), spec.source.clone())];
        let until_keys = spec.until.as_ref().map(|u| {
            let k = |s: &Signal| key(s.topic(), s.ros_type(), depth, Dir::Reader);
            let keys = (k(&u.source), k(&u.started), k(&u.exited));
            sources.extend([
                (keys.0.clone(), u.source.clone()),
                (keys.1.clone(), u.started.clone()),
                (keys.2.clone(), u.exited.clone()),
            ]);
            keys
        });
        let mut slots: Vec<(Key, Slot)> = Vec::new();
        let target_key = match &spec.target {
            TargetSpec::Slot(s) => {
                let k = key(s.topic(), s.ros_type(), depth, Dir::Writer);
                slots.push((k.clone(), s.clone()));
                Some(k)
            }
            TargetSpec::Anon(_) => None,
        };
        let interrupt_key = spec.until.as_ref().map(|u| {
            let k = key(
                u.interrupt.topic(),
                u.interrupt.ros_type(),
                depth,
                Dir::Writer,
            );
            slots.push((k.clone(), u.interrupt.clone()));
            k
        });
        // this statement's own holds while it arms: released whatever happens
        let held = Holds::new(&self.participant);
        let readers = sources
            .iter()
            .map(|(k, _)| held.reader(k))
            .collect::<Result<Vec<_>>>()?;
        // a slot is reached through a response of this process that reads it, or else over DDS
        let writers = slots
            .iter()
            .map(|(k, _)| {
                let local = self.local
                    && self
                        .participant
                        .inlets()
                        .find(&k.topic, &k.ros_type)
                        .is_some();
                if local {
                    Ok(None)
                } else {
                    held.writer(k).map(Some)
                }
            })
            .collect::<Result<Vec<_>>>()?;
        for (r, (_, s)) in readers.iter().zip(&sources) {
            r.wait_for_publishers(1)
                .timeout(spec.timeout)
                .await
                .map_err(|_| Error::Timeout {
                    what: format!(
                        "a publisher of {} on {}: is the component that emits it running?",
                        s.ros_type(),
                        s.topic()
                    ),
                    after: spec.timeout,
                })?;
        }
        for (w, (_, s)) in writers.iter().zip(&slots) {
            let Some(w) = w else { continue };
            w.wait_for_subscribers(1)
                .timeout(spec.timeout)
                .await
                .map_err(|_| Error::Timeout {
                    what: format!(
                        "a subscriber of {} on {}: is the response running?",
                        s.ros_type(),
                        s.topic()
                    ),
                    after: spec.timeout,
                })?;
        }
        let causes = spec
            .until
            .as_ref()
            .is_some_and(|u| self.keeps_causes(&u.state, &u.interrupt));
        if let Some(u) = &spec.until {
            tracing::debug!(response = %u.state, causes, "until: the response keeps causes (C6) or not (C7)");
        }
        let mut st = self.state.lock().unwrap();
        // the table's own holds, once per source and slot
        for ((k, _), r) in sources.iter().zip(&readers) {
            if !st.relays.contains_key(k) {
                self.participant.pooled_reader(k)?;
                let relay = self.relay(k, r.clone());
                st.relays.insert(k.clone(), relay);
            }
        }
        for ((k, _), w) in slots.iter().zip(&writers) {
            match st.outlets.get_mut(k) {
                // B1: an outlet whose response of this process left, and a new statement reaches the slot over
                // DDS: the outlet takes the writer
                Some(o) => {
                    if let (None, Some(w)) = (&o.dds, w) {
                        self.participant.pooled_writer(k)?;
                        o.dds = Some(w.clone());
                        let _ = o.more.send(w.matched_watch());
                    }
                }
                None => {
                    if w.is_some() {
                        self.participant.pooled_writer(k)?;
                    }
                    let inlet = self.local.then(|| self.participant.inlets().hold(&k.topic));
                    let outlet = self.outlet(k, inlet, w.clone());
                    st.outlets.insert(k.clone(), outlet);
                }
            }
        }
        let target = match spec.target {
            TargetSpec::Slot(_) => Target::Slot(target_key.expect("a slot target has its key")),
            TargetSpec::Anon(mut f) => {
                let k = st.next_anon;
                st.next_anon += 1;
                let q = Arc::new(AnonQueue::new(spec.source.topic().to_owned(), depth));
                let consumer = q.clone();
                tokio::spawn(async move {
                    while let Some(m) = consumer.next().await {
                        f(m);
                    }
                });
                st.anon.insert(k, q);
                Target::Anon(k)
            }
        };
        let until = until_keys.map(|(source, started, exited)| Until {
            source,
            started,
            exited,
            interrupt: Target::Slot(interrupt_key.expect("an until has its slot")),
            causes,
        });
        let id = st.table.arm(source_key, target, spec.kind, until, now_ns());
        st.table.set_rearm(id, spec.rearm);
        st.records.insert(
            id,
            Record {
                owner: spec.owner,
                filter: spec.filter,
                map: spec.map,
                starts: spec.starts,
                departure: None,
            },
        );
        drop(st);
        drop(held);
        self.changed.send_modify(|g| *g += 1);
        Ok(ConnectionGuard {
            id,
            manager: self.clone(),
        })
    }

    /// The guard dropped: remove the connection, and cancel anonymous-slot calls it has not begun.
    fn remove(&self, id: ConnId) {
        let mut st = self.state.lock().unwrap();
        if let Some(Target::Anon(k)) = st.table.target(id) {
            if let Some(q) = st.anon.get(k) {
                q.cancel();
            }
        }
        st.table.remove(id);
        st.records.remove(&id);
        self.prune(&mut st);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }

    fn contains(&self, id: ConnId) -> bool {
        self.state.lock().unwrap().table.contains(id)
    }

    /// The connection's link and the departure that put it out of `Armed`, if it is live.
    fn link(&self, id: ConnId) -> Option<(Link, Option<Departure>)> {
        let st = self.state.lock().unwrap();
        let link = st.table.link(id)?;
        let d = st.records.get(&id).and_then(|r| r.departure.clone());
        Some((link, d))
    }

    fn delivered(&self, id: ConnId) -> u64 {
        let st = self.state.lock().unwrap();
        st.table
            .list()
            .into_iter()
            .find(|c| c.id == id)
            .map(|c| c.delivered)
            .unwrap_or(0)
    }
}

/// What a relay or outlet tells the table about its peers.
enum Change {
    /// All of them have been gone for [`GONE_AFTER`].
    Gone,
    /// One is back after that.
    Back,
}

/// Whether a source or slot has peers (the sum of some match counts), with the grace of [`GONE_AFTER`]
/// before it counts as gone.
struct Presence {
    counts: Vec<tokio::sync::watch::Receiver<usize>>,
    /// No peer since this moment (not yet reported).
    empty_since: Option<tokio::time::Instant>,
    /// Reported gone (and not back since).
    gone: bool,
}

impl Presence {
    fn new(counts: Vec<tokio::sync::watch::Receiver<usize>>) -> Presence {
        let mut p = Presence {
            counts,
            empty_since: None,
            gone: false,
        };
        if p.total() == 0 {
            p.empty_since = Some(tokio::time::Instant::now());
        }
        p
    }

    fn total(&mut self) -> usize {
        self.counts.iter_mut().map(|c| *c.borrow_and_update()).sum()
    }

    /// Another count to add (a writer made later).
    fn add(&mut self, count: tokio::sync::watch::Receiver<usize>) {
        self.counts.push(count);
    }

    /// The next change worth telling; `None` once the endpoints are gone. Cancel-safe: the state lives here.
    async fn next(&mut self) -> Option<Change> {
        loop {
            let deadline = self.empty_since.map(|t| t + GONE_AFTER);
            let changed = async {
                if self.counts.is_empty() {
                    return std::future::pending::<bool>().await;
                }
                let all = self.counts.iter_mut().map(|c| Box::pin(c.changed()));
                futures::future::select_all(all).await.0.is_ok()
            };
            tokio::select! {
                ok = changed => {
                    if !ok {
                        return None;
                    }
                    if self.total() == 0 {
                        if !self.gone && self.empty_since.is_none() {
                            self.empty_since = Some(tokio::time::Instant::now());
                        }
                    } else {
                        self.empty_since = None;
                        if std::mem::take(&mut self.gone) {
                            return Some(Change::Back);
                        }
                    }
                }
                _ = async { tokio::time::sleep_until(deadline.expect("guarded")).await }, if deadline.is_some() => {
                    self.empty_since = None;
                    if self.total() == 0 {
                        self.gone = true;
                        return Some(Change::Gone);
                    }
                }
            }
        }
    }
}

/// Pool holds taken by a statement while it arms, given back when dropped (on success, on error, on a
/// cancelled arm).
struct Holds<'a> {
    participant: &'a Participant,
    keys: Mutex<Vec<Key>>,
}

impl<'a> Holds<'a> {
    fn new(participant: &'a Participant) -> Holds<'a> {
        Holds {
            participant,
            keys: Mutex::new(Vec::new()),
        }
    }
    fn reader(&self, k: &Key) -> Result<Arc<RawSubscription>> {
        let r = self.participant.pooled_reader(k)?;
        self.keys.lock().unwrap().push(k.clone());
        Ok(r)
    }
    fn writer(&self, k: &Key) -> Result<Arc<RawPublisher>> {
        let w = self.participant.pooled_writer(k)?;
        self.keys.lock().unwrap().push(k.clone());
        Ok(w)
    }
}

impl Drop for Holds<'_> {
    fn drop(&mut self) {
        for k in self.keys.get_mut().unwrap().drain(..) {
            self.participant.release(&k);
        }
    }
}

/// A live connection. Dropping it removes the connection: once the drop returns, nothing more is delivered
/// through it (an anonymous slot already running finishes; no new call begins).
///
/// ```no_run
/// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventHandle, go: radar_ros::ResponseHandle)
/// #     -> radar_ros::Result<()> {
/// {
///     let c = radar.whenever(&tick).start(&go).await?;
///     println!("connection {} is live: {}", c.id(), c.is_live());
/// } // dropped here: tick no longer starts go
/// # Ok(()) }
/// ```
#[must_use = "a connection lives only as long as this guard; bind it (`let _c = ...`) to keep it for the scope"]
pub struct ConnectionGuard {
    id: ConnId,
    manager: Arc<Manager>,
}

impl ConnectionGuard {
    /// Its id in the manager's list.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Whether it still delivers (a fired `once` without `until` does not).
    pub fn is_live(&self) -> bool {
        self.manager.contains(self.id)
    }

    /// Resolves when the connection no longer delivers: a `once` (without `until`) that fired. (An anonymous
    /// slot's call for that last delivery runs in its own task and may still be running.)
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, go: radar_ros::EventRef, r: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// let c = radar.once(&go).start(&r).await?;
    /// c.closed().await; // the once has fired
    /// assert!(!c.is_live());
    /// # Ok(()) }
    /// ```
    pub async fn closed(&self) {
        let mut rx = self.manager.changed.subscribe();
        while self.is_live() {
            if rx.changed().await.is_err() {
                return;
            }
        }
    }

    /// Whether it can deliver now ([`Link::Armed`]), or waits because a component left; `None` once it no
    /// longer exists (a fired `once`). See [components that leave](crate#when-components-leave).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventRef, go: radar_ros::ResponseRef)
    /// #     -> radar_ros::Result<()> {
    /// use radar_ros::Link;
    /// let c = radar.whenever(&tick).start(&go).await?;
    /// let d = c.departed().await.expect("a whenever lives until dropped");
    /// eprintln!("{d}");                       // which component left, and why
    /// match c.link() {
    ///     Some(Link::WaitingForSource) => eprintln!("tick will be heard again when it is back"),
    ///     Some(Link::TargetLost) => eprintln!("go is gone: make the statement again when it is back"),
    ///     other => eprintln!("{other:?}"),
    /// }
    /// # Ok(()) }
    /// ```
    pub fn link(&self) -> Option<Link> {
        self.manager.link(self.id).map(|(l, _)| l)
    }

    /// The component whose leaving put the connection out of [`Link::Armed`], while it is out.
    pub fn departure(&self) -> Option<Departure> {
        self.manager.link(self.id).and_then(|(_, d)| d)
    }

    /// Resolves when a component of this connection leaves the graph (its source's last publisher, or its
    /// target's last subscriber, or the response of its `until`), with who left and why; or with `None` when
    /// the connection ends without that (a fired `once`). Resolves at once if one has already left.
    pub async fn departed(&self) -> Option<Departure> {
        let mut rx = self.manager.changed.subscribe();
        loop {
            match self.manager.link(self.id) {
                None => return None,
                Some((_, Some(d))) => return Some(d),
                Some((_, None)) => {}
            }
            if rx.changed().await.is_err() {
                return None;
            }
        }
    }

    /// Signals delivered from its source so far (0 once a fired `once` is gone).
    pub fn delivered(&self) -> u64 {
        self.manager.delivered(self.id)
    }
}

impl std::fmt::Debug for ConnectionGuard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ConnectionGuard")
            .field("id", &self.id)
            .finish()
    }
}

impl Drop for ConnectionGuard {
    fn drop(&mut self) {
        self.manager.remove(self.id);
    }
}
