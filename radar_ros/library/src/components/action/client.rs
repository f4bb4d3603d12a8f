//! An action server as a RADAR response (rules A1-A7): a goal starts it, a cancel interrupts it, the result
//! ends it.

use std::{
    sync::{Arc, Mutex},
    time::Duration,
};

use futures::{FutureExt, StreamExt};
use ros2_client::{
    action::{GoalId, GoalStatusEnum},
    RmwRequestId,
};

use super::{
    wire::{served_types, server_endpoints, Client, Wire},
    Action,
};
use crate::{
    components::response::{accepted, hand_over, Response, ResponseHandle},
    error::SlotError,
    graph::Graph,
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

/// The goal of the current run, as far as the client knows it.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct GoalTrack {
    /// The goal request sent and its goal id.
    pub(crate) sent: Option<(RmwRequestId, GoalId)>,
    /// `Some(accepted)` once the server answered.
    pub(crate) answer: Option<bool>,
    /// The result request sent for it: a server may answer only one per goal (ros2-client's does), so a
    /// cancel waits for the answer to this one rather than asking again.
    pub(crate) result_req: Option<RmwRequestId>,
    /// Its result has arrived (nothing left to cancel).
    pub(crate) finished: bool,
    /// The server left the graph mid-goal (nobody to cancel with).
    pub(crate) server_left: bool,
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
pub(crate) struct ActionProxy<A: Action> {
    pub(crate) client: Arc<Client<A>>,
    pub(crate) graph: Graph,
    pub(crate) action: String,
    pub(crate) feedback: Arc<Watched<ros2_client::Publisher<A::Feedback>>>,
    pub(crate) goal: Arc<Mutex<GoalTrack>>,
    pub(crate) options: ActionResponseOptions,
    /// Whether this process serves the action itself (its endpoints are matched locally, unseen by
    /// discovery).
    pub(crate) local: crate::node::participant::Served,
    /// The server found by the last start, and the graph's change count then: while nothing on the graph
    /// changed, it is still there (the scan of discovery data costs tens of microseconds a start).
    pub(crate) known: Option<(u64, ros2_client::dds::rustdds::GUID)>,
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
    ) -> std::result::Result<Option<ros2_client::dds::rustdds::GUID>, SlotError> {
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
    async fn server_gone(&self, server: Option<ros2_client::dds::rustdds::GUID>) -> SlotError {
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
