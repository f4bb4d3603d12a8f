//! The transport's types, as the layers above `node/` and `graph/` name them. Components, connections and
//! `radar/` (but for `radar/mod.rs`, where the transport is chosen and built) never name `rustdds` or
//! ros2-client's DDS backend themselves (`tests/layering.rs` checks it), so that a second transport (Zenoh,
//! docs/zenoh.md) changes these and the layers below them, not the binding of the semantics.
//!
//! Topic endpoints ([`Publisher`], [`Subscription`]) are over DDS or, with the `zenoh` feature, over Zenoh: an
//! enum each (not a trait object: each sample takes one match, and the hot path stays monomorphic). Nodes,
//! services and actions are DDS's today.

use futures::Stream;
use ros2_client::{MessageInfo, ReadResult};

/// A ROS node of a component or program.
pub(crate) type RosNode = ros2_client::dds::Node;
/// A service server.
pub(crate) type Server<Q, A> = ros2_client::dds::Server<Q, A>;
/// A service client.
pub(crate) type Client<Q, A> = ros2_client::dds::Client<Q, A>;
/// What identifies an endpoint, or a participant, on the graph: a DDS GUID (16 bytes, as an rmw_zenoh GID).
pub(crate) type EndpointId = ros2_client::dds::rustdds::GUID;
/// Actions: clients, servers, goal and cancel handles.
pub(crate) use ros2_client::action;
pub(crate) use ros2_client::dds::{ActionClient, ActionServer, ServiceMapping};

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

    /// Sends `m` as `sent` says: with that source time and, over DDS, carrying that cause (see
    /// [`crate::wire::cause`]). Over Zenoh the source time goes into rmw_zenoh's attachment, which has no field
    /// for the cause (docs/zenoh.md).
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
            Publisher::Zenoh(p) => p.publish_stamped(m, ros2_client::ROSTime::from_nanos(sent.at)),
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
            Subscription::Zenoh(s) => futures::future::Either::Right(s.async_stream()),
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
            Subscription::Zenoh(s) => futures::future::Either::Right(s.async_stream()),
        }
    }
}
