//! # radar_ros: RADAR reactive semantics on ROS 2
//!
//! RADAR (Biggs & MacDonald) lets deliberative robot code say *when this happens, do that*. This crate maps
//! its three concepts onto ROS 2, over real DDS through `ros2-client`, with no ROS installation:
//!
//! - **Events** ([`Event`], [`Radar::spawn_event`]) are nodes that publish `<name>/triggered`. An event checks
//!   its condition only while at least one subscriber is matched on `triggered`.
//! - **Responses** ([`Response`], [`Radar::spawn_response`]) are nodes with `start`, `interrupt` and `exit` slot
//!   topics, emitting `started`, `interrupted` and `exited`. The exit slot always runs.
//! - Both publish a transient-local `<name>/state` that `ros2 topic echo` shows.
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
//! // `ros2 topic pub --once /hello/start std_msgs/msg/Empty` now runs it.
//! # Ok(()) }
//! ```
//!
//! ## Response semantics
//!
//! Decided in one place, [`semantics::response::ResponseMachine`], and tested line by line:
//!
//! 1. Idle + `start` → emit `started` (carrying the payload), then run the start behaviour with the payload.
//!    The start behaviour always runs up to its first await point before the response takes the next signal,
//!    so `started` never announces a behaviour that did not run at all.
//! 2. The start behaviour returns → run the exit slot → emit `exited` *after* the exit slot completed → idle.
//!    `exited` carries the start behaviour's output (or the output type's default if the run did not
//!    complete).
//! 3. Running + `interrupt` → the start behaviour is cancelled at its current await point → emit `interrupted`
//!    as the interrupt slot begins → interrupt slot → exit slot → `exited`.
//! 4. Running + `exit` → the start behaviour is cancelled → exit slot (no interrupt slot) → `exited`.
//! 5. `interrupt` or `exit` while idle, interrupting or exiting: ignored, counted in the state message.
//! 6. `start` while not idle: per-response [`StartPolicy`]: `Ignore` (default, counted), `Restart` (interrupt
//!    the current run as in 3, then start with the new payload), `QueueOne` (run the newest payload after
//!    `exited`; one replaced in the queue counts as ignored).
//! 7. The exit slot always runs: after a normal end, an interrupt, an exit signal, an error returned by the
//!    start behaviour, or a panic in it. A panic in any slot is caught, logged, counted in the state, `exited`
//!    is still sent, and the node keeps serving.
//! 8. The exit slot may return [`ExitAction::Restart`] (the paper's `on exit: restart`): after `exited` the
//!    response starts again with the same payload. A queued start (policy 6) takes precedence.
//! 9. Slots are plain async Rust on tokio; sleeping in them never blocks a thread.
//!
//! Stopping a response ([`ResponseHandle::shutdown`] or dropping the handle) ends a running start behaviour as
//! an `exit` signal would, so the exit slot still runs.
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
//! activate an event), its samples are dropped, and a warning names both types. Malformed samples are
//! dropped with a warning; the component keeps serving.
//!
//! ## Discovery range
//!
//! `ROS_DOMAIN_ID` and `ROS_AUTOMATIC_DISCOVERY_RANGE` are honoured ([`RadarBuilder`]). With `LOCALHOST`,
//! RustDDS 0.15 does not deliver between endpoints of the *same* participant, so components in one process
//! cannot signal each other; use the default subnet range (a private network namespace isolates it, as the
//! test suite does with `tests/isolated.sh`).
//!
//! ## Layers
//!
//! [`semantics`] holds the RADAR rules in plain Rust (no DDS, no runtime). [`response`], [`event`],
//! [`signal`] and [`endpoints`] bind them to ROS 2 nodes and topics; a private `graph` module keeps the DDS
//! match counts.

#![warn(missing_docs)]

pub mod connect;
pub mod endpoints;
pub mod error;
pub mod event;
mod graph;
pub mod lookup;
pub mod macros;
pub mod manager_node;
pub mod msg;
#[cfg(test)]
mod msg_layout;
pub mod names;
pub mod radar;
pub mod raw;
pub mod response;
pub mod semantics;
pub mod signal;

pub use connect::{AsResponse, Connect, Connection, ResponseRef, Signal, Slot, Statement};
pub use error::{Error, Result, SlotError};
pub use event::{Event, EventHandle, EventNode, EventSubscription, TimerEvent, TopicEvent};
pub use lookup::EventRef;
pub use manager_node::ManagerHandle;
pub use names::ComponentName;
pub use radar::{
    discovery_range_from_env, domain_id_from_env, lease_from_env, parse_domain_id, DiscoveryRange,
    Radar, RadarBuilder, DEFAULT_LEASE,
};
pub use raw::{RawMessage, RawPublisher, RawSubscription};
pub use response::{FnResponse, Response, ResponseHandle};
pub use semantics::response::{ExitAction, ExitReason, Phase, StartPolicy};
pub use signal::{SignalPublisher, SignalSubscription};
