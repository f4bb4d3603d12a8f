//! In-process delivery: the signals and slots of this participant's components, reachable without a DDS hop.
//!
//! **Slots.** A response registers each of its slot topics here ([`Inlets::open`]) and reads what arrives on the returned
//! [`Inbox`] beside its DDS readers. The embedded manager, arming a statement whose target slot is one of
//! these (same topic, same type), delivers through the [`Inlet`] instead of a DDS writer: one hop (the
//! source's) instead of two. The inlet outlives the response that opened it, so a connection that holds it
//! sees the response leave (its presence drops to 0) and a response of the same name come back (1 again),
//! as it sees DDS subscribers leave and come back.
//!
//! **Signals.** An event's `triggered` and a response's `started`, `interrupted` and `exited` writers open a
//! [`Tap`] on their topic and hand each signal to it before writing it. The manager's relay for that topic
//! listens to the tap (its listener runs in the emitting task, with the time of emission, before the DDS
//! write); samples of other publishers (another process, `ros2 topic pub`) still come over DDS. The relay keeps its
//! DDS reader either way: it is what the event counts as a listener, what arming waits for and what tells the
//! connection its source left. The signal writers and the relays' readers are made [`marked`], so such a writer
//! sends such a reader of this participant nothing over DDS (RustDDS patch 62); a pair matched otherwise (a
//! writer made elsewhere) still is, and the relay skips the DDS samples of the writers the tap names. A
//! listener gets what is emitted from the moment it began to listen ([`TapListener::since`], by the source
//! time the DDS samples carry); what a writer of this process emits while a statement arms (its reader, made
//! first, may activate an event) is kept for it from before its reader is made ([`Buffered`]) and handed to
//! the table once the statement is in it, so each signal reaches the relay exactly once.

use std::{
    collections::HashMap,
    sync::{Arc, Mutex, Weak},
    time::{Duration, Instant},
};

use radar_semantics::response::{Cause, Sent};
use ros2_client::dds::rustdds::GUID;
use tokio::sync::{mpsc, watch};

use crate::wire::raw::RawMessage;

/// What an inbox receives: a message, and when and by which statement it was sent.
type Delivered = (RawMessage, Sent);

/// One slot topic of this process.
pub(crate) struct Inlet {
    /// The open inbox's type and sender, while a response reads it.
    // boxed: a tokio channel allocates its slots 32 at a time, so each slot of each response held 32 of these
    // from the start (12 KiB per response; boxed, about 1 KiB)
    open: Mutex<Option<(String, mpsc::UnboundedSender<Box<Delivered>>)>>,
    /// 1 while a response reads it, 0 otherwise: the peer count a connection watches.
    present: watch::Sender<usize>,
}

impl Inlet {
    /// Hands `m`, sent as `sent`, to the response reading the slot if it reads `ros_type` (else it is dropped,
    /// as a DDS sample with no reader is). Returns whether it was handed over.
    pub(crate) fn deliver(&self, ros_type: &str, m: RawMessage, sent: Sent) -> bool {
        match &*self.open.lock().unwrap() {
            Some((t, tx)) if t == ros_type => tx.send(Box::new((m, sent))).is_ok(),
            _ => false,
        }
    }

    /// Whether a response of this process reads the slot now with `ros_type`.
    pub(crate) fn reads(&self, ros_type: &str) -> bool {
        matches!(&*self.open.lock().unwrap(), Some((t, _)) if t == ros_type)
    }

    /// 1 while a response reads the slot, 0 otherwise.
    pub(crate) fn presence(&self) -> watch::Receiver<usize> {
        self.present.subscribe()
    }
}

/// The slot topics of this process's responses. An entry lives while a response reads the slot or a
/// connection holds it, and goes with the last of them (nothing is kept for names that have gone).
#[derive(Default)]
pub(crate) struct Inlets(Mutex<HashMap<String, Arc<Inlet>>>);

impl Inlets {
    fn entry(&self, topic: &str) -> Arc<Inlet> {
        self.0
            .lock()
            .unwrap()
            .entry(topic.to_owned())
            .or_insert_with(|| {
                Arc::new(Inlet {
                    open: Mutex::new(None),
                    present: watch::channel(0).0,
                })
            })
            .clone()
    }

    /// Opens the slot `topic` of type `ros_type` for a response (component names are unique in a process, so
    /// one response at a time opens a topic). Closed when the inbox is dropped.
    pub(crate) fn open(self: &Arc<Self>, topic: &str, ros_type: &str) -> Inbox {
        let inlet = self.entry(topic);
        let (tx, rx) = mpsc::unbounded_channel();
        *inlet.open.lock().unwrap() = Some((ros_type.to_owned(), tx));
        inlet.present.send_replace(1);
        Inbox {
            rx,
            inlet,
            topic: topic.to_owned(),
            inlets: Arc::downgrade(self),
        }
    }

    /// The slot `topic`, for a connection that delivers to it whenever a response of this process reads it
    /// (and watches it come and go). Let go of it with [`Inlets::release`].
    pub(crate) fn hold(&self, topic: &str) -> Arc<Inlet> {
        self.entry(topic)
    }

    /// The slot `topic` if a response of this process reads it now with type `ros_type`.
    pub(crate) fn find(&self, topic: &str, ros_type: &str) -> Option<Arc<Inlet>> {
        let inlet = self.0.lock().unwrap().get(topic)?.clone();
        inlet.reads(ros_type).then_some(inlet)
    }

    /// Forgets `topic` if no response reads it and nothing but this map holds it.
    pub(crate) fn release(&self, topic: &str) {
        let mut map = self.0.lock().unwrap();
        if let Some(i) = map.get(topic) {
            if Arc::strong_count(i) == 1 && i.open.lock().unwrap().is_none() {
                map.remove(topic);
            }
        }
    }

    /// How many slot topics are known.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.0.lock().unwrap().len()
    }
}

/// How long the writers of components that have gone stay known on a tap: their last samples may still come
/// over DDS (repaired by a peer's negative acknowledgement, say), and those must be skipped; far longer than
/// a writer lingers after its component goes (3 s) plus any repair.
const GONE_WRITERS_KEPT: Duration = Duration::from_secs(10);

/// One signal topic and type of this process, as emitted by its components.
#[derive(Default)]
pub(crate) struct Tap {
    /// Every writer of this process that emits on the topic, and since when the gone ones are gone.
    writers: Mutex<HashMap<GUID, Option<Instant>>>,
    /// The relays listening, each while its token lives, with the source time from which it gets signals here.
    listeners: Mutex<Vec<Listening>>,
}

struct Listening {
    token: Weak<()>,
    since: i64,
    f: Listener,
}

/// A relay's listening on a tap: it lasts while this lives.
pub(crate) struct TapListener {
    _token: Arc<()>,
    since: i64,
}

impl TapListener {
    /// The source time (as DDS samples carry it) from which the listener gets this process's signals through
    /// the tap; the DDS samples of this process's writers stamped before it did not come through the tap.
    pub(crate) fn since(&self) -> i64 {
        self.since
    }
}

/// A signal as a tap hands it over: the message, its time of emission (as the DDS sample carries it) and its
/// cause.
pub(crate) type Emitted = (RawMessage, i64, Option<Cause>);

/// What a tap gave while a statement armed (C1 with local delivery): a relay's DDS reader is sent nothing by
/// this process's signal writers (RustDDS patch 62), so what they emit from before the reader is made until
/// the relay listens must be kept here, as the reader would have kept it.
pub(crate) struct Buffered {
    listener: TapListener,
    kept: Arc<Mutex<Kept>>,
}

/// What a [`Buffered`] does with what the tap hands it.
enum Kept {
    /// Keeps the last `depth` of it.
    Keeping(std::collections::VecDeque<Emitted>, usize),
    /// Hands what was emitted before `until` to `to` (a signal the tap had already handed over when the
    /// buffer was emptied, whose listener call came after), and drops the rest (the relay got it itself).
    Forwarding { until: i64, to: Listener },
}

impl Buffered {
    /// From when it kept what was emitted (see [`TapListener::since`]).
    pub(crate) fn since(&self) -> i64 {
        self.listener.since()
    }

    /// What it kept that was emitted before `until` (a relay that listens from `until` gets the rest itself),
    /// in order of emission; from now on, a signal emitted before `until` whose hand-over was still under way
    /// (the tap calls its listeners outside its lock) goes to `late`.
    pub(crate) fn before(self, until: i64, late: Listener) -> Vec<Emitted> {
        let kept = std::mem::replace(
            &mut *self.kept.lock().unwrap(),
            Kept::Forwarding { until, to: late },
        );
        drop(self.listener);
        let Kept::Keeping(got, _) = kept else {
            return Vec::new();
        };
        // two emitters may have handed theirs over out of order
        let mut got: Vec<Emitted> = got.into_iter().filter(|(_, at, _)| *at < until).collect();
        got.sort_by_key(|(_, at, _)| *at);
        got
    }
}

/// Called with each signal emitted on a tap, its time of emission (ns since the epoch) and its cause, in the
/// emitting task: it must not block.
pub(crate) type Listener = Arc<dyn Fn(&RawMessage, i64, Option<Cause>) + Send + Sync>;

impl Tap {
    /// Stamps `m` now (carrying `cause`) and hands it to every relay listening since that stamp, in this
    /// task; encodes it once, and only if one listens. Returns the time of emission, to be written with the
    /// DDS sample. (The stamp is taken under the tap's lock, so a signal a listener does not get here is
    /// stamped before it listened and comes to it over DDS; the listeners are called outside the lock: a
    /// relay is made under its manager's lock, and a listener takes that lock.)
    pub(crate) fn emit<M: serde::Serialize>(&self, m: &M, cause: Option<Cause>) -> i64 {
        let (at, stamp, listeners) = {
            let mut l = self.listeners.lock().unwrap();
            let at = now_ns();
            let stamp = crate::wire::cause::on_wire(at);
            l.retain(|x| x.token.strong_count() > 0);
            let fs: Vec<Listener> = l
                .iter()
                .filter(|x| x.since <= stamp)
                .map(|x| x.f.clone())
                .collect();
            (at, stamp, fs)
        };
        if listeners.is_empty() {
            return at;
        }
        match RawMessage::encode(m) {
            Ok(raw) => {
                for l in listeners {
                    l(&raw, stamp, cause);
                }
            }
            Err(e) => {
                tracing::warn!(error = %crate::error::Report(&e), "a signal did not encode for this process's connections")
            }
        }
        at
    }

    /// Calls `f` with what the components of this process emit here from now on, while the returned
    /// listener lives.
    pub(crate) fn listen(&self, f: Listener) -> TapListener {
        let token = Arc::new(());
        let mut l = self.listeners.lock().unwrap();
        // after every stamp taken before (stamps are taken under this lock; the wire rounds them)
        let since = crate::wire::cause::on_wire(now_ns()) + 1;
        l.push(Listening {
            token: Arc::downgrade(&token),
            since,
            f,
        });
        TapListener {
            _token: token,
            since,
        }
    }

    /// Keeps what the components of this process emit here from now on (the last `depth` of it, as a DDS
    /// reader of that depth would), for a statement that arms a relay of this topic: see [`Buffered`].
    pub(crate) fn buffer(&self, depth: usize) -> Buffered {
        let kept = Arc::new(Mutex::new(Kept::Keeping(Default::default(), depth.max(1))));
        let k = kept.clone();
        let listener = self.listen(Arc::new(move |raw: &RawMessage, at, by| {
            let mut k = k.lock().unwrap();
            match &mut *k {
                Kept::Keeping(q, depth) => {
                    if q.len() == *depth {
                        q.pop_front();
                    }
                    q.push_back((raw.clone(), at, by));
                }
                Kept::Forwarding { until, to } if at < *until => {
                    let to = to.clone();
                    drop(k);
                    to(raw, at, by);
                }
                Kept::Forwarding { .. } => {}
            }
        }));
        Buffered { listener, kept }
    }

    /// Whether a component of this process emits on the topic now.
    pub(crate) fn has_emitters(&self) -> bool {
        self.writers.lock().unwrap().values().any(Option::is_none)
    }

    /// The writer `w` of a component that emitted here is gone (it stays known a while: its last samples may
    /// still come over DDS).
    fn close(&self, w: GUID) {
        if let Some(gone) = self.writers.lock().unwrap().get_mut(&w) {
            *gone = Some(Instant::now());
        }
    }

    /// Whether the DDS writer `gid` is one of this process's on the topic (its samples came through the tap).
    pub(crate) fn is_local(&self, gid: ros2_client::Gid) -> bool {
        self.writers.lock().unwrap().contains_key(&GUID::from(gid))
    }

    /// Forgets writers gone longer than [`GONE_WRITERS_KEPT`]; whether the tap is of no more use (no writer,
    /// no listener).
    fn prune(&self) -> bool {
        let mut w = self.writers.lock().unwrap();
        w.retain(|_, gone| gone.is_none_or(|t| t.elapsed() < GONE_WRITERS_KEPT));
        let mut l = self.listeners.lock().unwrap();
        l.retain(|x| x.token.strong_count() > 0);
        w.is_empty() && l.is_empty()
    }
}

/// The signal topics of this process, by topic and type. A tap lives while a component emits on it, a relay
/// listens to it, or the writers of gone components may still have samples in flight.
#[derive(Default)]
pub(crate) struct Taps(Mutex<HashMap<(String, String), Arc<Tap>>>);

impl Taps {
    /// The tap of `topic` and `ros_type`, made on first use.
    pub(crate) fn get(&self, topic: &str, ros_type: &str) -> Arc<Tap> {
        let mut map = self.0.lock().unwrap();
        // the taps no longer of use go as new ones come (what a process makes is what it prunes)
        if map.len() >= 64 && map.len().is_power_of_two() {
            map.retain(|_, t| Arc::strong_count(t) > 1 || !t.prune());
        }
        map.entry((topic.to_owned(), ros_type.to_owned()))
            .or_default()
            .clone()
    }

    /// The tap of `topic` and `ros_type` if there is one, without making it.
    pub(crate) fn find(&self, topic: &str, ros_type: &str) -> Option<Arc<Tap>> {
        self.0
            .lock()
            .unwrap()
            .get(&(topic.to_owned(), ros_type.to_owned()))
            .cloned()
    }

    /// The tap for the DDS writer `writer` of a component of this process, before it emits anything; the
    /// writer is known there until the returned guard is dropped, and a while after.
    pub(crate) fn open(&self, topic: &str, ros_type: &str, writer: GUID) -> TapWriter {
        let tap = self.get(topic, ros_type);
        tap.writers.lock().unwrap().insert(writer, None);
        TapWriter { tap, writer }
    }

    /// Forgets the taps of no more use (see [`Tap`]); returns how many are left.
    #[cfg(test)]
    fn prune(&self) -> usize {
        let mut map = self.0.lock().unwrap();
        map.retain(|_, t| Arc::strong_count(t) > 1 || !t.prune());
        map.len()
    }
}

/// A component's writer on a tap: the tap hands what it emits to this process's relays.
pub(crate) struct TapWriter {
    tap: Arc<Tap>,
    writer: GUID,
}

impl TapWriter {
    /// See [`Tap::emit`].
    pub(crate) fn emit<M: serde::Serialize>(&self, m: &M, cause: Option<Cause>) -> i64 {
        self.tap.emit(m, cause)
    }
}

impl Drop for TapWriter {
    fn drop(&mut self) {
        self.tap.close(self.writer);
    }
}

/// Runs `make`, which makes a signal writer of a component (whose every sample it hands to its tap) or a relay's
/// reader (which takes this process's signals from the taps): marked as they are made, before discovery can
/// match them, such writers send such readers of this participant nothing over DDS (RustDDS patch 62). A
/// pair matched otherwise (a writer made elsewhere) is sent over DDS and the relay skips it.
pub(crate) fn marked<R>(make: impl FnOnce() -> R) -> R {
    ros2_client::dds::rustdds::local_delivery::marking(make)
}

/// Now, in ns since the epoch (the clock of DDS source timestamps).
pub(crate) fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as i64)
        .unwrap_or(0)
}

/// What a response receives on one slot from this process's connections.
pub(crate) struct Inbox {
    rx: mpsc::UnboundedReceiver<Box<Delivered>>,
    inlet: Arc<Inlet>,
    topic: String,
    inlets: Weak<Inlets>,
}

impl Inbox {
    /// The messages with how they were sent, in delivery order.
    pub(crate) fn stream(&mut self) -> impl futures::Stream<Item = Delivered> + '_ {
        futures::stream::poll_fn(|cx| self.rx.poll_recv(cx).map(|d| d.map(|d| *d)))
    }
}

impl Drop for Inbox {
    fn drop(&mut self) {
        *self.inlet.open.lock().unwrap() = None;
        self.inlet.present.send_replace(0);
        if let Some(inlets) = self.inlets.upgrade() {
            let topic = std::mem::take(&mut self.topic);
            // this inbox's own hold goes first
            let inlet = std::mem::replace(
                &mut self.inlet,
                Arc::new(Inlet {
                    open: Mutex::new(None),
                    present: watch::channel(0).0,
                }),
            );
            drop(inlet);
            inlets.release(&topic);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_inlet_delivers_while_its_inbox_is_open_and_shows_presence() {
        let inlets = Arc::new(Inlets::default());
        assert!(inlets.find("/r/start", "std_msgs/msg/Empty").is_none());
        let mut inbox = inlets.open("/r/start", "std_msgs/msg/Empty");
        assert!(
            inlets.find("/r/start", "std_msgs/msg/String").is_none(),
            "another type is not this slot"
        );
        let inlet = inlets.find("/r/start", "std_msgs/msg/Empty").unwrap();
        let presence = inlet.presence();
        assert_eq!(*presence.borrow(), 1);
        let e = "std_msgs/msg/Empty";
        assert!(inlet.deliver(e, RawMessage::from_bytes(vec![0]), Sent::at(5)));
        assert_eq!(
            *inbox.rx.try_recv().unwrap(),
            (RawMessage::from_bytes(vec![0]), Sent::at(5))
        );
        assert!(
            !inlet.deliver(
                "std_msgs/msg/String",
                RawMessage::from_bytes(vec![0]),
                Sent::at(6)
            ),
            "a response of another start type does not get it"
        );
        drop(inbox);
        assert_eq!(*presence.borrow(), 0);
        assert!(
            !inlet.deliver(e, RawMessage::from_bytes(vec![0]), Sent::at(7)),
            "nobody reads it now"
        );
        assert!(inlets.find("/r/start", e).is_none());
        // a connection held it: a response of the same name comes back to the same inlet, present again
        let _again = inlets.open("/r/start", e);
        assert_eq!(*presence.borrow(), 1);
        assert!(inlet.deliver(e, RawMessage::from_bytes(vec![0]), Sent::at(8)));
    }

    #[test]
    fn b12_slot_topics_are_forgotten_when_nothing_reads_or_holds_them() {
        let inlets = Arc::new(Inlets::default());
        for i in 0..100 {
            let inbox = inlets.open(&format!("/r{i}/start"), "std_msgs/msg/Empty");
            drop(inbox);
        }
        assert_eq!(
            inlets.len(),
            0,
            "responses that came and went leave nothing"
        );
        let held = inlets.hold("/kept/start");
        let inbox = inlets.open("/kept/start", "std_msgs/msg/Empty");
        drop(inbox);
        assert_eq!(inlets.len(), 1, "a connection still holds it");
        drop(held);
        inlets.release("/kept/start");
        assert_eq!(inlets.len(), 0);
    }

    #[test]
    fn a_tap_hands_signals_to_its_listeners_and_names_its_writers() {
        let taps = Taps::default();
        let w = GUID::new_participant_guid();
        let tap = taps.open("/e/triggered", "std_msgs/msg/Int32", w);
        // nobody listens: nothing encoded, nothing kept
        let before = tap.emit(&crate::wire::msg::Int32 { data: 1 }, None);
        let got: Arc<Mutex<Vec<(RawMessage, i64)>>> = Default::default();
        let g = got.clone();
        let listener = taps
            .get("/e/triggered", "std_msgs/msg/Int32")
            .listen(Arc::new(move |raw, stamp, _| {
                g.lock().unwrap().push((raw.clone(), stamp))
            }));
        assert!(
            crate::wire::cause::on_wire(before) < listener.since(),
            "what was emitted before listening is older than the listener (it comes over DDS)"
        );
        let at = tap.emit(&crate::wire::msg::Int32 { data: 7 }, None);
        {
            let got = got.lock().unwrap();
            assert_eq!(got.len(), 1, "only what came after listening");
            assert_eq!(
                got[0].0.decode::<crate::wire::msg::Int32>().unwrap().data,
                7
            );
            assert_eq!(
                got[0].1,
                crate::wire::cause::on_wire(at),
                "the stamp DDS carries"
            );
            assert!(got[0].1 >= listener.since(), "its DDS sample is skipped");
        }
        drop(listener);
        tap.emit(&crate::wire::msg::Int32 { data: 8 }, None);
        assert_eq!(
            got.lock().unwrap().len(),
            1,
            "nothing once the listener is gone"
        );
        assert!(taps
            .get("/e/triggered", "std_msgs/msg/Int32")
            .is_local(ros2_client::Gid::from(w)));
        assert!(
            !taps
                .get("/e/triggered", "std_msgs/msg/String")
                .is_local(ros2_client::Gid::from(w)),
            "another type is another tap"
        );
    }

    /// A signal emitted while a listener registers, from another thread, reaches it exactly once: through the
    /// tap when stamped at or after [`TapListener::since`], else over DDS (the relay takes a DDS sample of
    /// this process's writer only when stamped before it). 2,000 rounds, no pause.
    #[test]
    fn each_signal_emitted_while_a_listener_registers_is_taken_one_way_exactly() {
        let taps = Arc::new(Taps::default());
        let w = GUID::new_participant_guid();
        let tap = Arc::new(taps.open("/race/triggered", "std_msgs/msg/Int32", w));
        for round in 0..2_000 {
            let emitter = {
                let tap = tap.clone();
                std::thread::spawn(move || {
                    (0..4)
                        .map(|i| tap.emit(&crate::wire::msg::Int32 { data: i }, None))
                        .collect::<Vec<i64>>()
                })
            };
            let got: Arc<Mutex<Vec<i64>>> = Default::default();
            let g = got.clone();
            let listener = taps
                .get("/race/triggered", "std_msgs/msg/Int32")
                .listen(Arc::new(move |_, stamp, _| g.lock().unwrap().push(stamp)));
            let stamps = emitter.join().unwrap();
            let got = got.lock().unwrap();
            for at in stamps {
                let wire = crate::wire::cause::on_wire(at);
                let by_tap = got.contains(&wire);
                let by_dds = wire < listener.since();
                assert!(
                    by_tap != by_dds,
                    "round {round}: stamp {wire} since {}: tap {by_tap}, dds {by_dds}",
                    listener.since()
                );
            }
        }
    }

    /// C1 with local delivery: a signal emitted from another thread while a statement's buffer is made, then
    /// handed over to its relay, reaches the relay exactly once if it was emitted after the buffer began:
    /// kept (then replayed), handed over late (its listener call came after the buffer was emptied), or taken
    /// by the relay's own listener; none if emitted before. 10,000 rounds, no pause.
    #[test]
    fn each_signal_emitted_while_a_statement_arms_reaches_its_relay_exactly_once() {
        let taps = Arc::new(Taps::default());
        let w = GUID::new_participant_guid();
        let tap = Arc::new(taps.open("/arm/triggered", "std_msgs/msg/Int32", w));
        let source = taps.get("/arm/triggered", "std_msgs/msg/Int32");
        for round in 0..10_000 {
            let emitter = {
                let tap = tap.clone();
                std::thread::spawn(move || {
                    (0..6)
                        .map(|i| {
                            crate::wire::cause::on_wire(
                                tap.emit(&crate::wire::msg::Int32 { data: i }, None),
                            )
                        })
                        .collect::<Vec<i64>>()
                })
            };
            let buffered = source.buffer(64);
            let begun = buffered.since();
            let got: Arc<Mutex<Vec<i64>>> = Default::default();
            let (live_got, late_got) = (got.clone(), got.clone());
            let relay = source.listen(Arc::new(move |_, at, _| live_got.lock().unwrap().push(at)));
            let kept = buffered.before(
                relay.since(),
                Arc::new(move |_, at, _| late_got.lock().unwrap().push(at)),
            );
            let stamps = emitter.join().unwrap();
            let mut all: Vec<i64> = kept.iter().map(|(_, at, _)| *at).collect();
            all.extend(got.lock().unwrap().iter());
            for at in stamps {
                let n = all.iter().filter(|x| **x == at).count();
                let want = usize::from(at >= begun);
                assert_eq!(
                    n,
                    want,
                    "round {round}: stamp {at}, buffer from {begun}, relay from {}",
                    relay.since()
                );
            }
        }
    }

    #[test]
    fn b12_taps_of_gone_components_are_forgotten() {
        let taps = Taps::default();
        for i in 0..100 {
            let w = taps.open(
                &format!("/e{i}/triggered"),
                "std_msgs/msg/Empty",
                GUID::new_participant_guid(),
            );
            drop(w);
        }
        // the writers of gone components stay known for a while ...
        assert_eq!(taps.prune(), 100);
        // ... then go
        for t in taps.0.lock().unwrap().values() {
            for gone in t.writers.lock().unwrap().values_mut() {
                *gone = Some(Instant::now() - GONE_WRITERS_KEPT);
            }
        }
        assert_eq!(taps.prune(), 0);
    }
}
