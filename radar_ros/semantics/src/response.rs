//! The RADAR response state machine, with no I/O.
//!
//! A response is in one of four [`Phase`]s. Inputs are the three slot signals (`start`, `interrupt`, `exit`)
//! and the completion of whichever slot is running. Each input returns the [`Effect`]s the runtime must carry
//! out, in order. The runtime (`radar_ros`'s response node) runs slots, publishes signals, and feeds completions
//! back; this file alone decides *what happens when*.
//!
//! The rules (numbered as in the crate documentation):
//!
//! 1. `Idle` + `start(p)` → emit `started(p)`, run the start behaviour with `p` → `Running`.
//! 2. Start behaviour returns → run the exit slot → `Exiting`; the exit slot completes → emit `exited` → `Idle`.
//! 3. `Running` + `interrupt` → cancel the start behaviour, emit `interrupted`, run the interrupt slot →
//!    `Interrupting`; it completes → run the exit slot → `Exiting` → `exited` → `Idle`.
//! 4. `Running` + `exit` → cancel the start behaviour, run the exit slot (no interrupt slot) → `Exiting`.
//! 5. `interrupt` or `exit` while `Idle`, `Interrupting` or `Exiting` → ignored, counted.
//! 6. `start` while not `Idle` → by [`StartPolicy`]: `Ignore` (counted), `Restart` (interrupt as in rule 3,
//!    then start anew with the newest payload), `QueueOne` (run the newest payload after `exited`; a start that
//!    replaces a queued one counts as ignored).
//! 7. The exit slot always runs, whatever ended the run: completion, interrupt, exit signal, error, panic. A
//!    panic in any slot is reported and treated as that slot finishing; a panic in the exit slot still ends
//!    with `exited`.
//! 8. The exit slot may ask for a restart: after `exited`, start again with the same payload. A queued or
//!    restart-policy start takes precedence over it (the newer payload wins; a run starts either way).
//! 9. A response that announces on acceptance ([`Announce::WhenAccepted`]: an action goal, which the server
//!    may reject) runs the start behaviour without `started`; `started` goes out when the behaviour reports
//!    [`Input::Accepted`], at most once per run and only while `Running`. A run that ends before that (a
//!    rejected goal, an interrupt or exit before acceptance) ends with `exited` and no `started`.
//! 10. A slot may hand over the run's output before it ends ([`Input::Output`]: the result of a goal that is
//!     being cancelled arrives in the interrupt slot): `exited` carries the last output handed over or returned
//!     in this run, else the default.

/// Where a response is in its lifecycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Waiting for `start`.
    Idle,
    /// The start behaviour runs.
    Running,
    /// The interrupt slot runs.
    Interrupting,
    /// The exit slot runs.
    Exiting,
}

impl Phase {
    /// The word shown in the state message.
    pub fn label(self) -> &'static str {
        match self {
            Phase::Idle => "idle",
            Phase::Running => "running",
            Phase::Interrupting => "interrupting",
            Phase::Exiting => "exiting",
        }
    }

    /// The `radar_msgs/msg/ResponseState` constant.
    pub fn code(self) -> u8 {
        match self {
            Phase::Idle => 0,
            Phase::Running => 1,
            Phase::Interrupting => 2,
            Phase::Exiting => 3,
        }
    }
}

/// What a response does with `start` while it is not idle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StartPolicy {
    /// Ignore the signal (counted in the state). The default, as in RADAR.
    #[default]
    Ignore,
    /// Interrupt the current run (interrupt slot, exit slot, `exited`), then start with the new payload.
    Restart,
    /// Keep the newest payload and start it after the current run's `exited`.
    QueueOne,
}

impl StartPolicy {
    /// The word shown in the state message.
    pub fn label(self) -> &'static str {
        match self {
            StartPolicy::Ignore => "ignore",
            StartPolicy::Restart => "restart",
            StartPolicy::QueueOne => "queue_one",
        }
    }
}

/// When a response emits `started` (rule 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Announce {
    /// As the start behaviour begins (rule 1). The default.
    #[default]
    OnStart,
    /// When the start behaviour reports [`Input::Accepted`] (an action server accepted the goal).
    WhenAccepted,
}

/// Why the exit slot is running.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExitReason {
    /// The start behaviour returned normally.
    Completed,
    /// An `interrupt` signal ended the run (the interrupt slot has run).
    Interrupted,
    /// An `exit` signal ended the run.
    ExitSignal,
    /// The start behaviour returned an error.
    Failed(String),
    /// The start behaviour panicked.
    Panicked(String),
}

impl ExitReason {
    /// The text shown in the state message.
    pub fn describe(&self) -> String {
        match self {
            ExitReason::Completed => "completed".into(),
            ExitReason::Interrupted => "interrupted".into(),
            ExitReason::ExitSignal => "exit_signal".into(),
            ExitReason::Failed(e) => format!("failed: {e}"),
            ExitReason::Panicked(e) => format!("panicked: {e}"),
        }
    }
}

/// How the start behaviour ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StartEnd<O> {
    /// It returned this output.
    Returned(O),
    /// It returned an error.
    Failed(String),
    /// It panicked with this message.
    Panicked(String),
}

/// What the exit slot decided.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExitAction {
    /// Go idle after `exited`.
    #[default]
    Done,
    /// Start again with the same payload after `exited` (the paper's `on exit: restart`).
    Restart,
}

/// An input to the machine.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Input<P, O> {
    /// A `start` signal with its payload.
    Start(P),
    /// An `interrupt` signal.
    Interrupt,
    /// An `exit` signal.
    Exit,
    /// The start behaviour ended by itself.
    StartEnded(StartEnd<O>),
    /// The interrupt slot finished (`Some(message)` if it panicked).
    InterruptEnded(Option<String>),
    /// The exit slot finished with a decision, or panicked (`Err(message)`).
    ExitEnded(Result<ExitAction, String>),
    /// The start behaviour has really begun (rule 9: emits `started` under [`Announce::WhenAccepted`]).
    Accepted,
    /// A slot handed over the run's output before ending (rule 10).
    Output(O),
}

/// Something the runtime must do, in the order given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Effect<P, O> {
    /// Publish `started` with the payload.
    EmitStarted(P),
    /// Begin the start behaviour with the payload.
    RunStart(P),
    /// Cancel the running start behaviour (drop it at its current await point).
    CancelStart,
    /// Publish `interrupted`.
    EmitInterrupted,
    /// Begin the interrupt slot.
    RunInterrupt,
    /// Begin the exit slot.
    RunExit(ExitReason),
    /// Publish `exited` with the output of the run (the start behaviour's result, or the default).
    EmitExited(O),
    /// A slot panicked: log it (it is already counted).
    ReportPanic {
        /// Which slot.
        slot: &'static str,
        /// The panic message.
        message: String,
    },
    /// A signal was ignored: log it at debug level (it is already counted).
    Ignored {
        /// Which signal.
        signal: &'static str,
        /// The phase it arrived in.
        phase: Phase,
    },
}

/// Counters exposed in the state message.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Runs started (including restarts).
    pub starts: u64,
    /// Runs that reached `exited`.
    pub exits: u64,
    /// Runs ended by `interrupt`.
    pub interrupts: u64,
    /// Runs ended by `exit`.
    pub exit_signals: u64,
    /// Start behaviours that returned normally.
    pub completed: u64,
    /// Start behaviours that returned an error.
    pub failures: u64,
    /// Panics caught in any slot.
    pub panics: u64,
    /// Restarts asked for by the exit slot.
    pub restarts: u64,
    /// `start` signals ignored or replaced in the queue.
    pub ignored_starts: u64,
    /// `interrupt` signals ignored.
    pub ignored_interrupts: u64,
    /// `exit` signals ignored.
    pub ignored_exits: u64,
}

/// The response state machine. `P` is the start payload, `O` the output carried on `exited`.
///
/// ```
/// use radar_semantics::response::{Effect, Input, Phase, ResponseMachine, StartEnd, StartPolicy, ExitAction};
/// let mut r = ResponseMachine::<u32, ()>::new(StartPolicy::Ignore);
/// assert_eq!(r.handle(Input::Start(7)), vec![Effect::EmitStarted(7), Effect::RunStart(7)]);
/// assert_eq!(r.phase(), Phase::Running);
/// r.handle(Input::Interrupt); // rule 3: cancel, emit interrupted, run the interrupt slot
/// assert_eq!(r.phase(), Phase::Interrupting);
/// r.handle(Input::InterruptEnded(None)); // then the exit slot
/// let fx = r.handle(Input::ExitEnded(Ok(ExitAction::Done)));
/// assert!(fx.contains(&Effect::EmitExited(())));
/// assert_eq!((r.phase(), r.counters().interrupts), (Phase::Idle, 1));
/// # let _ = StartEnd::<()>::Returned(());
/// ```
#[derive(Debug)]
pub struct ResponseMachine<P, O> {
    phase: Phase,
    policy: StartPolicy,
    /// Payload of the current run, kept for a restart.
    current: Option<P>,
    /// A start to run after the current run's `exited`.
    pending: Option<P>,
    /// Output of the current run, set when the start behaviour returned.
    output: Option<O>,
    last_exit: Option<ExitReason>,
    counters: Counters,
    /// Set by [`ResponseMachine::stop`]: no new runs, no restarts.
    stopping: bool,
    announce: Announce,
    /// Whether this run's `started` has gone out.
    announced: bool,
}

impl<P: Clone, O: Default> ResponseMachine<P, O> {
    /// A new, idle machine.
    pub fn new(policy: StartPolicy) -> Self {
        ResponseMachine {
            phase: Phase::Idle,
            policy,
            current: None,
            pending: None,
            output: None,
            last_exit: None,
            counters: Counters::default(),
            stopping: false,
            announce: Announce::OnStart,
            announced: false,
        }
    }

    /// A new, idle machine that emits `started` as `announce` says (rule 9).
    ///
    /// ```
    /// use radar_semantics::response::{Announce, Effect, Input, ResponseMachine, StartPolicy};
    /// let mut r = ResponseMachine::<u32, ()>::with_announce(StartPolicy::Ignore, Announce::WhenAccepted);
    /// assert_eq!(r.handle(Input::Start(7)), vec![Effect::RunStart(7)]);
    /// assert_eq!(r.handle(Input::Accepted), vec![Effect::EmitStarted(7)]);
    /// assert_eq!(r.handle(Input::Accepted), vec![]); // once per run
    /// ```
    pub fn with_announce(policy: StartPolicy, announce: Announce) -> Self {
        let mut m = Self::new(policy);
        m.announce = announce;
        m
    }

    /// When `started` is emitted.
    pub fn announce(&self) -> Announce {
        self.announce
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The start policy.
    pub fn policy(&self) -> StartPolicy {
        self.policy
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Why the last run ended, if any run has.
    pub fn last_exit(&self) -> Option<&ExitReason> {
        self.last_exit.as_ref()
    }

    /// Whether a start is queued.
    pub fn start_queued(&self) -> bool {
        self.pending.is_some()
    }

    /// Begins shutting down: a running start behaviour ends as if an `exit` signal arrived (so the exit slot
    /// still runs), a queued start is dropped, and no further run starts (not even an exit-slot restart).
    /// The runtime stops once the phase is back to [`Phase::Idle`].
    pub fn stop(&mut self) -> Vec<Effect<P, O>> {
        self.stopping = true;
        self.pending = None;
        let mut fx = Vec::new();
        if self.phase == Phase::Running {
            self.counters.exit_signals += 1;
            fx.push(Effect::CancelStart);
            self.run_exit(ExitReason::ExitSignal, &mut fx);
        }
        fx
    }

    /// Whether [`ResponseMachine::stop`] was called.
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// Feeds one input and returns what to do.
    pub fn handle(&mut self, input: Input<P, O>) -> Vec<Effect<P, O>> {
        let mut fx = Vec::new();
        match (self.phase, input) {
            (_, Input::Start(_)) if self.stopping => self.ignore("start", &mut fx),
            (Phase::Idle, Input::Start(p)) => self.begin(p, &mut fx),
            (_, Input::Start(p)) => match self.policy {
                StartPolicy::Ignore => self.ignore("start", &mut fx),
                StartPolicy::QueueOne => self.queue(p),
                StartPolicy::Restart => {
                    self.queue(p);
                    if self.phase == Phase::Running {
                        self.interrupt(&mut fx);
                    }
                }
            },
            (Phase::Running, Input::Interrupt) => self.interrupt(&mut fx),
            (_, Input::Interrupt) => self.ignore("interrupt", &mut fx),
            (Phase::Running, Input::Exit) => {
                self.counters.exit_signals += 1;
                fx.push(Effect::CancelStart);
                self.run_exit(ExitReason::ExitSignal, &mut fx);
            }
            (_, Input::Exit) => self.ignore("exit", &mut fx),
            (Phase::Running, Input::StartEnded(end)) => {
                let reason = match end {
                    StartEnd::Returned(o) => {
                        self.counters.completed += 1;
                        self.output = Some(o);
                        ExitReason::Completed
                    }
                    StartEnd::Failed(e) => {
                        self.counters.failures += 1;
                        ExitReason::Failed(e)
                    }
                    StartEnd::Panicked(m) => {
                        self.counters.panics += 1;
                        fx.push(Effect::ReportPanic {
                            slot: "start",
                            message: m.clone(),
                        });
                        ExitReason::Panicked(m)
                    }
                };
                self.run_exit(reason, &mut fx);
            }
            (Phase::Interrupting, Input::InterruptEnded(panic)) => {
                if let Some(m) = panic {
                    self.counters.panics += 1;
                    fx.push(Effect::ReportPanic {
                        slot: "interrupt",
                        message: m,
                    });
                }
                self.run_exit(ExitReason::Interrupted, &mut fx);
            }
            (Phase::Exiting, Input::ExitEnded(result)) => {
                let action = match result {
                    Ok(a) => a,
                    Err(m) => {
                        self.counters.panics += 1;
                        fx.push(Effect::ReportPanic {
                            slot: "exit",
                            message: m,
                        });
                        ExitAction::Done
                    }
                };
                self.counters.exits += 1;
                fx.push(Effect::EmitExited(self.output.take().unwrap_or_default()));
                self.phase = Phase::Idle;
                let finished = self.current.take();
                if self.stopping {
                    // shutting down: the run is over and nothing starts again
                } else if let Some(p) = self.pending.take() {
                    self.begin(p, &mut fx);
                } else if let (ExitAction::Restart, Some(p)) = (action, finished) {
                    self.counters.restarts += 1;
                    self.begin(p, &mut fx);
                }
            }
            (Phase::Running, Input::Accepted) if !self.announced => {
                self.announced = true;
                if let Some(p) = &self.current {
                    fx.push(Effect::EmitStarted(p.clone()));
                }
            }
            (_, Input::Accepted) => {}
            (Phase::Idle, Input::Output(_)) => {}
            (_, Input::Output(o)) => self.output = Some(o),
            // A completion that does not belong to the current phase cannot come from a correct runtime
            // (it cancels the start behaviour before moving on); ignoring it keeps the machine consistent.
            (_, Input::StartEnded(_) | Input::InterruptEnded(_) | Input::ExitEnded(_)) => {}
        }
        fx
    }

    fn begin(&mut self, p: P, fx: &mut Vec<Effect<P, O>>) {
        self.counters.starts += 1;
        self.phase = Phase::Running;
        self.output = None;
        self.current = Some(p.clone());
        self.announced = self.announce == Announce::OnStart;
        if self.announced {
            fx.push(Effect::EmitStarted(p.clone()));
        }
        fx.push(Effect::RunStart(p));
    }

    fn interrupt(&mut self, fx: &mut Vec<Effect<P, O>>) {
        self.counters.interrupts += 1;
        self.phase = Phase::Interrupting;
        fx.push(Effect::CancelStart);
        fx.push(Effect::EmitInterrupted);
        fx.push(Effect::RunInterrupt);
    }

    fn run_exit(&mut self, reason: ExitReason, fx: &mut Vec<Effect<P, O>>) {
        self.phase = Phase::Exiting;
        self.last_exit = Some(reason.clone());
        fx.push(Effect::RunExit(reason));
    }

    fn queue(&mut self, p: P) {
        if self.pending.replace(p).is_some() {
            self.counters.ignored_starts += 1;
        }
    }

    fn ignore(&mut self, signal: &'static str, fx: &mut Vec<Effect<P, O>>) {
        match signal {
            "start" => self.counters.ignored_starts += 1,
            "interrupt" => self.counters.ignored_interrupts += 1,
            _ => self.counters.ignored_exits += 1,
        }
        fx.push(Effect::Ignored {
            signal,
            phase: self.phase,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Effect::*;

    type M = ResponseMachine<u32, String>;

    fn running(policy: StartPolicy) -> M {
        let mut m = M::new(policy);
        assert_eq!(m.handle(Input::Start(7)), vec![EmitStarted(7), RunStart(7)]);
        m
    }

    #[test]
    fn rule1_start_while_idle_emits_started_then_runs_with_the_payload() {
        let m = running(StartPolicy::Ignore);
        assert_eq!(m.phase(), Phase::Running);
        assert_eq!(m.counters().starts, 1);
    }

    #[test]
    fn rule2_normal_end_runs_exit_slot_then_emits_exited_with_the_output() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::StartEnded(StartEnd::Returned("done".into())));
        assert_eq!(fx, vec![RunExit(ExitReason::Completed)]);
        assert_eq!(m.phase(), Phase::Exiting);
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(fx, vec![EmitExited("done".into())]);
        assert_eq!(m.phase(), Phase::Idle);
        assert_eq!(m.counters().completed, 1);
        assert_eq!(m.counters().exits, 1);
    }

    #[test]
    fn rule3_interrupt_cancels_start_emits_interrupted_runs_interrupt_then_exit() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::Interrupt);
        assert_eq!(fx, vec![CancelStart, EmitInterrupted, RunInterrupt]);
        assert_eq!(m.phase(), Phase::Interrupting);
        let fx = m.handle(Input::InterruptEnded(None));
        assert_eq!(fx, vec![RunExit(ExitReason::Interrupted)]);
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![EmitExited(String::new())],
            "interrupted runs carry the default output"
        );
        assert_eq!(m.counters().interrupts, 1);
        assert_eq!(m.last_exit(), Some(&ExitReason::Interrupted));
    }

    #[test]
    fn rule4_exit_signal_skips_the_interrupt_slot() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::Exit);
        assert_eq!(fx, vec![CancelStart, RunExit(ExitReason::ExitSignal)]);
        assert_eq!(m.phase(), Phase::Exiting);
        m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(m.counters().exit_signals, 1);
        assert_eq!(m.counters().interrupts, 0);
    }

    #[test]
    fn rule5_interrupt_and_exit_are_ignored_when_idle_interrupting_or_exiting() {
        let mut m = M::new(StartPolicy::Ignore);
        assert!(matches!(
            m.handle(Input::Interrupt)[..],
            [Ignored {
                signal: "interrupt",
                phase: Phase::Idle
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit)[..],
            [Ignored {
                signal: "exit",
                phase: Phase::Idle
            }]
        ));
        m.handle(Input::Start(1));
        m.handle(Input::Interrupt);
        assert!(matches!(
            m.handle(Input::Interrupt)[..],
            [Ignored {
                phase: Phase::Interrupting,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit)[..],
            [Ignored {
                phase: Phase::Interrupting,
                ..
            }]
        ));
        m.handle(Input::InterruptEnded(None));
        assert!(matches!(
            m.handle(Input::Interrupt)[..],
            [Ignored {
                phase: Phase::Exiting,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit)[..],
            [Ignored {
                phase: Phase::Exiting,
                ..
            }]
        ));
        assert_eq!(m.counters().ignored_interrupts, 3);
        assert_eq!(m.counters().ignored_exits, 3);
        assert_eq!(m.phase(), Phase::Exiting);
    }

    #[test]
    fn rule6_ignore_policy_counts_starts_while_busy() {
        let mut m = running(StartPolicy::Ignore);
        assert!(matches!(
            m.handle(Input::Start(8))[..],
            [Ignored {
                signal: "start",
                ..
            }]
        ));
        m.handle(Input::StartEnded(StartEnd::Returned(String::new())));
        assert!(matches!(
            m.handle(Input::Start(9))[..],
            [Ignored {
                phase: Phase::Exiting,
                ..
            }]
        ));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new())]
        );
        assert_eq!(m.counters().ignored_starts, 2);
        assert_eq!(m.phase(), Phase::Idle);
    }

    #[test]
    fn rule6_restart_policy_interrupts_then_starts_the_new_payload() {
        let mut m = running(StartPolicy::Restart);
        assert_eq!(
            m.handle(Input::Start(8)),
            vec![CancelStart, EmitInterrupted, RunInterrupt]
        );
        // a further start while interrupting replaces the pending payload
        assert!(m.handle(Input::Start(9)).is_empty());
        assert!(m.start_queued());
        m.handle(Input::InterruptEnded(None));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![EmitExited(String::new()), EmitStarted(9), RunStart(9)]
        );
        assert_eq!(
            m.counters().ignored_starts,
            1,
            "payload 8 was replaced by 9"
        );
        assert_eq!(m.counters().starts, 2);
    }

    #[test]
    fn rule6_queue_one_runs_the_newest_payload_after_exited() {
        let mut m = running(StartPolicy::QueueOne);
        assert!(m.handle(Input::Start(8)).is_empty());
        assert!(m.handle(Input::Start(9)).is_empty());
        assert_eq!(m.phase(), Phase::Running, "queue-one does not interrupt");
        m.handle(Input::StartEnded(StartEnd::Returned("a".into())));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![EmitExited("a".into()), EmitStarted(9), RunStart(9)]
        );
        assert_eq!(m.counters().ignored_starts, 1);
    }

    #[test]
    fn rule7_exit_slot_runs_after_error_and_panic_and_exited_follows_an_exit_panic() {
        let mut m = running(StartPolicy::Ignore);
        assert_eq!(
            m.handle(Input::StartEnded(StartEnd::Failed("no path".into()))),
            vec![RunExit(ExitReason::Failed("no path".into()))]
        );
        m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        m.handle(Input::Start(1));
        assert_eq!(
            m.handle(Input::StartEnded(StartEnd::Panicked("boom".into()))),
            vec![
                ReportPanic {
                    slot: "start",
                    message: "boom".into()
                },
                RunExit(ExitReason::Panicked("boom".into()))
            ]
        );
        // the exit slot panics too: exited is still emitted, and no restart happens
        assert_eq!(
            m.handle(Input::ExitEnded(Err("exit boom".into()))),
            vec![
                ReportPanic {
                    slot: "exit",
                    message: "exit boom".into()
                },
                EmitExited(String::new())
            ]
        );
        assert_eq!(m.phase(), Phase::Idle);
        assert_eq!(m.counters().failures, 1);
        assert_eq!(m.counters().panics, 2);
        assert_eq!(m.counters().exits, 2);
    }

    #[test]
    fn rule7_interrupt_slot_panic_still_runs_the_exit_slot() {
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Interrupt);
        assert_eq!(
            m.handle(Input::InterruptEnded(Some("oops".into()))),
            vec![
                ReportPanic {
                    slot: "interrupt",
                    message: "oops".into()
                },
                RunExit(ExitReason::Interrupted)
            ]
        );
    }

    #[test]
    fn rule8_exit_slot_restart_starts_again_with_the_same_payload() {
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Interrupt);
        m.handle(Input::InterruptEnded(None));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Restart)));
        assert_eq!(
            fx,
            vec![EmitExited(String::new()), EmitStarted(7), RunStart(7)]
        );
        assert_eq!(m.counters().restarts, 1);
        assert_eq!(m.phase(), Phase::Running);
    }

    #[test]
    fn rule8_a_queued_start_takes_precedence_over_an_exit_restart() {
        let mut m = running(StartPolicy::QueueOne);
        m.handle(Input::Start(9));
        m.handle(Input::StartEnded(StartEnd::Returned(String::new())));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Restart)));
        assert_eq!(
            fx,
            vec![EmitExited(String::new()), EmitStarted(9), RunStart(9)]
        );
        assert_eq!(m.counters().restarts, 0);
    }

    #[test]
    fn stop_runs_the_exit_slot_and_then_starts_nothing() {
        let mut m = running(StartPolicy::QueueOne);
        m.handle(Input::Start(9));
        assert_eq!(m.stop(), vec![CancelStart, RunExit(ExitReason::ExitSignal)]);
        assert!(!m.start_queued());
        assert!(matches!(
            m.handle(Input::Start(10))[..],
            [Ignored {
                signal: "start",
                ..
            }]
        ));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Restart))),
            vec![EmitExited(String::new())]
        );
        assert_eq!(m.phase(), Phase::Idle);
        assert!(
            M::new(StartPolicy::Ignore).stop().is_empty(),
            "an idle response just stops"
        );
    }

    #[test]
    fn stray_completions_do_not_change_the_phase() {
        let mut m = M::new(StartPolicy::Ignore);
        assert!(m
            .handle(Input::ExitEnded(Ok(ExitAction::Restart)))
            .is_empty());
        assert!(m
            .handle(Input::StartEnded(StartEnd::Returned(String::new())))
            .is_empty());
        assert_eq!(m.phase(), Phase::Idle);
    }

    fn announcing(policy: StartPolicy) -> M {
        let mut m = M::with_announce(policy, Announce::WhenAccepted);
        assert_eq!(m.handle(Input::Start(7)), vec![RunStart(7)]);
        m
    }

    #[test]
    fn rule9_started_goes_out_on_acceptance_once_per_run() {
        let mut m = announcing(StartPolicy::Ignore);
        assert_eq!(m.phase(), Phase::Running);
        assert_eq!(m.handle(Input::Accepted), vec![EmitStarted(7)]);
        assert_eq!(m.handle(Input::Accepted), vec![]);
        m.handle(Input::StartEnded(StartEnd::Returned("r".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Restart))),
            vec![EmitExited("r".into()), RunStart(7)]
        );
        assert_eq!(
            m.handle(Input::Accepted),
            vec![EmitStarted(7)],
            "a new run announces again"
        );
    }

    #[test]
    fn rule9_a_run_ended_before_acceptance_exits_without_started() {
        // rejected
        let mut m = announcing(StartPolicy::Ignore);
        m.handle(Input::StartEnded(StartEnd::Failed("rejected".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new())]
        );
        assert_eq!(
            m.handle(Input::Accepted),
            vec![],
            "nothing runs: no started"
        );
        // interrupted before acceptance: interrupted and exited, and a late acceptance says nothing
        let mut m = announcing(StartPolicy::Ignore);
        assert_eq!(
            m.handle(Input::Interrupt),
            vec![CancelStart, EmitInterrupted, RunInterrupt]
        );
        assert_eq!(m.handle(Input::Accepted), vec![]);
        m.handle(Input::InterruptEnded(None));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new())]
        );
        assert_eq!(m.counters().interrupts, 1);
    }

    #[test]
    fn rule10_an_output_handed_over_while_interrupting_is_carried_by_exited() {
        let mut m = announcing(StartPolicy::Ignore);
        m.handle(Input::Accepted);
        m.handle(Input::Interrupt);
        assert_eq!(m.handle(Input::Output("partial".into())), vec![]);
        m.handle(Input::InterruptEnded(None));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited("partial".into())]
        );
        // a returned output replaces one handed over; an output while idle is dropped
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Output("early".into()));
        m.handle(Input::StartEnded(StartEnd::Returned("final".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited("final".into())]
        );
        m.handle(Input::Output("stray".into()));
        m.handle(Input::Start(1));
        m.handle(Input::StartEnded(StartEnd::Failed("x".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new())]
        );
    }
}
