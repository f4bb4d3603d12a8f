//! Looking at the ROS graph the way a command-line tool does (`radar ls`, `radar cat`, `radar con`): which
//! managers and connection lists are there, what a topic's subscribers take, when discovery has settled.
//! Programs that use RADAR rarely need this; [`Radar::introspect`] gives it.

use std::{collections::BTreeSet, time::Duration};

pub use crate::graph::GraphNode;
use crate::{radar::Radar, wait::Wait, wire::msg::RosMessage};

/// The DDS type name of a `Connect` request, as a manager's `connect` server announces it.
const CONNECT_REQUEST: &str = "radar_msgs::srv::dds_::Connect_Request_";

/// A view of the ROS graph from a [`Radar`], for tools.
///
/// ```no_run
/// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
/// use std::time::Duration;
/// let graph = radar.introspect();
/// graph.settle(Duration::from_millis(300)).timeout(Duration::from_secs(3)).await?;
/// println!("managers: {:?}", graph.managers());
/// # Ok(()) }
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Introspect<'a> {
    radar: &'a Radar,
}

impl Radar {
    /// The graph as a tool looks at it: see [`Introspect`].
    pub fn introspect(&self) -> Introspect<'_> {
        Introspect { radar: self }
    }
}

impl Introspect<'_> {
    /// The manager nodes on the graph that take connect requests (`serve_manager`, `radar_manager`),
    /// by name; this process's own included.
    pub fn managers(&self) -> Vec<String> {
        let mut names: BTreeSet<String> = self
            .radar
            .graph()
            .discovered_reader_topics(CONNECT_REQUEST)
            .into_iter()
            .filter_map(|t| {
                crate::wire::dds_names::service_of_request(&t)
                    .and_then(|s| s.strip_suffix("/connect"))
                    .map(str::to_owned)
            })
            .collect();
        names.extend(self.radar.participant().served_managers().names());
        names.into_iter().collect()
    }

    /// Whether the graph shows the node `node` (fully qualified) serving parameters (`<node>/list_parameters`),
    /// so that [`Radar::parameters_of`] has something to read.
    pub fn serves_parameters(&self, node: &str) -> bool {
        let topic = crate::wire::dds_names::request(&format!("{node}/list_parameters"));
        !self
            .radar
            .graph()
            .discovered_reader_types(&topic)
            .is_empty()
    }

    /// The topics on which programs and managers show their connections (`<node>/connections`, type
    /// `radar_msgs/msg/ConnectionList`), this program's own included.
    pub fn connection_topics(&self) -> Vec<String> {
        let ty = crate::wire::msg::ConnectionList::dds_type_name();
        let topics: BTreeSet<String> = self
            .radar
            .graph()
            .endpoints()
            .into_iter()
            .filter(|(w, t, d)| *w && *d == ty && t.ends_with("/connections"))
            .map(|(_, t, _)| t)
            .collect();
        topics.into_iter().collect()
    }

    /// A count that grows whenever discovery reports something (a participant, reader or writer found, lost or
    /// matched): a tool that lists the graph over and over compares it with the count it last listed at, and
    /// lists again only when it changed (listing 2,000 components copies all of discovery's data).
    pub fn generation(&self) -> u64 {
        *self.radar.graph().changes().borrow()
    }

    /// Waits until discovery has been quiet for `quiet` (no participant or endpoint found or lost): what a
    /// command-line tool does before it reports what is on the graph. Unbounded unless `.timeout(d)`; a
    /// timeout running out is not an error here (the graph is as settled as it got). Cancel safe: it only
    /// looks.
    pub fn settle(&self, quiet: Duration) -> Wait<'_, ()> {
        let graph = self.radar.graph();
        Wait::new(None, move |max| async move {
            let deadline = max.map(|m| tokio::time::Instant::now() + m);
            let mut changes = graph.changes();
            loop {
                changes.mark_unchanged();
                let now = tokio::time::Instant::now();
                let until = deadline.map_or(now + quiet, |d| d.min(now + quiet));
                match tokio::time::timeout_at(until, changes.changed()).await {
                    Ok(Ok(())) if deadline.is_none_or(|d| tokio::time::Instant::now() < d) => {
                        continue
                    }
                    _ => return Ok(()),
                }
            }
        })
    }

    /// The message type a subscriber on `topic` takes, waiting for one to appear (default
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change): what to publish there.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let ty = radar.introspect().subscriber_type("/count_up/start").await?;
    /// assert_eq!(ty, "std_msgs/msg/Empty");
    /// # Ok(()) }
    /// ```
    pub fn subscriber_type(&self, topic: &str) -> Wait<'static, String> {
        let (radar, topic) = (
            self.radar.clone(),
            self.radar.resolve(topic).map(|n| n.fully_qualified()),
        );
        Wait::discovery(move |timeout| async move {
            let topic = topic?;
            radar.topic_type(&topic, false, timeout).await
        })
    }
}

impl Introspect<'_> {
    /// The ROS nodes of the other programs on the graph (every DDS participant but this program's), each with
    /// its enclave and the topics and services it uses, from `ros_discovery_info` (which every ROS 2 program
    /// publishes: its nodes and their endpoints) and DDS discovery. Waits for discovery to be quiet for
    /// 300 ms, at most the timeout (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)`); a
    /// timeout running out is not an error (the graph is as settled as it got). What `radar security
    /// generate_policy` writes a policy from.
    pub fn nodes(&self) -> Wait<'static, Vec<GraphNode>> {
        let radar = self.radar.clone();
        Wait::new(Some(crate::DEFAULT_TIMEOUT), move |max| async move {
            let max = max.unwrap_or(crate::DEFAULT_TIMEOUT);
            let started = tokio::time::Instant::now();
            let info = crate::graph::nodes::DiscoveryInfo::read(radar.graph())?;
            radar
                .introspect()
                .settle(Duration::from_millis(300))
                .timeout(max.saturating_sub(started.elapsed()))
                .await?;
            let mut out = info.take(radar.graph());
            out.sort_by_key(|n| (n.enclave.clone(), n.fully_qualified()));
            Ok(out)
        })
    }
}
