//! Publishers and subscriptions that can wait until the other side is matched: typed ([`SignalPublisher`],
//! [`SignalSubscription`]) or raw ([`RawPublisher`], [`RawSubscription`]: serialized bodies of a type known
//! only by name). Plain code gets them from the [`Radar`](crate::Radar) (see `plain.rs`); the connection
//! manager's relays are raw ones from the participant's pool.
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
    error::{Error, Result},
    node::transport::{Publisher, Subscription},
    node::watched::Watched,
    wait::Wait,
    wire::msg::RosMessage,
    wire::raw::RawMessage,
};

/// A publisher on one topic that can wait for its subscribers: of `M` (see [`Radar::signal_publisher`](crate::Radar::signal_publisher)), or
/// of raw message bodies ([`RawPublisher`]). Over DDS, or over Zenoh (see `ZenohSignals`, with the `zenoh`
/// feature).
pub struct SignalPublisher<M: serde::Serialize> {
    topic: String,
    ros_type: String,
    publisher: Watched<Publisher<M>>,
}

/// A publisher of message bodies of a type known only by name (see [`Radar::raw_publisher`](crate::Radar::raw_publisher)).
pub type RawPublisher = SignalPublisher<RawMessage>;

impl<M: serde::Serialize + Send + Sync + 'static> SignalPublisher<M> {
    /// `publisher`, which writes `ros_type` on the absolute `topic` (over either transport).
    pub(crate) fn new(
        topic: String,
        ros_type: String,
        publisher: Watched<Publisher<M>>,
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

    /// Sends one message as `sent` says: with that source time, and carrying that cause (see
    /// [`crate::wire::cause`]; over Zenoh both in the attachment, docs/zenoh.md).
    pub(crate) fn publish_sent(&self, m: M, sent: radar_semantics::response::Sent) -> Result<()> {
        self.publisher
            .publish_sent(m, sent)
            .map_err(|e| Error::send(&self.topic, e.forget_data()))
    }

    /// Subscriptions (of the same type) matched now.
    pub fn subscribers(&self) -> usize {
        self.publisher.matching().matched_now()
    }

    /// Waits until at least `n` subscriptions of the same type are matched (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT); `.timeout(d)` to change it).
    pub fn wait_for_subscribers(&self, n: usize) -> Wait<'_, ()> {
        Wait::discovery(move |t| {
            self.publisher.matching().wait_matched(n, t, move || {
                format!("{n} subscriber(s) on {} ({})", self.topic, self.ros_type)
            })
        })
    }

    /// The live count of matched subscriptions.
    pub(crate) fn matched_watch(&self) -> tokio::sync::watch::Receiver<usize> {
        self.publisher.matching().matched.clone()
    }

    /// Whether the last subscriber this publisher had was of process `participant` when it went (lately).
    pub(crate) fn emptied_by(&self, participant: crate::node::transport::EndpointId) -> bool {
        self.publisher.matching().emptied_by(participant)
    }

    /// The last subscriber left: who, and why (as far as DDS told).
    pub(crate) fn departure(&self) -> crate::departure::Departure {
        let cause = self
            .publisher
            .matching()
            .last_loss()
            .unwrap_or(crate::departure::LossCause::Left);
        crate::departure::Departure::of_subscriber(&self.topic, cause)
    }

    /// Waits until no subscription is matched (default limit [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT)).
    pub fn wait_for_no_subscribers(&self) -> Wait<'_, ()> {
        Wait::discovery(move |t| async move {
            let mut rx = self.publisher.matching().matched.clone();
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

/// A subscription to one topic that can wait for its publishers: of `M` (see [`Radar::signal_subscription`](crate::Radar::signal_subscription)
/// and [`Radar::state_subscription`](crate::Radar::state_subscription)), or of raw message bodies ([`RawSubscription`]).
pub struct SignalSubscription<M: 'static> {
    topic: String,
    ros_type: String,
    subscription: Watched<Subscription<M>>,
}

/// A subscription delivering message bodies of a type known only by name (see [`Radar::raw_subscription`](crate::Radar::raw_subscription)).
pub type RawSubscription = SignalSubscription<RawMessage>;

impl<M: Send + Sync + 'static> SignalSubscription<M> {
    /// `subscription`, which reads `ros_type` on the absolute `topic` (over either transport).
    pub(crate) fn new(
        topic: String,
        ros_type: String,
        subscription: Watched<Subscription<M>>,
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
        self.subscription.matching().matched_now()
    }

    /// Waits until at least `n` publishers of the same type are matched (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT); `.timeout(d)` to change it).
    pub fn wait_for_publishers(&self, n: usize) -> Wait<'_, ()> {
        Wait::discovery(move |t| {
            self.subscription.matching().wait_matched(n, t, move || {
                format!("{n} publisher(s) on {} ({})", self.topic, self.ros_type)
            })
        })
    }

    /// The live count of matched publishers.
    pub(crate) fn matched_watch(&self) -> tokio::sync::watch::Receiver<usize> {
        self.subscription.matching().matched.clone()
    }

    /// Whether the last publisher this subscription had was of process `participant` when it went (lately).
    pub(crate) fn emptied_by(&self, participant: crate::node::transport::EndpointId) -> bool {
        self.subscription.matching().emptied_by(participant)
    }

    /// The last publisher left: who, and why (as far as DDS told).
    pub(crate) fn departure(&self) -> crate::departure::Departure {
        let cause = self
            .subscription
            .matching()
            .last_loss()
            .unwrap_or(crate::departure::LossCause::Left);
        crate::departure::Departure::of_publisher(&self.topic, cause)
    }

    /// The next sample of `stream` (this subscription's) from a publisher of the right type, with its source
    /// timestamp (ns since the epoch, 0 if unknown).
    async fn next_stamped<T>(
        &self,
        stream: impl Stream<Item = ros2_client::ReadResult<(T, MessageInfo)>>,
    ) -> Result<(T, i64)> {
        self.next_info(stream).await.map(|(m, info)| {
            (
                m,
                info.source_timestamp().map(|t| t.to_nanos()).unwrap_or(0),
            )
        })
    }

    async fn next_info<T>(
        &self,
        stream: impl Stream<Item = ros2_client::ReadResult<(T, MessageInfo)>>,
    ) -> Result<(T, MessageInfo)> {
        let mut accepted = Box::pin(self.subscription.matching().accepted(
            stream,
            &self.topic,
            &self.ros_type,
        ));
        accepted
            .next()
            .await
            .ok_or_else(|| Error::Closed(self.topic.clone()))
    }
}

impl<M: RosMessage> SignalSubscription<M> {
    /// The next message with its source timestamp (nanoseconds since the epoch, 0 if unknown); unbounded
    /// unless `.timeout(d)`. Malformed messages, and messages of publishers of another type, are skipped.
    pub fn recv_stamped(&self) -> Wait<'_, (M, i64)> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            self.next_stamped(self.messages()).await
        })
    }

    /// This subscription's samples, whichever transport it is on.
    fn messages(&self) -> impl Stream<Item = ros2_client::ReadResult<(M, MessageInfo)>> + '_ {
        self.subscription.async_stream()
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
            self.next_stamped(self.messages()).await.map(|(m, _)| m)
        })
    }

    /// Takes a message that has already arrived, without waiting.
    pub fn try_recv(&self) -> Option<M> {
        self.subscription.take_accepted()
    }

    /// The next message with the GID of its publisher.
    pub(crate) async fn recv_from(&self) -> Result<(M, ros2_client::Gid)> {
        let (m, info) = self.next_info(self.messages()).await?;
        Ok((m, info.publisher_gid()))
    }

    /// The next message with when and by which statement it was sent (see [`crate::wire::cause`]).
    pub(crate) async fn recv_sent(&self) -> Result<(M, radar_semantics::response::Sent)> {
        let (m, info) = self.next_info(self.messages()).await?;
        Ok((
            m,
            crate::wire::cause::sent(&info, crate::wire::local::now_ns()),
        ))
    }
}

impl SignalSubscription<RawMessage> {
    /// This subscription's message bodies, whichever transport it is on (over DDS read with a seed, over
    /// Zenoh with `RawMessage`'s `Deserialize`).
    fn bodies(
        &self,
    ) -> impl Stream<Item = ros2_client::ReadResult<(RawMessage, MessageInfo)>> + '_ {
        self.subscription.bodies()
    }

    /// The next message body with its source timestamp (ns since the epoch, 0 if unknown); unbounded unless
    /// `.timeout(d)`. Samples from publishers of another type, and unreadable ones, are skipped.
    pub fn recv_stamped(&self) -> Wait<'_, (RawMessage, i64)> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            self.next_stamped(self.bodies()).await
        })
    }

    /// The next message body as it came (a recorder's view: `radar record` keeps it for `radar verify`): its
    /// source time as written, the statement's cause it carries and its writer. Unbounded unless `.timeout(d)`.
    pub fn recv_sample(&self) -> Wait<'_, Sample> {
        Wait::signal(format!("a message on {}", self.topic), async move {
            let (body, info) = self.next_info(self.bodies()).await?;
            let cause = info
                .related_request_id()
                .and_then(|r| crate::wire::cause::from_identity(r.into()))
                .map(|c| (c.statement, c.delivery));
            let mut writer = [0u8; 16];
            writer.copy_from_slice(&info.publisher_gid().as_bytes()[..16]);
            Ok(Sample {
                body,
                stamp: info.source_timestamp().map_or(0, |t| t.to_nanos()),
                cause,
                writer,
            })
        })
    }

    /// The message bodies from publishers of the right type, with when and by which statement they were sent
    /// (see [`crate::wire::cause`]; the time of reading if the sample has no source time), their writers and
    /// their source times as written (ns, 0 if none). One stream for a reader's life (making a stream per
    /// message costs as much as the message).
    pub(crate) fn stream_from(
        &self,
    ) -> impl Stream<
        Item = (
            RawMessage,
            radar_semantics::response::Sent,
            ros2_client::Gid,
            i64,
        ),
    > + '_ {
        self.subscription
            .matching()
            .accepted(self.bodies(), &self.topic, &self.ros_type)
            .map(|(m, info)| {
                (
                    m,
                    crate::wire::cause::sent(&info, crate::wire::local::now_ns()),
                    info.publisher_gid(),
                    info.source_timestamp().map_or(0, |t| t.to_nanos()),
                )
            })
    }
}

/// A sample as it came on a topic ([`RawSubscription::recv_sample`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Sample {
    /// Its body.
    pub body: RawMessage,
    /// Its source time as its writer stamped it (ns since the epoch, 0 if none).
    pub stamp: i64,
    /// The cause it carries, if a RADAR statement sent it or a RADAR response's run emitted it: the
    /// statement's id and the delivery's number (0 on an `until`'s interrupt; rules R13, C6).
    pub cause: Option<(u128, u64)>,
    /// Its writer's id (GID): the first 12 bytes name the process's participant.
    pub writer: [u8; 16],
}
