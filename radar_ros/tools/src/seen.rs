//! What `radar record` saw, as `radar verify` reads it back: one JSON object per sample, on the recording's
//! `/radar/trace` channel, beside the ROS messages themselves. It keeps what CDR does not carry: the cause of a
//! slot signal or a response's signal (the DDS related sample identity), the writer of each sample (which
//! process emitted it), and the states and connection lists in the few fields the rules need.

use serde::{Deserialize, Serialize};

/// The channel of a recording that holds these.
pub(crate) const CHANNEL: &str = "/radar/trace";

/// One thing seen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub(crate) enum Seen {
    /// A sample of a component's signal or slot (`topic` ends in the endpoint's name).
    Signal {
        topic: String,
        /// Its source time (ns since the epoch, by its writer's clock).
        stamp: i64,
        /// When the recorder read it (ns, its clock).
        log: i64,
        /// The statement (32 hex digits) and delivery it carries.
        cause: Option<(String, u64)>,
        /// Its writer (32 hex digits; the first 24 name the process's participant).
        writer: String,
        /// Its body's length.
        len: usize,
    },
    /// A response's state.
    ResponseState {
        name: String,
        stamp: i64,
        log: i64,
        state: String,
        last_exit_reason: String,
        policy: String,
        restarts: u64,
    },
    /// An event's state.
    EventState {
        name: String,
        stamp: i64,
        log: i64,
        active: bool,
        listeners: u32,
    },
    /// A manager's connection list.
    Connections {
        manager: String,
        stamp: i64,
        log: i64,
        connections: Vec<SeenConnection>,
    },
}

/// A connection as a list shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct SeenConnection {
    pub(crate) id: u64,
    /// `once` or `whenever`.
    pub(crate) kind: String,
    pub(crate) source: String,
    pub(crate) target: String,
    pub(crate) until: String,
    /// When the statement began (ns).
    pub(crate) since: i64,
    /// Its id, as its causes carry it (32 hex digits).
    pub(crate) statement: String,
}

impl Seen {
    /// Its source time: what a recording is ordered by.
    pub(crate) fn stamp(&self) -> i64 {
        match self {
            Seen::Signal { stamp, .. }
            | Seen::ResponseState { stamp, .. }
            | Seen::EventState { stamp, .. }
            | Seen::Connections { stamp, .. } => *stamp,
        }
    }

    /// When the recorder read it.
    pub(crate) fn log(&self) -> i64 {
        match self {
            Seen::Signal { log, .. }
            | Seen::ResponseState { log, .. }
            | Seen::EventState { log, .. }
            | Seen::Connections { log, .. } => *log,
        }
    }
}

/// Bytes as hex digits.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The cause of a sample, for a [`Seen::Signal`].
pub(crate) fn cause(c: Option<(u128, u64)>) -> Option<(String, u64)> {
    c.map(|(s, d)| (format!("{s:032x}"), d))
}

impl SeenConnection {
    /// The connection `c` of a list.
    pub(crate) fn of(c: &radar_ros::msg::Connection) -> SeenConnection {
        SeenConnection {
            id: c.id,
            kind: c.kind_label.clone(),
            source: c.source.clone(),
            target: c.target.clone(),
            until: c.until.clone(),
            since: crate::common::stamp_ns(&c.since),
            statement: c.statement.clone(),
        }
    }
}
