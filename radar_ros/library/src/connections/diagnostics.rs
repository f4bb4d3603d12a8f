//! Health where ROS tools look (issue 70): each program node and each manager node publishes
//! `diagnostic_msgs/msg/DiagnosticArray` on `/diagnostics`, as `diagnostic_updater` does (rqt_runtime_monitor,
//! the diagnostic aggregator and Foxglove's diagnostics panel read it), on every change of its connections and
//! once a second.
//!
//! | status `name` | level |
//! |---|---|
//! | `<node>: connections` (a summary) | the worst of those below |
//! | `<node>: connection <id>` | OK armed; WARN waiting for its source or target, suspended (its owner went silent), or its own code panicked; ERROR target lost |
//! | `<node>: malformed messages` (program nodes) | OK none; WARN messages dropped that did not decode as their slot's or topic's type |
//!
//! Each status's `values` carry what a person needs to act: the source, target and `until` topics, the owner,
//! what was delivered, who left, the last panic, and per topic and publisher the malformed counts.

use crate::{
    interfaces::diagnostic_msgs::msg::{DiagnosticArray, DiagnosticStatus, KeyValue},
    interfaces::std_msgs::msg::Header,
    node::endpoints::{emit, publish_connections, Watched},
    node::transport::Publisher,
    wire::malformed::MalformedCount,
    wire::msg::ConnectionList,
    wire::msg::{Connection, Time},
};

/// The topic every node publishes its health on, as ROS 2's `diagnostic_updater` does.
pub(crate) const TOPIC: &str = "/diagnostics";

/// Where a program or manager node shows its connections: their `connections` list, and their health on
/// `/diagnostics` (with the malformed messages of the process, for a program node).
pub(crate) struct Shown {
    /// The node's fully qualified name.
    pub node: String,
    /// `<node>/connections`.
    pub list: Watched<Publisher<ConnectionList>>,
    /// `/diagnostics` (none where the enclave's permissions do not grant it: [`health_publisher`]).
    pub health: Option<Watched<Publisher<DiagnosticArray>>>,
    /// The process's malformed messages, reported by this node (its program node's), or none.
    pub malformed: Option<crate::graph::Graph>,
}

impl Shown {
    /// Publishes `connections` as the list and as health (a change of the list).
    pub(crate) fn publish(&self, connections: Vec<Connection>) {
        self.health(&connections);
        publish_connections(&self.list, &self.node, connections);
    }

    /// Publishes the health of `connections` alone: the once-a-second beat (the list, transient-local, goes
    /// out on change only).
    pub(crate) fn health(&self, connections: &[Connection]) {
        if let Some(health) = &self.health {
            let malformed = self.malformed.as_ref().map(|g| g.malformed().counts());
            emit(
                health,
                TOPIC,
                array(&self.node, connections, malformed.as_deref()),
            );
        }
    }
}

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.to_owned(),
        value: value.to_string(),
    }
}

/// The `/diagnostics` publisher of node `node` (on `ros_node`), or none where a DDS Security enclave's permissions
/// do not grant it (a policy written before `/diagnostics` was published): the node runs without it and warns
/// once, saying what to grant.
pub(crate) fn health_publisher(
    graph: &crate::graph::Graph,
    ros_node: &mut crate::node::transport::RosNode,
    node: &str,
) -> crate::error::Result<Option<Watched<Publisher<DiagnosticArray>>>> {
    let qos = crate::wire::qos::signal_qos();
    match crate::node::endpoints::typed_publisher(graph, ros_node, TOPIC, &qos) {
        Ok(p) => Ok(Some(p)),
        Err(e) if e.not_allowed_by_security() => {
            tracing::warn!(
                node,
                "{TOPIC} is not granted by this enclave's permissions: {node} publishes no health there; grant \
                 publishing {TOPIC} in the enclave's policy (docs/security.md)"
            );
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// The status of one connection: its level, and why.
fn connection_status(node: &str, c: &Connection) -> DiagnosticStatus {
    let (level, why) = match (c.state, c.departure.is_empty()) {
        (Connection::STATE_TARGET_LOST, _) => (DiagnosticStatus::ERROR, c.state_label.clone()),
        (Connection::STATE_ARMED, true) if c.panics == 0 => {
            (DiagnosticStatus::OK, c.state_label.clone())
        }
        (Connection::STATE_ARMED, true) => (
            DiagnosticStatus::WARN,
            format!("{} panics in its code; the last: {}", c.panics, c.panic),
        ),
        // armed but suspended (its owner went silent), or waiting: who left and why
        (_, false) => (
            DiagnosticStatus::WARN,
            format!("{}: {}", c.state_label, c.departure),
        ),
        (_, true) => (DiagnosticStatus::WARN, c.state_label.clone()),
    };
    let mut values = vec![
        kv("kind", &c.kind_label),
        kv("source", &c.source),
        kv("target", &c.target),
        kv("until", &c.until),
        kv("state", &c.state_label),
        kv("owner", &c.owner),
        kv("delivered", c.delivered),
        kv("panics", c.panics),
    ];
    if !c.departure.is_empty() {
        values.push(kv("departure", &c.departure));
    }
    if !c.panic.is_empty() {
        values.push(kv("last panic", &c.panic));
    }
    DiagnosticStatus {
        level,
        name: format!("{node}: connection {}", c.id),
        message: why,
        hardware_id: node.to_owned(),
        values,
    }
}

/// The status of the messages this process dropped as malformed.
fn malformed_status(node: &str, malformed: &[MalformedCount]) -> DiagnosticStatus {
    let total: u64 = malformed.iter().map(|m| m.count).sum();
    let (level, message) = if total == 0 {
        (DiagnosticStatus::OK, "none".to_owned())
    } else {
        let topics: std::collections::BTreeSet<&str> =
            malformed.iter().map(|m| m.topic.as_str()).collect();
        (
            DiagnosticStatus::WARN,
            format!(
                "{total} dropped that did not decode as their type, on {}",
                topics.into_iter().collect::<Vec<_>>().join(", ")
            ),
        )
    };
    DiagnosticStatus {
        level,
        name: format!("{node}: malformed messages"),
        message,
        hardware_id: node.to_owned(),
        values: malformed
            .iter()
            .map(|m| {
                kv(
                    &format!("{} from {}", m.topic, m.publisher),
                    format!("{} (expected {})", m.count, m.expected),
                )
            })
            .collect(),
    }
}

/// What node `node` reports: a summary, one status per connection, and (given `malformed`) the messages this
/// process dropped.
pub(crate) fn array(
    node: &str,
    connections: &[Connection],
    malformed: Option<&[MalformedCount]>,
) -> DiagnosticArray {
    let mut status: Vec<DiagnosticStatus> = connections
        .iter()
        .map(|c| connection_status(node, c))
        .collect();
    let count = |level| status.iter().filter(|s| s.level == level).count();
    let message = format!(
        "{} connections: {} ok, {} warn, {} error",
        connections.len(),
        count(DiagnosticStatus::OK),
        count(DiagnosticStatus::WARN),
        count(DiagnosticStatus::ERROR)
    );
    if let Some(m) = malformed {
        status.push(malformed_status(node, m));
    }
    let summary = DiagnosticStatus {
        level: status
            .iter()
            .map(|s| s.level)
            .max()
            .unwrap_or(DiagnosticStatus::OK),
        name: format!("{node}: connections"),
        message,
        hardware_id: node.to_owned(),
        values: vec![kv("connections", connections.len())],
    };
    status.insert(0, summary);
    DiagnosticArray {
        header: Header {
            stamp: Time::now(),
            frame_id: String::new(),
        },
        status,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn conn(id: u64, state: u8, label: &str) -> Connection {
        Connection {
            id,
            state,
            state_label: label.into(),
            kind_label: "whenever".into(),
            source: "/e/triggered".into(),
            target: "/r/start".into(),
            ..Connection::default()
        }
    }

    #[test]
    fn each_condition_has_its_level_and_says_why() {
        let armed = conn(1, Connection::STATE_ARMED, "armed");
        let waiting = Connection {
            departure: "/e left (exited)".into(),
            ..conn(
                2,
                Connection::STATE_WAITING_FOR_SOURCE,
                "waiting for source",
            )
        };
        let lost = conn(3, Connection::STATE_TARGET_LOST, "target lost");
        let panicking = Connection {
            panics: 2,
            panic: "filter: boom".into(),
            ..conn(4, Connection::STATE_ARMED, "armed")
        };
        let silent = Connection {
            departure: "its owner /planner went silent".into(),
            ..conn(5, Connection::STATE_ARMED, "armed")
        };
        let bad = [MalformedCount {
            topic: "/r/start".into(),
            publisher: "0112ab".into(),
            expected: "std_msgs/msg/Empty".into(),
            count: 3,
        }];
        let a = array(
            "/prog",
            &[armed, waiting, lost, panicking, silent],
            Some(&bad),
        );
        let by_name = |n: &str| a.status.iter().find(|s| s.name == n).unwrap();
        assert_eq!(by_name("/prog: connection 1").level, DiagnosticStatus::OK);
        let w = by_name("/prog: connection 2");
        assert_eq!(w.level, DiagnosticStatus::WARN);
        assert!(w.message.contains("/e left"), "{}", w.message);
        assert_eq!(
            by_name("/prog: connection 3").level,
            DiagnosticStatus::ERROR
        );
        let p = by_name("/prog: connection 4");
        assert_eq!(p.level, DiagnosticStatus::WARN);
        assert!(p.message.contains("filter: boom"), "{}", p.message);
        assert!(by_name("/prog: connection 5")
            .message
            .contains("went silent"));
        let m = by_name("/prog: malformed messages");
        assert_eq!(m.level, DiagnosticStatus::WARN);
        assert!(m.message.starts_with("3 dropped"), "{}", m.message);
        let summary = &a.status[0];
        assert_eq!(
            (summary.name.as_str(), summary.level),
            ("/prog: connections", DiagnosticStatus::ERROR)
        );
        assert_eq!(summary.message, "5 connections: 1 ok, 3 warn, 1 error");
        // nothing wrong: all OK
        let fine = array(
            "/prog",
            &[conn(1, Connection::STATE_ARMED, "armed")],
            Some(&[]),
        );
        assert!(fine.status.iter().all(|s| s.level == DiagnosticStatus::OK));
        assert_eq!(
            fine.status[0].message,
            "1 connections: 1 ok, 0 warn, 0 error"
        );
    }
}
