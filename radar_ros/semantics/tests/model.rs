//! Model-based tests: random sequences of inputs, thousands per run, checked against small reference models
//! written from the rules in the crate documentation (not from the code), the way a reader of those rules
//! would predict what a response emits and what a connection delivers.

use proptest::prelude::*;
use radar_semantics::{
    connection::{ConnectionTable, Kind, Link, ResponseView, Until},
    response::{
        Announce, Effect, ExitAction, Input, Phase, ResponseMachine, StartEnd, StartPolicy,
    },
};

// ------------------------------------------------------------------------------------------- responses

/// What the wire shows of a response: its three signals.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Wire {
    Started(u8),
    Interrupted,
    Exited,
}

/// The response rules 1-10, as the crate documentation states them.
#[derive(Debug)]
struct ResponseModel {
    policy: StartPolicy,
    /// Rule 9: `started` on acceptance instead of at once.
    on_accept: bool,
    /// Whether this run has said `started`.
    announced: bool,
    phase: Phase,
    payload: Option<u8>,
    queued: Option<u8>,
    stopping: bool,
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

    /// Rule 1: started, then the run (rule 9: started waits for acceptance).
    fn begin(&mut self, p: u8, wire: &mut Vec<Wire>) {
        self.starts += 1;
        self.phase = Phase::Running;
        self.payload = Some(p);
        self.announced = !self.on_accept;
        if self.announced {
            wire.push(Wire::Started(p));
        }
    }

    /// Rule 3: interrupted as the interrupt slot begins.
    fn interrupt(&mut self, wire: &mut Vec<Wire>) {
        self.interrupts += 1;
        self.phase = Phase::Interrupting;
        wire.push(Wire::Interrupted);
    }

    fn input(&mut self, i: &Input<u8, ()>) -> Vec<Wire> {
        let mut wire = Vec::new();
        match i {
            // rule 9: once per run, while running
            Input::Accepted => {
                if self.phase == Phase::Running && !self.announced {
                    self.announced = true;
                    wire.push(Wire::Started(self.payload.expect("a run has a payload")));
                }
            }
            // rule 10: only what exited carries changes (not seen on this wire)
            Input::Output(()) => {}
            Input::Start(p) => {
                if self.stopping {
                    self.ignored_starts += 1;
                } else if self.phase == Phase::Idle {
                    self.begin(*p, &mut wire);
                } else {
                    // rule 6
                    match self.policy {
                        StartPolicy::Ignore => self.ignored_starts += 1,
                        StartPolicy::QueueOne | StartPolicy::Restart => {
                            if self.queued.replace(*p).is_some() {
                                self.ignored_starts += 1;
                            }
                            if self.policy == StartPolicy::Restart && self.phase == Phase::Running {
                                self.interrupt(&mut wire);
                            }
                        }
                    }
                }
            }
            Input::Interrupt if self.phase == Phase::Running => self.interrupt(&mut wire),
            Input::Interrupt => self.ignored_interrupts += 1, // rule 5
            Input::Exit if self.phase == Phase::Running => {
                // rule 4
                self.exit_signals += 1;
                self.phase = Phase::Exiting;
            }
            Input::Exit => self.ignored_exits += 1, // rule 5
            Input::StartEnded(end) => {
                // rule 2 (and 7: the exit slot runs after an error or a panic too)
                if let StartEnd::Panicked(_) = end {
                    self.panics += 1;
                }
                self.phase = Phase::Exiting;
            }
            Input::InterruptEnded(panic) => {
                if panic.is_some() {
                    self.panics += 1;
                }
                self.phase = Phase::Exiting;
            }
            Input::ExitEnded(r) => {
                // rules 2, 7, 8
                if r.is_err() {
                    self.panics += 1;
                }
                self.exits += 1;
                wire.push(Wire::Exited);
                self.phase = Phase::Idle;
                let finished = self.payload.take();
                if self.stopping {
                } else if let Some(p) = self.queued.take() {
                    self.begin(p, &mut wire);
                } else if let (Ok(ExitAction::Restart), Some(p)) = (r, finished) {
                    self.restarts += 1;
                    self.begin(p, &mut wire);
                }
            }
        }
        wire
    }

    /// Stopping the response ends a run as an `exit` signal would.
    fn stop(&mut self) -> Vec<Wire> {
        self.stopping = true;
        self.queued = None;
        if self.phase == Phase::Running {
            self.exit_signals += 1;
            self.phase = Phase::Exiting;
        }
        Vec::new()
    }
}

/// What the test harness asks for at each step; completions apply to whichever slot runs.
#[derive(Clone, Debug)]
enum Step {
    Start(u8),
    Interrupt,
    Exit,
    /// The running slot finishes: 0 normally, 1 with an error (start) or a restart (exit), 2 by panicking.
    Finish(u8),
    /// The start behaviour reports acceptance (rule 9).
    Accept,
    /// A slot hands over the output (rule 10).
    Output,
}

fn step() -> impl Strategy<Value = Step> {
    prop_oneof![
        3 => (0u8..4).prop_map(Step::Start),
        2 => Just(Step::Interrupt),
        1 => Just(Step::Exit),
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
    fx.iter()
        .filter_map(|e| match e {
            Effect::EmitStarted(p) => Some(Wire::Started(*p)),
            Effect::EmitInterrupted => Some(Wire::Interrupted),
            Effect::EmitExited(()) => Some(Wire::Exited),
            _ => None,
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// The machine emits exactly what the rules say, in order, and counts what they say, for any sequence of
    /// signals and slot completions a runtime can feed it; and the runtime's slot bookkeeping (which slot runs,
    /// from the effects) never sees two slots at once or a completion out of place.
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
            let (fx, expected) = if stop_at == Some(k) {
                (m.stop(), model.stop())
            } else {
                let input = match s {
                    Step::Start(p) => Input::Start(*p),
                    Step::Interrupt => Input::Interrupt,
                    Step::Exit => Input::Exit,
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
                let expected = model.input(&input);
                (m.handle(input), expected)
            };
            prop_assert_eq!(wire_of(&fx), expected, "step {} {:?}", k, s);
            // the runtime's view: which slot runs after these effects
            for e in &fx {
                match e {
                    Effect::RunStart(_) => {
                        prop_assert_eq!(slot, Slot::None, "a start while a slot runs");
                        slot = Slot::Start;
                        runs += 1;
                        // under rule 1 `started` came just before the run it announces
                        started_this_run = if on_accept { 0 } else { 1 };
                    }
                    Effect::CancelStart => { prop_assert_eq!(slot, Slot::Start); slot = Slot::None }
                    Effect::RunInterrupt => { prop_assert_eq!(slot, Slot::None); slot = Slot::Interrupt }
                    Effect::RunExit(_) => {
                        prop_assert!(slot == Slot::None || slot == Slot::Start || slot == Slot::Interrupt);
                        slot = Slot::Exit
                    }
                    Effect::EmitStarted(_) => {
                        started += 1;
                        if on_accept {
                            prop_assert_eq!(slot, Slot::Start, "started on acceptance only while the run runs");
                            started_this_run += 1;
                        }
                        prop_assert!(started_this_run <= 1, "one started per run (rule 9)");
                    }
                    Effect::EmitExited(_) => {
                        prop_assert_eq!(slot, Slot::Exit, "exited only after the exit slot (rule 7)");
                        slot = Slot::None;
                        exited += 1;
                    }
                    _ => {}
                }
            }
            prop_assert!(runs - exited <= 1, "one run at a time");
            prop_assert!(started <= runs);
            if !on_accept {
                prop_assert_eq!(started, runs, "rule 1: every run says started");
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

/// Connection rules 1-5, as the crate documentation states them, for signals read in the order emitted.
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
    until: Option<ModelWindow>,
}

impl ModelConn {
    /// Whether the table must read its source for it.
    fn reads(&self, s: &str) -> bool {
        (self.source == s && !self.spent && self.link != Link::TargetLost)
            || (self.until.is_some() && ["U", "R.started", "R.exited"].contains(&s))
    }
}

#[derive(Clone, Debug)]
struct ModelWindow {
    running: bool,
    runs_later: bool,
    awaiting: bool,
    open: bool,
}

#[derive(Clone, Debug)]
enum Op {
    Arm {
        source: usize,
        target: usize,
        once: bool,
        until: bool,
        runs_later: bool,
        rearm: bool,
    },
    Remove(usize),
    Signal(usize),
    /// A signal of E1, E2 or U read now but emitted that many steps ago (it was in flight).
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
            .prop_map(|(source, target, once, until, runs_later, rearm)|
                Op::Arm { source, target, once, until, runs_later, rearm }),
        1 => prop_oneof![
            (0usize..2).prop_map(Op::SourceLeaves),
            (0usize..2).prop_map(Op::SourceBack),
            Just(Op::QLeaves),
            Just(Op::QBack),
            Just(Op::RLeaves),
            Just(Op::RBack),
        ],
        1 => (0usize..8).prop_map(Op::Remove),
        // E1, E2, U, R.started, R.exited
        6 => (0usize..5).prop_map(Op::Signal),
        1 => (0usize..3, 1i64..4).prop_map(|(k, back)| Op::LateSignal(k, back)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// What a table delivers, and which connections it keeps, is what the rules say: nothing emitted before a
    /// connection was armed, every signal for `whenever`, exactly one for `once`, U to R's `interrupt` only
    /// within a run the connection started, nothing after removal; and when components leave and come back,
    /// what rule 5 says.
    #[test]
    fn the_connection_table_follows_the_documented_rules(ops in prop::collection::vec(op(), 0..80)) {
        let mut t = ConnectionTable::<&'static str, &'static str>::new();
        let mut model: Vec<ModelConn> = Vec::new();
        let mut ids: Vec<u64> = Vec::new();
        let mut r_running = false; // R's signals alternate: started, exited, started, ...
        for (now, o) in ops.iter().enumerate() {
            let now = now as i64 * 10;
            match *o {
                Op::Arm { source, target, once, until, runs_later, rearm } => {
                    let kind = if once { Kind::Once } else { Kind::Whenever };
                    let (source, target) = (SOURCES[source], TARGETS[target]);
                    // an until only on R (its started/exited are the ones generated here), seeing R as it is
                    let until = (until && target == "R.start").then_some(Until {
                        source: "U",
                        started: "R.started",
                        exited: "R.exited",
                        interrupt: "R.interrupt",
                        response: ResponseView { running: r_running, runs_later },
                    });
                    let window = until.as_ref().map(|u| ModelWindow {
                        running: u.response.running,
                        runs_later,
                        awaiting: false,
                        open: false,
                    });
                    let id = t.arm(source, target, kind, until, now);
                    t.set_rearm(id, rearm);
                    ids.push(id);
                    model.push(ModelConn {
                        id, source, target, kind, armed_at: now, spent: false, link: Link::Armed, rearm, until: window,
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
                        r_running = false;
                    }
                    for c in model.iter_mut() {
                        if c.target == target && matches!(c.link, Link::Armed | Link::WaitingForSource) {
                            c.link = if c.rearm { Link::WaitingForTarget } else { Link::TargetLost };
                        }
                        if let (Some(w), "R.start") = (&mut c.until, target) {
                            *w = ModelWindow { running: false, runs_later: w.runs_later, awaiting: false, open: false };
                        }
                    }
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
                Op::Signal(_) | Op::LateSignal(..) => {
                    let (k, emitted) = match *o {
                        Op::LateSignal(k, back) => (k, now - back * 10 + 5),
                        Op::Signal(k) => (k, now),
                        _ => unreachable!(),
                    };
                    let source = match k {
                        0 => "E1",
                        1 => "E2",
                        2 => "U",
                        3 if !r_running => { r_running = true; "R.started" }
                        4 if r_running => { r_running = false; "R.exited" }
                        _ => continue,
                    };
                    let got: Vec<(u64, &str)> =
                        t.on_signal(&source, emitted).into_iter().map(|d| (d.id, d.target)).collect();
                    let mut want = Vec::new();
                    for c in model.iter_mut() {
                        if emitted < c.armed_at {
                            continue;
                        }
                        if let Some(w) = &mut c.until {
                            if source == "R.started" {
                                w.running = true;
                                w.open = w.awaiting;
                                w.awaiting = false;
                            }
                            if source == "R.exited" {
                                w.running = false;
                                w.open = false;
                            }
                            if source == "U" && w.open {
                                want.push((c.id, "R.interrupt"));
                            }
                        }
                        if c.source == source && !c.spent && c.link == Link::Armed {
                            want.push((c.id, c.target));
                            if let Some(w) = &mut c.until {
                                if !w.running || w.runs_later {
                                    w.awaiting = true;
                                }
                            }
                            if c.kind == Kind::Once {
                                c.spent = true;
                            }
                        }
                    }
                    model.retain(|c| !(c.spent && c.until.is_none()));
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
