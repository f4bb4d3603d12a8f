//! The wire: the DDS participant every part stands on, endpoints and the pool that shares them, topics typed
//! and raw, ROS names and how they appear on DDS, QoS, and the messages.

pub(crate) mod cause;
pub(crate) mod dds_names;
pub(crate) mod local;
pub(crate) mod malformed;
pub mod msg;
#[cfg(test)]
mod msg_layout;
mod msg_support;
pub(crate) mod names;
pub mod qos;
pub(crate) mod raw;
pub(crate) mod readers;
pub(crate) mod refs;
