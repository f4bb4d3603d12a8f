//! Moving ROS messages through without knowing their Rust type: the basis of type-agnostic relays.
//!
//! A [`RawMessage`] is the CDR body of a message (what follows the 4-byte encapsulation header). CDR puts no
//! length before a tuple, and bytes have no alignment, so reading the body as a tuple of bytes ([`RawSeed`])
//! and writing it back as one ([`RawMessage`]'s `Serialize`) reproduces it exactly. A relay can therefore
//! forward any message type; only the type *name*, needed to match DDS topics, must be known at run time.
//!
//! Assumption: the body is little-endian CDR, as every ROS 2 RMW writes on little-endian machines (x86-64,
//! ARM64); the republished message is little-endian too.

use std::{fmt, time::Duration};

use futures::StreamExt;
use ros2_client::MessageTypeName;
use serde::{
    de::{DeserializeSeed, SeqAccess, Visitor},
    ser::SerializeTuple,
    Deserializer, Serialize, Serializer,
};

use crate::{
    endpoints::{signal_qos_depth, topic_name, Watched, SIGNAL_DEPTH},
    error::{Error, Result},
    radar::Radar,
};

/// The serialized CDR body of a ROS message of some type.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RawMessage(pub Vec<u8>);

impl Serialize for RawMessage {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(self.0.len())?;
        for b in &self.0 {
            t.serialize_element(b)?;
        }
        t.end()
    }
}

impl RawMessage {
    /// Encodes `m` as a little-endian CDR body.
    pub fn encode<M: serde::Serialize>(m: &M) -> Result<RawMessage> {
        ros2_client::dds::rustdds::cdr_encoding::to_vec::<M, byteorder::LittleEndian>(m)
            .map(RawMessage)
            .map_err(|e| Error::Dds {
                what: "a CDR encoding".into(),
                detail: e.to_string(),
            })
    }

    /// Decodes the body as `M` (little-endian CDR).
    pub fn decode<M: crate::msg::RosMessage>(&self) -> Result<M> {
        ros2_client::dds::rustdds::cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(&self.0)
            .map(|(m, _)| m)
            .map_err(|e| Error::Dds {
                what: format!("a {} from {} bytes", M::ros_type_name(), self.0.len()),
                detail: e.to_string(),
            })
    }
}

/// Reads a whole message body as a [`RawMessage`].
#[derive(Clone, Copy, Debug, Default)]
pub struct RawSeed;

impl<'de> DeserializeSeed<'de> for RawSeed {
    type Value = RawMessage;
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<RawMessage, D::Error> {
        d.deserialize_tuple(usize::MAX, RawVisitor)
    }
}

struct RawVisitor;

impl<'de> Visitor<'de> for RawVisitor {
    type Value = RawMessage;
    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("the bytes of a CDR message body")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<RawMessage, A::Error> {
        let mut bytes = Vec::new();
        // the body ends where the input ends: the deserializer reports that as an error, which is our stop
        while let Ok(Some(b)) = seq.next_element::<u8>() {
            bytes.push(b);
        }
        Ok(RawMessage(bytes))
    }
}

/// Parses `pkg/msg/Name` (or `pkg/Name`) into a DDS type name.
pub fn parse_type_name(ros_type: &str) -> Result<MessageTypeName> {
    let parts: Vec<&str> = ros_type.split('/').collect();
    let ok = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    match parts[..] {
        [pkg, "msg", name] | [pkg, name] if ok(pkg) && ok(name) => {
            Ok(MessageTypeName::new(pkg, name))
        }
        _ => Err(Error::InvalidName {
            name: ros_type.to_owned(),
            reason: "a message type is written package/msg/Name, e.g. std_msgs/msg/String".into(),
        }),
    }
}

/// A publisher of raw messages of a type known only by name.
pub struct RawPublisher {
    topic: String,
    ros_type: String,
    publisher: Watched<ros2_client::Publisher<RawMessage>>,
}

impl RawPublisher {
    /// Sends one message body as it is.
    pub fn publish(&self, m: RawMessage) -> Result<()> {
        self.publisher
            .publish(m)
            .map_err(|e| Error::dds(format!("a message on {}", self.topic), e))
    }

    /// Subscriptions (of the same type) matched now.
    pub fn subscribers(&self) -> usize {
        *self.publisher.matched.borrow()
    }

    /// Waits until at least `n` subscriptions of the same type are matched.
    pub async fn wait_for_subscribers(&self, n: usize, timeout: Duration) -> Result<()> {
        self.publisher
            .wait_matched(n, timeout, || {
                format!("{n} subscriber(s) on {} ({})", self.topic, self.ros_type)
            })
            .await
    }
}

/// A subscription delivering raw message bodies of a type known only by name.
pub struct RawSubscription {
    topic: String,
    ros_type: String,
    subscription: Watched<ros2_client::Subscription<RawMessage>>,
}

impl RawSubscription {
    /// The type, `pkg/msg/Name`.
    pub fn ros_type(&self) -> &str {
        &self.ros_type
    }

    /// Publishers (of the same type) matched now.
    pub fn publishers(&self) -> usize {
        *self.subscription.matched.borrow()
    }

    /// Waits until at least `n` publishers of the same type are matched.
    pub async fn wait_for_publishers(&self, n: usize, timeout: Duration) -> Result<()> {
        self.subscription
            .wait_matched(n, timeout, || {
                format!("{n} publisher(s) on {} ({})", self.topic, self.ros_type)
            })
            .await
    }

    /// The next message body with its source timestamp (ns since the epoch, 0 if unknown).
    pub async fn recv_stamped(&self) -> Result<(RawMessage, i64)> {
        let mut stream = Box::pin(self.subscription.async_stream_seed(RawSeed));
        loop {
            match stream.next().await {
                Some(Ok((_, info))) if !self.subscription.accepts(&info) => {}
                Some(Ok((m, info))) => {
                    return Ok((
                        m,
                        info.source_timestamp().map(|t| t.to_nanos()).unwrap_or(0),
                    ));
                }
                Some(Err(e)) => {
                    tracing::warn!(topic = %self.topic, error = %e, "skipped an unreadable sample")
                }
                None => return Err(Error::Closed(self.topic.clone())),
            }
        }
    }
}

impl Radar {
    /// A publisher of `ros_type` (e.g. `std_msgs/msg/String`) on `topic` that sends message bodies unchanged.
    pub fn raw_publisher(&self, topic: &str, ros_type: &str) -> Result<RawPublisher> {
        self.raw_publisher_depth(topic, ros_type, SIGNAL_DEPTH)
    }

    /// [`Radar::raw_publisher`] keeping the last `depth` messages (reliable, volatile).
    pub fn raw_publisher_depth(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
    ) -> Result<RawPublisher> {
        let topic = self.resolve(topic)?.fully_qualified();
        let ty = parse_type_name(ros_type)?;
        let qos = signal_qos_depth(depth);
        let publisher = self.with_client_node(|node| {
            let t = node
                .create_topic(&topic_name(&topic)?, ty.clone(), &qos)
                .map_err(|e| Error::dds(format!("topic {topic} ({ros_type})"), e))?;
            let p = node
                .create_publisher::<RawMessage>(&t, Some(qos.clone()))
                .map_err(|e| Error::dds(format!("a publisher on {topic}"), e))?;
            Ok(Watched::writer(self.graph(), p, &topic, &ty))
        })?;
        Ok(RawPublisher {
            topic,
            ros_type: ros_type.to_owned(),
            publisher,
        })
    }

    /// A subscription to `ros_type` on `topic` that yields message bodies unchanged.
    pub fn raw_subscription(&self, topic: &str, ros_type: &str) -> Result<RawSubscription> {
        self.raw_subscription_depth(topic, ros_type, SIGNAL_DEPTH)
    }

    /// [`Radar::raw_subscription`] keeping the last `depth` messages not yet taken (reliable, volatile).
    pub fn raw_subscription_depth(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
    ) -> Result<RawSubscription> {
        let topic = self.resolve(topic)?.fully_qualified();
        let ty = parse_type_name(ros_type)?;
        let qos = signal_qos_depth(depth);
        let subscription = self.with_client_node(|node| {
            let t = node
                .create_topic(&topic_name(&topic)?, ty.clone(), &qos)
                .map_err(|e| Error::dds(format!("topic {topic} ({ros_type})"), e))?;
            let s = node
                .create_subscription::<RawMessage>(&t, Some(qos.clone()))
                .map_err(|e| Error::dds(format!("a subscription on {topic}"), e))?;
            Ok(Watched::reader(self.graph(), s, &topic, &ty))
        })?;
        Ok(RawSubscription {
            topic,
            ros_type: ros_type.to_owned(),
            subscription,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_names_parse_or_say_how_to_write_them() {
        assert_eq!(
            parse_type_name("std_msgs/msg/String")
                .unwrap()
                .dds_msg_type(),
            "std_msgs::msg::dds_::String_"
        );
        assert_eq!(
            parse_type_name("std_msgs/Empty").unwrap().dds_msg_type(),
            "std_msgs::msg::dds_::Empty_"
        );
        for bad in [
            "String",
            "std_msgs/srv/X",
            "a/msg/b/c",
            "std-msgs/msg/X",
            "",
        ] {
            let e = parse_type_name(bad).unwrap_err().to_string();
            assert!(e.contains("package/msg/Name"), "{bad}: {e}");
        }
    }
}
