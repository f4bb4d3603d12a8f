//! The ROS graph as radar_ros sees it: components found by name ([`Component`], [`ComponentName`],
//! [`Endpoint`]), the nodes on it ([`GraphNode`]), and why a component left ([`Departure`], [`LossCause`]).
//! How far discovery reaches is a setting of the `Radar` (`radar_ros::settings`).

pub use crate::departure::{Departure, LossCause};
pub use crate::endpoint::Endpoint;
pub use crate::wire::names::ComponentName;
pub use lookup::Component;

// How the graph is kept:
//
// Who is matched with whom, from DDS discovery, with counts that also drop when a peer process dies.
//
// ros2-client's `Publisher::get_subscription_count` never drops after a subscriber process is killed: its
// spinner ignores the DDS "participant lost" event. This module consumes the participant's status events
// itself (the process runs no ros2-client spinner) and keeps, for every local writer and reader, the set of
// matched remote endpoints:
//
// - `RemoteReaderMatched` / `RemoteWriterMatched` add a peer (also for readers in the same participant);
// - `ReaderLost` / `WriterLost` remove it (a peer that closes its endpoint or exits cleanly: milliseconds);
// - `ParticipantLost` removes every endpoint of that participant. After `kill -9` this is the only signal, and
//   it comes when the dead participant's lease expires: 3 s for radar_ros peers (`DEFAULT_LEASE`, announced
//   every 0.6 s), 20 s for Fast DDS (rclpy) peers, 50 s for other RustDDS programs, plus up to one lease
//   check period (0.6 s with radar_ros's lease).
//
// RustDDS matches endpoints of one topic whatever their type names; ROS 2 (and Fast DDS) do not. So on every
// match the peer's type, from DDS discovery data, is compared with the local endpoint's: a peer of another
// type is not counted, a warning names both types, and [`Graph::accepts`] tells readers to drop its samples.
//
// Counts are published through `tokio::sync::watch` channels, so an event reacts to a change at once.

use std::{
    collections::{BTreeSet, HashMap},
    sync::{Arc, Mutex},
};

use futures::StreamExt;
use ros2_client::dds::rustdds::{self, DomainParticipantStatusEvent, StatusEvented, GUID};
use tokio::sync::watch;

mod discovery;
pub(crate) mod lookup;
pub(crate) mod nodes;
mod observers;
mod peers;
pub(crate) mod processes;
#[cfg(feature = "zenoh")]
pub(crate) mod tokens;

pub(crate) use observers::OBSERVER_USER_DATA;

pub use nodes::GraphNode;

use discovery::TopicIndex;

#[derive(Default)]
struct Entry {
    peers: BTreeSet<GUID>,
    /// Why the last peer that went went.
    last_loss: Option<LossCause>,
    /// Matched peers whose type differs from ours.
    rejected: BTreeSet<GUID>,
    /// (topic, DDS type name) once registered.
    identity: Option<(String, String)>,
    tx: Option<watch::Sender<usize>>,
    /// For a reader: the writers of other participants that have shown they send to it (RustDDS patch 18).
    heard: BTreeSet<GUID>,
    /// For a writer: the matched readers that only observe (`radar_observe=1;` in their USER_DATA).
    observing: BTreeSet<GUID>,
    /// For a writer: the count of matched readers that do not only observe ([`Graph::watch_listeners`]).
    listeners_tx: Option<watch::Sender<usize>>,
    /// The participants (their participant GUIDs) whose endpoint was the last peer of this one when it went,
    /// latest last (a few: `peers::EMPTIED_KEPT`): the departures its count has told (`Graph::emptied_by`).
    emptied_by: std::collections::VecDeque<GUID>,
}

impl Entry {
    fn notify(&self) {
        if let Some(tx) = &self.tx {
            tx.send_replace(self.peers.len());
        }
        if let Some(tx) = &self.listeners_tx {
            tx.send_replace(self.peers.len() - self.observing.len());
        }
    }
}

#[derive(Default)]
struct Table {
    /// Local writer -> matched remote readers.
    writers: HashMap<GUID, Entry>,
    /// Local reader -> matched remote writers.
    readers: HashMap<GUID, Entry>,
    /// Local endpoints deleted lately, and when. DDS may still report a match with one (a writer made just
    /// before a reader of this participant was deleted is matched with it by the event loop afterwards, and no
    /// loss is reported for a local endpoint): such a match is not counted, or the count would never drop.
    forgotten: HashMap<GUID, std::time::Instant>,
    /// `forgotten`'s length at which it is pruned next (`peers.rs`).
    forgotten_prune_at: usize,
    /// Peer -> the local endpoints (and their side) that may hold it in a set (`peers.rs`).
    mentions: HashMap<GUID, std::collections::HashSet<(Side, GUID)>>,
    /// Participants (by their participant GUID) and remote endpoints that left the graph lately, and when: a
    /// caller whose request is answered after it left owns nothing (B7). A participant that exits cleanly is
    /// known gone by its endpoints' disposes at once, by itself only when its lease runs out.
    left: HashMap<GUID, std::time::Instant>,
    /// `left`'s length at which it is pruned next.
    left_prune_at: usize,
    /// Readers, local and remote, that only observe (`observers.rs`).
    observers: std::collections::HashSet<GUID>,
}

/// How long a participant that left is remembered.
const LEFT_FOR: std::time::Duration = std::time::Duration::from_secs(600);

/// Shared match table of one DDS participant.
#[derive(Clone)]
pub(crate) struct Graph {
    table: Arc<Mutex<Table>>,
    participant: Arc<Mutex<Option<rustdds::DomainParticipant>>>,
    /// Participants that left the graph (cleanly or by lease expiry).
    /// (RustDDS does not export `GuidPrefix`: a GUID carries it; compare `.prefix`.)
    lost: tokio::sync::broadcast::Sender<GUID>,
    /// Bumped after every discovery event (an endpoint or participant found, matched or lost).
    changed: Arc<watch::Sender<u64>>,
    /// What arrived that did not decode, from whom.
    malformed: Arc<crate::wire::malformed::Malformed>,
    /// Every endpoint by topic, for lookups by name.
    index: Arc<Mutex<TopicIndex>>,
    /// Over Zenoh, the session whose liveliness tokens are the graph (`tokens.rs`).
    #[cfg(feature = "zenoh")]
    zenoh: Arc<Mutex<Option<tokens::Tokens>>>,
}

impl Default for Graph {
    fn default() -> Self {
        Graph {
            table: Default::default(),
            participant: Default::default(),
            lost: tokio::sync::broadcast::channel(64).0,
            changed: Arc::new(watch::channel(0).0),
            malformed: Default::default(),
            index: Default::default(),
            #[cfg(feature = "zenoh")]
            zenoh: Default::default(),
        }
    }
}

/// How often [`Graph::wait_for`] looks again without a discovery event.
const GRAPH_POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// A deadline far enough away to mean "none".
pub(crate) fn no_deadline() -> tokio::time::Instant {
    tokio::time::Instant::now() + std::time::Duration::from_secs(86_400 * 365)
}

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
enum Side {
    /// Our writer, their reader.
    Writer,
    /// Our reader, their writer.
    Reader,
}

impl Graph {
    /// Watches the number of subscriptions of type `dds_type` matched with a local writer on `topic`.
    pub(crate) fn watch_writer(
        &self,
        writer: GUID,
        topic: &str,
        dds_type: &str,
    ) -> watch::Receiver<usize> {
        self.watch(Side::Writer, writer, topic, dds_type)
    }

    /// Watches the number of publishers of type `dds_type` matched with a local reader on `topic`.
    pub(crate) fn watch_reader(
        &self,
        reader: GUID,
        topic: &str,
        dds_type: &str,
    ) -> watch::Receiver<usize> {
        self.watch(Side::Reader, reader, topic, dds_type)
    }

    /// Whether every peer of `guid` has matched `guid` back, as far as can be known. DDS discovery completes on
    /// each side separately, and a volatile writer only sends to readers it has matched, so one side's view is
    /// not enough for nothing to be lost. A peer in this participant is asked; a writer of another participant
    /// has matched a reader of ours once it has been heard from (its first HEARTBEAT or DATA to us, RustDDS
    /// patch 18); a reader of another participant cannot show it, and is assumed to have.
    pub(crate) fn reciprocated(&self, guid: GUID) -> bool {
        let t = self.table.lock().unwrap();
        let (mine, theirs, reader) = match (t.writers.get(&guid), t.readers.get(&guid)) {
            (Some(e), _) => (e, &t.readers, false),
            (None, Some(e)) => (e, &t.writers, true),
            (None, None) => return true,
        };
        mine.peers.iter().all(|p| match theirs.get(p) {
            // a peer of this participant: it has matched us back
            Some(o) if o.identity.is_some() => o.peers.contains(&guid),
            // a writer of another participant, for a reader: it has shown it sends to us (B8: a volatile writer
            // that has not matched us yet would not send what it writes now); a reader of another participant
            // cannot show that it matched a writer
            _ => !reader || p.prefix == guid.prefix || mine.heard.contains(p),
        })
    }

    /// Whether a sample that `reader` received from `writer` comes from a peer of the right type.
    ///
    /// A sample can arrive before this graph has processed the match of its writer (DDS delivers what a
    /// writer sent just before the match as soon as the match is made, and the match event reaches this
    /// graph a moment later): the writer's type is then looked up in discovery data here, so a publisher of
    /// another type is never accepted, not even in that moment.
    pub(crate) fn accepts(&self, reader: GUID, writer: ros2_client::Gid) -> bool {
        let writer = GUID::from(writer);
        let t = self.table.lock().unwrap();
        let Some(e) = t.readers.get(&reader) else {
            return true;
        };
        if e.rejected.contains(&writer) {
            return false;
        }
        if e.peers.contains(&writer) {
            return true;
        }
        match (&e.identity, self.peer_type(&t, Side::Reader, writer)) {
            (Some((_, ours)), Some(theirs)) => *ours == theirs,
            _ => true,
        }
    }

    /// The participant's count of messages that did not decode.
    pub(crate) fn malformed(&self) -> &crate::wire::malformed::Malformed {
        &self.malformed
    }

    /// Changes after every discovery event, so code waiting for something to appear on the graph can look
    /// again at once instead of polling.
    pub(crate) fn changes(&self) -> watch::Receiver<u64> {
        self.changed.subscribe()
    }

    /// The one way to wait on the graph: asks `check` now, then after every discovery event (and every
    /// [`GRAPH_POLL`], for matches made between two events), until it answers something, or `deadline`
    /// passes (`None` then). Cancel safe: it only looks.
    pub(crate) async fn wait_for<T>(
        &self,
        deadline: tokio::time::Instant,
        mut check: impl FnMut() -> Option<T>,
    ) -> Option<T> {
        let mut changes = self.changes();
        loop {
            changes.mark_unchanged();
            if let Some(t) = check() {
                return Some(t);
            }
            let now = tokio::time::Instant::now();
            if now >= deadline {
                return None;
            }
            let _ =
                tokio::time::timeout_at(deadline.min(now + GRAPH_POLL), changes.changed()).await;
        }
    }

    /// The endpoint whose GID is `gid` (a sample's writer, a request's client) as the graph names it: over DDS
    /// its GUID, whose prefix is its process; over Zenoh, where a GID is a hash of its token, its session's
    /// participant GUID when a token names it (else the GID as it is).
    pub(crate) fn process_of_gid(&self, gid: ros2_client::Gid) -> GUID {
        #[cfg(feature = "zenoh")]
        if let Some(session) = self.session_of_gid(gid) {
            return session;
        }
        GUID::from(gid)
    }

    /// Tells of every participant that leaves the graph from now on.
    pub(crate) fn participants_lost(&self) -> tokio::sync::broadcast::Receiver<GUID> {
        self.lost.subscribe()
    }

    /// The DDS participant, once set (until the participant shuts down).
    pub(crate) fn domain_participant(&self) -> Option<rustdds::DomainParticipant> {
        self.participant.lock().unwrap().clone()
    }

    /// This participant's id on the graph (a fresh one once the participant has shut down).
    pub(crate) fn own_id(&self) -> GUID {
        use rustdds::RTPSEntity;
        #[cfg(feature = "zenoh")]
        if let Some(own) = self.own_session() {
            return own;
        }
        self.domain_participant()
            .map(|p| p.guid())
            .unwrap_or_else(GUID::new_participant_guid)
    }

    pub(crate) fn set_participant(&self, p: rustdds::DomainParticipant) {
        *self.participant.lock().unwrap() = Some(p);
    }

    /// The DDS type a matched endpoint has: from our own table for endpoints of this participant (RustDDS's
    /// discovery lists only other participants'), else from discovery data.
    fn peer_type(&self, t: &Table, side: Side, peer: GUID) -> Option<String> {
        let own = match side {
            Side::Writer => t.readers.get(&peer),
            Side::Reader => t.writers.get(&peer),
        };
        if let Some((_, ty)) = own.and_then(|e| e.identity.as_ref()) {
            return Some(ty.clone());
        }
        // the topic index knows nearly every peer (copying all of discovery's data per match made
        // connecting N endpoints cost N^2)
        let wanted_writer = matches!(side, Side::Reader);
        if let Some(ty) = self.index.lock().unwrap().type_of(&peer, wanted_writer) {
            return Some(ty);
        }
        let p = self.participant.lock().unwrap().clone()?;
        match side {
            Side::Writer => p
                .discovered_readers()
                .into_iter()
                .find(|r| r.reader_proxy.remote_reader_guid == peer)
                .map(|r| r.subscription_topic_data.type_name().clone()),
            Side::Reader => p
                .discovered_writers()
                .into_iter()
                .find(|w| w.writer_proxy.remote_writer_guid == peer)
                .map(|w| w.publication_topic_data.type_name),
        }
    }

    /// Adds a matched peer, unless its announced type differs from ours. Returns whether the count changed.
    fn admit(e: &mut Entry, side: Side, peer: GUID, theirs: Option<String>) -> bool {
        if let Some((topic, ours)) = &e.identity {
            if let Some(theirs) = theirs {
                if &theirs != ours {
                    if e.rejected.insert(peer) {
                        let (ours, theirs) = (
                            crate::wire::dds_names::ros_type(ours),
                            crate::wire::dds_names::ros_type(&theirs),
                        );
                        match side {
                            Side::Reader => tracing::warn!(
                                %topic, expected = %ours, offered = %theirs, writer = ?peer,
                                "ignoring a publisher of another type; publish {ours} on {topic}"
                            ),
                            Side::Writer => tracing::warn!(
                                %topic, offered = %ours, requested = %theirs, reader = ?peer,
                                "not counting a subscriber of another type; subscribe with {ours} to {topic}"
                            ),
                        }
                    }
                    return false;
                }
            }
        }
        e.peers.insert(peer)
    }

    /// [`Graph::admit`] for a local writer's reader `peer`, noting whether it only observes.
    fn admit_reader(t: &mut Table, writer: GUID, peer: GUID, ty: Option<String>) -> bool {
        let observes = t.observers.contains(&peer);
        let e = t.writers.entry(writer).or_default();
        let added = Self::admit(e, Side::Writer, peer, ty);
        if added && observes {
            e.observing.insert(peer);
        }
        added
    }

    fn watch(&self, side: Side, guid: GUID, topic: &str, dds_type: &str) -> watch::Receiver<usize> {
        let mut t = self.table.lock().unwrap();
        let map = match side {
            Side::Writer => &mut t.writers,
            Side::Reader => &mut t.readers,
        };
        let e = map.entry(guid).or_default();
        if e.identity.is_none() {
            e.identity = Some((topic.to_owned(), dds_type.to_owned()));
            self.index.lock().unwrap().insert(
                matches!(side, Side::Writer),
                guid,
                topic.to_owned(),
                dds_type.to_owned(),
            );
            // peers matched before we knew our type are checked now
            let early: Vec<GUID> = std::mem::take(&mut e.peers).into_iter().collect();
            let typed: Vec<(GUID, Option<String>)> = early
                .into_iter()
                .map(|p| (p, self.peer_type(&t, side, p)))
                .collect();
            let map = match side {
                Side::Writer => &mut t.writers,
                Side::Reader => &mut t.readers,
            };
            let e = map.get_mut(&guid).expect("entry was just made");
            for (peer, ty) in typed {
                Self::admit(e, side, peer, ty);
            }
            // local endpoints that matched this one before it had a type are checked now too
            let other_side = match side {
                Side::Writer => Side::Reader,
                Side::Reader => Side::Writer,
            };
            for o in t.holders(&guid, other_side) {
                let other = match side {
                    Side::Writer => &mut t.readers,
                    Side::Reader => &mut t.writers,
                };
                if let Some(o) = other.get_mut(&o) {
                    if o.peers.remove(&guid) {
                        Self::admit(o, other_side, guid, Some(dds_type.to_owned()));
                        o.notify();
                    }
                }
            }
        }
        let map = match side {
            Side::Writer => &mut t.writers,
            Side::Reader => &mut t.readers,
        };
        let e = map.get_mut(&guid).expect("entry exists");
        match &e.tx {
            Some(tx) => tx.subscribe(),
            None => {
                let (tx, rx) = watch::channel(e.peers.len());
                e.tx = Some(tx);
                rx
            }
        }
    }

    /// Whether the remote endpoint `guid`, or its participant, has left the graph (and not come back).
    pub(crate) fn has_left(&self, guid: GUID) -> bool {
        let t = self.table.lock().unwrap();
        t.left.contains_key(&guid) || t.left.contains_key(&participant_of(guid))
    }

    fn note_left(t: &mut Table, guid: GUID) {
        let now = std::time::Instant::now();
        // pruned when twice as many as after the last pruning (every time past 1,024 made a process whose
        // peer of 10,000 endpoints left scan the list 10,000 times)
        if t.left.len() >= t.left_prune_at.max(1024) {
            t.left.retain(|_, at| now.duration_since(*at) < LEFT_FOR);
            if t.left.len() > 4096 {
                // a graph where endpoints come and go very often: remember the last minute only
                t.left
                    .retain(|_, at| now.duration_since(*at) < std::time::Duration::from_secs(60));
            }
            t.left_prune_at = 2 * t.left.len();
        }
        t.left.insert(guid, now);
    }

    /// Forgets a local endpoint that was deleted (also as the peer of other local endpoints).
    pub(crate) fn forget(&self, guid: GUID) {
        self.index.lock().unwrap().remove(&guid);
        self.table.lock().unwrap().forget_local(guid);
    }

    /// Why the last peer that left local endpoint `guid` left, if one did.
    pub(crate) fn last_loss(&self, guid: GUID) -> Option<LossCause> {
        let t = self.table.lock().unwrap();
        t.writers
            .get(&guid)
            .or_else(|| t.readers.get(&guid))
            .and_then(|e| e.last_loss.clone())
    }

    fn apply(&self, ev: DomainParticipantStatusEvent) {
        self.index_event(&ev);
        let mut t = self.table.lock().unwrap();
        if let DomainParticipantStatusEvent::ReaderDetected { reader } = &ev {
            if observers::observes(&reader.user_data) {
                Self::mark_observer_in(&mut t, reader.guid);
            }
        }
        match ev {
            DomainParticipantStatusEvent::RemoteReaderMatched {
                local_writer,
                remote_reader,
            } => {
                if t.was_forgotten(&remote_reader) {
                    return;
                }
                t.mention(remote_reader, Side::Writer, local_writer);
                let ty = self.peer_type(&t, Side::Writer, remote_reader);
                if Self::admit_reader(&mut t, local_writer, remote_reader, ty) {
                    t.writers[&local_writer].notify();
                }
            }
            DomainParticipantStatusEvent::RemoteWriterMatched {
                local_reader,
                remote_writer,
            } => {
                if t.was_forgotten(&remote_writer) {
                    return;
                }
                t.mention(remote_writer, Side::Reader, local_reader);
                let ty = self.peer_type(&t, Side::Reader, remote_writer);
                let e = t.readers.entry(local_reader).or_default();
                if Self::admit(e, Side::Reader, remote_writer, ty) {
                    e.notify();
                }
            }
            DomainParticipantStatusEvent::RemoteWriterHeard {
                local_reader,
                remote_writer,
            } => {
                t.mention(remote_writer, Side::Reader, local_reader);
                t.readers
                    .entry(local_reader)
                    .or_default()
                    .heard
                    .insert(remote_writer);
            }
            DomainParticipantStatusEvent::ReaderLost { guid, reason } => {
                Self::note_left(&mut t, guid);
                t.observers.remove(&guid);
                t.drop_peers(&[guid], &LossCause::of(&reason));
            }
            DomainParticipantStatusEvent::WriterLost { guid, reason } => {
                Self::note_left(&mut t, guid);
                t.drop_peers(&[guid], &LossCause::of(&reason));
            }
            DomainParticipantStatusEvent::ParticipantDiscovered { dpd } => {
                t.left.remove(&participant_of(dpd.guid));
            }
            DomainParticipantStatusEvent::ParticipantLost { id, reason } => {
                tracing::debug!(participant = ?id, ?reason, "DDS participant lost");
                let mut who = GUID::new_participant_guid();
                who.prefix = id;
                Self::note_left(&mut t, participant_of(who));
                t.observers.retain(|g| g.prefix != id);
                let _ = self.lost.send(who);
                let gone = t.mentioned_of_participant(who);
                t.drop_peers(&gone, &LossCause::of(&reason));
            }
            _ => {}
        }
    }

    /// Keeps the topic index current with a discovery event.
    fn index_event(&self, ev: &DomainParticipantStatusEvent) {
        let mut index = self.index.lock().unwrap();
        match ev {
            DomainParticipantStatusEvent::ReaderDetected { reader: e }
            | DomainParticipantStatusEvent::WriterDetected { writer: e } => {
                if let Some(t) = crate::wire::dds_names::ros_topic(&e.topic_name) {
                    let writer = matches!(ev, DomainParticipantStatusEvent::WriterDetected { .. });
                    index.insert(writer, e.guid, t.to_owned(), e.type_name.clone());
                }
            }
            DomainParticipantStatusEvent::ReaderLost { guid, .. }
            | DomainParticipantStatusEvent::WriterLost { guid, .. } => index.remove(guid),
            DomainParticipantStatusEvent::ParticipantLost { id, .. } => {
                let id = *id;
                index.remove_matching(|g| g.prefix == id)
            }
            _ => {}
        }
    }

    /// Consumes the participant's status events until `stop` fires. Must be the only consumer.
    pub(crate) async fn run(
        self,
        participant: rustdds::DomainParticipant,
        mut stop: tokio::sync::oneshot::Receiver<()>,
    ) {
        let listener = participant.status_listener();
        let mut events = listener.as_async_status_stream();
        loop {
            tokio::select! {
                _ = &mut stop => break,
                ev = events.next() => match ev {
                    Some(ev) => {
                        self.apply(ev);
                        self.changed.send_modify(|g| *g = g.wrapping_add(1));
                    }
                    None => break,
                },
            }
        }
        self.participant.lock().unwrap().take();
    }
}

/// The participant GUID of any GUID (its prefix, with the participant's entity id).
pub(super) fn participant_of(guid: GUID) -> GUID {
    let mut p = GUID::new_participant_guid();
    p.prefix = guid.prefix;
    p
}
