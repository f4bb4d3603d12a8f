//! What this process's nodes declared on the ROS graph (every topic, service and action radar_ros made for
//! them), for writing the access-control policy of a program from what it does ([`crate::Radar::policy`],
//! `RADAR_GENERATE_POLICY`): a response's node reads its slots and writes its signals, the program node that
//! drives it writes its slots, and so on. Recorded in every build (a recording run is usually plain); kept per
//! domain and node for the life of the process.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Mutex;

/// How a node uses a name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Access {
    /// It writes the topic.
    Publish,
    /// It reads the topic.
    Subscribe,
    /// It serves the service.
    Reply,
    /// It calls the service.
    Request,
    /// It sends goals to the action.
    Call,
    /// It serves the action.
    Execute,
}

type Node = (u16, String);

static DECLARED: Mutex<BTreeMap<Node, BTreeSet<(Access, String)>>> = Mutex::new(BTreeMap::new());

/// Notes that the node `node` (fully qualified) of domain `domain` uses `name` (fully qualified) as `access`.
pub(crate) fn record(domain: u16, node: &str, access: Access, name: &str) {
    DECLARED
        .lock()
        .unwrap()
        .entry((domain, node.to_owned()))
        .or_default()
        .insert((access, name.to_owned()));
}

/// [`record`] for a ros2-client node.
pub(crate) fn record_node(node: &crate::node::transport::RosNode, access: Access, name: &str) {
    record(node.domain_id(), &node.fully_qualified_name(), access, name);
}

/// What the nodes `nodes` of domain `domain` declared so far: each node (fully qualified) with its uses.
pub(crate) fn uses(
    domain: u16,
    nodes: &BTreeSet<String>,
) -> Vec<(String, BTreeSet<(Access, String)>)> {
    DECLARED
        .lock()
        .unwrap()
        .iter()
        .filter(|((d, node), _)| *d == domain && nodes.contains(node))
        .map(|((_, node), uses)| (node.clone(), uses.clone()))
        .collect()
}
