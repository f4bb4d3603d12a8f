//! How ROS 2 names appear on DDS: the conventions every ROS 2 middleware (rmw) layer follows, kept in one place.
//!
//! | ROS 2 | DDS |
//! |---|---|
//! | topic `/a/b` | topic `rt/a/b` |
//! | service `/s`: requests, replies | topics `rq/sRequest`, `rr/sReply` |
//! | action `/a` | services `/a/_action/send_goal`, `cancel_goal`, `get_result`; topics `/a/_action/feedback`, `status` |
//! | type `pkg/msg/T` (`srv`, `action` alike) | type `pkg::msg::dds_::T_` |

/// The DDS topic of the ROS topic `ros` (`/a/b` -> `rt/a/b`).
pub(crate) fn topic(ros: &str) -> String {
    format!("rt{ros}")
}

/// The ROS topic of a DDS topic, if it is one (`rt/a/b` -> `/a/b`; a service's topics are not).
pub(crate) fn ros_topic(dds: &str) -> Option<&str> {
    dds.strip_prefix("rt")
}

/// The DDS topic of service `service`'s requests (`/s` -> `rq/sRequest`).
pub(crate) fn request(service: &str) -> String {
    format!("rq{service}Request")
}

/// The DDS topic of service `service`'s replies (`/s` -> `rr/sReply`).
pub(crate) fn reply(service: &str) -> String {
    format!("rr{service}Reply")
}

/// The DDS topics of the services `names` of node `node`: each one's requests (written by a client: `true`) and
/// replies (read), as `Graph::participants_matched_on` takes them.
pub(crate) fn service_topics(node: &str, names: &[&str]) -> Vec<(bool, String)> {
    names
        .iter()
        .flat_map(|s| {
            let service = format!("{node}/{s}");
            [(true, request(&service)), (false, reply(&service))]
        })
        .collect()
}

/// The service whose requests go on the DDS topic `dds`, if it is such a topic (`rq/sRequest` -> `/s`).
pub(crate) fn service_of_request(dds: &str) -> Option<&str> {
    dds.strip_prefix("rq")?.strip_suffix("Request")
}

/// The service whose replies go on the DDS topic `dds`, if it is such a topic (`rr/sReply` -> `/s`).
pub(crate) fn service_of_reply(dds: &str) -> Option<&str> {
    dds.strip_prefix("rr")?.strip_suffix("Reply")
}

/// The three services of an action.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ActionService {
    SendGoal,
    CancelGoal,
    GetResult,
}

impl ActionService {
    /// All three.
    pub(crate) const ALL: [ActionService; 3] = [
        ActionService::SendGoal,
        ActionService::CancelGoal,
        ActionService::GetResult,
    ];

    /// The ROS service of action `action` (`/a` -> `/a/_action/send_goal`).
    pub(crate) fn of(self, action: &str) -> String {
        let part = match self {
            ActionService::SendGoal => "send_goal",
            ActionService::CancelGoal => "cancel_goal",
            ActionService::GetResult => "get_result",
        };
        format!("{action}/_action/{part}")
    }
}

/// The ROS topic of action `action`'s feedback (`/a` -> `/a/_action/feedback`).
pub(crate) fn action_feedback(action: &str) -> String {
    format!("{action}/_action/feedback")
}

/// The ROS type of a DDS type name (`std_msgs::msg::dds_::Int32_` -> `std_msgs/msg/Int32`).
pub(crate) fn ros_type(dds: &str) -> String {
    dds.replacen("::msg::dds_::", "/msg/", 1)
        .replacen("::srv::dds_::", "/srv/", 1)
        .replacen("::action::dds_::", "/action/", 1)
        .trim_end_matches('_')
        .to_owned()
}

/// The action type whose goal requests have the DDS type `send_goal_request`
/// (`test_msgs::action::dds_::Fibonacci_SendGoal_Request_` -> `test_msgs/action/Fibonacci`).
pub(crate) fn action_type_of_goal_request(send_goal_request: &str) -> String {
    send_goal_request
        .replacen("::action::dds_::", "/action/", 1)
        .trim_end_matches("_SendGoal_Request_")
        .to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_names_map_onto_dds_and_back() {
        assert_eq!(topic("/a/b"), "rt/a/b");
        assert_eq!(ros_topic("rt/a/b"), Some("/a/b"));
        assert_eq!(ros_topic("rq/sRequest"), None);
        assert_eq!(request("/m/connect"), "rq/m/connectRequest");
        assert_eq!(reply("/m/connect"), "rr/m/connectReply");
        assert_eq!(
            service_of_request("rq/m/connectRequest"),
            Some("/m/connect")
        );
        assert_eq!(service_of_request("rr/m/connectReply"), None);
        assert_eq!(
            request(&ActionService::SendGoal.of("/fib")),
            "rq/fib/_action/send_goalRequest"
        );
        assert_eq!(action_feedback("/fib"), "/fib/_action/feedback");
        assert_eq!(
            ros_type("std_msgs::msg::dds_::Int32_"),
            "std_msgs/msg/Int32"
        );
        assert_eq!(
            ros_type("radar_msgs::srv::dds_::Connect_Request_"),
            "radar_msgs/srv/Connect_Request"
        );
        assert_eq!(
            action_type_of_goal_request("test_msgs::action::dds_::Fibonacci_SendGoal_Request_"),
            "test_msgs/action/Fibonacci"
        );
    }
}
