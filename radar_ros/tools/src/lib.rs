//! The programs around radar_ros, as a library: `radar`, RADAR on a ROS 2 graph from the shell with no ROS
//! installation (like OpenRTM's rtshell), and `radar_manager`, a standalone connection manager node.
//!
//! ```text
//! radar ls [NS] [-l]                       events and responses, their types and state     (rtls)
//! radar cat NAME                           one component: topics, state, connections        (rtcat)
//! radar act start|interrupt|exit NAME [P]  drive a response, show the signal that follows   (rtact)
//! radar inject TOPIC [PAYLOAD]             publish into a slot                              (rtinject)
//! radar watch [NAMES]                      a live timeline of signals and state changes     (rtprint)
//! radar con once|whenever SOURCE SLOT      connect through a manager's services             (rtcon)
//! radar dis ID                             remove a detached connection                     (rtdis)
//! radar graph [-o FILE.svg|FILE.dot]       components and live connections as a picture     (rtstodot)
//! radar record -o FILE.mcap [NAMES]        signals and state changes to MCAP (ros2msg/cdr)  (rtlog)
//! radar replay FILE.mcap [--rate R]        publish the recorded signals with their timing   (rtlog)
//! radar view [--port N] [--allow-act]      the system live in a browser (graph, states, timeline)
//! ```
//!
//! Every verb honours `ROS_DOMAIN_ID`, takes `--json` (one JSON document per line) and exits non-zero with a
//! message that says what to do when something is wrong: [`cli::run`]'s [`Error`], printed with its causes.
//!
//! Layout: [`cli`] parses the arguments and runs one module of `verbs` per verb; `common` and `components` hold
//! what several verbs share; [`codec`] turns payloads to and from YAML/JSON, [`schemas`] gives the ROS 2 message
//! definitions a recording stores, [`picture`] draws `radar graph`, [`mcap_out`] writes recordings that
//! survive being cut off, and `view` serves `radar view`'s page and WebSocket.

#![warn(missing_docs)]

pub mod cli;
pub use radar_ros::codec;
mod common;
mod components;
mod error;
pub use error::Error;
pub mod logging;
pub mod mcap_out;
pub mod picture;
pub mod schemas;
mod seen;
mod verbs;
mod view;
