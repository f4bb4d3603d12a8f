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

/// ros2-client's action client of `A`.
pub(crate) type Client<A> = crate::node::transport::ActionClient<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// ros2-client's action server of `A` (before it is made async).
pub(super) type SyncServer<A> = crate::node::transport::ActionServer<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// The action client of `A` at the fully qualified `action` on `node`: the one way radar_ros makes one
/// (enhanced mapping, signal QoS for the services and feedback, state QoS for the status).
pub(crate) fn action_client<A: Action>(
    node: &mut crate::node::transport::RosNode,
    action: &str,
) -> Result<Client<A>> {
    crate::node::declared::record_node(node, crate::node::declared::Access::Call, action);
    node.dds("an action client")?
        .create_action_client::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
            crate::node::transport::ServiceMapping::Enhanced,
            &ros_name(action)?,
            &ros2_client::ActionTypeName::new(A::PACKAGE, A::NAME),
            client_qos(),
        )
        .map_err(|e| Error::transport(format!("an action client for {action}"), e))
}

/// The action server of `A` at the fully qualified `action` on `node`, made as [`action_client`] makes the
/// client.
pub(crate) fn action_server<A: Action>(
    node: &mut crate::node::transport::RosNode,
    action: &str,
) -> Result<SyncServer<A>> {
    crate::node::declared::record_node(node, crate::node::declared::Access::Execute, action);
    node.dds("an action server")?
        .create_action_server::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
            crate::node::transport::ServiceMapping::Enhanced,
            &ros_name(action)?,
            &ros2_client::ActionTypeName::new(A::PACKAGE, A::NAME),
            server_qos(),
        )
        .map_err(|e| Error::transport(format!("an action server for {action}"), e))
}
