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
//! write) and skips the DDS samples of the writers the tap names, which it already has; samples of other publishers (another
//! process, `ros2 topic pub`) still come over DDS. The relay keeps its DDS reader either way: it is what the
//! event counts as a listener.

use std::{
    collections::{HashMap, HashSet},
    sync::{Arc, Mutex, Weak},
};

use ros2_client::dds::rustdds::GUID;
use tokio::sync::{mpsc, watch};

use crate::raw::RawMessage;

/// One slot topic of this process.
pub(crate) struct Inlet {
    /// The open inbox's type and sender, while a response reads it.
    open: Mutex<Option<(String, mpsc::UnboundedSender<RawMessage>)>>,
    /// 1 while a response reads it, 0 otherwise: the peer count a connection watches.
    present: watch::Sender<usize>,
}

impl Inlet {
    /// Hands `m` to the response reading the slot, if one does (else it is dropped, as a DDS sample with no
    /// reader is). Returns whether it was handed over.
    pub(crate) fn deliver(&self, m: RawMessage) -> bool {
        match &*self.open.lock().unwrap() {
            Some((_, tx)) => tx.send(m).is_ok(),
            None => false,
        }
    }

    /// 1 while a response reads the slot, 0 otherwise.
    pub(crate) fn presence(&self) -> watch::Receiver<usize> {
        self.present.subscribe()
    }
}

/// The slot topics of this process's responses.
#[derive(Default)]
pub(crate) struct Inlets(Mutex<HashMap<String, Arc<Inlet>>>);

impl Inlets {
    /// Opens the slot `topic` of type `ros_type` for a response (component names are unique in a process, so
    /// one response at a time opens a topic). Closed when the inbox is dropped.
    pub(crate) fn open(&self, topic: &str, ros_type: &str) -> Inbox {
        let inlet = self
            .0
            .lock()
            .unwrap()
            .entry(topic.to_owned())
            .or_insert_with(|| {
                Arc::new(Inlet {
                    open: Mutex::new(None),
                    present: watch::channel(0).0,
                })
            })
            .clone();
        let (tx, rx) = mpsc::unbounded_channel();
        *inlet.open.lock().unwrap() = Some((ros_type.to_owned(), tx));
        inlet.present.send_replace(1);
        Inbox { rx, inlet }
    }

    /// The slot `topic` if a response of this process reads it now with type `ros_type`.
    pub(crate) fn find(&self, topic: &str, ros_type: &str) -> Option<Arc<Inlet>> {
        let inlet = self.0.lock().unwrap().get(topic)?.clone();
        let open = matches!(&*inlet.open.lock().unwrap(), Some((t, _)) if t == ros_type);
        open.then_some(inlet)
    }
}

/// One signal topic and type of this process, as emitted by its components.
#[derive(Default)]
pub(crate) struct Tap {
    /// Every writer of this process that has emitted on the topic (kept after it goes: its last samples may
    /// still be in flight over DDS).
    writers: Mutex<HashSet<GUID>>,
    /// Writers of this process on the topic now.
    live: std::sync::atomic::AtomicUsize,
    /// The relays listening, each while its token lives.
    listeners: Mutex<Vec<(Weak<()>, Listener)>>,
}

/// Called with each signal emitted on a tap and its time of emission (ns since the epoch), in the emitting
/// task: it must not block.
pub(crate) type Listener = Arc<dyn Fn(&RawMessage, i64) + Send + Sync>;

impl Tap {
    /// Hands `m` to every relay listening, in this task; encodes it once, and only if one listens. (The
    /// listeners are called outside the tap's lock: a relay is made under its manager's lock, and a listener
    /// takes that lock.)
    pub(crate) fn emit<M: serde::Serialize>(&self, m: &M) {
        let listeners: Vec<Listener> = {
            let mut l = self.listeners.lock().unwrap();
            l.retain(|(token, _)| token.strong_count() > 0);
            l.iter().map(|(_, f)| f.clone()).collect()
        };
        if listeners.is_empty() {
            return;
        }
        let stamp = now_ns();
        match RawMessage::encode(m) {
            Ok(raw) => {
                for l in listeners {
                    l(&raw, stamp);
                }
            }
            Err(e) => {
                tracing::warn!(error = %e, "a signal did not encode for this process's connections")
            }
        }
    }

    /// Calls `f` with what the components of this process emit here from now on, while the returned token
    /// lives.
    pub(crate) fn listen(&self, f: Listener) -> Arc<()> {
        let token = Arc::new(());
        self.listeners
            .lock()
            .unwrap()
            .push((Arc::downgrade(&token), f));
        token
    }

    /// Whether a component of this process emits on the topic now.
    pub(crate) fn has_emitters(&self) -> bool {
        self.live.load(std::sync::atomic::Ordering::Relaxed) > 0
    }

    /// The writer of a component that emitted here is gone (its GUID stays known: its last samples may still
    /// come over DDS).
    pub(crate) fn close(&self) {
        self.live.fetch_sub(1, std::sync::atomic::Ordering::Relaxed);
    }

    /// Whether the DDS writer `gid` is one of this process's on the topic (its samples came through the tap).
    pub(crate) fn is_local(&self, gid: ros2_client::Gid) -> bool {
        self.writers.lock().unwrap().contains(&GUID::from(gid))
    }
}

/// The signal topics of this process, by topic and type.
#[derive(Default)]
pub(crate) struct Taps(Mutex<HashMap<(String, String), Arc<Tap>>>);

impl Taps {
    /// The tap of `topic` and `ros_type`, made on first use.
    pub(crate) fn get(&self, topic: &str, ros_type: &str) -> Arc<Tap> {
        self.0
            .lock()
            .unwrap()
            .entry((topic.to_owned(), ros_type.to_owned()))
            .or_default()
            .clone()
    }

    /// The tap for the DDS writer `writer` of a component of this process, before it emits anything.
    pub(crate) fn open(&self, topic: &str, ros_type: &str, writer: GUID) -> Arc<Tap> {
        let tap = self.get(topic, ros_type);
        tap.writers.lock().unwrap().insert(writer);
        tap.live.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        tap
    }
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
    rx: mpsc::UnboundedReceiver<RawMessage>,
    inlet: Arc<Inlet>,
}

impl Inbox {
    /// The messages, in delivery order.
    pub(crate) fn stream(&mut self) -> impl futures::Stream<Item = RawMessage> + '_ {
        futures::stream::poll_fn(|cx| self.rx.poll_recv(cx))
    }
}

impl Drop for Inbox {
    fn drop(&mut self) {
        *self.inlet.open.lock().unwrap() = None;
        self.inlet.present.send_replace(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_inlet_delivers_while_its_inbox_is_open_and_shows_presence() {
        let inlets = Inlets::default();
        assert!(inlets.find("/r/start", "std_msgs/msg/Empty").is_none());
        let mut inbox = inlets.open("/r/start", "std_msgs/msg/Empty");
        assert!(
            inlets.find("/r/start", "std_msgs/msg/String").is_none(),
            "another type is not this slot"
        );
        let inlet = inlets.find("/r/start", "std_msgs/msg/Empty").unwrap();
        let presence = inlet.presence();
        assert_eq!(*presence.borrow(), 1);
        assert!(inlet.deliver(RawMessage(vec![0])));
        assert_eq!(inbox.rx.try_recv().unwrap(), RawMessage(vec![0]));
        drop(inbox);
        assert_eq!(*presence.borrow(), 0);
        assert!(!inlet.deliver(RawMessage(vec![0])), "nobody reads it now");
        assert!(inlets.find("/r/start", "std_msgs/msg/Empty").is_none());
        // a response of the same name comes back: the same inlet, present again
        let _again = inlets.open("/r/start", "std_msgs/msg/Empty");
        assert_eq!(*presence.borrow(), 1);
        assert!(inlet.deliver(RawMessage(vec![0])));
    }

    #[test]
    fn a_tap_hands_signals_to_its_listeners_and_names_its_writers() {
        let taps = Taps::default();
        let w = GUID::new_participant_guid();
        let tap = taps.open("/e/triggered", "std_msgs/msg/Int32", w);
        tap.emit(&crate::msg::Int32 { data: 1 }); // nobody listens: nothing encoded, nothing kept
        let got: Arc<Mutex<Vec<(RawMessage, i64)>>> = Default::default();
        let g = got.clone();
        let token = taps
            .get("/e/triggered", "std_msgs/msg/Int32")
            .listen(Arc::new(move |raw, stamp| {
                g.lock().unwrap().push((raw.clone(), stamp))
            }));
        tap.emit(&crate::msg::Int32 { data: 7 });
        {
            let got = got.lock().unwrap();
            assert_eq!(got.len(), 1, "only what came after listening");
            assert_eq!(got[0].0.decode::<crate::msg::Int32>().unwrap().data, 7);
            assert!(got[0].1 > 0);
        }
        drop(token);
        tap.emit(&crate::msg::Int32 { data: 8 });
        assert_eq!(
            got.lock().unwrap().len(),
            1,
            "nothing once the token is gone"
        );
        assert!(tap.is_local(ros2_client::Gid::from(w)));
        assert!(
            !taps
                .get("/e/triggered", "std_msgs/msg/String")
                .is_local(ros2_client::Gid::from(w)),
            "another type is another tap"
        );
    }
}
