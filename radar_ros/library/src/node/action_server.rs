//! Action servers on the transport of their node: over DDS ros2-client's `AsyncActionServer` (its goal table,
//! its status publication, result requests held until the result), over Zenoh a goal table of radar_ros's own
//! on ros2-client's Zenoh `ActionServer` (its queryables and publishers), with the same operations, so that
//! `components/action/server.rs` (rules S1-S7) runs on either.

use ros2_client::action::{GoalEndStatus, GoalId};
#[cfg(feature = "zenoh")]
use ros2_client::RmwRequestId;

#[cfg(feature = "zenoh")]
pub(crate) use super::zenoh_goals::ZenohGoals;

use crate::error::Text;

type Dds<G, R, F> = ros2_client::action::AsyncActionServer<G, R, F>;

/// An action server, on the transport of its node (made once: the variants' sizes differ).
#[allow(clippy::large_enum_variant)]
pub(crate) enum ActionServer<G, R, F>
where
    G: ros2_client::Message + Clone,
    R: ros2_client::Message + Clone,
    F: ros2_client::Message,
{
    /// Over DDS.
    Dds(Dds<G, R, F>),
    /// Over Zenoh, as rmw_zenoh's: queryables for the three services, publishers for feedback and status.
    #[cfg(feature = "zenoh")]
    Zenoh(ZenohGoals<G, R, F>),
}

/// A goal request just read: its id, and how it is answered.
pub(crate) enum NewGoal<G> {
    /// Over DDS: ros2-client's handle.
    Dds(ros2_client::action::NewGoalHandle<G>),
    /// Over Zenoh: the query's id and the goal's.
    #[cfg(feature = "zenoh")]
    Zenoh(RmwRequestId, GoalId),
}

impl<G> NewGoal<G> {
    /// The goal's id.
    pub(crate) fn goal_id(&self) -> GoalId {
        match self {
            NewGoal::Dds(h) => h.goal_id(),
            #[cfg(feature = "zenoh")]
            NewGoal::Zenoh(_, id) => *id,
        }
    }
}

/// An accepted goal (`executing`: the server said it runs).
pub(crate) enum Goal<G> {
    /// Over DDS, accepted.
    DdsAccepted(ros2_client::action::AcceptedGoalHandle<G>),
    /// Over DDS, executing.
    DdsExecuting(ros2_client::action::ExecutingGoalHandle<G>),
    /// Over Zenoh: its id (the table knows its status).
    #[cfg(feature = "zenoh")]
    Zenoh(GoalId),
}

/// A cancel request just read: which goals it names, and how it is answered.
pub(crate) enum CancelRequest {
    /// Over DDS: ros2-client's handle (the goals it names, accepted or executing, already found).
    Dds(ros2_client::action::CancelHandle),
    /// Over Zenoh: the query's id and the accepted or executing goals it names.
    #[cfg(feature = "zenoh")]
    Zenoh(RmwRequestId, Vec<GoalId>),
}

impl CancelRequest {
    /// Whether it names `goal`.
    pub(crate) fn contains_goal(&self, goal: &GoalId) -> bool {
        match self {
            CancelRequest::Dds(c) => c.contains_goal(goal),
            #[cfg(feature = "zenoh")]
            CancelRequest::Zenoh(_, goals) => goals.contains(goal),
        }
    }
}

fn text(e: impl std::fmt::Debug) -> Text {
    Text(format!("{e:?}"))
}

impl<G, R, F> ActionServer<G, R, F>
where
    G: ros2_client::Message + Clone + Send + Sync + 'static,
    R: ros2_client::Message + Clone + Default + Send + Sync + 'static,
    F: ros2_client::Message + Send + Sync + 'static,
{
    /// The next goal request and its goal (`None`: it did not decode; answer it with [`Self::reject_goal`]).
    /// An error: the server is closed.
    pub(crate) async fn receive_new_goal(&self) -> Result<(NewGoal<G>, Option<G>), Text> {
        match self {
            ActionServer::Dds(s) => {
                let h = s.receive_new_goal().await.map_err(text)?;
                let goal = s.get_new_goal(h.clone());
                Ok((NewGoal::Dds(h), goal))
            }
            #[cfg(feature = "zenoh")]
            ActionServer::Zenoh(z) => {
                let (req, id, goal) = z.receive_new_goal().await?;
                Ok((NewGoal::Zenoh(req, id), Some(goal)))
            }
        }
    }

    /// Accepts the goal (status ACCEPTED).
    pub(crate) async fn accept_goal(&self, h: NewGoal<G>) -> Result<Goal<G>, Text> {
        match (self, h) {
            (ActionServer::Dds(s), NewGoal::Dds(h)) => {
                s.accept_goal(h).await.map(Goal::DdsAccepted).map_err(text)
            }
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), NewGoal::Zenoh(req, id)) => {
                z.answer_goal(req, id, true)?;
                Ok(Goal::Zenoh(id))
            }
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("a goal of another transport".into())),
        }
    }

    /// Rejects the goal.
    pub(crate) async fn reject_goal(&self, h: NewGoal<G>) -> Result<(), Text> {
        match (self, h) {
            (ActionServer::Dds(s), NewGoal::Dds(h)) => s.reject_goal(h).await.map_err(text),
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), NewGoal::Zenoh(req, id)) => z.answer_goal(req, id, false),
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("a goal of another transport".into())),
        }
    }

    /// Marks an accepted goal executing (status EXECUTING); an executing one stays so.
    pub(crate) async fn start_executing_goal(&self, g: Goal<G>) -> Result<Goal<G>, Text> {
        match (self, g) {
            (ActionServer::Dds(s), Goal::DdsAccepted(h)) => s
                .start_executing_goal(h)
                .await
                .map(Goal::DdsExecuting)
                .map_err(text),
            (ActionServer::Dds(_), g @ Goal::DdsExecuting(_)) => Ok(g),
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), Goal::Zenoh(id)) => {
                z.executing(&id);
                Ok(Goal::Zenoh(id))
            }
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("a goal of another transport".into())),
        }
    }

    /// Sends feedback of an executing goal.
    pub(crate) async fn publish_feedback(&self, g: &Goal<G>, f: F) -> Result<(), Text> {
        match (self, g) {
            (ActionServer::Dds(s), Goal::DdsExecuting(h)) => {
                s.publish_feedback(h.clone(), f).await.map_err(|e| {
                    Text(match e {
                        ros2_client::action::GoalError::NoSuchGoal => "no such goal".into(),
                        ros2_client::action::GoalError::WrongGoalState => "not executing".into(),
                        ros2_client::action::GoalError::DDSReadError(e) => e.to_string(),
                        ros2_client::action::GoalError::DDSWriteError(e) => e.to_string(),
                    })
                })
            }
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), Goal::Zenoh(id)) => z
                .server()
                .publish_feedback(*id, f)
                .map_err(|e| Text(e.to_string())),
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("not an executing goal".into())),
        }
    }

    /// Ends the goal with `status` and `result`: answers its result requests, those held and those to come
    /// (over DDS: resolves once a client asked for it).
    pub(crate) async fn send_result_response(
        &self,
        g: Goal<G>,
        status: GoalEndStatus,
        result: R,
    ) -> Result<(), Text> {
        let g = self.start_executing_goal(g).await?;
        match (self, g) {
            (ActionServer::Dds(s), Goal::DdsExecuting(h)) => s
                .send_result_response(h, status, result)
                .await
                .map_err(text),
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), Goal::Zenoh(id)) => z.finish(id, status, result),
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("a goal of another transport".into())),
        }
    }

    /// Answers result requests until the server closes (over Zenoh; over DDS ros2-client's server does, and
    /// this returns at once).
    pub(crate) async fn answer_results(&self) {
        #[cfg(feature = "zenoh")]
        if let ActionServer::Zenoh(z) = self {
            z.answer_results().await
        }
    }

    /// The next cancel request. An error: the server is closed.
    pub(crate) async fn receive_cancel_request(&self) -> Result<CancelRequest, Text> {
        match self {
            ActionServer::Dds(s) => s
                .receive_cancel_request()
                .await
                .map(CancelRequest::Dds)
                .map_err(text),
            #[cfg(feature = "zenoh")]
            ActionServer::Zenoh(z) => {
                let (req, goals) = z.receive_cancel_request().await?;
                Ok(CancelRequest::Zenoh(req, goals))
            }
        }
    }

    /// Answers a cancel request: `goals` (of those it names) are canceling (status CANCELING); none: rejected.
    pub(crate) async fn respond_to_cancel_requests(
        &self,
        c: &CancelRequest,
        goals: impl Iterator<Item = GoalId>,
    ) -> Result<(), Text> {
        match (self, c) {
            (ActionServer::Dds(s), CancelRequest::Dds(c)) => {
                s.respond_to_cancel_requests(c, goals).await.map_err(text)
            }
            #[cfg(feature = "zenoh")]
            (ActionServer::Zenoh(z), CancelRequest::Zenoh(req, _)) => z.answer_cancel(*req, goals),
            #[cfg_attr(not(feature = "zenoh"), allow(unreachable_patterns))]
            _ => Err(Text("a cancel request of another transport".into())),
        }
    }
}
