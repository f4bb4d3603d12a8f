//! The goal table of an action server over Zenoh (`zenoh` feature): what ros2-client's DDS
//! `AsyncActionServer` keeps for a DDS server, kept here for ros2-client's Zenoh `ActionServer` (which has
//! only the queryables and publishers): goal statuses, published on each change; results, kept for the last
//! [`ENDED_KEPT`] ended goals; result requests held until their goal ends.

use std::{collections::BTreeMap, sync::Mutex};

use ros2_client::{
    action::{GoalEndStatus, GoalId},
    action_msgs::{GoalInfo, GoalStatus, GoalStatusEnum},
    builtin_interfaces::Time,
    RmwRequestId,
};

use crate::error::Text;

/// How many ended goals the table keeps, to answer a late result request and list in its status.
const ENDED_KEPT: usize = 16;

/// What the table knows of a goal.
struct Known<R> {
    status: GoalStatusEnum,
    accepted: Time,
    /// Its end's status code and result, once it ended.
    result: Option<(i8, R)>,
    /// Result requests held until it ends.
    waiting: Vec<RmwRequestId>,
    /// When it ended, in the order of ends (for forgetting the oldest).
    ended: u64,
}

/// The goals, with the rules of ros2-client's DDS `AsyncActionServer`: a cancel names accepted or executing
/// goals (by id, all, or all accepted at or before a time: action_msgs/srv/CancelGoal's policy); a result
/// request for a goal not known is answered UNKNOWN.
#[derive(Default)]
struct Table<R> {
    goals: BTreeMap<GoalId, Known<R>>,
    ends: u64,
}

impl<R: Clone + Default> Table<R> {
    fn accepted(&mut self, id: GoalId, at: Time) {
        let known = Known {
            status: GoalStatusEnum::Accepted,
            accepted: at,
            result: None,
            waiting: Vec::new(),
            ended: 0,
        };
        self.goals.insert(id, known);
    }

    /// Marks an accepted goal executing (a canceling or ended one stays so); whether it changed.
    fn executing(&mut self, id: &GoalId) -> bool {
        match self.goals.get_mut(id) {
            Some(k) if k.status == GoalStatusEnum::Accepted => {
                k.status = GoalStatusEnum::Executing;
                true
            }
            _ => false,
        }
    }

    /// The accepted or executing goals `info` names.
    fn named(&self, info: &GoalInfo) -> Vec<GoalId> {
        let zero_stamp = info.stamp.to_nanos() == 0;
        let by_time = |k: &Known<R>| !zero_stamp && k.accepted.to_nanos() <= info.stamp.to_nanos();
        self.goals
            .iter()
            .filter(|(_, k)| {
                matches!(
                    k.status,
                    GoalStatusEnum::Accepted | GoalStatusEnum::Executing
                )
            })
            .filter(|(id, k)| match info.goal_id == GoalId::ZERO {
                true => zero_stamp || by_time(k),
                false => **id == info.goal_id || by_time(k),
            })
            .map(|(id, _)| *id)
            .collect()
    }

    /// Marks `goals` (those still running) canceling; what the cancel's answer lists.
    fn canceling(&mut self, goals: impl Iterator<Item = GoalId>) -> Vec<GoalInfo> {
        goals
            .filter_map(|id| {
                let k = self.goals.get_mut(&id).filter(|k| k.result.is_none())?;
                k.status = GoalStatusEnum::Canceling;
                Some(GoalInfo {
                    goal_id: id,
                    stamp: k.accepted,
                })
            })
            .collect()
    }

    /// Ends goal `id` with `status`: the result requests held for it (`None`: no such goal).
    fn end(&mut self, id: &GoalId, status: GoalStatusEnum, result: R) -> Option<Vec<RmwRequestId>> {
        self.ends += 1;
        let k = self.goals.get_mut(id)?;
        k.status = status;
        k.result = Some((status as i8, result));
        k.ended = self.ends;
        let waiting = std::mem::take(&mut k.waiting);
        self.forget_oldest();
        Some(waiting)
    }

    /// A result request for `id`: answered now (the goal ended, or is not known), or held (`None`).
    fn result_asked(&mut self, id: &GoalId, req: RmwRequestId) -> Option<(i8, R)> {
        match self.goals.get_mut(id) {
            Some(k) => match &k.result {
                Some(r) => Some(r.clone()),
                None => {
                    k.waiting.push(req);
                    None
                }
            },
            None => Some((GoalStatusEnum::Unknown as i8, R::default())),
        }
    }

    /// Forgets the goals that ended longest ago, beyond [`ENDED_KEPT`].
    fn forget_oldest(&mut self) {
        let mut ended: Vec<(u64, GoalId)> = self
            .goals
            .iter()
            .filter(|(_, k)| k.result.is_some())
            .map(|(id, k)| (k.ended, *id))
            .collect();
        if ended.len() > ENDED_KEPT {
            ended.sort_unstable();
            for (_, id) in &ended[..ended.len() - ENDED_KEPT] {
                self.goals.remove(id);
            }
        }
    }

    fn statuses(&self) -> Vec<GoalStatus> {
        self.goals
            .iter()
            .map(|(id, k)| GoalStatus {
                goal_info: GoalInfo {
                    goal_id: *id,
                    stamp: k.accepted,
                },
                status: k.status,
            })
            .collect()
    }
}

/// An action server over Zenoh: ros2-client's queryables and publishers, and the goal [`Table`].
pub(crate) struct ZenohGoals<G, R, F> {
    server: ros2_client::zenoh::ActionServer<G, R, F>,
    table: Mutex<Table<R>>,
}

impl<G, R, F> ZenohGoals<G, R, F>
where
    G: serde::de::DeserializeOwned + Send + Sync + 'static,
    R: serde::Serialize + Clone + Default + Send + Sync + 'static,
    F: serde::Serialize + Send + Sync + 'static,
{
    /// The server `server`, serving no goal yet.
    pub(crate) fn new(server: ros2_client::zenoh::ActionServer<G, R, F>) -> Self {
        ZenohGoals {
            server,
            table: Mutex::new(Table {
                goals: BTreeMap::new(),
                ends: 0,
            }),
        }
    }

    /// ros2-client's server, for what needs no table (feedback).
    pub(crate) fn server(&self) -> &ros2_client::zenoh::ActionServer<G, R, F> {
        &self.server
    }

    /// The next goal request that decodes (one that does not has no id to answer: it goes unanswered);
    /// an error: the server is closed.
    pub(crate) async fn receive_new_goal(&self) -> Result<(RmwRequestId, GoalId, G), Text> {
        loop {
            match self.server.async_receive_goal().await {
                Ok(goal) => return Ok(goal),
                Err(ros2_client::ServiceError::NoReply) => return Err(Text("closed".into())),
                Err(e) => {
                    tracing::warn!(error = %crate::error::Report(&e), "a goal request that does not decode: dropped")
                }
            }
        }
    }

    /// The next cancel request that decodes, with the goals it names; an error: the server is closed.
    pub(crate) async fn receive_cancel_request(&self) -> Result<(RmwRequestId, Vec<GoalId>), Text> {
        loop {
            match self.server.async_receive_cancel().await {
                Ok((req, info)) => {
                    let named = self.table.lock().unwrap().named(&info);
                    return Ok((req, named));
                }
                Err(ros2_client::ServiceError::NoReply) => return Err(Text("closed".into())),
                Err(e) => {
                    tracing::warn!(error = %crate::error::Report(&e), "a cancel request that does not decode: dropped")
                }
            }
        }
    }

    /// Answers goal request `req`; an accepted goal enters the table (status ACCEPTED).
    pub(crate) fn answer_goal(
        &self,
        req: RmwRequestId,
        id: GoalId,
        accepted: bool,
    ) -> Result<(), Text> {
        if accepted {
            self.table.lock().unwrap().accepted(id, Time::now());
        }
        let answered = self
            .server
            .respond_goal(req, accepted)
            .map_err(|e| Text(e.to_string()));
        if accepted {
            self.publish_status();
        }
        answered
    }

    /// Marks an accepted goal executing (status EXECUTING).
    pub(crate) fn executing(&self, id: &GoalId) {
        if self.table.lock().unwrap().executing(id) {
            self.publish_status();
        }
    }

    /// Answers cancel request `req`: `goals` still running are canceling (status CANCELING); none: rejected.
    pub(crate) fn answer_cancel(
        &self,
        req: RmwRequestId,
        goals: impl Iterator<Item = GoalId>,
    ) -> Result<(), Text> {
        let canceling = self.table.lock().unwrap().canceling(goals);
        self.publish_status();
        let code = if canceling.is_empty() {
            ros2_client::action_msgs::CancelGoalResponseEnum::Rejected
        } else {
            ros2_client::action_msgs::CancelGoalResponseEnum::None
        };
        self.server
            .respond_cancel(req, code, canceling)
            .map_err(|e| Text(e.to_string()))
    }

    /// Ends goal `id`: answers the result requests held for it, keeps the result for those to come.
    pub(crate) fn finish(&self, id: GoalId, status: GoalEndStatus, result: R) -> Result<(), Text> {
        let status = match status {
            GoalEndStatus::Succeeded => GoalStatusEnum::Succeeded,
            GoalEndStatus::Canceled => GoalStatusEnum::Canceled,
            GoalEndStatus::Aborted => GoalStatusEnum::Aborted,
        };
        let waiting = self.table.lock().unwrap().end(&id, status, result.clone());
        let waiting = waiting.ok_or_else(|| Text("no such goal".into()))?;
        self.publish_status();
        for req in waiting {
            self.server
                .respond_result(req, status as i8, result.clone())
                .map_err(|e| Text(e.to_string()))?;
        }
        Ok(())
    }

    /// Reads result requests until the server closes: answers those of ended (or unknown) goals at once,
    /// holds the others until [`Self::finish`].
    pub(crate) async fn answer_results(&self) {
        loop {
            let (req, id) = match self.server.async_receive_result_request().await {
                Ok(r) => r,
                Err(ros2_client::ServiceError::NoReply) => return,
                Err(e) => {
                    tracing::warn!(error = %crate::error::Report(&e), "a result request that does not decode: dropped");
                    continue;
                }
            };
            let now = self.table.lock().unwrap().result_asked(&id, req);
            if let Some((code, result)) = now {
                if let Err(e) = self.server.respond_result(req, code, result) {
                    tracing::debug!(error = %crate::error::Report(&e), "a result request not answered");
                }
            }
        }
    }

    fn publish_status(&self) {
        let list = self.table.lock().unwrap().statuses();
        if let Err(e) = self.server.publish_status(list) {
            tracing::debug!(error = %crate::error::Report(&e), "goal statuses not published");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Goal ids in the table's order: `ids()[n]` sorts before `ids()[n + 1]`.
    fn ids() -> Vec<GoalId> {
        let mut ids: Vec<GoalId> = (0..64).map(|_| GoalId::new_random()).collect();
        ids.sort();
        ids
    }

    fn req(n: i64) -> RmwRequestId {
        RmwRequestId {
            writer_gid: ros2_client::Gid::from([1; 16]),
            sequence_number: n,
        }
    }

    fn at(s: i64) -> Time {
        Time::from_nanos(s * 1_000_000_000)
    }

    fn info(goal: GoalId, stamp: Time) -> GoalInfo {
        GoalInfo {
            goal_id: goal,
            stamp,
        }
    }

    #[test]
    fn a_cancel_names_running_goals_by_id_all_or_accepted_at_or_before_a_time() {
        let ids = ids();
        let id = |n: u8| ids[usize::from(n)];
        let mut t = Table::<i32>::default();
        t.accepted(id(1), at(10));
        t.accepted(id(2), at(20));
        t.accepted(id(3), at(30));
        assert!(t.executing(&id(2)));
        t.end(&id(3), GoalStatusEnum::Succeeded, 7);
        // by id (a zero stamp), all (zero id and stamp), by time (zero id), by id or time
        assert_eq!(t.named(&info(id(2), Time::ZERO)), vec![id(2)]);
        assert_eq!(t.named(&info(GoalId::ZERO, Time::ZERO)), vec![id(1), id(2)]);
        assert_eq!(t.named(&info(GoalId::ZERO, at(15))), vec![id(1)]);
        assert_eq!(t.named(&info(id(2), at(10))), vec![id(1), id(2)]);
        // an ended goal is named by nothing; a goal not known, neither
        assert!(t.named(&info(id(3), Time::ZERO)).is_empty());
        assert!(t.named(&info(id(9), Time::ZERO)).is_empty());
        // canceling: listed with its acceptance time, no longer executing
        let c = t.canceling([id(2), id(3)].into_iter());
        assert_eq!(c.len(), 1);
        assert_eq!((c[0].goal_id, c[0].stamp), (id(2), at(20)));
        assert!(
            !t.executing(&id(2)),
            "a canceling goal does not execute again"
        );
        assert!(t.named(&info(id(2), Time::ZERO)).is_empty());
    }

    #[test]
    fn a_result_request_is_held_until_its_goal_ends_and_answered_after() {
        let ids = ids();
        let id = |n: u8| ids[usize::from(n)];
        let mut t = Table::<i32>::default();
        t.accepted(id(1), at(1));
        assert_eq!(t.result_asked(&id(1), req(1)), None, "held");
        assert_eq!(t.result_asked(&id(1), req(2)), None, "held");
        let held = t.end(&id(1), GoalStatusEnum::Canceled, 5).unwrap();
        assert_eq!(held, vec![req(1), req(2)]);
        assert_eq!(
            t.result_asked(&id(1), req(3)),
            Some((GoalStatusEnum::Canceled as i8, 5)),
            "a late request is answered with the kept result"
        );
        assert_eq!(
            t.result_asked(&id(9), req(4)),
            Some((GoalStatusEnum::Unknown as i8, 0)),
            "a goal not known: UNKNOWN"
        );
        assert!(t.end(&id(9), GoalStatusEnum::Aborted, 0).is_none());
    }

    #[test]
    fn the_table_keeps_the_last_ended_goals_and_every_running_one() {
        let ids = ids();
        let id = |n: u8| ids[usize::from(n)];
        let mut t = Table::<i32>::default();
        t.accepted(id(63), at(1));
        for n in 0..(ENDED_KEPT as u8 + 5) {
            t.accepted(id(n), at(2));
            t.end(&id(n), GoalStatusEnum::Succeeded, i32::from(n));
        }
        assert_eq!(t.goals.len(), ENDED_KEPT + 1);
        assert!(t.goals.contains_key(&id(63)), "the running goal stays");
        assert!(!t.goals.contains_key(&id(4)), "the oldest ended ones go");
        assert!(t.goals.contains_key(&id(5)));
        let statuses = t.statuses();
        assert_eq!(statuses.len(), ENDED_KEPT + 1);
    }
}
