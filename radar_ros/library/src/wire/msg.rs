//! ROS 2 message types used by RADAR signals, and the [`RosMessage`] trait that ties a Rust type to its ROS
//! interface name.
//!
//! Any type that serializes to the same CDR layout as a ROS message can carry a signal: implement
//! [`RosMessage`] for it (or use [`ros_message!`](crate::ros_message)). The standard types that RADAR users
//! need most are provided here; the `radar_msgs` types mirror `msgs/radar_msgs/msg/*.msg` field for field.
//!
//! ```
//! use radar_ros::msg::{RosMessage, StringMsg};
//! assert_eq!(StringMsg::ros_type_name(), "std_msgs/msg/String");
//! ```

use serde::{de::DeserializeOwned, Deserialize, Serialize};

pub use super::msg_support::{fixed_array, WString};

/// A Rust type that is the wire form of a ROS 2 message.
///
/// The serde field order must match the `.msg` definition, because ROS 2 on DDS serializes with CDR, which
/// carries no field names.
pub trait RosMessage:
    Serialize + DeserializeOwned + Clone + Default + std::fmt::Debug + Send + Sync + 'static
{
    /// The ROS package of the interface, e.g. `"std_msgs"`.
    const PACKAGE: &'static str;
    /// The message name within the package, e.g. `"String"`.
    const NAME: &'static str;
    /// The interface kind the message belongs to: `"msg"`, or `"action"` for the parts of an action
    /// (`test_msgs/action/Fibonacci_Goal`).
    const INTERFACE: &'static str = "msg";

    /// The ROS interface name as the `ros2` command line shows it, e.g. `"std_msgs/msg/String"`.
    fn ros_type_name() -> String {
        format!("{}/{}/{}", Self::PACKAGE, Self::INTERFACE, Self::NAME)
    }

    /// The type name DDS discovery carries, e.g. `"std_msgs::msg::dds_::String_"`.
    ///
    /// ```
    /// use radar_ros::{action::FibonacciGoal, msg::{RosMessage, StringMsg}};
    /// assert_eq!(StringMsg::dds_type_name(), "std_msgs::msg::dds_::String_");
    /// assert_eq!(FibonacciGoal::dds_type_name(), "test_msgs::action::dds_::Fibonacci_Goal_");
    /// ```
    fn dds_type_name() -> String {
        format!(
            "{}::{}::dds_::{}_",
            Self::PACKAGE,
            Self::INTERFACE,
            Self::NAME
        )
    }

    /// The RIHS01 hash of the type's definition (`RIHS01_<64 hex digits>`, as rosidl computes it), when known:
    /// generated types ([`radar_idl::rust`](https://docs.rs/radar_idl)) carry it; hand-written ones may leave it out.
    const TYPE_HASH: Option<&'static str> = None;

    /// The ros2-client form of the type name. ros2-client can name only `msg` interfaces this way; use
    /// [`RosMessage::dds_type_name`] for the others.
    fn message_type_name() -> ros2_client::MessageTypeName {
        ros2_client::MessageTypeName::new(Self::PACKAGE, Self::NAME)
    }
}

/// A ROS 2 service type: `pkg/srv/Name` with its request and response messages (generated ones implement it).
pub trait RosService: Send + Sync + 'static {
    /// The ROS package, e.g. `"std_srvs"`.
    const PACKAGE: &'static str;
    /// The service's name in the package, e.g. `"Trigger"`.
    const NAME: &'static str;
    /// `<Name>_Request`.
    type Request: RosMessage;
    /// `<Name>_Response`.
    type Response: RosMessage;
    /// The service's RIHS01 hash (REP 2011) as rosidl computes it for the service as a whole (its request,
    /// response and event messages), when known: what rmw_zenoh names in the service's key expression and
    /// liveliness tokens. Generated types carry it.
    const TYPE_HASH: Option<&'static str> = None;

    /// `pkg/srv/Name`, as `ros2 service` shows it.
    fn ros_type_name() -> String {
        format!("{}/srv/{}", Self::PACKAGE, Self::NAME)
    }
}

/// A message type as radar_ros creates topics with it: the ROS name and the DDS name (what it is compared by),
/// and its RIHS01 hash when known (announced in the endpoints' USER_DATA as ROS 2 Jazzy does).
#[derive(Clone, Debug)]
pub(crate) struct TypeName {
    /// `pkg/msg/Name`
    pub(crate) ros: String,
    /// `pkg::msg::dds_::Name_`
    pub(crate) dds: String,
    /// `RIHS01_...`
    pub(crate) hash: Option<&'static str>,
}

impl PartialEq for TypeName {
    fn eq(&self, other: &Self) -> bool {
        self.ros == other.ros && self.dds == other.dds
    }
}

impl Eq for TypeName {}

impl TypeName {
    pub(crate) fn of<M: RosMessage>() -> TypeName {
        TypeName {
            ros: M::ros_type_name(),
            dds: M::dds_type_name(),
            hash: M::TYPE_HASH,
        }
    }

    /// This type, with `M`'s hash if it is `M` (a component whose Rust type is `M` says its ROS type as a
    /// string, which may name another type at run time).
    pub(crate) fn with_hash_of<M: RosMessage>(mut self) -> TypeName {
        if self.ros == M::ros_type_name() {
            self.hash = M::TYPE_HASH;
        }
        self
    }

    /// `pkg`, `msg` or `action`, `Name`.
    pub(crate) fn new(package: &str, interface: &str, name: &str) -> TypeName {
        TypeName {
            ros: format!("{package}/{interface}/{name}"),
            dds: format!("{package}::{interface}::dds_::{name}_"),
            hash: type_hash_of(&format!("{package}/{interface}/{name}")),
        }
    }
}

/// The RIHS01 hash of `ros_type` (`pkg/msg/Name`) if it is one of the types radar_ros ships
/// ([`crate::interfaces`]): what an endpoint typed at run time (a relay, a raw publisher) announces.
pub(crate) fn type_hash_of(ros_type: &str) -> Option<&'static str> {
    let table = crate::interfaces::TYPE_HASHES;
    table
        .binary_search_by(|(t, _)| (*t).cmp(ros_type))
        .ok()
        .map(|i| table[i].1)
}

/// Implements [`RosMessage`] for a type: `ros_message!(MyType, "my_pkg", "MyType");`, with its RIHS01 hash:
/// `ros_message!(MyType, "my_pkg", "MyType", hash Some("RIHS01_..."))`, or for a part of an action:
/// `ros_message!(MyGoal, "my_pkg", action "Dock_Goal");` (with its hash: `..., action "Dock_Goal", hash
/// Some("RIHS01_..."))`). (Generated types implement it themselves.)
#[macro_export]
macro_rules! ros_message {
    ($ty:ty, $pkg:literal, $name:literal) => {
        impl $crate::msg::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
        }
    };
    ($ty:ty, $pkg:literal, $name:literal, hash $hash:expr) => {
        impl $crate::msg::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
            const TYPE_HASH: Option<&'static str> = $hash;
        }
    };
    ($ty:ty, $pkg:literal, action $name:literal) => {
        impl $crate::msg::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
            const INTERFACE: &'static str = "action";
        }
    };
    ($ty:ty, $pkg:literal, action $name:literal, hash $hash:expr) => {
        impl $crate::msg::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
            const INTERFACE: &'static str = "action";
            const TYPE_HASH: Option<&'static str> = $hash;
        }
    };
}

// The standard types RADAR users need most: generated from their definitions with the rest of
// `radar_ros::interfaces` (the names radar_ros has always given them stay).

/// `std_msgs/msg/Empty`: the default payload of every RADAR signal
/// ([`interfaces::std_msgs::msg::Empty`](crate::interfaces::std_msgs::msg::Empty)).
///
/// ROS 2 serializes an empty struct with one padding byte (rclpy does so); a zero-sized Rust type would put
/// nothing on the wire and peers would receive nothing, so it carries that byte explicitly.
pub use crate::interfaces::std_msgs::msg::Empty;
/// `std_msgs/msg/String` ([`interfaces::std_msgs::msg::String`](crate::interfaces::std_msgs::msg::String)).
pub use crate::interfaces::std_msgs::msg::String as StringMsg;
pub use crate::interfaces::{
    builtin_interfaces::msg::Time,
    geometry_msgs::msg::{Point, Pose, PoseStamped, Quaternion},
    std_msgs::msg::{Bool, Float64, Header, Int32, Int64},
};

impl From<&str> for StringMsg {
    fn from(s: &str) -> Self {
        StringMsg { data: s.to_owned() }
    }
}

impl PartialOrd for Time {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

/// Times in order: by second, then nanosecond.
impl Ord for Time {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        (self.sec, self.nanosec).cmp(&(other.sec, other.nanosec))
    }
}

impl Time {
    /// The wall-clock time now.
    ///
    /// ```
    /// let t = radar_ros::msg::Time::now();
    /// assert!(t.sec > 0);
    /// ```
    pub fn now() -> Time {
        let d = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        Time {
            sec: d.as_secs() as i32,
            nanosec: d.subsec_nanos(),
        }
    }

    /// The time `ns` nanoseconds after the Unix epoch (a signal's source timestamp, say).
    ///
    /// ```
    /// use radar_ros::msg::Time;
    /// let t = Time::from_nanos(2_500_000_000);
    /// assert_eq!((t.sec, t.nanosec), (2, 500_000_000));
    /// assert_eq!(t.to_nanos(), 2_500_000_000);
    /// ```
    pub fn from_nanos(ns: i64) -> Time {
        Time {
            sec: ns.div_euclid(1_000_000_000) as i32,
            nanosec: ns.rem_euclid(1_000_000_000) as u32,
        }
    }

    /// Nanoseconds since the Unix epoch.
    pub fn to_nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }
}

/// `radar_msgs/msg/ResponseState`: what a response is doing, published transient-local on `<response>/state`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ResponseState {
    /// When this state was entered.
    pub stamp: Time,
    /// Fully qualified node name of the response.
    pub name: String,
    /// One of the `STATE_*` constants.
    pub state: u8,
    /// The state as a word: `idle`, `running`, `interrupting`, `exiting`.
    pub state_label: String,
    /// What the start slot accepts, e.g. `std_msgs/msg/Empty`.
    pub start_type: String,
    /// Policy for `start` while busy: `ignore`, `restart`, `queue_one`.
    pub start_policy: String,
    /// Why the last run ended: `completed`, `interrupted`, `exit_signal`, `failed: ...`, `panicked: ...`.
    pub last_exit_reason: String,
    /// Runs started (including restarts).
    pub starts: u64,
    /// Runs that reached `exited`.
    pub exits: u64,
    /// Runs ended by an `interrupt` signal.
    pub interrupts: u64,
    /// Runs ended by an `exit` signal.
    pub exit_signals: u64,
    /// Runs whose start behaviour returned normally.
    pub completed: u64,
    /// Runs whose start behaviour returned an error.
    pub failures: u64,
    /// Panics caught in any slot.
    pub panics: u64,
    /// Restarts requested by the exit slot.
    pub restarts: u64,
    /// `start` signals ignored by the policy (or replaced in the queue).
    pub ignored_starts: u64,
    /// `interrupt` signals ignored (idle, or already interrupting/exiting).
    pub ignored_interrupts: u64,
    /// `exit` signals ignored (idle, or already interrupting/exiting).
    pub ignored_exits: u64,
    /// Whether a start is queued to run after the current run.
    pub start_queued: bool,
    /// Slot messages that did not decode as their type, dropped (shown at the next state change).
    pub malformed: u64,
}
ros_message!(ResponseState, "radar_msgs", "ResponseState", hash <crate::interfaces::radar_msgs::msg::ResponseState as RosMessage>::TYPE_HASH);

impl ResponseState {
    /// Idle: waiting for `start`.
    pub const STATE_IDLE: u8 = 0;
    /// The start behaviour is running.
    pub const STATE_RUNNING: u8 = 1;
    /// The interrupt slot is running.
    pub const STATE_INTERRUPTING: u8 = 2;
    /// The exit slot is running.
    pub const STATE_EXITING: u8 = 3;
}

/// `radar_msgs/msg/EventState`: whether an event is checking, published transient-local on `<event>/state`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventState {
    /// When this state was entered: for a trigger, when `triggered` was emitted (its source timestamp).
    pub stamp: Time,
    /// Fully qualified node name of the event.
    pub name: String,
    /// True while at least one subscriber listens on `triggered` and the check runs.
    pub active: bool,
    /// Subscribers matched on `triggered`.
    pub listeners: u32,
    /// What `triggered` carries, e.g. `std_msgs/msg/Empty`.
    pub trigger_type: String,
    /// Signals emitted on `triggered`.
    pub triggers: u64,
    /// Times the event went from inactive to active.
    pub activations: u64,
    /// Checks that returned an error or panicked.
    pub check_errors: u64,
    /// The last such error, empty if none.
    pub last_error: String,
}
ros_message!(EventState, "radar_msgs", "EventState", hash <crate::interfaces::radar_msgs::msg::EventState as RosMessage>::TYPE_HASH);

/// `radar_msgs/msg/Connection`: one live connection, as a manager lists it.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Connection {
    /// Unique within its manager.
    pub id: u64,
    /// [`Connection::ONCE`] or [`Connection::WHENEVER`].
    pub kind: u8,
    /// `once` or `whenever`.
    pub kind_label: String,
    /// Topic of the source signal.
    pub source: String,
    /// Its type.
    pub source_type: String,
    /// Topic of the target slot, or `(anonymous)`.
    pub target: String,
    /// Topic of the `until` signal, empty if none.
    pub until: String,
    /// Who made it.
    pub owner: String,
    /// Signals delivered from the source so far.
    pub delivered: u64,
    /// History depth of the relay's reader and writer.
    pub depth: u32,
    /// One of the `STATE_*` constants: whether it can deliver now.
    pub state: u8,
    /// `armed`, `waiting for source`, `waiting for target` or `target lost`.
    pub state_label: String,
    /// Who left and why, while it is not armed (or after its `until`'s response left); else empty.
    pub departure: String,
    /// DDS hops a signal takes from source to target: 0 (both in the manager's process), 1 (one of them), 2
    /// (neither: source -> manager -> target).
    pub hops: u8,
    /// Panics caught in the connection's own code (its filter, map, or anonymous slot's call).
    pub panics: u64,
    /// The last of them: which closure and its message, else empty.
    pub panic: String,
    /// When the statement began: it delivers signals emitted from then on (rule C1).
    pub since: Time,
    /// The statement's id as the causes of its slot signals carry it (32 hex digits, rule C6).
    pub statement: String,
}
ros_message!(Connection, "radar_msgs", "Connection", hash <crate::interfaces::radar_msgs::msg::Connection as RosMessage>::TYPE_HASH);

impl Connection {
    /// `once`.
    pub const ONCE: u8 = 0;
    /// `whenever`.
    pub const WHENEVER: u8 = 1;
    /// Source and target are there.
    pub const STATE_ARMED: u8 = 0;
    /// Every publisher of the source left; it delivers again when one is back.
    pub const STATE_WAITING_FOR_SOURCE: u8 = 1;
    /// The target left; the connection re-arms when a target of that name is back.
    pub const STATE_WAITING_FOR_TARGET: u8 = 2;
    /// The target left; nothing more is delivered.
    pub const STATE_TARGET_LOST: u8 = 3;

    /// The `STATE_*` code of a link state.
    pub fn state_of(link: radar_semantics::connection::Link) -> u8 {
        match link {
            radar_semantics::connection::Link::Armed => Self::STATE_ARMED,
            radar_semantics::connection::Link::WaitingForSource => Self::STATE_WAITING_FOR_SOURCE,
            radar_semantics::connection::Link::WaitingForTarget => Self::STATE_WAITING_FOR_TARGET,
            radar_semantics::connection::Link::TargetLost => Self::STATE_TARGET_LOST,
        }
    }
}

/// `radar_msgs/msg/ConnectionList`: every live connection of one manager.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ConnectionList {
    /// When it was published.
    pub stamp: Time,
    /// The manager node.
    pub manager: String,
    /// The connections.
    pub connections: Vec<Connection>,
}
ros_message!(ConnectionList, "radar_msgs", "ConnectionList", hash <crate::interfaces::radar_msgs::msg::ConnectionList as RosMessage>::TYPE_HASH);

/// Request of `radar_msgs/srv/Connect`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ConnectRequest {
    /// [`Connection::ONCE`] or [`Connection::WHENEVER`].
    pub kind: u8,
    /// Source signal topic.
    pub source: String,
    /// Target slot topic.
    pub target: String,
    /// Optional `until` signal topic.
    pub until: String,
    /// Seconds to wait for discovery; 0 means 5.
    pub timeout: f64,
    /// History depth of the relay; 0 means 10.
    pub depth: u32,
    /// Keep the connection after the caller leaves the graph (only `Disconnect` ends it).
    pub detach: bool,
}

/// Response of `radar_msgs/srv/Connect`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ConnectResponse {
    /// Whether the connection was made.
    pub ok: bool,
    /// Why not.
    pub error: String,
    /// Its id.
    pub id: u64,
}

/// Request of `radar_msgs/srv/Disconnect`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DisconnectRequest {
    /// The connection.
    pub id: u64,
}

/// Response of `radar_msgs/srv/Disconnect`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DisconnectResponse {
    /// Whether it existed and was removed.
    pub ok: bool,
    /// Why not.
    pub error: String,
}

/// Request of `radar_msgs/srv/List` (empty: one padding byte on the wire, as ROS does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ListRequest {
    structure_needs_at_least_one_member: u8,
}

/// Response of `radar_msgs/srv/List`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ListResponse {
    /// The connections.
    pub connections: Vec<Connection>,
}

impl ros2_client::Message for ConnectRequest {}
impl ros2_client::Message for ConnectResponse {}
impl ros2_client::Message for DisconnectRequest {}
impl ros2_client::Message for DisconnectResponse {}
impl ros2_client::Message for ListRequest {}
impl ros2_client::Message for ListResponse {}

/// How many bytes may follow a message's last field: CDR pads a serialized payload to a multiple of 4.
pub(crate) const PADDING: usize = 4;

/// Whether `bytes` are a whole message of type `M` (a message body in little-endian CDR, with no more after it
/// than the padding to a multiple of 4): what a connection manager checks before it counts a signal as
/// delivered to a slot of type `M` (rule C2). Generated interfaces list one per type (`READERS`).
///
/// ```
/// use radar_ros::{msg::{reads, Int32}, topics::RawMessage};
/// assert!(reads::<Int32>(RawMessage::encode(&Int32 { data: 7 }).unwrap().as_bytes()));
/// assert!(!reads::<Int32>(&[1, 0]), "too short");
/// assert!(!reads::<Int32>(&[7, 0, 0, 0, 1, 0, 0, 0]), "another definition: more than padding left");
/// ```
pub fn reads<M: RosMessage>(bytes: &[u8]) -> bool {
    ros2_client::dds::rustdds::cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(bytes)
        .is_ok_and(|(_, used)| bytes.len().saturating_sub(used) < PADDING)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::msg_layout::{fields, msg_file_constants, msg_file_fields};

    fn msg_file(name: &str) -> String {
        let p = format!(
            "{}/../../msgs/radar_msgs/msg/{name}.msg",
            env!("CARGO_MANIFEST_DIR")
        );
        std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{p}: {e}"))
    }

    #[test]
    fn response_state_mirrors_the_msg_file_field_for_field() {
        let text = msg_file("ResponseState");
        assert_eq!(fields(&ResponseState::default()), msg_file_fields(&text));
        let consts = msg_file_constants(&text);
        let want = [
            ("STATE_IDLE", ResponseState::STATE_IDLE),
            ("STATE_RUNNING", ResponseState::STATE_RUNNING),
            ("STATE_INTERRUPTING", ResponseState::STATE_INTERRUPTING),
            ("STATE_EXITING", ResponseState::STATE_EXITING),
        ];
        assert_eq!(
            consts,
            want.map(|(n, v)| (n.to_owned(), v.to_string())).to_vec()
        );
        for phase in [
            crate::Phase::Idle,
            crate::Phase::Running,
            crate::Phase::Interrupting,
            crate::Phase::Exiting,
        ] {
            let c = format!("STATE_{}", phase.label().to_uppercase());
            assert!(consts.contains(&(c, phase.code().to_string())), "{phase:?}");
        }
    }

    fn srv_file(name: &str) -> (String, String) {
        let p = format!(
            "{}/../../msgs/radar_msgs/srv/{name}.srv",
            env!("CARGO_MANIFEST_DIR")
        );
        let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
        let (req, resp) = text.split_once("\n---").expect("--- in a .srv");
        (req.to_owned(), resp.to_owned())
    }

    #[test]
    fn connection_messages_and_services_mirror_their_files() {
        assert_eq!(
            fields(&Connection::default()),
            msg_file_fields(&msg_file("Connection"))
        );
        let one = ConnectionList {
            connections: vec![Connection::default()],
            ..Default::default()
        };
        assert_eq!(fields(&one), msg_file_fields(&msg_file("ConnectionList")));
        let (req, resp) = srv_file("Connect");
        assert_eq!(fields(&ConnectRequest::default()), msg_file_fields(&req));
        assert_eq!(fields(&ConnectResponse::default()), msg_file_fields(&resp));
        let (req, resp) = srv_file("Disconnect");
        assert_eq!(fields(&DisconnectRequest::default()), msg_file_fields(&req));
        assert_eq!(
            fields(&DisconnectResponse::default()),
            msg_file_fields(&resp)
        );
        let (req, resp) = srv_file("List");
        assert!(msg_file_fields(&req).is_empty());
        assert_eq!(
            fields(&ListRequest::default()).len(),
            1,
            "an empty request carries one padding byte"
        );
        let list = ListResponse {
            connections: vec![Connection::default()],
        };
        assert_eq!(fields(&list), msg_file_fields(&resp));
        let consts = msg_file_constants(&msg_file("Connection"));
        let want = [
            ("ONCE", Connection::ONCE),
            ("WHENEVER", Connection::WHENEVER),
            ("STATE_ARMED", Connection::STATE_ARMED),
            (
                "STATE_WAITING_FOR_SOURCE",
                Connection::STATE_WAITING_FOR_SOURCE,
            ),
            (
                "STATE_WAITING_FOR_TARGET",
                Connection::STATE_WAITING_FOR_TARGET,
            ),
            ("STATE_TARGET_LOST", Connection::STATE_TARGET_LOST),
        ];
        assert_eq!(
            consts,
            want.map(|(n, v)| (n.to_owned(), v.to_string())).to_vec()
        );
        // every link state has its constant, named after its label
        for link in [
            radar_semantics::connection::Link::Armed,
            radar_semantics::connection::Link::WaitingForSource,
            radar_semantics::connection::Link::WaitingForTarget,
            radar_semantics::connection::Link::TargetLost,
        ] {
            let name = format!("STATE_{}", link.label().replace(' ', "_").to_uppercase());
            let code = Connection::state_of(link).to_string();
            assert!(consts.contains(&(name, code)), "{link:?}");
        }
    }

    #[test]
    fn event_state_mirrors_the_msg_file_field_for_field() {
        assert_eq!(
            fields(&EventState::default()),
            msg_file_fields(&msg_file("EventState"))
        );
    }

    #[test]
    fn standard_messages_have_the_ros_layout() {
        assert_eq!(Empty::ros_type_name(), "std_msgs/msg/Empty");
        assert_eq!(
            fields(&Empty::default()),
            [(
                "structure_needs_at_least_one_member".to_owned(),
                "uint8".to_owned()
            )]
        );
        let ps = fields(&PoseStamped::default());
        assert_eq!(
            ps,
            [
                ("header".to_owned(), "std_msgs/Header".to_owned()),
                ("pose".to_owned(), "Pose".to_owned())
            ]
        );
        assert_eq!(
            fields(&Header::default()),
            [
                ("stamp".to_owned(), "builtin_interfaces/Time".to_owned()),
                ("frame_id".to_owned(), "string".to_owned())
            ]
        );
    }
}
