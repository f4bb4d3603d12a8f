//! Publishing into slots and listening to signals from plain code: the [`Radar`] methods that make
//! publishers and subscriptions with signal QoS (or the `state` QoS), and `inject` (the paper's `rtinject`).
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

use crate::{
    error::{Error, Result},
    node::pool::{Dir, Key},
    node::topics::{RawPublisher, RawSubscription, SignalPublisher, SignalSubscription},
    radar::Radar,
    wait::Wait,
    wire::msg::RosMessage,
    wire::qos::{signal_qos, state_qos, SIGNAL_DEPTH},
    wire::raw::RawMessage,
    wire::refs::Slot,
};

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
    /// use radar_ros::{topics::RawMessage, msg::StringMsg};
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

    /// [`Radar::raw_subscription`] that only observes: it receives every sample, but an event whose
    /// `triggered` it reads does not count it as a listener, so it never makes the event check (its reader
    /// announces `radar_observe=1;` in its DDS USER_DATA). What `radar record` and `radar watch` use: they see each
    /// trigger of an event that something else keeps active, and change nothing.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let triggers = radar.observe_raw("/start_event/triggered", "std_msgs/msg/Empty")?;
    /// let (body, stamp_ns) = triggers.recv_stamped().await?;
    /// # Ok(()) }
    /// ```
    pub fn observe_raw(&self, topic: &str, ros_type: &str) -> Result<RawSubscription> {
        self.participant()
            .raw_observer(topic, ros_type, SIGNAL_DEPTH)
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
            if !crate::wire::raw::carries::<M>(slot.ros_type()) {
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
