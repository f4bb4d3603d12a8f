//! The RADAR response state machine, with no I/O.
//!
//! A response is in one of four [`Phase`]s. Inputs are the three slot signals (`start`, `interrupt`, `exit`)
//! and the completion of whichever slot is running. Each input returns the [`Effect`]s the runtime must carry
//! out, in order. The runtime (`radar_ros`'s response node) runs slots, publishes signals, and feeds completions
//! back; this file alone decides *what happens when*.
//!
//! The rules, R1-R14 (the crate documentation, the README and the tests use these numbers):
//!
//! - **R1.** `Idle` + `start(p)` → emit `started(p)`, run the start behaviour with `p` → `Running`. The start
//!   behaviour runs up to its first await point before the response takes its next signal, so `started`
//!   never announces a behaviour that did not run at all.
//! - **R2.** Start behaviour returns → run the exit slot → `Exiting`; the exit slot completes → emit `exited`
//!   → `Idle`.
//! - **R3.** `Running` + `interrupt` → cancel the start behaviour, emit `interrupted`, run the interrupt slot →
//!   `Interrupting`; it completes → run the exit slot → `Exiting` → `exited` → `Idle`.
//! - **R4.** `Running` + `exit` → cancel the start behaviour, run the exit slot (no interrupt slot) → `Exiting`.
//! - **R5.** `interrupt` or `exit` while `Idle`, `Interrupting` or `Exiting` → ignored, counted.
//! - **R6.** `start` while not `Idle` → by [`StartPolicy`]: `Ignore` (counted), `Restart` (interrupt as in R3,
//!   then start anew with the newest payload), `QueueOne` (run the newest payload after `exited`; a start that
//!   replaces a queued one counts as ignored). A start a statement sent that is not taken (ignored, replaced
//!   in the queue, dropped by a stop) is announced with its cause ([`Effect::EmitDropped`]): the statement
//!   learns that no run of it will come (C3).
//! - **R7.** The exit slot always runs, whatever ended the run: completion, interrupt, exit signal, error,
//!   panic, or the response being stopped ([`ResponseMachine::stop`]; the runtime stops every response when
//!   its process is told to stop). A panic in any slot is reported and treated as that slot finishing; a panic
//!   in the exit slot still ends with `exited`.
//! - **R8.** The exit slot may ask for a restart: after `exited`, start again with the same payload. A queued or
//!   restart-policy start takes precedence over it (the newer payload wins; a run starts either way). A
//!   restarted run has no [cause](Cause): no statement started it.
//! - **R9.** A response that announces on acceptance ([`Announce::WhenAccepted`]: an action goal, which the
//!   server may reject) runs the start behaviour without `started`; `started` goes out when the behaviour
//!   reports [`Input::Accepted`], at most once per run and only while `Running`. A run that ends before that (a
//!   rejected goal, an interrupt or exit before acceptance) ends with `exited` and no `started`.
//! - **R10.** A slot may hand over the run's output before it ends ([`Input::Output`]: the result of a goal that
//!   is being cancelled arrives in the interrupt slot): `exited` carries the last output handed over or
//!   returned in this run, else the default.
//!
//! Slot signals travel on three topics and may be read in another order than they were sent. Each carries
//! when the signal that caused it was emitted ([`Sent::at`]; a relay keeps the original time), so the response
//! orders them by cause, not by arrival:
//!
//! - **R11.** Every run *begins* at the later of the time its start signal was emitted and the end of the run
//!   before it (for a queued start or an R8 restart: when it actually starts). An `interrupt` or `exit` emitted
//!   before the current run began is not for this run: ignored, counted.
//! - **R12.** An `interrupt` or `exit` that reaches an idle response is kept (the newest few, for
//!   [`HOLD`]): a `start` emitted before it (at most [`HOLD`] before) that arrives afterwards begins its run,
//!   which then takes the kept signal as soon as it has run up to its first await (R1;
//!   [`ResponseMachine::resume`]), as if the two had arrived in the order they were sent. A kept signal that is
//!   used this way is no longer counted as ignored. When a run begins, the kept signals sent before its start
//!   go (they are for no later run), except an `until`'s interrupt naming another statement (R14: its
//!   statement's start may still be on its way).
//! - **R13.** A run started by a statement carries that statement's [`Cause`], and so do its `started`,
//!   `interrupted` and `exited`. An `interrupt` sent by an `until` names its statement ([`Sent::by`]): it
//!   interrupts only a run begun by a start of that statement (and only if it was emitted after that start
//!   was sent: R14); any other run, or none, ignores it. Untargeted interrupts (injected, `whenever X interrupt R`)
//!   interrupt whatever runs.
//! - **R14.** An `until`'s interrupt bounds a run of its statement whose start was sent before it, also when that
//!   run begins after it: R11 does not apply to it (R13 does). One that names the statement of a *queued* start
//!   (R6: `QueueOne`, or `Restart` while the run before is still in its interrupt or exit slot) is kept with it,
//!   and one that reaches a busy response while its statement's start is still on its way is kept as in R12:
//!   the run begins (R1, `started`) and takes the interrupt at its first await. A newer start that replaces the
//!   queued one takes it if it is of the same statement and was sent before it; else it is kept again, as in
//!   R12, for that statement's next start. So an `until` bounds its statement's run even when that run had to
//!   wait for another, or its start replaced another of the same statement.
//!
//! Stamps come from the senders' clocks, and a machine takes them as rule T1 says ([`crate::time`]): never
//! later than its own clock, at most [`LATE`](crate::time::LATE) before it; when its own clock steps back, the
//! times it remembers follow (T2). A host whose clock is off cannot keep a response from taking its own
//! host's signals.

mod kept;
mod signals;
mod stop;

pub use signals::{
    Announce, Cause, Counters, Effect, ExitAction, ExitReason, IgnoreReason, Input, Phase, Sent,
    StartEnd, StartPolicy, StatementId,
};

use kept::{Kept, KeptSignals};

use crate::time::Clock;
pub use crate::time::HOLD;

/// The response state machine. `P` is the start payload, `O` the output carried on `exited`.
///
/// ```
/// use radar_semantics::response::{Effect, Input, Phase, ResponseMachine, Sent, StartEnd, StartPolicy, ExitAction};
/// let mut r = ResponseMachine::<u32, ()>::new(StartPolicy::Ignore);
/// assert_eq!(r.handle(Input::Start(7, Sent::at(10))), vec![Effect::EmitStarted(7, None), Effect::RunStart(7)]);
/// assert_eq!(r.phase(), Phase::Running);
/// r.handle(Input::Interrupt(Sent::at(20))); // R3: cancel, emit interrupted, run the interrupt slot
/// assert_eq!(r.phase(), Phase::Interrupting);
/// r.handle(Input::InterruptEnded(None)); // then the exit slot
/// let fx = r.handle(Input::ExitEnded(Ok(ExitAction::Done)));
/// assert!(fx.contains(&Effect::EmitExited((), None)));
/// assert_eq!((r.phase(), r.counters().interrupts), (Phase::Idle, 1));
/// # let _ = StartEnd::<()>::Returned(());
/// ```
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ResponseMachine<P, O> {
    phase: Phase,
    policy: StartPolicy,
    /// Payload of the current run, kept for a restart.
    current: Option<P>,
    /// A start to run after the current run's `exited`.
    pending: Option<(P, Sent)>,
    /// An `until`'s interrupt for the queued start's run, sent after that start (R14).
    bound: Option<Kept>,
    /// Output of the current run, set when the start behaviour returned.
    output: Option<O>,
    last_exit: Option<ExitReason>,
    counters: Counters,
    /// Set by [`ResponseMachine::stop`]: no new runs, no restarts.
    stopping: bool,
    announce: Announce,
    /// Whether this run's `started` has gone out.
    announced: bool,
    /// The current run's cause (R13).
    cause: Option<Cause>,
    /// When the current run began (R11).
    began: i64,
    /// When the start that began the current run was sent (R13, R14).
    start_at: i64,
    /// When the last run ended (its `exited`).
    ended: i64,
    /// The receiver's clock: the one given to [`ResponseMachine::handle_at`] (or, through
    /// [`ResponseMachine::handle`], the newest stamp seen).
    clock: Clock,
    /// Signals kept while idle (R12), oldest first.
    kept: KeptSignals,
    /// A kept signal the run just begun takes once it has run to its first await (R12).
    held: Option<Kept>,
}

impl<P: Clone, O: Default> ResponseMachine<P, O> {
    /// A new, idle machine.
    pub fn new(policy: StartPolicy) -> Self {
        ResponseMachine {
            phase: Phase::Idle,
            policy,
            current: None,
            pending: None,
            bound: None,
            output: None,
            last_exit: None,
            counters: Counters::default(),
            stopping: false,
            announce: Announce::OnStart,
            announced: false,
            cause: None,
            began: i64::MIN,
            start_at: i64::MIN,
            ended: i64::MIN,
            clock: Clock::default(),
            kept: KeptSignals::default(),
            held: None,
        }
    }

    /// A new, idle machine that emits `started` as `announce` says (R9).
    ///
    /// ```
    /// use radar_semantics::response::{Announce, Effect, Input, ResponseMachine, Sent, StartPolicy};
    /// let mut r = ResponseMachine::<u32, ()>::with_announce(StartPolicy::Ignore, Announce::WhenAccepted);
    /// assert_eq!(r.handle(Input::Start(7, Sent::at(1))), vec![Effect::RunStart(7)]);
    /// assert_eq!(r.handle(Input::Accepted), vec![Effect::EmitStarted(7, None)]);
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

    /// The cause of the current run (or of the run that just ended), if a statement started it (R13).
    pub fn cause(&self) -> Option<Cause> {
        self.cause
    }

    /// When the current run began (R11), if one has.
    pub fn began(&self) -> Option<i64> {
        (self.began != i64::MIN).then_some(self.began)
    }

    /// Feeds one input and returns what to do, with no clock of its own: the clock is the newest time the
    /// machine has seen, stamps included (for tests and for a machine whose stamps all come from one clock).
    #[must_use = "the effects are what the binding must carry out, in order"]
    pub fn handle(&mut self, input: Input<P, O>) -> Vec<Effect<P, O>> {
        let mut now = self.clock.now();
        if let Input::Start(_, s) | Input::Interrupt(s) | Input::Exit(s) = &input {
            now = now.max(s.at);
        }
        self.handle_at(input, now)
    }

    /// Feeds one input at time `now` (ns since the epoch, the clock of [`Sent::at`]: the receiver's own) and
    /// returns what to do. The input's stamp is taken as rule T1 says ([`Sent::received`]): never later than
    /// `now`. A `now` before the last one given is the clock stepping back (T2): the times the machine
    /// remembers move back with it.
    #[must_use = "the effects are what the binding must carry out, in order"]
    pub fn handle_at(&mut self, input: Input<P, O>, now: i64) -> Vec<Effect<P, O>> {
        if let Some(now) = self.clock.set(now) {
            self.step_back(now);
        }
        let input = match input {
            Input::Start(p, s) => Input::Start(p, s.received(now)),
            Input::Interrupt(s) => Input::Interrupt(s.received(now)),
            Input::Exit(s) => Input::Exit(s.received(now)),
            other => other,
        };
        let mut fx = Vec::new();
        match (self.phase, input) {
            (_, Input::Start(_, s)) if self.stopping => {
                Self::dropped(s, &mut fx);
                self.ignore("start", IgnoreReason::Phase, &mut fx)
            }
            (Phase::Idle, Input::Start(p, s)) => {
                self.begin(p, s, &mut fx);
                self.take_kept(s);
            }
            (_, Input::Start(p, s)) => self.start_while_busy(p, s, &mut fx),
            (Phase::Running, Input::Interrupt(s)) => match self.applies(&s, true) {
                Ok(()) => {
                    self.interrupt(&mut fx);
                    self.bound_next(s);
                }
                Err(why) => self.not_for_this_run(s, why, &mut fx),
            },
            (Phase::Idle, Input::Interrupt(s)) => {
                self.keep(Kept::Interrupt(s));
                self.ignore("interrupt", IgnoreReason::Phase, &mut fx)
            }
            (_, Input::Interrupt(s)) => self.not_for_this_run(s, IgnoreReason::Phase, &mut fx),
            (Phase::Running, Input::Exit(s)) => match self.applies(&s, false) {
                Ok(()) => {
                    self.counters.exit_signals += 1;
                    fx.push(Effect::CancelStart);
                    self.run_exit(ExitReason::ExitSignal, &mut fx);
                }
                Err(why) => self.ignore("exit", why, &mut fx),
            },
            (Phase::Idle, Input::Exit(s)) => {
                self.keep(Kept::Exit(s));
                self.ignore("exit", IgnoreReason::Phase, &mut fx)
            }
            (_, Input::Exit(_)) => self.ignore("exit", IgnoreReason::Phase, &mut fx),
            (Phase::Running, Input::StartEnded(end)) => self.start_ended(end, &mut fx),
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
            (Phase::Exiting, Input::ExitEnded(result)) => self.exit_ended(result, &mut fx),
            (Phase::Running, Input::Accepted) if !self.announced => {
                self.announced = true;
                if let Some(p) = &self.current {
                    fx.push(Effect::EmitStarted(p.clone(), self.cause));
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

    /// R12: the run just begun has reached its first await; if it took a kept `interrupt` or `exit` (sent
    /// after its start, read before it), that signal applies now. The runtime calls this once after each
    /// [`Effect::RunStart`] has run to its first await point.
    #[must_use = "the effects are what the binding must carry out, in order"]
    pub fn resume(&mut self) -> Vec<Effect<P, O>> {
        // a held signal was judged for this run when it was taken (R12: sent after the start, for its
        // statement; R14: an until's interrupt for a queued run): it applies now
        let mut fx = Vec::new();
        match self.held.take() {
            Some(Kept::Interrupt(s)) if self.phase == Phase::Running => {
                self.counters.ignored_interrupts =
                    self.counters.ignored_interrupts.saturating_sub(1);
                self.interrupt(&mut fx);
                self.bound_next(s);
            }
            Some(Kept::Bound(s)) if self.phase == Phase::Running => {
                self.interrupt(&mut fx);
                self.bound_next(s);
            }
            Some(Kept::Exit(_)) if self.phase == Phase::Running => {
                self.counters.ignored_exits = self.counters.ignored_exits.saturating_sub(1);
                self.counters.exit_signals += 1;
                fx.push(Effect::CancelStart);
                self.run_exit(ExitReason::ExitSignal, &mut fx);
            }
            _ => {}
        }
        fx
    }

    /// Whether a kept signal waits for [`ResponseMachine::resume`].
    pub fn resume_due(&self) -> bool {
        self.held.is_some()
    }

    /// R11 and R13: whether an `interrupt` (`targeted`: it may name a statement) or `exit` sent as `s` is for
    /// the current run.
    fn applies(&self, s: &Sent, targeted: bool) -> Result<(), IgnoreReason> {
        match (targeted, s.by) {
            // R13, R14: an until's interrupt is for a run of its statement whose start was sent before it
            (true, Some(by)) => {
                if self.cause.map(|c| c.statement) != Some(by.statement) {
                    Err(IgnoreReason::OtherRun)
                } else if s.at < self.start_at {
                    Err(IgnoreReason::Before)
                } else {
                    Ok(())
                }
            }
            // R11
            _ if s.at < self.began => Err(IgnoreReason::Before),
            _ => Ok(()),
        }
    }

    /// R12: keeps a signal that reached the idle response, dropping what is too old to be used.
    /// R6: a `start` while not idle, by the start policy.
    fn start_while_busy(&mut self, p: P, s: Sent, fx: &mut Vec<Effect<P, O>>) {
        match self.policy {
            StartPolicy::Ignore => {
                Self::dropped(s, fx);
                self.ignore("start", IgnoreReason::Phase, fx)
            }
            StartPolicy::QueueOne => self.queue(p, s, fx),
            StartPolicy::Restart => {
                self.queue(p, s, fx);
                if self.phase == Phase::Running {
                    self.interrupt(fx);
                }
            }
        }
    }

    /// R2, R7: the start behaviour ended: the exit slot runs, for the reason it ended.
    fn start_ended(&mut self, end: StartEnd<O>, fx: &mut Vec<Effect<P, O>>) {
        self.held = None;
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
        self.run_exit(reason, fx);
    }

    /// R2, R6, R7, R8: the exit slot ended: `exited`, then a queued start, or a restart.
    fn exit_ended(&mut self, result: Result<ExitAction, String>, fx: &mut Vec<Effect<P, O>>) {
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
        fx.push(Effect::EmitExited(
            self.output.take().unwrap_or_default(),
            self.cause,
        ));
        self.phase = Phase::Idle;
        self.ended = self.clock.now();
        let finished = self.current.take();
        if self.stopping {
            // shutting down: the run is over and nothing starts again
        } else if let Some((p, s)) = self.pending.take() {
            self.begin(p, s, fx);
            // R14: the until's interrupt that came while this start waited ends this run at its first await
            self.held = self.bound.take();
        } else if let (ExitAction::Restart, Some(p)) = (action, finished) {
            self.counters.restarts += 1;
            self.begin(p, Sent::at(self.clock.now()), fx);
        }
    }

    /// T2: the clock stepped back to `now`: what is remembered as later than `now` is brought back to it.
    fn step_back(&mut self, now: i64) {
        self.began = self.began.min(now);
        self.ended = self.ended.min(now);
        self.kept.step_back(now);
        if let Some(k) = self.held.as_mut() {
            let s = k.sent_mut();
            s.at = s.at.min(now);
        }
        if let Some((_, s)) = &mut self.pending {
            s.at = s.at.min(now);
        }
    }

    fn keep(&mut self, k: Kept) {
        self.kept.keep(k, self.clock.now());
    }

    /// R12: the run begun by a start sent as `s` takes the earliest kept signal that was sent after it (within
    /// [`HOLD`]) and is for it; kept signals sent before the start are of no use any more, but another
    /// statement's `until` interrupt stays for its own run (R14).
    fn take_kept(&mut self, s: Sent) {
        self.held = self.kept.take_for_run(s, self.cause, self.began);
    }

    fn begin(&mut self, p: P, s: Sent, fx: &mut Vec<Effect<P, O>>) {
        self.counters.starts += 1;
        self.phase = Phase::Running;
        self.output = None;
        self.current = Some(p.clone());
        self.cause = s.by;
        self.start_at = s.at;
        self.began = s.at.max(self.ended);
        self.held = None;
        self.announced = self.announce == Announce::OnStart;
        if self.announced {
            fx.push(Effect::EmitStarted(p.clone(), self.cause));
        }
        fx.push(Effect::RunStart(p));
    }

    fn interrupt(&mut self, fx: &mut Vec<Effect<P, O>>) {
        self.counters.interrupts += 1;
        self.phase = Phase::Interrupting;
        self.held = None;
        fx.push(Effect::CancelStart);
        fx.push(Effect::EmitInterrupted(self.cause));
        fx.push(Effect::RunInterrupt);
    }

    fn run_exit(&mut self, reason: ExitReason, fx: &mut Vec<Effect<P, O>>) {
        self.phase = Phase::Exiting;
        self.held = None;
        self.last_exit = Some(reason.clone());
        fx.push(Effect::RunExit(reason));
    }

    fn queue(&mut self, p: P, s: Sent, fx: &mut Vec<Effect<P, O>>) {
        if let Some((_, old)) = self.pending.replace((p, s)) {
            self.counters.ignored_starts += 1;
            Self::dropped(old, fx);
        }
        // R14: what was kept with a start this one replaces is kept again: an until's interrupt sent after
        // both starts of its statement bounds the newer one's run too, and one of another statement waits for
        // that statement's next start
        if let Some(b) = self.bound.take() {
            self.keep(b);
        }
        // an until's interrupt of this start's statement, sent after it and kept while the start was on its
        // way, goes with it
        self.bound = self.kept.take_until_of(s);
    }

    /// An interrupt `s` that is not for the current run (or reached a response in its interrupt or exit slot):
    /// an `until`'s is kept for a run of its statement that has not begun yet (R14), any other is ignored.
    fn not_for_this_run(&mut self, s: Sent, why: IgnoreReason, fx: &mut Vec<Effect<P, O>>) {
        if self.bind_queued(s) {
            return;
        }
        if s.by.is_some() && !self.stopping {
            // its statement's start may still be on its way (R14, as R12 for an idle response)
            self.keep(Kept::Interrupt(s));
        }
        self.ignore("interrupt", why, fx)
    }

    /// R14: an `until`'s interrupt `s` that has interrupted a run also bounds its statement's next run, if that
    /// run's start was sent before it (queued, or still on its way).
    fn bound_next(&mut self, s: Sent) {
        if s.by.is_some() && !self.bind_queued(s) {
            self.keep(Kept::Bound(s));
        }
    }

    /// R14: an `until`'s interrupt `s` that is not for the current run, but for the queued start's (sent by the
    /// same statement, before `s`): kept for that run. Whether it was.
    fn bind_queued(&mut self, s: Sent) -> bool {
        let for_queued = match (s.by, &self.pending) {
            (Some(by), Some((_, start))) => {
                start.by.map(|c| c.statement) == Some(by.statement) && s.at >= start.at
            }
            _ => false,
        };
        if for_queued {
            self.bound = Some(Kept::Bound(s));
        }
        for_queued
    }

    /// R6: a start sent as `s` is not taken: if a statement sent it, it hears of it.
    fn dropped(s: Sent, fx: &mut Vec<Effect<P, O>>) {
        if let Some(c) = s.by {
            fx.push(Effect::EmitDropped(c));
        }
    }

    fn ignore(&mut self, signal: &'static str, why: IgnoreReason, fx: &mut Vec<Effect<P, O>>) {
        match signal {
            "start" => self.counters.ignored_starts += 1,
            "interrupt" => self.counters.ignored_interrupts += 1,
            _ => self.counters.ignored_exits += 1,
        }
        fx.push(Effect::Ignored {
            signal,
            phase: self.phase,
            why,
        });
    }
}

#[cfg(test)]
// the tests step machines into a state and look at the effects of the steps that matter
#[allow(unused_must_use)]
mod tests {
    use super::*;
    use Effect::*;

    type M = ResponseMachine<u32, String>;

    fn running(policy: StartPolicy) -> M {
        let mut m = M::new(policy);
        assert_eq!(
            m.handle(Input::Start(7, Sent::default())),
            vec![EmitStarted(7, None), RunStart(7)]
        );
        m
    }

    #[test]
    fn r1_start_while_idle_emits_started_then_runs_with_the_payload() {
        let m = running(StartPolicy::Ignore);
        assert_eq!(m.phase(), Phase::Running);
        assert_eq!(m.counters().starts, 1);
    }

    #[test]
    fn r2_normal_end_runs_exit_slot_then_emits_exited_with_the_output() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::StartEnded(StartEnd::Returned("done".into())));
        assert_eq!(fx, vec![RunExit(ExitReason::Completed)]);
        assert_eq!(m.phase(), Phase::Exiting);
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(fx, vec![EmitExited("done".into(), None)]);
        assert_eq!(m.phase(), Phase::Idle);
        assert_eq!(m.counters().completed, 1);
        assert_eq!(m.counters().exits, 1);
    }

    #[test]
    fn r3_interrupt_cancels_start_emits_interrupted_runs_interrupt_then_exit() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::Interrupt(Sent::default()));
        assert_eq!(fx, vec![CancelStart, EmitInterrupted(None), RunInterrupt]);
        assert_eq!(m.phase(), Phase::Interrupting);
        let fx = m.handle(Input::InterruptEnded(None));
        assert_eq!(fx, vec![RunExit(ExitReason::Interrupted)]);
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![EmitExited(String::new(), None)],
            "interrupted runs carry the default output"
        );
        assert_eq!(m.counters().interrupts, 1);
        assert_eq!(m.last_exit(), Some(&ExitReason::Interrupted));
    }

    #[test]
    fn r4_exit_signal_skips_the_interrupt_slot() {
        let mut m = running(StartPolicy::Ignore);
        let fx = m.handle(Input::Exit(Sent::default()));
        assert_eq!(fx, vec![CancelStart, RunExit(ExitReason::ExitSignal)]);
        assert_eq!(m.phase(), Phase::Exiting);
        m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(m.counters().exit_signals, 1);
        assert_eq!(m.counters().interrupts, 0);
    }

    #[test]
    fn r5_interrupt_and_exit_are_ignored_when_idle_interrupting_or_exiting() {
        let mut m = M::new(StartPolicy::Ignore);
        assert!(matches!(
            m.handle(Input::Interrupt(Sent::default()))[..],
            [Ignored {
                signal: "interrupt",
                phase: Phase::Idle,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit(Sent::default()))[..],
            [Ignored {
                signal: "exit",
                phase: Phase::Idle,
                ..
            }]
        ));
        m.handle(Input::Start(1, Sent::default()));
        m.handle(Input::Interrupt(Sent::default()));
        assert!(matches!(
            m.handle(Input::Interrupt(Sent::default()))[..],
            [Ignored {
                phase: Phase::Interrupting,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit(Sent::default()))[..],
            [Ignored {
                phase: Phase::Interrupting,
                ..
            }]
        ));
        m.handle(Input::InterruptEnded(None));
        assert!(matches!(
            m.handle(Input::Interrupt(Sent::default()))[..],
            [Ignored {
                phase: Phase::Exiting,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit(Sent::default()))[..],
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
    fn r6_ignore_policy_counts_starts_while_busy() {
        let mut m = running(StartPolicy::Ignore);
        assert!(matches!(
            m.handle(Input::Start(8, Sent::default()))[..],
            [Ignored {
                signal: "start",
                ..
            }]
        ));
        m.handle(Input::StartEnded(StartEnd::Returned(String::new())));
        assert!(matches!(
            m.handle(Input::Start(9, Sent::default()))[..],
            [Ignored {
                phase: Phase::Exiting,
                ..
            }]
        ));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new(), None)]
        );
        assert_eq!(m.counters().ignored_starts, 2);
        assert_eq!(m.phase(), Phase::Idle);
    }

    #[test]
    fn r6_restart_policy_interrupts_then_starts_the_new_payload() {
        let mut m = running(StartPolicy::Restart);
        assert_eq!(
            m.handle(Input::Start(8, Sent::default())),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        // a further start while interrupting replaces the pending payload
        assert!(m.handle(Input::Start(9, Sent::default())).is_empty());
        assert!(m.start_queued());
        m.handle(Input::InterruptEnded(None));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![
                EmitExited(String::new(), None),
                EmitStarted(9, None),
                RunStart(9)
            ]
        );
        assert_eq!(
            m.counters().ignored_starts,
            1,
            "payload 8 was replaced by 9"
        );
        assert_eq!(m.counters().starts, 2);
    }

    #[test]
    fn r6_queue_one_runs_the_newest_payload_after_exited() {
        let mut m = running(StartPolicy::QueueOne);
        assert!(m.handle(Input::Start(8, Sent::default())).is_empty());
        assert!(m.handle(Input::Start(9, Sent::default())).is_empty());
        assert_eq!(m.phase(), Phase::Running, "queue-one does not interrupt");
        m.handle(Input::StartEnded(StartEnd::Returned("a".into())));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        assert_eq!(
            fx,
            vec![
                EmitExited("a".into(), None),
                EmitStarted(9, None),
                RunStart(9)
            ]
        );
        assert_eq!(m.counters().ignored_starts, 1);
    }

    #[test]
    fn r7_exit_slot_runs_after_error_and_panic_and_exited_follows_an_exit_panic() {
        let mut m = running(StartPolicy::Ignore);
        assert_eq!(
            m.handle(Input::StartEnded(StartEnd::Failed("no path".into()))),
            vec![RunExit(ExitReason::Failed("no path".into()))]
        );
        m.handle(Input::ExitEnded(Ok(ExitAction::Done)));
        m.handle(Input::Start(1, Sent::default()));
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
                EmitExited(String::new(), None)
            ]
        );
        assert_eq!(m.phase(), Phase::Idle);
        assert_eq!(m.counters().failures, 1);
        assert_eq!(m.counters().panics, 2);
        assert_eq!(m.counters().exits, 2);
    }

    #[test]
    fn r7_interrupt_slot_panic_still_runs_the_exit_slot() {
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Interrupt(Sent::default()));
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
    fn r8_exit_slot_restart_starts_again_with_the_same_payload() {
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Interrupt(Sent::default()));
        m.handle(Input::InterruptEnded(None));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Restart)));
        assert_eq!(
            fx,
            vec![
                EmitExited(String::new(), None),
                EmitStarted(7, None),
                RunStart(7)
            ]
        );
        assert_eq!(m.counters().restarts, 1);
        assert_eq!(m.phase(), Phase::Running);
    }

    #[test]
    fn r8_a_queued_start_takes_precedence_over_an_exit_restart() {
        let mut m = running(StartPolicy::QueueOne);
        m.handle(Input::Start(9, Sent::default()));
        m.handle(Input::StartEnded(StartEnd::Returned(String::new())));
        let fx = m.handle(Input::ExitEnded(Ok(ExitAction::Restart)));
        assert_eq!(
            fx,
            vec![
                EmitExited(String::new(), None),
                EmitStarted(9, None),
                RunStart(9)
            ]
        );
        assert_eq!(m.counters().restarts, 0);
    }

    #[test]
    fn stop_runs_the_exit_slot_and_then_starts_nothing() {
        let mut m = running(StartPolicy::QueueOne);
        m.handle(Input::Start(9, Sent::default()));
        assert_eq!(m.stop(), vec![CancelStart, RunExit(ExitReason::ExitSignal)]);
        assert!(!m.start_queued());
        assert!(matches!(
            m.handle(Input::Start(10, Sent::default()))[..],
            [Ignored {
                signal: "start",
                ..
            }]
        ));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Restart))),
            vec![EmitExited(String::new(), None)]
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
        assert_eq!(
            m.handle(Input::Start(7, Sent::default())),
            vec![RunStart(7)]
        );
        m
    }

    #[test]
    fn r9_started_goes_out_on_acceptance_once_per_run() {
        let mut m = announcing(StartPolicy::Ignore);
        assert_eq!(m.phase(), Phase::Running);
        assert_eq!(m.handle(Input::Accepted), vec![EmitStarted(7, None)]);
        assert_eq!(m.handle(Input::Accepted), vec![]);
        m.handle(Input::StartEnded(StartEnd::Returned("r".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Restart))),
            vec![EmitExited("r".into(), None), RunStart(7)]
        );
        assert_eq!(
            m.handle(Input::Accepted),
            vec![EmitStarted(7, None)],
            "a new run announces again"
        );
    }

    #[test]
    fn r9_a_run_ended_before_acceptance_exits_without_started() {
        // rejected
        let mut m = announcing(StartPolicy::Ignore);
        m.handle(Input::StartEnded(StartEnd::Failed("rejected".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new(), None)]
        );
        assert_eq!(
            m.handle(Input::Accepted),
            vec![],
            "nothing runs: no started"
        );
        // interrupted before acceptance: interrupted and exited, and a late acceptance says nothing
        let mut m = announcing(StartPolicy::Ignore);
        assert_eq!(
            m.handle(Input::Interrupt(Sent::default())),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        assert_eq!(m.handle(Input::Accepted), vec![]);
        m.handle(Input::InterruptEnded(None));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new(), None)]
        );
        assert_eq!(m.counters().interrupts, 1);
    }

    #[test]
    fn r10_an_output_handed_over_while_interrupting_is_carried_by_exited() {
        let mut m = announcing(StartPolicy::Ignore);
        m.handle(Input::Accepted);
        m.handle(Input::Interrupt(Sent::default()));
        assert_eq!(m.handle(Input::Output("partial".into())), vec![]);
        m.handle(Input::InterruptEnded(None));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited("partial".into(), None)]
        );
        // a returned output replaces one handed over; an output while idle is dropped
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Output("early".into()));
        m.handle(Input::StartEnded(StartEnd::Returned("final".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited("final".into(), None)]
        );
        m.handle(Input::Output("stray".into()));
        m.handle(Input::Start(1, Sent::default()));
        m.handle(Input::StartEnded(StartEnd::Failed("x".into())));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new(), None)]
        );
    }

    // ---- R11-R13: order by cause, not by arrival

    const K: Cause = Cause {
        statement: 7,
        delivery: 1,
    };
    const OTHER: Cause = Cause {
        statement: 8,
        delivery: 1,
    };

    fn started_by(policy: StartPolicy, s: Sent) -> M {
        let mut m = M::new(policy);
        let fx = m.handle(Input::Start(7, s));
        assert_eq!(fx, vec![EmitStarted(7, s.by), RunStart(7)]);
        m
    }

    #[test]
    fn r11_an_interrupt_or_exit_sent_before_the_run_began_is_not_for_it() {
        let mut m = started_by(StartPolicy::Ignore, Sent::at(100));
        assert!(matches!(
            m.handle(Input::Interrupt(Sent::at(90)))[..],
            [Ignored {
                why: IgnoreReason::Before,
                ..
            }]
        ));
        assert!(matches!(
            m.handle(Input::Exit(Sent::at(99)))[..],
            [Ignored {
                signal: "exit",
                why: IgnoreReason::Before,
                ..
            }]
        ));
        assert_eq!(m.phase(), Phase::Running);
        assert_eq!(
            (m.counters().ignored_interrupts, m.counters().ignored_exits),
            (1, 1)
        );
        // sent at or after the run began: for this run
        assert_eq!(
            m.handle(Input::Interrupt(Sent::at(100))),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
    }

    #[test]
    fn r11_a_run_begins_no_earlier_than_the_end_of_the_run_before_it() {
        // a start sent at 100 arrives while a run goes on; it is queued, and that run ends at 300
        let mut m = started_by(StartPolicy::QueueOne, Sent::at(50));
        assert!(m.handle_at(Input::Start(8, Sent::at(100)), 110).is_empty());
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 290);
        let fx = m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 300);
        assert_eq!(
            fx,
            vec![
                EmitExited(String::new(), None),
                EmitStarted(8, None),
                RunStart(8)
            ]
        );
        assert_eq!(m.began(), Some(300));
        // an interrupt sent at 200 was meant for the run before (it arrived late): not for this one
        assert!(matches!(
            m.handle_at(Input::Interrupt(Sent::at(200)), 310)[..],
            [Ignored { .. }]
        ));
        // a restart (R8) begins when it starts, and has no cause
        let mut m = started_by(StartPolicy::Ignore, Sent::by(50, K));
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 60);
        let fx = m.handle_at(Input::ExitEnded(Ok(ExitAction::Restart)), 70);
        assert_eq!(
            fx,
            vec![
                EmitExited(String::new(), Some(K)),
                EmitStarted(7, None),
                RunStart(7)
            ]
        );
        assert_eq!((m.began(), m.cause()), (Some(70), None));
    }

    #[test]
    fn r12_an_interrupt_read_before_the_start_it_follows_interrupts_that_run() {
        let mut m = M::new(StartPolicy::Ignore);
        // the interrupt (sent at 200) is read first, while idle: ignored for now, kept
        assert!(matches!(
            m.handle_at(Input::Interrupt(Sent::at(200)), 210)[..],
            [Ignored { .. }]
        ));
        assert_eq!(m.counters().ignored_interrupts, 1);
        // the start sent at 150 arrives: its run begins, runs to its first await, then takes the interrupt
        assert_eq!(
            m.handle_at(Input::Start(1, Sent::at(150)), 220),
            vec![EmitStarted(1, None), RunStart(1)]
        );
        assert!(m.resume_due());
        assert_eq!(
            m.resume(),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        assert!(m.resume().is_empty(), "once");
        assert_eq!(
            (m.counters().interrupts, m.counters().ignored_interrupts),
            (1, 0)
        );
        // the same with an exit signal
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Exit(Sent::at(200)), 210);
        m.handle_at(Input::Start(1, Sent::at(150)), 220);
        assert_eq!(
            m.resume(),
            vec![CancelStart, RunExit(ExitReason::ExitSignal)]
        );
        assert_eq!(m.counters().ignored_exits, 0);
    }

    #[test]
    fn r12_kept_signals_do_not_reach_starts_sent_after_them_or_long_before() {
        // sent after the interrupt: the interrupt came first, the run is not interrupted
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(Sent::at(200)), 210);
        m.handle_at(Input::Start(1, Sent::at(250)), 260);
        assert!(!m.resume_due() && m.resume().is_empty());
        // a start sent more than HOLD before the interrupt is not its cause
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(Sent::at(HOLD + 200)), HOLD + 210);
        m.handle_at(Input::Start(1, Sent::at(100)), HOLD + 220);
        assert!(m.resume().is_empty());
        // an interrupt sent before the previous run ended is not for the next run (R11)
        let mut m = started_by(StartPolicy::Ignore, Sent::at(10));
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 20);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 300);
        m.handle_at(Input::Interrupt(Sent::at(200)), 310); // read late, while idle
        m.handle_at(Input::Start(1, Sent::at(150)), 320); // begins at 300 (the end of the run before)
        assert!(m.resume().is_empty());
    }

    #[test]
    fn r14_an_until_interrupt_for_a_queued_start_bounds_its_run() {
        let other = Cause {
            statement: 9,
            delivery: 1,
        };
        for policy in [StartPolicy::QueueOne, StartPolicy::Restart] {
            // R runs another statement's run; K's start is queued (Restart: the run before is interrupted and
            // still in its interrupt slot)
            let mut m = started_by(policy, Sent::by(10, other));
            m.handle_at(Input::Start(8, Sent::by(20, K)), 20);
            assert!(m.start_queued(), "{policy:?}");
            // K's until comes while that start waits: kept for its run, not ignored
            let fx = m.handle_at(Input::Interrupt(Sent::by(30, K)), 30);
            assert!(
                !fx.iter().any(|e| matches!(e, Ignored { .. })),
                "{policy:?}: {fx:?}"
            );
            // the run before ends; K's run begins, announced, and takes the interrupt at its first await
            if policy == StartPolicy::QueueOne {
                m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
            } else {
                m.handle_at(Input::InterruptEnded(None), 40);
            }
            let fx = m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
            assert_eq!(
                fx,
                vec![
                    EmitExited(String::new(), Some(other)),
                    EmitStarted(8, Some(K)),
                    RunStart(8)
                ],
                "{policy:?}"
            );
            assert!(m.resume_due(), "{policy:?}");
            assert_eq!(
                m.resume(),
                vec![CancelStart, EmitInterrupted(Some(K)), RunInterrupt],
                "{policy:?}"
            );
            assert_eq!(m.counters().ignored_interrupts, 0, "{policy:?}");
        }
    }

    #[test]
    fn r14_an_until_interrupt_sent_before_the_queued_start_or_by_another_statement_is_not_kept() {
        let other = Cause {
            statement: 9,
            delivery: 1,
        };
        // sent before K's start: not for its run
        let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, other));
        m.handle_at(Input::Start(8, Sent::by(30, K)), 30);
        m.handle_at(Input::Interrupt(Sent::by(20, K)), 31);
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
        assert!(!m.resume_due() && m.resume().is_empty());
        // another statement's until: not for K's run
        let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, other));
        m.handle_at(Input::Start(8, Sent::by(20, K)), 20);
        let third = Cause {
            statement: 5,
            delivery: 1,
        };
        m.handle_at(Input::Interrupt(Sent::by(30, third)), 30);
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
        assert!(!m.resume_due());
        // a newer start of no statement that replaces the queued one does not take it
        let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, other));
        m.handle_at(Input::Start(8, Sent::by(20, K)), 20);
        m.handle_at(Input::Interrupt(Sent::by(30, K)), 30);
        m.handle_at(Input::Start(9, Sent::at(35)), 35);
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
        assert!(!m.resume_due());
    }

    #[test]
    fn r14_a_start_that_replaces_a_queued_one_of_its_statement_takes_the_until_sent_after_both() {
        let other = Cause {
            statement: 9,
            delivery: 1,
        };
        let k2 = Cause {
            statement: K.statement,
            delivery: K.delivery + 1,
        };
        // K's two starts (sent at 20 and 25) both came before its until's interrupt (30), the first queued
        // and then replaced: the run the second begins is bounded by that interrupt
        for (second_at, bounded) in [(25, true), (35, false)] {
            let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, other));
            m.handle_at(Input::Start(8, Sent::by(20, K)), 20);
            m.handle_at(Input::Interrupt(Sent::by(30, K)), 30);
            m.handle_at(Input::Start(9, Sent::by(second_at, k2)), 36);
            m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
            let fx = m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
            assert!(fx.contains(&RunStart(9)), "{fx:?}");
            assert_eq!(m.resume_due(), bounded, "second start sent at {second_at}");
            if bounded {
                assert_eq!(
                    m.resume(),
                    vec![CancelStart, EmitInterrupted(Some(k2)), RunInterrupt]
                );
            }
        }
        // a start of no statement replaces K's queued one, and K's second start (sent before the interrupt)
        // comes later still: the interrupt, kept again, bounds that run
        let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, other));
        m.handle_at(Input::Start(8, Sent::by(20, K)), 20);
        m.handle_at(Input::Interrupt(Sent::by(30, K)), 30);
        m.handle_at(Input::Start(7, Sent::at(35)), 35);
        m.handle_at(Input::Start(9, Sent::by(25, k2)), 36);
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 40);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 50);
        assert_eq!(
            m.resume(),
            vec![CancelStart, EmitInterrupted(Some(k2)), RunInterrupt]
        );
    }

    #[test]
    fn r6_a_start_a_statement_sent_that_is_not_taken_is_announced_with_its_cause() {
        let dropped = |fx: &[Effect<u32, String>]| -> Vec<Cause> {
            fx.iter()
                .filter_map(|e| match e {
                    EmitDropped(c) => Some(*c),
                    _ => None,
                })
                .collect()
        };
        // busy, ignore: dropped
        let mut m = started_by(StartPolicy::Ignore, Sent::by(10, OTHER));
        assert_eq!(dropped(&m.handle(Input::Start(2, Sent::by(20, K)))), [K]);
        // a start no statement sent: nothing to tell
        assert!(dropped(&m.handle(Input::Start(3, Sent::at(30)))).is_empty());
        // queue_one: the start a newer one replaces is dropped, not the one that waits
        let mut m = started_by(StartPolicy::QueueOne, Sent::by(10, OTHER));
        assert!(dropped(&m.handle(Input::Start(2, Sent::by(20, K)))).is_empty());
        let k2 = Cause {
            statement: 5,
            delivery: 1,
        };
        assert_eq!(dropped(&m.handle(Input::Start(3, Sent::by(30, k2)))), [K]);
        // a stop drops the queued one
        assert_eq!(dropped(&m.stop()), [k2]);
        // and every start it reads from then on
        assert_eq!(dropped(&m.handle(Input::Start(4, Sent::by(40, K)))), [K]);
        // a start taken is not dropped
        let mut m = M::new(StartPolicy::Ignore);
        assert!(dropped(&m.handle(Input::Start(1, Sent::by(10, K)))).is_empty());
    }

    #[test]
    fn r14_a_kept_until_interrupt_outlives_another_run_until_its_statements_start_comes() {
        // K's until interrupt (sent at 30, after K's start sent at 20) overtakes that start and is kept
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(Sent::by(30, K)), 40);
        // a plain start sent at 70 arrives first: its run is not K's, the interrupt is not for it
        assert_eq!(
            m.handle_at(Input::Start(1, Sent::at(70)), 80),
            vec![EmitStarted(1, None), RunStart(1)]
        );
        assert!(!m.resume_due() && m.resume().is_empty());
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 90);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 100);
        // K's start arrives: its run takes the interrupt that was sent after it
        assert_eq!(
            m.handle_at(Input::Start(2, Sent::by(20, K)), 110),
            vec![EmitStarted(2, Some(K)), RunStart(2)]
        );
        assert!(m.resume_due());
        assert_eq!(
            m.resume(),
            vec![CancelStart, EmitInterrupted(Some(K)), RunInterrupt]
        );
        // a run of K itself drops its statement's older interrupt: sent before this start, for no later run
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(Sent::by(30, K)), 40);
        m.handle_at(Input::Start(1, Sent::by(70, K)), 80);
        m.handle_at(Input::StartEnded(StartEnd::Returned(String::new())), 90);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), 100);
        m.handle_at(Input::Start(2, Sent::by(20, K)), 110);
        assert!(!m.resume_due() && m.resume().is_empty());
    }

    const HOUR: i64 = 3_600_000_000_000;

    #[test]
    fn t1_a_start_stamped_by_a_clock_an_hour_ahead_does_not_blind_the_response() {
        let now = 10 * HOUR;
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now + HOUR)), now);
        assert_eq!(
            m.began(),
            Some(now),
            "the run begins when the start arrived"
        );
        // this host's own interrupt, a second later, interrupts it
        assert_eq!(
            m.handle_at(Input::Interrupt(Sent::at(now + 1_000)), now + 1_000),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        m.handle_at(Input::InterruptEnded(None), now + 2_000);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), now + 3_000);
        // and the next run, started from a host in step, is interrupted by this host too
        m.handle_at(Input::Start(2, Sent::at(now + 4_000)), now + 4_000);
        assert_eq!(m.began(), Some(now + 4_000));
        assert_eq!(
            m.handle_at(Input::Interrupt(Sent::at(now + 5_000)), now + 5_000),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
    }

    #[test]
    fn t1_signals_from_a_clock_far_behind_are_taken_as_late_not_as_older_than_every_run() {
        let now = 10 * HOUR;
        // a start from that host begins its run LATE before it arrived (T1), not an hour before
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now - HOUR)), now);
        assert_eq!(m.began(), Some(now - crate::time::LATE));
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now)), now);
        // an interrupt from a host an hour behind, read LATE after the run began, interrupts it
        let later = now + crate::time::LATE;
        assert_eq!(
            m.handle_at(Input::Interrupt(Sent::at(later - HOUR)), later),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        // read sooner, it is taken as sent before the run began (R11): the bound skew leaves
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now)), now);
        assert!(matches!(
            m.handle_at(Input::Interrupt(Sent::at(now + 10 - HOUR)), now + 10)[..],
            [Ignored {
                why: IgnoreReason::Before,
                ..
            }]
        ));
    }

    #[test]
    fn t2_after_this_hosts_clock_steps_back_its_signals_still_apply() {
        let now = 10 * HOUR;
        let step = 10_000_000_000; // an NTP correction of 10 s
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now)), now);
        // the clock steps back while the run goes on: an interrupt stamped by it applies
        let stepped = now + 1_000 - step;
        assert_eq!(
            m.handle_at(Input::Interrupt(Sent::at(stepped)), stepped),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
        m.handle_at(Input::InterruptEnded(None), stepped + 1);
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), stepped + 2);
        // a run that ended before a step does not make the next run begin in the future
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Start(1, Sent::at(now)), now);
        m.handle_at(
            Input::StartEnded(StartEnd::Returned(String::new())),
            now + 10,
        );
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), now + 20);
        let stepped = now + 30 - step;
        m.handle_at(Input::Start(2, Sent::at(stepped)), stepped);
        assert_eq!(m.began(), Some(stepped));
        assert_eq!(
            m.handle_at(Input::Exit(Sent::at(stepped + 5)), stepped + 5),
            vec![CancelStart, RunExit(ExitReason::ExitSignal)]
        );
        // a start queued before the step begins no later than the stepped clock when it runs
        let mut m = M::new(StartPolicy::QueueOne);
        m.handle_at(Input::Start(1, Sent::at(now)), now);
        m.handle_at(Input::Start(2, Sent::at(now + 10)), now + 10);
        let stepped = now + 20 - step;
        m.handle_at(
            Input::StartEnded(StartEnd::Returned(String::new())),
            stepped,
        );
        m.handle_at(Input::ExitEnded(Ok(ExitAction::Done)), stepped + 1);
        assert_eq!(m.began(), Some(stepped + 1));
        assert_eq!(
            m.handle_at(Input::Interrupt(Sent::at(stepped + 2)), stepped + 2),
            vec![CancelStart, EmitInterrupted(None), RunInterrupt]
        );
    }

    #[test]
    fn r13_an_until_interrupt_interrupts_only_runs_of_its_statement() {
        let until_k = Sent::by(
            500,
            Cause {
                statement: K.statement,
                delivery: 0,
            },
        );
        // a run of another statement, or of none, is not interrupted
        for run in [Sent::by(100, OTHER), Sent::at(100)] {
            let mut m = started_by(StartPolicy::Ignore, run);
            assert!(matches!(
                m.handle(Input::Interrupt(until_k))[..],
                [Ignored {
                    why: IgnoreReason::OtherRun,
                    ..
                }]
            ));
            assert_eq!(m.phase(), Phase::Running);
        }
        // a run of K is, with its cause on every signal of the run
        let mut m = started_by(StartPolicy::Ignore, Sent::by(100, K));
        assert_eq!(
            m.handle(Input::Interrupt(until_k)),
            vec![CancelStart, EmitInterrupted(Some(K)), RunInterrupt]
        );
        m.handle(Input::InterruptEnded(None));
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Done))),
            vec![EmitExited(String::new(), Some(K))]
        );
        // untargeted interrupts interrupt any run
        let mut m = started_by(StartPolicy::Ignore, Sent::by(100, OTHER));
        assert_eq!(m.handle(Input::Interrupt(Sent::at(200))).len(), 3);
    }

    #[test]
    fn r13_a_kept_until_interrupt_is_taken_only_by_a_start_of_its_statement() {
        let until_k = Sent::by(
            500,
            Cause {
                statement: K.statement,
                delivery: 0,
            },
        );
        // another statement's start sent before it: not its run
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(until_k), 510);
        m.handle_at(Input::Start(1, Sent::by(400, OTHER)), 520);
        assert!(!m.resume_due() && m.resume().is_empty());
        // K's start sent before it: interrupted
        let mut m = M::new(StartPolicy::Ignore);
        m.handle_at(Input::Interrupt(until_k), 510);
        m.handle_at(Input::Start(2, Sent::by(450, K)), 530);
        assert_eq!(
            m.resume(),
            vec![CancelStart, EmitInterrupted(Some(K)), RunInterrupt]
        );
    }

    #[test]
    fn r9_an_until_interrupt_before_acceptance_interrupts_the_goal() {
        // an action goal awaiting acceptance is a run of the statement that sent it
        let mut m = M::with_announce(StartPolicy::Ignore, Announce::WhenAccepted);
        assert_eq!(
            m.handle(Input::Start(7, Sent::by(100, K))),
            vec![RunStart(7)]
        );
        let until_k = Sent::by(
            150,
            Cause {
                statement: K.statement,
                delivery: 0,
            },
        );
        assert_eq!(
            m.handle(Input::Interrupt(until_k)),
            vec![CancelStart, EmitInterrupted(Some(K)), RunInterrupt]
        );
    }

    #[test]
    fn r7_abandoned_runs_still_run_their_exit_slot() {
        // running: the exit slot runs
        let mut m = running(StartPolicy::QueueOne);
        assert_eq!(
            m.abandon(),
            vec![CancelStart, RunExit(ExitReason::ExitSignal)]
        );
        // interrupting: the exit slot runs after the interrupt slot that was cut short
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::Interrupt(Sent::default()));
        assert_eq!(m.abandon(), vec![RunExit(ExitReason::Interrupted)]);
        // exiting: the exit slot did not reach its end: it runs again
        let mut m = running(StartPolicy::Ignore);
        m.handle(Input::StartEnded(StartEnd::Failed("x".into())));
        assert_eq!(m.abandon(), vec![RunExit(ExitReason::Failed("x".into()))]);
        assert_eq!(
            m.handle(Input::ExitEnded(Ok(ExitAction::Restart))),
            vec![EmitExited(String::new(), None)]
        );
        assert_eq!(m.phase(), Phase::Idle, "and nothing starts again");
        assert!(M::new(StartPolicy::Ignore).abandon().is_empty());
    }
}
