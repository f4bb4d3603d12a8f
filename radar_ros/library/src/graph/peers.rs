//! Which local endpoints hold which peer, so that a peer that goes (or a local endpoint deleted) is taken out
//! of the entries that hold it, not out of every entry.
//!
//! Before, each departure scanned every local endpoint's sets: a process with 2,000 components (10,000
//! endpoints) that stopped with an observer attached made 10,000 deletions of 10,000 scans each, and its
//! SIGTERM took 9 s, past the shutdown timeout. Now a departure costs what the entries holding that peer
//! hold.

use std::collections::{HashMap, HashSet};

use ros2_client::dds::rustdds::GUID;

use super::{Entry, Side, Table};
use crate::departure::LossCause;

/// How long a deleted local endpoint is remembered (far above the event loop's delay).
pub(super) const FORGOTTEN_FOR: std::time::Duration = std::time::Duration::from_secs(30);

/// Below this many, the deleted endpoints remembered are not pruned.
const FORGOTTEN_PRUNE_MIN: usize = 1024;

/// How many of the participants that left an endpoint without peers it remembers.
pub(super) const EMPTIED_KEPT: usize = 4;

impl super::Graph {
    /// Whether local endpoint `guid` was left without peers when an endpoint of `participant` (a GUID of it)
    /// went, lately: its match count has then told that departure (it reached zero), which a look at the
    /// processes running a component (`connections/manager/instances.rs`) must not tell again.
    pub(crate) fn emptied_by(&self, guid: GUID, participant: GUID) -> bool {
        let t = self.table.lock().unwrap();
        t.writers
            .get(&guid)
            .or_else(|| t.readers.get(&guid))
            .is_some_and(|e| e.emptied_by.contains(&super::participant_of(participant)))
    }
}

impl Table {
    /// Notes that local endpoint `local` (a writer for [`Side::Writer`]) may hold `peer` in one of its sets.
    /// A note may outlive what it notes (it is only a place to look).
    pub(super) fn mention(&mut self, peer: GUID, side: Side, local: GUID) {
        self.mentions.entry(peer).or_default().insert((side, local));
    }

    /// The local endpoints of `side` that may hold `peer`.
    pub(super) fn holders(&self, peer: &GUID, side: Side) -> Vec<GUID> {
        self.mentions.get(peer).map_or_else(Vec::new, |m| {
            m.iter()
                .filter(|(s, _)| *s == side)
                .map(|(_, g)| *g)
                .collect()
        })
    }

    fn entries(&mut self, side: Side) -> &mut HashMap<GUID, Entry> {
        match side {
            Side::Writer => &mut self.writers,
            Side::Reader => &mut self.readers,
        }
    }

    /// Takes the peers `gone` out of every local endpoint that holds one, each endpoint told once, with `cause`
    /// as its last loss if it lost a matched peer.
    pub(super) fn drop_peers(&mut self, gone: &[GUID], cause: &LossCause) {
        let mut touched: HashSet<(Side, GUID)> = HashSet::new();
        for g in gone {
            let Some(holders) = self.mentions.remove(g) else {
                continue;
            };
            for (side, local) in holders {
                let Some(e) = self.entries(side).get_mut(&local) else {
                    continue;
                };
                e.rejected.remove(g);
                e.heard.remove(g);
                e.observing.remove(g);
                if e.peers.remove(g) {
                    e.last_loss = Some(cause.clone());
                    if e.peers.is_empty() {
                        let p = super::participant_of(*g);
                        e.emptied_by.retain(|q| *q != p);
                        if e.emptied_by.len() == EMPTIED_KEPT {
                            e.emptied_by.pop_front();
                        }
                        e.emptied_by.push_back(p);
                    }
                    touched.insert((side, local));
                }
            }
        }
        for (side, local) in touched {
            if let Some(e) = self.entries(side).get(&local) {
                e.notify();
            }
        }
    }

    /// Every peer of participant `prefix_of` (a GUID of it) that a local endpoint may hold.
    pub(super) fn mentioned_of_participant(&self, prefix_of: GUID) -> Vec<GUID> {
        self.mentions
            .keys()
            .filter(|g| g.prefix == prefix_of.prefix)
            .copied()
            .collect()
    }

    /// Deletes local endpoint `guid`: its own entries and what notes them, and it as a peer of the others.
    pub(super) fn forget_local(&mut self, guid: GUID) {
        let now = std::time::Instant::now();
        // pruned when twice as many as the last time (amortized: a process deleting 10,000 endpoints at once
        // does not scan the list 10,000 times)
        if self.forgotten.len() >= self.forgotten_prune_at {
            self.forgotten
                .retain(|_, at| now.duration_since(*at) < FORGOTTEN_FOR);
            self.forgotten_prune_at = (2 * self.forgotten.len()).max(FORGOTTEN_PRUNE_MIN);
        }
        self.forgotten.insert(guid, now);
        self.observers.remove(&guid);
        for side in [Side::Writer, Side::Reader] {
            let Some(e) = self.entries(side).remove(&guid) else {
                continue;
            };
            for peer in e.peers.iter().chain(&e.rejected).chain(&e.heard) {
                if let Some(m) = self.mentions.get_mut(peer) {
                    m.remove(&(side, guid));
                    if m.is_empty() {
                        self.mentions.remove(peer);
                    }
                }
            }
        }
        self.drop_peers(&[guid], &LossCause::Left);
    }

    /// Whether local endpoint `guid` was deleted lately (a match DDS reports with it now is not counted).
    pub(super) fn was_forgotten(&self, guid: &GUID) -> bool {
        self.forgotten
            .get(guid)
            .is_some_and(|at| at.elapsed() < FORGOTTEN_FOR)
    }
}

#[cfg(test)]
mod tests {
    use ros2_client::dds::rustdds::{DomainParticipantStatusEvent as Ev, LostReason, GUID};

    use super::super::Graph;
    use crate::departure::LossCause;

    /// Endpoint `entity` of participant `p` (a writer when `entity` is even: only the GUID's bytes matter here).
    fn guid(p: u8, entity: u8) -> GUID {
        let mut b = [p; 16];
        b[12..].copy_from_slice(&[0, 0, entity, 0x02]);
        GUID::from_bytes(b)
    }

    const TOPIC: &str = "rt/t";
    const TYPE: &str = "std_msgs::msg::dds_::Empty_";

    fn matched(g: &Graph, local_writer: GUID, remote_reader: GUID) {
        g.apply(Ev::RemoteReaderMatched {
            local_writer,
            remote_reader,
        });
    }

    #[test]
    fn a_peer_that_goes_leaves_exactly_the_endpoints_that_held_it() {
        let g = Graph::default();
        let (w1, w2) = (guid(1, 2), guid(1, 4));
        let (c1, c2) = (
            g.watch_writer(w1, TOPIC, TYPE),
            g.watch_writer(w2, TOPIC, TYPE),
        );
        // remote readers: x of participant 2 on both writers, y of participant 2 on w1, z of 3 on w2
        let (x, y, z) = (guid(2, 1), guid(2, 3), guid(3, 1));
        for (w, r) in [(w1, x), (w2, x), (w1, y), (w2, z)] {
            matched(&g, w, r);
        }
        assert_eq!((*c1.borrow(), *c2.borrow()), (2, 2));
        g.apply(Ev::ReaderLost {
            guid: x,
            reason: LostReason::Disposed,
        });
        assert_eq!((*c1.borrow(), *c2.borrow()), (1, 1));
        assert_eq!(g.last_loss(w1), Some(LossCause::Left));
        // participant 3 goes: only w2 held one of its endpoints
        g.apply(Ev::ParticipantLost {
            id: z.prefix,
            reason: LostReason::Disposed,
        });
        assert_eq!((*c1.borrow(), *c2.borrow()), (1, 0));
        // a reader lost twice, or a participant nobody held, changes nothing
        g.apply(Ev::ReaderLost {
            guid: x,
            reason: LostReason::Disposed,
        });
        g.apply(Ev::ParticipantLost {
            id: guid(9, 1).prefix,
            reason: LostReason::Disposed,
        });
        assert_eq!((*c1.borrow(), *c2.borrow()), (1, 0));
        assert_eq!(g.table.lock().unwrap().mentions.len(), 1, "y only");
    }

    /// C5: a component that quits cleanly and is started again in a new process: the count of the writer that
    /// reaches its slot goes to zero and back, and the graph says which process's going made it zero (the
    /// look at the processes does not tell that departure again), and only that one.
    #[test]
    fn an_endpoint_remembers_which_processes_left_it_without_peers() {
        let g = Graph::default();
        let w = guid(1, 2);
        let c = g.watch_writer(w, TOPIC, TYPE);
        // the old process 2 and a second reader of process 3; 3 goes first (not the last one), then 2
        let (old, other, new) = (guid(2, 1), guid(3, 1), guid(4, 1));
        matched(&g, w, old);
        matched(&g, w, other);
        g.apply(Ev::ReaderLost {
            guid: other,
            reason: LostReason::Disposed,
        });
        assert!(!g.emptied_by(w, other), "1 peer was left when 3 went");
        g.apply(Ev::ReaderLost {
            guid: old,
            reason: LostReason::Disposed,
        });
        assert_eq!(*c.borrow(), 0);
        assert!(g.emptied_by(w, old), "2's going left it without peers");
        assert!(
            g.emptied_by(w, guid(2, 7)),
            "asked by any GUID of process 2"
        );
        // the new process comes: nothing of it is remembered
        matched(&g, w, new);
        assert!(!g.emptied_by(w, new));
        assert!(g.emptied_by(w, old), "still known");
        // only the last few are kept
        for p in 10..20 {
            matched(&g, w, guid(p, 1));
            g.apply(Ev::ReaderLost {
                guid: new,
                reason: LostReason::Disposed,
            });
            g.apply(Ev::ReaderLost {
                guid: guid(p, 1),
                reason: LostReason::Disposed,
            });
        }
        assert!(g.emptied_by(w, guid(19, 1)));
        assert!(
            !g.emptied_by(w, old),
            "forgotten after {} more",
            super::EMPTIED_KEPT
        );
        assert!(g.table.lock().unwrap().writers[&w].emptied_by.len() <= super::EMPTIED_KEPT);
    }

    #[test]
    fn a_deleted_local_endpoint_leaves_its_local_peers_and_takes_its_notes() {
        let g = Graph::default();
        // a writer and a reader of this participant matched with each other, and a remote reader
        let (w, r, remote) = (guid(1, 2), guid(1, 1), guid(2, 1));
        let cw = g.watch_writer(w, TOPIC, TYPE);
        let cr = g.watch_reader(r, TOPIC, TYPE);
        matched(&g, w, r);
        g.apply(Ev::RemoteWriterMatched {
            local_reader: r,
            remote_writer: w,
        });
        matched(&g, w, remote);
        assert_eq!((*cw.borrow(), *cr.borrow()), (2, 1));
        g.forget(r);
        assert_eq!(*cw.borrow(), 1, "the writer lost the deleted reader");
        // DDS may report the match once more after the deletion: not counted
        matched(&g, w, r);
        assert_eq!(*cw.borrow(), 1);
        g.forget(w);
        let t = g.table.lock().unwrap();
        assert!(t.writers.is_empty() && t.readers.is_empty());
        assert!(
            t.mentions.is_empty(),
            "no note of a deleted endpoint is left: {}",
            t.mentions.len()
        );
    }

    #[test]
    fn an_endpoint_matched_before_it_had_a_type_is_checked_when_it_gets_one() {
        let g = Graph::default();
        let (w, r) = (guid(1, 2), guid(1, 1));
        let cw = g.watch_writer(w, TOPIC, TYPE);
        // the local reader matched w before it was registered with its type
        matched(&g, w, r);
        assert_eq!(*cw.borrow(), 1);
        // it is of another type: w stops counting it
        let _cr = g.watch_reader(r, TOPIC, "std_msgs::msg::dds_::String_");
        assert_eq!(*cw.borrow(), 0);
    }
}
