//! Errors by kind, each saying what went wrong and what to do next, with the underlying error kept as
//! [`std::error::Error::source`].
//!
//! ```
//! use radar_ros::Error;
//! let e = radar_ros::Radar::builder().namespace("not a namespace").build().unwrap_err();
//! assert!(matches!(e, Error::InvalidName { .. }));
//! assert!(e.to_string().contains("not a namespace"));
//! ```

/// A boxed underlying error (an [`Error`]'s cause, from [`std::error::Error::source`]).
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// Everything that can go wrong in radar_ros.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Configuration: an environment variable or builder setting that cannot be used, or a missing runtime.
    #[error("invalid {setting} \"{value}\": {reason}")]
    Config {
        /// The setting: `ROS_DOMAIN_ID`, `RADAR_LEASE_SECONDS`, ...
        setting: &'static str,
        /// Its value as found.
        value: String,
        /// Why it was refused and what to set instead.
        reason: String,
    },
    /// A node, namespace, topic or type name breaks the ROS naming rules.
    #[error("invalid ROS name \"{name}\": {reason}")]
    InvalidName {
        /// The name as given.
        name: String,
        /// Which rule it breaks and how to fix it.
        reason: String,
    },
    /// A component with this name already runs in this process.
    #[error("a RADAR component named \"{0}\" already runs in this process; pick another name or namespace")]
    DuplicateName(String),
    /// Lookup: no component of that name appeared on the ROS graph in time.
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
    /// Lookup: the name belongs to a component of the other kind.
    #[error("\"{name}\" is a RADAR {found}, but {expected} was asked for; look it up with radar.{found}(..)")]
    WrongKind {
        /// The name, fully qualified.
        name: String,
        /// What was asked for, with its article (`an event`).
        expected: &'static str,
        /// What is there.
        found: &'static str,
    },
    /// Lookup: several types are published on a component's topic.
    #[error("{topic} carries several types ({}); rename one of the components", types.join(", "))]
    Ambiguous {
        /// The topic.
        topic: String,
        /// The types seen on it.
        types: Vec<String>,
    },
    /// Types: a connection's source carries another type than its target slot accepts.
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
    /// Types: Rust code given to a connection or a call (a filter, a transform, an anonymous slot, an injected
    /// payload) takes or gives another type than the topic carries.
    #[error("{what} uses {given} but {topic} carries {expected}; use {expected} there")]
    PayloadType {
        /// What was given: `a filter`, `a map`, `an anonymous slot`, `an injected payload`.
        what: &'static str,
        /// The topic.
        topic: String,
        /// The topic's type.
        expected: String,
        /// The Rust side's type.
        given: String,
    },
    /// A connection statement that cannot mean anything.
    #[error("invalid statement: {0}")]
    InvalidStatement(String),
    /// Waiting for something on the ROS graph took longer than allowed.
    #[error("timed out after {after:?} waiting for {what}")]
    Timeout {
        /// What was awaited.
        what: String,
        /// How long we waited.
        after: std::time::Duration,
    },
    /// Transport: the middleware (DDS or Zenoh) refused to create an endpoint or to send. The message says
    /// what failed and what to do; the middleware's own error is the [`source`](std::error::Error::source)
    /// ([`Error::report`] prints both).
    #[error("ROS 2 could not {what}{hint}")]
    Transport {
        /// What was being done: `create a publisher on /x`, `send on /x`.
        what: String,
        /// The underlying error.
        source: BoxError,
        /// What to do about it, if known.
        hint: String,
    },
    /// Codec: a message could not be encoded or decoded as CDR of its type (why: the
    /// [`source`](std::error::Error::source); [`Error::report`] prints both).
    #[error("could not {what}")]
    Codec {
        /// `decode a std_msgs/msg/String from 3 bytes`, ...
        what: String,
        /// The underlying error.
        source: BoxError,
    },
    /// A component left the ROS graph while we waited for its signal (it exited, crashed, hangs, or the
    /// network cut it off): what it would have sent will not come.
    #[error(
        "gave up waiting for {waiting_for}: {departure}; start it again (or find out why it stopped) and wait \
         again"
    )]
    ComponentLost {
        /// What was awaited: `a signal on /bumper/triggered`.
        waiting_for: String,
        /// Which component left, and why.
        departure: crate::departure::Departure,
    },
    /// The component, connection or participant was shut down while the call was in progress.
    #[error("{0} is shut down")]
    Closed(String),
    /// Another program's manager refused a request (its services answered `ok = false`), saying why.
    #[error("the manager {manager} refused: {reason}")]
    Refused {
        /// The manager node.
        manager: String,
        /// Its answer: what is wrong and what to do.
        reason: String,
    },
}

/// A message as an error, for sources that only give text.
#[derive(Clone, Debug)]
pub(crate) struct Text(pub(crate) String);

impl std::fmt::Display for Text {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Text {}

/// An error and its causes, each after a colon, as a command-line tool prints an error chain:
/// `could not decode a std_msgs/msg/String from 3 bytes: unexpected end`. Every [`Error`] keeps its cause in
/// [`source`](std::error::Error::source) only, so that printing the chain shows it once.
///
/// ```
/// use radar_ros::error::Report;
/// let io = std::io::Error::other("disk full");
/// let e = std::io::Error::other(io);
/// assert_eq!(Report(&e).to_string(), "disk full");
/// ```
#[derive(Clone, Copy)]
pub struct Report<'a>(pub &'a (dyn std::error::Error + 'static));

impl std::fmt::Display for Report<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)?;
        let mut cause = self.0.source();
        while let Some(c) = cause {
            write!(f, ": {c}")?;
            cause = c.source();
        }
        Ok(())
    }
}

impl std::fmt::Debug for Report<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// Whether the process ran out of file descriptors, by the OS error somewhere in `source`'s chain (EMFILE,
/// ENFILE), or by its text where a layer kept only text.
fn out_of_descriptors(source: &(dyn std::error::Error + 'static)) -> bool {
    let mut cause = Some(source);
    while let Some(c) = cause {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            if matches!(io.raw_os_error(), Some(24 | 23)) {
                return true;
            }
        }
        cause = c.source();
    }
    Report(source).to_string().contains("Too many open files")
}

/// Whether `source` is DDS Security refusing what was asked (RustDDS's `NotAllowedBySecurity`).
fn denied_by_security(source: &(dyn std::error::Error + 'static)) -> bool {
    format!("{source:?}").contains("NotAllowedBySecurity")
}

impl Error {
    /// This error with its causes, for printing: `ROS 2 could not create a publisher on /x: <the middleware's
    /// error>`.
    pub fn report(&self) -> Report<'_> {
        Report(self)
    }

    /// Whether this is DDS Security refusing to create an endpoint this enclave's permissions do not grant.
    pub(crate) fn not_allowed_by_security(&self) -> bool {
        match self {
            Error::Transport { source, .. } => denied_by_security(source.as_ref()),
            _ => false,
        }
    }

    /// A transport error while creating `what`, keeping `source`.
    pub(crate) fn transport(
        what: impl Into<String>,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Error {
        let text = Report(&source).to_string();
        let hint = if out_of_descriptors(&source) {
            // radar_ros's own need is small since RustDDS patch 15 (2,000 components: about 22 descriptors)
            "; this process ran out of file descriptors: each `Radar` (a DDS participant) holds a few sockets and \
             its components almost none, so look for what else holds them (many `Radar`s or DDS contexts, open \
             files), or raise the limit (`ulimit -n 65536`, or LimitNOFILE= in a systemd unit)"
                .to_owned()
        } else if text.contains("not allowed by security") || denied_by_security(&source) {
            "; this program's enclave (ROS_SECURITY_KEYSTORE/enclaves/<enclave>/permissions.xml) does not grant \
             it: grant it in the enclave's policy (`radar security create_permission KEYSTORE ENCLAVE POLICY`) or \
             run this part under an enclave that has it; see docs/security.md"
                .to_owned()
        } else {
            String::new()
        };
        Error::Transport {
            what: format!("create {}", what.into()),
            source: Box::new(source),
            hint,
        }
    }

    /// A failed send of a message on `topic`.
    pub(crate) fn send(
        topic: &str,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Error {
        Error::Transport {
            what: format!("send on {topic}"),
            source: Box::new(source),
            hint: String::new(),
        }
    }

    /// A codec error while doing `what`.
    pub(crate) fn codec(what: impl Into<String>, source: impl std::fmt::Display) -> Error {
        Error::Codec {
            what: what.into(),
            source: Box::new(Text(source.to_string())),
        }
    }
}

/// Result alias for this crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// An error returned from a user's slot or event check. Any `std::error::Error` converts into it with `?`,
/// keeping the text of its causes.
///
/// ```
/// use radar_ros::SlotError;
/// fn parse(s: &str) -> Result<u32, SlotError> {
///     Ok(s.parse::<u32>()?) // a ParseIntError becomes a SlotError
/// }
/// assert!(parse("x").is_err());
/// assert_eq!(SlotError::msg("blocked").to_string(), "blocked");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlotError(String);

impl std::fmt::Display for SlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<E: std::error::Error> From<E> for SlotError {
    /// The error and each of its causes (`source()`), as [`Report`] prints them: an error that keeps its cause
    /// in `source()` only (radar_ros's own, `std::io::Error::other(..)`'s wrappers, thiserror's `#[source]`)
    /// does not lose it on the way into a response's `exited` or an event's state.
    fn from(e: E) -> Self {
        let mut text = e.to_string();
        let mut cause = e.source();
        while let Some(c) = cause {
            text.push_str(": ");
            text.push_str(&c.to_string());
            cause = c.source();
        }
        SlotError(text)
    }
}

impl SlotError {
    /// An error from a message.
    ///
    /// ```
    /// let e = radar_ros::SlotError::msg("the gripper is blocked");
    /// assert_eq!(e.to_string(), "the gripper is blocked");
    /// ```
    pub fn msg(m: impl Into<String>) -> SlotError {
        SlotError(m.into())
    }

    /// The message.
    pub fn message(&self) -> &str {
        &self.0
    }

    /// The message, taken.
    pub fn into_message(self) -> String {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use std::error::Error as _;

    use super::*;

    #[test]
    fn transport_errors_keep_their_cause_in_source_only_and_tell_file_descriptors_by_the_os_error()
    {
        // told by the OS error itself, wherever it is in the chain
        let emfile = std::io::Error::from_raw_os_error(24);
        let e = Error::transport("a publisher on /x", std::io::Error::other(emfile));
        let text = e.to_string();
        assert!(
            text.starts_with("ROS 2 could not create a publisher on /x; this process ran out of file descriptors"),
            "{text}"
        );
        assert!(text.contains("ulimit -n"), "{text}");
        // the cause is in source() only: printed once, by the chain
        assert!(!text.contains("os error 24"), "{text}");
        let chain = e.report().to_string();
        assert_eq!(chain.matches("os error 24").count(), 1, "{chain}");
        assert!(chain.ends_with("(os error 24)"), "{chain}");
        // a layer that kept only the text
        let e = Error::transport("a reader", std::io::Error::other("Too many open files"));
        assert!(e.to_string().contains("ulimit -n"));
        // anything else: no hint
        let e = Error::transport("a reader", std::io::Error::from_raw_os_error(2));
        assert_eq!(e.to_string(), "ROS 2 could not create a reader");
        let e = Error::codec(
            "decode a std_msgs/msg/String from 3 bytes",
            "unexpected end",
        );
        assert_eq!(
            e.to_string(),
            "could not decode a std_msgs/msg/String from 3 bytes"
        );
        assert_eq!(
            e.report().to_string(),
            "could not decode a std_msgs/msg/String from 3 bytes: unexpected end"
        );
        assert!(e.source().is_some());
    }

    #[test]
    fn a_slot_error_made_with_question_mark_keeps_every_cause() {
        fn slot() -> std::result::Result<(), SlotError> {
            let refused = std::io::Error::from(std::io::ErrorKind::ConnectionRefused);
            Err(Error::transport("a publisher on /dock/start", refused))?;
            Ok(())
        }
        let e = slot().unwrap_err();
        assert_eq!(
            e.message(),
            format!(
                "ROS 2 could not create a publisher on /dock/start: {}",
                std::io::Error::from(std::io::ErrorKind::ConnectionRefused)
            )
        );
        // an error without causes is its text alone
        let e: SlotError = "x".parse::<u32>().unwrap_err().into();
        assert_eq!(e.message(), "invalid digit found in string");
    }
}
