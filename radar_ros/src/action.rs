//! ROS 2 actions as RADAR responses, and RADAR responses as ROS 2 actions.
//!
//! An action is a response in all but name: a goal starts it, a cancel interrupts it, the result ends it. Two
//! bridges, both built on the response machinery (same topics, same `state`, same counters):
//!
//! - [`Radar::action_response`]: an **action server** (rclpy, rclcpp, Nav2, another radar_ros program) as a
//!   response, usable in every statement (`radar.once(&bumper).interrupt(&navigate)`).
//! - [`Radar::serve_as_action`]: a **response** (local or found on the graph) as an action server, so any
//!   action client (`ros2 action send_goal`, rclpy's `ActionClient`, BehaviorTree.ROS2) can drive it.
//!
//! # Mapping rules (next to the response rules of [`radar_semantics::response`])
//!
//! An action server as a response (`A1`-`A7`):
//!
//! | A | RADAR | action protocol |
//! |---|---|---|
//! | 1 | `start(goal)` while idle | sends the goal (after waiting, up to the server timeout, for the server to be matched both ways) |
//! | 2 | `started(goal)` | the server **accepted** the goal (response rule R9); never before |
//! | 3 | `exited(result)`, run failed | the server **rejected** the goal: no `started`, state `failed: goal rejected` |
//! | 4 | `interrupt` while the goal runs | `interrupted` at once, then a cancel request; `exited` carries the result the server reports for the canceled (or meanwhile finished) goal |
//! | 5 | `interrupt` before the server answered (also the `until` of the statement that sent the goal: the run is that statement's from the start, not from acceptance, R13) | `interrupted`; the goal is canceled as soon as it is accepted (or dropped if rejected, or never sent if the server has not appeared yet); no `started` |
//! | 6 | the run ends otherwise while the goal may still run: an `exit` signal, the response or its program stopping, a failure on this side (a result that does not decode) | the goal is canceled too (an exit slot always runs, and a goal left running would be an orphan); not when the server has left |
//! | 7 | `exited`, run failed | the goal ended `ABORTED` or was canceled by someone else (the result is carried), or the server left the graph mid-goal (`failed: the action server ... left`) |
//!
//! A server of another action type on that name fails each run with an error that names the type served there
//! (DDS would match the endpoints anyway); [`Radar::action_type`] tells the type of a named action.
//!
//! Feedback is the response's `feedback` signal (`<response>/feedback`, the action's feedback type), usable as
//! a connection source and in `waitfor`. `start` while a goal runs follows the response's
//! [`StartPolicy`]: ignored by default, `Restart` cancels the goal and sends the new one,
//! `QueueOne` sends it after `exited`.
//!
//! A response as an action server (`S1`-`S6`):
//!
//! | S | action protocol | RADAR |
//! |---|---|---|
//! | 1 | goal while the response is idle and no goal of this server runs | accepted, then `start(goal)`; status `EXECUTING` when the response says `started` |
//! | 2 | goal while a goal runs, or the response is busy | **rejected** (a response runs one thing at a time; cancel the first goal, or wait for its result) |
//! | 3 | cancel of the running goal (also before the response said `started`) | accepted (status `CANCELING`), then `interrupt` (again when `started` comes, if it had not yet); the result is `exited`'s payload with status `CANCELED` |
//! | 4 | — | `exited` after a completed run: `SUCCEEDED` with `exited`'s payload; after a failed, panicked, interrupted (by someone else) or exit-signalled run: `ABORTED` |
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

use std::{
    collections::BTreeSet,
    sync::{Arc, Mutex},
    time::Duration,
};

use futures::{FutureExt, StreamExt};
use ros2_client::{
    action::{
        ActionClientQosPolicies, ActionServerQosPolicies, AsyncActionServer, GoalEndStatus, GoalId,
        GoalStatusEnum,
    },
    ActionTypeName, Name, RmwRequestId, ServiceMapping,
};
use serde::{Deserialize, Serialize};

use radar_semantics::response::{Announce, Cause, Sent};

use crate::{
    endpoints::{emit, publisher, Watched, REPLY_WAIT},
    error::{Error, Result, SlotError},
    graph::Graph,
    msg::{Empty, ResponseState, RosMessage, TypeName},
    names::ComponentName,
    qos::{signal_qos, state_qos},
    radar::Radar,
    refs::{AsResponse, ResponseRef, Signal},
    response::{accepted, hand_over, Response, ResponseHandle},
    shutdown::ComponentTask,
    StartPolicy,
};

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

    /// `pkg/action/Name`, as `ros2 action` shows it.
    fn ros_type_name() -> String {
        format!("{}/action/{}", Self::PACKAGE, Self::NAME)
    }
}

/// A RADAR message as ros2-client's action endpoints carry it (ros2-client's own `Message` trait).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(transparent)]
struct Wire<T>(T);

impl<T: RosMessage> ros2_client::Message for Wire<T> {}

/// The DDS topics of an action's endpoints: `(is a request or status/feedback reader on the server, topic)`
/// as a client sees them: `true` for the server's readers (our writers match them), `false` for its writers.
fn server_endpoints(action: &str) -> Vec<(bool, String)> {
    vec![
        (true, format!("rq{action}/_action/send_goalRequest")),
        (true, format!("rq{action}/_action/cancel_goalRequest")),
        (true, format!("rq{action}/_action/get_resultRequest")),
        (false, format!("rr{action}/_action/send_goalReply")),
        (false, format!("rr{action}/_action/cancel_goalReply")),
        (false, format!("rr{action}/_action/get_resultReply")),
        (false, format!("rt{action}/_action/feedback")),
    ]
}

/// `test_msgs::action::dds_::Fibonacci_SendGoal_Request_` -> `test_msgs/action/Fibonacci`.
fn action_type_of(send_goal_request_type: &str) -> String {
    send_goal_request_type
        .replacen("::action::dds_::", "/action/", 1)
        .trim_end_matches("_SendGoal_Request_")
        .to_owned()
}

/// The ROS action types the graph shows served (goal request readers) at the fully qualified `action`.
fn served_types(graph: &Graph, action: &str) -> BTreeSet<String> {
    graph
        .discovered_reader_types(&format!("rq{action}/_action/send_goalRequest"))
        .iter()
        .map(|t| action_type_of(t))
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

/// How an action-backed response waits and gives up.
///
/// ```
/// use std::time::Duration;
/// let o = radar_ros::action::ActionResponseOptions::default()
///     .named("nav")
///     .server_timeout(Duration::from_secs(20))
///     .start_policy(radar_ros::StartPolicy::Restart);
/// # let _ = o;
/// ```
#[derive(Clone, Debug)]
pub struct ActionResponseOptions {
    name: Option<String>,
    server_timeout: Duration,
    cancel_timeout: Duration,
    policy: StartPolicy,
}

impl Default for ActionResponseOptions {
    fn default() -> Self {
        ActionResponseOptions {
            name: None,
            server_timeout: crate::DEFAULT_TIMEOUT,
            cancel_timeout: Duration::from_secs(10),
            policy: StartPolicy::Ignore,
        }
    }
}

impl ActionResponseOptions {
    /// The response's name (default: the action's name, e.g. `/fibonacci`).
    #[must_use]
    pub fn named(mut self, name: &str) -> Self {
        self.name = Some(name.to_owned());
        self
    }
    /// How long a start waits for the action server to be on the graph before the run fails (default
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT)).
    #[must_use]
    pub fn server_timeout(mut self, d: Duration) -> Self {
        self.server_timeout = d;
        self
    }
    /// How long an interrupt waits for the server to report the canceled goal's result (default 10 s); after
    /// that the exit slot runs and `exited` carries the default result.
    #[must_use]
    pub fn cancel_timeout(mut self, d: Duration) -> Self {
        self.cancel_timeout = d;
        self
    }
    /// What `start` does while a goal runs (default: ignored).
    #[must_use]
    pub fn start_policy(mut self, p: StartPolicy) -> Self {
        self.policy = p;
        self
    }
}

/// A response that drives an action server: a [`ResponseHandle`] (it derefs to one and stands for the
/// response in statements) plus the `feedback` signal.
#[must_use = "the response runs only while its handle lives; bind it (`let r = radar.action_response(..)?`)"]
pub struct ActionResponseHandle {
    handle: ResponseHandle,
    feedback: Signal,
    action: String,
}

impl ActionResponseHandle {
    /// The `feedback` signal: every feedback message of the running goal.
    pub fn feedback(&self) -> Signal {
        self.feedback.clone()
    }
    /// The action's fully qualified name.
    pub fn action(&self) -> &str {
        &self.action
    }
    /// Stops the response (a running goal is canceled through the exit slot, rule A6) and waits.
    pub async fn shutdown(self) {
        self.handle.shutdown().await
    }
}

impl std::ops::Deref for ActionResponseHandle {
    type Target = ResponseHandle;
    fn deref(&self) -> &ResponseHandle {
        &self.handle
    }
}

impl AsResponse for ActionResponseHandle {
    fn response_ref(&self) -> ResponseRef {
        self.handle.response_ref()
    }
}

impl std::fmt::Debug for ActionResponseHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ActionResponseHandle")
            .field("response", &self.handle.name().fully_qualified())
            .field("action", &self.action)
            .finish()
    }
}

type Client<A> = ros2_client::ActionClient<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// The goal of the current run, as far as the client knows it.
#[derive(Clone, Copy, Debug, Default)]
struct GoalTrack {
    /// The goal request sent and its goal id.
    sent: Option<(RmwRequestId, GoalId)>,
    /// `Some(accepted)` once the server answered.
    answer: Option<bool>,
    /// The result request sent for it: a server may answer only one per goal (ros2-client's does), so a
    /// cancel waits for the answer to this one rather than asking again.
    result_req: Option<RmwRequestId>,
    /// Its result has arrived (nothing left to cancel).
    finished: bool,
    /// The server left the graph mid-goal (nobody to cancel with).
    server_left: bool,
}

impl GoalTrack {
    /// Rule A6: whether the exit slot, run for `reason`, cancels this goal: one that the server may still be
    /// running (sent, not rejected, no result yet, the server still there), unless the interrupt slot has
    /// canceled it already. Whatever else ended the run (an exit signal, the program stopping, a failure on
    /// this side such as a result that does not decode) leaves no goal running behind it.
    fn exit_cancels(&self, reason: &crate::ExitReason) -> bool {
        self.sent.is_some()
            && self.answer != Some(false)
            && !self.finished
            && !self.server_left
            && !matches!(
                reason,
                crate::ExitReason::Completed | crate::ExitReason::Interrupted
            )
    }
}

/// The response behaviour that drives an action server.
struct ActionProxy<A: Action> {
    client: Arc<Client<A>>,
    graph: Graph,
    action: String,
    feedback: Arc<Watched<ros2_client::Publisher<A::Feedback>>>,
    goal: Arc<Mutex<GoalTrack>>,
    options: ActionResponseOptions,
    /// Whether this process serves the action itself (its endpoints are matched locally, unseen by
    /// discovery).
    local: crate::participant::Served,
    /// The server found by the last start, and the graph's change count then: while nothing on the graph
    /// changed, it is still there (the scan of discovery data costs tens of microseconds a start).
    known: Option<(u64, ros2_client::dds::rustdds::GUID)>,
}

impl<A: Action> ActionProxy<A> {
    fn failed(&self, what: impl std::fmt::Display) -> SlotError {
        SlotError(format!(
            "{what} (action {} {})",
            self.action,
            A::ros_type_name()
        ))
    }

    /// The server's participant once it is matched both ways (`None`: served in this process).
    async fn wait_server(
        &mut self,
    ) -> std::result::Result<Option<ros2_client::dds::rustdds::GUID>, SlotError> {
        let mut changes = self.graph.changes();
        if let Some((v, server)) = self.known {
            if v == *changes.borrow_and_update() {
                return Ok(Some(server));
            }
        }
        let wanted = server_endpoints(&self.action);
        let deadline = tokio::time::Instant::now() + self.options.server_timeout;
        loop {
            if self.local.contains(&self.action) {
                return Ok(None);
            }
            // the count is read before the scan: a change during the scan is seen by the next start
            let version = *changes.borrow_and_update();
            if let Some(p) = self
                .graph
                .participants_matched_on(&wanted)
                .into_iter()
                .next()
            {
                // DDS matches endpoints whatever their types: a server of another action would take goals it
                // cannot read, and answer with results we cannot read
                let served = served_types(&self.graph, &self.action);
                if !served.contains(&A::ros_type_name()) {
                    return Err(self.failed(format_args!(
                        "the action server there serves {}: use that action's Rust type, or another action name",
                        served.into_iter().collect::<Vec<_>>().join(", ")
                    )));
                }
                self.known = Some((version, p));
                return Ok(Some(p));
            }
            // discovery events wake us; a short poll covers matches made between two events
            let wait = tokio::time::timeout(Duration::from_millis(50), changes.changed());
            if tokio::time::Instant::now() >= deadline {
                return Err(self.failed(format_args!(
                    "no action server answered within {:?}: start it, or check the action's name, type and \
                     ROS_DOMAIN_ID",
                    self.options.server_timeout
                )));
            }
            let _ = wait.await;
        }
    }

    /// Resolves when the server's participant no longer offers the action (left, crashed, or cut off).
    async fn server_gone(&self, server: Option<ros2_client::dds::rustdds::GUID>) -> SlotError {
        let Some(server) = server else {
            return std::future::pending().await;
        };
        let wanted = server_endpoints(&self.action);
        let mut changes = self.graph.changes();
        loop {
            if changes.changed().await.is_err() {
                return self.failed("the participant shut down");
            }
            if !self
                .graph
                .participants_matched_on(&wanted)
                .contains(&server)
            {
                return self.failed("the action server left the ROS graph mid-goal");
            }
        }
    }

    /// Cancels the goal of this run if it is (or becomes) accepted and has not finished, and hands its
    /// result over to `exited` (rules A4-A6).
    async fn cancel_current(&self) {
        let track = *self.goal.lock().unwrap();
        let Some((req, goal_id)) = track.sent else {
            return;
        };
        if track.finished {
            return;
        }
        let client = &self.client;
        let limit = self.options.cancel_timeout;
        let work = async {
            let accepted = match track.answer {
                Some(a) => a,
                // rule A5: the answer is still to come; a canceled goal must not start running afterwards
                None => match client.goal_client().async_receive_response(req).await {
                    Ok(r) => r.accepted,
                    Err(e) => {
                        tracing::warn!(action = %self.action, error = ?e, "no answer to the goal");
                        false
                    }
                },
            };
            if !accepted {
                return;
            }
            match client
                .async_cancel_goal(goal_id, ros2_client::builtin_interfaces::Time::ZERO)
                .await
            {
                Ok(r) => {
                    tracing::debug!(action = %self.action, code = ?r.return_code, "cancel answered")
                }
                Err(e) => {
                    tracing::warn!(action = %self.action, error = ?e, "cancel request failed")
                }
            }
            let result_req = match self.goal.lock().unwrap().result_req {
                Some(r) => Ok(r),
                None => client.request_result(goal_id),
            };
            let result = match result_req {
                Ok(r) => client
                    .result_client()
                    .async_receive_response(r)
                    .await
                    .map(|r| (r.status, r.result)),
                Err(e) => {
                    tracing::warn!(action = %self.action, error = ?e, "could not ask for the result");
                    return;
                }
            };
            match result {
                Ok((status, Wire(result))) => {
                    tracing::debug!(action = %self.action, ?status, "canceled goal ended");
                    self.goal.lock().unwrap().finished = true;
                    hand_over(result);
                }
                Err(e) => {
                    tracing::warn!(action = %self.action, error = ?e, "no result for the canceled goal")
                }
            }
        };
        if tokio::time::timeout(limit, work).await.is_err() {
            tracing::warn!(
                action = %self.action,
                "the action server did not end the canceled goal within {limit:?}; the response goes on without it"
            );
        }
    }
}

impl<A: Action> Response for ActionProxy<A> {
    type Start = A::Goal;
    type Output = A::Result;

    async fn start(&mut self, goal: A::Goal) -> std::result::Result<A::Result, SlotError> {
        *self.goal.lock().unwrap() = GoalTrack::default();
        let server = self.wait_server().await?;
        let client = self.client.clone();
        let (req, goal_id) = client
            .send_goal(Wire(goal))
            .map_err(|e| self.failed(format_args!("could not send the goal: {e:?}")))?;
        self.goal.lock().unwrap().sent = Some((req, goal_id));
        let answer = futures::select_biased! {
            r = client.goal_client().async_receive_response(req).fuse() =>
                r.map_err(|e| self.failed(format_args!("the goal's answer did not decode: {e:?}")))?,
            gone = self.server_gone(server).fuse() => {
                self.goal.lock().unwrap().server_left = true;
                return Err(gone);
            }
        };
        self.goal.lock().unwrap().answer = Some(answer.accepted);
        if !answer.accepted {
            return Err(self.failed("goal rejected by the action server"));
        }
        accepted(); // rule A2: started now
        let feedback = self.feedback.clone();
        // feedback is forwarded while the goal runs; if its stream ended the result is still awaited (B10)
        let forward = client
            .feedback_stream(goal_id)
            .for_each(|f| {
                if let Ok(Wire(f)) = f {
                    emit(&feedback, "feedback", f);
                }
                async {}
            })
            .then(|()| std::future::pending::<()>());
        let result_req = client
            .request_result(goal_id)
            .map_err(|e| self.failed(format_args!("could not ask for the result: {e:?}")))?;
        self.goal.lock().unwrap().result_req = Some(result_req);
        let (status, Wire(result)) = futures::select_biased! {
            r = client.result_client().async_receive_response(result_req).fuse() =>
                r.map(|r| (r.status, r.result))
                    .map_err(|e| self.failed(format_args!("the goal's result did not arrive: {e:?}")))?,
            gone = self.server_gone(server).fuse() => {
                self.goal.lock().unwrap().server_left = true;
                return Err(gone);
            }
            () = forward.fuse() => unreachable!("forwarding feedback never ends"),
        };
        self.goal.lock().unwrap().finished = true;
        match status {
            GoalStatusEnum::Succeeded => Ok(result),
            other => {
                hand_over(result);
                Err(self.failed(format_args!("goal ended {}", status_label(other))))
            }
        }
    }

    async fn interrupt(&mut self) {
        self.cancel_current().await;
    }

    async fn exit(&mut self, reason: crate::ExitReason) -> crate::ExitAction {
        let cancels = self.goal.lock().unwrap().exit_cancels(&reason);
        if cancels {
            self.cancel_current().await; // rule A6
        }
        crate::ExitAction::Done
    }

    fn start_policy(&self) -> StartPolicy {
        self.options.policy
    }
}

fn status_label(s: GoalStatusEnum) -> &'static str {
    match s {
        GoalStatusEnum::Unknown => "UNKNOWN",
        GoalStatusEnum::Accepted => "ACCEPTED",
        GoalStatusEnum::Executing => "EXECUTING",
        GoalStatusEnum::Canceling => "CANCELING",
        GoalStatusEnum::Succeeded => "SUCCEEDED",
        GoalStatusEnum::Canceled => "CANCELED",
        GoalStatusEnum::Aborted => "ABORTED",
    }
}

impl Radar {
    /// The action server `action` (relative names resolve in this Radar's namespace) as a RADAR response named
    /// like the action: `start` sends a goal, `started` says the server accepted it, `interrupt` cancels it,
    /// `exited` carries the result, `feedback` is a signal (the rules are in [`crate::action`]).
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
        let action_name = ros_name(&action_fq)?;
        let response_name = options.name.clone().unwrap_or_else(|| action_fq.clone());
        let (graph, local) = (self.graph().clone(), self.participant().served_actions());
        let fq = action_fq.clone();
        let handle = self.spawn_response_with(
            &response_name,
            Announce::WhenAccepted,
            move |node, g, name| {
                let client = node
                    .create_action_client::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                        ServiceMapping::Enhanced,
                        &action_name,
                        &ActionTypeName::new(A::PACKAGE, A::NAME),
                        client_qos(),
                    )
                    .map_err(|e| Error::transport(format!("an action client for {fq}"), e))?;
                let feedback = publisher::<A::Feedback>(
                    g,
                    node,
                    &name.topic("feedback"),
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
        let feedback = Signal::new(handle.topic("feedback"), A::Feedback::ros_type_name());
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
            let mut changes = graph.changes();
            let deadline = tokio::time::Instant::now() + timeout;
            loop {
                let types = served_types(&graph, &action);
                match types.len() {
                    0 => {}
                    1 => return Ok(types.into_iter().next().expect("one")),
                    _ => {
                        return Err(Error::Ambiguous {
                            topic: format!("{action} (action)"),
                            types: types.into_iter().collect(),
                        })
                    }
                }
                match tokio::time::timeout_at(deadline, changes.changed()).await {
                    Ok(Ok(())) => {}
                    Ok(Err(_)) => return Err(Error::Closed("the participant".into())),
                    Err(_) => {
                        return Err(Error::Timeout {
                            what: format!(
                            "an action server on {action} (is it running, in this ROS_DOMAIN_ID?)"
                        ),
                            after: timeout,
                        })
                    }
                }
            }
        })
    }

    /// Serves `response` (a local handle, or one found on the graph with [`Radar::response`]) as the ROS 2
    /// action server `action`, so that any action client drives it (the rules are in [`crate::action`]). The
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
        let (mut node, claim) = self.participant().claim_node(&node_name)?;
        let server = node
            .create_action_server::<Wire<A::Goal>, Wire<A::Result>, Wire<A::Feedback>>(
                ServiceMapping::Enhanced,
                &ros_name(&action_fq)?,
                &ActionTypeName::new(A::PACKAGE, A::NAME),
                server_qos(),
            )
            .map_err(|e| Error::transport(format!("an action server for {action_fq}"), e))?;
        let server = Arc::new(AsyncActionServer::new(server));
        let name = r.name().clone();
        let io = ServerIo::<A> {
            start: self.signal_publisher::<A::Goal>(start_slot.topic())?,
            interrupt: self.signal_publisher::<Empty>(r.interrupt_slot().topic())?,
            started: self.signal_subscription::<A::Goal>(r.started().topic())?,
            exited: self.signal_subscription::<A::Result>(exited.topic())?,
            feedback: self.signal_subscription::<A::Feedback>(&name.topic("feedback"))?,
            state: self.state_subscription::<ResponseState>(&name.topic("state"))?,
        };
        let served = self.participant().served_actions().mark(action_fq.clone());
        let (graph, fq) = (self.graph().clone(), action_fq.clone());
        let task = ComponentTask::spawn(
            self.participant().components(),
            &node_name.fully_qualified(),
            move |stop| async move {
                let _claim = claim;
                let _node = node;
                let _served = served;
                serve::<A>(server, io, graph, fq, stop).await;
            },
        );
        tracing::info!(action = %action_fq, response = %name, "serving a response as an action");
        Ok(ActionServerHandle {
            action: action_fq,
            response: name,
            task,
        })
    }
}

/// A response served as an action server; dropping it stops the server (a running goal is aborted).
#[must_use = "the action server runs only while its handle lives; bind it (`let s = radar.serve_as_action(..)?`)"]
pub struct ActionServerHandle {
    action: String,
    response: ComponentName,
    task: ComponentTask,
}

impl ActionServerHandle {
    /// The action's fully qualified name.
    pub fn action(&self) -> &str {
        &self.action
    }
    /// The response it drives.
    pub fn response(&self) -> &ComponentName {
        &self.response
    }
    /// Stops the server (a running goal is aborted, the response is interrupted) and waits.
    pub async fn shutdown(self) {
        self.task.stop_and_wait().await
    }
}

impl std::fmt::Debug for ActionServerHandle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ActionServerHandle")
            .field("action", &self.action)
            .field("response", &self.response.fully_qualified())
            .finish()
    }
}

struct ServerIo<A: Action> {
    start: crate::SignalPublisher<A::Goal>,
    interrupt: crate::SignalPublisher<Empty>,
    started: crate::SignalSubscription<A::Goal>,
    exited: crate::SignalSubscription<A::Result>,
    feedback: crate::SignalSubscription<A::Feedback>,
    state: crate::SignalSubscription<ResponseState>,
}

type Server<A> = AsyncActionServer<
    Wire<<A as Action>::Goal>,
    Wire<<A as Action>::Result>,
    Wire<<A as Action>::Feedback>,
>;

/// The goal the server runs now.
struct Active<G> {
    accepted: Option<ros2_client::action::AcceptedGoalHandle<Wire<G>>>,
    executing: Option<ros2_client::action::ExecutingGoalHandle<Wire<G>>>,
    id: GoalId,
    cancel_requested: bool,
    /// The response's `exits` counter when the goal was started.
    exits_before: u64,
    ignored_before: u64,
    /// Until when `started` may take.
    started_by: tokio::time::Instant,
    /// The cause the goal's start carries: the run it begins carries it back on `started` and `exited` (R13).
    cause: Cause,
}

impl<G> Active<G> {
    /// Whether a `started` or `exited` sent as `sent` belongs to this goal's run: one that carries this goal's
    /// cause; or, from a response that carries no causes (rclpy), any (rule S7).
    fn owns(&self, sent: &Sent, response_keeps_causes: bool) -> bool {
        match sent.by {
            Some(c) => c == self.cause,
            None => !response_keeps_causes,
        }
    }
}

/// How long the response has to say `started` after the goal's start was sent.
const STARTED_WITHIN: Duration = Duration::from_secs(5);

/// Numbers the statements of served actions (R13): far above any connection's number, so that a manager of
/// the same participant never takes one for its own.
static SERVER_STATEMENTS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1 << 48);

fn graph_guid(graph: &Graph) -> ros2_client::dds::rustdds::GUID {
    use ros2_client::dds::rustdds::RTPSEntity;
    graph
        .domain_participant()
        .map(|p| p.guid())
        .unwrap_or_else(ros2_client::dds::rustdds::GUID::new_participant_guid)
}

enum Incoming<G> {
    Goal(ros2_client::action::NewGoalHandle<Wire<G>>),
    Cancel(ros2_client::action::CancelHandle),
}

async fn serve<A: Action>(
    server: Arc<Server<A>>,
    io: ServerIo<A>,
    graph: Graph,
    action: String,
    mut stop: tokio::sync::oneshot::Receiver<()>,
) {
    // goals and cancel requests are read in tasks of their own, so that no read is ever cancelled half-way
    let (tx, mut incoming) = tokio::sync::mpsc::unbounded_channel();
    let readers = {
        let (s, tx2) = (server.clone(), tx.clone());
        let goals = tokio::spawn(async move {
            while let Ok(g) = s.receive_new_goal().await {
                if tx2.send(Incoming::Goal(g)).is_err() {
                    break;
                }
            }
        });
        let s = server.clone();
        let cancels = tokio::spawn(async move {
            while let Ok(c) = s.receive_cancel_request().await {
                if tx.send(Incoming::Cancel(c)).is_err() {
                    break;
                }
            }
        });
        [goals, cancels]
    };
    let mut state = io.state.try_recv();
    let mut active: Option<Active<A::Goal>> = None;
    // this server's starts carry causes of its own (R13): its participant's statement base, and a number no
    // connection of its manager has
    let statement = (u128::from(crate::cause::statement_base(graph_guid(&graph))) << 64)
        | u128::from(SERVER_STATEMENTS.fetch_add(1, std::sync::atomic::Ordering::Relaxed));
    let mut goals: u64 = 0;
    // a cancel interrupts the goal's run only (R13), not another statement's run of the response
    let interrupt = |io: &ServerIo<A>| {
        let sent = Sent::by(
            crate::local::now_ns(),
            Cause {
                statement,
                delivery: 0,
            },
        );
        io.interrupt.publish_sent(Empty::default(), sent)
    };
    loop {
        // a RADAR response publishes its state, and carries causes
        let keeps_causes = io.state.publishers() > 0;
        let started_by = active
            .as_ref()
            .filter(|a| a.executing.is_none())
            .map(|a| a.started_by);
        tokio::select! {
            _ = &mut stop => break,
            Some(inc) = incoming.recv() => match inc {
                Incoming::Goal(g) => {
                    wait_callers(&graph, &action, "send_goal").await;
                    let busy = active.is_some()
                        || state.as_ref().is_some_and(|s| s.state != crate::Phase::Idle.code())
                        || io.start.subscribers() == 0;
                    let goal = server.get_new_goal(g.clone());
                    match goal {
                        Some(Wire(goal)) if !busy => match server.accept_goal(g).await {
                            Ok(h) => {
                                let s = state.clone().unwrap_or_default();
                                goals += 1;
                                let cause = Cause { statement, delivery: goals };
                                let sent = Sent::by(crate::local::now_ns(), cause);
                                if let Err(e) = io.start.publish_sent(goal, sent) {
                                    tracing::warn!(%action, error = %e, "could not start the response");
                                }
                                active = Some(Active {
                                    id: h.goal_id(),
                                    accepted: Some(h),
                                    executing: None,
                                    cancel_requested: false,
                                    exits_before: s.exits,
                                    ignored_before: s.ignored_starts,
                                    started_by: tokio::time::Instant::now() + STARTED_WITHIN,
                                    cause,
                                });
                            }
                            Err(e) => tracing::warn!(%action, error = ?e, "could not accept a goal"),
                        },
                        _ => {
                            tracing::info!(%action, "goal rejected: the response is busy or not on the graph (rule S2)");
                            if let Err(e) = server.reject_goal(g).await {
                                tracing::warn!(%action, error = ?e, "could not reject a goal");
                            }
                        }
                    }
                }
                Incoming::Cancel(c) => {
                    wait_callers(&graph, &action, "cancel_goal").await;
                    let ours: Vec<GoalId> = active
                        .as_ref()
                        .filter(|a| !a.cancel_requested && c.contains_goal(&a.id))
                        .map(|a| a.id)
                        .into_iter()
                        .collect();
                    if let Err(e) = server.respond_to_cancel_requests(&c, ours.iter().copied()).await {
                        tracing::warn!(%action, error = ?e, "could not answer a cancel request");
                    }
                    if let (Some(a), false) = (active.as_mut(), ours.is_empty()) {
                        a.cancel_requested = true;
                        if let Err(e) = interrupt(&io) {
                            tracing::warn!(%action, error = %e, "could not interrupt the response");
                        }
                    }
                }
            },
            Ok((_, sent)) = io.started.recv_sent() => {
                if let Some(a) = active.as_mut().filter(|a| a.owns(&sent, keeps_causes)) {
                    if let Some(h) = a.accepted.take() {
                        match server.start_executing_goal(h).await {
                            Ok(e) => a.executing = Some(e),
                            Err(e) => tracing::warn!(%action, error = ?e, "could not mark the goal executing"),
                        }
                    }
                    // canceled before the response said started: that interrupt may have overtaken the start
                    // (two topics) and been ignored by an idle response; interrupt the run now
                    if a.cancel_requested {
                        let _ = interrupt(&io);
                    }
                }
            }
            Ok(f) = io.feedback.recv() => {
                if let Some(h) = active.as_ref().and_then(|a| a.executing.clone()) {
                    if let Err(e) = server.publish_feedback(h, Wire(f)).await {
                        tracing::debug!(%action, error = ?e, "feedback not sent");
                    }
                }
            }
            Ok((result, sent)) = io.exited.recv_sent() => {
                // S7: only the run this goal started answers it
                if let Some(a) = active.take_if(|a| a.owns(&sent, keeps_causes)) {
                    // why the run ended: the state that follows this `exited`
                    let reason = exit_reason(&io.state, &mut state, a.exits_before).await;
                    let status = if a.cancel_requested {
                        GoalEndStatus::Canceled
                    } else if reason == "completed" {
                        GoalEndStatus::Succeeded
                    } else {
                        GoalEndStatus::Aborted
                    };
                    finish::<A>(&server, &action, a, status, result);
                }
            }
            Ok(s) = io.state.recv() => {
                let ignored = active.as_ref().is_some_and(|a| a.executing.is_none() && s.ignored_starts > a.ignored_before);
                state = Some(s);
                if ignored {
                    tracing::info!(%action, "the response ignored the goal's start: goal aborted (rule S6)");
                    let a = active.take().expect("checked");
                    finish::<A>(&server, &action, a, GoalEndStatus::Aborted, Default::default());
                }
            }
            _ = async {
                match started_by {
                    Some(t) => tokio::time::sleep_until(t).await,
                    None => std::future::pending().await,
                }
            } => {
                tracing::warn!(%action, "the response did not start the goal within {STARTED_WITHIN:?}: goal aborted (rule S6)");
                let a = active.take().expect("a goal waits for started");
                finish::<A>(&server, &action, a, GoalEndStatus::Aborted, Default::default());
            }
            _ = io.start.wait_for_no_subscribers(), if active.is_some() => {
                tracing::warn!(%action, "the response left the ROS graph: goal aborted (rule S6)");
                let a = active.take().expect("checked");
                finish::<A>(&server, &action, a, GoalEndStatus::Aborted, Default::default());
            }
        }
    }
    if let Some(a) = active.take() {
        let _ = interrupt(&io);
        finish::<A>(
            &server,
            &action,
            a,
            GoalEndStatus::Aborted,
            Default::default(),
        );
    }
    for r in readers {
        r.abort();
    }
}

/// Sends the goal's result in a task of its own: the reply waits for the client's result request.
fn finish<A: Action>(
    server: &Arc<Server<A>>,
    action: &str,
    a: Active<A::Goal>,
    status: GoalEndStatus,
    result: A::Result,
) {
    let (server, action) = (server.clone(), action.to_owned());
    tokio::spawn(async move {
        let executing = match (a.executing, a.accepted) {
            (Some(e), _) => Some(e),
            (None, Some(h)) => server.start_executing_goal(h).await.ok(),
            (None, None) => None,
        };
        let Some(h) = executing else {
            return;
        };
        let send = server.send_result_response(h, status, Wire(result));
        match tokio::time::timeout(Duration::from_secs(60), send).await {
            Ok(Ok(())) => tracing::debug!(%action, ?status, "goal result sent"),
            Ok(Err(e)) => tracing::warn!(%action, error = ?e, "could not send a goal's result"),
            Err(_) => tracing::debug!(%action, "no client asked for the goal's result within 60 s"),
        }
    });
}

/// The exit reason of the run that ended with the `exited` just read: from the first state whose `exits` is
/// past `exits_before` (the response publishes it right after `exited`), at most 1 s.
async fn exit_reason(
    sub: &crate::SignalSubscription<ResponseState>,
    latest: &mut Option<ResponseState>,
    exits_before: u64,
) -> String {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(1);
    loop {
        if let Some(s) = latest.as_ref().filter(|s| s.exits > exits_before) {
            return s.last_exit_reason.clone();
        }
        match tokio::time::timeout_at(deadline, sub.recv()).await {
            Ok(Ok(s)) => *latest = Some(s),
            _ => return String::new(),
        }
    }
}

/// Waits (at most [`REPLY_WAIT`] each) until every participant that has a request writer on the action's
/// `service` is matched by our reply writer (and, for goals, our feedback writer): a fresh client process (`ros2 action send_goal`) can send its
/// request before we have matched its reply reader, and a reply sent then goes nowhere.
async fn wait_callers(graph: &Graph, action: &str, service: &str) {
    let request = format!("rq{action}/_action/{service}Request");
    let reply = format!("rr{action}/_action/{service}Reply");
    // a goal's sender also reads feedback (a volatile topic): match it first, or a fresh client (`ros2
    // action send_goal --feedback`) misses the first feedback of the goal
    let feedback = format!("rt{action}/_action/feedback");
    let callers = graph.participants_matched_on(&[(false, request)]);
    for c in callers {
        if !graph.wait_reader_of(&reply, c, REPLY_WAIT).await {
            tracing::debug!(%action, %service, "answering before the caller's reply reader is matched");
        }
        if service == "send_goal" && !graph.wait_reader_of(&feedback, c, REPLY_WAIT).await {
            tracing::debug!(%action, "starting a goal before the caller's feedback reader is matched");
        }
    }
}

// ------------------------------------------------------------------------- the tutorial's action type

/// `test_msgs/action/Fibonacci_Goal`: the goal of the ROS 2 tutorial action (`int32 order`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciGoal {
    /// How many numbers of the sequence to compute.
    pub order: i32,
}
crate::ros_message!(FibonacciGoal, "test_msgs", action "Fibonacci_Goal");

/// `test_msgs/action/Fibonacci_Result` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciResult {
    /// The sequence computed.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciResult, "test_msgs", action "Fibonacci_Result");

/// `test_msgs/action/Fibonacci_Feedback` (`int32[] sequence`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciFeedback {
    /// The sequence so far.
    pub sequence: Vec<i32>,
}
crate::ros_message!(FibonacciFeedback, "test_msgs", action "Fibonacci_Feedback");

/// `test_msgs/action/Fibonacci`: the action of the ROS 2 tutorials, as the `ros-jazzy-test-msgs` package
/// defines it, for examples and tests (`ros2 action send_goal /fibonacci test_msgs/action/Fibonacci
/// "{order: 5}"`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fibonacci;

impl Action for Fibonacci {
    const PACKAGE: &'static str = "test_msgs";
    const NAME: &'static str = "Fibonacci";
    type Goal = FibonacciGoal;
    type Result = FibonacciResult;
    type Feedback = FibonacciFeedback;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ExitReason;

    fn running_goal() -> GoalTrack {
        GoalTrack {
            sent: Some((RmwRequestId::default(), GoalId::new_random())),
            answer: Some(true),
            ..GoalTrack::default()
        }
    }

    #[test]
    fn a6_an_exit_leaves_no_goal_running_whatever_ended_the_run() {
        let g = running_goal();
        for reason in [
            ExitReason::ExitSignal,
            ExitReason::Failed("the goal's result did not arrive".into()),
            ExitReason::Failed("the feedback stream ended".into()),
            ExitReason::Panicked("boom".into()),
        ] {
            assert!(g.exit_cancels(&reason), "{reason:?}");
        }
        // nothing to cancel: the interrupt slot did, the goal ended, was rejected, never sent, or the server left
        assert!(!g.exit_cancels(&ExitReason::Interrupted));
        assert!(!g.exit_cancels(&ExitReason::Completed));
        let finished = GoalTrack {
            finished: true,
            ..running_goal()
        };
        let rejected = GoalTrack {
            answer: Some(false),
            ..running_goal()
        };
        let left = GoalTrack {
            server_left: true,
            ..running_goal()
        };
        for g in [finished, rejected, left, GoalTrack::default()] {
            assert!(!g.exit_cancels(&ExitReason::ExitSignal), "{g:?}");
        }
        // sent and not answered yet (A5): canceled once accepted
        let unanswered = GoalTrack {
            answer: None,
            ..running_goal()
        };
        assert!(unanswered.exit_cancels(&ExitReason::ExitSignal));
    }
}
