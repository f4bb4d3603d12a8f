//! ROS 2 actions as RADAR responses, and RADAR responses as ROS 2 actions.
//!
//! An action is a response in all but name: a goal starts it, a cancel interrupts it, the result ends it. Two
//! bridges, both built on the response machinery (same topics, same `state`, same counters):
//!
//! - [`Radar::action_response`](crate::Radar::action_response): an **action server** (rclpy, rclcpp, Nav2, another radar_ros program) as a
//!   response, usable in every statement (`radar.once(&bumper).interrupt(&navigate)`).
//! - [`Radar::serve_as_action`](crate::Radar::serve_as_action): a **response** (local or found on the graph) as an action server, so any
//!   action client (`ros2 action send_goal`, rclpy's `ActionClient`, BehaviorTree.ROS2) can drive it.
//!
//! # Mapping rules (next to the response rules of [`radar_semantics::response`])
//!
//! An action server as a response (`A1`-`A7`, decided by [`radar_semantics::goal::GoalMachine`], one per
//! run, where the rules are stated in full): `start(goal)` sends the goal once the server is matched both ways
//! (A1); `started` means the server accepted it (A2: its answer says so, or, when the answer was lost on the
//! way, the server's status list names the goal); a rejected goal fails the run (A3); `interrupt` cancels
//! the goal, at once or as soon as it is accepted (A4, A5); any other end of the run cancels a goal that may
//! still run (A6); the goal's end, or the server leaving, ends the run (A7).
//!
//! A server of another action type on that name fails each run with an error that names the type served there
//! (DDS would match the endpoints anyway); [`Radar::action_type`](crate::Radar::action_type) tells the type of a named action.
//!
//! Feedback is the response's `feedback` signal (`<response>/feedback`, the action's feedback type), usable as
//! a connection source and in `waitfor`. `start` while a goal runs follows the response's
//! [`StartPolicy`](crate::StartPolicy): ignored by default, `Restart` cancels the goal and sends the new one,
//! `QueueOne` sends it after `exited`.
//!
//! A response as an action server (`S1`-`S7`, decided by [`radar_semantics::served::ServedAction`], where
//! the rules are stated in full; the server reads goals and cancel requests in tasks of their own, so a cancel
//! never waits behind a goal):
//!
//! | S | action protocol | RADAR |
//! |---|---|---|
//! | 1 | goal while the response is idle and no goal of this server runs | accepted, then `start(goal)`; status `EXECUTING` when the response says `started` |
//! | 2 | goal while a goal runs, or the response is busy | **rejected** (a response runs one thing at a time; cancel the first goal, or wait for its result) |
//! | 3 | cancel of the running goal (also before the response said `started`) | accepted (status `CANCELING`), then `interrupt` (again when `started` comes, if it had not yet); the result is `exited`'s payload with status `CANCELED` |
//! | 4 | — | `exited` after a completed run: `SUCCEEDED` with `exited`'s payload; after a failed, panicked, interrupted (by someone else) or exit-signalled run: `ABORTED` (the state that follows `exited` says which; without one within 1 s, `ABORTED`) |
//! | 5 | feedback | every message on the response's `feedback` topic while the goal executes |
//! | 6 | — | the response leaves the graph, or ignores the start: the goal is `ABORTED` |
//! | 7 | — | only the run the goal started answers it: the goal's start carries a cause (R13) that the run's `started` and `exited` carry back; another run of the response (another statement's, overlapping) does not end the goal. A response that carries no causes (rclpy) is taken at its word: its next `started` and `exited` are the goal's |
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar, bumper: radar_ros::EventHandle) -> radar_ros::Result<()> {
//! use radar_ros::action::{Fibonacci, FibonacciGoal};
//! let fib = radar.action_response::<Fibonacci>("/fibonacci")?;       // an rclpy action server, say
//! let _stop = radar.once(&bumper).interrupt(&fib).await?;              // the bumper cancels the goal
//! radar.inject(fib.reference().start_slot(), FibonacciGoal { order: 8 }).await?;
//! let result: radar_ros::action::FibonacciResult = radar.waitfor(fib.reference().exited()).await?;
//! # Ok(()) }
//! ```

pub(crate) mod client;
mod fibonacci;
pub(crate) mod server;
pub(crate) mod wire;

pub use client::{ActionResponseHandle, ActionResponseOptions};
pub use fibonacci::{Fibonacci, FibonacciFeedback, FibonacciGoal, FibonacciResult};
pub use server::ActionServerHandle;

use crate::wire::msg::RosMessage;

/// The RIHS01 hashes of the types rosidl makes up around an action (no `.action` file defines them), as its
/// `share/<pkg>/action/<Name>.json` lists them: what rmw_zenoh names in the key expressions and tokens of the
/// action's `send_goal` and `get_result` services and its `feedback` topic.
///
/// ```
/// use radar_ros::action::{Action, Fibonacci};
/// let h = Fibonacci::TYPE_HASHES.unwrap();
/// assert!(h.send_goal.starts_with("RIHS01_"));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ActionTypeHashes {
    /// `pkg/action/Name_SendGoal`: the `send_goal` service.
    pub send_goal: &'static str,
    /// `pkg/action/Name_GetResult`: the `get_result` service.
    pub get_result: &'static str,
    /// `pkg/action/Name_FeedbackMessage`: the `feedback` topic's type (the goal id and the feedback).
    pub feedback_message: &'static str,
}

/// A ROS 2 action type: its name and the messages of its three parts.
///
/// ```
/// use radar_ros::action::{Action, Fibonacci};
/// assert_eq!(Fibonacci::ros_type_name(), "test_msgs/action/Fibonacci");
/// ```
///
/// Declare one of your own with message types named as rosidl names them (`ros_message!(T, "pkg", action
/// "Dock_Goal")`):
///
/// ```
/// use radar_ros::{action::Action, ros_message};
/// #[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
/// pub struct DockGoal { pub station: String }
/// ros_message!(DockGoal, "my_robot", action "Dock_Goal");
/// #[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
/// pub struct DockResult { pub docked: bool }
/// ros_message!(DockResult, "my_robot", action "Dock_Result");
/// #[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
/// pub struct DockFeedback { pub distance: f32 }
/// ros_message!(DockFeedback, "my_robot", action "Dock_Feedback");
/// pub struct Dock;
/// impl Action for Dock {
///     const PACKAGE: &'static str = "my_robot";
///     const NAME: &'static str = "Dock";
///     type Goal = DockGoal;
///     type Result = DockResult;
///     type Feedback = DockFeedback;
/// }
/// ```
pub trait Action: Send + Sync + 'static {
    /// The ROS package, e.g. `"test_msgs"`.
    const PACKAGE: &'static str;
    /// The action's name in the package, e.g. `"Fibonacci"`.
    const NAME: &'static str;
    /// `<Name>_Goal`: what `start` takes and `started` carries.
    type Goal: RosMessage;
    /// `<Name>_Result`: what `exited` carries.
    type Result: RosMessage;
    /// `<Name>_Feedback`: what the `feedback` signal carries.
    type Feedback: RosMessage;
    /// The RIHS01 hashes of the types rosidl makes up around the action, which rmw_zenoh names in its key
    /// expressions and liveliness tokens (`None`: not known; generated actions carry them).
    const TYPE_HASHES: Option<ActionTypeHashes> = None;

    /// `pkg/action/Name`, as `ros2 action` shows it.
    fn ros_type_name() -> String {
        format!("{}/action/{}", Self::PACKAGE, Self::NAME)
    }
}
