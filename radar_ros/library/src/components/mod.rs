//! Components: events (condition checks that emit `triggered` while something listens), responses (behaviour
//! with `start`, `interrupt` and `exit` slots) and ROS 2 actions on both sides, each a ROS 2 node, and the
//! references by which connections name them.

pub mod action;
pub(crate) mod event;
pub(crate) mod own_node;
pub(crate) mod response;
pub(crate) mod trigger;
