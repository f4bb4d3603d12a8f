//! # radar_semantics: what RADAR does, with no I/O
//!
//! RADAR (Biggs & MacDonald) means the same on any middleware: events that check only while something
//! listens, responses with `start`, `interrupt` and `exit` slots whose exit slot always runs, and `once` /
//! `whenever` / `until` connections that deliver signals to slots for as long as a block of code lives. This
//! crate holds those rules as plain state machines that take inputs and return what must happen; it has no
//! dependencies, no async runtime and no DDS, so every rule is tested here on its own, line by line. The ROS 2
//! binding (the `radar_ros` crate) runs slots, moves messages and carries out what these machines decide.
//!
//! - [`response`]: the response state machine ([`response::ResponseMachine`], rules 1-8).
//! - [`event`]: the event activation rule ([`event::Activation`]).
//! - [`connection`]: the connection table ([`connection::ConnectionTable`]: once, whenever, until windows,
//!   no stale signals, removal).
//!
//! ```
//! use radar_semantics::response::{Effect, Input, ResponseMachine, StartPolicy};
//! let mut r = ResponseMachine::<&str, ()>::new(StartPolicy::Ignore);
//! let fx = r.handle(Input::Start("go"));
//! assert!(matches!(fx[..], [Effect::EmitStarted("go"), Effect::RunStart("go")]));
//! ```

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod connection;
pub mod event;
pub mod response;
