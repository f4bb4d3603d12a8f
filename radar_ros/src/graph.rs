//! Who is matched with whom, from DDS discovery, with counts that also drop when a peer process dies.
//!
//! ros2-client's `Publisher::get_subscription_count` never drops after a subscriber process is killed: its
//! spinner ignores the DDS "participant lost" event. This module consumes the participant's status events
//! itself (the process runs no ros2-client spinner) and keeps, for every local writer and reader, the set of
//! matched remote endpoints:
//!
//! - `RemoteReaderMatched` / `RemoteWriterMatched` add a peer (also for readers in the same participant);
//! - `ReaderLost` / `WriterLost` remove it (a peer that closes its endpoint or exits cleanly: milliseconds);
//! - `ParticipantLost` removes every endpoint of that participant. After `kill -9` this is the only signal, and
//!   it comes when the dead participant's lease expires: 20 s for Fast DDS (rclpy) peers, 50 s for RustDDS
//!   peers (RustDDS announces 5 x its 10 s SPDP period), plus up to 2 s for RustDDS's lease check.
//!
//! Counts are published through `tokio::sync::watch` channels, so an event reacts to a change at once.

use std::{
    collections::{BTreeSet, HashMap},
    sync::{Arc, Mutex},
};

use futures::StreamExt;
use ros2_client::dds::rustdds::{self, DomainParticipantStatusEvent, StatusEvented, GUID};
use tokio::sync::watch;

#[derive(Default)]
struct Entry {
    peers: BTreeSet<GUID>,
    tx: Option<watch::Sender<usize>>,
}

impl Entry {
    fn notify(&self) {
        if let Some(tx) = &self.tx {
            tx.send_replace(self.peers.len());
        }
    }
}

#[derive(Default)]
struct Table {
    /// Local writer -> matched remote readers.
    writers: HashMap<GUID, Entry>,
    /// Local reader -> matched remote writers.
    readers: HashMap<GUID, Entry>,
}

/// Shared match table of one DDS participant.
#[derive(Clone, Default)]
pub(crate) struct Graph {
    table: Arc<Mutex<Table>>,
}

impl Graph {
    /// Watches the number of subscriptions matched with a local writer.
    pub(crate) fn watch_writer(&self, writer: GUID) -> watch::Receiver<usize> {
        Self::watch(&mut self.table.lock().unwrap().writers, writer)
    }

    /// Watches the number of publishers matched with a local reader.
    pub(crate) fn watch_reader(&self, reader: GUID) -> watch::Receiver<usize> {
        Self::watch(&mut self.table.lock().unwrap().readers, reader)
    }

    fn watch(map: &mut HashMap<GUID, Entry>, guid: GUID) -> watch::Receiver<usize> {
        let e = map.entry(guid).or_default();
        match &e.tx {
            Some(tx) => tx.subscribe(),
            None => {
                let (tx, rx) = watch::channel(e.peers.len());
                e.tx = Some(tx);
                rx
            }
        }
    }

    /// Forgets a local endpoint that was deleted.
    pub(crate) fn forget(&self, guid: GUID) {
        let mut t = self.table.lock().unwrap();
        t.writers.remove(&guid);
        t.readers.remove(&guid);
    }

    fn apply(&self, ev: DomainParticipantStatusEvent) {
        let mut t = self.table.lock().unwrap();
        match ev {
            DomainParticipantStatusEvent::RemoteReaderMatched {
                local_writer,
                remote_reader,
            } => {
                let e = t.writers.entry(local_writer).or_default();
                if e.peers.insert(remote_reader) {
                    e.notify();
                }
            }
            DomainParticipantStatusEvent::RemoteWriterMatched {
                local_reader,
                remote_writer,
            } => {
                let e = t.readers.entry(local_reader).or_default();
                if e.peers.insert(remote_writer) {
                    e.notify();
                }
            }
            DomainParticipantStatusEvent::ReaderLost { guid, .. } => {
                Self::remove_where(&mut t.writers, |g| *g == guid);
            }
            DomainParticipantStatusEvent::WriterLost { guid, .. } => {
                Self::remove_where(&mut t.readers, |g| *g == guid);
            }
            DomainParticipantStatusEvent::ParticipantLost { id, .. } => {
                tracing::debug!(participant = ?id, "DDS participant lost");
                Self::remove_where(&mut t.writers, |g| g.prefix == id);
                Self::remove_where(&mut t.readers, |g| g.prefix == id);
            }
            _ => {}
        }
    }

    fn remove_where(map: &mut HashMap<GUID, Entry>, pred: impl Fn(&GUID) -> bool) {
        for e in map.values_mut() {
            let before = e.peers.len();
            e.peers.retain(|g| !pred(g));
            if e.peers.len() != before {
                e.notify();
            }
        }
    }

    /// Consumes the participant's status events until `stop` fires. Must be the only consumer.
    pub(crate) async fn run(
        self,
        participant: rustdds::DomainParticipant,
        mut stop: tokio::sync::oneshot::Receiver<()>,
    ) {
        let listener = participant.status_listener();
        drop(participant);
        let mut events = listener.as_async_status_stream();
        loop {
            tokio::select! {
                _ = &mut stop => break,
                ev = events.next() => match ev {
                    Some(ev) => self.apply(ev),
                    None => break,
                },
            }
        }
    }
}
