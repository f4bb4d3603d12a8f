//! [`Radar::serve_as_action`]: a response as an action server; its machinery is in
//! `components/action/server.rs`.

use crate::components::action::server::{serve, ActionServerHandle, ServerIo};
use crate::components::action::{wire::action_server, Action};
use crate::{
    error::{Error, Result},
    radar::Radar,
    wire::msg::{Empty, ResponseState, RosMessage},
    wire::names::ComponentName,
    wire::refs::AsResponse,
};
use std::sync::Arc;

impl Radar {
    /// Serves `response` (a local handle, or one found on the graph with [`Radar::response`]) as the ROS 2
    /// action server `action`, so that any action client drives it (the rules are in [`crate::components::action`]). The
    /// response's start type must be the action's goal type and its output type the result type; feedback is
    /// whatever the response (or anyone) publishes on `<response>/feedback`.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{FnResponse, action::{Fibonacci, FibonacciGoal, FibonacciResult}};
    /// let fib = radar.spawn_response("fibonacci", FnResponse::new(|g: FibonacciGoal| async move {
    ///     Ok(FibonacciResult { sequence: (0..g.order).collect() })
    /// }))?;
    /// let server = radar.serve_as_action::<Fibonacci>(&fib, "/fibonacci")?;
    /// // `ros2 action send_goal /fibonacci test_msgs/action/Fibonacci "{order: 5}"` now runs it
    /// # Ok(()) }
    /// ```
    pub fn serve_as_action<A: Action>(
        &self,
        response: impl AsResponse,
        action: &str,
    ) -> Result<ActionServerHandle> {
        let r = response.response_ref();
        let (goal_t, result_t) = (A::Goal::ros_type_name(), A::Result::ros_type_name());
        let start_slot = r.start_slot();
        if start_slot.ros_type() != goal_t {
            return Err(Error::TypeMismatch {
                source_topic: format!("{action} (goals)"),
                source_type: goal_t,
                slot_topic: start_slot.topic().to_owned(),
                slot_type: start_slot.ros_type().to_owned(),
            });
        }
        let exited = r.exited();
        if exited.ros_type() != result_t {
            return Err(Error::TypeMismatch {
                source_topic: exited.topic().to_owned(),
                source_type: exited.ros_type().to_owned(),
                slot_topic: format!("{action} (results)"),
                slot_type: result_t,
            });
        }
        let action_c = self.resolve(action)?;
        let action_fq = action_c.fully_qualified();
        let node_name = ComponentName::resolve(
            &format!("{}_action_server", action_c.base()),
            action_c.namespace(),
        )?;
        let mut claimed = self.participant().claim_node(&node_name)?;
        let server = action_server::<A>(&mut claimed.node, &action_fq)?;
        let server = Arc::new(server);
        let name = r.name().clone();
        let io = ServerIo::<A> {
            start: self.signal_publisher::<A::Goal>(start_slot.topic())?,
            interrupt: self.signal_publisher::<Empty>(r.interrupt_slot().topic())?,
            started: self.signal_subscription::<A::Goal>(r.started().topic())?,
            exited: self.signal_subscription::<A::Result>(exited.topic())?,
            feedback: self.signal_subscription::<A::Feedback>(
                &name.endpoint(crate::endpoint::Endpoint::Feedback),
            )?,
            state: self.state_subscription::<ResponseState>(
                &name.endpoint(crate::endpoint::Endpoint::State),
            )?,
        };
        let served = self.participant().served_actions().mark(action_fq.clone());
        let (graph, fq) = (self.graph().clone(), action_fq.clone());
        let task = self
            .participant()
            .spawn_component(claimed, served, move |stop| async move {
                serve::<A>(server, io, graph, fq, stop).await;
            });
        tracing::info!(action = %action_fq, response = %name, "serving a response as an action");
        Ok(ActionServerHandle {
            action: action_fq,
            response: name,
            task,
        })
    }
}
