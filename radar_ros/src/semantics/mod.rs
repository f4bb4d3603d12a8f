//! RADAR semantics in plain Rust: no DDS, no async runtime. The ROS 2 binding ([`crate::response`],
//! [`crate::event`]) executes what these machines decide.

pub mod connection;
pub mod event;
pub mod response;
