//! Connections: `once`, `whenever`, `until`, `waitfor` and anonymous slots, executed by an embedded
//! connection manager over DDS.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, start_event: radar_ros::EventHandle,
//! #            end_event: radar_ros::EventHandle, count_up: radar_ros::ResponseHandle) -> radar_ros::Result<()> {
//! // once start_event start count_up until end_event
//! let _c = radar.once(start_event.triggered()).start(&count_up).until(end_event.triggered()).await?;
//! // the connection lives until `_c` is dropped (end of scope, `?`, panic)
//! let output: radar_ros::msg::Empty = radar.waitfor(count_up.reference().exited(), None).await?;
//! # Ok(()) }
//! ```
//!
//! What is delivered when is decided by [`crate::semantics::connection::ConnectionTable`];
//! this module moves the messages. The manager keeps one reader per source topic and one writer per target
//! slot however many connections share them (per QoS depth: see [`Connect::depth`]), and forwards serialized messages unchanged
//! ([`crate::raw::RawMessage`]), so it needs no Rust type for them. A slot of type
//! `std_msgs/msg/Empty` (interrupt, exit, or an Empty start) accepts a source of any type: the signal counts,
//! its payload is dropped. Any other slot needs the source's type to be the same.
//!
//! A statement returns once its relay is armed end to end: the relay's readers have matched the sources'
//! writers and its writer has matched the slot's reader. Only signals emitted after that are delivered (by
//! source timestamp against the manager's clock: hosts of one ROS graph are assumed to be in time sync).

use std::{
    collections::HashMap,
    future::{Future, IntoFuture},
    pin::Pin,
    sync::{
        atomic::{AtomicBool, Ordering},
        Arc, Mutex,
    },
    time::Duration,
};

use crate::{
    endpoints::SIGNAL_DEPTH,
    error::{Error, Result},
    msg::{Empty, RosMessage},
    names::ComponentName,
    radar::{Radar, WeakRadar},
    raw::{RawMessage, RawPublisher, RawSubscription},
    semantics::connection::{ConnId, ConnectionTable, Kind, Until},
};

/// A signal: a topic a component publishes, with its type.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Signal {
    topic: String,
    ros_type: String,
}

impl Signal {
    /// A signal on the absolute `topic` of type `ros_type` (`pkg/msg/Name`).
    pub fn new(topic: impl Into<String>, ros_type: impl Into<String>) -> Signal {
        Signal {
            topic: topic.into(),
            ros_type: ros_type.into(),
        }
    }
    /// The topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }
    /// The type, `pkg/msg/Name`.
    pub fn ros_type(&self) -> &str {
        &self.ros_type
    }
}

/// A slot: a topic a component subscribes to, with its type.
pub type Slot = Signal;

/// The signals and slots of a response, wherever it runs.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ResponseRef {
    name: ComponentName,
    start_type: String,
    output_type: String,
}

impl ResponseRef {
    /// A response named `name` whose start slot takes `start_type` and whose `exited` carries `output_type`.
    pub fn new(name: ComponentName, start_type: String, output_type: String) -> ResponseRef {
        ResponseRef {
            name,
            start_type,
            output_type,
        }
    }
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        &self.name
    }
    /// `started`, carrying the start payload.
    pub fn started(&self) -> Signal {
        Signal::new(self.name.topic("started"), self.start_type.clone())
    }
    /// `interrupted`.
    pub fn interrupted(&self) -> Signal {
        Signal::new(self.name.topic("interrupted"), Empty::ros_type_name())
    }
    /// `exited`, carrying the run's output.
    pub fn exited(&self) -> Signal {
        Signal::new(self.name.topic("exited"), self.output_type.clone())
    }
    /// The `start` slot.
    pub fn start_slot(&self) -> Slot {
        Signal::new(self.name.topic("start"), self.start_type.clone())
    }
    /// The `interrupt` slot.
    pub fn interrupt_slot(&self) -> Slot {
        Signal::new(self.name.topic("interrupt"), Empty::ros_type_name())
    }
    /// The `exit` slot.
    pub fn exit_slot(&self) -> Slot {
        Signal::new(self.name.topic("exit"), Empty::ros_type_name())
    }
}

/// Something that names a response: a local [`ResponseHandle`](crate::ResponseHandle) or a [`ResponseRef`].
pub trait AsResponse {
    /// Its signals and slots.
    fn response_ref(&self) -> ResponseRef;
}

impl<R: AsResponse + ?Sized> AsResponse for &R {
    fn response_ref(&self) -> ResponseRef {
        (**self).response_ref()
    }
}

impl AsResponse for ResponseRef {
    fn response_ref(&self) -> ResponseRef {
        self.clone()
    }
}

impl AsResponse for crate::ResponseHandle {
    fn response_ref(&self) -> ResponseRef {
        self.reference().clone()
    }
}

#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Target {
    Slot(String),
    Anon(u64),
}

type AnonFn = Box<dyn FnMut(RawMessage) + Send>;
type FilterFn = Arc<dyn Fn(&RawMessage) -> bool + Send + Sync>;
type MapFn = Arc<dyn Fn(&RawMessage) -> Option<RawMessage> + Send + Sync>;

struct Reader {
    sub: Arc<RawSubscription>,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
}

impl Drop for Reader {
    fn drop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
    }
}

struct Writer {
    publisher: Arc<RawPublisher>,
    empty: bool,
}

/// How long a writer no connection needs any more is kept before it is deleted (see
/// [`crate::endpoints::WRITER_LINGER`]). A writer asked for again while it lingers is reused, without new
/// discovery.
use crate::endpoints::WRITER_LINGER;

#[derive(Default)]
struct State {
    table: ConnectionTable<String, Target>,
    readers: HashMap<String, Reader>,
    writers: HashMap<String, Writer>,
    /// Writers no connection needs, kept for [`WRITER_LINGER`] from when they were retired.
    lingering: HashMap<String, (Writer, std::time::Instant)>,
    anon: HashMap<u64, Arc<AnonQueue>>,
    /// Who made each connection.
    owners: HashMap<ConnId, String>,
    /// Connection properties: filters and payload transforms.
    filters: HashMap<ConnId, FilterFn>,
    maps: HashMap<ConnId, MapFn>,
    /// Writers for `inject`, one per slot, kept for the manager's life.
    injectors: HashMap<String, Arc<RawPublisher>>,
    /// Topics held by statements still arming (readers/writers not yet in the table).
    pending: HashMap<String, usize>,
    next_anon: u64,
}

/// The embedded connection manager of one [`Radar`].
pub(crate) struct Manager {
    radar: WeakRadar,
    state: Mutex<State>,
    /// Bumped whenever the table may have changed.
    changed: tokio::sync::watch::Sender<u64>,
    /// Wakes the task that deletes lingering writers.
    retired: Arc<tokio::sync::Notify>,
    sweeper: std::sync::Once,
}

/// The manager's key for a relay endpoint on `topic` with history `depth`: the topic itself at the default
/// depth, so connections asking for another depth get endpoints of their own (`#` is not valid in ROS names).
fn endpoint_key(topic: &str, depth: usize) -> String {
    if depth == SIGNAL_DEPTH {
        topic.to_owned()
    } else {
        format!("{topic}#depth={depth}")
    }
}

/// The topic and depth of an endpoint key.
fn split_key(key: &str) -> (&str, usize) {
    match key.split_once("#depth=") {
        Some((t, d)) => (t, d.parse().unwrap_or(SIGNAL_DEPTH)),
        None => (key, SIGNAL_DEPTH),
    }
}

fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

impl Manager {
    pub(crate) fn new(radar: WeakRadar) -> Manager {
        Manager {
            radar,
            state: Mutex::new(State::default()),
            changed: tokio::sync::watch::channel(0).0,
            retired: Arc::new(tokio::sync::Notify::new()),
            sweeper: std::sync::Once::new(),
        }
    }

    /// Starts (once, from inside the runtime) the task that deletes writers whose linger is over.
    fn start_sweeper(self: &Arc<Self>) {
        self.sweeper.call_once(|| {
            let me = Arc::downgrade(self);
            let retired = self.retired.clone();
            tokio::spawn(async move {
                loop {
                    retired.notified().await;
                    loop {
                        tokio::time::sleep(WRITER_LINGER).await;
                        let Some(m) = me.upgrade() else { return };
                        let mut st = m.state.lock().unwrap();
                        Self::sweep(&mut st);
                        if st.lingering.is_empty() {
                            break;
                        }
                    }
                }
            });
        });
    }

    /// Deletes the lingering writers whose time is up.
    fn sweep(st: &mut State) {
        st.lingering
            .retain(|_, (_, since)| since.elapsed() < WRITER_LINGER);
    }

    fn radar(&self) -> Result<Radar> {
        self.radar
            .upgrade()
            .ok_or_else(|| Error::Closed("the RADAR participant".into()))
    }

    /// One signal read on `topic`: deliver it. Publishing happens under the lock, so a connection removed
    /// before this takes the lock gets nothing, and one removed after got this signal already.
    fn dispatch(&self, topic: &str, raw: RawMessage, stamp: i64) {
        let mut guard = self.state.lock().unwrap();
        let st = &mut *guard;
        let filters = &st.filters;
        let deliveries = st.table.on_signal_with(&topic.to_owned(), stamp, |id| {
            filters.get(&id).is_none_or(|f| f(&raw))
        });
        for d in &deliveries {
            let payload = match st.maps.get(&d.id) {
                Some(map) => match map(&raw) {
                    Some(p) => p,
                    None => continue, // the transform warned
                },
                None => raw.clone(),
            };
            match &d.target {
                Target::Slot(slot) => {
                    if let Some(w) = st.writers.get(slot) {
                        let m = if w.empty {
                            RawMessage(vec![0])
                        } else {
                            payload
                        };
                        if let Err(e) = w.publisher.publish(m) {
                            tracing::warn!(%slot, error = %e, "could not deliver a signal");
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
        // a `once` that fired is gone: forget its properties
        for d in &deliveries {
            if !st.table.contains(d.id) {
                st.owners.remove(&d.id);
                st.filters.remove(&d.id);
                st.maps.remove(&d.id);
            }
        }
        self.prune(st);
        drop(guard);
        self.changed.send_modify(|g| *g += 1);
    }

    /// The writer `inject` uses for `slot`, made on first use.
    pub(crate) fn injector(&self, radar: &Radar, slot: &Slot) -> Result<Arc<RawPublisher>> {
        let mut st = self.state.lock().unwrap();
        if let Some(p) = st.injectors.get(&slot.topic) {
            return Ok(p.clone());
        }
        let p = Arc::new(radar.raw_publisher(&slot.topic, &slot.ros_type)?);
        st.injectors.insert(slot.topic.clone(), p.clone());
        Ok(p)
    }

    /// Every live connection, as `radar_msgs/msg/Connection`.
    pub(crate) fn list(&self) -> Vec<crate::msg::Connection> {
        let st = self.state.lock().unwrap();
        st.table
            .list()
            .into_iter()
            .map(|c| crate::msg::Connection {
                id: c.id,
                kind: match c.kind {
                    Kind::Once => crate::msg::Connection::ONCE,
                    Kind::Whenever => crate::msg::Connection::WHENEVER,
                },
                kind_label: match c.kind {
                    Kind::Once => "once".into(),
                    Kind::Whenever => "whenever".into(),
                },
                source_type: st
                    .readers
                    .get(&c.source)
                    .map(|r| r.sub.ros_type().to_owned())
                    .unwrap_or_default(),
                source: split_key(&c.source).0.to_owned(),
                depth: split_key(&c.source).1.min(u32::MAX as usize) as u32,
                target: match c.target {
                    Target::Slot(t) => split_key(&t).0.to_owned(),
                    Target::Anon(_) => "(anonymous)".into(),
                },
                until: c
                    .until
                    .map(|u| split_key(&u).0.to_owned())
                    .unwrap_or_default(),
                owner: st.owners.get(&c.id).cloned().unwrap_or_default(),
                delivered: c.delivered,
            })
            .collect()
    }

    /// Resolves at the next change of the table.
    pub(crate) fn changes(&self) -> tokio::sync::watch::Receiver<u64> {
        self.changed.subscribe()
    }

    /// Drops the readers and writers that no connection (live or arming) needs any more: an event whose only
    /// listener was a fired `once` deactivates. Looks only at what the table released, so its cost does not
    /// grow with the number of connections.
    fn prune(&self, st: &mut State) {
        let (sources, targets) = st.table.take_released();
        self.prune_keys(st, sources, targets);
    }

    /// Drops the readers of `sources` and the writers or anonymous queues of `targets` that nothing needs.
    fn prune_keys(&self, st: &mut State, sources: Vec<String>, targets: Vec<Target>) {
        for s in sources {
            if !st.table.reads(&s) && !st.pending.contains_key(&s) {
                st.readers.remove(&s);
            }
        }
        let mut retired = false;
        for t in targets {
            if st.table.writes(&t) {
                continue;
            }
            match t {
                Target::Slot(k) => {
                    if st.pending.contains_key(&k) {
                        continue;
                    }
                    if let Some(w) = st.writers.remove(&k) {
                        st.lingering.insert(k, (w, std::time::Instant::now()));
                        retired = true;
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
        if retired {
            self.retired.notify_one();
        }
    }

    fn reader(
        self: &Arc<Self>,
        radar: &Radar,
        st: &mut State,
        sig: &Signal,
        depth: usize,
    ) -> Result<Arc<RawSubscription>> {
        let key = endpoint_key(&sig.topic, depth);
        if let Some(r) = st.readers.get(&key) {
            return Ok(r.sub.clone());
        }
        let sub = Arc::new(radar.raw_subscription_depth(&sig.topic, &sig.ros_type, depth)?);
        let (stop, mut stop_rx) = tokio::sync::oneshot::channel();
        let me = Arc::downgrade(self);
        let task_sub = sub.clone();
        let topic = key.clone();
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    _ = &mut stop_rx => break,
                    r = task_sub.recv_stamped() => match (r, me.upgrade()) {
                        (Ok((raw, stamp)), Some(m)) => m.dispatch(&topic, raw, if stamp > 0 { stamp } else { now_ns() }),
                        _ => break,
                    },
                }
            }
        });
        st.readers.insert(
            key,
            Reader {
                sub: sub.clone(),
                stop: Some(stop),
            },
        );
        Ok(sub)
    }

    fn writer(
        &self,
        radar: &Radar,
        st: &mut State,
        slot: &Slot,
        depth: usize,
    ) -> Result<Arc<RawPublisher>> {
        let key = endpoint_key(&slot.topic, depth);
        if let Some(w) = st.writers.get(&key) {
            return Ok(w.publisher.clone());
        }
        if let Some((w, _)) = st.lingering.remove(&key) {
            let p = w.publisher.clone();
            st.writers.insert(key, w);
            return Ok(p);
        }
        let p = Arc::new(radar.raw_publisher_depth(&slot.topic, &slot.ros_type, depth)?);
        st.writers.insert(
            key,
            Writer {
                publisher: p.clone(),
                empty: slot.ros_type == Empty::ros_type_name(),
            },
        );
        Ok(p)
    }

    async fn arm(self: &Arc<Self>, spec: Spec) -> Result<Connection> {
        let radar = self.radar()?;
        self.start_sweeper();
        if let TargetSpec::Slot(slot) = &spec.target {
            let delivered = match &spec.mapped_type {
                Some(t) => Signal::new(spec.source.topic.clone(), t.clone()),
                None => spec.source.clone(),
            };
            check_types(&delivered, slot)?;
        }
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
        let depth = spec.depth;
        let key = |s: &Signal| endpoint_key(&s.topic, depth);
        let held: Vec<String> = sources.iter().chain(&slots).map(key).collect();
        let (readers, writers) = {
            let mut st = self.state.lock().unwrap();
            for t in &held {
                *st.pending.entry(t.clone()).or_default() += 1;
            }
            let made = (|| -> Result<_> {
                let r: Vec<_> = sources
                    .iter()
                    .map(|s| self.reader(&radar, &mut st, s, depth))
                    .collect::<Result<_>>()?;
                let w: Vec<_> = slots
                    .iter()
                    .map(|s| self.writer(&radar, &mut st, s, depth))
                    .collect::<Result<_>>()?;
                Ok((r, w))
            })();
            match made {
                Ok(x) => x,
                Err(e) => {
                    self.release(&mut st, &held);
                    return Err(e);
                }
            }
        };
        let matched = async {
            for (r, s) in readers.iter().zip(&sources) {
                r.wait_for_publishers(1, spec.timeout)
                    .await
                    .map_err(|_| Error::Timeout {
                        what: format!(
                            "a publisher of {} on {}: is the component that emits it running?",
                            s.ros_type, s.topic
                        ),
                        after: spec.timeout,
                    })?;
            }
            for (w, s) in writers.iter().zip(&slots) {
                w.wait_for_subscribers(1, spec.timeout)
                    .await
                    .map_err(|_| Error::Timeout {
                        what: format!(
                            "a subscriber of {} on {}: is the response running?",
                            s.ros_type, s.topic
                        ),
                        after: spec.timeout,
                    })?;
            }
            Ok::<(), Error>(())
        }
        .await;
        let mut st = self.state.lock().unwrap();
        if let Err(e) = matched {
            self.release(&mut st, &held);
            return Err(e);
        }
        let (target, anon) = match spec.target {
            TargetSpec::Slot(s) => (Target::Slot(key(&s)), None),
            TargetSpec::Anon(f) => {
                let k = st.next_anon;
                st.next_anon += 1;
                (Target::Anon(k), Some((k, f)))
            }
        };
        let until = spec.until.map(|u| Until {
            source: key(&u.source),
            started: key(&u.started),
            exited: key(&u.exited),
            interrupt: Target::Slot(key(&u.interrupt)),
        });
        let id = st
            .table
            .arm(key(&spec.source), target, spec.kind, until, now_ns());
        st.owners.insert(id, spec.owner);
        if let Some(f) = spec.filter {
            st.filters.insert(id, f);
        }
        if let Some(m) = spec.map {
            st.maps.insert(id, m);
        }
        if let Some((k, mut f)) = anon {
            let q = Arc::new(AnonQueue::new(
                split_key(&key(&spec.source)).0.to_owned(),
                depth,
            ));
            let consumer = q.clone();
            tokio::spawn(async move {
                while let Some(m) = consumer.next().await {
                    f(m);
                }
            });
            st.anon.insert(k, q);
        }
        self.release(&mut st, &held);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
        Ok(Connection {
            id,
            manager: self.clone(),
        })
    }

    fn release(&self, st: &mut State, held: &[String]) {
        for t in held {
            if let Some(n) = st.pending.get_mut(t) {
                *n -= 1;
                if *n == 0 {
                    st.pending.remove(t);
                }
            }
        }
        self.prune(st);
        // endpoints made for a statement that failed, or held while it armed
        let slots = held.iter().cloned().map(Target::Slot).collect();
        self.prune_keys(st, held.to_vec(), slots);
    }

    /// The guard dropped: remove the connection, and cancel anonymous-slot calls it has not begun.
    fn remove(&self, id: ConnId) {
        let mut st = self.state.lock().unwrap();
        let anon = match st.table.target(id) {
            Some(Target::Anon(k)) => Some(*k),
            _ => None,
        };
        if let Some(q) = anon.and_then(|k| st.anon.get(&k)) {
            q.cancel();
        }
        st.table.remove(id);
        st.owners.remove(&id);
        st.filters.remove(&id);
        st.maps.remove(&id);
        self.prune(&mut st);
        drop(st);
        self.changed.send_modify(|g| *g += 1);
    }
}

/// The payloads waiting for one anonymous slot: keep-last `depth`, like a ROS subscription's queue, so a
/// slow closure under a fast source costs bounded memory and sees the newest signals.
struct AnonQueue {
    source: String,
    depth: usize,
    queue: Mutex<std::collections::VecDeque<RawMessage>>,
    ready: tokio::sync::Notify,
    /// No more pushes: the consumer ends once the queue is empty.
    closed: AtomicBool,
    /// The guard dropped: the consumer ends before the next call.
    cancelled: AtomicBool,
    dropped: std::sync::atomic::AtomicU64,
}

impl AnonQueue {
    fn new(source: String, depth: usize) -> AnonQueue {
        AnonQueue {
            source,
            depth,
            queue: Mutex::new(Default::default()),
            ready: tokio::sync::Notify::new(),
            closed: AtomicBool::new(false),
            cancelled: AtomicBool::new(false),
            dropped: Default::default(),
        }
    }

    fn push(&self, m: RawMessage) {
        let mut q = self.queue.lock().unwrap();
        if q.len() >= self.depth {
            q.pop_front();
            if self.dropped.fetch_add(1, Ordering::Relaxed) == 0 {
                tracing::warn!(
                    source = %self.source, depth = self.depth,
                    "an anonymous slot is slower than its source: the oldest queued signal was dropped \
                     (keep-last {}); give the connection a larger .depth(n) to keep more", self.depth
                );
            }
        }
        q.push_back(m);
        drop(q);
        self.ready.notify_one();
    }

    fn close(&self) {
        self.closed.store(true, Ordering::SeqCst);
        self.ready.notify_one();
    }

    fn cancel(&self) {
        self.cancelled.store(true, Ordering::SeqCst);
        self.close();
    }

    /// The next payload to call the slot with; `None` when closed and drained, or cancelled.
    async fn next(&self) -> Option<RawMessage> {
        loop {
            if self.cancelled.load(Ordering::SeqCst) {
                return None;
            }
            if let Some(m) = self.queue.lock().unwrap().pop_front() {
                return Some(m);
            }
            if self.closed.load(Ordering::SeqCst) {
                return None;
            }
            // a push between the check and here left a permit, so this returns at once
            self.ready.notified().await;
        }
    }
}

fn check_types(source: &Signal, slot: &Slot) -> Result<()> {
    if slot.ros_type == Empty::ros_type_name() || slot.ros_type == source.ros_type {
        Ok(())
    } else {
        Err(Error::TypeMismatch {
            source_topic: source.topic.clone(),
            source_type: source.ros_type.clone(),
            slot_topic: slot.topic.clone(),
            slot_type: slot.ros_type.clone(),
        })
    }
}

/// A live connection. Dropping it removes the connection: once the drop returns, nothing more is delivered
/// through it (an anonymous slot already running finishes; no new call begins).
#[must_use = "a connection lives only as long as this guard; bind it (`let _c = ...`) to keep it for the scope"]
pub struct Connection {
    id: ConnId,
    manager: Arc<Manager>,
}

impl Connection {
    /// Its id in the manager's list.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Whether it still delivers (a fired `once` without `until` does not).
    pub fn is_live(&self) -> bool {
        self.manager.state.lock().unwrap().table.contains(self.id)
    }

    /// Resolves when the connection no longer delivers: a `once` (without `until`) that fired. (An anonymous
    /// slot's call for that last delivery runs in its own task and may still be running.)
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
        let st = self.manager.state.lock().unwrap();
        st.table
            .list()
            .into_iter()
            .find(|c| c.id == self.id)
            .map(|c| c.delivered)
            .unwrap_or(0)
    }
}

impl std::fmt::Debug for Connection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Connection").field("id", &self.id).finish()
    }
}

impl Drop for Connection {
    fn drop(&mut self) {
        self.manager.remove(self.id);
    }
}

enum TargetSpec {
    Slot(Slot),
    Anon(AnonFn),
}

struct UntilSpec {
    source: Signal,
    started: Signal,
    exited: Signal,
    interrupt: Slot,
}

struct Spec {
    owner: String,
    filter: Option<FilterFn>,
    map: Option<MapFn>,
    /// The payload type after `map`, if any.
    mapped_type: Option<String>,
    kind: Kind,
    source: Signal,
    target: TargetSpec,
    until: Option<UntilSpec>,
    timeout: Duration,
    /// History depth of the relay's endpoints.
    depth: usize,
}

/// `once E` / `whenever E`: pick a target with [`start`](Statement::start), [`interrupt`](Statement::interrupt),
/// [`exit`](Statement::exit) or [`call`](Statement::call).
#[must_use = "a statement does nothing until given a target and awaited"]
pub struct Statement {
    radar: Radar,
    kind: Kind,
    source: Signal,
}

/// A statement with its target; `.await` it to arm the connection.
#[must_use = "a connection is made only when this is awaited"]
pub struct Connect {
    radar: Radar,
    spec: Spec,
    response: Option<ResponseRef>,
    /// Whether the target is a response's start slot (`until` needs one).
    starts: bool,
    /// A mistake found while building the statement, reported when it is awaited.
    error: Option<Error>,
}

impl Statement {
    fn to(self, target: TargetSpec, response: Option<ResponseRef>) -> Connect {
        let starts =
            matches!((&target, &response), (TargetSpec::Slot(s), Some(r)) if *s == r.start_slot());
        Connect {
            starts,
            error: None,
            radar: self.radar,
            spec: Spec {
                owner: format!("process {}", std::process::id()),
                filter: None,
                map: None,
                mapped_type: None,
                kind: self.kind,
                source: self.source,
                target,
                until: None,
                timeout: Duration::from_secs(5),
                depth: SIGNAL_DEPTH,
            },
            response,
        }
    }
    /// `... start R`.
    pub fn start(self, r: &impl AsResponse) -> Connect {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.start_slot()), Some(r))
    }
    /// `... interrupt R`.
    pub fn interrupt(self, r: &impl AsResponse) -> Connect {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.interrupt_slot()), Some(r))
    }
    /// `... exit R`.
    pub fn exit(self, r: &impl AsResponse) -> Connect {
        let r = r.response_ref();
        self.to(TargetSpec::Slot(r.exit_slot()), Some(r))
    }
    /// `... slot`: any slot topic with its type.
    pub fn slot(self, slot: Slot) -> Connect {
        self.to(TargetSpec::Slot(slot), None)
    }
    /// An anonymous slot: `f` runs with each delivered payload, decoded as `M` (the source's type, or
    /// `std_msgs/msg/Empty` to ignore the payload).
    pub fn call<M: RosMessage>(self, mut f: impl FnMut(M) + Send + 'static) -> Connect {
        let topic = self.source.topic.clone();
        let ty = M::ros_type_name();
        let error = (ty != self.source.ros_type && ty != Empty::ros_type_name()).then(|| {
            Error::TypeMismatch {
                source_topic: self.source.topic.clone(),
                source_type: self.source.ros_type.clone(),
                slot_topic: "(anonymous slot)".into(),
                slot_type: ty.clone(),
            }
        });
        let empty = ty == Empty::ros_type_name();
        let mut c = self.to(
            TargetSpec::Anon(Box::new(move |raw: RawMessage| {
                let decoded = if empty { Ok(M::default()) } else { raw.decode::<M>() };
                match decoded {
                    Ok(m) => f(m),
                    Err(e) => tracing::warn!(%topic, error = %e, "anonymous slot: payload does not decode"),
                }
            })),
            None,
        );
        c.error = error;
        c
    }
}

impl Connect {
    /// `... until U`: U's signals interrupt R while a run this statement started is in progress (see
    /// [`crate::semantics::connection`]). Only for `start` targets.
    pub fn until(mut self, u: Signal) -> Connect {
        match (&self.response, self.starts) {
            (Some(r), true) => {
                self.spec.until = Some(UntilSpec {
                    source: u,
                    started: r.started(),
                    exited: r.exited(),
                    interrupt: r.interrupt_slot(),
                })
            }
            _ => {
                self.error.get_or_insert(Error::InvalidStatement(
                    "`until` goes with a `start` target: once E start R until U".into(),
                ));
            }
        }
        self
    }
    /// Records who asked for the connection (shown in the manager's `connections` list).
    pub(crate) fn owner(mut self, owner: String) -> Connect {
        self.spec.owner = owner;
        self
    }

    /// Connection property: deliver only the signals whose payload (decoded as the source's type `M`)
    /// satisfies `f`. A refused signal does not use up a `once`.
    pub fn filter<M: RosMessage>(
        mut self,
        f: impl Fn(&M) -> bool + Send + Sync + 'static,
    ) -> Connect {
        if M::ros_type_name() != self.spec.source.ros_type {
            self.error
                .get_or_insert(self.source_type_error::<M>("filter"));
            return self;
        }
        let topic = self.spec.source.topic.clone();
        self.spec.filter = Some(Arc::new(move |raw: &RawMessage| match raw.decode::<M>() {
            Ok(m) => f(&m),
            Err(e) => {
                tracing::warn!(%topic, error = %e, "filter: payload does not decode; not delivered");
                false
            }
        }));
        self
    }

    /// Connection property: deliver `f(payload)` instead of the payload; the slot must take `N`.
    pub fn map<M: RosMessage, N: RosMessage>(
        mut self,
        f: impl Fn(M) -> N + Send + Sync + 'static,
    ) -> Connect {
        if M::ros_type_name() != self.spec.source.ros_type {
            self.error.get_or_insert(self.source_type_error::<M>("map"));
            return self;
        }
        let topic = self.spec.source.topic.clone();
        self.spec.mapped_type = Some(N::ros_type_name());
        self.spec.map = Some(Arc::new(move |raw: &RawMessage| {
            let m = raw
                .decode::<M>()
                .map_err(|e| tracing::warn!(%topic, error = %e, "map: payload does not decode; not delivered"))
                .ok()?;
            RawMessage::encode(&f(m))
                .map_err(|e| tracing::warn!(%topic, error = %e, "map: result does not encode; not delivered"))
                .ok()
        }));
        self
    }

    fn source_type_error<M: RosMessage>(&self, what: &str) -> Error {
        Error::TypeMismatch {
            source_topic: self.spec.source.topic.clone(),
            source_type: self.spec.source.ros_type.clone(),
            slot_topic: format!("({what} closure)"),
            slot_type: M::ros_type_name(),
        }
    }

    /// Connection property: the history depth of the relay (default 10, as rclpy's): how many signals
    /// the relay's reader queues while the manager has not taken them, and its writer keeps for
    /// retransmission to a slow or lossy target. Connections asking for a depth other than the default get
    /// a reader and writer of their own (shared with connections asking for the same depth). At least 1.
    pub fn depth(mut self, depth: usize) -> Connect {
        if depth == 0 {
            self.error.get_or_insert(Error::InvalidStatement(
                "a connection's QoS depth must be at least 1 (the default is 10)".into(),
            ));
        }
        self.spec.depth = depth.max(1);
        self
    }

    /// How long arming may wait for discovery (default 5 s).
    pub fn timeout(mut self, d: Duration) -> Connect {
        self.spec.timeout = d;
        self
    }
}

impl IntoFuture for Connect {
    type Output = Result<Connection>;
    type IntoFuture = Pin<Box<dyn Future<Output = Result<Connection>> + Send>>;
    fn into_future(self) -> Self::IntoFuture {
        Box::pin(async move {
            if let Some(e) = self.error {
                return Err(e);
            }
            self.radar.manager().arm(self.spec).await
        })
    }
}

impl Radar {
    /// `once source ...`: the connection delivers one signal.
    pub fn once(&self, source: Signal) -> Statement {
        Statement {
            radar: self.clone(),
            kind: Kind::Once,
            source,
        }
    }

    /// `whenever source ...`: the connection delivers every signal while it lives.
    pub fn whenever(&self, source: Signal) -> Statement {
        Statement {
            radar: self.clone(),
            kind: Kind::Whenever,
            source,
        }
    }

    /// Every live connection of this program's embedded manager (what a served manager lists on its
    /// `connections` topic).
    pub fn connections(&self) -> Vec<crate::msg::Connection> {
        self.manager().list()
    }

    /// `waitfor source`: the payload of the next signal emitted after this call, decoded as `M`; with a
    /// timeout, fails with [`Error::Timeout`] after it.
    pub async fn waitfor<M: RosMessage>(
        &self,
        source: Signal,
        timeout: Option<Duration>,
    ) -> Result<M> {
        let (tx, rx) = tokio::sync::oneshot::channel();
        let mut tx = Some(tx);
        let what = format!("a signal on {}", source.topic);
        let arm_timeout = timeout.unwrap_or(Duration::from_secs(5));
        let start = tokio::time::Instant::now();
        let _c = self
            .once(source)
            .call(move |m: M| {
                if let Some(tx) = tx.take() {
                    let _ = tx.send(m);
                }
            })
            .timeout(arm_timeout)
            .await?;
        let wait = async { rx.await.map_err(|_| Error::Closed(what.clone())) };
        match timeout {
            None => wait.await,
            Some(t) => {
                let left = t.saturating_sub(start.elapsed());
                tokio::time::timeout(left, wait)
                    .await
                    .map_err(|_| Error::Timeout {
                        what: what.clone(),
                        after: t,
                    })?
            }
        }
    }

    /// Sends `payload` into a slot directly (the paper's `rtinject`): waits up to `timeout` for the slot's
    /// subscriber, then publishes once. The writer is kept for later injections into the same slot.
    pub async fn inject<M: RosMessage>(
        &self,
        slot: Slot,
        payload: M,
        timeout: Duration,
    ) -> Result<()> {
        if slot.ros_type != M::ros_type_name() {
            return Err(Error::TypeMismatch {
                source_topic: "(injected payload)".into(),
                source_type: M::ros_type_name(),
                slot_topic: slot.topic,
                slot_type: slot.ros_type,
            });
        }
        // one writer per slot, kept: a writer deleted right after publishing can lose its sample in flight
        let p = self.manager().injector(self, &slot)?;
        p.wait_for_subscribers(1, timeout).await?;
        p.publish(RawMessage::encode(&payload)?)
    }
}
