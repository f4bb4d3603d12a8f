//! A response served as a ROS 2 action server, with no I/O: which goals are accepted, what a cancel does, and
//! how each goal ends.
//!
//! The binding (`radar_ros::action`) reads goals, cancel requests, the response's `started`, `exited`,
//! `feedback` and `state`, feeds them to a [`ServedAction`] and carries out the [`Effect`]s it returns, in order
//! (accepting and rejecting goals, starting and interrupting the response, sending results). Times are ns since
//! the epoch, as the response rules use them.
//!
//! The rules, S1-S7 (the `radar_ros` documentation of actions, the README and the tests use these numbers):
//!
//! - **S1.** A goal while the response is idle, on the graph, and no goal of this server is running or ending
//!   → accepted, then the response is started with it; its start carries a [`Cause`] of this server's own
//!   statement (R13). The goal is *executing* when the response says `started`.
//! - **S2.** A goal while a goal runs (or is ending), or while the response is busy or not on the graph →
//!   rejected (a response runs one thing at a time: cancel the first goal, or wait for its result).
//! - **S3.** A cancel request that covers the running goal → the goal is canceling (the request is answered with
//!   it), then the response is interrupted; if the response says `started` after that (the interrupt may have
//!   overtaken the start on another topic, and an idle response ignores it), it is interrupted again. The
//!   goal ends `Canceled` with `exited`'s payload. A cancel that covers no running goal is answered with none.
//! - **S4.** `exited` of the goal's run, not canceled → the goal ends when the state that follows it tells why
//!   the run ended (state and `exited` travel on two topics: that state may have been read already): `Succeeded` (with `exited`'s payload) after a completed run, else `Aborted` (failed,
//!   panicked, interrupted by someone else, exit signal). If no such state comes within
//!   [`Timing::reason_within`] (a response without a state topic), `Aborted`.
//! - **S5.** Feedback goes to the executing goal only.
//! - **S6.** The goal is `Aborted` (with the default result) if the response ignores its start (its
//!   `ignored_starts` grows before `started`), does not say `started` within [`Timing::started_within`], leaves
//!   the graph, or the server stops (the response is interrupted then).
//! - **S7.** Only the run the goal started answers it: its `started` and `exited` carry the goal's cause back. A
//!   `started` or `exited` of another run (another statement's) does not touch the goal. A response that carries
//!   no causes (rclpy) is taken at its word: its next `started` and `exited` are the goal's.
//!
//! ```
//! use radar_semantics::served::{Effect, EndStatus, ResponseView, ServedAction};
//! use radar_semantics::response::ExitReason;
//! let mut s = ServedAction::<u32, &str>::new(7 << 64);
//! let idle = ResponseView { idle: true, on_graph: true, ..ResponseView::default() };
//! let fx = s.goal(1, &idle, 100);
//! let Effect::Accept { start, .. } = fx[0] else { panic!() };
//! assert!(matches!(s.started(&start, true, 200)[..], [Effect::Execute(1)]));
//! assert!(s.exited("done", &start, true, &idle, 300).is_empty()); // why did the run end?
//! let after = ResponseView { exits: 1, last_exit: Some(ExitReason::Completed), ..idle };
//! assert!(matches!(
//!     s.state(&after, 310)[..],
//!     [Effect::Finish { goal: 1, status: EndStatus::Succeeded, result: Some("done") }]
//! ));
//! ```

use crate::response::{Cause, ExitReason, Sent, StatementId};

/// What the server knows of the response, from its `state` topic and its `start` topic's matches.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ResponseView {
    /// Its state says idle (or it publishes none).
    pub idle: bool,
    /// Its start slot is matched: it is on the graph.
    pub on_graph: bool,
    /// Runs that reached `exited` (the state's counter).
    pub exits: u64,
    /// Starts it ignored (the state's counter).
    pub ignored_starts: u64,
    /// Why its last run ended, if one has.
    pub last_exit: Option<ExitReason>,
}

/// How a goal ended, as the action protocol names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EndStatus {
    /// S4: the run completed.
    Succeeded,
    /// S3: a cancel request ended it.
    Canceled,
    /// S4, S6: anything else.
    Aborted,
}

/// What the binding must do, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
#[must_use = "the binding must carry out every effect"]
pub enum Effect<G, R> {
    /// S1: accept the goal, then publish the response's `start` with the goal, sent as `start`.
    Accept {
        /// The goal.
        goal: G,
        /// When and by which cause the start is sent.
        start: Sent,
    },
    /// S2: reject the goal.
    Reject(G),
    /// S3: answer the cancel request: these goals are canceling (none: it covered no running goal).
    AnswerCancel(Vec<G>),
    /// S3, S6: publish the response's `interrupt`, sent as this (it names this server's statement, R13).
    Interrupt(Sent),
    /// S1: the goal's run said `started`: the goal is executing.
    Execute(G),
    /// S3, S4, S6: send the goal's result with this status (`None`: the result type's default).
    Finish {
        /// The goal.
        goal: G,
        /// Its status.
        status: EndStatus,
        /// Its result.
        result: Option<R>,
    },
}

/// How long the server waits for the response.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timing {
    /// S6: for `started` after the goal's start was sent, in ns (default 5 s).
    pub started_within: i64,
    /// S4: for the state that says why the goal's run ended, after its `exited`, in ns (default 1 s).
    pub reason_within: i64,
}

impl Default for Timing {
    fn default() -> Timing {
        Timing {
            started_within: 5_000_000_000,
            reason_within: 1_000_000_000,
        }
    }
}

/// The goal being run.
#[derive(Clone, Debug)]
struct Running<G> {
    id: G,
    cause: Cause,
    executing: bool,
    canceling: bool,
    /// The response's counters when the goal was accepted.
    exits_before: u64,
    ignored_before: u64,
    /// S6: when `started` is overdue.
    started_by: i64,
}

/// A goal whose run has sent `exited`, waiting for the state that says why (S4).
#[derive(Clone, Debug)]
struct Ending<G, R> {
    id: G,
    result: R,
    exits_before: u64,
    until: i64,
}

/// One action server's goals (rules S1-S7); `G` identifies a goal, `R` is the result type.
#[derive(Clone, Debug)]
pub struct ServedAction<G, R> {
    statement: StatementId,
    timing: Timing,
    goals: u64,
    running: Option<Running<G>>,
    ending: Option<Ending<G, R>>,
}

impl<G: Clone + PartialEq, R> ServedAction<G, R> {
    /// A server whose starts carry causes of `statement` (unique on the graph, R13).
    pub fn new(statement: StatementId) -> Self {
        Self::with_timing(statement, Timing::default())
    }

    /// [`ServedAction::new`] with other waits.
    pub fn with_timing(statement: StatementId, timing: Timing) -> Self {
        ServedAction {
            statement,
            timing,
            goals: 0,
            running: None,
            ending: None,
        }
    }

    /// The goal that is running or ending, if any.
    pub fn current(&self) -> Option<&G> {
        self.running
            .as_ref()
            .map(|r| &r.id)
            .or(self.ending.as_ref().map(|e| &e.id))
    }

    /// Whether a goal's run has not ended yet (the response leaving aborts it, S6).
    pub fn goal_running(&self) -> bool {
        self.running.is_some()
    }

    /// S5: the goal feedback goes to: the executing one.
    pub fn feedback_goal(&self) -> Option<&G> {
        self.running.as_ref().filter(|r| r.executing).map(|r| &r.id)
    }

    /// When [`ServedAction::tick`] has something to do (a goal waiting for `started` or for its reason).
    pub fn next_deadline(&self) -> Option<i64> {
        let started = self
            .running
            .as_ref()
            .filter(|r| !r.executing)
            .map(|r| r.started_by);
        let reason = self.ending.as_ref().map(|e| e.until);
        match (started, reason) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// S1, S2: a goal arrives while the response looks like `response`.
    #[must_use = "the binding must carry out every effect"]
    pub fn goal(&mut self, id: G, response: &ResponseView, now: i64) -> Vec<Effect<G, R>> {
        if self.current().is_some() || !response.idle || !response.on_graph {
            return vec![Effect::Reject(id)];
        }
        self.goals += 1;
        let cause = Cause {
            statement: self.statement,
            delivery: self.goals,
        };
        self.running = Some(Running {
            id: id.clone(),
            cause,
            executing: false,
            canceling: false,
            exits_before: response.exits,
            ignored_before: response.ignored_starts,
            started_by: now.saturating_add(self.timing.started_within),
        });
        vec![Effect::Accept {
            goal: id,
            start: Sent::by(now, cause),
        }]
    }

    /// The binding could not accept the goal it was told to (the transport failed): it is forgotten.
    pub fn accept_failed(&mut self, id: &G) {
        if self.running.as_ref().is_some_and(|r| r.id == *id) {
            self.running = None;
        }
    }

    /// S3: a cancel request; `covers` says which goals it names (by id, by time, or all).
    #[must_use = "the binding must carry out every effect"]
    pub fn cancel(&mut self, covers: impl Fn(&G) -> bool, now: i64) -> Vec<Effect<G, R>> {
        let interrupt = self.interrupt(now);
        match self
            .running
            .as_mut()
            .filter(|r| !r.canceling && covers(&r.id))
        {
            Some(r) => {
                r.canceling = true;
                vec![Effect::AnswerCancel(vec![r.id.clone()]), interrupt]
            }
            None => vec![Effect::AnswerCancel(Vec::new())],
        }
    }

    /// S1, S3, S7: the response said `started`, sent as `sent`; `keeps_causes`: it is a RADAR response (it
    /// publishes its state), so its signals carry their run's cause.
    #[must_use = "the binding must carry out every effect"]
    pub fn started(&mut self, sent: &Sent, keeps_causes: bool, now: i64) -> Vec<Effect<G, R>> {
        let interrupt = self.interrupt(now);
        let Some(r) = self
            .running
            .as_mut()
            .filter(|r| owns(r, sent, keeps_causes))
        else {
            return Vec::new();
        };
        let mut fx = Vec::new();
        if !r.executing {
            r.executing = true;
            fx.push(Effect::Execute(r.id.clone()));
        }
        if r.canceling {
            fx.push(interrupt);
        }
        fx
    }

    /// S3, S4, S7: the response said `exited` with `result`, sent as `sent`; `response` is what its last state
    /// read says (the state that follows `exited` may have been read before it).
    #[must_use = "the binding must carry out every effect"]
    pub fn exited(
        &mut self,
        result: R,
        sent: &Sent,
        keeps_causes: bool,
        response: &ResponseView,
        now: i64,
    ) -> Vec<Effect<G, R>> {
        let Some(r) = self.running.take_if(|r| owns(r, sent, keeps_causes)) else {
            return Vec::new();
        };
        if r.canceling {
            return vec![finish(r.id, EndStatus::Canceled, Some(result))];
        }
        self.ending = Some(Ending {
            id: r.id,
            result,
            exits_before: r.exits_before,
            until: now.saturating_add(self.timing.reason_within),
        });
        self.state(response, now)
    }

    /// S4, S6: the response's state changed.
    #[must_use = "the binding must carry out every effect"]
    pub fn state(&mut self, response: &ResponseView, _now: i64) -> Vec<Effect<G, R>> {
        if let Some(e) = self.ending.take_if(|e| response.exits > e.exits_before) {
            let status = match response.last_exit {
                Some(ExitReason::Completed) => EndStatus::Succeeded,
                _ => EndStatus::Aborted,
            };
            return vec![finish(e.id, status, Some(e.result))];
        }
        match self
            .running
            .take_if(|r| !r.executing && response.ignored_starts > r.ignored_before)
        {
            Some(r) => vec![finish(r.id, EndStatus::Aborted, None)],
            None => Vec::new(),
        }
    }

    /// S4, S6: time passed; call it at [`ServedAction::next_deadline`].
    #[must_use = "the binding must carry out every effect"]
    pub fn tick(&mut self, now: i64) -> Vec<Effect<G, R>> {
        let mut fx = Vec::new();
        if let Some(e) = self.ending.take_if(|e| now >= e.until) {
            fx.push(finish(e.id, EndStatus::Aborted, Some(e.result)));
        }
        if let Some(r) = self
            .running
            .take_if(|r| !r.executing && now >= r.started_by)
        {
            fx.push(finish(r.id, EndStatus::Aborted, None));
        }
        fx
    }

    /// S6: the response left the graph.
    #[must_use = "the binding must carry out every effect"]
    pub fn response_gone(&mut self) -> Vec<Effect<G, R>> {
        match self.running.take() {
            Some(r) => vec![finish(r.id, EndStatus::Aborted, None)],
            None => Vec::new(),
        }
    }

    /// S6: the server stops: a running goal's run is interrupted and the goal aborted; a goal that is ending
    /// ends with what is known.
    #[must_use = "the binding must carry out every effect"]
    pub fn stop(&mut self, now: i64) -> Vec<Effect<G, R>> {
        let mut fx = Vec::new();
        if let Some(r) = self.running.take() {
            fx.push(self.interrupt(now));
            fx.push(finish(r.id, EndStatus::Aborted, None));
        }
        if let Some(e) = self.ending.take() {
            fx.push(finish(e.id, EndStatus::Aborted, Some(e.result)));
        }
        fx
    }

    /// An interrupt for this server's goal's run only (R13: it names the statement).
    fn interrupt(&self, now: i64) -> Effect<G, R> {
        Effect::Interrupt(Sent::by(
            now,
            Cause {
                statement: self.statement,
                delivery: 0,
            },
        ))
    }
}

/// S7: whether a `started` or `exited` sent as `sent` is the goal's run's.
fn owns<G>(r: &Running<G>, sent: &Sent, keeps_causes: bool) -> bool {
    match sent.by {
        Some(c) => c == r.cause,
        None => !keeps_causes,
    }
}

fn finish<G, R>(goal: G, status: EndStatus, result: Option<R>) -> Effect<G, R> {
    Effect::Finish {
        goal,
        status,
        result,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: StatementId = 9 << 64;

    fn idle() -> ResponseView {
        ResponseView {
            idle: true,
            on_graph: true,
            ..ResponseView::default()
        }
    }

    fn accepted(s: &mut ServedAction<u32, &'static str>, id: u32, now: i64) -> Sent {
        match &s.goal(id, &idle(), now)[..] {
            [Effect::Accept { goal, start }] if *goal == id => *start,
            fx => panic!("{fx:?}"),
        }
    }

    #[test]
    fn s1_s2_one_goal_at_a_time_and_only_to_an_idle_response_on_the_graph() {
        let mut s = ServedAction::<u32, &str>::new(S);
        let busy = ResponseView {
            idle: false,
            ..idle()
        };
        let gone = ResponseView {
            on_graph: false,
            ..idle()
        };
        assert_eq!(s.goal(1, &busy, 0), [Effect::Reject(1)]);
        assert_eq!(s.goal(1, &gone, 0), [Effect::Reject(1)]);
        let start = accepted(&mut s, 2, 10);
        assert_eq!(
            start.by,
            Some(Cause {
                statement: S,
                delivery: 1
            })
        );
        assert_eq!(s.goal(3, &idle(), 20), [Effect::Reject(3)]);
        // the next goal's start carries the next delivery
        let _ = s.exited("r", &start, true, &idle(), 30);
        let _ = s.state(
            &ResponseView {
                exits: 1,
                last_exit: Some(ExitReason::Completed),
                ..idle()
            },
            31,
        );
        assert_eq!(accepted(&mut s, 4, 40).by.unwrap().delivery, 2);
    }

    #[test]
    fn s3_a_cancel_interrupts_the_goals_run_and_ends_it_canceled() {
        let mut s = ServedAction::<u32, &str>::new(S);
        let start = accepted(&mut s, 1, 0);
        assert_eq!(s.cancel(|g| *g == 2, 5), [Effect::AnswerCancel(vec![])]);
        let fx = s.cancel(|g| *g == 1, 6);
        assert_eq!(fx[0], Effect::AnswerCancel(vec![1]));
        assert!(matches!(
            fx[1],
            Effect::Interrupt(Sent {
                at: 6,
                by: Some(Cause {
                    statement: S,
                    delivery: 0
                })
            })
        ));
        // the interrupt overtook the start: started comes after it, so the run is interrupted again
        let fx = s.started(&start, true, 7);
        assert!(matches!(fx[..], [Effect::Execute(1), Effect::Interrupt(_)]));
        assert_eq!(
            s.cancel(|_| true, 8),
            [Effect::AnswerCancel(vec![])],
            "already canceling"
        );
        assert_eq!(
            s.exited("partial", &start, true, &idle(), 9),
            [finish(1, EndStatus::Canceled, Some("partial"))]
        );
    }

    #[test]
    fn s4_the_state_after_exited_says_how_the_goal_ended() {
        for (reason, status) in [
            (Some(ExitReason::Completed), EndStatus::Succeeded),
            (Some(ExitReason::Failed("no".into())), EndStatus::Aborted),
            (Some(ExitReason::Interrupted), EndStatus::Aborted),
            (Some(ExitReason::ExitSignal), EndStatus::Aborted),
        ] {
            let mut s = ServedAction::<u32, &str>::new(S);
            let start = accepted(&mut s, 1, 0);
            let _ = s.started(&start, true, 1);
            assert!(s.exited("r", &start, true, &idle(), 2).is_empty());
            assert_eq!(s.goal(2, &idle(), 3), [Effect::Reject(2)], "still ending");
            // a state from before the exit does not decide
            assert!(s.state(&idle(), 3).is_empty());
            let after = ResponseView {
                exits: 1,
                last_exit: reason,
                ..idle()
            };
            assert_eq!(s.state(&after, 4), [finish(1, status, Some("r"))]);
        }
        // no state within the wait: aborted, with the result
        let mut s = ServedAction::<u32, &str>::new(S);
        let start = accepted(&mut s, 1, 0);
        let _ = s.started(&start, true, 1);
        let _ = s.exited("r", &start, true, &idle(), 2);
        assert_eq!(s.next_deadline(), Some(2 + 1_000_000_000));
        assert!(
            s.state(&idle(), 3).is_empty(),
            "a state from before the run ended"
        );
        assert!(s.tick(1_000_000_001).is_empty());
        assert_eq!(
            s.tick(1_000_000_002),
            [finish(1, EndStatus::Aborted, Some("r"))]
        );
    }

    #[test]
    fn s4_the_state_read_before_exited_decides_too() {
        let mut s = ServedAction::<u32, &str>::new(S);
        let start = accepted(&mut s, 1, 0);
        let _ = s.started(&start, true, 1);
        // the state that follows `exited` came first, on its own topic
        let after = ResponseView {
            exits: 1,
            last_exit: Some(ExitReason::Completed),
            ..idle()
        };
        assert!(s.state(&after, 2).is_empty(), "the run has not said exited");
        assert_eq!(
            s.exited("r", &start, true, &after, 3),
            [finish(1, EndStatus::Succeeded, Some("r"))]
        );
        assert_eq!(s.current(), None);
    }

    #[test]
    fn s5_feedback_goes_to_the_executing_goal_only() {
        let mut s = ServedAction::<u32, &str>::new(S);
        assert_eq!(s.feedback_goal(), None);
        let start = accepted(&mut s, 1, 0);
        assert_eq!(s.feedback_goal(), None, "accepted, not executing");
        let _ = s.started(&start, true, 1);
        assert_eq!(s.feedback_goal(), Some(&1));
    }

    #[test]
    fn s6_ignored_late_gone_or_stopped_goals_are_aborted() {
        let mut s = ServedAction::<u32, &str>::new(S);
        let _ = accepted(&mut s, 1, 0);
        let ignored = ResponseView {
            ignored_starts: 1,
            ..idle()
        };
        assert_eq!(s.state(&ignored, 1), [finish(1, EndStatus::Aborted, None)]);

        let _ = accepted(&mut s, 2, 10);
        assert_eq!(s.next_deadline(), Some(10 + 5_000_000_000));
        assert_eq!(
            s.tick(10 + 5_000_000_000),
            [finish(2, EndStatus::Aborted, None)]
        );

        let start = accepted(&mut s, 3, 20);
        let _ = s.started(&start, true, 21);
        assert!(
            s.tick(30 + 5_000_000_000).is_empty(),
            "executing: no deadline"
        );
        assert_eq!(s.response_gone(), [finish(3, EndStatus::Aborted, None)]);

        let _ = accepted(&mut s, 4, 40);
        let fx = s.stop(41);
        assert!(matches!(fx[0], Effect::Interrupt(_)));
        assert_eq!(fx[1], finish(4, EndStatus::Aborted, None));
    }

    #[test]
    fn s7_only_the_goals_run_answers_it() {
        let mut s = ServedAction::<u32, &str>::new(S);
        let start = accepted(&mut s, 1, 0);
        let other = Sent::by(
            1,
            Cause {
                statement: 5,
                delivery: 1,
            },
        );
        assert!(s.started(&other, true, 1).is_empty());
        assert!(s.started(&Sent::at(1), true, 1).is_empty(), "injected run");
        assert!(s.exited("theirs", &other, true, &idle(), 2).is_empty());
        assert_eq!(s.current(), Some(&1));
        assert_eq!(s.started(&start, true, 3), [Effect::Execute(1)]);
        // a response that carries no causes is taken at its word
        let mut s = ServedAction::<u32, &str>::new(S);
        let _ = accepted(&mut s, 1, 0);
        assert_eq!(s.started(&Sent::at(1), false, 1), [Effect::Execute(1)]);
    }
}
