//! The transport's types, as the layers above `node/` and `graph/` name them. Components, connections and
//! `radar/` (but for `radar/mod.rs`, where the transport is chosen and built) never name `rustdds` or
//! ros2-client's DDS backend themselves (`tests/layering.rs` checks it), so that a second transport (Zenoh,
//! docs/zenoh.md) changes these and the layers below them, not the binding of the semantics.
//!
//! Nodes ([`RosNode`]), topic endpoints ([`Publisher`], [`Subscription`]) and services ([`Server`], [`Client`])
//! are over DDS or, with the `zenoh` feature, over Zenoh: an enum each (not a trait object: each sample takes
//! one match, and the hot path stays monomorphic). Actions are in `node/actions.rs` (clients) and
//! `node/action_server.rs` (servers).

use futures::{Stream, StreamExt};
use ros2_client::{MessageInfo, ReadResult, RmwRequestId};

use crate::error::{Result, Text};

/// A ROS node of a component or program, on the transport of its participant. (One per component, made once
/// and kept in place: the variants' sizes differ.)
#[allow(clippy::large_enum_variant)]
pub(crate) enum RosNode {
    /// Over DDS.
    Dds(ros2_client::dds::Node),
    /// Over Zenoh, as rmw_zenoh's.
    #[cfg(feature = "zenoh")]
    Zenoh(ZenohNode),
}

/// A node over Zenoh, with what its endpoints need that the backend's node does not say.
#[cfg(feature = "zenoh")]
pub(crate) struct ZenohNode {
    /// The backend's node.
    pub(crate) node: ros2_client::zenoh::Node,
    /// Its domain.
    pub(crate) domain_id: u16,
    /// Where samples that do not decode are counted (the participant's).
    pub(crate) malformed: std::sync::Arc<crate::wire::malformed::Malformed>,
    /// How long a fall of a match count must last to be believed (the lease: a router restart is not a
    /// departure).
    pub(crate) grace: std::time::Duration,
    /// Its session: the tokens that tell why a peer went.
    pub(crate) ctx: ros2_client::zenoh::Context,
}

impl RosNode {
    /// Its domain.
    pub(crate) fn domain_id(&self) -> u16 {
        match self {
            RosNode::Dds(n) => n.domain_id(),
            #[cfg(feature = "zenoh")]
            RosNode::Zenoh(n) => n.domain_id,
        }
    }

    /// Its fully qualified name.
    pub(crate) fn fully_qualified_name(&self) -> String {
        match self {
            RosNode::Dds(n) => n.fully_qualified_name(),
            #[cfg(feature = "zenoh")]
            RosNode::Zenoh(n) => n.node.fully_qualified_name(),
        }
    }
}

/// A service server, on the transport of its node (made once: the variants' sizes may differ).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Server<Q: ros2_client::Message, A: ros2_client::Message> {
    /// Over DDS.
    Dds(ros2_client::dds::Server<Q, A>),
    /// Over Zenoh: a queryable, as rmw_zenoh's.
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Server<Q, A>),
}

impl<Q, A> Server<Q, A>
where
    Q: ros2_client::Message + 'static,
    A: ros2_client::Message + 'static,
{
    /// The requests as they arrive, with their ids (a request that cannot be read: an error saying why).
    pub(crate) fn receive_request_stream(
        &self,
    ) -> impl Stream<Item = std::result::Result<(RmwRequestId, Q), Text>> + '_ {
        let text = |e: &dyn std::fmt::Display| Text(e.to_string());
        #[cfg(not(feature = "zenoh"))]
        {
            let Server::Dds(s) = self;
            s.receive_request_stream()
                .map(move |r| r.map_err(|e| text(&e)))
        }
        #[cfg(feature = "zenoh")]
        match self {
            Server::Dds(s) => futures::future::Either::Left(
                s.receive_request_stream()
                    .map(move |r| r.map_err(|e| text(&e))),
            ),
            Server::Zenoh(s) => futures::future::Either::Right(
                futures::stream::unfold(s, |s| async move {
                    match s.async_receive_request().await {
                        // the queryable is closed: the stream ends, as DDS's does
                        Err(ros2_client::ServiceError::NoReply) => None,
                        r => Some((r, s)),
                    }
                })
                .map(move |r| r.map_err(|e| text(&e))),
            ),
        }
    }

    /// Answers request `id`.
    pub(crate) async fn async_send_response(
        &self,
        id: RmwRequestId,
        resp: A,
    ) -> std::result::Result<(), Text> {
        match self {
            Server::Dds(s) => s
                .async_send_response(id, resp)
                .await
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            Server::Zenoh(s) => s.send_response(id, resp).map_err(|e| Text(e.to_string())),
        }
    }

    /// Whether a reply to a caller needs the caller's reply reader matched first (DDS: a reply sent before goes
    /// nowhere; Zenoh: the reply travels back on the query's own path).
    pub(crate) fn replies_need_match(&self) -> bool {
        matches!(self, Server::Dds(_))
    }
}

/// A service client, on the transport of its node (made once: the variants' sizes may differ).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Client<Q: ros2_client::Message, A: ros2_client::Message> {
    /// Over DDS.
    Dds(ros2_client::dds::Client<Q, A>),
    /// Over Zenoh: a query, as rmw_zenoh's.
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Client<Q, A>),
}

impl<Q, A> Client<Q, A>
where
    Q: ros2_client::Message + 'static,
    A: ros2_client::Message + 'static,
{
    /// Calls the service and waits for its answer (unbounded: the caller bounds it).
    pub(crate) async fn async_call_service(&self, req: Q) -> std::result::Result<A, Text> {
        match self {
            Client::Dds(c) => c
                .async_call_service(req)
                .await
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            Client::Zenoh(c) => c.async_call(req).await.map_err(|e| Text(e.to_string())),
        }
    }
}
/// What identifies an endpoint, or a participant, on the graph: a DDS GUID (16 bytes, as an rmw_zenoh GID).
pub(crate) type EndpointId = ros2_client::dds::rustdds::GUID;
/// Actions: clients, servers, goal and cancel handles.
pub(crate) use ros2_client::action;
pub(crate) use ros2_client::dds::ServiceMapping;

/// What a failed write gives back (the message, and why), whichever transport it was on.
pub(crate) type WriteError<M> = ros2_client::WriteError<M>;

/// A typed publisher, on the transport it was made on. (One per endpoint, made once: the variants' sizes
/// differ, and boxing the larger would only add a pointer to follow on each sample.)
#[allow(clippy::large_enum_variant)]
pub(crate) enum Publisher<M: serde::Serialize> {
    /// Over DDS.
    Dds(ros2_client::dds::Publisher<M>),
    /// Over Zenoh, as rmw_zenoh's.
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Publisher<M>),
}

impl<M: serde::Serialize> Publisher<M> {
    /// Sends `m`, stamped now.
    pub(crate) fn publish(&self, m: M) -> Result<(), WriteError<M>> {
        match self {
            Publisher::Dds(p) => p.publish(m),
            #[cfg(feature = "zenoh")]
            Publisher::Zenoh(p) => p.publish(m),
        }
    }

    /// Sends `m` as `sent` says: with that source time and carrying that cause (see [`crate::wire::cause`]).
    /// Over Zenoh both go into the attachment: the time in rmw_zenoh's field, the cause after its three fields
    /// (ros2-client patch 19; rmw_zenoh's readers stop before it, docs/zenoh.md).
    pub(crate) fn publish_sent(
        &self,
        m: M,
        sent: radar_semantics::response::Sent,
    ) -> Result<(), WriteError<M>> {
        match self {
            Publisher::Dds(p) => p
                .publish_with_options(m, crate::wire::cause::write_options(sent))
                .map(|_| ()),
            #[cfg(feature = "zenoh")]
            Publisher::Zenoh(p) => p.publish_related(
                m,
                ros2_client::ROSTime::from_nanos(sent.at),
                sent.by.map(|c| crate::wire::cause::identity(c).into()),
            ),
        }
    }

    /// Waits at most `max_wait` until every matched reliable subscription has acknowledged what was sent
    /// (over DDS: RustDDS's acknowledgments); whether they all did. Over Zenoh there are no acknowledgments: a
    /// sample put is on its link, and this returns at once.
    pub(crate) fn wait_for_acknowledgments(
        &self,
        max_wait: std::time::Duration,
    ) -> Result<bool, WriteError<()>> {
        match self {
            Publisher::Dds(p) => p.wait_for_acknowledgments(max_wait),
            #[cfg(feature = "zenoh")]
            Publisher::Zenoh(_) => {
                let _ = max_wait;
                Ok(true)
            }
        }
    }

    /// Its id on the graph: the DDS writer's GUID, or over Zenoh its GID (16 bytes either way).
    pub(crate) fn id(&self) -> EndpointId {
        match self {
            Publisher::Dds(p) => p.guid(),
            #[cfg(feature = "zenoh")]
            Publisher::Zenoh(p) => p.gid().into(),
        }
    }
}

/// A typed subscription, on the transport it was made on (see [`Publisher`]).
#[allow(clippy::large_enum_variant)]
pub(crate) enum Subscription<M: 'static> {
    /// Over DDS.
    Dds(ros2_client::dds::Subscription<M>),
    /// Over Zenoh, as rmw_zenoh's.
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Subscription<M>),
}

impl<M: serde::de::DeserializeOwned + 'static> Subscription<M> {
    /// A sample that has already arrived, without waiting.
    pub(crate) fn take(&self) -> ReadResult<Option<(M, MessageInfo)>> {
        match self {
            Subscription::Dds(s) => s.take(),
            #[cfg(feature = "zenoh")]
            Subscription::Zenoh(s) => s.try_take(),
        }
    }

    /// Its samples as they arrive.
    pub(crate) fn async_stream(&self) -> impl Stream<Item = ReadResult<(M, MessageInfo)>> + '_ {
        #[cfg(not(feature = "zenoh"))]
        {
            let Subscription::Dds(s) = self;
            s.async_stream()
        }
        #[cfg(feature = "zenoh")]
        match self {
            Subscription::Dds(s) => futures::future::Either::Left(s.async_stream()),
            Subscription::Zenoh(s) => {
                futures::future::Either::Right(until_closed(s.async_stream()))
            }
        }
    }
}

impl Subscription<crate::wire::raw::RawMessage> {
    /// Its message bodies as they arrive (over DDS read with a seed, over Zenoh with `RawMessage`'s
    /// `Deserialize`).
    pub(crate) fn bodies(
        &self,
    ) -> impl Stream<Item = ReadResult<(crate::wire::raw::RawMessage, MessageInfo)>> + '_ {
        #[cfg(not(feature = "zenoh"))]
        {
            let Subscription::Dds(s) = self;
            s.async_stream_seed(crate::wire::raw::RawSeed)
        }
        #[cfg(feature = "zenoh")]
        match self {
            Subscription::Dds(s) => {
                futures::future::Either::Left(s.async_stream_seed(crate::wire::raw::RawSeed))
            }
            Subscription::Zenoh(s) => {
                futures::future::Either::Right(until_closed(s.async_stream()))
            }
        }
    }
}

/// A Zenoh subscription's stream until its subscriber is closed (the session gone): the backend's never ends
/// on its own, and would say `Closed` for ever.
#[cfg(feature = "zenoh")]
fn until_closed<T>(stream: impl Stream<Item = ReadResult<T>>) -> impl Stream<Item = ReadResult<T>> {
    stream.take_while(|r| std::future::ready(!matches!(r, Err(ros2_client::ReadError::Closed))))
}

#[cfg(all(test, feature = "zenoh"))]
mod tests {
    use super::*;
    use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_zenoh_subscriptions_stream_ends_when_its_session_closes() {
        let ctx = ros2_client::zenoh::Context::with_options(
            ros2_client::zenoh::ContextOptions::new().domain_id(231),
        )
        .unwrap();
        let node = ctx
            .new_node(
                NodeName::new("/", "closing").unwrap(),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .unwrap();
        let topic = node.create_topic(
            &Name::new("/", "closing").unwrap(),
            MessageTypeName::new("std_msgs", "Empty"),
            &QosProfile::default(),
        );
        let sub = Subscription::Zenoh(
            node.create_subscription::<crate::wire::msg::Empty>(&topic, None)
                .unwrap(),
        );
        ctx.session().close().await.unwrap();
        let mut stream = Box::pin(sub.async_stream());
        let next = tokio::time::timeout(std::time::Duration::from_secs(5), stream.next())
            .await
            .expect("the stream answers at once");
        assert!(
            next.is_none(),
            "it ends (not `Closed` for ever): {:?}",
            next.map(|r| r.map(|_| ()))
        );
    }
}
