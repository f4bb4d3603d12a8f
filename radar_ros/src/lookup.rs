//! Finding RADAR components by name through ROS graph discovery, instead of a naming service.
//!
//! `radar.response("count_up")` resolves the name like any ROS name (relative names in the Radar's namespace,
//! absolute names as given) and waits (default 5 s) until the graph shows a response there: a subscription on
//! `<name>/start` and a publisher on `<name>/exited`. `radar.event("start_event")` waits for a publisher on
//! `<name>/triggered`. The types come from discovery, so the returned reference works in connections exactly
//! like a local handle, whichever process or host the component runs in.

use std::{collections::BTreeSet, time::Duration};

use crate::{
    connect::{ResponseRef, Signal},
    error::{Error, Result},
    graph::ros_type_of_dds,
    names::ComponentName,
    radar::Radar,
};

/// An event as seen on the graph.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EventRef {
    name: ComponentName,
    payload_type: String,
}

impl EventRef {
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        &self.name
    }
    /// Its `triggered` signal.
    pub fn triggered(&self) -> Signal {
        Signal::new(self.name.topic("triggered"), self.payload_type.clone())
    }
}

/// Default time to wait for a component to appear.
pub const DEFAULT_LOOKUP_TIMEOUT: Duration = Duration::from_secs(5);

enum Found {
    Event(String),
    Response(String, String),
}

/// What the graph shows at `name` now: `Ok(None)` if nothing (yet).
fn inspect(endpoints: &[(bool, String, String)], name: &ComponentName) -> Result<Option<Found>> {
    let types = |writer: bool, endpoint: &str| -> BTreeSet<String> {
        let topic = name.topic(endpoint);
        endpoints
            .iter()
            .filter(|(w, t, _)| *w == writer && *t == topic)
            .map(|(_, _, ty)| ros_type_of_dds(ty))
            .collect()
    };
    let one = |set: BTreeSet<String>, endpoint: &str| -> Result<Option<String>> {
        match set.len() {
            0 => Ok(None),
            1 => Ok(set.into_iter().next()),
            _ => Err(Error::Ambiguous {
                topic: name.topic(endpoint),
                types: set.into_iter().collect(),
            }),
        }
    };
    if let Some(p) = one(types(true, "triggered"), "triggered")? {
        return Ok(Some(Found::Event(p)));
    }
    let start = one(types(false, "start"), "start")?;
    let exited = one(types(true, "exited"), "exited")?;
    match (start, exited) {
        (Some(s), Some(o)) => Ok(Some(Found::Response(s, o))),
        _ => Ok(None),
    }
}

/// The RADAR components the graph shows, closest to `wanted` first.
fn candidates(endpoints: &[(bool, String, String)], wanted: &str) -> Vec<String> {
    let mut names = BTreeSet::new();
    for (w, t, _) in endpoints {
        for (writer, suffix, kind) in [(true, "/triggered", "event"), (false, "/start", "response")]
        {
            if *w == writer {
                if let Some(n) = t.strip_suffix(suffix) {
                    names.insert(format!("{n} ({kind})"));
                }
            }
        }
    }
    let mut v: Vec<String> = names.into_iter().collect();
    v.sort_by_key(|c| distance(c.split(' ').next().unwrap_or(c), wanted));
    v
}

/// Levenshtein distance, for suggestions.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

impl Radar {
    async fn lookup(&self, name: &str, want_event: bool, timeout: Duration) -> Result<Found> {
        let name = self.resolve(name)?;
        let kind = if want_event { "event" } else { "response" };
        let deadline = tokio::time::Instant::now() + timeout;
        // look again after every discovery event (and every 100 ms, in case an event came before the data)
        let mut changes = self.graph().changes();
        loop {
            changes.mark_unchanged();
            let eps = self.graph().endpoints();
            match inspect(&eps, &name)? {
                Some(Found::Event(_)) if !want_event => {
                    return Err(Error::WrongKind {
                        name: name.fully_qualified(),
                        expected: "a response",
                        found: "event",
                    })
                }
                Some(Found::Response(..)) if want_event => {
                    return Err(Error::WrongKind {
                        name: name.fully_qualified(),
                        expected: "an event",
                        found: "response",
                    })
                }
                Some(f) => return Ok(f),
                None if tokio::time::Instant::now() >= deadline => {
                    return Err(Error::NotFound {
                        name: name.fully_qualified(),
                        kind,
                        after: timeout,
                        candidates: candidates(&eps, &name.fully_qualified()),
                    })
                }
                None => {
                    let next = tokio::time::timeout(Duration::from_millis(100), changes.changed());
                    if let Ok(Err(_)) = next.await {
                        // the participant is closing: no more events, fall back to polling
                        tokio::time::sleep(Duration::from_millis(20)).await;
                    }
                }
            }
        }
    }

    /// Finds the event `name` on the ROS graph, waiting up to 5 s for it to appear.
    pub async fn event(&self, name: &str) -> Result<EventRef> {
        self.event_within(name, DEFAULT_LOOKUP_TIMEOUT).await
    }

    /// Finds the event `name`, waiting up to `timeout`.
    pub async fn event_within(&self, name: &str, timeout: Duration) -> Result<EventRef> {
        match self.lookup(name, true, timeout).await? {
            Found::Event(payload_type) => Ok(EventRef {
                name: self.resolve(name)?,
                payload_type,
            }),
            Found::Response(..) => unreachable!("lookup checks the kind"),
        }
    }

    /// Finds the response `name` on the ROS graph, waiting up to 5 s for it to appear.
    pub async fn response(&self, name: &str) -> Result<ResponseRef> {
        self.response_within(name, DEFAULT_LOOKUP_TIMEOUT).await
    }

    /// Finds the response `name`, waiting up to `timeout`.
    pub async fn response_within(&self, name: &str, timeout: Duration) -> Result<ResponseRef> {
        match self.lookup(name, false, timeout).await? {
            Found::Response(start, output) => {
                Ok(ResponseRef::new(self.resolve(name)?, start, output))
            }
            Found::Event(_) => unreachable!("lookup checks the kind"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eps() -> Vec<(bool, String, String)> {
        let e = "std_msgs::msg::dds_::Empty_".to_owned();
        let s = "std_msgs::msg::dds_::String_".to_owned();
        vec![
            (true, "/start_event/triggered".into(), e.clone()),
            (false, "/count_up/start".into(), s.clone()),
            (true, "/count_up/exited".into(), e.clone()),
            (false, "/count_down/start".into(), e.clone()),
            (true, "/count_down/exited".into(), e.clone()),
            (true, "/twice/triggered".into(), e),
            (true, "/twice/triggered".into(), s),
        ]
    }

    fn n(s: &str) -> ComponentName {
        ComponentName::resolve(s, "/").unwrap()
    }

    #[test]
    fn components_are_recognised_by_their_topics_and_types() {
        match inspect(&eps(), &n("count_up")).unwrap() {
            Some(Found::Response(s, o)) => assert_eq!(
                (s.as_str(), o.as_str()),
                ("std_msgs/msg/String", "std_msgs/msg/Empty")
            ),
            _ => panic!("count_up is a response"),
        }
        assert!(
            matches!(inspect(&eps(), &n("start_event")).unwrap(), Some(Found::Event(t)) if t == "std_msgs/msg/Empty")
        );
        assert!(inspect(&eps(), &n("nothing")).unwrap().is_none());
        let e = inspect(&eps(), &n("twice")).err().unwrap().to_string();
        assert!(
            e.contains("/twice/triggered") && e.contains("std_msgs/msg/String"),
            "{e}"
        );
    }

    #[test]
    fn suggestions_come_closest_first() {
        let c = candidates(&eps(), "/count_upp");
        assert_eq!(c[0], "/count_up (response)");
        assert_eq!(c[1], "/count_down (response)");
        assert!(c.contains(&"/start_event (event)".to_owned()));
    }
}
