//! Components that leave the ROS graph: why, and how that reads to a user.
//!
//! radar_ros learns that a component left when the last DDS endpoint it watches on one of the component's
//! topics goes: the source signal of a connection or a waiter loses its last publisher, or a slot loses its
//! last subscriber. DDS tells why: the peer announced that it closes the endpoint or exits (milliseconds), or
//! nothing was heard from its process for longer than its lease (a crash, `kill -9`, a hang, a cut cable:
//! 3 s plus up to 0.6 s for radar_ros peers, 20 s for Fast DDS peers such as rclpy nodes).

use std::time::Duration;

/// Why a component's endpoint left the graph.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LossCause {
    /// It said goodbye: it closed the endpoint, or its process exited normally.
    Left,
    /// Nothing was heard from its process for `silent_for`, longer than its DDS lease: it crashed, was killed,
    /// hangs (or is stopped), or the network cut it off.
    Unreachable {
        /// How long its process had been silent when the lease ran out.
        silent_for: Duration,
    },
    /// A new instance of it appeared in another process (a launch `respawn`, a systemd restart) while the old
    /// one was still on the graph: the old one crashed or hangs, and its lease has not run out yet.
    Replaced,
}

impl std::fmt::Display for LossCause {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LossCause::Left => f.write_str("it closed that endpoint or its process exited"),
            LossCause::Unreachable { silent_for } => write!(
                f,
                "nothing was heard from its process for {:.1} s, longer than its lease: it crashed, was \
                 killed, hangs, or the network cut it off",
                silent_for.as_secs_f64()
            ),
            LossCause::Replaced => f.write_str(
                "a new instance of it started in another process (respawned) while the old one was still on \
                 the graph: the old one crashed or hangs",
            ),
        }
    }
}

/// A connected component that left the ROS graph: which, through which topic that was seen, and why.
///
/// ```
/// use radar_ros::{graph::Departure, graph::LossCause};
/// let d = Departure::of_publisher("/bumper/triggered", LossCause::Left);
/// assert_eq!(d.component(), "/bumper");
/// assert!(d.to_string().starts_with("/bumper left the ROS graph"));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Departure {
    component: String,
    topic: String,
    publisher: bool,
    cause: LossCause,
}

/// `/ns/name/triggered` -> `/ns/name`; a topic that is not a RADAR endpoint names itself.
fn component_of(topic: &str) -> String {
    match crate::endpoint::Endpoint::of_topic(topic) {
        Some((parent, _)) => parent.to_owned(),
        None => topic.to_owned(),
    }
}

impl Departure {
    /// The last publisher of signal `topic` left.
    pub fn of_publisher(topic: &str, cause: LossCause) -> Departure {
        Departure {
            component: component_of(topic),
            topic: topic.to_owned(),
            publisher: true,
            cause,
        }
    }

    /// The last subscriber of slot `topic` left.
    pub fn of_subscriber(topic: &str, cause: LossCause) -> Departure {
        Departure {
            component: component_of(topic),
            topic: topic.to_owned(),
            publisher: false,
            cause,
        }
    }

    /// The component: the topic's parent for a RADAR endpoint (`/bumper` for `/bumper/triggered`), else the
    /// topic itself.
    pub fn component(&self) -> &str {
        &self.component
    }

    /// The topic through which the departure was seen.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Why it left.
    pub fn cause(&self) -> &LossCause {
        &self.cause
    }
}

impl std::fmt::Display for Departure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let verb = match self.cause {
            LossCause::Left => "left the ROS graph",
            LossCause::Unreachable { .. } => "is unreachable",
            LossCause::Replaced => "was replaced",
        };
        let side = if self.publisher {
            "publisher"
        } else {
            "subscriber"
        };
        match self.cause {
            // the new instance is there: it is the old one that is gone
            LossCause::Replaced => write!(
                f,
                "{} {verb} (the old {side} of {} is gone): {}",
                self.component, self.topic, self.cause
            ),
            _ => write!(
                f,
                "{} {verb} ({} has no {side} now): {}",
                self.component, self.topic, self.cause
            ),
        }
    }
}

impl LossCause {
    /// The cause of a DDS participant's or endpoint's loss, as RustDDS tells it.
    pub(crate) fn of(reason: &ros2_client::dds::rustdds::LostReason) -> LossCause {
        use ros2_client::dds::rustdds::LostReason;
        match reason {
            LostReason::Disposed => LossCause::Left,
            LostReason::Timeout { elapsed, .. } => LossCause::Unreachable {
                silent_for: elapsed.to_std(),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn components_are_named_after_their_endpoints() {
        assert_eq!(component_of("/a/b/exited"), "/a/b");
        assert_eq!(component_of("/count_up/start"), "/count_up");
        assert_eq!(component_of("/scan_ok"), "/scan_ok");
        assert_eq!(component_of("/triggered"), "/triggered");
        // an action response's feedback is one of its endpoints too
        assert_eq!(component_of("/fib/feedback"), "/fib");
        let d = Departure::of_subscriber(
            "/arm/start",
            LossCause::Unreachable {
                silent_for: Duration::from_millis(3400),
            },
        );
        assert_eq!(
            d.to_string(),
            "/arm is unreachable (/arm/start has no subscriber now): nothing was heard from its process for \
             3.4 s, longer than its lease: it crashed, was killed, hangs, or the network cut it off"
        );
    }
}
