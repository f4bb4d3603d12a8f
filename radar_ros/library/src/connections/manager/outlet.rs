//! How the table's slots are reached: an outlet per slot, to the response of this process that reads it or
//! over DDS, and the watch on the slot's readers (rule C5). A signal a relay read reaches a slot as
//! relay -> `Manager::dispatch` (the table decides) -> [`Outlet::deliver`].

use std::sync::Arc;

use radar_semantics::response::Sent;

use super::{presence::Presence, End, Manager, Target};
use crate::{
    departure::Departure,
    node::pool::Key,
    node::topics::RawPublisher,
    wire::local::Inlet,
    wire::msg::{Empty, RosMessage},
    wire::raw::RawMessage,
};

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
                tracing::warn!(slot = %self.key.topic, error = %crate::error::Report(&e), "could not deliver a signal");
            }
        }
    }
}

impl Manager {
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
                tracing::warn!(slot = %k.topic, error = %crate::error::Report(&e), "no DDS writer for a slot whose response left this process");
                None
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
