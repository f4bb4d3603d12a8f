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
pub(crate) fn record_node(node: &ros2_client::Node, access: Access, name: &str) {
    record(node.domain_id(), &node.fully_qualified_name(), access, name);
}

/// The policy (sros2's format 0.2.0, `radar security create_permission` reads it) granting the enclave
/// `enclave` what the nodes `nodes` of domain `domain` declared so far, one profile per node, every name
/// absolute.
pub(crate) fn policy_xml(domain: u16, nodes: &BTreeSet<String>, enclave: &str) -> String {
    use super::model::{Kind, Policy, Rule};
    let declared = DECLARED.lock().unwrap();
    let mut policy = Policy::default();
    // what the ROS 2 context makes for every participant (ros2-client's /rosout and /parameter_events topics)
    for access in ["publish", "subscribe"] {
        for t in ["/rosout", "/parameter_events"] {
            policy.add(
                enclave,
                "/",
                "_ros_context",
                Rule::allow(Kind::Topics, access),
                t,
            );
        }
    }
    for ((d, node), uses) in declared.iter() {
        if *d != domain || !nodes.contains(node) {
            continue;
        }
        let (ns, base) = match node.rsplit_once('/') {
            Some(("", b)) => ("/", b),
            Some((ns, b)) => (ns, b),
            None => ("/", node.as_str()),
        };
        let profile = policy.profile(enclave, ns, base);
        for (access, name) in uses {
            let rule = match access {
                Access::Publish => Rule::allow(Kind::Topics, "publish"),
                Access::Subscribe => Rule::allow(Kind::Topics, "subscribe"),
                Access::Reply => Rule::allow(Kind::Services, "reply"),
                Access::Request => Rule::allow(Kind::Services, "request"),
                Access::Call => Rule::allow(Kind::Actions, "call"),
                Access::Execute => Rule::allow(Kind::Actions, "execute"),
            };
            profile.entry(rule).or_default().insert(name.clone());
        }
    }
    policy.to_xml("what the program declared (radar_ros, RADAR_GENERATE_POLICY)")
}
