//! How the table's sources and slots are reached: a relay per source (its reader's task feeds the table; with
//! local delivery it also takes this process's emitters from their tap), an outlet per slot (to the response of
//! this process that reads it, or over DDS), and the watch on each one's peers (rule C5).

use std::sync::Arc;

use futures::StreamExt;
use radar_semantics::response::Sent;

use super::{End, Manager, Target, GONE_AFTER};
use crate::{
    departure::Departure,
    node::pool::Key,
    node::topics::{RawPublisher, RawSubscription},
    wire::local::Inlet,
    wire::msg::{Empty, RosMessage},
    wire::raw::RawMessage,
};

/// A source the table reads: the task that feeds its reader's signals to the table (stopped on drop), and
/// its listening to this process's emitters of the source (ends on drop).
pub(super) struct Relay {
    _stop: tokio::sync::oneshot::Sender<()>,
    _tap: Option<Arc<()>>,
}

/// A slot the table writes: to the response of this process that reads it, or on its topic.
pub(super) struct Outlet {
    key: Key,
    /// The slot in this process (with local delivery): a response of this process reads it, or may.
    pub(super) inlet: Option<Arc<Inlet>>,
    /// A DDS writer on the slot's topic (held in the participant's pool), once one is needed: when no response
    /// of this process reads the slot.
    pub(super) dds: Option<Arc<RawPublisher>>,
    /// The slot takes `std_msgs/msg/Empty`: the payload is dropped.
    empty: bool,
    /// Tells the watcher of the slot's readers about a DDS writer made later (its match count).
    pub(super) more: tokio::sync::mpsc::UnboundedSender<tokio::sync::watch::Receiver<usize>>,
    /// Stops the task that watches the slot's readers.
    _stop: tokio::sync::oneshot::Sender<()>,
}

impl Outlet {
    /// Whether a response of this process reads the slot now.
    pub(super) fn local(&self) -> bool {
        self.inlet
            .as_ref()
            .is_some_and(|i| i.reads(&self.key.ros_type))
    }

    pub(super) fn deliver(&self, m: RawMessage, sent: Sent) {
        let m = if self.empty {
            RawMessage::from_bytes(vec![0])
        } else {
            m
        };
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

impl Manager {
    /// A relay for `k`, whose reader `sub` is held once more for it; its task feeds the table, and tells it
    /// when the source's publishers have all gone (and when one is back). With local delivery it takes what
    /// this process's components emit on `k` from their tap, and skips their samples on DDS.
    pub(super) fn relay(self: &Arc<Self>, k: &Key, sub: Arc<RawSubscription>) -> Relay {
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
    pub(super) fn outlet(
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
        if needs_writer && inlet.is_some() {
            // it writes the slot over DDS if that response leaves: the program's policy must grant it
            self.participant.declare_writer(&k.topic);
        }
        let mut presence = Presence::new(counts);
        let key = k.clone();
        let departure = slot_departure(me.clone(), key.clone());
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
        let mut st = self.state();
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
}

/// What a relay or outlet tells the table about its peers.
pub(super) enum Change {
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

/// Who left when the slot `key` has no reader any more: its writer's last matched subscriber, or the slot's.
fn slot_departure(me: std::sync::Weak<Manager>, key: Key) -> impl Fn() -> Departure {
    move || {
        let writer = me
            .upgrade()
            .and_then(|m| m.state().outlets.get(&key).and_then(|o| o.dds.clone()));
        match writer {
            Some(p) => p.departure(),
            None => Departure::of_subscriber(&key.topic, crate::departure::LossCause::Left),
        }
    }
}
