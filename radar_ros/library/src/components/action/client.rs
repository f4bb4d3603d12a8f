//! An action server as a RADAR response (rules A1-A7): a goal starts it, a cancel interrupts it, the result
//! ends it.

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use crate::node::transport::action::{GoalId, GoalStatusEnum};
use futures::{FutureExt, StreamExt};

use radar_semantics::goal::{Answer, Cancel, GoalMachine, GoalStatus, RunEnd};

use super::{
    wire::{served_types, server_endpoints, Client, Wire},
    Action,
};
use crate::{
    components::response::{accepted, hand_over, Response, ResponseHandle},
    error::SlotError,
    graph::Graph,
    node::actions::{Call, Outcome},
    node::endpoints::{emit, Watched},
    wire::refs::{AsResponse, ResponseRef, Signal},
    StartPolicy,
};

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
    pub(crate) name: Option<String>,
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
    pub(crate) handle: ResponseHandle,
    pub(crate) feedback: Signal,
    pub(crate) action: String,
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
    /// Stops the response (a running goal is canceled through the exit slot, rule A6) and waits (unbounded
    /// unless `.timeout(d)`).
    ///
    /// # Cancel safety
    ///
    /// The stop is asked for when this is called; dropping the returned wait (or its timeout running out)
    /// leaves the component finishing on its own, its exit slot included.
    pub fn shutdown(self) -> crate::Wait<'static, ()> {
        self.handle.shutdown()
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

/// The goal of the current run: what the rules know of it ([`GoalMachine`], rules A1-A7) and the calls
/// that carry it on the wire.
pub(crate) struct GoalTrack<R: Clone> {
    /// What the rules know of the goal, and decide.
    pub(crate) rules: GoalMachine,
    /// The goal call sent and its goal id.
    pub(crate) sent: Option<(Call<bool>, GoalId)>,
    /// The result call sent for it: a server may answer only one per goal (ros2-client's does), so a
    /// cancel waits for the answer to this one rather than asking again.
    pub(crate) result_req: Option<Call<Outcome<Wire<R>>>>,
}

impl<R: Clone> Default for GoalTrack<R> {
    fn default() -> Self {
        GoalTrack {
            rules: GoalMachine::default(),
            sent: None,
            result_req: None,
        }
    }
}

/// The response behaviour that drives an action server.
pub(crate) struct ActionProxy<A: Action> {
    pub(crate) client: Arc<Client<A>>,
    pub(crate) graph: Graph,
    pub(crate) action: String,
    pub(crate) feedback: Arc<Watched<crate::node::transport::Publisher<A::Feedback>>>,
    pub(crate) goal: Arc<Mutex<GoalTrack<A::Result>>>,
    pub(crate) options: ActionResponseOptions,
    /// Whether this process serves the action itself (its endpoints are matched locally, unseen by
    /// discovery).
    pub(crate) local: crate::node::participant::Served,
    /// The server found by the last start, and the graph's change count then: while nothing on the graph
    /// changed, it is still there (the scan of discovery data costs tens of microseconds a start).
    pub(crate) known: Option<(u64, crate::node::transport::EndpointId)>,
}

impl<A: Action> ActionProxy<A> {
    fn failed(&self, what: impl std::fmt::Display) -> SlotError {
        SlotError::msg(format!(
            "{what} (action {} {})",
            self.action,
            A::ros_type_name()
        ))
    }

    /// The server's participant once it is matched both ways (`None`: served in this process).
    async fn wait_server(
        &mut self,
    ) -> std::result::Result<Option<crate::node::transport::EndpointId>, SlotError> {
        let mut changes = self.graph.changes();
        if let Some((v, server)) = self.known {
            if v == *changes.borrow_and_update() {
                return Ok(Some(server));
            }
        }
        let wanted = server_endpoints(&self.action);
        let deadline = tokio::time::Instant::now() + self.options.server_timeout;
        let found = self
            .graph
            .wait_for(deadline, || {
                if self.local.contains(&self.action) {
                    return Some(None);
                }
                // the count is read before the scan: a change during the scan is seen by the next start
                let version = *changes.borrow_and_update();
                let p = self
                    .graph
                    .participants_matched_on(&wanted)
                    .into_iter()
                    .next()?;
                Some(Some((version, p)))
            })
            .await;
        let (version, p) = match found {
            Some(Some(found)) => found,
            Some(None) => return Ok(None),
            None => {
                return Err(self.failed(format_args!(
                    "no action server answered within {:?}: start it, or check the action's name, type and \
                     ROS_DOMAIN_ID",
                    self.options.server_timeout
                )))
            }
        };
        // DDS matches endpoints whatever their types: a server of another action would take goals it cannot
        // read, and answer with results we cannot read
        let served = served_types(&self.graph, &self.action);
        if !served.contains(&A::ros_type_name()) {
            return Err(self.failed(format_args!(
                "the action server there serves {}: use that action's Rust type, or another action name",
                served.into_iter().collect::<Vec<_>>().join(", ")
            )));
        }
        self.known = Some((version, p));
        Ok(Some(p))
    }

    /// Resolves when the server's participant no longer offers the action (left, crashed, or cut off).
    async fn server_gone(&self, server: Option<crate::node::transport::EndpointId>) -> SlotError {
        let Some(server) = server else {
            return std::future::pending().await;
        };
        let wanted = server_endpoints(&self.action);
        let gone = || {
            (!self
                .graph
                .participants_matched_on(&wanted)
                .contains(&server))
            .then_some(())
        };
        match self.graph.wait_for(crate::graph::no_deadline(), gone).await {
            Some(()) => self.failed("the action server left the ROS graph mid-goal"),
            None => std::future::pending().await,
        }
    }

    /// Carries out a slot's decision about the goal (rules A4-A6): cancels it (at once, or once the answer
    /// still to come accepts it) and hands the result the server reports over to `exited`.
    async fn cancel(&self, decision: Cancel) {
        let Some((req, goal_id)) = self.goal.lock().unwrap().sent.clone() else {
            return;
        };
        let client = &self.client;
        let limit = self.options.cancel_timeout;
        let work = async {
            let decision = match decision {
                Cancel::Nothing => return,
                Cancel::Now => Cancel::Now,
                // rule A5: the answer is still to come; a canceled goal must not start running afterwards
                Cancel::OnceAccepted => {
                    let accepted = match client.goal_answer(&req, goal_id).await {
                        Ok(accepted) => accepted,
                        Err(e) => {
                            tracing::warn!(action = %self.action, error = ?e, "no answer to the goal");
                            false
                        }
                    };
                    self.goal.lock().unwrap().rules.answered_late(accepted)
                }
            };
            if decision != Cancel::Now {
                return;
            }
            match client.cancel(goal_id).await {
                Ok(code) => {
                    tracing::debug!(action = %self.action, %code, "cancel answered")
                }
                Err(e) => {
                    tracing::warn!(action = %self.action, error = ?e, "cancel request failed")
                }
            }
            let result_req = match self.goal.lock().unwrap().result_req.clone() {
                Some(r) => Ok(r),
                None => client.request_result(goal_id),
            };
            let result = match result_req {
                Ok(r) => client.result(&r).await,
                Err(e) => {
                    tracing::warn!(action = %self.action, error = ?e, "could not ask for the result");
                    return;
                }
            };
            match result {
                Ok((status, Wire(result))) => {
                    tracing::debug!(action = %self.action, ?status, "canceled goal ended");
                    let _ = self.goal.lock().unwrap().rules.ended(goal_status(status));
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
            .map_err(|e| self.failed(format_args!("could not send the goal: {e}")))?;
        {
            let mut g = self.goal.lock().unwrap();
            g.sent = Some((req.clone(), goal_id));
            g.rules.sent(); // rule A1
        }
        let answer = futures::select_biased! {
            r = client.goal_answer(&req, goal_id).fuse() =>
                r.map_err(|e| self.failed(format_args!("the goal's answer did not come: {e}")))?,
            gone = self.server_gone(server).fuse() => {
                let _ = self.goal.lock().unwrap().rules.server_left(); // rule A7
                return Err(gone);
            }
        };
        match self.goal.lock().unwrap().rules.answered(answer) {
            Answer::Rejected => return Err(self.failed("goal rejected by the action server")), // rule A3
            Answer::Started => accepted(), // rule A2
        }
        let feedback = self.feedback.clone();
        // feedback is forwarded while the goal runs; if its stream ended the result is still awaited (B10)
        let forward = client
            .feedback(goal_id)
            .for_each(|Wire(f)| {
                emit(&feedback, "feedback", f);
                async {}
            })
            .then(|()| std::future::pending::<()>());
        let result_req = client
            .request_result(goal_id)
            .map_err(|e| self.failed(format_args!("could not ask for the result: {e}")))?;
        self.goal.lock().unwrap().result_req = Some(result_req.clone());
        let (status, Wire(result)) = futures::select_biased! {
            r = client.result(&result_req).fuse() =>
                r.map_err(|e| self.failed(format_args!("the goal's result did not arrive: {e}")))?,
            gone = self.server_gone(server).fuse() => {
                let _ = self.goal.lock().unwrap().rules.server_left(); // rule A7
                return Err(gone);
            }
            () = forward.fuse() => unreachable!("forwarding feedback never ends"),
        };
        let end = self.goal.lock().unwrap().rules.ended(goal_status(status));
        match end {
            RunEnd::Completed => Ok(result),
            RunEnd::Failed { status } => {
                hand_over(result);
                Err(self.failed(format_args!("goal ended {}", status.label())))
            }
            RunEnd::ServerLeft => unreachable!("a result is no leaving"),
        }
    }

    async fn interrupt(&mut self) {
        let decision = self.goal.lock().unwrap().rules.interrupt(); // rules A4, A5
        self.cancel(decision).await;
    }

    async fn exit(&mut self, reason: crate::ExitReason) -> crate::ExitAction {
        let decision = self.goal.lock().unwrap().rules.exit(&reason); // rule A6
        self.cancel(decision).await;
        crate::ExitAction::Done
    }

    fn start_policy(&self) -> StartPolicy {
        self.options.policy
    }
}

/// The wire's goal status in the rules' terms (A7): anything that is no end is `Unknown`, a failure.
fn goal_status(s: GoalStatusEnum) -> GoalStatus {
    match s {
        GoalStatusEnum::Succeeded => GoalStatus::Succeeded,
        GoalStatusEnum::Canceled => GoalStatus::Canceled,
        GoalStatusEnum::Aborted => GoalStatus::Aborted,
        GoalStatusEnum::Unknown
        | GoalStatusEnum::Accepted
        | GoalStatusEnum::Executing
        | GoalStatusEnum::Canceling => GoalStatus::Unknown,
    }
}
