//! Model-based tests: random sequences of inputs, thousands per run, checked against small reference models
//! written from the rules in the crate documentation (not from the code), the way a reader of those rules
//! would predict what a response emits and what a connection delivers.

// some steps only bring the table into a state; their effects are checked where they matter
#![allow(unused_must_use)]

use proptest::prelude::*;
use radar_semantics::{
    connection::{ConnectionTable, Kind, Link, Until, Via},
    response::{
        Announce, Cause, Effect, ExitAction, Input, Phase, ResponseMachine, Sent, StartEnd,
        StartPolicy, HOLD,
    },
};

// ------------------------------------------------------------------------------------------- responses

/// What the wire shows of a response: its three signals, with the cause they carry (its statement).
#[derive(Clone, Debug, PartialEq, Eq)]
enum Wire {
    Started(u8, Option<u128>),
    Interrupted(Option<u128>),
    Exited(Option<u128>),
}

/// A slot signal an idle response keeps (R12).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KeptSignal {
    exit: bool,
    at: i64,
    /// The `until` statement an interrupt names (R13).
    by: Option<u128>,
    /// Counted as ignored until a run takes it (R12); an until's interrupt that interrupted the run before, or
    /// waited with a queued start (R14), is not.
    counted: bool,
}

/// The response rules R1-R14, as the crate documentation states them.
#[derive(Debug)]
struct ResponseModel {
    policy: StartPolicy,
    /// R9: `started` on acceptance instead of at once.
    on_accept: bool,
    /// Whether this run has said `started`.
    announced: bool,
    phase: Phase,
    payload: Option<u8>,
    queued: Option<(u8, Sent)>,
    stopping: bool,
    /// R11: when the run began, when the last one ended; the clock.
    began: i64,
    ended: i64,
    now: i64,
    /// R14: when the start of this run was sent.
    start_at: i64,
    /// R13: the statement whose start began this run.
    cause: Option<u128>,
    /// R12: what an idle response keeps, and what the run just begun takes at its first await.
    kept: Vec<KeptSignal>,
    held: Option<KeptSignal>,
    /// R14: an until's interrupt kept for the queued start's run.
    bound: Option<KeptSignal>,
    starts: u64,
    exits: u64,
    interrupts: u64,
    exit_signals: u64,
    ignored_starts: u64,
    ignored_interrupts: u64,
    ignored_exits: u64,
    restarts: u64,
    panics: u64,
}

impl ResponseModel {
    fn new(policy: StartPolicy, on_accept: bool) -> Self {
        ResponseModel {
            policy,
            on_accept,
            announced: false,
            phase: Phase::Idle,
            payload: None,
            queued: None,
            stopping: false,
            began: i64::MIN,
            ended: i64::MIN,
            now: i64::MIN,
            start_at: i64::MIN,
            cause: None,
            kept: Vec::new(),
            held: None,
            bound: None,
            starts: 0,
            exits: 0,
            interrupts: 0,
            exit_signals: 0,
            ignored_starts: 0,
            ignored_interrupts: 0,
            ignored_exits: 0,
            restarts: 0,
            panics: 0,
        }
    }

    /// R1: started, then the run (R9: started waits for acceptance); R11: the run begins no earlier than the
    /// end of the one before; R13: it carries its statement.
    fn begin(&mut self, p: u8, s: Sent, wire: &mut Vec<Wire>) {
        self.starts += 1;
        self.phase = Phase::Running;
        self.payload = Some(p);
        self.cause = s.by.map(|c| c.statement);
        self.began = s.at.max(self.ended);
        self.start_at = s.at;
        self.held = None;
        self.announced = !self.on_accept;
        if self.announced {
            wire.push(Wire::Started(p, self.cause));
        }
    }

    /// R3: interrupted as the interrupt slot begins.
    fn interrupt(&mut self, wire: &mut Vec<Wire>) {
        self.interrupts += 1;
        self.phase = Phase::Interrupting;
        self.held = None;
        wire.push(Wire::Interrupted(self.cause));
    }

    /// R11 and R13: whether a signal sent at `at` (an interrupt naming `by`) is for the current run.
    fn for_this_run(&self, at: i64, by: Option<u128>) -> bool {
        match by {
            // R13, R14: an until's, for a run of its statement whose start was sent before it
            Some(k) => self.cause == Some(k) && at >= self.start_at,
            // R11
            None => at >= self.began,
        }
    }

    fn input(&mut self, i: &Input<u8, ()>, now: i64) -> Vec<Wire> {
        self.now = self.now.max(now);
        if let Input::Start(_, s) | Input::Interrupt(s) | Input::Exit(s) = i {
            self.now = self.now.max(s.at);
        }
        let mut wire = Vec::new();
        match i {
            // R9: once per run, while running
            Input::Accepted => {
                if self.phase == Phase::Running && !self.announced {
                    self.announced = true;
                    wire.push(Wire::Started(
                        self.payload.expect("a run has a payload"),
                        self.cause,
                    ));
                }
            }
            // R10: only what exited carries changes (not seen on this wire)
            Input::Output(()) => {}
            Input::Start(p, s) => {
                if self.stopping {
                    self.ignored_starts += 1;
                } else if self.phase == Phase::Idle {
                    self.begin(*p, *s, &mut wire);
                    // R12: the earliest kept signal sent after this start (within HOLD) and meant for its run
                    let (began, cause) = (self.began, self.cause);
                    if let Some(i) = self.kept.iter().position(|k| {
                        let for_run = match (k.exit, k.by) {
                            // R14: an until's, sent after its statement's start, whenever the run began
                            (false, Some(b)) => cause == Some(b),
                            _ => k.at >= began,
                        };
                        k.at > s.at && k.at - s.at <= HOLD && for_run
                    }) {
                        self.held = Some(self.kept.remove(i));
                    }
                    // R12: what was sent before this start goes, but another statement's until (R14)
                    self.kept
                        .retain(|k| k.at > s.at || (!k.exit && k.by.is_some() && k.by != cause));
                } else {
                    // R6
                    match self.policy {
                        StartPolicy::Ignore => self.ignored_starts += 1,
                        StartPolicy::QueueOne | StartPolicy::Restart => {
                            if self.queued.replace((*p, *s)).is_some() {
                                self.ignored_starts += 1;
                            }
                            // R14: what was kept with a start this one replaces is kept again (as in R12);
                            // an until's interrupt of its statement, sent after it and kept while it was on
                            // its way (or with the start it replaces), goes with it
                            if let Some(b) = self.bound.take() {
                                self.keep(b);
                            }
                            let st = s.by.map(|c| c.statement);
                            self.bound = st
                                .and_then(|st| {
                                    self.kept.iter().position(|k| {
                                        !k.exit
                                            && k.by == Some(st)
                                            && k.at > s.at
                                            && k.at - s.at <= HOLD
                                    })
                                })
                                .map(|i| self.kept.remove(i));
                            if self.policy == StartPolicy::Restart && self.phase == Phase::Running {
                                self.interrupt(&mut wire);
                            }
                        }
                    }
                }
            }
            Input::Interrupt(s) | Input::Exit(s) => {
                let exit = matches!(i, Input::Exit(_));
                let by = if exit {
                    None
                } else {
                    s.by.map(|c| c.statement)
                };
                if self.phase == Phase::Running && self.for_this_run(s.at, by) {
                    if exit {
                        // R4
                        self.exit_signals += 1;
                        self.phase = Phase::Exiting;
                        self.held = None;
                    } else {
                        self.interrupt(&mut wire);
                        self.bound_next(s.at, by);
                    }
                } else if !exit
                    && by.is_some()
                    && self
                        .queued
                        .is_some_and(|(_, q)| q.by.map(|c| c.statement) == by && s.at >= q.at)
                {
                    // R14: an until's interrupt for the queued start's statement, sent after that start
                    self.bound = Some(KeptSignal {
                        exit: false,
                        at: s.at,
                        by,
                        counted: false,
                    });
                } else {
                    // R5, R11, R13 (and R12: an idle response keeps it; R14: any response keeps an until's)
                    if (self.phase == Phase::Idle || (!exit && by.is_some())) && !self.stopping {
                        self.keep(KeptSignal {
                            exit,
                            at: s.at,
                            by,
                            counted: true,
                        });
                    }
                    if exit {
                        self.ignored_exits += 1;
                    } else {
                        self.ignored_interrupts += 1;
                    }
                }
            }
            Input::StartEnded(end) => {
                // R2 (and R7: the exit slot runs after an error or a panic too)
                if let StartEnd::Panicked(_) = end {
                    self.panics += 1;
                }
                self.phase = Phase::Exiting;
                self.held = None;
            }
            Input::InterruptEnded(panic) => {
                if panic.is_some() {
                    self.panics += 1;
                }
                self.phase = Phase::Exiting;
            }
            Input::ExitEnded(r) => {
                // R2, R7, R8
                if r.is_err() {
                    self.panics += 1;
                }
                self.exits += 1;
                wire.push(Wire::Exited(self.cause));
                self.phase = Phase::Idle;
                self.ended = self.now;
                let finished = self.payload.take();
                if self.stopping {
                } else if let Some((p, s)) = self.queued.take() {
                    self.begin(p, s, &mut wire);
                    // R14: the run takes the kept interrupt at its first await (as a kept signal of R12)
                    if let Some(k) = self.bound.take() {
                        self.held = Some(k);
                    }
                } else if let (Ok(ExitAction::Restart), Some(p)) = (r, finished) {
                    self.restarts += 1;
                    self.begin(p, Sent::at(self.now), &mut wire);
                }
            }
        }
        wire
    }

    /// R14: an until's interrupt that interrupted a run also bounds its statement's next run whose start was
    /// sent before it (queued, or on its way: kept as in R12, not counted as ignored).
    fn bound_next(&mut self, at: i64, by: Option<u128>) {
        if by.is_none() {
            return;
        }
        let k = KeptSignal {
            exit: false,
            at,
            by,
            counted: false,
        };
        if self
            .queued
            .is_some_and(|(_, q)| q.by.map(|c| c.statement) == by && at >= q.at)
        {
            self.bound = Some(k);
        } else {
            self.keep(k);
        }
    }

    /// R12: keeps a signal, the newest 8 sent within HOLD of now.
    fn keep(&mut self, k: KeptSignal) {
        self.kept.retain(|k| k.at >= self.now.saturating_sub(HOLD));
        if self.kept.len() == 8 {
            self.kept.remove(0);
        }
        self.kept.push(k);
    }

    /// R12: the run just begun reached its first await: a signal it took applies now.
    fn resume(&mut self) -> Vec<Wire> {
        let mut wire = Vec::new();
        if let (Some(k), Phase::Running) = (self.held.take(), self.phase) {
            if k.exit {
                self.exit_signals += 1;
                self.phase = Phase::Exiting;
            } else {
                if k.counted {
                    self.ignored_interrupts -= 1;
                }
                self.interrupt(&mut wire);
                self.bound_next(k.at, k.by);
            }
            if k.exit {
                self.ignored_exits -= 1;
            }
        }
        wire
    }

    /// Stopping the response ends a run as an `exit` signal would.
    fn stop(&mut self) -> Vec<Wire> {
        self.stopping = true;
        self.queued = None;
        self.bound = None;
        self.kept.clear();
        self.held = None;
        if self.phase == Phase::Running {
            self.exit_signals += 1;
            self.phase = Phase::Exiting;
        }
        Vec::new()
    }
}

/// Two statements, as R13 sees them: their starts carry these, their `until`s name them.
const STATEMENTS: [u128; 2] = [1 << 64 | 1, 1 << 64 | 2];

fn by(k: u8) -> Option<Cause> {
    (k > 0).then(|| Cause {
        statement: STATEMENTS[k as usize - 1],
        delivery: 1,
    })
}

/// How late a signal is read, in steps of 10: it was emitted before the signals read before it (R11, R12).
const LATE: [i64; 4] = [0, 3, 12, 25];

/// What the test harness asks for at each step; completions apply to whichever slot runs.
#[derive(Clone, Debug)]
enum Step {
    /// A start with a payload, read `LATE[late]` after it was sent, by no statement (0) or one of two.
    Start(u8, usize, u8),
    /// An interrupt read late, naming no statement (0) or one of two (an until's).
    Interrupt(usize, u8),
    Exit(usize),
    /// The running slot finishes: 0 normally, 1 with an error (start) or a restart (exit), 2 by panicking.
    Finish(u8),
    /// The start behaviour reports acceptance (R9).
    Accept,
    /// A slot hands over the output (R10).
    Output,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        3 => (0u8..4, 0usize..4, 0u8..3).prop_map(|(p, l, b)| Step::Start(p, l, b)),
        2 => (0usize..4, 0u8..3).prop_map(|(l, b)| Step::Interrupt(l, b)),
        1 => (0usize..4).prop_map(Step::Exit),
        5 => (0u8..3).prop_map(Step::Finish),
        2 => Just(Step::Accept),
        1 => Just(Step::Output),
    ]
}

fn policy() -> impl Strategy<Value = StartPolicy> {
    prop_oneof![
        Just(StartPolicy::Ignore),
        Just(StartPolicy::QueueOne),
        Just(StartPolicy::Restart)
    ]
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Slot {
    None,
    Start,
    Interrupt,
    Exit,
}

fn wire_of(fx: &[Effect<u8, ()>]) -> Vec<Wire> {
    let st = |c: &Option<Cause>| c.map(|c| c.statement);
    fx.iter()
        .filter_map(|e| match e {
            Effect::EmitStarted(p, c) => Some(Wire::Started(*p, st(c))),
            Effect::EmitInterrupted(c) => Some(Wire::Interrupted(st(c))),
            Effect::EmitExited((), c) => Some(Wire::Exited(st(c))),
            _ => None,
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// The machine emits exactly what the rules say, in order, and counts what they say, for any sequence of
    /// signals (read in another order than they were sent, from two statements and from none) and slot
    /// completions a runtime can feed it; and the runtime's slot bookkeeping (which slot runs, from the
    /// effects) never sees two slots at once or a completion out of place.
    #[test]
    fn the_response_machine_follows_the_documented_rules(
        policy in policy(),
        on_accept in any::<bool>(),
        steps in prop::collection::vec(step(), 0..60),
        stop_at in prop::option::of(0usize..60),
    ) {
        let announce = if on_accept { Announce::WhenAccepted } else { Announce::OnStart };
        let mut m = ResponseMachine::<u8, ()>::with_announce(policy, announce);
        let mut model = ResponseModel::new(policy, on_accept);
        let mut slot = Slot::None;
        // runs begun, `started` and `exited` seen
        let (mut runs, mut started, mut exited) = (0u64, 0u64, 0u64);
        let mut started_this_run = 0;
        for (k, s) in steps.iter().enumerate() {
            let now = 1000 + k as i64 * 10;
            let sent = |late: usize, b: u8| Sent { at: now - LATE[late], by: by(b) };
            let (mut fx, mut expected) = if stop_at == Some(k) {
                (m.stop(), model.stop())
            } else {
                let input = match s {
                    Step::Start(p, late, b) => Input::Start(*p, sent(*late, *b)),
                    Step::Interrupt(late, b) => Input::Interrupt(sent(*late, *b)),
                    Step::Exit(late) => Input::Exit(sent(*late, 0)),
                    Step::Accept => Input::Accepted,
                    Step::Output => Input::Output(()),
                    Step::Finish(how) => match slot {
                        Slot::None => continue,
                        Slot::Start => Input::StartEnded(match how {
                            0 => StartEnd::Returned(()),
                            1 => StartEnd::Failed("e".into()),
                            _ => StartEnd::Panicked("p".into()),
                        }),
                        Slot::Interrupt => Input::InterruptEnded((*how == 2).then(|| "p".into())),
                        Slot::Exit => Input::ExitEnded(match how {
                            0 => Ok(ExitAction::Done),
                            1 => Ok(ExitAction::Restart),
                            _ => Err("p".into()),
                        }),
                    },
                };
                let expected = model.input(&input, now);
                (m.handle_at(input, now), expected)
            };
            // the runtime: a run just begun runs to its first await, then the machine resumes (R12)
            if fx.iter().any(|e| matches!(e, Effect::RunStart(_))) {
                fx.extend(m.resume());
                expected.extend(model.resume());
            }
            prop_assert_eq!(wire_of(&fx), expected, "step {} {:?}", k, s);
            // the runtime's view: which slot runs after these effects
            for e in &fx {
                match e {
                    Effect::RunStart(_) => {
                        prop_assert_eq!(slot, Slot::None, "a start while a slot runs");
                        slot = Slot::Start;
                        runs += 1;
                        // under R1 `started` came just before the run it announces
                        started_this_run = if on_accept { 0 } else { 1 };
                    }
                    Effect::CancelStart => { prop_assert_eq!(slot, Slot::Start); slot = Slot::None }
                    Effect::RunInterrupt => { prop_assert_eq!(slot, Slot::None); slot = Slot::Interrupt }
                    Effect::RunExit(_) => {
                        prop_assert!(slot == Slot::None || slot == Slot::Start || slot == Slot::Interrupt);
                        slot = Slot::Exit
                    }
                    Effect::EmitStarted(..) => {
                        started += 1;
                        if on_accept {
                            prop_assert_eq!(slot, Slot::Start, "started on acceptance only while the run runs");
                            started_this_run += 1;
                        }
                        prop_assert!(started_this_run <= 1, "one started per run (R9)");
                    }
                    Effect::EmitExited(..) => {
                        prop_assert_eq!(slot, Slot::Exit, "exited only after the exit slot (R7)");
                        slot = Slot::None;
                        exited += 1;
                    }
                    _ => {}
                }
            }
            prop_assert!(runs - exited <= 1, "one run at a time");
            prop_assert!(started <= runs);
            if !on_accept {
                prop_assert_eq!(started, runs, "R1: every run says started");
            }
            prop_assert_eq!(m.phase(), model.phase);
            let c = m.counters();
            prop_assert_eq!(
                (c.starts, c.exits, c.interrupts, c.exit_signals, c.ignored_starts, c.ignored_interrupts,
                 c.ignored_exits, c.restarts, c.panics),
                (model.starts, model.exits, model.interrupts, model.exit_signals, model.ignored_starts,
                 model.ignored_interrupts, model.ignored_exits, model.restarts, model.panics)
            );
        }
    }
}

// ------------------------------------------------------------------------------------------ connections

/// Connection rules C1-C7, as the crate documentation states them.
#[derive(Clone, Debug)]
struct ModelConn {
    id: u64,
    source: &'static str,
    target: &'static str,
    kind: Kind,
    armed_at: i64,
    spent: bool,
    link: Link,
    rearm: bool,
    delivered: u64,
    until: Option<ModelWindow>,
    /// C3: a spent once whose run has ended.
    over: bool,
}

impl ModelConn {
    /// Whether the table must read its source for it.
    fn reads(&self, s: &str) -> bool {
        (self.source == s && !self.spent && self.link != Link::TargetLost)
            || (self.until.is_some() && ["U", "R.started", "R.exited"].contains(&s))
    }
}

/// C3 for one until, as C6 (a response that keeps causes) and C7 (one that does not) say.
#[derive(Clone, Debug, Default)]
struct ModelWindow {
    causes: bool,
    // C6
    /// The latest start delivery whose run may be going.
    outstanding: Option<u64>,
    /// C7: the newest signal of U that was not sent.
    kept: Option<i64>,
    // C7, without causes: R's runs by their signals in emission order
    last: Option<i64>,
    running: bool,
    awaiting: bool,
    sent_while_running: Option<i64>,
    open_since: Option<i64>,
}

impl ModelWindow {
    fn new(causes: bool) -> Self {
        ModelWindow {
            causes,
            ..Default::default()
        }
    }
    /// Whether R's signal at `at` is newer than those applied (older ones are left alone).
    fn newer(&mut self, at: i64) -> bool {
        if self.last.is_some_and(|l| at < l) {
            return false;
        }
        self.last = Some(at);
        true
    }
    fn keep(&mut self, u: i64) {
        self.kept = Some(self.kept.map_or(u, |k| k.max(u)));
    }
    /// C3: no run of the statement may be going or still to come, by R's signals.
    fn settled(&self) -> bool {
        if self.causes {
            self.outstanding.is_none()
        } else {
            self.open_since.is_none() && !self.awaiting && self.sent_while_running.is_none()
        }
    }
    /// C6/C7: this statement delivered start `n`, its source emitted at `at`. A kept U that follows it.
    fn start_delivered(&mut self, n: u64, at: i64) -> Option<i64> {
        if self.causes {
            self.outstanding = Some(n);
            self.kept.take().filter(|&u| u > at && u - at <= HOLD)
        } else {
            if self.running {
                self.sent_while_running = Some(at);
            } else {
                self.awaiting = true;
            }
            None
        }
    }
    /// R's `started` at `at`: a kept U that goes now.
    fn started(&mut self, at: i64) -> Option<i64> {
        if self.causes || !self.newer(at) {
            return None;
        }
        self.running = true;
        self.sent_while_running = None;
        self.open_since = self.awaiting.then_some(at);
        self.awaiting = false;
        let kept = self.kept.take();
        match (self.open_since, kept) {
            (Some(since), Some(u)) if u >= since && u - since <= HOLD => Some(u),
            _ => None,
        }
    }
    /// R's `exited` at `at`, ending this statement's delivery `ours` (if it says so).
    fn exited(&mut self, at: i64, ours: Option<u64>) {
        if self.causes {
            if let (Some(n), Some(m)) = (self.outstanding, ours) {
                if m >= n {
                    self.outstanding = None;
                }
            }
            return;
        }
        if !self.newer(at) {
            return;
        }
        self.running = false;
        self.open_since = None;
        if self
            .sent_while_running
            .take()
            .is_some_and(|sent| at <= sent)
        {
            self.awaiting = true;
        }
    }
    /// U at `at`: whether it goes to R's interrupt.
    fn u(&mut self, at: i64) -> bool {
        if self.causes {
            if self.outstanding.is_some() {
                return true;
            }
            self.keep(at);
            return false;
        }
        match self.open_since {
            Some(since) => at >= since,
            None => {
                if self.awaiting || self.sent_while_running.is_some() {
                    self.keep(at);
                }
                false
            }
        }
    }
}

#[derive(Clone, Debug)]
enum Op {
    Arm {
        source: usize,
        target: usize,
        once: bool,
        until: bool,
        causes: bool,
        rearm: bool,
    },
    Remove(usize),
    /// E1, E2, U, R.started read now, as emitted now.
    Signal(usize),
    /// R.exited read now, carrying the cause of the latest start delivered to R (true) or none.
    RExited(bool),
    /// A signal of E1, E2 or U, or R's started or exited, read now but emitted that many steps ago (it was in
    /// flight).
    LateSignal(usize, i64),
    /// E1 or E2 leaves the graph / comes back.
    SourceLeaves(usize),
    SourceBack(usize),
    /// Q leaves / comes back.
    QLeaves,
    QBack,
    /// R (all four of its endpoints) leaves / comes back.
    RLeaves,
    RBack,
}

const SOURCES: [&str; 3] = ["E1", "E2", "U"];
const TARGETS: [&str; 2] = ["R.start", "Q.start"];

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        2 => (0usize..2, 0usize..2, any::<bool>(), any::<bool>(), any::<bool>(), any::<bool>())
            .prop_map(|(source, target, once, until, causes, rearm)|
                Op::Arm { source, target, once, until, causes, rearm }),
        1 => prop_oneof![
            (0usize..2).prop_map(Op::SourceLeaves),
            (0usize..2).prop_map(Op::SourceBack),
            Just(Op::QLeaves),
            Just(Op::QBack),
            Just(Op::RLeaves),
            Just(Op::RBack),
        ],
        1 => (0usize..8).prop_map(Op::Remove),
        // E1, E2, U, R.started
        6 => (0usize..4).prop_map(Op::Signal),
        2 => any::<bool>().prop_map(Op::RExited),
        2 => (0usize..5, 1i64..4).prop_map(|(k, back)| Op::LateSignal(k, back)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// What a table delivers, and which connections it keeps, is what the rules say: nothing emitted before a
    /// connection was armed, every signal for `whenever`, exactly one for `once`, U to R's `interrupt` as C6
    /// and C7 say (signals read out of order included), nothing after removal; and when components leave and
    /// come back, what C5 says.
    #[test]
    fn the_connection_table_follows_the_documented_rules(ops in prop::collection::vec(op(), 0..80)) {
        let mut t = ConnectionTable::<&'static str, &'static str>::with_statement_base(9);
        let mut model: Vec<ModelConn> = Vec::new();
        let mut ids: Vec<u64> = Vec::new();
        // the cause of the latest start delivered to R
        let mut r_cause: Option<Cause> = None;
        for (now, o) in ops.iter().enumerate() {
            let now = now as i64 * 10;
            match *o {
                Op::Arm { source, target, once, until, causes, rearm } => {
                    let kind = if once { Kind::Once } else { Kind::Whenever };
                    let (source, target) = (SOURCES[source], TARGETS[target]);
                    // an until only on R (its started/exited are the ones generated here)
                    let until = (until && target == "R.start").then_some(Until {
                        source: "U",
                        started: "R.started",
                        exited: "R.exited",
            dropped: "R.dropped",
                        interrupt: "R.interrupt",
                        causes,
                    });
                    let window = until.as_ref().map(|_| ModelWindow::new(causes));
                    let id = t.arm(source, target, kind, until, now);
                    t.set_rearm(id, rearm);
                    ids.push(id);
                    model.push(ModelConn {
                        id, source, target, kind, armed_at: now, spent: false, over: false, link: Link::Armed, rearm,
                        delivered: 0, until: window,
                    });
                }
                Op::Remove(k) => {
                    if let Some(id) = ids.get(k).copied() {
                        let existed = model.iter().any(|c| c.id == id);
                        prop_assert_eq!(t.remove(id), existed);
                        model.retain(|c| c.id != id);
                    }
                }
                Op::SourceLeaves(k) | Op::SourceBack(k) => {
                    let source = SOURCES[k];
                    let leaves = matches!(o, Op::SourceLeaves(_));
                    let mut got = if leaves { t.source_lost(&source) } else { t.source_back(&source) };
                    got.sort();
                    let mut want = Vec::new();
                    for c in model.iter_mut().filter(|c| c.source == source) {
                        if leaves && !c.spent && c.link == Link::Armed {
                            c.link = Link::WaitingForSource;
                            want.push(c.id);
                        }
                        if !leaves && c.link == Link::WaitingForSource {
                            c.link = Link::Armed;
                            want.push(c.id);
                        }
                    }
                    want.sort();
                    prop_assert_eq!(got, want);
                }
                Op::QLeaves | Op::RLeaves => {
                    let target = if matches!(o, Op::QLeaves) { "Q.start" } else { "R.start" };
                    t.target_lost(&target);
                    if target == "R.start" {
                        t.target_lost(&"R.interrupt");
                        t.source_lost(&"R.started");
                        t.source_lost(&"R.exited");
                    }
                    for c in model.iter_mut() {
                        if c.target == target && matches!(c.link, Link::Armed | Link::WaitingForSource) {
                            c.link = if c.rearm { Link::WaitingForTarget } else { Link::TargetLost };
                        }
                        // C5: R's run ended with it; a new R did not take this statement's start (C3: a
                        // spent once ... until is over)
                        if let (Some(w), "R.start") = (&mut c.until, target) {
                            *w = ModelWindow::new(w.causes);
                            c.over |= c.spent;
                        }
                    }
                    model.retain(|c| !c.over);
                }
                Op::QBack | Op::RBack => {
                    let target = if matches!(o, Op::QBack) { "Q.start" } else { "R.start" };
                    t.target_back(&target, now);
                    if target == "R.start" {
                        t.target_back(&"R.interrupt", now);
                        t.source_back(&"R.started");
                        t.source_back(&"R.exited");
                    }
                    for c in model.iter_mut() {
                        if c.target == target && c.link == Link::WaitingForTarget {
                            c.link = Link::Armed;
                            c.armed_at = c.armed_at.max(now);
                        }
                    }
                }
                Op::Signal(_) | Op::LateSignal(..) | Op::RExited(_) => {
                    let (k, emitted) = match *o {
                        Op::LateSignal(k, back) => (k, now - back * 10 + 5),
                        Op::Signal(k) => (k, now),
                        Op::RExited(_) => (4, now),
                        _ => unreachable!(),
                    };
                    let source = ["E1", "E2", "U", "R.started", "R.exited"][k];
                    let from = match *o {
                        Op::RExited(true) => r_cause,
                        _ => None,
                    };
                    let got: Vec<(u64, &str, Via)> = t
                        .on_signal_with(&source, emitted, from, |_| true)
                        .into_iter()
                        .map(|d| (d.id, d.target, d.via))
                        .collect();
                    let mut want = Vec::new();
                    for c in model.iter_mut() {
                        if emitted < c.armed_at {
                            continue; // C1
                        }
                        if let Some(w) = &mut c.until {
                            if source == "R.started" {
                                if let Some(at) = w.started(emitted) {
                                    want.push((c.id, "R.interrupt", Via::Until { at }));
                                }
                            }
                            if source == "R.exited" {
                                let ours = from.filter(|f| f.statement == t.statement(c.id)).map(|f| f.delivery);
                                w.exited(emitted, ours);
                                // C3: a spent once is over when the run its start began has ended
                                if c.spent && w.settled() {
                                    c.over = true;
                                }
                            }
                            if source == "U" && w.u(emitted) {
                                want.push((c.id, "R.interrupt", Via::Until { at: emitted }));
                            }
                        }
                        if c.source == source && !c.spent && c.link == Link::Armed {
                            c.delivered += 1;
                            want.push((c.id, c.target, Via::Signal { n: c.delivered }));
                            if c.target == "R.start" {
                                r_cause = Some(t.cause(c.id, c.delivered));
                            }
                            if let Some(w) = &mut c.until {
                                if let Some(at) = w.start_delivered(c.delivered, emitted) {
                                    want.push((c.id, "R.interrupt", Via::Until { at }));
                                }
                            }
                            if c.kind == Kind::Once {
                                c.spent = true;
                            }
                        }
                    }
                    model.retain(|c| !(c.over || (c.spent && c.until.is_none())));
                    prop_assert_eq!(got, want, "signal {} emitted at {}, read at {}", source, emitted, now);
                }
            }
            for c in &model {
                prop_assert!(t.contains(c.id), "connection {} is live", c.id);
                prop_assert_eq!(t.link(c.id), Some(c.link), "connection {}", c.id);
            }
            for s in SOURCES.iter().chain(&["R.started", "R.exited"]) {
                prop_assert_eq!(t.reads(s), model.iter().any(|c| c.reads(s)), "reads {}", s);
            }
            prop_assert_eq!(t.len(), model.len());
        }
    }
}

// ------------------------------------------------------------------------- the two, over a reordering network

/// What happens at each step of the network simulation.
#[derive(Clone, Debug)]
enum Net {
    /// E, U or the plain injector P emits now.
    EmitE,
    EmitU,
    EmitP,
    /// The oldest message on one channel is read (each channel keeps its order; channels do not).
    Deliver(usize),
    /// The response's running slot finishes (0 normally, 1 with a restart from the exit slot).
    Finish(u8),
}

fn net() -> impl Strategy<Value = Net> {
    prop_oneof![
        2 => Just(Net::EmitE),
        3 => Just(Net::EmitU),
        1 => Just(Net::EmitP),
        10 => (0usize..CHANNELS).prop_map(Net::Deliver),
        3 => (0u8..2).prop_map(Net::Finish),
    ]
}

/// The channels: E, U, R's started and exited to the manager; the manager's starts and interrupts, and P's
/// starts, to the response.
const CHANNELS: usize = 7;
const E_M: usize = 0;
const U_M: usize = 1;
const STARTED_M: usize = 2;
const EXITED_M: usize = 3;
const M_START: usize = 4;
const M_INTERRUPT: usize = 5;
const P_START: usize = 6;

#[derive(Clone, Copy, Debug)]
enum Msg {
    /// A signal of E, U, or R's `started`/`exited` (with its cause), emitted at `at`.
    Signal { at: i64, from: Option<Cause> },
    /// A slot signal to R.
    Slot(Sent),
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// `once|whenever E start R until U` through a manager, with every message on its own channel and the
    /// channels read in any interleaving (a signal of U can be read before the E it follows, R's `started` after
    /// a U that came after it, the manager's interrupt before its start): whatever the order of arrival,
    /// - R is interrupted only in a run this statement started, by a signal of U emitted after that run began
    ///   (never another statement's run, P's, or an exit-slot restart), and
    /// - once everything in flight has been read, no run of this statement is left running although a signal of
    ///   U was emitted after it began (nothing is lost because it was read in the wrong order).
    #[test]
    fn until_follows_cause_not_arrival_order(
        once in any::<bool>(),
        policy in prop_oneof![Just(StartPolicy::Ignore), Just(StartPolicy::QueueOne)],
        steps in prop::collection::vec(net(), 0..80),
    ) {
        let mut t = ConnectionTable::<&'static str, &'static str>::with_statement_base(5);
        let kind = if once { Kind::Once } else { Kind::Whenever };
        let until = Until { source: "U", started: "R.started", exited: "R.exited", dropped: "R.dropped", interrupt: "R.interrupt", causes: true };
        let id = t.arm("E", "R.start", kind, Some(until), 0);
        let k = t.statement(id);
        let mut r = ResponseMachine::<u8, ()>::new(policy);
        let mut chan: Vec<std::collections::VecDeque<Msg>> = vec![Default::default(); CHANNELS];
        let mut slot = Slot::None;
        let mut us: Vec<i64> = Vec::new();
        // the oracle's own record, from what the harness sent and what R said on the wire (never R's state):
        // when E emitted the signal behind each start delivery of the statement, and when R announced the
        // statement's run that is going now
        let mut e_at: std::collections::HashMap<u64, i64> = Default::default();
        let mut announced: Option<(u64, i64)> = None;
        let mut now = 10i64;
        // R's effects: signals go to the manager, the slot bookkeeping of a runtime; returns whether R said
        // `interrupted`, and with which cause
        let run_effects = |fx: Vec<Effect<u8, ()>>, r: &mut ResponseMachine<u8, ()>, now: i64,
                               chan: &mut Vec<std::collections::VecDeque<Msg>>, slot: &mut Slot,
                               announced: &mut Option<(u64, i64)>| {
            let mut interrupted = Vec::new();
            let mut queue = fx;
            while !queue.is_empty() {
                let mut more = Vec::new();
                for e in queue {
                    match e {
                        Effect::EmitStarted(_, c) => {
                            *announced = c.filter(|c| c.statement == k).map(|c| (c.delivery, now));
                            chan[STARTED_M].push_back(Msg::Signal { at: now, from: c })
                        }
                        Effect::EmitExited((), c) => {
                            *announced = None;
                            chan[EXITED_M].push_back(Msg::Signal { at: now, from: c })
                        }
                        Effect::EmitInterrupted(c) => {
                            *announced = None;
                            interrupted.push(c)
                        }
                        Effect::RunStart(_) => {
                            *slot = Slot::Start;
                            // the run reaches its first await: R12
                            more.extend(r.resume());
                        }
                        Effect::CancelStart => *slot = Slot::None,
                        Effect::RunInterrupt => *slot = Slot::Interrupt,
                        Effect::RunExit(_) => *slot = Slot::Exit,
                        _ => {}
                    }
                }
                queue = more;
            }
            interrupted
        };
        let drain: Vec<Net> = (0..400).map(|i| Net::Deliver(i % CHANNELS)).collect();
        for (i, s) in steps.iter().chain(drain.iter()).enumerate() {
            let draining = i >= steps.len();
            now += 10;
            match s {
                Net::EmitE => chan[E_M].push_back(Msg::Signal { at: now, from: None }),
                Net::EmitU => { us.push(now); chan[U_M].push_back(Msg::Signal { at: now, from: None }) }
                Net::EmitP => chan[P_START].push_back(Msg::Slot(Sent::at(now))),
                Net::Finish(how) => {
                    let input = match slot {
                        Slot::None => continue,
                        Slot::Start => Input::StartEnded(StartEnd::Returned(())),
                        Slot::Interrupt => Input::InterruptEnded(None),
                        Slot::Exit => Input::ExitEnded(Ok(if *how == 1 { ExitAction::Restart } else { ExitAction::Done })),
                    };
                    let fx = r.handle_at(input, now);
                    run_effects(fx, &mut r, now, &mut chan, &mut slot, &mut announced);
                }
                Net::Deliver(c) => {
                    let Some(m) = chan[*c].pop_front() else { continue };
                    match (*c, m) {
                        (E_M | U_M | STARTED_M | EXITED_M, Msg::Signal { at, from }) => {
                            let source = ["E", "U", "R.started", "R.exited"][*c];
                            for d in t.on_signal_with(&source, at, from, |_| true) {
                                match d.via {
                                    // the relay keeps the source's time and adds the cause (C6)
                                    Via::Signal { n } => {
                                        let cause = t.cause(id, n);
                                        e_at.insert(cause.delivery, at);
                                        chan[M_START].push_back(Msg::Slot(Sent::by(at, cause)))
                                    }
                                    // the interrupt carries the time of U's signal, and names the statement
                                    Via::Until { at: u } => chan[M_INTERRUPT].push_back(Msg::Slot(Sent::by(
                                        u,
                                        Cause { statement: k, delivery: 0 },
                                    ))),
                                }
                            }
                        }
                        (M_START | P_START, Msg::Slot(sent)) => {
                            let fx = r.handle_at(Input::Start(0, sent), now);
                            run_effects(fx, &mut r, now, &mut chan, &mut slot, &mut announced);
                        }
                        (M_INTERRUPT, Msg::Slot(sent)) => {
                            let fx = r.handle_at(Input::Interrupt(sent), now);
                            for c in run_effects(fx, &mut r, now, &mut chan, &mut slot, &mut announced) {
                                // safety: only a run of this statement, and only by a signal of U sent after the E
                                // whose start began that run (R13, R14)
                                let c = c.filter(|c| c.statement == k);
                                prop_assert!(c.is_some(), "interrupted a run that is not the statement's");
                                let e = e_at[&c.unwrap().delivery];
                                prop_assert!(sent.at >= e, "interrupted by a U sent at {} before its run's E at {}", sent.at, e);
                            }
                        }
                        _ => unreachable!(),
                    }
                }
            }
            let _ = draining;
        }
        prop_assert!(chan.iter().all(|c| c.is_empty()), "everything in flight was read");
        // liveness: a run of the statement whose start behaviour still runs (announced on the wire, neither
        // interrupted nor exited, its start slot not finished), with a U emitted after the E whose start began
        // it (R13, R14: also while that start waited for another run, or was on its way), was not interrupted
        if let (Some((n, _)), Slot::Start) = (announced, slot) {
            let e = e_at[&n];
            prop_assert!(
                !us.iter().any(|&u| u >= e),
                "a run of the statement whose E was emitted at {} runs on, though U was emitted at {:?}", e, us
            );
        }
    }
}
