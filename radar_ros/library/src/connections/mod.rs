//! Connections: `once` / `whenever` statements and `until`, `waitfor`, the connection manager that carries out
//! what the semantics' table decides (relays, outlets, anonymous slots), the manager as a ROS node and other
//! programs' managers, in-process delivery, and causes and departures on the wire.

pub(crate) mod diagnostics;
pub(crate) mod manager;
pub(crate) mod program;
pub(crate) mod remote;
pub(crate) mod statement;
pub(crate) mod waiter;
