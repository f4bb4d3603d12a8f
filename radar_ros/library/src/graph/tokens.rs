//! Over Zenoh, the graph's other half: the endpoints and processes of the ROS graph from the liveliness tokens
//! (ros2-client patch 17: each token with the session that declared it), named as DDS discovery names them
//! (topics `rt/...`, a service's `rq/...Request` and `rr/...Reply`, each endpoint a GUID whose prefix is its
//! process), so that the graph's lookups (`discovery.rs`: types on a topic, the processes that serve a manager
//! or run a component) answer the same over either transport. Match counts over Zenoh are not here: each
//! endpoint watches its own (`node/watched.rs`).

use std::collections::BTreeSet;

use ros2_client::{dds::rustdds::GUID, zenoh::ParsedEntity, EntityKind};

use super::Graph;
use crate::wire::dds_names;

/// The Zenoh session a graph reads its tokens from, its own id (to tell its own endpoints apart), and how long
/// a session's tokens must stay gone for it to be taken as gone (the lease).
#[derive(Clone)]
pub(super) struct Tokens {
    ctx: ros2_client::zenoh::Context,
    own: String,
    grace: std::time::Duration,
}

/// The participant GUID of the Zenoh session `zid` (its hex id, as tokens write it): the first 12 bytes of the id
/// are the prefix, as a DDS participant's.
pub(crate) fn participant_of_session(zid: &str) -> GUID {
    endpoint_guid(zid, None)
}

/// The GUID of entity `(node_id, entity_id)` of session `zid`, or with `None` the session's participant GUID.
fn endpoint_guid(zid: &str, entity: Option<(u64, u64)>) -> GUID {
    let mut bytes = [0u8; 16];
    for (i, pair) in zid.as_bytes().chunks(2).take(12).enumerate() {
        bytes[i] = std::str::from_utf8(pair)
            .ok()
            .and_then(|h| u8::from_str_radix(h, 16).ok())
            .unwrap_or(0);
    }
    match entity {
        // a participant's entity id, as DDS writes it
        None => bytes[12..].copy_from_slice(&[0, 0, 1, 0xc1]),
        Some((node, entity)) => {
            let id = ((node as u32) << 20) | (entity as u32 & 0xf_ffff);
            bytes[12..].copy_from_slice(&id.to_be_bytes());
        }
    }
    GUID::from_bytes(bytes)
}

/// What DDS discovery would say of the token `e`: its endpoints as `(is_writer, GUID, DDS topic, DDS type)`
/// (a service's server reads its requests and writes its replies; a client the other way round); none for a
/// node.
fn as_dds(e: &ParsedEntity) -> Vec<(bool, GUID, String, String)> {
    let (Some(name), Some(ty)) = (&e.topic_name, &e.type_name) else {
        return Vec::new();
    };
    let guid = endpoint_guid(&e.zid, Some((e.node_id, e.entity_id)));
    let service = |ends: [bool; 2]| {
        let base = ty.strip_suffix('_').unwrap_or(ty);
        vec![
            (
                ends[0],
                guid,
                dds_names::request(name),
                format!("{base}_Request_"),
            ),
            (
                ends[1],
                guid,
                dds_names::reply(name),
                format!("{base}_Response_"),
            ),
        ]
    };
    match e.kind {
        EntityKind::Publisher => vec![(true, guid, dds_names::topic(name), ty.clone())],
        EntityKind::Subscription => vec![(false, guid, dds_names::topic(name), ty.clone())],
        EntityKind::ServiceServer => service([false, true]),
        EntityKind::ServiceClient => service([true, false]),
        EntityKind::Node => Vec::new(),
    }
}

impl Graph {
    /// Reads the graph from the tokens of the Zenoh session `ctx` from now on (over Zenoh, instead of
    /// [`Graph::set_participant`]); a session whose tokens are gone for `grace` has left.
    pub(crate) fn set_zenoh(&self, ctx: ros2_client::zenoh::Context, grace: std::time::Duration) {
        let own = ctx.session().zid().to_string();
        *self.zenoh.lock().unwrap() = Some(Tokens { ctx, own, grace });
    }

    /// This session's participant GUID over Zenoh (`None` over DDS).
    pub(super) fn own_session(&self) -> Option<GUID> {
        let z = self.zenoh.lock().unwrap();
        z.as_ref().map(|t| participant_of_session(&t.own))
    }

    /// Over Zenoh, the endpoints the tokens name (`remote`: of other sessions only), as DDS discovery names
    /// them; `None` over DDS.
    pub(super) fn token_endpoints(
        &self,
        remote: bool,
    ) -> Option<Vec<(bool, GUID, String, String)>> {
        let t = self.zenoh.lock().unwrap().clone()?;
        Some(
            t.ctx
                .graph_entities()
                .iter()
                .filter(|(_, e)| !remote || e.zid != t.own)
                .flat_map(|(_, e)| as_dds(e))
                .collect(),
        )
    }

    /// Over Zenoh, the sessions on the graph (this one included), as participant GUIDs; `None` over DDS.
    pub(super) fn token_sessions(&self) -> Option<BTreeSet<GUID>> {
        let t = self.zenoh.lock().unwrap().clone()?;
        Some(
            t.ctx
                .graph_entities()
                .iter()
                .map(|(_, e)| participant_of_session(&e.zid))
                .collect(),
        )
    }

    /// Over Zenoh, the nodes of the other sessions (their `NN` tokens), each with the topics and services its
    /// endpoints' tokens name, and the enclave its token names. `None` over DDS.
    pub(crate) fn token_nodes(&self) -> Option<Vec<super::GraphNode>> {
        let t = self.zenoh.lock().unwrap().clone()?;
        let mut nodes: std::collections::BTreeMap<(String, u64), super::GraphNode> =
            Default::default();
        for (_, e) in t
            .ctx
            .graph_entities()
            .iter()
            .filter(|(_, e)| e.zid != t.own)
        {
            let node =
                nodes
                    .entry((e.zid.clone(), e.node_id))
                    .or_insert_with(|| super::GraphNode {
                        namespace: e.namespace.clone(),
                        name: e.node_name.clone(),
                        enclave: e.enclave.clone(),
                        ..Default::default()
                    });
            for (writer, _, dds, _) in as_dds(e) {
                node.uses(writer, &dds);
            }
        }
        Some(nodes.into_values().collect())
    }

    /// Over Zenoh, the process (its session's participant GUID) of the endpoint whose GID is `gid` (what a
    /// sample's or a request's attachment names), if a token names it; `None` over DDS or for an unknown GID.
    pub(crate) fn session_of_gid(&self, gid: ros2_client::Gid) -> Option<GUID> {
        let t = self.zenoh.lock().unwrap().clone()?;
        t.ctx
            .graph_entities()
            .iter()
            .find(|(g, _)| *g == gid)
            .map(|(_, e)| participant_of_session(&e.zid))
    }

    /// Over Zenoh: follows the tokens until `stop` fires, telling of each change ([`Graph::changes`]) and of
    /// each session that left ([`Graph::participants_lost`], [`Graph::has_left`]): one whose tokens have all been
    /// gone for the grace (a router restart makes every other session's tokens vanish for a moment: not a
    /// departure, as a DDS peer silent for less than its lease is not one).
    pub(crate) async fn run_tokens(self, mut stop: tokio::sync::oneshot::Receiver<()>) {
        let Some(t) = self.zenoh.lock().unwrap().clone() else {
            return;
        };
        let events = t.ctx.graph_event_stream();
        let mut present = self.token_sessions().unwrap_or_default();
        // sessions whose tokens are gone, since when
        let mut missing: std::collections::HashMap<GUID, tokio::time::Instant> = Default::default();
        let mut check =
            tokio::time::interval((t.grace / 4).max(std::time::Duration::from_millis(50)));
        loop {
            tokio::select! {
                _ = &mut stop => break,
                _ = check.tick() => {
                    let gone: Vec<GUID> = missing
                        .iter()
                        .filter(|(_, since)| since.elapsed() >= t.grace)
                        .map(|(g, _)| *g)
                        .collect();
                    for g in gone {
                        missing.remove(&g);
                        Graph::note_left(&mut self.table.lock().unwrap(), g);
                        let _ = self.lost.send(g);
                    }
                }
                ev = events.recv() => {
                    if ev.is_err() {
                        break;
                    }
                    // a burst of tokens (a process starting) is read once
                    while events.try_recv().is_ok() {}
                    let now = self.token_sessions().unwrap_or_default();
                    for g in present.difference(&now) {
                        missing.entry(*g).or_insert_with(tokio::time::Instant::now);
                    }
                    for g in &now {
                        missing.remove(g);
                    }
                    present = now;
                    self.index.lock().unwrap().invalidate();
                    self.changed.send_modify(|g| *g = g.wrapping_add(1));
                }
            }
        }
        self.zenoh.lock().unwrap().take();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sessions_endpoints_share_its_participant_and_differ_from_each_other() {
        let zid = "a1b2c3d4e5f60718293a4b5c6d7e8f90";
        let p = participant_of_session(zid);
        let a = endpoint_guid(zid, Some((0, 1)));
        let b = endpoint_guid(zid, Some((0, 2)));
        let c = endpoint_guid(zid, Some((1, 1)));
        assert_eq!(super::super::participant_of(a), p);
        assert_eq!(super::super::participant_of(c), p);
        assert!(a != b && a != c && b != c);
        assert_ne!(
            participant_of_session("ffb2c3d4e5f60718293a4b5c6d7e8f90"),
            p,
            "another session is another participant"
        );
    }
}
