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

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The policy (sros2's format 0.2.0, `radar security create_permission` reads it) granting the enclave
/// `enclave` what the nodes `nodes` of domain `domain` declared so far, one profile per node, every name
/// absolute.
pub(crate) fn policy_xml(domain: u16, nodes: &BTreeSet<String>, enclave: &str) -> String {
    let declared = DECLARED.lock().unwrap();
    let mut out = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- what the program declared (radar_ros, RADAR_GENERATE_POLICY) -->\n\
         <policy version=\"0.2.0\">\n  <enclaves>\n    <enclave path=\"{}\">\n      <profiles>\n",
        escape(enclave)
    );
    // what the ROS 2 context makes for every participant (ros2-client's /rosout and /parameter_events topics)
    out += "        <profile ns=\"/\" node=\"_ros_context\">\n          <topics publish=\"ALLOW\" subscribe=\"ALLOW\">\n            \
            <topic>/rosout</topic>\n            <topic>/parameter_events</topic>\n          </topics>\n        </profile>\n";
    for ((d, node), uses) in declared.iter() {
        if *d != domain || !nodes.contains(node) {
            continue;
        }
        let (ns, base) = match node.rsplit_once('/') {
            Some(("", b)) => ("/", b),
            Some((ns, b)) => (ns, b),
            None => ("/", node.as_str()),
        };
        out += &format!(
            "        <profile ns=\"{}\" node=\"{}\">\n",
            escape(ns),
            escape(base)
        );
        for (access, tag, item, attr) in [
            (Access::Publish, "topics", "topic", "publish"),
            (Access::Subscribe, "topics", "topic", "subscribe"),
            (Access::Reply, "services", "service", "reply"),
            (Access::Request, "services", "service", "request"),
            (Access::Call, "actions", "action", "call"),
            (Access::Execute, "actions", "action", "execute"),
        ] {
            let names: Vec<&String> = uses
                .iter()
                .filter(|(a, _)| *a == access)
                .map(|(_, n)| n)
                .collect();
            if names.is_empty() {
                continue;
            }
            out += &format!("          <{tag} {attr}=\"ALLOW\">\n");
            for n in names {
                out += &format!("            <{item}>{}</{item}>\n", escape(n));
            }
            out += &format!("          </{tag}>\n");
        }
        out += "        </profile>\n";
    }
    out += "      </profiles>\n    </enclave>\n  </enclaves>\n</policy>\n";
    out
}
