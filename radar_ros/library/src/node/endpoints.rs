//! The ROS 2 endpoints every component and the manager are made of: one way to create them, their live match
//! counts, the filter for samples from peers of another type, and the task behind a component handle.

use futures::{Stream, StreamExt};
use ros2_client::{dds::Node, MessageInfo, Name, QosProfile};

use radar_semantics::response::{Cause, Sent};

use crate::{
    error::{Error, Result},
    graph::Graph,
    node::transport::{Publisher, Subscription},
    wire::local::{TapWriter, Taps},
    wire::msg::TypeName,
};

/// A ROS endpoint with its live match count (peers of the same type only): from the participant's [`Graph`]
/// over DDS, from the liveliness tokens over Zenoh. Dropping it removes it from the graph.
pub(crate) struct Watched<T> {
    // before `inner`: fields drop in order, and the graph forgets the endpoint before the endpoint goes (as
    // before the matching had a type of its own), so its own departure is not taken for a peer's
    matching: Matching,
    inner: T,
}

/// What an endpoint is matched with, whichever transport it is on: the live count and where it comes from.
pub(crate) struct Matching {
    source: Source,
    /// Matched peers now and as they change.
    pub(crate) matched: tokio::sync::watch::Receiver<usize>,
}

enum Source {
    /// The endpoint's GUID in the participant's graph (RustDDS's match events).
    Dds {
        guid: ros2_client::dds::rustdds::GUID,
        graph: Graph,
    },
    /// Over Zenoh the count comes from the liveliness tokens (ros2-client's `watch_matched`, bridged by a task
    /// that ends with the endpoint); samples that do not decode are counted here.
    #[cfg(feature = "zenoh")]
    Zenoh {
        malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
        bridge: tokio::task::AbortHandle,
    },
}

impl Matching {
    /// Waits until at least `n` peers of the same type are matched, and over DDS those in this participant
    /// have matched this endpoint back (see `Graph::reciprocated`), so that nothing sent from now on is lost.
    /// (Over Zenoh a subscription's interest is declared before its token, on the same link: a sample sent
    /// once the token is counted arrives, `tests/zenoh_matched.rs`.)
    #[allow(irrefutable_let_patterns)] // without the zenoh feature, DDS is the only source
    pub(crate) async fn wait_matched(
        &self,
        n: usize,
        timeout: std::time::Duration,
        what: impl Fn() -> String,
    ) -> Result<()> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut rx = self.matched.clone();
        match tokio::time::timeout_at(deadline, rx.wait_for(|c| *c >= n)).await {
            Ok(Ok(_)) => {}
            Ok(Err(_)) => return Err(Error::Closed(what())),
            Err(_) => {
                return Err(Error::Timeout {
                    what: what(),
                    after: timeout,
                })
            }
        }
        if let Source::Dds { guid, graph } = &self.source {
            while !graph.reciprocated(*guid) {
                if tokio::time::Instant::now() >= deadline {
                    return Err(Error::Timeout {
                        what: format!("{} (matched on this side only)", what()),
                        after: timeout,
                    });
                }
                tokio::time::sleep(std::time::Duration::from_millis(1)).await;
            }
        }
        Ok(())
    }

    /// Why the last peer that went went, if one did (over Zenoh a token's deletion does not say: none).
    pub(crate) fn last_loss(&self) -> Option<crate::departure::LossCause> {
        match &self.source {
            Source::Dds { guid, graph } => graph.last_loss(*guid),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => None,
        }
    }

    /// The number of peers matched now.
    pub(crate) fn matched_now(&self) -> usize {
        *self.matched.borrow()
    }

    /// Whether a sample from this writer should be used (false for peers of another type). Over Zenoh a
    /// subscription hears its type only (the key carries the type and, when known, its hash: ros2-client
    /// patch 16): every sample is used.
    pub(crate) fn accepts(&self, info: &MessageInfo) -> bool {
        match &self.source {
            Source::Dds { guid, graph } => graph.accepts(*guid, info.publisher_gid()),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { .. } => true,
        }
    }

    /// The first sample `take` gives (one taken from the subscription's queue without waiting, each call)
    /// that comes from a peer of the subscription's type; `None` once the queue is empty or the transport fails.
    pub(crate) fn first_accepted<M>(
        &self,
        mut take: impl FnMut() -> ros2_client::ReadResult<Option<(M, MessageInfo)>>,
    ) -> Option<M> {
        loop {
            match take() {
                Ok(Some((m, info))) if self.accepts(&info) => return Some(m),
                Ok(Some(_)) => continue,
                Err(_) | Ok(None) => return None,
            }
        }
    }

    /// Where samples that do not decode are counted.
    fn malformed(&self) -> &crate::wire::malformed::Malformed {
        match &self.source {
            Source::Dds { graph, .. } => graph.malformed(),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { malformed, .. } => malformed,
        }
    }

    /// The samples of `stream` (a stream of this endpoint's subscription) that come from peers of the
    /// subscription's type, in arrival order. RustDDS matches endpoints whatever their types, so samples of a
    /// peer of another type are dropped here (the graph warned when it matched); samples that do not decode
    /// are dropped and counted (a warning names the expected type, once per topic). Nothing stops the stream
    /// but the subscription ending.
    pub(crate) fn accepted<'a, T: 'a>(
        &'a self,
        stream: impl Stream<Item = ros2_client::ReadResult<(T, MessageInfo)>> + 'a,
        topic: &'a str,
        expected: &'a str,
    ) -> impl Stream<Item = (T, MessageInfo)> + 'a {
        stream.filter_map(move |r| async move {
            match r {
                Ok((m, info)) if self.accepts(&info) => Some((m, info)),
                Ok(_) => None,
                Err(e) => {
                    // the transport does not say who sent it
                    self.malformed().note(topic, expected, None, &e);
                    None
                }
            }
        })
    }
}

impl<T> Watched<T> {
    /// Its matching: the live count, waiting on it, why the last peer left.
    pub(crate) fn matching(&self) -> &Matching {
        &self.matching
    }
}

impl<M: 'static + serde::de::DeserializeOwned> Watched<Subscription<M>> {
    /// A sample that has already arrived from a peer of the right type, without waiting.
    pub(crate) fn take_accepted(&self) -> Option<M> {
        self.matching.first_accepted(|| self.take())
    }
}

impl Watched<Subscription<crate::wire::raw::RawMessage>> {
    /// The samples of peers of the subscription's type, decoded as `M`, in arrival order: `Some` message, or
    /// `None` for one that did not decode. Those are dropped, counted per publisher and logged once per
    /// publisher (the participant's [`Malformed`](crate::wire::malformed::Malformed) registry).
    pub(crate) fn decoded<'a, M: crate::wire::msg::RosMessage>(
        &'a self,
        topic: &'a str,
        expected: &'a str,
    ) -> impl Stream<Item = Option<(M, MessageInfo)>> + 'a {
        self.matching
            .accepted(self.bodies(), topic, expected)
            .map(move |(raw, info)| match raw.decode::<M>() {
                Ok(m) => Some((m, info)),
                Err(e) => {
                    let who = format!("{:?}", info.publisher_gid());
                    self.matching
                        .malformed()
                        .note(topic, expected, Some(&who), &e);
                    None
                }
            })
    }
}

impl<T> std::ops::Deref for Watched<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.inner
    }
}

impl Drop for Matching {
    fn drop(&mut self) {
        match &self.source {
            Source::Dds { guid, graph } => graph.forget(*guid),
            #[cfg(feature = "zenoh")]
            Source::Zenoh { bridge, .. } => bridge.abort(),
        }
    }
}

/// `inner`, an endpoint over Zenoh, with its matched count from `counts` (its `watch_matched`: the count at once,
/// then each change), kept current by a task on the caller's tokio runtime that ends with the endpoint.
#[cfg(feature = "zenoh")]
pub(crate) fn over_zenoh<T>(
    inner: T,
    counts: async_channel::Receiver<usize>,
    malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
) -> Result<Watched<T>> {
    let runtime = tokio::runtime::Handle::try_current().map_err(|_| Error::Config {
        setting: "tokio runtime",
        value: "none".into(),
        reason: "make Zenoh endpoints inside a tokio runtime (#[tokio::main], or Runtime::enter): each keeps \
                 its matched count current from a task"
            .into(),
    })?;
    let (tx, matched) = tokio::sync::watch::channel(counts.try_recv().unwrap_or(0));
    let bridge = runtime
        .spawn(async move {
            while let Ok(n) = counts.recv().await {
                if tx.send(n).is_err() {
                    break;
                }
            }
        })
        .abort_handle();
    Ok(Watched {
        inner,
        matching: Matching {
            source: Source::Zenoh { malformed, bridge },
            matched,
        },
    })
}

pub(crate) fn topic_name(topic: &str) -> Result<Name> {
    Name::parse(topic).map_err(|e| Error::InvalidName {
        name: topic.to_owned(),
        reason: format!("{e}"),
    })
}

/// The DDS topic for the absolute ROS `topic`. Made on the DDS participant directly rather than through
/// `Node::create_topic`, which can name only `msg` types (not the `action` ones an action's parts have).
fn topic(
    graph: &Graph,
    topic: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<ros2_client::dds::rustdds::Topic> {
    let name = topic_name(topic)?;
    if !name.is_absolute() {
        return Err(Error::InvalidName {
            name: topic.to_owned(),
            reason: "an endpoint's topic must be absolute here".into(),
        });
    }
    let mut dds_qos: ros2_client::dds::rustdds::QosPolicies = qos.into();
    // USER_DATA, which the endpoints made on this topic take: the type's hash as ROS 2 Jazzy announces it
    // (REP 2011), and for a reader that only observes, that it does (`graph/observers.rs`)
    let mut user_data = ty
        .hash
        .map(|h| format!("typehash={h};"))
        .unwrap_or_default();
    if observer {
        user_data.push_str(crate::graph::OBSERVER_USER_DATA);
    }
    if !user_data.is_empty() {
        dds_qos = dds_qos.with_user_data(user_data);
    }
    let participant = graph
        .domain_participant()
        .ok_or_else(|| Error::Closed(format!("the DDS participant (creating topic {topic})")))?;
    participant
        .create_topic(
            crate::wire::dds_names::topic(topic),
            ty.dds.clone(),
            &dds_qos,
            ros2_client::dds::rustdds::TopicKind::NoKey,
        )
        .map_err(|e| Error::transport(format!("topic {topic} ({})", ty.dds), e))
}

/// Creates a publisher of `M` on the absolute `topic`, announced as type `ty` (the Rust type only has to
/// serialize: a raw message is published under any type name).
pub(crate) fn publisher<M: serde::Serialize>(
    graph: &Graph,
    node: &mut Node,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    let t = topic(graph, topic_abs, ty, qos, false)?;
    crate::node::declared::record_node(node, crate::node::declared::Access::Publish, topic_abs);
    let inner = node
        .create_publisher(&t, Some(qos.clone()))
        .map_err(|e| Error::transport(format!("a publisher on {topic_abs}"), e))?;
    let guid = inner.guid();
    let matched = graph.watch_writer(guid, topic_abs, &ty.dds);
    Ok(Watched {
        inner: Publisher::Dds(inner),
        matching: Matching {
            source: Source::Dds {
                guid,
                graph: graph.clone(),
            },
            matched,
        },
    })
}

/// Creates a subscription of `M` on the absolute `topic`, announced as type `ty`.
pub(crate) fn subscription<M: 'static>(
    graph: &Graph,
    node: &mut Node,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
) -> Result<Watched<Subscription<M>>> {
    subscription_as(graph, node, topic_abs, ty, qos, false)
}

/// [`subscription`], or with `observer` one that only observes: an event does not count it as a listener
/// (`graph/observers.rs`).
pub(crate) fn subscription_as<M: 'static>(
    graph: &Graph,
    node: &mut Node,
    topic_abs: &str,
    ty: &TypeName,
    qos: &QosProfile,
    observer: bool,
) -> Result<Watched<Subscription<M>>> {
    let t = topic(graph, topic_abs, ty, qos, observer)?;
    crate::node::declared::record_node(node, crate::node::declared::Access::Subscribe, topic_abs);
    let inner = node
        .create_subscription(&t, Some(qos.clone()))
        .map_err(|e| Error::transport(format!("a subscription on {topic_abs}"), e))?;
    let guid = inner.guid();
    let matched = graph.watch_reader(guid, topic_abs, &ty.dds);
    if observer {
        graph.mark_observer(guid);
    }
    Ok(Watched {
        inner: Subscription::Dds(inner),
        matching: Matching {
            source: Source::Dds {
                guid,
                graph: graph.clone(),
            },
            matched,
        },
    })
}

/// Creates a publisher of `M` on the absolute `topic`, announced as `M`'s ROS type.
pub(crate) fn typed_publisher<M: crate::wire::msg::RosMessage>(
    graph: &Graph,
    node: &mut Node,
    topic_abs: &str,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    publisher(graph, node, topic_abs, &TypeName::of::<M>(), qos)
}

/// Creates a subscription of `M` on the absolute `topic`, announced as `M`'s ROS type.
pub(crate) fn typed_subscription<M: crate::wire::msg::RosMessage>(
    graph: &Graph,
    node: &mut Node,
    topic_abs: &str,
    qos: &QosProfile,
) -> Result<Watched<Subscription<M>>> {
    subscription(graph, node, topic_abs, &TypeName::of::<M>(), qos)
}

/// A component's signal writer: each signal goes to this process's connections first (its tap), then on DDS,
/// stamped with the time of emission and carrying the run's cause (rules R11-R13, C6; see [`crate::wire::cause`]).
pub(crate) struct SignalWriter<M: serde::Serialize> {
    dds: Watched<Publisher<M>>,
    tap: TapWriter,
}

impl<M: serde::Serialize> SignalWriter<M> {
    /// `dds`, which writes `ros_type` on `topic`, with its tap in `taps`.
    pub(crate) fn new(
        taps: &Taps,
        dds: Watched<Publisher<M>>,
        topic: &str,
        ros_type: &str,
    ) -> Self {
        let tap = taps.open(topic, ros_type, dds.id());
        SignalWriter { dds, tap }
    }

    /// Emits `m` now, carrying `cause` (`topic` names it in a warning); the source timestamp it carries.
    pub(crate) fn emit(&self, topic: &str, m: M, cause: Option<Cause>) -> i64 {
        let sent = Sent {
            at: self.tap.emit(&m, cause),
            by: cause,
        };
        if let Err(e) = self.dds.publish_sent(m, sent) {
            tracing::warn!(topic, error = %e.forget_data(), "could not publish");
        }
        sent.at
    }
}

impl<M: serde::Serialize> std::ops::Deref for SignalWriter<M> {
    type Target = Watched<Publisher<M>>;
    fn deref(&self) -> &Self::Target {
        &self.dds
    }
}

/// Publishes, logging (not failing) on error: a message that cannot be sent must not stop the component.
pub(crate) fn emit<M: serde::Serialize>(p: &Publisher<M>, topic: &str, m: M) {
    if let Err(e) = p.publish(m) {
        tracing::warn!(topic, error = %e.forget_data(), "could not publish");
    }
}

/// Publishes `connections` as the `connections` list of the program or manager node `node`.
pub(crate) fn publish_connections(
    p: &Publisher<crate::wire::msg::ConnectionList>,
    node: &str,
    connections: Vec<crate::wire::msg::Connection>,
) {
    let list = crate::wire::msg::ConnectionList {
        stamp: crate::wire::msg::Time::now(),
        manager: node.to_owned(),
        connections,
    };
    emit(p, "connections", list);
}

/// Text of a caught panic.
pub(crate) fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_owned()
    }
}

/// Spaces out publications of something that changes often (a `state`, a connection list): the first change
/// after a quiet spell goes out at once, later ones at most every `every`, and the last change always.
pub(crate) struct Throttle {
    every: std::time::Duration,
    last: tokio::time::Instant,
    dirty: bool,
}

impl Throttle {
    /// A throttle that has just published.
    pub(crate) fn new(every: std::time::Duration) -> Throttle {
        Throttle {
            every,
            last: tokio::time::Instant::now(),
            dirty: false,
        }
    }

    /// Something changed: whether to publish now (if not, [`Throttle::due`] says when).
    pub(crate) fn changed(&mut self) -> bool {
        if self.last.elapsed() >= self.every {
            self.published();
            true
        } else {
            self.dirty = true;
            false
        }
    }

    /// Record a publication made for another reason.
    pub(crate) fn published(&mut self) {
        self.last = tokio::time::Instant::now();
        self.dirty = false;
    }

    /// Resolves when a held-back change is due (never if none is); call [`Throttle::published`] after
    /// publishing it.
    pub(crate) async fn due(&self) {
        if self.dirty {
            tokio::time::sleep_until(self.last + self.every).await
        } else {
            std::future::pending().await
        }
    }
}

/// A service request that did not decode: dropped, counted (the transport does not say who sent it) and
/// logged once per service.
pub(crate) fn malformed(
    graph: &crate::graph::Graph,
    manager: &str,
    service: &str,
    e: &dyn std::fmt::Display,
) {
    let topic = format!("{manager}/{service}");
    let expected = format!("radar_msgs/srv/{}_Request", capitalized(service));
    graph.malformed().note(&topic, &expected, None, e);
}

fn capitalized(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// How long a reply waits for the caller's reply reader to be matched.
pub(crate) const REPLY_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// Answers request `id` of service `service` once our reply writer has matched the caller's reply reader
/// (at most [`REPLY_WAIT`]), in a task of its own so other requests are not held up. A fresh client process
/// (`ros2 service call`, rclpy's `call_async` right after `wait_for_service`) can send its request before
/// our side has matched its reply reader, and a reply sent then goes nowhere.
pub(crate) fn reply<Req, Resp>(
    srv: &std::sync::Arc<ros2_client::dds::Server<Req, Resp>>,
    graph: &crate::graph::Graph,
    manager: &str,
    service: &'static str,
    id: ros2_client::RmwRequestId,
    resp: Resp,
) where
    Req: ros2_client::Message + Send + Sync + 'static,
    Resp: ros2_client::Message + Send + Sync + 'static,
{
    let (srv, graph) = (srv.clone(), graph.clone());
    let topic = crate::wire::dds_names::reply(&format!("{manager}/{service}"));
    tokio::spawn(async move {
        let caller: ros2_client::dds::rustdds::GUID = id.writer_gid.into();
        if !graph.wait_reader_of(&topic, caller, REPLY_WAIT).await {
            tracing::debug!(%topic, "answering before the caller's reply reader is matched");
        }
        if let Err(e) = srv.async_send_response(id, resp).await {
            tracing::warn!(error = ?e, %service, "could not answer a request");
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_throttle_lets_the_first_change_through_and_holds_back_the_next() {
        let every = std::time::Duration::from_millis(100);
        let mut t = Throttle::new(every);
        tokio::time::advance(every).await;
        assert!(
            t.changed(),
            "first change after a quiet spell goes out at once"
        );
        assert!(!t.changed(), "the next one within `every` is held back");
        let t0 = tokio::time::Instant::now();
        t.due().await;
        assert_eq!(
            t0.elapsed(),
            every,
            "and is due `every` after the last publication"
        );
        t.published();
        // nothing held back: never due
        let due = tokio::time::timeout(every * 10, t.due()).await;
        assert!(due.is_err());
    }
}
