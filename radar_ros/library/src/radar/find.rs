//! [`Radar::event`], [`Radar::response`], [`Radar::components`]: components found on the graph by name, from
//! `graph/lookup.rs`.

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
            use crate::endpoint::Endpoint as E;
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
