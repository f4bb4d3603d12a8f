//! QoS and topic helpers shared by the ROS 2 binding.

use ros2_client::{
    qos::{Durability, History},
    Name, Node, Publisher, QosProfile, Subscription,
};

use crate::{
    error::{Error, Result},
    msg::RosMessage,
};

/// QoS of every signal and slot topic: reliable, volatile, keep-last 10 (rclpy's and `ros2 topic pub`'s
/// default, so command-line tools match it).
pub fn signal_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// QoS of `state` topics: reliable, transient-local, keep-last 1, so a late subscriber gets the current state.
pub fn state_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

fn topic_name(topic: &str) -> Result<Name> {
    Name::parse(topic).map_err(|e| Error::InvalidName {
        name: topic.to_owned(),
        reason: format!("{e}"),
    })
}

/// Creates a publisher of `M` on the absolute topic `topic`.
pub(crate) fn publisher<M: RosMessage>(
    node: &mut Node,
    topic: &str,
    qos: &QosProfile,
) -> Result<Publisher<M>> {
    let t = node
        .create_topic(&topic_name(topic)?, M::message_type_name(), qos)
        .map_err(|e| Error::dds(format!("topic {topic} ({})", M::ros_type_name()), e))?;
    node.create_publisher(&t, Some(qos.clone()))
        .map_err(|e| Error::dds(format!("a publisher on {topic}"), e))
}

/// Creates a subscription of `M` on the absolute topic `topic`.
pub(crate) fn subscription<M: RosMessage>(
    node: &mut Node,
    topic: &str,
    qos: &QosProfile,
) -> Result<Subscription<M>> {
    let t = node
        .create_topic(&topic_name(topic)?, M::message_type_name(), qos)
        .map_err(|e| Error::dds(format!("topic {topic} ({})", M::ros_type_name()), e))?;
    node.create_subscription(&t, Some(qos.clone()))
        .map_err(|e| Error::dds(format!("a subscription on {topic}"), e))
}

/// Publishes, logging (not failing) on error: a signal that cannot be sent must not stop the component.
pub(crate) fn emit<M: RosMessage>(p: &Publisher<M>, topic: &str, m: M) {
    if let Err(e) = p.publish(m) {
        tracing::warn!(topic, error = ?e, "could not publish");
    }
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
