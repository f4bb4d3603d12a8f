//! The ROS 2 endpoints every component and the manager are made of: one way to create them on either transport
//! (their match counts and type filter are `watched.rs`'s), a component's signal writer, and small helpers of
//! components' tasks.

use ros2_client::QosProfile;

use radar_semantics::response::{Cause, Sent};

use crate::{
    error::{Error, Result},
    graph::Graph,
    node::transport::{Publisher, RosNode, Subscription},
    wire::local::{TapWriter, Taps},
    wire::msg::TypeName,
};

use crate::node::watched::over_dds;
pub(crate) use crate::node::watched::{topic_name, Watched};

/// The DDS topic for the absolute ROS `topic`. Made on the DDS participant directly rather than through
/// `Node::create_topic`, which can name only `msg` types (not the `action` ones an action's parts have).
fn topic(
    graph: &Graph,
    topic: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<ros2_client::dds::rustdds::Topic> {
    let name = topic_name(topic)?;
    if !name.is_absolute() {
        return Err(Error::InvalidName {
            name: topic.to_owned(),
            reason: "an endpoint's topic must be absolute here".into(),
        });
    }
    let mut dds_qos: ros2_client::dds::rustdds::QosPolicies = qos.into();
    // USER_DATA, which the endpoints made on this topic take: the type's hash as ROS 2 Jazzy announces it
    // (REP 2011), and for a reader that only observes, that it does (`graph/observers.rs`)
    let mut user_data = ty
        .hash
        .map(|h| format!("typehash={h};"))
        .unwrap_or_default();
    if observer {
        user_data.push_str(crate::graph::OBSERVER_USER_DATA);
    }
    if !user_data.is_empty() {
        dds_qos = dds_qos.with_user_data(user_data);
    }
    let participant = graph
        .domain_participant()
        .ok_or_else(|| Error::Closed(format!("the DDS participant (creating topic {topic})")))?;
    participant
        .create_topic(
            crate::wire::dds_names::topic(topic),
            ty.dds.clone(),
            &dds_qos,
            ros2_client::dds::rustdds::TopicKind::NoKey,
        )
        .map_err(|e| Error::transport(format!("topic {topic} ({})", ty.dds), e))
}

/// Creates a publisher of `M` on the absolute `topic`, announced as type `ty` (the Rust type only has to
/// serialize: a raw message is published under any type name), on the transport of `node`.
pub(crate) fn publisher<M: serde::Serialize + Send + Sync + 'static>(
    graph: &Graph,
    node: &mut RosNode,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    let made = match &mut *node {
        RosNode::Dds(dds) => dds_publisher(graph, dds, topic_abs, ty, qos),
        #[cfg(feature = "zenoh")]
        RosNode::Zenoh(z) => crate::node::zenoh::publisher(z, topic_abs, ty, qos),
    }?;
    crate::node::declared::record_node(node, crate::node::declared::Access::Publish, topic_abs);
    Ok(made)
}

fn dds_publisher<M: serde::Serialize>(
    graph: &Graph,
    node: &mut ros2_client::dds::Node,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    let t = topic(graph, topic_abs, ty, qos, false)?;
    let inner = node
        .create_publisher(&t, Some(qos.clone()))
        .map_err(|e| Error::transport(format!("a publisher on {topic_abs}"), e))?;
    let guid = inner.guid();
    let matched = graph.watch_writer(guid, topic_abs, &ty.dds);
    Ok(over_dds(Publisher::Dds(inner), guid, graph, matched))
}

/// Creates a subscription of `M` on the absolute `topic`, announced as type `ty`.
pub(crate) fn subscription<M: serde::de::DeserializeOwned + Send + Sync + 'static>(
    graph: &Graph,
    node: &mut RosNode,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Subscription<M>>> {
    subscription_as(graph, node, topic_abs, ty, qos, false)
}

/// [`subscription`], or with `observer` one that only observes: an event does not count it as a listener
/// (over DDS its USER_DATA says so, `graph/observers.rs`; over Zenoh it declares no liveliness token, so no
/// publisher counts it).
pub(crate) fn subscription_as<M: serde::de::DeserializeOwned + Send + Sync + 'static>(
    graph: &Graph,
    node: &mut RosNode,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<Watched<Subscription<M>>> {
    let made = match &mut *node {
        RosNode::Dds(dds) => dds_subscription(graph, dds, topic_abs, ty, qos, observer),
        #[cfg(feature = "zenoh")]
        RosNode::Zenoh(z) => crate::node::zenoh::subscription(z, topic_abs, ty, qos, observer),
    }?;
    crate::node::declared::record_node(node, crate::node::declared::Access::Subscribe, topic_abs);
    Ok(made)
}

fn dds_subscription<M: 'static>(
    graph: &Graph,
    node: &mut ros2_client::dds::Node,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<Watched<Subscription<M>>> {
    let t = topic(graph, topic_abs, ty, qos, observer)?;
    let inner = node
        .create_subscription(&t, Some(qos.clone()))
        .map_err(|e| Error::transport(format!("a subscription on {topic_abs}"), e))?;
    let guid = inner.guid();
    let matched = graph.watch_reader(guid, topic_abs, &ty.dds);
    if observer {
        graph.mark_observer(guid);
    }
    Ok(over_dds(Subscription::Dds(inner), guid, graph, matched))
}

/// Creates a publisher of `M` on the absolute `topic`, announced as `M`'s ROS type.
pub(crate) fn typed_publisher<M: crate::wire::msg::RosMessage>(
    graph: &Graph,
    node: &mut RosNode,
    topic_abs: &str,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    publisher(graph, node, topic_abs, &TypeName::of::<M>(), qos)
}

/// Creates a subscription of `M` on the absolute `topic`, announced as `M`'s ROS type.
pub(crate) fn typed_subscription<M: crate::wire::msg::RosMessage>(
    graph: &Graph,
    node: &mut RosNode,
    topic_abs: &str,
    qos: &QosProfile,
) -> Result<Watched<Subscription<M>>> {
    subscription(graph, node, topic_abs, &TypeName::of::<M>(), qos)
}

/// A component's signal writer: each signal goes to this process's connections first (its tap), then on DDS,
/// stamped with the time of emission and carrying the run's cause (rules R11-R13, C6; see [`crate::wire::cause`]).
pub(crate) struct SignalWriter<M: serde::Serialize> {
    dds: Watched<Publisher<M>>,
    tap: TapWriter,
}

impl<M: serde::Serialize> SignalWriter<M> {
    /// `dds`, which writes `ros_type` on `topic`, with its tap in `taps`.
    pub(crate) fn new(
        taps: &Taps,
        dds: Watched<Publisher<M>>,
        topic: &str,
        ros_type: &str,
    ) -> Self {
        let tap = taps.open(topic, ros_type, dds.id());
        SignalWriter { dds, tap }
    }

    /// Emits `m` now, carrying `cause` (`topic` names it in a warning); the source timestamp it carries.
    pub(crate) fn emit(&self, topic: &str, m: M, cause: Option<Cause>) -> i64 {
        let sent = Sent {
            at: self.tap.emit(&m, cause),
            by: cause,
        };
        if let Err(e) = self.dds.publish_sent(m, sent) {
            tracing::warn!(topic, error = %e.forget_data(), "could not publish");
        }
        sent.at
    }
}

impl<M: serde::Serialize> std::ops::Deref for SignalWriter<M> {
    type Target = Watched<Publisher<M>>;
    fn deref(&self) -> &Self::Target {
        &self.dds
    }
}

/// Publishes, logging (not failing) on error: a message that cannot be sent must not stop the component.
pub(crate) fn emit<M: serde::Serialize>(p: &Publisher<M>, topic: &str, m: M) {
    if let Err(e) = p.publish(m) {
        tracing::warn!(topic, error = %e.forget_data(), "could not publish");
    }
}

/// Publishes `connections` as the `connections` list of the program or manager node `node`.
pub(crate) fn publish_connections(
    p: &Publisher<crate::wire::msg::ConnectionList>,
    node: &str,
    connections: Vec<crate::wire::msg::Connection>,
) {
    let list = crate::wire::msg::ConnectionList {
        stamp: crate::wire::msg::Time::now(),
        manager: node.to_owned(),
        connections,
    };
    emit(p, "connections", list);
}

/// Text of a caught panic.
pub(crate) fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_owned()
    }
}

/// Spaces out publications of something that changes often (a `state`, a connection list): the first change
/// after a quiet spell goes out at once, later ones at most every `every`, and the last change always.
pub(crate) struct Throttle {
    every: std::time::Duration,
    last: tokio::time::Instant,
    dirty: bool,
}

impl Throttle {
    /// A throttle that has just published.
    pub(crate) fn new(every: std::time::Duration) -> Throttle {
        Throttle {
            every,
            last: tokio::time::Instant::now(),
            dirty: false,
        }
    }

    /// Something changed: whether to publish now (if not, [`Throttle::due`] says when).
    pub(crate) fn changed(&mut self) -> bool {
        if self.last.elapsed() >= self.every {
            self.published();
            true
        } else {
            self.dirty = true;
            false
        }
    }

    /// Record a publication made for another reason.
    pub(crate) fn published(&mut self) {
        self.last = tokio::time::Instant::now();
        self.dirty = false;
    }

    /// Resolves when a held-back change is due (never if none is); call [`Throttle::published`] after
    /// publishing it.
    pub(crate) async fn due(&self) {
        if self.dirty {
            tokio::time::sleep_until(self.last + self.every).await
        } else {
            std::future::pending().await
        }
    }
}

/// A service request that did not decode: dropped, counted (the transport does not say who sent it) and
/// logged once per service.
pub(crate) fn malformed(
    graph: &crate::graph::Graph,
    manager: &str,
    service: &str,
    e: &dyn std::fmt::Display,
) {
    let topic = format!("{manager}/{service}");
    let expected = format!("radar_msgs/srv/{}_Request", capitalized(service));
    graph.malformed().note(&topic, &expected, None, e);
}

fn capitalized(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// How long a reply waits for the caller's reply reader to be matched.
pub(crate) const REPLY_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// Answers request `id` of service `service` once our reply writer has matched the caller's reply reader
/// (at most [`REPLY_WAIT`]), in a task of its own so other requests are not held up. A fresh client process
/// (`ros2 service call`, rclpy's `call_async` right after `wait_for_service`) can send its request before
/// our side has matched its reply reader, and a reply sent then goes nowhere.
pub(crate) fn reply<Req, Resp>(
    srv: &std::sync::Arc<crate::node::transport::Server<Req, Resp>>,
    graph: &crate::graph::Graph,
    manager: &str,
    service: &'static str,
    id: ros2_client::RmwRequestId,
    resp: Resp,
) where
    Req: ros2_client::Message + Send + Sync + 'static,
    Resp: ros2_client::Message + Send + Sync + 'static,
{
    let (srv, graph) = (srv.clone(), graph.clone());
    let topic = crate::wire::dds_names::reply(&format!("{manager}/{service}"));
    tokio::spawn(async move {
        let caller: ros2_client::dds::rustdds::GUID = id.writer_gid.into();
        if srv.replies_need_match() && !graph.wait_reader_of(&topic, caller, REPLY_WAIT).await {
            tracing::debug!(%topic, "answering before the caller's reply reader is matched");
        }
        if let Err(e) = srv.async_send_response(id, resp).await {
            tracing::warn!(error = %crate::error::Report(&e), %service, "could not answer a request");
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_throttle_lets_the_first_change_through_and_holds_back_the_next() {
        let every = std::time::Duration::from_millis(100);
        let mut t = Throttle::new(every);
        tokio::time::advance(every).await;
        assert!(
            t.changed(),
            "first change after a quiet spell goes out at once"
        );
        assert!(!t.changed(), "the next one within `every` is held back");
        let t0 = tokio::time::Instant::now();
        t.due().await;
        assert_eq!(
            t0.elapsed(),
            every,
            "and is due `every` after the last publication"
        );
        t.published();
        // nothing held back: never due
        let due = tokio::time::timeout(every * 10, t.due()).await;
        assert!(due.is_err());
    }
}
