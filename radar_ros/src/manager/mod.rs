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

mod anon;

use std::{
    collections::HashMap,
    sync::{Arc, Mutex},
    time::Duration,
};

use radar_semantics::connection::{ConnId, ConnectionTable, Kind, Until};

use crate::{
    error::{Error, Result},
    msg::{Empty, RosMessage},
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
/// A connection's transform: what to deliver instead of a payload (`None`: nothing).
pub(crate) type MapFn = Arc<dyn Fn(&RawMessage) -> Option<RawMessage> + Send + Sync>;

/// Where a connection delivers.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Target {
    Slot(Key),
    Anon(u64),
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
}

/// What a live connection carries besides what the table knows.
struct Record {
    owner: String,
    filter: Option<FilterFn>,
    map: Option<MapFn>,
}

/// A source the table reads: the task that feeds its reader's signals to the table (stopped on drop).
struct Relay {
    _stop: tokio::sync::oneshot::Sender<()>,
}

/// A slot the table writes.
struct Outlet {
    publisher: Arc<RawPublisher>,
    /// The slot takes `std_msgs/msg/Empty`: the payload is dropped.
    empty: bool,
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
    state: Mutex<State>,
    /// Bumped whenever the table may have changed.
    changed: tokio::sync::watch::Sender<u64>,
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

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
    pub(crate) fn new(participant: Arc<Participant>) -> Manager {
        Manager {
            participant,
            state: Mutex::new(State::default()),
            changed: tokio::sync::watch::channel(0).0,
        }
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
                        if let Err(e) = o.publisher.publish(m) {
                            tracing::warn!(slot = %k.topic, error = %e, "could not deliver a signal");
                        }
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
            .map(|c| C {
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
                    if st.outlets.remove(&k).is_some() {
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

    /// A relay for `k`, whose reader `sub` is held once more for it; its task feeds the table.
    fn relay(self: &Arc<Self>, k: &Key, sub: Arc<RawSubscription>) -> Relay {
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let me = Arc::downgrade(self);
        let source = k.clone();
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    _ = &mut stop_rx => break,
                    r = sub.recv_stamped() => match (r, me.upgrade()) {
                        (Ok((raw, stamp)), Some(m)) => {
                            m.dispatch(&source, raw, if stamp > 0 { stamp } else { now_ns() })
                        }
                        _ => break,
                    },
                }
            }
        });
        Relay { _stop: stop }
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
            .map(|k| held.writer(k))
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
                self.participant.pooled_writer(k)?;
                let empty = k.ros_type == Empty::ros_type_name();
                st.outlets.insert(
                    k.clone(),
                    Outlet {
                        publisher: w.clone(),
                        empty,
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
        });
        let id = st
            .table
            .arm(source_keys[0].clone(), target, spec.kind, until, now_ns());
        st.records.insert(
            id,
            Record {
                owner: spec.owner,
                filter: spec.filter,
                map: spec.map,
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
