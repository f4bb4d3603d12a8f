//! An action server driven as a RADAR response, with no I/O: what one run of the response does with the goal it
//! sends, and how the run ends.
//!
//! A goal starts the response, a cancel interrupts it, the result ends it. The binding
//! (`radar_ros::action_response`) waits for the server, sends the goal, reads its answer and result, and asks a
//! [`GoalMachine`] (one per run) what each of them means for the run; the machine decides, the binding moves
//! the messages. The response itself (start policy, `started`/`interrupted`/`exited`, counters) is the
//! [`response`](crate::response) machine: these rules only say what its start, interrupt and exit slots do.
//!
//! The rules, A1-A7 (the `radar_ros` documentation of actions, the README and the tests use these numbers):
//!
//! - **A1.** `start(goal)` while idle → the goal is sent, once the server is matched both ways (waiting up to
//!   the server timeout; without a server the run fails and nothing is sent).
//! - **A2.** `started(goal)` goes out when the server **accepts** the goal (response rule R9), never before.
//! - **A3.** The server **rejects** the goal → the run fails (`goal rejected`): no `started`.
//! - **A4.** `interrupt` while the accepted goal runs → `interrupted` at once (the response's R3), then a cancel
//!   request; the result the server reports for the canceled (or meanwhile finished) goal is what `exited`
//!   carries.
//! - **A5.** `interrupt` before the server answered (also the `until` of the statement that sent the goal: the
//!   run is that statement's from the start, not from acceptance, R13) → the goal is canceled as soon as it is
//!   accepted, dropped if rejected, never sent if the server had not appeared yet; no `started`.
//! - **A6.** The run ends otherwise while the goal may still run (an `exit` signal, the response or its program
//!   stopping, a failure on this side such as a result that does not decode) → the exit slot cancels the goal
//!   (a goal left running would be an orphan), not when the server has left, and not twice.
//! - **A7.** The goal ends `SUCCEEDED` → the run completes with its result. It ends `ABORTED`, or `CANCELED` by
//!   someone else → the run fails, and `exited` carries the result. The server leaves the graph mid-goal → the
//!   run fails (`the action server left`), and nothing is canceled.
//!
//! ```
//! use radar_semantics::goal::{Answer, Cancel, GoalMachine, GoalStatus, RunEnd};
//! use radar_semantics::response::ExitReason;
//! let mut g = GoalMachine::new();
//! g.sent(); // A1
//! assert_eq!(g.answered(true), Answer::Started); // A2
//! assert_eq!(g.interrupt(), Cancel::Now); // A4
//! assert_eq!(g.exit(&ExitReason::Interrupted), Cancel::Nothing); // canceled once, not twice
//! assert_eq!(g.ended(GoalStatus::Canceled), RunEnd::Failed { status: GoalStatus::Canceled });
//! ```

use crate::response::ExitReason;

/// How a goal ended, as the server reports it with its result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GoalStatus {
    /// It reached its end.
    Succeeded,
    /// A cancel request ended it.
    Canceled,
    /// The server gave up on it.
    Aborted,
    /// A status that is no end (the server's error); taken as a failure.
    Unknown,
}

impl GoalStatus {
    /// Its name in the action protocol.
    pub fn label(self) -> &'static str {
        match self {
            GoalStatus::Succeeded => "SUCCEEDED",
            GoalStatus::Canceled => "CANCELED",
            GoalStatus::Aborted => "ABORTED",
            GoalStatus::Unknown => "UNKNOWN",
        }
    }
}

/// What the server's answer to the goal means for the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer {
    /// A2: accepted: the run says `started`, then asks for the result and forwards feedback.
    Started,
    /// A3: rejected: the run fails, without `started`.
    Rejected,
}

/// Whether, and when, a slot cancels the goal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cancel {
    /// Nothing to cancel: never sent, rejected, ended, the server left, or canceled already.
    Nothing,
    /// A4, A6: the goal was accepted and has not ended: cancel it now.
    Now,
    /// A5: the answer is still to come: wait for it, then cancel the goal if it was accepted (report the
    /// answer with [`GoalMachine::answered_late`]).
    OnceAccepted,
}

/// How the run ends, for what the server said of the goal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunEnd {
    /// A7: the goal succeeded: the run completes with its result.
    Completed,
    /// A7: the goal ended otherwise: the run fails, and `exited` carries the result.
    Failed {
        /// How the goal ended.
        status: GoalStatus,
    },
    /// A7: the server left the graph mid-goal: the run fails; nothing is canceled.
    ServerLeft,
}

/// What one run knows of its goal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GoalMachine {
    sent: bool,
    /// `Some(accepted)` once the server answered.
    answer: Option<bool>,
    /// Its result (or the server's leaving) has ended it: nothing left to cancel.
    ended: bool,
    server_left: bool,
    /// A slot has canceled it (or will, once accepted).
    canceled: bool,
}

impl GoalMachine {
    /// A1: a run begins: no goal sent yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// A1: the server is matched both ways and the goal went out.
    pub fn sent(&mut self) {
        self.sent = true;
    }

    /// A2, A3: the server answered the goal.
    pub fn answered(&mut self, accepted: bool) -> Answer {
        self.answer = Some(accepted);
        if accepted {
            Answer::Started
        } else {
            Answer::Rejected
        }
    }

    /// A5: the answer a [`Cancel::OnceAccepted`] waited for: whether to cancel now.
    pub fn answered_late(&mut self, accepted: bool) -> Cancel {
        self.answer = Some(accepted);
        if accepted && !self.ended && !self.server_left {
            Cancel::Now
        } else {
            Cancel::Nothing
        }
    }

    /// A7: the goal's result arrived with `status`.
    pub fn ended(&mut self, status: GoalStatus) -> RunEnd {
        self.ended = true;
        match status {
            GoalStatus::Succeeded => RunEnd::Completed,
            status => RunEnd::Failed { status },
        }
    }

    /// A7: the server left the graph while the goal was out.
    pub fn server_left(&mut self) -> RunEnd {
        self.server_left = true;
        RunEnd::ServerLeft
    }

    /// A4, A5: the interrupt slot runs: what it does with the goal.
    pub fn interrupt(&mut self) -> Cancel {
        self.cancel()
    }

    /// A6: the exit slot runs, for `reason`: whether it cancels the goal. A completed run's goal has ended; an
    /// interrupted run's was canceled by the interrupt slot (A4, A5); whatever else ended the run leaves no
    /// goal running behind it.
    pub fn exit(&mut self, reason: &ExitReason) -> Cancel {
        match reason {
            ExitReason::Completed | ExitReason::Interrupted => Cancel::Nothing,
            _ => self.cancel(),
        }
    }

    /// Whether the server may still be running the goal: sent, not rejected, not ended, the server there.
    pub fn may_run(&self) -> bool {
        self.sent && self.answer != Some(false) && !self.ended && !self.server_left
    }

    fn cancel(&mut self) -> Cancel {
        if !self.may_run() || self.canceled {
            return Cancel::Nothing;
        }
        self.canceled = true;
        match self.answer {
            Some(_) => Cancel::Now,
            None => Cancel::OnceAccepted,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn accepted() -> GoalMachine {
        let mut g = GoalMachine::new();
        g.sent();
        assert_eq!(g.answered(true), Answer::Started);
        g
    }

    #[test]
    fn a1_nothing_is_canceled_before_the_goal_is_sent() {
        let mut g = GoalMachine::new();
        assert!(!g.may_run());
        assert_eq!(g.interrupt(), Cancel::Nothing);
        assert_eq!(
            GoalMachine::new().exit(&ExitReason::ExitSignal),
            Cancel::Nothing
        );
    }

    #[test]
    fn a2_an_accepted_goal_starts_the_run() {
        let g = accepted();
        assert!(g.may_run());
    }

    #[test]
    fn a3_a_rejected_goal_fails_the_run_and_leaves_nothing_to_cancel() {
        let mut g = GoalMachine::new();
        g.sent();
        assert_eq!(g.answered(false), Answer::Rejected);
        assert!(!g.may_run());
        assert_eq!(
            g.exit(&ExitReason::Failed("goal rejected".into())),
            Cancel::Nothing
        );
    }

    #[test]
    fn a4_an_interrupt_of_an_accepted_goal_cancels_it_once() {
        let mut g = accepted();
        assert_eq!(g.interrupt(), Cancel::Now);
        assert_eq!(g.interrupt(), Cancel::Nothing, "not twice");
        assert_eq!(
            g.exit(&ExitReason::ExitSignal),
            Cancel::Nothing,
            "not again at exit"
        );
        assert_eq!(
            g.ended(GoalStatus::Canceled),
            RunEnd::Failed {
                status: GoalStatus::Canceled
            }
        );
    }

    #[test]
    fn a5_an_interrupt_before_the_answer_cancels_once_accepted_or_drops_a_rejected_goal() {
        let mut g = GoalMachine::new();
        g.sent();
        assert_eq!(g.interrupt(), Cancel::OnceAccepted);
        assert_eq!(g.answered_late(true), Cancel::Now);
        let mut g = GoalMachine::new();
        g.sent();
        assert_eq!(g.interrupt(), Cancel::OnceAccepted);
        assert_eq!(g.answered_late(false), Cancel::Nothing);
        // the server left while the answer was awaited
        let mut g = GoalMachine::new();
        g.sent();
        assert_eq!(g.interrupt(), Cancel::OnceAccepted);
        assert_eq!(g.server_left(), RunEnd::ServerLeft);
        assert_eq!(g.answered_late(true), Cancel::Nothing);
    }

    #[test]
    fn a6_an_exit_leaves_no_goal_running_whatever_ended_the_run() {
        for reason in [
            ExitReason::ExitSignal,
            ExitReason::Failed("the goal's result did not arrive".into()),
            ExitReason::Failed("the feedback stream ended".into()),
            ExitReason::Panicked("boom".into()),
        ] {
            assert_eq!(accepted().exit(&reason), Cancel::Now, "{reason:?}");
            let mut unanswered = GoalMachine::new();
            unanswered.sent();
            assert_eq!(unanswered.exit(&reason), Cancel::OnceAccepted, "{reason:?}");
        }
        // the interrupt slot canceled it, or it ended
        assert_eq!(accepted().exit(&ExitReason::Interrupted), Cancel::Nothing);
        assert_eq!(accepted().exit(&ExitReason::Completed), Cancel::Nothing);
        let mut ended = accepted();
        let _ = ended.ended(GoalStatus::Aborted);
        assert_eq!(ended.exit(&ExitReason::ExitSignal), Cancel::Nothing);
        let mut left = accepted();
        let _ = left.server_left();
        assert_eq!(left.exit(&ExitReason::ExitSignal), Cancel::Nothing);
    }

    #[test]
    fn a7_the_goals_end_says_how_the_run_ends() {
        assert_eq!(accepted().ended(GoalStatus::Succeeded), RunEnd::Completed);
        for status in [
            GoalStatus::Aborted,
            GoalStatus::Canceled,
            GoalStatus::Unknown,
        ] {
            assert_eq!(accepted().ended(status), RunEnd::Failed { status });
        }
        assert_eq!(accepted().server_left(), RunEnd::ServerLeft);
        assert_eq!(GoalStatus::Aborted.label(), "ABORTED");
    }
}
