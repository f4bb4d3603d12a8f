//! Errors, each saying what went wrong and what to do next.

/// Everything that can go wrong when building RADAR components.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A node, namespace or topic name breaks the ROS naming rules.
    #[error("invalid ROS name \"{name}\": {reason}")]
    InvalidName {
        /// The name as given.
        name: String,
        /// Which rule it breaks and how to fix it.
        reason: String,
    },
    /// `ROS_DOMAIN_ID` (or an explicit domain id) is not usable.
    #[error(
        "invalid ROS_DOMAIN_ID \"{value}\": {reason}. Set ROS_DOMAIN_ID to a whole number from 0 to 232 \
         (0-101 and 215-232 avoid the Linux ephemeral port range), or unset it for domain 0"
    )]
    InvalidDomainId {
        /// The value as found.
        value: String,
        /// Why it was refused.
        reason: String,
    },
    /// An environment variable radar_ros reads has a value it cannot use.
    #[error("invalid {var}=\"{value}\": {reason}")]
    InvalidEnv {
        /// The variable.
        var: &'static str,
        /// Its value as found.
        value: String,
        /// Why it was refused and what to set instead.
        reason: String,
    },
    /// A component with this name already runs in this process.
    #[error("a RADAR component named \"{0}\" already runs in this process; pick another name or namespace")]
    DuplicateName(String),
    /// DDS or ros2-client refused to create an entity.
    #[error("ROS 2 (DDS) could not create {what}: {detail}")]
    Dds {
        /// What was being created.
        what: String,
        /// The underlying error.
        detail: String,
    },
    /// Waiting for something on the ROS graph took longer than allowed.
    #[error("timed out after {after:?} waiting for {what}")]
    Timeout {
        /// What was awaited.
        what: String,
        /// How long we waited.
        after: std::time::Duration,
    },
    /// A connection's source carries another type than its target slot accepts.
    #[error(
        "type mismatch: {source_topic} carries {source_type} but {slot_topic} takes {slot_type}; connect a \
         signal of type {slot_type}, or a slot that takes {source_type}"
    )]
    TypeMismatch {
        /// The source signal's topic.
        source_topic: String,
        /// Its type.
        source_type: String,
        /// The slot's topic.
        slot_topic: String,
        /// Its type.
        slot_type: String,
    },
    /// No component of that name appeared on the ROS graph in time.
    #[error(
        "no RADAR {kind} named \"{name}\" appeared on the ROS graph within {after:?}; is it running, in this \
         ROS_DOMAIN_ID and namespace? Components seen: {}",
        if candidates.is_empty() { "none".to_owned() } else { candidates.join(", ") }
    )]
    NotFound {
        /// The name looked for, fully qualified.
        name: String,
        /// `event` or `response`.
        kind: &'static str,
        /// How long we waited.
        after: std::time::Duration,
        /// RADAR components that were found, closest names first.
        candidates: Vec<String>,
    },
    /// The name belongs to a component of the other kind.
    #[error("\"{name}\" is a RADAR {found}, but {expected} was asked for; look it up with radar.{found}(..)")]
    WrongKind {
        /// The name, fully qualified.
        name: String,
        /// What was asked for, with its article (`an event`).
        expected: &'static str,
        /// What is there.
        found: &'static str,
    },
    /// Several types are published on a component's topic.
    #[error("{topic} carries several types ({}); rename one of the components", types.join(", "))]
    Ambiguous {
        /// The topic.
        topic: String,
        /// The types seen on it.
        types: Vec<String>,
    },
    /// A connection statement that cannot mean anything.
    #[error("invalid statement: {0}")]
    InvalidStatement(String),
    /// The component was shut down while the call was in progress.
    #[error("{0} is shut down")]
    Closed(String),
}

impl Error {
    pub(crate) fn dds(what: impl Into<String>, detail: impl std::fmt::Debug) -> Error {
        let mut detail = format!("{detail:?}");
        if detail.contains("Too many open files") {
            // seen at scale: RustDDS holds about 3 file descriptors per reader or writer
            detail.push_str(
                "; this process ran out of file descriptors: every DDS reader or writer holds a few (about \
                 20 per response, 6 per event), so raise the limit (`ulimit -n 65536`, or LimitNOFILE= in a \
                 systemd unit) or spread components over more processes",
            );
        }
        Error::Dds {
            what: what.into(),
            detail,
        }
    }
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// An error returned from a user's slot or event check. Any `std::error::Error` converts into it with `?`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlotError(pub String);

impl std::fmt::Display for SlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error> From<E> for SlotError {
    fn from(e: E) -> Self {
        SlotError(e.to_string())
    }
}

impl SlotError {
    /// An error from a message.
    pub fn msg(m: impl Into<String>) -> SlotError {
        SlotError(m.into())
    }
}
