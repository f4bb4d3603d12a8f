//! Finding RADAR components by name through ROS graph discovery, instead of a naming service.
//!
//! `radar.response("count_up")` resolves the name like any ROS name (relative names in the Radar's namespace,
//! absolute names as given) and waits (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change) until the graph
//! shows a response there: a subscription on `<name>/start` and a publisher on `<name>/exited`.
//! `radar.event("start_event")` waits for a publisher on `<name>/triggered`. The types come from discovery, so
//! the returned reference works in connections exactly like a local handle, whichever process or host the
//! component runs in.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! let bumper = radar.event("/robot/bumper").await?;
//! let dock = radar.response("/robot/dock").await?;
//! let _c = radar.whenever(&bumper).start(&dock).await?;
//! # Ok(()) }
//! ```

use std::collections::BTreeSet;

use crate::{
    error::{Error, Result},
    wire::dds_names::ros_type as ros_type_of_dds,
    wire::names::ComponentName,
    wire::refs::{EventRef, ResponseRef},
};

pub(crate) enum Found {
    Event(String),
    Response(String, String),
}

/// A RADAR component seen on the ROS graph (from [`Radar::components`](crate::Radar::components)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Component {
    /// An event: a publisher on `<name>/triggered`.
    Event(EventRef),
    /// A response: a subscription on `<name>/start` and a publisher on `<name>/exited`.
    Response(ResponseRef),
}

impl Component {
    /// Its name.
    pub fn name(&self) -> &ComponentName {
        match self {
            Component::Event(e) => e.name(),
            Component::Response(r) => r.name(),
        }
    }

    /// `"event"` or `"response"`.
    pub fn kind(&self) -> &'static str {
        match self {
            Component::Event(_) => "event",
            Component::Response(_) => "response",
        }
    }
}

/// The DDS types of the writers (`true`) or readers on a ROS topic.
pub(crate) type TypesOn<'a> = &'a dyn Fn(bool, &str) -> BTreeSet<String>;

/// What the graph shows at `name` now: `Ok(None)` if nothing (yet).
pub(crate) fn inspect(types_on: TypesOn<'_>, name: &ComponentName) -> Result<Option<Found>> {
    let types = |writer: bool, endpoint: &str| -> BTreeSet<String> {
        types_on(writer, &name.topic(endpoint))
            .iter()
            .map(|ty| ros_type_of_dds(ty))
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

/// [`TypesOn`] for a list of endpoints, indexed once (a listing asks it several topics per component: a scan of
/// the list each time made listing 2,000 components cost O(components x endpoints), most of `radar view`'s CPU).
pub(crate) fn in_list(
    endpoints: &[(bool, String, String)],
) -> impl Fn(bool, &str) -> BTreeSet<String> + '_ {
    let mut index: std::collections::HashMap<(bool, &str), BTreeSet<String>> =
        std::collections::HashMap::new();
    for (w, t, ty) in endpoints {
        index
            .entry((*w, t.as_str()))
            .or_default()
            .insert(ty.clone());
    }
    move |writer, topic| index.get(&(writer, topic)).cloned().unwrap_or_default()
}

/// The RADAR components the graph shows, closest to `wanted` first.
pub(crate) fn candidates(endpoints: &[(bool, String, String)], wanted: &str) -> Vec<String> {
    let mut names = BTreeSet::new();
    for (w, t, _) in endpoints {
        match (w, crate::graph::Endpoint::of_topic(t)) {
            (true, Some((n, crate::graph::Endpoint::Triggered))) => {
                names.insert(format!("{n} (event)"))
            }
            (false, Some((n, crate::graph::Endpoint::Start))) => {
                names.insert(format!("{n} (response)"))
            }
            _ => false,
        };
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

/// [`Radar::event`], [`Radar::response`], [`Radar::components`]: components found on the graph by name, from
/// `graph/lookup.rs`.
///
/// (This concept's face on `Radar`, in a module of its own for its imports.)
mod on_radar {
    use crate::graph::lookup::{candidates, in_list, inspect, Component, Found, TypesOn};
    use crate::{
        error::{Error, Result},
        radar::Radar,
        wait::Wait,
        wire::dds_names::ros_type as ros_type_of_dds,
        wire::names::ComponentName,
        wire::refs::{EventRef, ResponseRef},
    };
    use std::{collections::BTreeSet, time::Duration};

    impl Radar {
        /// Every RADAR component the ROS graph shows now (this process's own included), by name. A freshly
        /// created `Radar` sees little until discovery has run: [`Introspect::settle`](crate::radar::introspect::Introspect::settle)
        /// first.
        ///
        /// ```no_run
        /// # async fn f(radar: radar_ros::Radar) {
        /// use std::time::Duration;
        /// let _ = radar.introspect().settle(Duration::from_millis(300)).timeout(Duration::from_secs(3)).await;
        /// for c in radar.components() {
        ///     println!("{} {}", c.kind(), c.name());
        /// }
        /// # }
        /// ```
        pub fn components(&self) -> Vec<Component> {
            let eps = self.graph().endpoints();
            let types_on = in_list(&eps);
            let mut names = BTreeSet::new();
            for (w, t, _) in &eps {
                use crate::graph::Endpoint as E;
                let n = match (w, E::of_topic(t)) {
                    (true, Some((n, E::Triggered | E::Exited))) | (false, Some((n, E::Start))) => {
                        Some(n)
                    }
                    _ => None,
                };
                if let Some(n) = n {
                    names.insert(n.to_owned());
                }
            }
            names
                .into_iter()
                .filter_map(|n| {
                    let name = ComponentName::resolve(&n, "/").ok()?;
                    match inspect(&types_on, &name) {
                        Ok(Some(Found::Event(p))) => Some(Component::Event(EventRef::new(name, p))),
                        Ok(Some(Found::Response(s, o))) => {
                            Some(Component::Response(ResponseRef::new(name, s, o)))
                        }
                        Ok(None) => None,
                        Err(e) => {
                            tracing::warn!(component = %name, error = %crate::error::Report(&e), "not listed");
                            None
                        }
                    }
                })
                .collect()
        }

        /// Looks at the graph after every discovery event ([`Graph::wait_for`](crate::graph::Graph::wait_for)) until `found` says yes or no, for at most `timeout`; `found` gets the graph's topic index
        /// (writer or not, ROS topic -> DDS types) and answers `Ok(None)` for "not yet"; `gave_up` gets every
        /// endpoint seen.
        pub(crate) async fn wait_on_graph<T>(
            &self,
            timeout: Duration,
            mut found: impl FnMut(TypesOn<'_>) -> Result<Option<T>>,
            gave_up: impl FnOnce(&[(bool, String, String)]) -> Error,
        ) -> Result<T> {
            let deadline = tokio::time::Instant::now() + timeout;
            let graph = self.graph().clone();
            let types_on = move |writer: bool, topic: &str| graph.types_on(writer, topic);
            match self
                .graph()
                .wait_for(deadline, || found(&types_on).transpose())
                .await
            {
                Some(r) => r,
                None => Err(gave_up(&self.graph().endpoints())),
            }
        }

        async fn lookup(&self, name: &str, want_event: bool, timeout: Duration) -> Result<Found> {
            let name = self.resolve(name)?;
            let kind = if want_event { "event" } else { "response" };
            self.wait_on_graph(
                timeout,
                |types_on| match inspect(types_on, &name)? {
                    Some(Found::Event(_)) if !want_event => Err(Error::WrongKind {
                        name: name.fully_qualified(),
                        expected: "a response",
                        found: "event",
                    }),
                    Some(Found::Response(..)) if want_event => Err(Error::WrongKind {
                        name: name.fully_qualified(),
                        expected: "an event",
                        found: "response",
                    }),
                    f => Ok(f),
                },
                |eps| Error::NotFound {
                    name: name.fully_qualified(),
                    kind,
                    after: timeout,
                    candidates: candidates(eps, &name.fully_qualified()),
                },
            )
            .await
        }

        /// The type published on `topic` (`writer`) or subscribed to, as soon as the graph shows one.
        pub(crate) async fn topic_type(
            &self,
            topic: &str,
            writer: bool,
            timeout: Duration,
        ) -> Result<String> {
            let what = if writer { "publisher" } else { "subscriber" };
            self.wait_on_graph(
                timeout,
                |types_on| {
                    Ok(types_on(writer, topic)
                        .iter()
                        .next()
                        .map(|ty| ros_type_of_dds(ty)))
                },
                |_| Error::Timeout {
                    what: format!(
                        "a {what} on {topic}: is the component running, in this domain and namespace?"
                    ),
                    after: timeout,
                },
            )
            .await
        }

        /// Finds the event `name` on the ROS graph, waiting for it to appear (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT),
        /// `.timeout(d)` to change).
        ///
        /// ```no_run
        /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
        /// let bumper = radar.event("/robot/bumper").await?;
        /// println!("{} carries {}", bumper.name(), bumper.triggered().ros_type());
        /// # Ok(()) }
        /// ```
        pub fn event(&self, name: &str) -> Wait<'static, EventRef> {
            let (radar, name) = (self.clone(), name.to_owned());
            Wait::discovery(move |t| async move {
                match radar.lookup(&name, true, t).await? {
                    Found::Event(payload_type) => {
                        Ok(EventRef::new(radar.resolve(&name)?, payload_type))
                    }
                    Found::Response(..) => unreachable!("lookup checks the kind"),
                }
            })
        }

        /// Finds the response `name` on the ROS graph, waiting for it to appear (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT),
        /// `.timeout(d)` to change).
        ///
        /// ```no_run
        /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
        /// use std::time::Duration;
        /// let dock = radar.response("/robot/dock").timeout(Duration::from_secs(20)).await?;
        /// # Ok(()) }
        /// ```
        pub fn response(&self, name: &str) -> Wait<'static, ResponseRef> {
            let (radar, name) = (self.clone(), name.to_owned());
            Wait::discovery(move |t| async move {
                match radar.lookup(&name, false, t).await? {
                    Found::Response(start, output) => {
                        Ok(ResponseRef::new(radar.resolve(&name)?, start, output))
                    }
                    Found::Event(_) => unreachable!("lookup checks the kind"),
                }
            })
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
        match inspect(&in_list(&eps()), &n("count_up")).unwrap() {
            Some(Found::Response(s, o)) => assert_eq!(
                (s.as_str(), o.as_str()),
                ("std_msgs/msg/String", "std_msgs/msg/Empty")
            ),
            _ => panic!("count_up is a response"),
        }
        assert!(
            matches!(inspect(&in_list(&eps()), &n("start_event")).unwrap(), Some(Found::Event(t)) if t == "std_msgs/msg/Empty")
        );
        assert!(inspect(&in_list(&eps()), &n("nothing")).unwrap().is_none());
        let e = inspect(&in_list(&eps()), &n("twice"))
            .err()
            .unwrap()
            .to_string();
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
