//! The ROS nodes on the graph: what each program says of its nodes on `ros_discovery_info` (a node's name and
//! its endpoints' GUIDs), joined with DDS discovery (each endpoint's topic, each participant's enclave).

use std::collections::{BTreeSet, HashMap};

use ros2_client::{dds::rustdds::GUID, entities_info::ParticipantEntitiesInfo, Gid};

use super::Graph;
use crate::error::{Error, Result};

/// A reader of `ros_discovery_info`, made before the graph settles: each participant's writer is durable, so
/// its last sample comes when the reader matches it (see [`DiscoveryInfo::take`]). Over Zenoh there is none:
/// the nodes are the liveliness tokens' (`tokens.rs`).
pub(crate) struct DiscoveryInfo {
    reader: Option<ros2_client::dds::rustdds::no_key::DataReaderCdr<ParticipantEntitiesInfo>>,
    me: GUID,
}

impl DiscoveryInfo {
    /// Starts reading `ros_discovery_info` on the graph's participant (over Zenoh, nothing to start).
    pub(crate) fn read(graph: &Graph) -> Result<DiscoveryInfo> {
        use ros2_client::{builtin_topics::ros_discovery, dds::rustdds};
        #[cfg(feature = "zenoh")]
        if let Some(me) = graph.own_session() {
            return Ok(DiscoveryInfo { reader: None, me });
        }
        let dp = graph
            .domain_participant()
            .ok_or_else(|| Error::Closed("the DDS participant".into()))?;
        let what = "read ros_discovery_info";
        let qos = rustdds::QosPolicyBuilder::new()
            .durability(rustdds::policy::Durability::TransientLocal)
            .reliable(rustdds::Duration::ZERO)
            .history(rustdds::policy::History::KeepLast { depth: 4096 })
            .build();
        let topic = dp
            .create_topic(
                ros_discovery::TOPIC_NAME.to_owned(),
                ros_discovery::TYPE_NAME.to_owned(),
                &qos,
                rustdds::TopicKind::NoKey,
            )
            .map_err(|e| Error::transport(what, e))?;
        let reader = dp
            .create_subscriber(&qos)
            .and_then(|s| {
                s.create_datareader_no_key_cdr::<ParticipantEntitiesInfo>(&topic, Some(qos))
            })
            .map_err(|e| Error::transport(what, e))?;
        Ok(DiscoveryInfo {
            reader: Some(reader),
            me: rustdds::RTPSEntity::guid(&dp),
        })
    }

    /// The nodes of the other programs the samples received so far describe (see [`Graph::nodes`]); over
    /// Zenoh, those the tokens name now.
    pub(crate) fn take(self, graph: &Graph) -> Vec<GraphNode> {
        let Some(mut reader) = self.reader else {
            #[cfg(feature = "zenoh")]
            return graph.token_nodes().unwrap_or_default();
            #[cfg(not(feature = "zenoh"))]
            return Vec::new();
        };
        let mut infos: Vec<ParticipantEntitiesInfo> = Vec::new();
        let mut bad = 0;
        while bad < 1000 {
            match reader.take_next_sample() {
                Ok(Some(s)) => infos.push(s.into_value()),
                Ok(None) => break,
                // a sample that does not decode (a peer's bad node name): the others still count
                Err(e) => {
                    bad += 1;
                    tracing::debug!(error = %crate::error::Report(&e), "an undecodable ros_discovery_info sample")
                }
            }
        }
        graph.nodes(&infos, self.me)
    }
}

/// A ROS node of another program on the graph, as `ros2 node info` shows it: its name, the security enclave
/// its participant announced (ROS 2 writes `enclave=/path;` in the participant's DDS USER_DATA; `/` when it
/// runs in none) and the names it uses. Services it serves or calls are by service name; an action shows as
/// its services and topics (`<action>/_action/send_goal`, `<action>/_action/feedback`, ...), as ROS 2's graph
/// API shows it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GraphNode {
    /// The node's namespace (`/`, `/robot`).
    pub namespace: String,
    /// The node's name in its namespace.
    pub name: String,
    /// The enclave its participant announced (`/` if none).
    pub enclave: String,
    /// The topics it publishes.
    pub publishes: BTreeSet<String>,
    /// The topics it subscribes to.
    pub subscribes: BTreeSet<String>,
    /// The services it serves.
    pub serves: BTreeSet<String>,
    /// The services it calls.
    pub calls: BTreeSet<String>,
}

impl GraphNode {
    /// The node's fully qualified name (`/robot/planner`).
    pub fn fully_qualified(&self) -> String {
        match self.namespace.as_str() {
            "/" | "" => format!("/{}", self.name),
            ns => format!("{ns}/{}", self.name),
        }
    }

    /// Notes that the node writes (`writer`) or reads the DDS topic `dds`: a topic it publishes or subscribes
    /// to, or a service it serves (reads its requests, writes its replies) or calls.
    pub(super) fn uses(&mut self, writer: bool, dds: &str) {
        use crate::wire::dds_names as w;
        let (name, set) = if let Some(t) = w::ros_topic(dds) {
            (t, [&mut self.subscribes, &mut self.publishes])
        } else if let Some(s) = w::service_of_request(dds) {
            (s, [&mut self.serves, &mut self.calls])
        } else if let Some(s) = w::service_of_reply(dds) {
            (s, [&mut self.calls, &mut self.serves])
        } else {
            return;
        };
        let [if_reads, if_writes] = set;
        match writer {
            true => if_writes,
            false => if_reads,
        }
        .insert(name.to_owned());
    }
}

/// The `enclave` of a participant's USER_DATA (`key=value;` pairs, as rmw_dds_common writes and reads them);
/// `/` when it names none.
fn enclave_of(user_data: &[u8]) -> String {
    String::from_utf8_lossy(user_data)
        .split(';')
        .find_map(|kv| kv.trim().strip_prefix("enclave=").map(str::to_owned))
        .filter(|e| !e.is_empty())
        .unwrap_or_else(|| "/".to_owned())
}

impl Graph {
    /// The nodes that `infos` (`ros_discovery_info` samples, oldest first: the last of each participant counts)
    /// name, of participants discovery still knows other than `me`, with their enclaves and the names they use.
    pub(crate) fn nodes(&self, infos: &[ParticipantEntitiesInfo], me: GUID) -> Vec<GraphNode> {
        let enclaves: HashMap<Gid, String> = self
            .participants()
            .into_iter()
            .filter(|(g, _)| *g != me)
            .map(|(g, ud)| (Gid::from(g), enclave_of(&ud)))
            .collect();
        let endpoints: HashMap<Gid, (bool, String)> = self
            .remote_dds_endpoints()
            .into_iter()
            .map(|(w, g, topic, _)| (Gid::from(g), (w, topic)))
            .collect();
        let latest: HashMap<Gid, &ParticipantEntitiesInfo> =
            infos.iter().map(|i| (i.gid(), i)).collect();
        let mut out = Vec::new();
        for (gid, info) in latest {
            // a participant that left, or this one
            let Some(enclave) = enclaves.get(&gid) else {
                continue;
            };
            for n in info.nodes() {
                let mut node = GraphNode {
                    namespace: n.namespace().to_owned(),
                    name: n.name().to_owned(),
                    enclave: enclave.clone(),
                    ..GraphNode::default()
                };
                let uses = n
                    .writers()
                    .iter()
                    .chain(n.readers())
                    .filter_map(|g| endpoints.get(g));
                for (writer, dds) in uses {
                    node.uses(*writer, dds);
                }
                out.push(node);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_participants_enclave_is_read_as_rmw_writes_it() {
        assert_eq!(enclave_of(b"enclave=/robot/planner;"), "/robot/planner");
        assert_eq!(enclave_of(b"securitycontext=x;enclave=/a;"), "/a");
        assert_eq!(enclave_of(b""), "/");
        assert_eq!(enclave_of(b"enclave=;"), "/");
    }

    #[test]
    fn a_nodes_endpoints_are_sorted_into_topics_and_services_both_ways() {
        let mut n = GraphNode::default();
        n.uses(true, "rt/dock/exited");
        n.uses(false, "rt/dock/start");
        n.uses(false, "rq/dock/get_parametersRequest");
        n.uses(true, "rr/dock/get_parametersReply");
        n.uses(true, "rq/radar_manager/connectRequest");
        n.uses(false, "rr/radar_manager/connectReply");
        n.uses(true, "ros_discovery_info");
        let set = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<BTreeSet<_>>();
        assert_eq!(n.publishes, set(&["/dock/exited"]));
        assert_eq!(n.subscribes, set(&["/dock/start"]));
        assert_eq!(n.serves, set(&["/dock/get_parameters"]));
        assert_eq!(n.calls, set(&["/radar_manager/connect"]));
    }
}
