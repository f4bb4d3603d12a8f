//! Publishing into slots and listening to signals from plain code, with match counts from discovery.
//!
//! [`SignalPublisher`] and [`SignalSubscription`] are typed, signal-QoS endpoints on the [`Radar`]'s client
//! node. Unlike raw ros2-client endpoints they can wait until the other side is matched, so a message sent
//! right after [`SignalPublisher::wait_for_subscribers`] is not lost to discovery.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! use radar_ros::msg::Empty;
//! use std::time::Duration;
//! let start = radar.signal_publisher::<Empty>("/count_up/start")?;
//! start.wait_for_subscribers(1, Duration::from_secs(5)).await?;
//! start.publish(Empty::default())?;
//! # Ok(()) }
//! ```

use std::time::Duration;

use futures::StreamExt;

use crate::{
    endpoints::{publisher, signal_qos, subscription, Watched},
    error::{Error, Result},
    msg::RosMessage,
    radar::Radar,
};

/// A publisher of `M` on one topic, with signal QoS.
pub struct SignalPublisher<M: RosMessage> {
    topic: String,
    publisher: Watched<ros2_client::Publisher<M>>,
}

impl<M: RosMessage> SignalPublisher<M> {
    /// The absolute topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Sends one message.
    pub fn publish(&self, m: M) -> Result<()> {
        self.publisher
            .publish(m)
            .map_err(|e| Error::dds(format!("a message on {}", self.topic), e))
    }

    /// Subscriptions matched now.
    pub fn subscribers(&self) -> usize {
        *self.publisher.matched.borrow()
    }

    /// Waits until at least `n` subscriptions are matched.
    pub async fn wait_for_subscribers(&self, n: usize, timeout: Duration) -> Result<()> {
        self.publisher
            .wait_matched(n, timeout, || {
                format!(
                    "{n} subscriber(s) on {} ({})",
                    self.topic,
                    M::ros_type_name()
                )
            })
            .await
    }

    /// Waits until no subscription is matched.
    pub async fn wait_for_no_subscribers(&self, timeout: Duration) -> Result<()> {
        let mut rx = self.publisher.matched.clone();
        let r = tokio::time::timeout(timeout, rx.wait_for(|c| *c == 0)).await;
        r.map(|_| ()).map_err(|_| Error::Timeout {
            what: format!("subscribers of {} to leave", self.topic),
            after: timeout,
        })
    }
}

/// A subscription to `M` on one topic, with signal QoS.
pub struct SignalSubscription<M: RosMessage> {
    topic: String,
    subscription: Watched<ros2_client::Subscription<M>>,
}

impl<M: RosMessage> SignalSubscription<M> {
    /// The absolute topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Publishers matched now.
    pub fn publishers(&self) -> usize {
        *self.subscription.matched.borrow()
    }

    /// Waits until at least `n` publishers are matched.
    pub async fn wait_for_publishers(&self, n: usize, timeout: Duration) -> Result<()> {
        self.subscription
            .wait_matched(n, timeout, || {
                format!(
                    "{n} publisher(s) on {} ({})",
                    self.topic,
                    M::ros_type_name()
                )
            })
            .await
    }

    /// Receives the next message with its source timestamp (nanoseconds since the epoch, 0 if unknown).
    /// Malformed messages are logged and skipped.
    pub async fn recv_stamped(&self) -> Result<(M, i64)> {
        let mut stream = Box::pin(self.subscription.async_stream());
        loop {
            match stream.next().await {
                Some(Ok((_, info))) if !self.subscription.accepts(&info) => {}
                Some(Ok((m, info))) => {
                    let t = info.source_timestamp().map(|t| t.to_nanos()).unwrap_or(0);
                    return Ok((m, t));
                }
                Some(Err(e)) => tracing::warn!(
                    topic = %self.topic,
                    expected = %M::ros_type_name(),
                    error = %e,
                    "skipped a message that does not decode"
                ),
                None => return Err(Error::Closed(self.topic.clone())),
            }
        }
    }

    /// Receives the next message.
    pub async fn recv(&self) -> Result<M> {
        self.recv_stamped().await.map(|(m, _)| m)
    }

    /// Receives the next message, or fails after `timeout`.
    pub async fn recv_timeout(&self, timeout: Duration) -> Result<M> {
        tokio::time::timeout(timeout, self.recv())
            .await
            .map_err(|_| Error::Timeout {
                what: format!("a message on {}", self.topic),
                after: timeout,
            })?
    }

    /// Takes a message that has already arrived, without waiting.
    pub fn try_recv(&self) -> Option<M> {
        loop {
            match self.subscription.take() {
                Ok(Some((m, info))) if self.subscription.accepts(&info) => return Some(m),
                Ok(Some(_)) => continue,
                Err(_) => return None,
                Ok(None) => return None,
            }
        }
    }
}

impl Radar {
    /// A publisher on `topic` (relative names resolve in this Radar's namespace), with signal QoS.
    pub fn signal_publisher<M: RosMessage>(&self, topic: &str) -> Result<SignalPublisher<M>> {
        let topic = self.resolve(topic)?.fully_qualified();
        let p = self
            .with_client_node(|node| publisher::<M>(self.graph(), node, &topic, &signal_qos()))?;
        Ok(SignalPublisher {
            topic,
            publisher: p,
        })
    }

    /// A subscription to `topic` (relative names resolve in this Radar's namespace), with signal QoS.
    pub fn signal_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.subscription_with_qos(topic, signal_qos())
    }

    /// A subscription to a component's transient-local `state` topic (gets the current state on subscribing).
    pub fn state_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.subscription_with_qos(topic, crate::endpoints::state_qos())
    }

    fn subscription_with_qos<M: RosMessage>(
        &self,
        topic: &str,
        qos: ros2_client::QosProfile,
    ) -> Result<SignalSubscription<M>> {
        let topic = self.resolve(topic)?.fully_qualified();
        let s =
            self.with_client_node(|node| subscription::<M>(self.graph(), node, &topic, &qos))?;
        Ok(SignalSubscription {
            topic,
            subscription: s,
        })
    }
}
