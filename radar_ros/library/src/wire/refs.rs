//! Names for what connections join: signals (what components publish), slots (what they subscribe to), and
//! references to events and responses wherever they run.
//!
//! A [`Signal`] and a [`Slot`] are both a topic with its message type, but they are different types, so a
//! statement cannot be given a slot as its source, or a signal as its target:
//!
//! ```compile_fail
//! # async fn f(radar: radar_ros::Radar, r: radar_ros::ResponseRef) {
//! // a slot is not a source: this does not compile
//! let _c = radar.whenever(r.start_slot()).start(&r).await;
//! # }
//! ```
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, r: radar_ros::ResponseRef) {
//! // a signal is: this compiles
//! let _c = radar.whenever(r.exited()).start(&r).await;
//! # }
//! ```
//!
//! Anything that names a signal ([`AsSignal`]: a [`Signal`], an event's handle or [`EventRef`], which stand for
//! its `triggered`) is accepted where a source is expected; anything that names a response ([`AsResponse`]: a
//! local [`ResponseHandle`](crate::ResponseHandle) or a [`ResponseRef`] found on the graph) where a response is.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, tick: radar_ros::EventHandle, go: radar_ros::ResponseHandle)
//! #     -> radar_ros::Result<()> {
//! let arm = radar.response("arm/grasp").await?;                       // a ResponseRef
//! let _a = radar.whenever(&tick).start(&go).await?;                  // an event stands for its triggered
//! let _b = radar.once(go.reference().exited()).start(&arm).await?;   // any signal
//! # Ok(()) }
//! ```
//!
//! This module depends on nothing else in the crate but names and message type names: it is the vocabulary
//! every other module speaks.

use crate::{wire::msg::Empty, wire::msg::RosMessage, wire::names::ComponentName};

/// Defines a topic-with-type reference type (the same fields and accessors for signals and slots).
macro_rules! topic_ref {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name {
            topic: String,
            ros_type: String,
        }

        impl $name {
            /// On the absolute `topic`, of type `ros_type` (`pkg/msg/Name`).
            pub fn new(topic: impl Into<String>, ros_type: impl Into<String>) -> $name {
                $name {
                    topic: topic.into(),
                    ros_type: ros_type.into(),
                }
            }
            /// The absolute topic.
            pub fn topic(&self) -> &str {
                &self.topic
            }
            /// The message type, `pkg/msg/Name`.
            pub fn ros_type(&self) -> &str {
                &self.ros_type
            }
        }
    };
}

topic_ref!(
    /// A signal: a topic a RADAR component publishes (an event's `triggered`, a response's `started`,
    /// `interrupted`, `exited`), with its message type. The source of a connection.
    ///
    /// ```
    /// let s = radar_ros::Signal::new("/bumper/triggered", "std_msgs/msg/Empty");
    /// assert_eq!(s.topic(), "/bumper/triggered");
    /// ```
    Signal
);

topic_ref!(
    /// A slot: a topic a RADAR component subscribes to (a response's `start`, `interrupt`, `exit`), with its
    /// message type. The target of a connection, or of [`Radar::inject`](crate::Radar::inject).
    ///
    /// ```
    /// let s = radar_ros::Slot::new("/dock/start", "std_msgs/msg/Empty");
    /// assert_eq!(s.ros_type(), "std_msgs/msg/Empty");
    /// ```
    Slot
);

/// Something that names a signal, accepted wherever a connection's source is expected: a [`Signal`], or an
/// event (its handle or an [`EventRef`]), which stands for its `triggered`.
///
/// ```
/// use radar_ros::{AsSignal, Signal};
/// let s = Signal::new("/bumper/triggered", "std_msgs/msg/Empty");
/// assert_eq!((&s).signal(), s);
/// ```
pub trait AsSignal {
    /// The signal named.
    fn signal(&self) -> Signal;
}

impl AsSignal for Signal {
    fn signal(&self) -> Signal {
        self.clone()
    }
}

impl<T: AsSignal + ?Sized> AsSignal for &T {
    fn signal(&self) -> Signal {
        (**self).signal()
    }
}

/// An event as seen on the ROS graph (from [`Radar::event`](crate::Radar::event)); a local
/// [`EventHandle`](crate::EventHandle) names the same things.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EventRef {
    name: ComponentName,
    payload_type: String,
}

impl EventRef {
    /// The event `name` whose `triggered` carries `payload_type` (`pkg/msg/Name`).
    pub fn new(name: ComponentName, payload_type: impl Into<String>) -> EventRef {
        EventRef {
            name,
            payload_type: payload_type.into(),
        }
    }
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        &self.name
    }
    /// Its `triggered` signal.
    pub fn triggered(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Triggered),
            self.payload_type.clone(),
        )
    }
}

impl AsSignal for EventRef {
    fn signal(&self) -> Signal {
        self.triggered()
    }
}

/// The signals and slots of a response, wherever it runs (from [`Radar::response`](crate::Radar::response) or
/// a local handle's [`reference`](crate::ResponseHandle::reference)).
///
/// ```
/// use radar_ros::{graph::ComponentName, ResponseRef};
/// let dock = ResponseRef::new(ComponentName::resolve("/robot/dock", "/").unwrap(), "std_msgs/msg/Empty", "std_msgs/msg/Empty");
/// assert_eq!(dock.exited().topic(), "/robot/dock/exited");
/// assert_eq!(dock.start_slot().topic(), "/robot/dock/start");
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ResponseRef {
    name: ComponentName,
    start_type: String,
    output_type: String,
}

impl ResponseRef {
    /// A response named `name` whose start slot takes `start_type` and whose `exited` carries `output_type`.
    pub fn new(
        name: ComponentName,
        start_type: impl Into<String>,
        output_type: impl Into<String>,
    ) -> ResponseRef {
        ResponseRef {
            name,
            start_type: start_type.into(),
            output_type: output_type.into(),
        }
    }
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        &self.name
    }
    /// `started`, carrying the start payload.
    pub fn started(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Started),
            self.start_type.clone(),
        )
    }
    /// `interrupted`.
    pub fn interrupted(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Interrupted),
            Empty::ros_type_name(),
        )
    }
    /// `exited`, carrying the run's output.
    pub fn exited(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Exited),
            self.output_type.clone(),
        )
    }
    /// `dropped`: a start a statement sent that the response did not take, with that statement's cause (R6).
    pub fn dropped(&self) -> Signal {
        Signal::new(
            self.name.endpoint(crate::endpoint::Endpoint::Dropped),
            Empty::ros_type_name(),
        )
    }
    /// The `start` slot.
    pub fn start_slot(&self) -> Slot {
        Slot::new(
            self.name.endpoint(crate::endpoint::Endpoint::Start),
            self.start_type.clone(),
        )
    }
    /// The `interrupt` slot.
    pub fn interrupt_slot(&self) -> Slot {
        Slot::new(
            self.name.endpoint(crate::endpoint::Endpoint::Interrupt),
            Empty::ros_type_name(),
        )
    }
    /// The `exit` slot.
    pub fn exit_slot(&self) -> Slot {
        Slot::new(
            self.name.endpoint(crate::endpoint::Endpoint::Exit),
            Empty::ros_type_name(),
        )
    }
}

/// Something that names a response: a local [`ResponseHandle`](crate::ResponseHandle) or a [`ResponseRef`].
///
/// ```
/// use radar_ros::{AsResponse, graph::ComponentName, ResponseRef};
/// let r = ResponseRef::new(ComponentName::resolve("dock", "/").unwrap(), "std_msgs/msg/Empty", "std_msgs/msg/Empty");
/// assert_eq!((&r).response_ref(), r);
/// ```
pub trait AsResponse {
    /// Its signals and slots.
    fn response_ref(&self) -> ResponseRef;
}

impl<R: AsResponse + ?Sized> AsResponse for &R {
    fn response_ref(&self) -> ResponseRef {
        (**self).response_ref()
    }
}

impl AsResponse for ResponseRef {
    fn response_ref(&self) -> ResponseRef {
        self.clone()
    }
}
