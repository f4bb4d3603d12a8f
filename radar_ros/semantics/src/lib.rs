//! # radar_semantics: what RADAR does, with no I/O
//!
//! RADAR (Biggs & MacDonald) means the same on any middleware: events that check only while something
//! listens, responses with `start`, `interrupt` and `exit` slots whose exit slot always runs, and `once` /
//! `whenever` / `until` connections that deliver signals to slots for as long as a block of code lives. This
//! crate holds those rules as plain state machines that take inputs and return what must happen; it has no
//! dependencies, no async runtime and no DDS, so every rule is tested here on its own, line by line. The ROS 2
//! binding (the `radar_ros` crate) runs slots, moves messages and carries out what these machines decide.
//!
//! - [`response`]: the response state machine ([`response::ResponseMachine`], rules R1-R14).
//! - [`event`]: the event activation rule ([`event::Activation`], rule E1).
//! - [`served`]: a response served as a ROS 2 action server ([`served::ServedAction`], rules S1-S7).
//! - [`goal`]: an action server driven as a response, one goal per run ([`goal::GoalMachine`], rules A1-A7).
//! - [`connection`]: the connection table ([`connection::ConnectionTable`], rules C1-C7: once, whenever,
//!   until windows, no stale signals, removal, components that leave, signals read out of order).
//! - [`instances`]: which process runs a component, so that one started again within its lease is told from
//!   the one it replaces (rule C5).
//! - [`time`]: what a receiver makes of another clock's stamps, and of its own clock stepping back (rules
//!   T1-T2).
//!
//! The rules are stated once, in `radar_spec` (`radar_ros/spec/src/rules/mod.rs`; the list is `docs/rules.md`),
//! as checks over a whole trace, apart from these machines. Each module here says, step by step, how its
//! machine carries them out, under the same numbers; the `radar_ros` documentation, the README and the tests
//! (named `r3_...`, `c6_...`) use them too.
//!
//! ```
//! use radar_semantics::response::{Effect, Input, ResponseMachine, Sent, StartPolicy};
//! let mut r = ResponseMachine::<&str, ()>::new(StartPolicy::Ignore);
//! let fx = r.handle(Input::Start("go", Sent::at(1_000)));
//! assert!(matches!(fx[..], [Effect::EmitStarted("go", None), Effect::RunStart("go")]));
//! ```

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod connection;
pub mod event;
pub mod goal;
pub mod instances;
pub mod response;
pub mod served;
pub mod time;
