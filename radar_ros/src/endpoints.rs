//! QoS and topic helpers shared by the ROS 2 binding.

use ros2_client::{
    qos::{Durability, History},
    Name, Node, Publisher, QosProfile, Subscription,
};

use crate::{
    error::{Error, Result},
    graph::Graph,
    msg::RosMessage,
};

/// A ROS endpoint with its live match count from the participant's [`Graph`] (peers of the same type only).
/// Dropping it removes it from the graph.
pub(crate) struct Watched<T> {
    inner: T,
    guid: ros2_client::dds::rustdds::GUID,
    graph: Graph,
    /// Matched peers now and as they change.
    pub(crate) matched: tokio::sync::watch::Receiver<usize>,
}

impl<M> Watched<Publisher<M>>
where
    M: serde::Serialize,
{
    /// Registers a writer of type `ty` on `topic` with the graph.
    pub(crate) fn writer(
        graph: &Graph,
        inner: Publisher<M>,
        topic: &str,
        ty: &ros2_client::MessageTypeName,
    ) -> Self {
        let guid = inner.guid();
        let matched = graph.watch_writer(guid, topic, &ty.dds_msg_type());
        Watched {
            inner,
            guid,
            graph: graph.clone(),
            matched,
        }
    }
}

impl<M: 'static> Watched<Subscription<M>> {
    /// Registers a reader of type `ty` on `topic` with the graph.
    pub(crate) fn reader(
        graph: &Graph,
        inner: Subscription<M>,
        topic: &str,
        ty: &ros2_client::MessageTypeName,
    ) -> Self {
        let guid = inner.guid();
        let matched = graph.watch_reader(guid, topic, &ty.dds_msg_type());
        Watched {
            inner,
            guid,
            graph: graph.clone(),
            matched,
        }
    }
}

impl<T> Watched<T> {
    /// Waits until at least `n` peers of the same type are matched, and those in this participant have
    /// matched this endpoint back (see `Graph::reciprocated`), so that nothing sent from now on is lost.
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
        while !self.graph.reciprocated(self.guid) {
            if tokio::time::Instant::now() >= deadline {
                return Err(Error::Timeout {
                    what: format!("{} (matched on this side only)", what()),
                    after: timeout,
                });
            }
            tokio::time::sleep(std::time::Duration::from_millis(1)).await;
        }
        Ok(())
    }

    /// Whether a sample from this writer should be used (false for peers of another type).
    pub(crate) fn accepts(&self, info: &ros2_client::MessageInfo) -> bool {
        self.graph.accepts(self.guid, info.publisher_gid())
    }
}

impl<T> std::ops::Deref for Watched<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.inner
    }
}

impl<T> Drop for Watched<T> {
    fn drop(&mut self) {
        self.graph.forget(self.guid);
    }
}

/// How long a writer whose last sample was just written is kept before it is deleted.
///
/// A RustDDS write only queues the sample for the participant's event loop; deleting the writer right after
/// (a `once` that just fired, a guard dropped right after a delivery, a response's final `exited` at
/// shutdown) can lose the sample before it is sent, and a lost reliable sample is repaired only by the
/// writer's next heartbeat (100 ms to 1 s). Three seconds cover several repair rounds.
pub(crate) const WRITER_LINGER: std::time::Duration = std::time::Duration::from_secs(3);

/// QoS of every signal and slot topic: reliable, volatile, keep-last 10 (rclpy's and `ros2 topic pub`'s
/// default, so command-line tools match it).
pub fn signal_qos() -> QosProfile {
    signal_qos_depth(SIGNAL_DEPTH)
}

/// History depth of signal and slot endpoints: rclpy's default.
pub const SIGNAL_DEPTH: usize = 10;

/// [`signal_qos`] with another history depth (a connection's relay may ask for one).
pub fn signal_qos_depth(depth: usize) -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth })
}

/// QoS of `state` topics: reliable, transient-local, keep-last 1, so a late subscriber gets the current state.
pub fn state_qos() -> QosProfile {
    QosProfile::publisher_default()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

pub(crate) fn topic_name(topic: &str) -> Result<Name> {
    Name::parse(topic).map_err(|e| Error::InvalidName {
        name: topic.to_owned(),
        reason: format!("{e}"),
    })
}

/// Creates a publisher of `M` on the absolute topic `topic`.
pub(crate) fn publisher<M: RosMessage>(
    graph: &Graph,
    node: &mut Node,
    topic: &str,
    qos: &QosProfile,
) -> Result<Watched<Publisher<M>>> {
    let t = node
        .create_topic(&topic_name(topic)?, M::message_type_name(), qos)
        .map_err(|e| Error::dds(format!("topic {topic} ({})", M::ros_type_name()), e))?;
    let inner = node
        .create_publisher(&t, Some(qos.clone()))
        .map_err(|e| Error::dds(format!("a publisher on {topic}"), e))?;
    Ok(Watched::writer(
        graph,
        inner,
        topic,
        &M::message_type_name(),
    ))
}

/// Creates a subscription of `M` on the absolute topic `topic`.
pub(crate) fn subscription<M: RosMessage>(
    graph: &Graph,
    node: &mut Node,
    topic: &str,
    qos: &QosProfile,
) -> Result<Watched<Subscription<M>>> {
    let t = node
        .create_topic(&topic_name(topic)?, M::message_type_name(), qos)
        .map_err(|e| Error::dds(format!("topic {topic} ({})", M::ros_type_name()), e))?;
    let inner = node
        .create_subscription(&t, Some(qos.clone()))
        .map_err(|e| Error::dds(format!("a subscription on {topic}"), e))?;
    Ok(Watched::reader(
        graph,
        inner,
        topic,
        &M::message_type_name(),
    ))
}

/// Publishes, logging (not failing) on error: a signal that cannot be sent must not stop the component.
pub(crate) fn emit<M: RosMessage>(p: &Publisher<M>, topic: &str, m: M) {
    if let Err(e) = p.publish(m) {
        tracing::warn!(topic, error = ?e, "could not publish");
    }
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

/// The task behind a component handle: asks it to stop on drop, or stops it and waits.
pub(crate) struct ComponentTask {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<()>>,
}

impl ComponentTask {
    /// Spawns `f(stop)`, where `stop` resolves when the handle asks the component to stop (or is dropped).
    pub(crate) fn spawn<F, Fut>(f: F) -> ComponentTask
    where
        F: FnOnce(tokio::sync::oneshot::Receiver<()>) -> Fut,
        Fut: std::future::Future<Output = ()> + Send + 'static,
    {
        let (stop, rx) = tokio::sync::oneshot::channel();
        ComponentTask {
            stop: Some(stop),
            task: Some(tokio::spawn(f(rx))),
        }
    }

    fn request_stop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
    }

    /// Asks the component to stop and waits until its task has ended.
    pub(crate) async fn stop_and_wait(mut self) {
        self.request_stop();
        if let Some(task) = self.task.take() {
            let _ = task.await;
        }
    }
}

impl Drop for ComponentTask {
    fn drop(&mut self) {
        self.request_stop();
    }
}
