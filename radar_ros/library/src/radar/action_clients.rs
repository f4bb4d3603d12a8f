//! [`Radar::action_response`]: an action server (rclpy, rclcpp, Nav2, another radar_ros program) as a RADAR
//! response; its machinery is in `components/action/client.rs`.

use crate::components::action::client::{ActionProxy, ActionResponseHandle, ActionResponseOptions};
use crate::components::action::{
    wire::{action_client, served_types},
    Action,
};
use crate::{
    error::{Error, Result},
    node::endpoints::publisher,
    radar::Radar,
    wire::msg::{RosMessage, TypeName},
    wire::qos::signal_qos,
    wire::refs::Signal,
};
use radar_semantics::response::Announce;
use std::sync::Arc;

impl Radar {
    /// The action server `action` (relative names resolve in this Radar's namespace) as a RADAR response named
    /// like the action: `start` sends a goal, `started` says the server accepted it, `interrupt` cancels it,
    /// `exited` carries the result, `feedback` is a signal (the rules are in [`crate::components::action`]).
    ///
    /// The server need not be running yet: each start waits for it (up to
    /// [`ActionResponseOptions::server_timeout`]) and fails the run if it does not come.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::action::{Fibonacci, FibonacciGoal};
    /// let fib = radar.action_response::<Fibonacci>("/fibonacci")?;
    /// let _log = radar.whenever(fib.feedback()).call(|f: radar_ros::action::FibonacciFeedback| {
    ///     println!("so far {:?}", f.sequence);
    /// }).await?;
    /// radar.inject(fib.reference().start_slot(), FibonacciGoal { order: 5 }).await?;
    /// # Ok(()) }
    /// ```
    pub fn action_response<A: Action>(&self, action: &str) -> Result<ActionResponseHandle> {
        self.action_response_with::<A>(action, ActionResponseOptions::default())
    }

    /// [`Radar::action_response`] with options (another response name, timeouts, start policy).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// use radar_ros::{action::{ActionResponseOptions, Fibonacci}, StartPolicy};
    /// let fib = radar.action_response_with::<Fibonacci>(
    ///     "/fibonacci",
    ///     ActionResponseOptions::default().named("fib").start_policy(StartPolicy::Restart),
    /// )?;
    /// assert_eq!(fib.name().fully_qualified(), "/fib");
    /// # Ok(()) }
    /// ```
    pub fn action_response_with<A: Action>(
        &self,
        action: &str,
        options: ActionResponseOptions,
    ) -> Result<ActionResponseHandle> {
        let action_fq = self.resolve(action)?.fully_qualified();
        let response_name = options.name.clone().unwrap_or_else(|| action_fq.clone());
        let (graph, local) = (self.graph().clone(), self.participant().served_actions());
        let fq = action_fq.clone();
        let handle = self.spawn_response_with(
            &response_name,
            Announce::WhenAccepted,
            move |node, g, name| {
                let client = action_client::<A>(node, &fq)?;
                let feedback = publisher::<A::Feedback>(
                    g,
                    node,
                    &name.endpoint(crate::endpoint::Endpoint::Feedback),
                    &TypeName::of::<A::Feedback>(),
                    &signal_qos(),
                )?;
                Ok(ActionProxy::<A> {
                    client: Arc::new(client),
                    graph,
                    action: fq,
                    feedback: Arc::new(feedback),
                    goal: Default::default(),
                    options,
                    local,
                    known: None,
                })
            },
        )?;
        let feedback = Signal::new(
            handle.name().endpoint(crate::endpoint::Endpoint::Feedback),
            A::Feedback::ros_type_name(),
        );
        tracing::info!(response = %handle.name(), action = %action_fq, "action response up");
        Ok(ActionResponseHandle {
            handle,
            feedback,
            action: action_fq,
        })
    }

    /// The type of the action server `action` (relative names resolve in this Radar's namespace), found on the
    /// ROS graph, waiting for one to appear (default [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)`
    /// to change): what `ros2 action list -t` shows, e.g. `test_msgs/action/Fibonacci`. Several servers of
    /// different types on one name are an error.
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// assert_eq!(radar.action_type("/fibonacci").await?, "test_msgs/action/Fibonacci");
    /// # Ok(()) }
    /// ```
    pub fn action_type(&self, action: &str) -> crate::Wait<'static, String> {
        let found = self.resolve(action).map(|n| n.fully_qualified());
        let graph = self.graph().clone();
        crate::Wait::discovery(move |timeout| async move {
            let action = found?;
            let deadline = tokio::time::Instant::now() + timeout;
            let one_type = || {
                let types = served_types(&graph, &action);
                match types.len() {
                    0 => None,
                    1 => Some(Ok(types.into_iter().next().expect("one"))),
                    _ => Some(Err(Error::Ambiguous {
                        topic: format!("{action} (action)"),
                        types: types.into_iter().collect(),
                    })),
                }
            };
            match graph.wait_for(deadline, one_type).await {
                Some(r) => r,
                None => Err(Error::Timeout {
                    what: format!(
                        "an action server on {action} (is it running, in this ROS_DOMAIN_ID?)"
                    ),
                    after: timeout,
                }),
            }
        })
    }
}
