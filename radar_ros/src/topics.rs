//! Publishing into slots and listening to signals from plain code: publishers and subscriptions with signal
//! QoS (or the `state` QoS) that can wait until the other side is matched, typed ([`SignalPublisher`],
//! [`SignalSubscription`]) or raw ([`RawPublisher`], [`RawSubscription`]: serialized bodies of a type known
//! only by name), and `inject` (the paper's `rtinject`).
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! use radar_ros::msg::Empty;
//! let start = radar.signal_publisher::<Empty>("/count_up/start")?;
//! start.wait_for_subscribers(1).await?;      // not lost to discovery
//! start.publish(Empty::default())?;
//! let exited = radar.signal_subscription::<Empty>("/count_up/exited")?;
//! exited.recv().await?;
//! # Ok(()) }
//! ```

use futures::{Stream, StreamExt};
use ros2_client::MessageInfo;

use crate::{
    endpoints::Watched,
    error::{Error, Result},
    msg::RosMessage,
    pool::{Dir, Key},
    qos::{signal_qos, state_qos, SIGNAL_DEPTH},
    radar::Radar,
    raw::{RawMessage, RawSeed},
    refs::Slot,
    wait::Wait,
};

/// A publisher on one topic that can wait for its subscribers: of `M` (see [`Radar::signal_publisher`]), or
/// of raw message bodies ([`RawPublisher`]).
pub struct SignalPublisher<M: serde::Serialize> {
    topic: String,
    ros_type: String,
    publisher: Watched<ros2_client::Publisher<M>>,
}

/// A publisher of message bodies of a type known only by name (see [`Radar::raw_publisher`]).
pub type RawPublisher = SignalPublisher<RawMessage>;

impl<M: serde::Serialize + Send + Sync + 'static> SignalPublisher<M> {
    pub(crate) fn new(
        topic: String,
        ros_type: String,
        publisher: Watched<ros2_client::Publisher<M>>,
    ) -> SignalPublisher<M> {
        SignalPublisher {
            topic,
            ros_type,
            publisher,
        }
    }

    /// The absolute topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The message type, `pkg/msg/Name`.
    pub fn ros_type(&self) -> &str {
        &self.ros_type
    }

    /// Sends one message.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// let p = radar.signal_publisher::<Empty>("/dock/start")?;
    /// p.wait_for_subscribers(1).await?;
    /// p.publish(Empty::default())?;
    /// println!("{} ({}) has {} subscriber(s)", p.topic(), p.ros_type(), p.subscribers());
    /// p.wait_for_no_subscribers().timeout(std::time::Duration::from_secs(60)).await?;
    /// # Ok(()) }
    /// ```
    pub fn publish(&self, m: M) -> Result<()> {
        self.publisher
            .publish(m)
            .map_err(|e| Error::send(&self.topic, e.forget_data()))
    }

    /// Subscriptions (of the same type) matched now.
    pub fn subscribers(&self) -> usize {
        self.publisher.matched_now()
    }

    /// Waits until at least `n` subscriptions of the same type are matched (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT); `.timeout(d)` to change it).
    pub fn wait_for_subscribers(&self, n: usize) -> Wait<'_, ()> {
        Wait::discovery(move |t| {
            self.publisher.wait_matched(n, t, move || {
                format!("{n} subscriber(s) on {} ({})", self.topic, self.ros_type)
            })
        })
    }

    /// Waits until no subscription is matched (default limit [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT)).
    pub fn wait_for_no_subscribers(&self) -> Wait<'_, ()> {
        Wait::discovery(move |t| async move {
            let mut rx = self.publisher.matched.clone();
            tokio::time::timeout(t, rx.wait_for(|c| *c == 0))
                .await
                .map(|_| ())
                .map_err(|_| Error::Timeout {
                    what: format!("subscribers of {} to leave", self.topic),
                    after: t,
                })
        })
    }
}

/// A subscription to one topic that can wait for its publishers: of `M` (see [`Radar::signal_subscription`]
/// and [`Radar::state_subscription`]), or of raw message bodies ([`RawSubscription`]).
pub struct SignalSubscription<M: 'static> {
    topic: String,
    ros_type: String,
    subscription: Watched<ros2_client::Subscription<M>>,
}

/// A subscription delivering message bodies of a type known only by name (see [`Radar::raw_subscription`]).
pub type RawSubscription = SignalSubscription<RawMessage>;

impl<M: Send + Sync + 'static> SignalSubscription<M> {
    pub(crate) fn new(
        topic: String,
        ros_type: String,
        subscription: Watched<ros2_client::Subscription<M>>,
    ) -> SignalSubscription<M> {
        SignalSubscription {
            topic,
            ros_type,
            subscription,
        }
    }

    /// The absolute topic.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// The message type, `pkg/msg/Name`.
    pub fn ros_type(&self) -> &str {
        &self.ros_type
    }

    /// Publishers (of the same type) matched now.
    pub fn publishers(&self) -> usize {
        self.subscription.matched_now()
    }

    /// Waits until at least `n` publishers of the same type are matched (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT); `.timeout(d)` to change it).
    pub fn wait_for_publishers(&self, n: usize) -> Wait<'_, ()> {
        Wait::discovery(move |t| {
            self.subscription.wait_matched(n, t, move || {
                format!("{n} publisher(s) on {} ({})", self.topic, self.ros_type)
            })
        })
    }

    /// The next sample of `stream` (this subscription's) from a publisher of the right type, with its source
    /// timestamp (ns since the epoch, 0 if unknown).
    async fn next_stamped<T>(
        &self,
        stream: impl Stream<Item = ros2_client::ReadResult<(T, MessageInfo)>>,
    ) -> Result<(T, i64)> {
        let mut accepted = Box::pin(self.subscription.accepted(
            stream,
            &self.topic,
            &self.ros_type,
        ));
        match accepted.next().await {
            Some((m, info)) => Ok((
                m,
                info.source_timestamp().map(|t| t.to_nanos()).unwrap_or(0),
            )),
            None => Err(Error::Closed(self.topic.clone())),
        }
    }
}

impl<M: RosMessage> SignalSubscription<M> {
    /// The next message with its source timestamp (nanoseconds since the epoch, 0 if unknown); unbounded
    /// unless `.timeout(d)`. Malformed messages, and messages of publishers of another type, are skipped.
    pub fn recv_stamped(&self) -> Wait<'_, (M, i64)> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            self.next_stamped(self.subscription.async_stream()).await
        })
    }

    /// The next message; unbounded unless `.timeout(d)`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::msg::Empty;
    /// let s = radar.signal_subscription::<Empty>("/dock/exited")?;
    /// s.wait_for_publishers(1).await?;
    /// println!("{} ({}) has {} publisher(s)", s.topic(), s.ros_type(), s.publishers());
    /// let (_, stamp) = s.recv_stamped().await?;           // with its source time
    /// let next = s.recv().timeout(std::time::Duration::from_secs(10)).await?;
    /// let already_there = s.try_recv();                  // without waiting
    /// # Ok(()) }
    /// ```
    pub fn recv(&self) -> Wait<'_, M> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            self.next_stamped(self.subscription.async_stream())
                .await
                .map(|(m, _)| m)
        })
    }

    /// Takes a message that has already arrived, without waiting.
    pub fn try_recv(&self) -> Option<M> {
        self.subscription.take_accepted()
    }
}

impl SignalSubscription<RawMessage> {
    /// The next message body with its source timestamp (ns since the epoch, 0 if unknown); unbounded unless
    /// `.timeout(d)`. Samples from publishers of another type, and unreadable ones, are skipped.
    pub fn recv_stamped(&self) -> Wait<'_, (RawMessage, i64)> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            self.next_stamped(self.subscription.async_stream_seed(RawSeed))
                .await
        })
    }
}

impl Radar {
    /// A publisher on `topic` (relative names resolve in this Radar's namespace), with signal QoS.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let p = radar.signal_publisher::<radar_ros::msg::Empty>("/dock/interrupt")?;
    /// # Ok(()) }
    /// ```
    pub fn signal_publisher<M: RosMessage>(&self, topic: &str) -> Result<SignalPublisher<M>> {
        self.participant().publisher::<M>(topic, &signal_qos())
    }

    /// A subscription to `topic` (relative names resolve in this Radar's namespace), with signal QoS.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let s = radar.signal_subscription::<radar_ros::msg::Empty>("/dock/exited")?;
    /// # Ok(()) }
    /// ```
    pub fn signal_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.participant().subscription::<M>(topic, &signal_qos())
    }

    /// A subscription to a component's transient-local `state` topic: gets the current state on subscribing.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::msg::ResponseState;
    /// let s = radar.state_subscription::<ResponseState>("/dock/state")?;
    /// println!("dock is {}", s.recv().await?.state_label);
    /// # Ok(()) }
    /// ```
    pub fn state_subscription<M: RosMessage>(&self, topic: &str) -> Result<SignalSubscription<M>> {
        self.participant().subscription::<M>(topic, &state_qos())
    }

    /// A publisher of `ros_type` (e.g. `std_msgs/msg/String`) on `topic` that sends message bodies unchanged
    /// (signal QoS).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{RawMessage, msg::StringMsg};
    /// let p = radar.raw_publisher("/say/start", "std_msgs/msg/String")?;
    /// p.wait_for_subscribers(1).await?;
    /// p.publish(RawMessage::encode(&StringMsg::from("hi"))?)?;
    /// # Ok(()) }
    /// ```
    pub fn raw_publisher(&self, topic: &str, ros_type: &str) -> Result<RawPublisher> {
        self.participant()
            .raw_publisher(topic, ros_type, SIGNAL_DEPTH)
    }

    /// A subscription to `ros_type` on `topic` that yields message bodies unchanged (signal QoS).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let s = radar.raw_subscription("/say/exited", "std_msgs/msg/String")?;
    /// let (body, stamp) = s.recv_stamped().await?;
    /// # Ok(()) }
    /// ```
    pub fn raw_subscription(&self, topic: &str, ros_type: &str) -> Result<RawSubscription> {
        self.participant()
            .raw_subscription(topic, ros_type, SIGNAL_DEPTH)
    }

    /// Sends `payload` into a slot directly (the paper's `rtinject`): waits for the slot's subscriber (default
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change), then publishes once. The writer
    /// comes from the participant's pool: injecting into the same slot again within a few seconds reuses it.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar, dock: radar_ros::ResponseRef) -> radar_ros::Result<()> {
    /// radar.inject(dock.start_slot(), radar_ros::msg::Empty::default()).await?;
    /// # Ok(()) }
    /// ```
    pub fn inject<M: RosMessage>(&self, slot: Slot, payload: M) -> Wait<'static, ()> {
        let participant = self.participant().clone();
        Wait::discovery(move |t| async move {
            if slot.ros_type() != M::ros_type_name() {
                return Err(Error::PayloadType {
                    what: "an injected payload",
                    topic: slot.topic().to_owned(),
                    expected: slot.ros_type().to_owned(),
                    given: M::ros_type_name(),
                });
            }
            let key = Key {
                topic: participant.resolve_topic(slot.topic())?,
                ros_type: slot.ros_type().to_owned(),
                depth: SIGNAL_DEPTH,
                dir: Dir::Writer,
            };
            let writer = participant.pooled_writer(&key)?;
            let sent = async {
                writer.wait_for_subscribers(1).timeout(t).await?;
                writer.publish(RawMessage::encode(&payload)?)
            }
            .await;
            // lingers: what was just written is not lost, and the next injection reuses the writer
            participant.release(&key);
            sent
        })
    }
}
