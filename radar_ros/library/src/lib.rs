//! # radar_ros: RADAR reactive semantics on ROS 2
//!
//! RADAR (Biggs & MacDonald) lets deliberative robot code say *when this happens, do that*. This crate maps
//! its three concepts onto ROS 2, over real DDS through `ros2-client`, with no ROS installation:
//!
//! - **Events** ([`Event`], [`Radar::spawn_event`]) are nodes that publish `<name>/triggered`. An event checks
//!   its condition only while at least one subscriber is matched on `triggered`.
//! - **Responses** ([`Response`], [`Radar::spawn_response`]) are nodes with `start`, `interrupt` and `exit` slot
//!   topics, emitting `started`, `interrupted` and `exited`. The exit slot always runs.
//! - **Connections** ([`Radar::once`], [`Radar::whenever`], `until`) tie a signal to a slot for as long as the
//!   block of code that made them lives, carried out by the embedded connection manager of the [`Radar`].
//! - Components publish a transient-local `<name>/state` that `ros2 topic echo` shows.
//!
//! ```no_run
//! use radar_ros::{Radar, TimerEvent, FnResponse, msg::Empty};
//! # #[tokio::main] async fn main() -> radar_ros::Result<()> {
//! let radar = Radar::new()?; // one DDS participant, domain from ROS_DOMAIN_ID
//! let tick = radar.spawn_event("tick", TimerEvent::new(std::time::Duration::from_secs(1)))?;
//! let hello = radar.spawn_response("hello", FnResponse::new(|_: Empty| async {
//!     println!("hello");
//!     Ok(Empty::default())
//! }))?;
//! {
//!     let _c = radar.whenever(&tick).start(&hello).await?; // says hello every second ...
//!     tokio::time::sleep(std::time::Duration::from_secs(5)).await;
//! } // ... until the guard goes
//! // `ros2 topic pub --once /hello/start std_msgs/msg/Empty` runs it too.
//! # Ok(()) }
//! ```
//!
//! ## Connections
//!
//! `radar.once(E).start(&R)` / `radar.whenever(E).start(&R)` (also `.interrupt(&R)`, `.exit(&R)`, `.slot(s)`,
//! or `.call(closure)`, an anonymous slot) return a [`ConnectionRequest`]; awaiting it arms the connection and
//! gives a [`ConnectionGuard`]: the connection lives exactly as long as the guard, so it ends with the block
//! that holds it, by `?`, or by a panic. Sources are anything that names a signal ([`AsSignal`]: a [`Signal`],
//! or an event, for its `triggered`); a [`Slot`] is a different type and is never accepted as a source.
//! The statements can also be written in the paper's syntax: [`once!`], [`whenever!`], [`waitfor!`].
//!
//! The rules, numbered once in [`radar_semantics`] and each tested ([`radar_semantics::connection`]):
//!
//! - **C1.** A connection delivers only signals emitted after it was armed; nothing stale, nothing replayed.
//! - **C2.** `whenever` delivers every signal while it lives; `once` delivers exactly one, then lets go of its
//!   source (an event whose only listener it was stops checking). A signal a connection property refuses (a
//!   filter, a transform that gives nothing, a payload an anonymous slot cannot read) is not a delivery.
//! - **C3.** <span id="until-windows"></span>**`once E start R until U`**: U's signals interrupt R only in the
//!   run this statement started, from the moment that run began. A run R starts by itself (its exit slot asking
//!   for a restart) or that another statement started is not interrupted by this one.
//! - **C4.** Dropping the guard ends the connection at once: when the drop returns, nothing more is delivered.
//! - **C5.** Components that leave: see [below](#when-components-leave).
//! - **C6, C7.** Signals travel on different topics, from different processes, and are read in another order
//!   than they were sent. Every start a statement delivers carries its cause (the statement, the delivery) and
//!   the time its source signal was emitted, and the `until`'s interrupts name the statement: a RADAR response
//!   orders its slot signals by when they were sent and interrupts only its runs of that statement (response
//!   rules R11-R13 below), so `until` holds whichever topic is read first, with the manager in R's process, in
//!   E's, or in a third. For a response that carries no causes (rclpy) the manager decides from the source
//!   times of R's `started` and `exited`; what that cannot know is said in docs/reliability.md.
//!
//! Connection properties: [`ConnectionRequest::filter`], [`ConnectionRequest::map`] (typed payload transform),
//! [`ConnectionRequest::depth`] (QoS history depth). Another program's manager can be used through a served
//! manager node ([`Radar::serve_manager`]; `radar_msgs/srv/Connect` from rclpy or the command line).
//!
//! ## When components leave
//!
//! A component leaves the graph when its process exits, crashes, is killed, hangs (or is stopped), or the
//! network cuts it off. radar_ros sees it when the last publisher of a connection's source, or the last
//! subscriber of its target slot, goes (after a 100 ms grace, so a signal sent just before leaving is
//! delivered first); DDS says why ([`LossCause`]): it said goodbye (milliseconds), or its lease ran out
//! (3-3.6 s for radar_ros peers, ~20 s for rclpy/Fast DDS peers; see the table below). What the deliberative
//! code sees (rule C5 of [`radar_semantics::connection`], each case tested):
//!
//! | what left | what happens | what the code sees |
//! |---|---|---|
//! | the source of a `waitfor` | the wait ends | [`Error::ComponentLost`] naming the component and the cause |
//! | the source of a `once`/`whenever` | it waits for the source: a new publisher of that name is delivered from | [`ConnectionGuard::link`] = [`Link::WaitingForSource`], [`ConnectionGuard::departed`] resolves |
//! | the target | nothing more is delivered (a new component of that name gets nothing) | [`Link::TargetLost`], a warning, [`ConnectionGuard::departed`] |
//! | the target, with [`ConnectionRequest::rearm`] | it waits, then delivers to the new target the signals emitted after it came | [`Link::WaitingForTarget`], then [`Link::Armed`] |
//! | the response of an `until` | the window closes: the dead run is not interrupted, nor a new R's runs | [`ConnectionGuard::departed`] |
//!
//! The manager's `connections` topic and `list` service show each connection's state (`state`,
//! `state_label`, `departure` in `radar_msgs/msg/Connection`). docs/reliability.md measures each case.
//!
//! ## Waiting
//!
//! Every call that waits returns a [`Wait`]: nothing happens until it is awaited, and `.timeout(d)` changes how
//! long it may take. Waiting for discovery (looking a component up, arming, a subscriber to appear) is
//! bounded by [`DEFAULT_TIMEOUT`] (5 s) unless told otherwise; waiting for a signal is unbounded unless told.
//! To wait for a signal without missing it, arm first ([`Radar::waiter`]), then do what makes it come, then
//! [`Waiter::recv`].
//!
//! ## Response semantics
//!
//! Decided in one place, the [`radar_semantics`] crate's `ResponseMachine`, and tested line by line (the
//! numbers are the crate's, R1-R14):
//!
//! - **R1.** Idle + `start` → emit `started` (carrying the payload), then run the start behaviour with the
//!   payload. The start behaviour always runs up to its first await point before the response takes the next
//!   signal, so `started` never announces a behaviour that did not run at all.
//! - **R2.** The start behaviour returns → run the exit slot → emit `exited` *after* the exit slot completed →
//!   idle. `exited` carries the start behaviour's output (or the output type's default if the run did not
//!   complete).
//! - **R3.** Running + `interrupt` → the start behaviour is cancelled at its current await point → emit
//!   `interrupted` as the interrupt slot begins → interrupt slot → exit slot → `exited`.
//! - **R4.** Running + `exit` → the start behaviour is cancelled → exit slot (no interrupt slot) → `exited`.
//! - **R5.** `interrupt` or `exit` while idle, interrupting or exiting: ignored, counted in the state message.
//! - **R6.** `start` while not idle: per-response [`StartPolicy`]: `Ignore` (default, counted), `Restart`
//!   (interrupt the current run as in R3, then start with the new payload), `QueueOne` (run the newest payload
//!   after `exited`; one replaced in the queue counts as ignored).
//! - **R7.** The exit slot always runs: after a normal end, an interrupt, an exit signal, an error returned by
//!   the start behaviour, a panic in it (also one raised before its future exists), and when the response or
//!   its program stops (see [below](#when-the-program-is-told-to-stop)). A panic in any slot is caught, logged,
//!   counted in the state, `exited` is still sent, and the node keeps serving.
//! - **R8.** The exit slot may return [`ExitAction::Restart`] (the paper's `on exit: restart`): after `exited`
//!   the response starts again with the same payload. A queued start (R6) takes precedence.
//! - **R9, R10.** A response that stands for a ROS 2 action goal ([`Radar::action_response`]) announces
//!   `started` when the server *accepts* the goal (a rejected goal ends with `exited` and no `started`), and the
//!   result of a canceled goal, which arrives while the interrupt slot runs, is what `exited` carries. How
//!   goals, cancels, results and feedback map onto signals both ways is in [`action`].
//! - **R11.** Slot signals are applied in the order they were sent (the source time of the signal that caused
//!   them; a relay keeps it): an `interrupt` or `exit` sent before the current run began is not for it.
//! - **R12.** An `interrupt` or `exit` that reaches an idle response is kept for a moment: a `start` sent before
//!   it that arrives afterwards runs, and is then interrupted, as if the two had arrived in order.
//! - **R13.** A run started by a statement carries its cause on `started`, `interrupted` and `exited`, and an
//!   `until`'s interrupt only interrupts runs of its own statement.
//! - **R14.** An `until`'s interrupt bounds its statement's run whose start was sent before it, also when that
//!   run had to wait for another (a `QueueOne` response busy, a `Restart` still in the run before's exit slot):
//!   the run begins and is interrupted at once.
//! - **T1, T2.** Stamps from other hosts' clocks are taken within 2 s before this host's clock, never after it,
//!   and this host's clock stepping back moves what a response remembers with it (`radar_semantics::time`).
//!
//! Slots are plain async Rust on tokio: sleeping in them never blocks a thread.
//!
//! ## When the program is told to stop
//!
//! A robot stops its motors in an exit slot, so the exit slot runs however the program ends (R7;
//! [`RadarBuilder::handle_signals`], [`RadarBuilder::shutdown_timeout`], [`Radar::shutdown`]):
//!
//! | how the program ends | what happens |
//! |---|---|
//! | SIGINT (Ctrl-C, `ros2 launch`) or SIGTERM (systemd, docker, launch's escalation) | every component of every `Radar` of the process stops: running responses end as an `exit` signal would end them, their exit slots run, `exited` and the final `state` are sent and acknowledged, the program leaves the ROS graph (peers see it at once) and the process exits with status 0 |
//! | more SIGINTs while that runs (Ctrl-C under `ros2 launch`: the terminal's, then launch's own) | nothing: the exit slots finish |
//! | a SIGTERM while that runs (launch's escalation after `sigterm_timeout`) | the process exits at once (status 143) |
//! | an exit slot that takes longer than the shutdown timeout (5 s) | an error line names what did not finish; the process exits with status 1 |
//! | `main` returns, or panics (the runtime drops every task) | a response in the middle of a run finishes it while its task is dropped: the exit slot runs on a thread of its own, `exited` is sent; an exit slot that was cut short runs again from its start |
//! | [`Radar::shutdown`] | as for a signal, without ending the process |
//! | a response handle is dropped, or [`ResponseHandle::shutdown`] | that response stops: its exit slot runs, `exited` is sent |
//!
//! Nothing is needed in `main` for this: the README's program, stopped with Ctrl-C, runs its exit slots. A
//! program that handles signals itself builds its `Radar` with `handle_signals(false)` and calls
//! [`Radar::shutdown`] when told to stop. Only `SIGKILL` (and power loss) skips exit slots: no process can act
//! on it.
//!
//! ## Event semantics
//!
//! An event is active exactly while at least one subscription is matched on its `triggered` topic, whoever
//! owns it. While active, [`Event::check`] runs in a loop and every value it resolves with is published; when
//! the last subscriber leaves, the running check is dropped at its await point. The match count comes from
//! the DDS participant's discovery status events, which radar_ros consumes itself (ros2-client's counts never
//! drop after a peer is killed):
//!
//! | the subscriber | the event notices within |
//! |---|---|
//! | is created or deleted, in this or another process | milliseconds (measured: 3 ms to activate, under 1 ms to deactivate) |
//! | its process exits cleanly (drops its participant) | milliseconds (measured: 3-5 ms) |
//! | its process is killed (`SIGKILL`) | the dead participant's DDS lease: about 3-3.6 s for radar_ros peers ([`DEFAULT_LEASE`] 3 s + a 0.6 s check; `RADAR_LEASE_SECONDS` changes it), ~20 s for Fast DDS (rclpy) peers, ~52 s for other RustDDS programs |
//!
//! ## Types on the wire
//!
//! RustDDS matches a reader and a writer of one topic whatever their type names; ROS 2 does not. radar_ros
//! checks the type each peer announces in discovery: a peer of another type is not counted (it does not
//! activate an event), its samples are dropped, and a warning names both types. A message that does not
//! decode as its topic's type (truncated, oversized, random bytes) is dropped and counted per topic and
//! publisher ([`Radar::malformed_messages`], a response's `state.malformed`); each publisher is logged once
//! per topic, so a peer flooding a slot with garbage neither stops the component nor floods the log, and valid
//! messages on the same topic keep flowing.
//!
//! ## Discovery range
//!
//! `ROS_DOMAIN_ID` and `ROS_AUTOMATIC_DISCOVERY_RANGE` are honoured ([`RadarBuilder`]). With `LOCALHOST`,
//! RustDDS 0.15 does not deliver between endpoints of the *same* participant, so components in one process
//! cannot signal each other; use the default subnet range (a private network namespace isolates it, as the
//! test suite does with `tests/isolated.sh`).
//!
//! `RMW_IMPLEMENTATION` is read as ROS 2 reads it: unset or a DDS middleware (`rmw_fastrtps_cpp`,
//! `rmw_cyclonedds_cpp`, ...; they all speak RTPS, as radar_ros does) runs; `rmw_zenoh_cpp` or a name radar_ros
//! does not know stops [`RadarBuilder::build`] with an error that says what to set, since a program on DDS
//! among peers on Zenoh would see none of them. With the `zenoh` feature, `ZenohSignals` gives signal
//! publishers and subscriptions over Zenoh (docs/zenoh.md).
//!
//! ## Layers
//!
//! The [`radar_semantics`] crate holds the RADAR rules in plain Rust (no DDS, no runtime). This crate binds
//! them to ROS 2: components and the connection manager stand on one participant core (context, match graph,
//! endpoint factory, endpoint pool); the README's architecture section says what each file owns.

#![warn(missing_docs)]
#![deny(rustdoc::broken_intra_doc_links)]

#[cfg(feature = "codec")]
pub mod codec;
mod components;
mod connections;
mod departure;
mod endpoint;
mod macros;
mod node;
mod radar;
pub mod security;
mod wait;
mod wire;

pub use components::action;
pub use node::{clock, params, ros_args, rosout};
pub use radar::introspect;
pub use wire::{msg, qos};

// The root: RADAR's own names (docs/public_api.md lists every export; a test keeps the list true).
pub use components::event::{Event, EventHandle, TimerEvent, TopicEvent};
pub use components::response::{FnResponse, Response, ResponseHandle};
pub use components::trigger::Trigger;
pub use connections::manager::ConnectionGuard;
pub use connections::statement::{ConnectionRequest, Statement};
pub use error::{Error, Result, SlotError};
pub use node::shutdown::DEFAULT_SHUTDOWN_TIMEOUT;
pub use radar::{Radar, RadarBuilder};
pub use radar_semantics::response::{ExitAction, ExitReason, Phase, StartPolicy};
pub use wait::{Wait, DEFAULT_TIMEOUT};
pub use wire::refs::{AsResponse, AsSignal, EventRef, ResponseRef, Signal, Slot};

pub mod error;
pub mod graph;

/// How a [`Radar`] reaches the graph: which hosts discovery looks at ([`DiscoveryRange`](settings::DiscoveryRange)),
/// how soon a silent peer counts as gone ([`DEFAULT_LEASE`](settings::DEFAULT_LEASE)), and the ROS domain from the
/// environment ([`domain_id_from_env`](settings::domain_id_from_env)), as [`RadarBuilder`] takes them.
pub mod settings {
    pub use crate::radar::domain_id_from_env;
    pub use crate::radar::settings::{DiscoveryRange, DEFAULT_LEASE};
}

pub mod statement {
    //! RADAR's statements (`once E ...`, `whenever E ...`, `waitfor`) as [`Radar::once`](crate::Radar::once), [`Radar::whenever`](crate::Radar::whenever) and
    //! [`Radar::waiter`](crate::Radar::waiter) build them: a [`Statement`] given its target is a [`ConnectionRequest`], whose type says
    //! which target it has ([`StartTarget`]: it may take `until U`; [`OtherTarget`]: interrupt, exit, a slot, an
    //! anonymous slot); a [`Waiter`] is a `waitfor` armed.
    pub use crate::connections::statement::{
        ConnectionRequest, OtherTarget, StartTarget, Statement,
    };
    pub use crate::connections::waiter::Waiter;
}

pub mod manager {
    //! Connection managers: another program's, reached through its services ([`RemoteManager`],
    //! [`RemoteStatement`]), this program's served as a node ([`ManagerHandle`], [`OWNER_SILENT`]), and the state of
    //! a connection's link to its target ([`Link`]).
    pub use crate::connections::remote::{RemoteManager, RemoteStatement};
    pub use crate::radar::manager_node::{ManagerHandle, OWNER_SILENT};
    pub use radar_semantics::connection::Link;
}

pub mod topics {
    //! Plain topics beside RADAR's: typed and raw publishers and subscriptions ([`SignalPublisher`],
    //! [`SignalSubscription`], [`RawPublisher`], [`RawSubscription`], [`Sample`]), payloads of any type
    //! ([`RawMessage`], [`DynMessage`]), a component's own subscriptions ([`EventSubscription`]), what did not decode
    //! ([`MalformedCount`]), and, over Zenoh, a Radar's signals counted (`ZenohSignals`, feature `zenoh`).
    pub use crate::components::own_node::EventSubscription;
    pub use crate::node::topics::{
        RawPublisher, RawSubscription, Sample, SignalPublisher, SignalSubscription,
    };
    #[cfg(feature = "zenoh")]
    pub use crate::node::zenoh::ZenohSignals;
    pub use crate::wire::malformed::MalformedCount;
    pub use crate::wire::raw::{DynMessage, RawMessage};
}

pub mod nodes {
    //! The ROS nodes a component's slots and checks run with ([`ComponentNode`]; [`EventNode`] and
    //! [`ResponseNode`] name it for each kind), for their own topics and parameters.
    pub use crate::components::event::EventNode;
    pub use crate::components::own_node::ComponentNode;
    pub use crate::components::response::ResponseNode;
}

// The old places, kept for one release (0.2.0) and hidden from the docs; each says where its name went.
#[allow(missing_docs, deprecated)]
mod old_names {
    use std::time::Duration;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::graph::Component")]
    pub type Component = crate::graph::Component;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::graph::ComponentName")]
    pub type ComponentName = crate::graph::ComponentName;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::graph::Endpoint")]
    pub type Endpoint = crate::graph::Endpoint;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::graph::Departure")]
    pub type Departure = crate::graph::Departure;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::graph::LossCause")]
    pub type LossCause = crate::graph::LossCause;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::settings::DiscoveryRange")]
    pub type DiscoveryRange = crate::settings::DiscoveryRange;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::manager::RemoteManager")]
    pub type RemoteManager = crate::manager::RemoteManager;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::manager::RemoteStatement")]
    pub type RemoteStatement = crate::manager::RemoteStatement;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::manager::ManagerHandle")]
    pub type ManagerHandle = crate::manager::ManagerHandle;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::manager::Link")]
    pub type Link = crate::manager::Link;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::statement::Waiter")]
    pub type Waiter<M> = crate::statement::Waiter<M>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::RawPublisher")]
    pub type RawPublisher = crate::topics::RawPublisher;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::RawSubscription")]
    pub type RawSubscription = crate::topics::RawSubscription;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::Sample")]
    pub type Sample = crate::topics::Sample;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::DynMessage")]
    pub type DynMessage = crate::topics::DynMessage;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::RawMessage")]
    pub type RawMessage = crate::topics::RawMessage;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::MalformedCount")]
    pub type MalformedCount = crate::topics::MalformedCount;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::nodes::ComponentNode")]
    pub type ComponentNode<'a> = crate::nodes::ComponentNode<'a>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::nodes::EventNode")]
    pub type EventNode<'a> = crate::nodes::EventNode<'a>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::nodes::ResponseNode")]
    pub type ResponseNode<'a> = crate::nodes::ResponseNode<'a>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::SignalPublisher")]
    pub type SignalPublisher<M> = crate::topics::SignalPublisher<M>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::SignalSubscription")]
    pub type SignalSubscription<M> = crate::topics::SignalSubscription<M>;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::EventSubscription")]
    pub type EventSubscription<M> = crate::topics::EventSubscription<M>;
    #[cfg(feature = "zenoh")]
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::topics::ZenohSignals")]
    pub type ZenohSignals = crate::topics::ZenohSignals;
    #[doc(hidden)]
    #[deprecated(
        since = "0.2.0",
        note = "renamed: radar_ros::error::BoxError (a signal's origin is its source)"
    )]
    pub type Source = crate::error::BoxError;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::settings::DEFAULT_LEASE")]
    pub const DEFAULT_LEASE: Duration = crate::settings::DEFAULT_LEASE;
    #[doc(hidden)]
    #[deprecated(since = "0.2.0", note = "moved: radar_ros::manager::OWNER_SILENT")]
    pub const OWNER_SILENT: Duration = crate::manager::OWNER_SILENT;
    #[doc(hidden)]
    #[deprecated(
        since = "0.2.0",
        note = "moved: radar_ros::settings::domain_id_from_env"
    )]
    pub fn domain_id_from_env() -> crate::Result<u16> {
        crate::settings::domain_id_from_env()
    }
}
#[doc(hidden)]
pub use old_names::*;

/// The Rust types of the interfaces radar_ros ships (ROS 2 Jazzy's `std_msgs`, `builtin_interfaces`,
/// `geometry_msgs`, `sensor_msgs`, `nav_msgs`, `std_srvs`, `action_msgs`, `unique_identifier_msgs`,
/// `diagnostic_msgs`), generated from their definitions by [`radar_idl`](https://docs.rs/radar_idl) as a crate's
/// own build script generates its interfaces, each a [`msg::RosMessage`] with its RIHS01 hash.
///
/// ```
/// use radar_ros::{interfaces::geometry_msgs::msg::PoseStamped, msg::RosMessage};
/// let mut goal = PoseStamped::default();
/// goal.pose.position.x = 1.0;
/// assert_eq!(goal.pose.orientation.w, 1.0); // the definition's default
/// assert_eq!(PoseStamped::ros_type_name(), "geometry_msgs/msg/PoseStamped");
/// assert!(PoseStamped::TYPE_HASH.unwrap().starts_with("RIHS01_"));
/// ```
pub mod interfaces {
    // generated by radar_idl from the definitions radar_ros ships, as a user's build script generates theirs;
    // kept in the repository so that a user's build compiles no generator (the architecture test keeps it
    // current: `RADAR_BLESS=1` writes it again)
    include!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/generated/interfaces.rs"
    ));
}

// generated types name radar_ros as `::radar_ros`, inside radar_ros too
extern crate self as radar_ros;

/// serde, as generated types derive it (`#[serde(crate = "::radar_ros::serde")]`), so that a crate with
/// generated types needs no serde of its own.
#[doc(hidden)]
pub use serde;

/// The RADAR rules themselves, in plain Rust (re-exported from the [`radar_semantics`] crate).
pub use radar_semantics;

pub mod transport {
    //! The transport radar_ros runs on, for your own plain nodes, topics and services beside RADAR's: its patched
    //! ros2-client and RustDDS. They are pre-1.0 crates with their own release pace; radar_ros's root does not
    //! re-export them, so that a change of theirs is not a change of radar_ros's face.
    //!
    //! ```no_run
    //! # async fn f(radar: radar_ros::Radar) {
    //! use radar_ros::transport::ros2_client::{NodeName, NodeOptions};
    //! // over DDS (None over Zenoh: a Radar on Zenoh has no DDS context)
    //! if let Some(ctx) = radar.dds_context() {
    //!     let node = ctx.new_node(NodeName::new("/", "my_node").unwrap(), NodeOptions::new());
    //! }
    //! # }
    //! ```
    /// The ROS 2 client library radar_ros runs on: ros2-client 0.12.1 with radar_ros's patches (the package
    /// `radar-ros2-client` in radar_ros's `third_party/`). Use this one for your own nodes, topics and services
    /// ([`Radar::dds_context`](crate::Radar::dds_context) is one of its contexts): a crates.io ros2-client
    /// would be a second copy, whose types do not mix with these.
    pub use ros2_client;

    /// The DDS implementation radar_ros runs on: RustDDS 0.15.1 with radar_ros's patches (the package
    /// `radar-rustdds` in radar_ros's `third_party/`), the same as `ros2_client::dds::rustdds`.
    pub use rustdds;
}

// Kept at the root for one release, hidden: `radar_ros::transport::ros2_client` and `::rustdds` are their place
// (rustc does not warn of a deprecated re-export, so the docs and CHANGES.md say it).
#[doc(hidden)]
pub use ros2_client;
#[doc(hidden)]
pub use rustdds;

/// The README's code, compiled as a doc test so that it cannot go stale.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
