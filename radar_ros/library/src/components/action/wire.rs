//! How an action looks on DDS: ros2-client's message wrapper, the endpoints' topics, the action type a goal
//! request's DDS type names, the QoS of both ends.

use std::collections::BTreeSet;

use ros2_client::{
    action::{ActionClientQosPolicies, ActionServerQosPolicies},
    Name,
};
use serde::{Deserialize, Serialize};

use super::Action;
use crate::{
    error::{Error, Result},
    graph::Graph,
    wire::dds_names::{self, ActionService},
    wire::msg::RosMessage,
    wire::qos::{signal_qos, state_qos},
};

/// A RADAR message as ros2-client's action endpoints carry it (ros2-client's own `Message` trait).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub(crate) struct Wire<T>(pub(super) T);

impl<T: RosMessage> ros2_client::Message for Wire<T> {}

/// The DDS topics of an action's endpoints: `(is a request or status/feedback reader on the server, topic)`
/// as a client sees them: `true` for the server's readers (our writers match them), `false` for its writers.
pub(crate) fn server_endpoints(action: &str) -> Vec<(bool, String)> {
    let mut e: Vec<(bool, String)> = ActionService::ALL
        .iter()
        .map(|s| (true, dds_names::request(&s.of(action))))
        .collect();
    e.extend(
        ActionService::ALL
            .iter()
            .map(|s| (false, dds_names::reply(&s.of(action)))),
    );
    e.push((false, dds_names::topic(&dds_names::action_feedback(action))));
    e
}

/// The ROS action types the graph shows served (goal request readers) at the fully qualified `action`.
pub(crate) fn served_types(graph: &Graph, action: &str) -> BTreeSet<String> {
    graph
        .discovered_reader_types(&dds_names::request(&ActionService::SendGoal.of(action)))
        .iter()
        .map(|t| dds_names::action_type_of_goal_request(t))
        .collect()
}

fn client_qos() -> ActionClientQosPolicies {
    ActionClientQosPolicies {
        goal_service: signal_qos(),
        result_service: signal_qos(),
        cancel_service: signal_qos(),
        feedback_subscription: signal_qos(),
        status_subscription: state_qos(),
    }
}

fn server_qos() -> ActionServerQosPolicies {
    ActionServerQosPolicies {
        goal_service: signal_qos(),
        result_service: signal_qos(),
        cancel_service: signal_qos(),
        feedback_publisher: signal_qos(),
        status_publisher: state_qos(),
    }
}

fn ros_name(fq: &str) -> Result<Name> {
    Name::parse(fq).map_err(|e| Error::InvalidName {
        name: fq.to_owned(),
        reason: format!("{e}"),
    })
}

/// The action client of `A`, on the transport of its node.
pub(crate) type Client<A> = crate::node::actions::ActionClient<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// The action server of `A`, on the transport of its node.
pub(crate) type Server<A> = crate::node::action_server::ActionServer<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// The action client of `A` at the fully qualified `action` on `node`: the one way radar_ros makes one (over DDS
/// the enhanced mapping, signal QoS for the services and feedback, state QoS for the status; over Zenoh as
/// rmw_zenoh's, the action's type hashes in its keys and tokens).
pub(crate) fn action_client<A: Action>(
    node: &mut crate::node::transport::RosNode,
    action: &str,
) -> Result<Client<A>> {
    crate::node::declared::record_node(node, crate::node::declared::Access::Call, action);
    let name = ros_name(action)?;
    let ty = ros2_client::ActionTypeName::new(A::PACKAGE, A::NAME);
    let what = || format!("an action client for {action}");
    match node {
        crate::node::transport::RosNode::Dds(node) => node
            .create_action_client::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                crate::node::transport::ServiceMapping::Enhanced,
                &name,
                &ty,
                client_qos(),
            )
            .map(crate::node::actions::ActionClient::Dds)
            .map_err(|e| Error::transport(what(), e)),
        #[cfg(feature = "zenoh")]
        crate::node::transport::RosNode::Zenoh(z) => {
            register_hashes::<A>()?;
            z.node
                .create_action_client::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                    &name, &ty,
                )
                .map(|c| crate::node::actions::ActionClient::Zenoh(std::sync::Arc::new(c)))
                .map_err(|e| Error::transport(what(), e))
        }
    }
}

/// Gives the Zenoh backend the hashes of `A`'s made-up types, which rmw_zenoh peers match on; an action
/// without them is refused (its endpoints would be announced with a hash no rmw_zenoh peer matches).
#[cfg(feature = "zenoh")]
fn register_hashes<A: Action>() -> Result<()> {
    let Some(h) = A::TYPE_HASHES else {
        return Err(Error::InvalidName {
            name: A::ros_type_name(),
            reason: "an action over Zenoh needs its RIHS01 type hashes (Action::TYPE_HASHES), which rmw_zenoh \
                     names in its keys: generate the action's Rust types with radar_idl (they carry them), or \
                     copy them from rosidl's share/<pkg>/action/<Name>.json"
                .into(),
        });
    };
    let dds = |part: &str| format!("{}::action::dds_::{}_{part}_", A::PACKAGE, A::NAME);
    for (part, hash) in [
        ("SendGoal", h.send_goal),
        ("GetResult", h.get_result),
        ("FeedbackMessage", h.feedback_message),
    ] {
        ros2_client::zenoh::register_type_hash(&dds(part), hash).map_err(|reason| {
            Error::InvalidName {
                name: A::ros_type_name(),
                reason,
            }
        })?;
    }
    Ok(())
}

/// The action server of `A` at the fully qualified `action` on `node`, made as [`action_client`] makes the
/// client.
pub(crate) fn action_server<A: Action>(
    node: &mut crate::node::transport::RosNode,
    action: &str,
) -> Result<Server<A>> {
    crate::node::declared::record_node(node, crate::node::declared::Access::Execute, action);
    let name = ros_name(action)?;
    let ty = ros2_client::ActionTypeName::new(A::PACKAGE, A::NAME);
    let what = || format!("an action server for {action}");
    match node {
        crate::node::transport::RosNode::Dds(node) => node
            .create_action_server::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                crate::node::transport::ServiceMapping::Enhanced,
                &name,
                &ty,
                server_qos(),
            )
            .map(|s| {
                crate::node::action_server::ActionServer::Dds(
                    crate::node::transport::action::AsyncActionServer::new(s),
                )
            })
            .map_err(|e| Error::transport(what(), e)),
        #[cfg(feature = "zenoh")]
        crate::node::transport::RosNode::Zenoh(z) => {
            register_hashes::<A>()?;
            z.node
                .create_action_server::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                    &name, &ty,
                )
                .map(|s| {
                    crate::node::action_server::ActionServer::Zenoh(
                        crate::node::action_server::ZenohGoals::new(s),
                    )
                })
                .map_err(|e| Error::transport(what(), e))
        }
    }
}
