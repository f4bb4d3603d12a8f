//! The transport's types, as the layers above `node/` and `graph/` name them. Components, connections and
//! `radar/` (but for `radar/mod.rs`, where the transport is chosen and built) never name `rustdds` or
//! ros2-client's DDS backend themselves (`tests/layering.rs` checks it), so that a second transport (Zenoh,
//! docs/zenoh.md) changes these and the layers below them, not the binding of the semantics. Today each is
//! DDS's, through ros2-client.

/// A ROS node of a component or program.
pub(crate) type RosNode = ros2_client::dds::Node;
/// A typed publisher.
pub(crate) type Publisher<M> = ros2_client::dds::Publisher<M>;
/// A typed subscription.
pub(crate) type Subscription<M> = ros2_client::dds::Subscription<M>;
/// A service server.
pub(crate) type Server<Q, A> = ros2_client::dds::Server<Q, A>;
/// A service client.
pub(crate) type Client<Q, A> = ros2_client::dds::Client<Q, A>;
/// What identifies an endpoint, or a participant, on the graph: a DDS GUID (16 bytes, as an rmw_zenoh GID).
pub(crate) type EndpointId = ros2_client::dds::rustdds::GUID;
/// Actions: clients, servers, goal and cancel handles.
pub(crate) use ros2_client::action;
pub(crate) use ros2_client::dds::{ActionClient, ActionServer, ServiceMapping};
