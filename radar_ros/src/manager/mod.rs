//! The embedded connection manager of one participant: it carries out what the connection table decides.
//!
//! What is delivered when is decided by [`radar_semantics::connection::ConnectionTable`]; this module moves the
//! messages. For every source the table needs it keeps one relay (a pooled raw reader and the task that feeds
//! each signal to the table), and for every slot one outlet (a pooled raw writer); connections on the same
//! topic, type and QoS depth share them. Messages are forwarded as serialized bodies ([`RawMessage`]), so the
//! manager needs no Rust type for them. A slot of type `std_msgs/msg/Empty` (interrupt, exit, or an Empty
//! start) accepts a source of any type: the signal counts, its payload is dropped. Any other slot needs the
//! source's type.
//!
//! A statement ([`crate::ConnectionRequest`]) is armed when its relay readers have matched the sources'
//! writers and its outlet writers have matched the slots' readers; only signals emitted after that are
//! delivered (by source timestamp against this host's clock: hosts of one ROS graph are assumed to be in time
//! sync).
//!
//! Each relay and outlet also watches its DDS match count: when the last publisher of a source, or the last
//! subscriber of a slot, has been gone for [`GONE_AFTER`], the table is told (connection rule 5) and the
//! connections it changes record the [`Departure`]; when one comes back, the table is told again.

mod anon;

use std::{
    collections::HashMap,
    sync::{Arc, Mutex},
    time::Duration,
};

use futures::StreamExt;
use radar_semantics::connection::{ConnId, ConnectionTable, Kind, Link, ResponseView, Until};

use crate::{
    departure::Departure,
    error::{Error, Result},
    local::Inlet,
    msg::{Empty, ResponseState, RosMessage},
    participant::Participant,
    pool::{Dir, Key},
    qos::state_qos,
    raw::RawMessage,
    refs::{Signal, Slot},
    topics::{RawPublisher, RawSubscription},
};
use anon::AnonQueue;

/// An anonymous slot: called with each delivered payload, in its own task.
pub(crate) type AnonFn = Box<dyn FnMut(RawMessage) + Send>;
/// A connection's filter: whether to deliver a payload.
pub(crate) type FilterFn = Arc<dyn Fn(&RawMessage) -> bool + Send + Sync>;
/// A connection's transform: what to deliver instead of a payload (`None`: nothing).
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
    /// R's `state` topic: whether R runs when armed, and its policy for starts while running.
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
    /// The component whose leaving put the connection out of `Armed`, while it is out.
    departure: Option<Departure>,
}

/// A source the table reads: the task that feeds its reader's signals to the table (stopped on drop), and
/// its listening to this process's emitters of the source (ends on drop).
struct Relay {
    _stop: tokio::sync::oneshot::Sender<()>,
    _tap: Option<Arc<()>>,
}

/// How a slot is reached.
enum Way {
    /// A DDS writer on the slot's topic (held in the participant's pool).
    Dds(Arc<RawPublisher>),
    /// A response of this process, directly: no DDS hop (see [`crate::local`]).
    Local(Arc<Inlet>),
}

impl Way {
    fn deliver(&self, k: &Key, m: RawMessage) {
        match self {
            Way::Dds(p) => {
                if let Err(e) = p.publish(m) {
                    tracing::warn!(slot = %k.topic, error = %e, "could not deliver a signal");
                }
            }
            // a response that has just left gets nothing, as over DDS
            Way::Local(inlet) => {
                inlet.deliver(m);
            }
        }
    }
}

/// A slot the table writes.
struct Outlet {
    way: Way,
    /// The slot takes `std_msgs/msg/Empty`: the payload is dropped.
    empty: bool,
    /// Stops the task that watches the slot's subscribers.
    _stop: tokio::sync::oneshot::Sender<()>,
}

#[derive(Default)]
struct State {
    table: ConnectionTable<Key, Target>,
    records: HashMap<ConnId, Record>,
    /// One per source the table reads, each holding the pooled reader once.
    relays: HashMap<Key, Relay>,
    /// One per slot the table writes, each holding the pooled writer once.
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
        Manager {
            participant,
            local,
            state: Mutex::new(State::default()),
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

    /// One signal read on `source`: deliver it. Publishing happens under the lock, so a connection removed
    /// before this takes the lock gets nothing, and one removed after got this signal already.
    fn dispatch(&self, source: &Key, raw: RawMessage, stamp: i64) {
        let mut guard = self.state.lock().unwrap();
        let st = &mut *guard;
        let records = &st.records;
        let deliveries = st.table.on_signal_with(source, stamp, |id| {
            records
                .get(&id)
                .and_then(|r| r.filter.as_ref())
                .is_none_or(|f| f(&raw))
        });
        for d in &deliveries {
            let payload = match st.records.get(&d.id).and_then(|r| r.map.as_ref()) {
                Some(map) => match map(&raw) {
                    Some(p) => p,
                    None => continue, // the transform warned
                },
                None => raw.clone(),
            };
            match &d.target {
                Target::Slot(k) => {
                    if let Some(o) = st.outlets.get(k) {
                        let m = if o.empty {
                            RawMessage(vec![0])
                        } else {
                            payload
                        };
                        o.way.deliver(k, m);
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
                            .get(&c.source.topic, &c.source.ros_type)
                            .has_emitters();
                    let target_local = match &c.target {
                        Target::Anon(_) => true,
                        Target::Slot(k) => {
                            matches!(
                                st.outlets.get(k),
                                Some(Outlet {
                                    way: Way::Local(_),
                                    ..
                                })
                            )
                        }
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
                    if let Some(Outlet {
                        way: Way::Dds(_), ..
                    }) = st.outlets.remove(&k)
                    {
                        self.participant.release(&k);
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
        let mut presence = Presence::new(sub.matched_watch());
        let tap = self
            .local
            .then(|| self.participant.taps().get(&k.topic, &k.ros_type));
        let token = tap.as_ref().map(|t| {
            let (me, source) = (me.clone(), source.clone());
            t.listen(Arc::new(move |raw: &RawMessage, stamp| {
                if let Some(m) = me.upgrade() {
                    m.dispatch(&source, raw.clone(), stamp);
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
                        (Some((raw, stamp, _)), Some(m)) => {
                            m.dispatch(&source, raw, if stamp > 0 { stamp } else { now_ns() });
                        }
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

    /// Watches the subscribers of the slot `k` (reached `way`) and tells the table when they have all gone,
    /// and when one is back. Stops when the returned sender is dropped.
    fn watch_outlet(self: &Arc<Self>, k: &Key, way: &Way) -> tokio::sync::oneshot::Sender<()> {
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let me = Arc::downgrade(self);
        let end = End::Target(Target::Slot(k.clone()));
        let (matched, publisher) = match way {
            Way::Dds(p) => (p.matched_watch(), Some(p.clone())),
            Way::Local(inlet) => (inlet.presence(), None),
        };
        let topic = k.topic.clone();
        let departure = move || match &publisher {
            Some(p) => p.departure(),
            None => Departure::of_subscriber(&topic, crate::departure::LossCause::Left),
        };
        let mut presence = Presence::new(matched);
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    biased;
                    _ = &mut stop_rx => break,
                    change = presence.next() => match (change, me.upgrade()) {
                        (Some(c), Some(m)) => m.peers_changed(&end, c, &departure),
                        _ => break,
                    },
                }
            }
        });
        stop
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

    /// What R's `state` says when an `until` statement is armed: whether it runs, and whether it runs a start
    /// that arrives meanwhile later. A response that publishes no state (not a RADAR response, say) counts as
    /// idle and dropping such starts.
    async fn response_view(&self, state_topic: &str, timeout: Duration) -> ResponseView {
        let look = async {
            let s = self
                .participant
                .subscription::<ResponseState>(state_topic, &state_qos())?;
            s.wait_for_publishers(1).timeout(timeout).await?;
            s.recv().timeout(timeout).await
        };
        match look.await {
            Ok(st) => ResponseView {
                running: st.state != ResponseState::STATE_IDLE,
                runs_later: st.start_policy != "ignore",
            },
            Err(e) => {
                tracing::debug!(topic = %state_topic, error = %e, "no state from the until's response");
                ResponseView::default()
            }
        }
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
        let mut sources = vec![spec.source.clone()];
        if let Some(u) = &spec.until {
            sources.extend([u.source.clone(), u.started.clone(), u.exited.clone()]);
        }
        let mut slots: Vec<Slot> = Vec::new();
        if let TargetSpec::Slot(s) = &spec.target {
            slots.push(s.clone());
        }
        if let Some(u) = &spec.until {
            slots.push(u.interrupt.clone());
        }
        let source_keys: Vec<Key> = sources
            .iter()
            .map(|s| key(s.topic(), s.ros_type(), depth, Dir::Reader))
            .collect();
        let slot_keys: Vec<Key> = slots
            .iter()
            .map(|s| key(s.topic(), s.ros_type(), depth, Dir::Writer))
            .collect();
        // this statement's own holds while it arms: released whatever happens
        let held = Holds::new(&self.participant);
        let readers = source_keys
            .iter()
            .map(|k| held.reader(k))
            .collect::<Result<Vec<_>>>()?;
        let writers = slot_keys
            .iter()
            .map(|k| {
                let inlet = self
                    .local
                    .then(|| self.participant.inlets().find(&k.topic, &k.ros_type))
                    .flatten();
                match inlet {
                    Some(inlet) => Ok(Way::Local(inlet)),
                    None => held.writer(k).map(Way::Dds),
                }
            })
            .collect::<Result<Vec<_>>>()?;
        for (r, s) in readers.iter().zip(&sources) {
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
        for (w, s) in writers.iter().zip(&slots) {
            let Way::Dds(w) = w else { continue };
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
        let view = match &spec.until {
            Some(u) => {
                self.response_view(&u.state, spec.timeout.min(Duration::from_secs(1)))
                    .await
            }
            None => ResponseView::default(),
        };
        let mut st = self.state.lock().unwrap();
        // the table's own holds, once per source and slot
        for (k, r) in source_keys.iter().zip(&readers) {
            if !st.relays.contains_key(k) {
                self.participant.pooled_reader(k)?;
                let relay = self.relay(k, r.clone());
                st.relays.insert(k.clone(), relay);
            }
        }
        for (k, w) in slot_keys.iter().zip(&writers) {
            if !st.outlets.contains_key(k) {
                let way = match w {
                    Way::Dds(p) => {
                        self.participant.pooled_writer(k)?;
                        Way::Dds(p.clone())
                    }
                    Way::Local(inlet) => Way::Local(inlet.clone()),
                };
                let empty = k.ros_type == Empty::ros_type_name();
                let stop = self.watch_outlet(k, &way);
                st.outlets.insert(
                    k.clone(),
                    Outlet {
                        way,
                        empty,
                        _stop: stop,
                    },
                );
            }
        }
        let target = match spec.target {
            TargetSpec::Slot(_) => Target::Slot(slot_keys[0].clone()),
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
        let until = spec.until.as_ref().map(|_| Until {
            source: source_keys[1].clone(),
            started: source_keys[2].clone(),
            exited: source_keys[3].clone(),
            interrupt: Target::Slot(slot_keys.last().expect("until has its slot").clone()),
            response: view,
        });
        let id = st
            .table
            .arm(source_keys[0].clone(), target, spec.kind, until, now_ns());
        st.table.set_rearm(id, spec.rearm);
        st.records.insert(
            id,
            Record {
                owner: spec.owner,
                filter: spec.filter,
                map: spec.map,
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

/// Whether a source or slot has peers, with the grace of [`GONE_AFTER`] before it counts as gone.
struct Presence {
    matched: tokio::sync::watch::Receiver<usize>,
    /// No peer since this moment (not yet reported).
    empty_since: Option<tokio::time::Instant>,
    /// Reported gone (and not back since).
    gone: bool,
}

impl Presence {
    fn new(mut matched: tokio::sync::watch::Receiver<usize>) -> Presence {
        let empty = *matched.borrow_and_update() == 0;
        Presence {
            matched,
            empty_since: empty.then(tokio::time::Instant::now),
            gone: false,
        }
    }

    /// The next change worth telling; `None` once the endpoint is gone. Cancel-safe: the state lives here.
    async fn next(&mut self) -> Option<Change> {
        loop {
            let deadline = self.empty_since.map(|t| t + GONE_AFTER);
            tokio::select! {
                c = self.matched.changed() => {
                    c.ok()?;
                    if *self.matched.borrow_and_update() == 0 {
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
                    if *self.matched.borrow() == 0 {
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
