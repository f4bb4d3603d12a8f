//! Messages that do not decode as their topic's type: dropped, counted per topic and publisher, and logged
//! once per publisher, so a peer that floods a slot with garbage neither stops the component nor floods the
//! log, and the count shows who sent what ([`Radar::malformed_messages`](crate::Radar::malformed_messages),
//! and a response's `state`).

use std::{collections::HashMap, sync::Mutex};

/// How many distinct (topic, publisher) pairs are tracked; past that, new publishers are counted together.
const MAX_TRACKED: usize = 4096;

/// What [`Radar::malformed_messages`](crate::Radar::malformed_messages) reports for one topic and publisher.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MalformedCount {
    /// The topic, e.g. `/arm/start`.
    pub topic: String,
    /// The publisher's GID (hex), or `(unknown)` where the transport does not tell (service requests,
    /// payloads already relayed), or `(others)` past the tracking limit.
    pub publisher: String,
    /// The type the messages should have had.
    pub expected: String,
    /// How many were dropped.
    pub count: u64,
}

/// The registry of one participant.
#[derive(Default)]
pub(crate) struct Malformed {
    seen: Mutex<HashMap<(String, String), (String, u64)>>,
}

impl Malformed {
    /// Counts one dropped message on `topic` from `publisher`; logs a warning the first time for that pair.
    /// Returns whether it was the first.
    pub(crate) fn note(
        &self,
        topic: &str,
        expected: &str,
        publisher: Option<&str>,
        error: &dyn std::fmt::Display,
    ) -> bool {
        let mut seen = self.seen.lock().unwrap();
        let mut who = publisher.unwrap_or("(unknown)").to_owned();
        if seen.len() >= MAX_TRACKED && !seen.contains_key(&(topic.to_owned(), who.clone())) {
            who = "(others)".to_owned();
        }
        let e = seen
            .entry((topic.to_owned(), who.clone()))
            .or_insert_with(|| (expected.to_owned(), 0));
        e.1 += 1;
        let first = e.1 == 1;
        drop(seen);
        if first {
            tracing::warn!(
                %topic, %expected, publisher = %who, %error,
                "dropped a message that does not decode as {expected}; publish {expected} on {topic}. Further \
                 ones from this publisher are counted (Radar::malformed_messages, the response's state), not \
                 logged"
            );
        }
        first
    }

    /// Every count, sorted by topic and publisher.
    pub(crate) fn counts(&self) -> Vec<MalformedCount> {
        let mut v: Vec<MalformedCount> = self
            .seen
            .lock()
            .unwrap()
            .iter()
            .map(|((topic, publisher), (expected, count))| MalformedCount {
                topic: topic.clone(),
                publisher: publisher.clone(),
                expected: expected.clone(),
                count: *count,
            })
            .collect();
        v.sort_by(|a, b| (&a.topic, &a.publisher).cmp(&(&b.topic, &b.publisher)));
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counted_per_topic_and_publisher_and_reported_first_once() {
        let m = Malformed::default();
        assert!(m.note("/a/start", "std_msgs/msg/String", Some("01"), &"short"));
        assert!(!m.note("/a/start", "std_msgs/msg/String", Some("01"), &"short"));
        assert!(m.note("/a/start", "std_msgs/msg/String", Some("02"), &"short"));
        assert!(m.note("/srv", "x/srv/Y_Request", None, &"short"));
        let c = m.counts();
        assert_eq!(
            c.iter()
                .map(|c| (c.topic.as_str(), c.publisher.as_str(), c.count))
                .collect::<Vec<_>>(),
            [
                ("/a/start", "01", 2),
                ("/a/start", "02", 1),
                ("/srv", "(unknown)", 1)
            ]
        );
    }

    #[test]
    fn past_the_limit_new_publishers_are_counted_together() {
        let m = Malformed::default();
        for i in 0..MAX_TRACKED + 10 {
            m.note("/t", "T", Some(&i.to_string()), &"bad");
        }
        let c = m.counts();
        assert_eq!(c.len(), MAX_TRACKED + 1);
        assert_eq!(
            c.iter()
                .find(|c| c.publisher == "(others)")
                .map(|c| c.count),
            Some(10)
        );
    }
}
