//! Model-based test of the action-client rules A1-A7: random runs of an action-backed response (the goal sent
//! or not, answered or not, its result, the server leaving, an interrupt, the exit slot, in any order the
//! protocol allows), checked against what the rules promise a server, written here from the rule table in
//! `radar_semantics::goal`'s documentation, not from the machine: a goal is canceled at most once, only while it
//! may run, and never left running when the run ends (no orphan); `started` only for an accepted goal.

use proptest::prelude::*;
use radar_semantics::{
    goal::{Answer, Cancel, GoalMachine, GoalStatus, RunEnd},
    response::ExitReason,
};

#[derive(Clone, Debug)]
enum Op {
    Send,
    Answer(bool),
    Result(u8),
    ServerLeft,
    Interrupt,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        2 => Just(Op::Send),
        2 => any::<bool>().prop_map(Op::Answer),
        2 => (0u8..4).prop_map(Op::Result),
        1 => Just(Op::ServerLeft),
        1 => Just(Op::Interrupt),
    ]
}

fn status(code: u8) -> GoalStatus {
    match code {
        0 => GoalStatus::Succeeded,
        1 => GoalStatus::Canceled,
        2 => GoalStatus::Aborted,
        _ => GoalStatus::Unknown,
    }
}

/// What the server sees of the goal, as the rules describe it.
#[derive(Default, Debug)]
struct Server {
    sent: bool,
    /// The answer it gave, if it has.
    answer: Option<bool>,
    /// The goal reached its end there.
    ended: bool,
    left: bool,
    /// Cancel requests it received.
    cancels: u32,
    /// A slot waits for the answer to cancel the goal (A5).
    cancel_pending: bool,
    /// The run's start slot still runs (an interrupt cancels it, R3: later answers reach the cancel).
    start_running: bool,
    interrupted: bool,
    started: bool,
    /// How the run ended, if its start slot ended it.
    run_end: Option<RunEnd>,
}

impl Server {
    /// The server may still be working on the goal.
    fn running(&self) -> bool {
        self.sent && self.answer != Some(false) && !self.ended && !self.left
    }

    /// A slot's decision about cancelling, checked against the rules and carried out.
    fn carry_out(&mut self, c: Cancel) {
        match c {
            Cancel::Nothing => {}
            Cancel::Now => {
                assert!(
                    self.running(),
                    "a cancel for a goal that cannot run: {self:?}"
                );
                assert_eq!(
                    self.answer,
                    Some(true),
                    "a cancel before acceptance: {self:?}"
                );
                self.cancels += 1;
            }
            Cancel::OnceAccepted => {
                assert!(self.running() && self.answer.is_none(), "{self:?}");
                self.cancel_pending = true;
            }
        }
        assert!(self.cancels <= 1, "a goal canceled twice: {self:?}");
    }
}

fn run(ops: &[Op], exit_code: u8) {
    let mut m = GoalMachine::new();
    let mut s = Server {
        start_running: true,
        ..Server::default()
    };
    for op in ops {
        match op {
            // A1: the start slot sends the goal, once
            Op::Send if s.start_running && !s.sent => {
                m.sent();
                s.sent = true;
            }
            Op::Answer(accepted) if s.sent && s.answer.is_none() && !s.left => {
                s.answer = Some(*accepted);
                if s.start_running {
                    let a = m.answered(*accepted);
                    // A2, A3
                    assert_eq!(a == Answer::Started, *accepted);
                    s.started = *accepted;
                    if !accepted {
                        s.start_running = false;
                        s.run_end = Some(RunEnd::Failed {
                            status: GoalStatus::Aborted,
                        });
                    }
                } else if s.cancel_pending {
                    // A5: the interrupt's cancel waited for this answer
                    s.cancel_pending = false;
                    let c = m.answered_late(*accepted);
                    assert_eq!(c == Cancel::Now, *accepted, "A5: cancel once accepted");
                    s.carry_out(c);
                }
            }
            Op::Result(code) if s.answer == Some(true) && !s.ended && !s.left => {
                s.ended = true;
                if s.start_running {
                    let end = m.ended(status(*code));
                    // A7
                    assert_eq!(end == RunEnd::Completed, *code == 0);
                    s.start_running = false;
                    s.run_end = Some(end);
                } else {
                    // the canceled goal's result, handed to `exited` (A4)
                    let _ = m.ended(status(*code));
                }
            }
            Op::ServerLeft if s.sent && !s.left => {
                s.left = true;
                let end = m.server_left();
                assert_eq!(end, RunEnd::ServerLeft);
                if s.start_running {
                    s.start_running = false;
                    s.run_end = Some(end);
                }
                s.cancel_pending = false;
            }
            // R3: one interrupt per run, while the start slot runs
            Op::Interrupt if s.start_running && !s.interrupted => {
                s.interrupted = true;
                s.start_running = false;
                let c = m.interrupt();
                s.carry_out(c);
                if !s.sent {
                    assert_eq!(c, Cancel::Nothing, "A5: a goal not sent is never sent");
                }
            }
            _ => {}
        }
    }
    // the exit slot runs for the reason the run ended
    let reason = if s.interrupted {
        ExitReason::Interrupted
    } else {
        match s.run_end {
            Some(RunEnd::Completed) => ExitReason::Completed,
            Some(_) => ExitReason::Failed("the goal failed".into()),
            // still running: an exit signal, the program stopping, or a failure on this side
            None if exit_code == 0 => ExitReason::ExitSignal,
            None if exit_code == 1 => ExitReason::Panicked("boom".into()),
            None => ExitReason::Failed("the result did not decode".into()),
        }
    };
    let c = m.exit(&reason);
    s.carry_out(c);
    // A4-A6: no orphan: a goal the server may still run has been (or will be, once accepted) canceled
    if s.running() {
        assert!(
            s.cancels == 1 || s.cancel_pending,
            "the run ended ({reason:?}) and left its goal running: {s:?}"
        );
    }
    // A2: started only for an accepted goal
    assert!(!s.started || s.answer == Some(true));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]
    #[test]
    fn action_clients_follow_a1_to_a7(ops in prop::collection::vec(op(), 0..12), exit_code in 0u8..3) {
        run(&ops, exit_code);
    }
}

#[test]
fn the_model_finds_an_orphan_when_the_exit_slot_cancels_nothing() {
    // an accepted goal, then an exit signal: the machine must say cancel; the check above would catch a
    // machine that did not (here: its answer ignored, as a binding that never asks the machine would)
    let mut m = GoalMachine::new();
    m.sent();
    let _ = m.answered(true);
    assert_eq!(m.exit(&ExitReason::ExitSignal), Cancel::Now);
    let result = std::panic::catch_unwind(|| {
        let mut s = Server {
            sent: true,
            answer: Some(true),
            ..Server::default()
        };
        s.carry_out(Cancel::Nothing);
        if s.running() {
            assert!(s.cancels == 1 || s.cancel_pending, "orphan");
        }
    });
    assert!(result.is_err(), "the oracle must see an orphan");
}
