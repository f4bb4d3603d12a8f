//! Moving ROS messages through without knowing their Rust type: the basis of type-agnostic relays. The
//! endpoints that carry them are [`RawPublisher`](crate::topics::RawPublisher) and
//! [`RawSubscription`](crate::topics::RawSubscription).
//!
//! A [`RawMessage`] is the CDR body of a message (what follows the 4-byte encapsulation header). CDR puts no
//! length before a tuple, and bytes have no alignment, so reading the body as a tuple of bytes ([`RawSeed`])
//! and writing it back as one ([`RawMessage`]'s `Serialize`) reproduces it exactly. A relay can therefore
//! forward any message type; only the type *name*, needed to match DDS topics, must be known at run time.
//!
//! Assumption: the body is little-endian CDR, as every ROS 2 RMW writes on little-endian machines (x86-64,
//! ARM64); the republished message is little-endian too.

use std::fmt;

use serde::{
    de::{DeserializeSeed, SeqAccess, Visitor},
    ser::SerializeTuple,
    Deserialize, Deserializer, Serialize, Serializer,
};

use crate::error::{Error, Result};
use crate::wire::msg::RosMessage;

/// The serialized CDR body of a ROS message of some type.
///
/// ```
/// use radar_ros::{topics::RawMessage, msg::StringMsg};
/// let raw = RawMessage::encode(&StringMsg::from("kitchen")).unwrap();
/// let back: StringMsg = raw.decode().unwrap();
/// assert_eq!(back.data, "kitchen");
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RawMessage(Vec<u8>);

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
    /// A body from its bytes (little-endian CDR, without the 4-byte encapsulation header).
    pub fn from_bytes(bytes: Vec<u8>) -> RawMessage {
        RawMessage(bytes)
    }

    /// Its bytes.
    pub fn as_bytes(&self) -> &[u8] {
        &self.0
    }

    /// Its bytes, taken.
    pub fn into_bytes(self) -> Vec<u8> {
        self.0
    }

    /// How many bytes it has.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether it has none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Encodes `m` as a little-endian CDR body.
    pub fn encode<M: serde::Serialize>(m: &M) -> Result<RawMessage> {
        ros2_client::dds::rustdds::cdr_encoding::to_vec::<M, byteorder::LittleEndian>(m)
            .map(RawMessage)
            .map_err(|e| Error::codec("encode a message as CDR", e))
    }

    /// Decodes the body as `M` (little-endian CDR).
    ///
    /// ```
    /// use radar_ros::{topics::RawMessage, msg::Int32};
    /// let raw = RawMessage::encode(&Int32 { data: 7 }).unwrap();
    /// assert_eq!(raw.decode::<Int32>().unwrap().data, 7);
    /// assert!(RawMessage::from_bytes(vec![1]).decode::<Int32>().is_err()); // too short: a codec error
    /// ```
    pub fn decode<M: crate::wire::msg::RosMessage>(&self) -> Result<M> {
        let (m, used) = ros2_client::dds::rustdds::cdr_encoding::from_bytes::<
            M,
            byteorder::LittleEndian,
        >(&self.0)
        .map_err(|e| {
            Error::codec(
                format!(
                    "decode a {} from {} bytes",
                    M::ros_type_name(),
                    self.0.len()
                ),
                e,
            )
        })?;
        // what is left beyond the alignment padding of the last field is another definition's
        if self.0.len().saturating_sub(used) >= crate::wire::msg::PADDING {
            return Err(Error::codec(
                format!(
                    "decode a {} from {} bytes: {} bytes are left over (a peer of another definition of the type?)",
                    M::ros_type_name(),
                    self.0.len(),
                    self.0.len() - used
                ),
                std::io::Error::from(std::io::ErrorKind::InvalidData),
            ));
        }
        Ok(m)
    }
}

/// A whole message body, as the subscriptions over DDS read it (with a seed): what a typed subscription of
/// `RawMessage` yields over Zenoh, where the backend's subscriptions decode with `Deserialize`.
impl<'de> Deserialize<'de> for RawMessage {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<RawMessage, D::Error> {
        RawSeed.deserialize(d)
    }
}

/// Reads a whole message body as a [`RawMessage`].
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RawSeed;

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

/// Parses `pkg/msg/Name` (or `pkg/Name`, or `pkg/action/Name_Goal` for a part of an action) into a type name.
pub(crate) fn parse_type_name(ros_type: &str) -> Result<crate::wire::msg::TypeName> {
    let parts: Vec<&str> = ros_type.split('/').collect();
    let ok = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    match parts[..] {
        [pkg, "msg", name] | [pkg, name] if ok(pkg) && ok(name) => {
            Ok(crate::wire::msg::TypeName::new(pkg, "msg", name))
        }
        [pkg, "action", name] if ok(pkg) && ok(name) => {
            Ok(crate::wire::msg::TypeName::new(pkg, "action", name))
        }
        _ => Err(Error::InvalidName {
            name: ros_type.to_owned(),
            reason: "a message type is written package/msg/Name, e.g. std_msgs/msg/String \
                     (package/action/Name_Goal for a part of an action)"
                .into(),
        }),
    }
}

/// A message whose ROS type is known only at run time: its CDR body, as [`RawMessage`] holds it.
///
/// The payload of components whose types their author gives as names (the Python package's events and
/// responses): such a component says its types when it is made ([`Response::start_type`](crate::Response::start_type),
/// [`Response::output_type`](crate::Response::output_type), [`Event::payload_type`](crate::Event::payload_type)),
/// and its payloads go through as they are, never decoded. The Rust type's own name, `radar_ros/msg/Dynamic`, is
/// no ROS type: spawning a component that does not say its types is an error.
///
/// ```
/// use radar_ros::{topics::DynMessage, topics::RawMessage, msg::StringMsg};
/// let body = RawMessage::encode(&StringMsg::from("kitchen")).unwrap();
/// let dynamic: DynMessage = body.decode().unwrap(); // the same bytes
/// assert_eq!(dynamic.0, body);
/// assert_eq!(RawMessage::encode(&dynamic).unwrap(), body);
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DynMessage(pub crate::wire::raw::RawMessage);
crate::ros_message!(DynMessage, "radar_ros", "Dynamic");

impl serde::Serialize for DynMessage {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        self.0.serialize(s)
    }
}

impl<'de> serde::Deserialize<'de> for DynMessage {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        use serde::de::DeserializeSeed;
        RawSeed.deserialize(d).map(DynMessage)
    }
}

/// Whether a payload decoded as `M` can be taken from (or sent to) a topic of type `ros_type`: `M` is that
/// type, or a [`DynMessage`], which takes any.
pub(crate) fn carries<M: RosMessage>(ros_type: &str) -> bool {
    let m = M::ros_type_name();
    m == ros_type || m == DynMessage::ros_type_name()
}

/// The ROS type of a component's payload, checked: a valid `pkg/msg/Name`, and not [`DynMessage`]'s placeholder.
pub(crate) fn component_type(
    ros_type: &str,
    what: &str,
) -> crate::Result<crate::wire::msg::TypeName> {
    if ros_type == DynMessage::ros_type_name() {
        return Err(crate::Error::InvalidName {
            name: ros_type.to_owned(),
            reason: format!(
                "{what} is a DynMessage, whose ROS type is known only at run time: say it where the \
                 component is made (`Response::start_type`/`output_type`, `Event::payload_type`, \
                 `ConnectionRequest::map_dyn`)"
            ),
        });
    }
    parse_type_name(ros_type)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hostile bytes (issue 32): whatever a peer sends on a slot, a state topic or a manager's service, decoding
    /// it as any of radar_ros's types returns (a value or an error): no panic, no allocation of what a forged
    /// length says. Seeded mutations of valid messages for `RADAR_FUZZ_SECONDS` (default 2).
    #[test]
    fn decoding_mutated_messages_never_panics() {
        use crate::wire::msg::*;
        // as a subscription or a service reads them: little-endian CDR into the type
        fn cdr<M: serde::de::DeserializeOwned>(b: &[u8]) {
            let _ = ros2_client::dds::rustdds::cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(
                b,
            );
        }
        fn decode_all(raw: &RawMessage) {
            let b = raw.as_bytes();
            cdr::<Empty>(b);
            cdr::<Int32>(b);
            cdr::<StringMsg>(b);
            cdr::<PoseStamped>(b);
            cdr::<ResponseState>(b);
            cdr::<EventState>(b);
            cdr::<Connection>(b);
            cdr::<ConnectionList>(b);
            cdr::<ConnectRequest>(b);
            cdr::<ConnectResponse>(b);
            cdr::<ListResponse>(b);
        }
        let list = ConnectionList {
            manager: "/radar_manager".into(),
            connections: vec![Connection {
                source: "/bumper/triggered".into(),
                target: "/dock/start".into(),
                ..Default::default()
            }],
            ..Default::default()
        };
        let seeds: Vec<Vec<u8>> = vec![
            RawMessage::encode(&list).unwrap().into_bytes(),
            RawMessage::encode(&ResponseState {
                name: "/dock".into(),
                state_label: "running".into(),
                ..Default::default()
            })
            .unwrap()
            .into_bytes(),
            RawMessage::encode(&ConnectRequest {
                source: "/a/triggered".into(),
                target: "/b/start".into(),
                ..Default::default()
            })
            .unwrap()
            .into_bytes(),
            RawMessage::encode(&StringMsg::from("kitchen"))
                .unwrap()
                .into_bytes(),
        ];
        let budget = std::time::Duration::from_secs_f64(
            std::env::var("RADAR_FUZZ_SECONDS")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or(2.0),
        );
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move |n: usize| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % (n.max(1) as u64)) as usize
        };
        let start = std::time::Instant::now();
        let mut runs = 0u64;
        while start.elapsed() < budget {
            let mut v = seeds[next(seeds.len())].clone();
            for _ in 0..1 + next(3) {
                let len = v.len();
                match next(5) {
                    0 if len > 0 => {
                        let i = next(len);
                        v[i] ^= 1 << next(8);
                    }
                    // a forged length or count: 4 bytes at an aligned offset set very large
                    1 if len >= 4 => {
                        let i = next(len / 4) * 4;
                        let big = [0xffff_ffffu32, 0x7fff_ffff, 0x1000_0000][next(3)];
                        v[i..i + 4].copy_from_slice(&big.to_le_bytes());
                    }
                    2 => v.truncate(next(len + 1)),
                    3 => {
                        let i = next(len + 1);
                        v.insert(i, next(256) as u8);
                    }
                    _ if len > 0 => {
                        let i = next(len);
                        v[i] = next(256) as u8;
                    }
                    _ => {}
                }
            }
            decode_all(&RawMessage::from_bytes(v));
            runs += 1;
        }
        println!("{runs} mutated messages decoded as every type");
    }

    #[test]
    fn a_raw_message_deserializes_to_the_whole_body_as_the_seed_reads_it() {
        let body = RawMessage::encode(&crate::wire::msg::StringMsg::from("kitchen")).unwrap();
        let (read, _) = ros2_client::dds::rustdds::cdr_encoding::from_bytes::<
            RawMessage,
            byteorder::LittleEndian,
        >(body.as_bytes())
        .unwrap();
        assert_eq!(read, body);
        assert_eq!(read.len(), 12, "a 4-byte length, 7 characters and a nul");
    }

    #[test]
    fn type_names_parse_or_say_how_to_write_them() {
        assert_eq!(
            parse_type_name("std_msgs/msg/String").unwrap().dds,
            "std_msgs::msg::dds_::String_"
        );
        assert_eq!(
            parse_type_name("std_msgs/Empty").unwrap().dds,
            "std_msgs::msg::dds_::Empty_"
        );
        let goal = parse_type_name("test_msgs/action/Fibonacci_Goal").unwrap();
        assert_eq!(
            (goal.ros.as_str(), goal.dds.as_str()),
            (
                "test_msgs/action/Fibonacci_Goal",
                "test_msgs::action::dds_::Fibonacci_Goal_"
            )
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
