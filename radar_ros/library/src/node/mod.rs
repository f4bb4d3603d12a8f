//! What every ROS 2 node has, for components and programs: `--ros-args`, parameters, `/rosout`, the clock
//! (wall or simulated) and how a program told to stop stops.

pub(crate) mod action_server;
pub(crate) mod actions;
pub mod clock;
pub(crate) mod declared;
pub(crate) mod domain;
pub(crate) mod endpoints;
pub mod params;
pub(crate) mod participant;
pub(crate) mod plain;
pub(crate) mod pool;
pub mod ros_args;
pub mod rosout;
pub(crate) mod services;
pub(crate) mod shutdown;
pub(crate) mod topics;
pub(crate) mod transport;
pub(crate) mod watched;
#[cfg(feature = "zenoh")]
pub(crate) mod zenoh;
#[cfg(feature = "zenoh")]
pub(crate) mod zenoh_goals;
