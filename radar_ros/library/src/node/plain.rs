//! The participant's plain endpoints: publishers and subscriptions on the program node (`Radar::signal_publisher`
//! and friends), and the pooled raw endpoints the connection manager's relays share.

use std::sync::Arc;

use ros2_client::QosProfile;

use crate::{
    error::Result,
    node::endpoints,
    node::participant::Participant,
    node::pool::{Dir, Key},
    node::topics::{RawPublisher, RawSubscription, SignalPublisher, SignalSubscription},
    node::transport::RosNode as Node,
    wire::{msg::RosMessage, qos::signal_qos_depth, raw::parse_type_name},
};

impl Participant {
    /// Makes an endpoint on the client node: `make(node, absolute topic)`.
    fn on_client_node<T>(
        &self,
        topic: &str,
        make: impl FnOnce(&mut Node, &str) -> Result<T>,
    ) -> Result<(String, T)> {
        let topic = self.resolve_topic(topic)?;
        let e = self.with_client_node(|node| make(node, &topic))?;
        Ok((topic, e))
    }

    /// A typed publisher on the client node (absolute or relative `topic`).
    pub(crate) fn publisher<M: RosMessage>(
        &self,
        topic: &str,
        qos: &QosProfile,
    ) -> Result<SignalPublisher<M>> {
        let (topic, p) = self.on_client_node(topic, |node, t| {
            endpoints::typed_publisher(self.graph(), node, t, qos)
        })?;
        Ok(SignalPublisher::new(topic, M::ros_type_name(), p))
    }

    /// A typed subscription on the client node (absolute or relative `topic`).
    pub(crate) fn subscription<M: RosMessage>(
        &self,
        topic: &str,
        qos: &QosProfile,
    ) -> Result<SignalSubscription<M>> {
        let (topic, s) = self.on_client_node(topic, |node, t| {
            endpoints::typed_subscription(self.graph(), node, t, qos)
        })?;
        Ok(SignalSubscription::new(topic, M::ros_type_name(), s))
    }

    /// A raw publisher of `ros_type` on `topic` (reliable, volatile, keep-last `depth`).
    pub(crate) fn raw_publisher(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
    ) -> Result<RawPublisher> {
        let ty = parse_type_name(ros_type)?;
        let (topic, p) = self.on_client_node(topic, |node, t| {
            endpoints::publisher(self.graph(), node, t, &ty, &signal_qos_depth(depth))
        })?;
        Ok(RawPublisher::new(topic, ros_type.to_owned(), p))
    }

    /// A raw subscription to `ros_type` on `topic` (reliable, volatile, keep-last `depth`).
    pub(crate) fn raw_subscription(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
    ) -> Result<RawSubscription> {
        self.raw_reader(topic, ros_type, depth, false)
    }

    /// [`Participant::raw_subscription`] that only observes: events do not count it as a listener.
    pub(crate) fn raw_observer(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
    ) -> Result<RawSubscription> {
        self.raw_reader(topic, ros_type, depth, true)
    }

    fn raw_reader(
        &self,
        topic: &str,
        ros_type: &str,
        depth: usize,
        observer: bool,
    ) -> Result<RawSubscription> {
        let ty = parse_type_name(ros_type)?;
        let qos = signal_qos_depth(depth);
        let (topic, s) = self.on_client_node(topic, |node, t| {
            endpoints::subscription_as(self.graph(), node, t, &ty, &qos, observer)
        })?;
        Ok(RawSubscription::new(topic, ros_type.to_owned(), s))
    }

    /// The pooled raw writer of `ros_type` on the absolute `topic` with history `depth`, held until
    /// [`Participant::release`] (see [`crate::node::pool`]).
    pub(crate) fn pooled_writer(&self, key: &Key) -> Result<Arc<RawPublisher>> {
        debug_assert_eq!(key.dir, Dir::Writer);
        self.pool().writer(key, || {
            self.raw_publisher(&key.topic, &key.ros_type, key.depth)
        })
    }

    /// The pooled raw reader for `key`, held until [`Participant::release`].
    pub(crate) fn pooled_reader(&self, key: &Key) -> Result<Arc<RawSubscription>> {
        debug_assert_eq!(key.dir, Dir::Reader);
        self.pool().reader(key, || {
            self.raw_subscription(&key.topic, &key.ros_type, key.depth)
        })
    }

    /// Over Zenoh, waits (until `deadline`) until the type hash of `key`'s type is known, from a peer on its
    /// topic if need be (see `node::zenoh::learn_type_hash`); over DDS at once.
    pub(crate) async fn learn_type_hash(
        &self,
        key: &Key,
        deadline: std::time::Instant,
    ) -> Result<()> {
        #[cfg(feature = "zenoh")]
        if let Some(ctx) = self.zenoh_context() {
            return crate::node::zenoh::learn_type_hash(&ctx, &key.topic, &key.ros_type, deadline)
                .await;
        }
        let _ = (key, deadline);
        Ok(())
    }

    /// Gives up one hold on a pooled endpoint; whether it is gone.
    pub(crate) fn release(&self, key: &Key) -> bool {
        self.pool().release(key)
    }
}
