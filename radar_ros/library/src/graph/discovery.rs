//! What DDS discovery knows of the graph, looked up by topic: the topic index kept current from discovery
//! events, and the graph's lookups (types on a topic, participants that serve endpoints, readers of a peer).

use std::collections::{BTreeSet, HashMap};

use ros2_client::dds::rustdds::{self, GUID};

use super::Graph;

/// How old the topic index may get before a lookup rebuilds it from the discovery data (discovery events,
/// which keep it current, can be dropped when their channel is full).
const RESYNC: std::time::Duration = std::time::Duration::from_secs(1);

/// The endpoints of the graph by (is a writer, ROS topic): their DDS types. Kept current from discovery
/// events and this participant's own endpoints, so that a lookup by name costs the same with 10 or 10,000
/// endpoints (it used to copy every endpoint discovery knew, per lookup).
#[derive(Default)]
pub(super) struct TopicIndex {
    by_topic: HashMap<(bool, String), HashMap<GUID, String>>,
    topic_of: HashMap<GUID, (bool, String)>,
    synced: Option<std::time::Instant>,
}

impl TopicIndex {
    pub(super) fn insert(&mut self, writer: bool, guid: GUID, topic: String, dds_type: String) {
        self.remove(&guid);
        self.by_topic
            .entry((writer, topic.clone()))
            .or_default()
            .insert(guid, dds_type);
        self.topic_of.insert(guid, (writer, topic));
    }

    /// The DDS type of endpoint `guid`, if it is known as a writer (`writer`) or reader.
    pub(super) fn type_of(&self, guid: &GUID, writer: bool) -> Option<String> {
        let key = self.topic_of.get(guid)?;
        if key.0 != writer {
            return None;
        }
        self.by_topic.get(key)?.get(guid).cloned()
    }

    pub(super) fn remove(&mut self, guid: &GUID) {
        if let Some(key) = self.topic_of.remove(guid) {
            if let Some(m) = self.by_topic.get_mut(&key) {
                m.remove(guid);
                if m.is_empty() {
                    self.by_topic.remove(&key);
                }
            }
        }
    }

    /// Makes the next lookup rebuild the index (over Zenoh, after each change of the tokens).
    #[cfg(feature = "zenoh")]
    pub(super) fn invalidate(&mut self) {
        self.synced = None;
    }

    pub(super) fn remove_matching(&mut self, pred: impl Fn(&GUID) -> bool) {
        let gone: Vec<GUID> = self.topic_of.keys().filter(|g| pred(g)).copied().collect();
        for g in gone {
            self.remove(&g);
        }
    }
}

impl Graph {
    /// Every endpoint on the graph that discovery knows, plus this participant's own registered ones:
    /// `(is_writer, ROS topic, DDS type)`. Copies all of discovery's data: for listings, not lookups
    /// ([`Graph::types_on`]).
    pub(crate) fn endpoints(&self) -> Vec<(bool, String, String)> {
        self.scan()
            .into_iter()
            .map(|(w, _, t, ty)| (w, t, ty))
            .collect()
    }

    pub(super) fn scan(&self) -> Vec<(bool, GUID, String, String)> {
        // over Zenoh every endpoint, this session's included, is in the tokens
        #[cfg(feature = "zenoh")]
        if let Some(all) = self.token_endpoints(false) {
            return all
                .into_iter()
                .filter_map(|(w, g, dds, ty)| {
                    crate::wire::dds_names::ros_topic(&dds).map(|t| (w, g, t.to_owned(), ty))
                })
                .collect();
        }
        let mut out = Vec::new();
        {
            let t = self.table.lock().unwrap();
            for (is_writer, map) in [(true, &t.writers), (false, &t.readers)] {
                for (g, e) in map.iter() {
                    if let Some((topic, ty)) = &e.identity {
                        out.push((is_writer, *g, topic.clone(), ty.clone()));
                    }
                }
            }
        }
        out.extend(
            self.remote_dds_endpoints()
                .into_iter()
                .filter_map(|(w, g, dds, ty)| {
                    crate::wire::dds_names::ros_topic(&dds).map(|t| (w, g, t.to_owned(), ty))
                }),
        );
        out
    }

    /// The DDS types of the writers (`writer`) or readers on the ROS `topic`, from the topic index
    /// (rebuilt from the discovery data when older than [`RESYNC`]).
    pub(crate) fn types_on(&self, writer: bool, topic: &str) -> BTreeSet<String> {
        self.indexed(|index| {
            index
                .by_topic
                .get(&(writer, topic.to_owned()))
                .map(|m| m.values().cloned().collect())
                .unwrap_or_default()
        })
    }

    /// The participants (participant GUIDs) with a writer on the ROS `topic`, from the topic index: for a
    /// RADAR component's `state` topic, the processes it runs in (one; two while a respawned one replaces one
    /// whose leaving is not known yet).
    pub(crate) fn writer_participants(&self, topic: &str) -> BTreeSet<GUID> {
        self.indexed(|index| {
            index
                .by_topic
                .get(&(true, topic.to_owned()))
                .map(|m| m.keys().map(|g| super::participant_of(*g)).collect())
                .unwrap_or_default()
        })
    }

    /// Whether the process `p` (a participant GUID) is off the graph but not yet taken as gone: over Zenoh, a
    /// session whose tokens all vanished less than the grace ago (a process killed: the router deletes its
    /// tokens at once; it has left once they stay gone for the grace, `run_tokens`). Always false over DDS,
    /// where a process stays on the graph until its lease runs out.
    pub(crate) fn vanished_within_lease(&self, p: GUID) -> bool {
        #[cfg(feature = "zenoh")]
        if let Some(present) = self.token_sessions() {
            return !present.contains(&p) && !self.has_left(p);
        }
        let _ = p;
        false
    }

    /// `f` on the topic index, rebuilt from the discovery data first when older than [`RESYNC`].
    fn indexed<R>(&self, f: impl FnOnce(&TopicIndex) -> R) -> R {
        let stale = self
            .index
            .lock()
            .unwrap()
            .synced
            .is_none_or(|at| at.elapsed() > RESYNC);
        if stale {
            let all = self.scan();
            let mut index = TopicIndex {
                synced: Some(std::time::Instant::now()),
                ..Default::default()
            };
            for (w, g, t, ty) in all {
                index.insert(w, g, t, ty);
            }
            *self.index.lock().unwrap() = index;
        }
        f(&self.index.lock().unwrap())
    }

    /// Waits (at most `within`) until a local writer has matched a reader on DDS topic `dds_topic` in the
    /// participant of `peer`; true if it has. A service reply must wait for this: a fresh client process
    /// (`ros2 service call`) may send its request before our reply writer has matched its reply reader, and
    /// a volatile writer sends nothing to a reader it has not matched. Returns at once for a peer in this
    /// participant (local matches are made when the endpoints are).
    pub(crate) async fn wait_reader_of(
        &self,
        dds_topic: &str,
        peer: GUID,
        within: std::time::Duration,
    ) -> bool {
        let deadline = tokio::time::Instant::now() + within;
        self.wait_for(deadline, || {
            self.has_reader_of(dds_topic, peer).then_some(())
        })
        .await
        .is_some()
    }

    pub(crate) fn has_reader_of(&self, dds_topic: &str, peer: GUID) -> bool {
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return true; // shutting down: nothing to wait for
        };
        if rustdds::RTPSEntity::guid(&p).prefix == peer.prefix {
            return true;
        }
        let candidates: BTreeSet<GUID> = {
            let t = self.table.lock().unwrap();
            t.writers
                .values()
                .flat_map(|e| e.peers.iter())
                .filter(|g| g.prefix == peer.prefix)
                .copied()
                .collect()
        };
        !candidates.is_empty()
            && p.discovered_readers().iter().any(|r| {
                candidates.contains(&r.reader_proxy.remote_reader_guid)
                    && r.subscription_topic_data.topic_name() == dds_topic
            })
    }

    /// The participants (as participant GUIDs) in which every `(remote_reads, dds_topic)` of `wanted` has an
    /// endpoint one of ours has matched: a remote reader on the topic that a local writer matched (`true`), or a
    /// remote writer that a local reader matched (`false`). How a client knows a service or an action server is
    /// reachable both ways before it sends a request. Endpoints in this participant are not seen here.
    pub(crate) fn participants_matched_on(&self, wanted: &[(bool, String)]) -> BTreeSet<GUID> {
        // over Zenoh an endpoint named by a token is reachable (no match to wait for)
        #[cfg(feature = "zenoh")]
        if let Some(remote) = self.token_endpoints(true) {
            let mut found: Option<BTreeSet<GUID>> = None;
            for (remote_reads, topic) in wanted {
                let here: BTreeSet<GUID> = remote
                    .iter()
                    .filter(|(w, _, t, _)| *w != *remote_reads && t == topic)
                    .map(|(_, g, _, _)| super::participant_of(*g))
                    .collect();
                found = Some(match found {
                    None => here,
                    Some(f) => f.intersection(&here).copied().collect(),
                });
            }
            return found.unwrap_or_default();
        }
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return BTreeSet::new();
        };
        let (writer_peers, reader_peers): (BTreeSet<GUID>, BTreeSet<GUID>) = {
            let t = self.table.lock().unwrap();
            (
                t.writers
                    .values()
                    .flat_map(|e| e.peers.iter())
                    .copied()
                    .collect(),
                t.readers
                    .values()
                    .flat_map(|e| e.peers.iter())
                    .copied()
                    .collect(),
            )
        };
        let participant_of = |g: GUID| {
            let mut who = GUID::new_participant_guid();
            who.prefix = g.prefix;
            who
        };
        let (readers, writers) = (p.discovered_readers(), p.discovered_writers());
        let mut found: Option<BTreeSet<GUID>> = None;
        for (remote_reads, topic) in wanted {
            let here: BTreeSet<GUID> = if *remote_reads {
                readers
                    .iter()
                    .filter(|r| r.subscription_topic_data.topic_name() == topic)
                    .map(|r| r.reader_proxy.remote_reader_guid)
                    .filter(|g| writer_peers.contains(g))
                    .map(participant_of)
                    .collect()
            } else {
                writers
                    .iter()
                    .filter(|w| &w.publication_topic_data.topic_name == topic)
                    .map(|w| w.writer_proxy.remote_writer_guid)
                    .filter(|g| reader_peers.contains(g))
                    .map(participant_of)
                    .collect()
            };
            found = Some(match found {
                None => here,
                Some(f) => f.intersection(&here).copied().collect(),
            });
        }
        found.unwrap_or_default()
    }

    /// Every endpoint of other participants that discovery knows: `(is_writer, GUID, DDS topic, DDS type)`,
    /// services' and actions' topics (`rq`, `rr`) included. For listings.
    pub(crate) fn remote_dds_endpoints(&self) -> Vec<(bool, GUID, String, String)> {
        #[cfg(feature = "zenoh")]
        if let Some(remote) = self.token_endpoints(true) {
            return remote;
        }
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return Vec::new();
        };
        let mut out: Vec<_> = p
            .discovered_writers()
            .into_iter()
            .map(|w| {
                (
                    true,
                    w.writer_proxy.remote_writer_guid,
                    w.publication_topic_data.topic_name,
                    w.publication_topic_data.type_name,
                )
            })
            .collect();
        out.extend(p.discovered_readers().into_iter().map(|r| {
            (
                false,
                r.reader_proxy.remote_reader_guid,
                r.subscription_topic_data.topic_name().clone(),
                r.subscription_topic_data.type_name().clone(),
            )
        }));
        out
    }

    /// The participants discovery knows (this one included): each one's GUID and the USER_DATA it announced
    /// (ROS 2's `enclave=/path;`).
    pub(crate) fn participants(&self) -> Vec<(GUID, Vec<u8>)> {
        // over Zenoh the tokens do not carry the enclave to radar_ros (ros2-client's parse drops it)
        #[cfg(feature = "zenoh")]
        if let Some(sessions) = self.token_sessions() {
            return sessions.into_iter().map(|g| (g, Vec::new())).collect();
        }
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return Vec::new();
        };
        p.discovered_participants()
            .into_iter()
            .map(|d| (d.guid, d.user_data))
            .collect()
    }

    /// What is known of whether the process of participant `p` still runs ([`super::processes`]): over
    /// Zenoh, a session that vanished within its grace is gone.
    pub(crate) fn liveness(&self, p: GUID) -> radar_semantics::instances::Liveness {
        if self.vanished_within_lease(p) {
            return radar_semantics::instances::Liveness::Dead;
        }
        self.participants()
            .into_iter()
            .find(|(g, _)| *g == p)
            .map_or(radar_semantics::instances::Liveness::Unknown, |(_, u)| {
                super::processes::liveness(&u)
            })
    }

    /// The process of participant `p`, as a user recognises it (`process 1234 on this host`).
    pub(crate) fn describe_process(&self, p: GUID) -> String {
        let user_data = self
            .participants()
            .into_iter()
            .find(|(g, _)| *g == p)
            .map(|(_, u)| u)
            .unwrap_or_default();
        super::processes::describe(&user_data, p.prefix.as_ref())
    }

    /// The DDS topics of discovered remote readers of DDS type `dds_type` (a service's servers, for its
    /// request type).
    pub(crate) fn discovered_reader_topics(&self, dds_type: &str) -> BTreeSet<String> {
        #[cfg(feature = "zenoh")]
        if let Some(remote) = self.token_endpoints(true) {
            return remote
                .into_iter()
                .filter(|(w, _, _, ty)| !*w && ty == dds_type)
                .map(|(_, _, t, _)| t)
                .collect();
        }
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return BTreeSet::new();
        };
        p.discovered_readers()
            .into_iter()
            .filter(|r| r.subscription_topic_data.type_name() == dds_type)
            .map(|r| r.subscription_topic_data.topic_name().clone())
            .collect()
    }

    /// The DDS type names that discovered remote readers on DDS topic `dds_topic` announce (a service's
    /// servers, for its request topic).
    pub(crate) fn discovered_reader_types(&self, dds_topic: &str) -> BTreeSet<String> {
        #[cfg(feature = "zenoh")]
        if let Some(remote) = self.token_endpoints(true) {
            return remote
                .into_iter()
                .filter(|(w, _, t, _)| !*w && t == dds_topic)
                .map(|(_, _, _, ty)| ty)
                .collect();
        }
        let Some(p) = self.participant.lock().unwrap().clone() else {
            return BTreeSet::new();
        };
        p.discovered_readers()
            .into_iter()
            .filter(|r| r.subscription_topic_data.topic_name() == dds_topic)
            .map(|r| r.subscription_topic_data.type_name().clone())
            .collect()
    }
}
