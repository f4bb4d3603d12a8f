//! A component's own node while it is being set up ([`Event::attach`](crate::Event::attach),
//! [`Response::attach`](crate::Response::attach)): its clock, its parameters, and subscriptions made on it.
//! Events and responses get the same access, through one type ([`EventNode`](crate::nodes::EventNode) and
//! [`ResponseNode`](crate::nodes::ResponseNode) name it).

use futures::StreamExt;

use crate::{
    error::Result,
    node::endpoints::{typed_subscription, Watched},
    wire::msg::RosMessage,
    wire::qos::signal_qos,
};

/// Access to a component's own node while it is being set up.
pub struct ComponentNode<'a> {
    pub(crate) node: &'a mut crate::node::transport::RosNode,
    pub(crate) participant: &'a crate::node::participant::Participant,
    pub(crate) params: &'a mut crate::node::params::Declared,
}

impl ComponentNode<'_> {
    /// The clock the component follows (simulated time with `use_sim_time`, see [`crate::node::clock`]).
    pub fn clock(&self) -> crate::node::clock::Clock {
        self.participant.clock()
    }

    /// Declares the component's parameters (once, all at once): served on its node for `ros2 param`, with
    /// values from the command line when it gives them (see [`crate::node::params`]).
    ///
    /// ```
    /// use radar_ros::{Response, nodes::ResponseNode, SlotError, msg::Empty, params::{ParamDecl, Params}};
    /// /// Counts to `limit`, one count every `period` seconds (both read when a run begins).
    /// struct CountUp(Option<Params>);
    /// impl Response for CountUp {
    ///     type Start = Empty;
    ///     type Output = Empty;
    ///     fn attach(&mut self, node: &mut ResponseNode<'_>) -> radar_ros::Result<()> {
    ///         self.0 = Some(node.declare([
    ///             ParamDecl::new("period", 0.5).float_range(0.01, 60.0),
    ///             ParamDecl::new("limit", 10).integer_range(1, 1000, 1),
    ///         ])?);
    ///         Ok(())
    ///     }
    ///     async fn start(&mut self, _: Empty) -> Result<Empty, SlotError> {
    ///         let p = self.0.as_ref().ok_or_else(|| SlotError::msg("not attached"))?;
    ///         let (period, limit) = (p.f64("period").unwrap_or(0.5), p.i64("limit").unwrap_or(10));
    ///         for _ in 0..limit {
    ///             tokio::time::sleep(std::time::Duration::from_secs_f64(period)).await;
    ///         }
    ///         Ok(Empty::default())
    ///     }
    /// }
    /// ```
    pub fn declare(
        &mut self,
        decls: impl IntoIterator<Item = crate::node::params::ParamDecl>,
    ) -> Result<crate::node::params::Params> {
        self.params.declare(self.participant, self.node, decls)
    }

    /// Subscribes the component's node to `topic` (resolved in the Radar's namespace when relative), with signal
    /// QoS (reliable, volatile, keep-last 10).
    ///
    /// ```
    /// use radar_ros::{Event, nodes::EventNode, topics::EventSubscription, SlotError, msg::{Empty, Float64}};
    /// /// Triggers when the battery reading falls below 20 %.
    /// struct LowBattery(Option<EventSubscription<Float64>>);
    /// impl Event for LowBattery {
    ///     type Payload = Empty;
    ///     fn attach(&mut self, node: &mut EventNode<'_>) -> radar_ros::Result<()> {
    ///         self.0 = Some(node.subscribe::<Float64>("battery")?);
    ///         Ok(())
    ///     }
    ///     async fn check(&mut self) -> Result<Empty, SlotError> {
    ///         let sub = self.0.as_ref().ok_or_else(|| SlotError::msg("not attached"))?;
    ///         loop {
    ///             if sub.recv().await.map_err(|e| SlotError::msg(e.to_string()))?.data < 0.2 {
    ///                 return Ok(Empty::default());
    ///             }
    ///         }
    ///     }
    /// }
    /// ```
    pub fn subscribe<M: RosMessage>(&mut self, topic: &str) -> Result<EventSubscription<M>> {
        let abs = self.participant.resolve_topic(topic)?;
        let inner =
            typed_subscription::<M>(self.participant.graph(), self.node, &abs, &signal_qos())?;
        Ok(EventSubscription { topic: abs, inner })
    }
}

/// A subscription made on a component's node (see [`ComponentNode::subscribe`]).
pub struct EventSubscription<M: RosMessage> {
    topic: String,
    inner: Watched<crate::node::transport::Subscription<M>>,
}

impl<M: RosMessage> EventSubscription<M> {
    /// Takes a message that has already arrived (skipping publishers of another type), without waiting.
    pub fn take(&self) -> Option<M> {
        self.inner.take_accepted()
    }

    /// The next message (skipping malformed ones and publishers of another type); unbounded unless
    /// `.timeout(d)`.
    ///
    /// # Cancel safety
    ///
    /// Cancel safe: a message is taken from the subscription's queue only when it is returned, so a wait
    /// that is dropped (a `select!` branch that lost) loses nothing.
    pub fn recv(&self) -> crate::Wait<'_, M> {
        crate::Wait::signal(format!("a message on {}", self.topic), async move {
            let expected = M::ros_type_name();
            let stream = self.inner.async_stream();
            let mut accepted = Box::pin(self.inner.matching().accepted(
                stream,
                &self.topic,
                &expected,
            ));
            match accepted.next().await {
                Some((m, _)) => Ok(m),
                None => Err(crate::Error::Closed(self.topic.clone())),
            }
        })
    }
}
