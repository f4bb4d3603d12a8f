//! Every rule of `radar_spec`, broken on purpose: a trace written by hand from the rule text, one that
//! RADAR allows (the spec must find nothing in it), and for each rule a copy of it doctored the way a faulty
//! machine would (the spec must name that rule). These are the oracle's own planted bugs: a rule that finds
//! nothing in its doctored trace, or something in the clean one, fails here.

use radar_spec::{check, rules::ALL, trace::*, End};

const E: Comp = Comp(0);
const R: Comp = Comp(2);
const U: Comp = Comp(3);

fn sig(c: Comp, kind: SignalKind) -> Signal {
    Signal { comp: c, kind }
}
fn slot(c: Comp, kind: SlotKind) -> Target {
    Target::Slot(Slot { comp: c, kind })
}
fn by(stmt: Stmt, delivery: u64) -> Option<Cause> {
    Some(Cause { stmt, delivery })
}

/// Writes a trace step by step, numbering signals and runs.
struct Tr {
    t: Trace,
    now: Time,
    next_sig: SigId,
    last_response_sig: SigId,
}

impl Tr {
    fn new(policy: Policy) -> Tr {
        Tr {
            t: Trace::new(vec![
                Component {
                    name: "/e".into(),
                    role: Role::Event,
                },
                Component {
                    name: "/prog".into(),
                    role: Role::Program,
                },
                Component {
                    name: "/r".into(),
                    role: Role::Response {
                        policy,
                        causes: true,
                    },
                },
                Component {
                    name: "/u".into(),
                    role: Role::Event,
                },
            ]),
            now: 0,
            next_sig: 1,
            last_response_sig: 0,
        }
    }
    /// A new step at the next time, with these records.
    fn step(&mut self, obs: &[Obs]) -> &mut Tr {
        self.now += 10;
        for (i, o) in obs.iter().enumerate() {
            if i == 0 {
                self.t.push(self.now, *o);
            } else {
                self.t.push_to_step(self.now, *o);
            }
        }
        self
    }
    fn sig(&mut self) -> SigId {
        self.next_sig += 1;
        self.next_sig - 1
    }
    fn emit(&mut self, signal: Signal, cause: Option<Cause>) -> (SigId, Obs) {
        let sig = self.sig();
        let stamp = self.now + 10;
        (
            sig,
            Obs::Emitted {
                inst: 0,
                sig,
                signal,
                stamp,
                cause,
                payload: Payload::default(),
            },
        )
    }
    fn arm(
        &mut self,
        stmt: Stmt,
        kind: Kind,
        source: Signal,
        target: Target,
        until: Option<Signal>,
    ) {
        let since = self.now + 10;
        let mut obs = vec![Obs::Armed {
            stmt,
            kind,
            source,
            target,
            until,
            since,
            accepts: Accepts::All,
        }];
        obs.push(Obs::Reading {
            signal: source,
            on: true,
        });
        if let Some(u) = until {
            obs.push(Obs::Reading {
                signal: u,
                on: true,
            });
        }
        self.step(&obs);
    }
    /// An event learns it is listened to and begins checking.
    fn listened(&mut self, e: Comp) {
        self.step(&[
            Obs::Listeners {
                inst: 0,
                comp: e,
                n: 1,
            },
            Obs::Checking {
                inst: 0,
                comp: e,
                on: true,
            },
        ]);
    }
    fn unlistened(&mut self, e: Comp) {
        self.step(&[
            Obs::Listeners {
                inst: 0,
                comp: e,
                n: 0,
            },
            Obs::Checking {
                inst: 0,
                comp: e,
                on: false,
            },
        ]);
    }
    /// The event fires: returns the emission and its stamp.
    fn fire(&mut self, e: Comp) -> (SigId, Time) {
        let (s, em) = self.emit(sig(e, SignalKind::Triggered), None);
        self.step(&[em]);
        (s, self.now)
    }
    /// The manager reads `s`, and with it does `then`.
    fn manager(&mut self, s: SigId, then: &[Obs]) {
        let mut obs = vec![Obs::ManagerRead {
            sig: s,
            now: self.now + 10,
        }];
        obs.extend_from_slice(then);
        self.step(&obs);
    }
    /// R reads a slot signal (`cause`, `stamp`), and with it does `then` (the run's records).
    fn read(&mut self, kind: SlotKind, stamp: Time, cause: Option<Cause>, then: &[Obs]) {
        let now = self.now + 10;
        let mut obs = vec![Obs::Read {
            inst: 0,
            comp: R,
            slot: kind,
            stamp,
            by: cause,
            payload: Payload::default(),
            now,
        }];
        obs.extend_from_slice(then);
        self.step(&obs);
    }
    /// What a run's beginning records: the run and its `started` (the manager reads it when `until` is on).
    fn begins(&mut self, run: Run, cause: Option<Cause>) -> Vec<Obs> {
        let (s, started) = self.emit(sig(R, SignalKind::Started), cause);
        self.last_response_sig = s;
        vec![
            Obs::RunBegan {
                inst: 0,
                comp: R,
                run,
                payload: 0,
                cause,
                now: self.now + 10,
            },
            started,
        ]
    }
    /// What an exit slot for `reason` records, and `exited`.
    fn exits(&mut self, run: Run, reason: ExitReason, cause: Option<Cause>) -> Vec<Obs> {
        let (s, exited) = self.emit(sig(R, SignalKind::Exited), cause);
        self.last_response_sig = s;
        vec![
            Obs::ExitBegan {
                inst: 0,
                comp: R,
                run,
                reason,
            },
            Obs::ExitEnded {
                inst: 0,
                comp: R,
                run,
                action: ExitAction::Done,
                now: self.now + 10,
            },
            exited,
        ]
    }
    /// The start behaviour returns and the run exits.
    fn completes(&mut self, run: Run, cause: Option<Cause>) {
        let mut obs = vec![Obs::StartEnded {
            inst: 0,
            comp: R,
            run,
            how: StartEnd::Returned,
        }];
        obs.extend(self.exits(run, ExitReason::Completed, cause));
        self.step(&obs);
    }
    /// What an interrupt that ends a run records.
    fn interrupted(&mut self, run: Run, cause: Option<Cause>) -> Vec<Obs> {
        let (_, int) = self.emit(sig(R, SignalKind::Interrupted), cause);
        let mut obs = vec![
            Obs::Cancelled {
                inst: 0,
                comp: R,
                run,
            },
            int,
            Obs::InterruptBegan {
                inst: 0,
                comp: R,
                run,
            },
            Obs::InterruptEnded {
                inst: 0,
                comp: R,
                run,
            },
        ];
        obs.extend(self.exits(run, ExitReason::Interrupted, cause));
        obs
    }
}

fn reading(s: Signal, on: bool) -> Obs {
    Obs::Reading { signal: s, on }
}
fn trig(c: Comp) -> Signal {
    sig(c, SignalKind::Triggered)
}
fn start() -> Target {
    slot(R, SlotKind::Start)
}

/// `once e start r` up to the run's beginning: e fires once, the manager sends it to r's start and the
/// statement ends; e, heard no more, stops checking; r reads the start (stamped `st`, returned) and runs.
fn once_start_begun() -> (Tr, Time) {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Once, trig(E), start(), None);
    t.listened(E);
    let (s1, st) = t.fire(E);
    t.manager(
        s1,
        &[
            Obs::Sent {
                stmt: 1,
                sig: s1,
                to: start(),
                stamp: st,
                by: by(1, 1),
            },
            Obs::Ended { stmt: 1 },
            reading(trig(E), false),
        ],
    );
    t.unlistened(E);
    let run = t.begins(1, by(1, 1));
    t.read(SlotKind::Start, st, by(1, 1), &run);
    (t, st)
}

/// `once e start r`, and the run's start behaviour returns: the exit slot runs, r says `exited`.
fn once_start() -> Tr {
    let (mut t, _) = once_start_begun();
    t.completes(1, by(1, 1));
    t
}

/// `once e start r until u` up to u's firing while r runs (returns u's signal and stamp).
fn once_until_fired() -> (Tr, SigId, Time) {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Once, trig(E), start(), Some(trig(U)));
    t.step(&[
        reading(sig(R, SignalKind::Started), true),
        reading(sig(R, SignalKind::Exited), true),
        reading(sig(R, SignalKind::Dropped), true),
    ]);
    t.listened(E);
    t.listened(U);
    let (s1, st) = t.fire(E);
    t.manager(
        s1,
        &[
            Obs::Sent {
                stmt: 1,
                sig: s1,
                to: start(),
                stamp: st,
                by: by(1, 1),
            },
            reading(trig(E), false),
        ],
    );
    t.unlistened(E);
    let run = t.begins(1, by(1, 1));
    t.read(SlotKind::Start, st, by(1, 1), &run);
    let started = t.last_response_sig;
    t.manager(started, &[]);
    let (u1, ut) = t.fire(U);
    (t, u1, ut)
}

/// The end of a `once ... until`: the manager reads r's `exited`, ends the statement and lets go of u and r.
fn until_over(t: &mut Tr) {
    let exited = t.last_response_sig;
    t.manager(
        exited,
        &[
            Obs::Ended { stmt: 1 },
            reading(trig(U), false),
            reading(sig(R, SignalKind::Started), false),
            reading(sig(R, SignalKind::Exited), false),
            reading(sig(R, SignalKind::Dropped), false),
        ],
    );
    t.unlistened(U);
}

/// The manager sends u's signal `u1` (stamp `ut`) to r's interrupt for statement 1, and r's run 1 is interrupted.
fn u_interrupts_run_1(t: &mut Tr, u1: SigId, ut: Time) {
    t.manager(
        u1,
        &[Obs::Sent {
            stmt: 1,
            sig: u1,
            to: slot(R, SlotKind::Interrupt),
            stamp: ut,
            by: by(1, 0),
        }],
    );
    let int = t.interrupted(1, by(1, 1));
    t.read(SlotKind::Interrupt, ut, by(1, 0), &int);
}

/// `once e start r until u`: u fires while r runs and interrupts it; when r has exited the statement ends.
fn once_until() -> Tr {
    let (mut t, u1, ut) = once_until_fired();
    u_interrupts_run_1(&mut t, u1, ut);
    until_over(&mut t);
    t
}

/// `whenever e start r` on a response of `policy`: e fires three times, the last two while r's first run goes
/// on; the scope ends after the runs.
fn whenever_busy(policy: Policy) -> Tr {
    let mut t = Tr::new(policy);
    t.arm(1, Kind::Whenever, trig(E), start(), None);
    t.listened(E);
    let mut sent = Vec::new();
    for n in 1..=3 {
        let (s, st) = t.fire(E);
        t.manager(
            s,
            &[Obs::Sent {
                stmt: 1,
                sig: s,
                to: start(),
                stamp: st,
                by: by(1, n),
            }],
        );
        sent.push(st);
        match (n, policy) {
            (1, _) => {
                let run = t.begins(1, by(1, 1));
                t.read(SlotKind::Start, st, by(1, 1), &run);
            }
            // ignored while busy: told at once
            (_, Policy::Ignore) => {
                let (_, d) = t.emit(sig(R, SignalKind::Dropped), by(1, n));
                t.read(SlotKind::Start, st, by(1, n), &[d]);
            }
            // queued; the third replaces the second, which is told
            (2, _) => t.read(SlotKind::Start, st, by(1, 2), &[]),
            (_, _) => {
                let (_, d) = t.emit(sig(R, SignalKind::Dropped), by(1, 2));
                t.read(SlotKind::Start, st, by(1, 3), &[d]);
            }
        }
    }
    let mut obs = vec![Obs::StartEnded {
        inst: 0,
        comp: R,
        run: 1,
        how: StartEnd::Returned,
    }];
    obs.extend(t.exits(1, ExitReason::Completed, by(1, 1)));
    if policy == Policy::QueueOne {
        obs.extend(t.begins(2, by(1, 3)));
    }
    t.step(&obs);
    if policy == Policy::QueueOne {
        t.completes(2, by(1, 3));
    }
    t.step(&[Obs::ScopeEnded { stmt: 1 }, reading(trig(E), false)]);
    t.unlistened(E);
    t
}

/// `whenever e start r until u` on a response that ignores starts while busy: e fires, r runs that start; e
/// fires again, r drops the second start and says so; u fires while the first run goes on: the statement began
/// that run, so u interrupts it (C6: a later start dropped does not end an earlier one's run); the scope ends.
fn whenever_until_busy() -> Tr {
    whenever_until_busy_where(true)
}

/// [`whenever_until_busy`], where the manager sends u's signal to r's interrupt if `sent`, or (doctored as the
/// machine was after issue 69's first fix) takes the dropped second start for the end of the run going, and
/// sends nothing: the first run then completes.
fn whenever_until_busy_where(sent: bool) -> Tr {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Whenever, trig(E), start(), Some(trig(U)));
    t.step(&[
        reading(sig(R, SignalKind::Started), true),
        reading(sig(R, SignalKind::Exited), true),
        reading(sig(R, SignalKind::Dropped), true),
    ]);
    t.listened(E);
    t.listened(U);
    for n in 1..=2 {
        let (s, st) = t.fire(E);
        t.manager(
            s,
            &[Obs::Sent {
                stmt: 1,
                sig: s,
                to: start(),
                stamp: st,
                by: by(1, n),
            }],
        );
        if n == 1 {
            let run = t.begins(1, by(1, 1));
            t.read(SlotKind::Start, st, by(1, 1), &run);
        } else {
            let (d, dropped) = t.emit(sig(R, SignalKind::Dropped), by(1, 2));
            t.read(SlotKind::Start, st, by(1, 2), &[dropped]);
            t.last_response_sig = d;
        }
        let said = t.last_response_sig;
        t.manager(said, &[]);
    }
    let (u1, ut) = t.fire(U);
    if sent {
        u_interrupts_run_1(&mut t, u1, ut);
    } else {
        t.manager(u1, &[]);
        t.completes(1, by(1, 1));
    }
    let exited = t.last_response_sig;
    t.manager(exited, &[]);
    t.step(&[
        Obs::ScopeEnded { stmt: 1 },
        reading(trig(E), false),
        reading(trig(U), false),
        reading(sig(R, SignalKind::Started), false),
        reading(sig(R, SignalKind::Exited), false),
        reading(sig(R, SignalKind::Dropped), false),
    ]);
    t.unlistened(E);
    t.unlistened(U);
    t
}

/// `whenever e call`: e fires, the anonymous slot is called; the scope ends.
fn whenever_call() -> Tr {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Whenever, trig(E), Target::Call, None);
    t.listened(E);
    let (s, st) = t.fire(E);
    t.manager(
        s,
        &[
            Obs::Sent {
                stmt: 1,
                sig: s,
                to: Target::Call,
                stamp: st,
                by: by(1, 1),
            },
            Obs::Called { stmt: 1, sig: s },
        ],
    );
    t.step(&[Obs::ScopeEnded { stmt: 1 }, reading(trig(E), false)]);
    t.unlistened(E);
    t
}

/// `once e start r`, and r is told to stop while it runs: its run ends through the exit slot; it leaves.
fn stopped() -> Tr {
    let (mut t, _) = once_start_begun();
    let mut obs = vec![
        Obs::Stopping { inst: 0, comp: R },
        Obs::Cancelled {
            inst: 0,
            comp: R,
            run: 1,
        },
    ];
    obs.extend(t.exits(1, ExitReason::ExitSignal, by(1, 1)));
    t.step(&obs);
    t.step(&[Obs::Left {
        comp: R,
        instance: 0,
        crashed: false,
    }]);
    t
}

/// `once e start r`, and r leaves before e fires: the statement sees it lost and lets go of e.
fn target_left() -> Tr {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Once, trig(E), start(), None);
    t.listened(E);
    t.step(&[Obs::Left {
        comp: R,
        instance: 0,
        crashed: false,
    }]);
    t.step(&[Obs::LossSeen { stmt: 1, comp: R }, reading(trig(E), false)]);
    t.unlistened(E);
    t
}

/// `once e start r`, while a second process named r comes up beside the first and goes again.
fn twin_came_and_went() -> Tr {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Once, trig(E), start(), None);
    t.listened(E);
    t.step(&[Obs::Spawned {
        comp: R,
        instance: 1,
        beside: true,
    }]);
    t.step(&[Obs::Left {
        comp: R,
        instance: 1,
        crashed: false,
    }]);
    let (s1, st) = t.fire(E);
    t.manager(
        s1,
        &[
            Obs::Sent {
                stmt: 1,
                sig: s1,
                to: start(),
                stamp: st,
                by: by(1, 1),
            },
            Obs::Ended { stmt: 1 },
            reading(trig(E), false),
        ],
    );
    t.unlistened(E);
    let run = t.begins(1, by(1, 1));
    t.read(SlotKind::Start, st, by(1, 1), &run);
    t.completes(1, by(1, 1));
    t
}

/// `once e start r`, and an `exit` published by hand after the start was sent reaches r first (R12): the run
/// takes it at its first await and ends through its exit slot.
fn exit_overtakes_start() -> (Tr, Time) {
    let mut t = Tr::new(Policy::Ignore);
    t.arm(1, Kind::Once, trig(E), start(), None);
    t.listened(E);
    let (s1, st) = t.fire(E);
    t.manager(
        s1,
        &[
            Obs::Sent {
                stmt: 1,
                sig: s1,
                to: start(),
                stamp: st,
                by: by(1, 1),
            },
            Obs::Ended { stmt: 1 },
            reading(trig(E), false),
        ],
    );
    t.unlistened(E);
    t.read(SlotKind::Exit, st + 5, None, &[]);
    (t, st)
}

fn exit_taken_at_first_await() -> Tr {
    let (mut t, st) = exit_overtakes_start();
    let mut obs = t.begins(1, by(1, 1));
    obs.push(Obs::Cancelled {
        inst: 0,
        comp: R,
        run: 1,
    });
    obs.extend(t.exits(1, ExitReason::ExitSignal, by(1, 1)));
    t.read(SlotKind::Start, st, by(1, 1), &obs);
    t
}

fn clean() -> Vec<(&'static str, Trace)> {
    vec![
        ("once_start", once_start().t),
        ("once_until", once_until().t),
        ("whenever_busy ignore", whenever_busy(Policy::Ignore).t),
        ("whenever_busy queue_one", whenever_busy(Policy::QueueOne).t),
        ("whenever_until_busy", whenever_until_busy().t),
        ("whenever_call", whenever_call().t),
        ("stopped", stopped().t),
        ("target_left", target_left().t),
        ("twin_came_and_went", twin_came_and_went().t),
        ("exit_taken_at_first_await", exit_taken_at_first_await().t),
    ]
}

fn judged(t: &Trace) -> Vec<&'static str> {
    check(t, End::Quiescent)
        .violations
        .iter()
        .map(|v| v.rule.name)
        .collect()
}

#[test]
fn the_clean_traces_break_nothing() {
    for (name, t) in clean() {
        let r = check(&t, End::Quiescent);
        assert!(
            r.ok(),
            "{name}: {r}\n{:#?}",
            t.records.iter().map(|r| r.obs).collect::<Vec<_>>()
        );
    }
}

/// The index of the `n`th record (from 0) matching `pred`.
fn find(t: &Trace, n: usize, pred: impl Fn(&Obs) -> bool) -> usize {
    t.records
        .iter()
        .enumerate()
        .filter(|(_, r)| pred(&r.obs))
        .nth(n)
        .map(|(i, _)| i)
        .expect("the clean trace has the record the doctoring changes")
}

/// The trace without the first record matching `pred`.
fn without(mut t: Trace, pred: impl Fn(&Obs) -> bool) -> Trace {
    let i = find(&t, 0, pred);
    t.records.remove(i);
    t
}

/// The trace up to and with the first record matching `pred`.
fn cut_after(mut t: Trace, pred: impl Fn(&Obs) -> bool) -> Trace {
    let i = find(&t, 0, pred);
    t.records.truncate(i + 1);
    t
}

/// The trace with `obs` put after the first record matching `pred`, in its step.
fn with_after(mut t: Trace, pred: impl Fn(&Obs) -> bool, obs: &[Obs]) -> Trace {
    let i = find(&t, 0, pred);
    let (at, step) = (t.records[i].at, t.records[i].step);
    for (k, o) in obs.iter().enumerate() {
        t.records.insert(i + 1 + k, Record { at, step, obs: *o });
    }
    t
}

/// The trace with these steps after its end, 10 ns apart.
fn then(mut t: Trace, steps: &[&[Obs]]) -> Trace {
    for obs in steps {
        let (at, step) = t.records.last().map_or((0, 0), |r| (r.at + 10, r.step + 1));
        t.records
            .extend(obs.iter().map(|o| Record { at, step, obs: *o }));
    }
    t
}

/// The trace with the first record matching `pred` changed by `f`.
fn changed(mut t: Trace, pred: impl Fn(&Obs) -> bool, f: impl Fn(&mut Obs)) -> Trace {
    let i = find(&t, 0, pred);
    f(&mut t.records[i].obs);
    t
}

fn is_sent(o: &Obs) -> bool {
    matches!(o, Obs::Sent { .. })
}
fn is_emitted(kind: SignalKind) -> impl Fn(&Obs) -> bool {
    move |o| matches!(o, Obs::Emitted { signal, .. } if signal.kind == kind)
}
fn is_read(kind: SlotKind) -> impl Fn(&Obs) -> bool {
    move |o| matches!(o, Obs::Read { slot, .. } if *slot == kind)
}

/// A signal emitted by hand (`ros2 topic pub`) into the trace: its emission, as a record of the step.
fn emitted(sig: SigId, signal: Signal, stamp: Time) -> Obs {
    Obs::Emitted {
        inst: 0,
        sig,
        signal,
        stamp,
        cause: None,
        payload: Payload::default(),
    }
}

/// Each rule and the traces doctored to break it, as a faulty machine would.
fn doctored() -> Vec<(&'static str, &'static str, Trace)> {
    let mut out: Vec<(&'static str, &'static str, Trace)> = Vec::new();
    let mut add = |rule, what, t| out.push((rule, what, t));
    // ---------------------------------------------------------------- responses
    add(
        "runs-begin-on-a-start",
        "a run begins with no start read",
        without(once_start().t, is_read(SlotKind::Start)),
    );
    add(
        "started-announces-its-run",
        "a run begins and `started` is not emitted",
        without(once_start().t, is_emitted(SignalKind::Started)),
    );
    add(
        "an-idle-start-begins-a-run",
        "a start read while idle begins nothing",
        cut_after(once_start().t, is_read(SlotKind::Start)),
    );
    add(
        "slots-in-order",
        "`exited` without the exit slot",
        without(once_start().t, |o| matches!(o, Obs::ExitBegan { .. })),
    );
    add("slots-in-order", "the exit slot runs twice", {
        let t = once_start().t;
        let ended = t.records[find(&t, 0, |o| matches!(o, Obs::ExitEnded { .. }))].obs;
        let began = t.records[find(&t, 0, |o| matches!(o, Obs::ExitBegan { .. }))].obs;
        with_after(t, |o| matches!(o, Obs::ExitEnded { .. }), &[began, ended])
    });
    add(
        "an-interrupt-for-the-run-ends-it",
        "an until's interrupt for the run is read and the run goes on",
        {
            let (mut t, u1, ut) = once_until_fired();
            t.manager(
                u1,
                &[Obs::Sent {
                    stmt: 1,
                    sig: u1,
                    to: slot(R, SlotKind::Interrupt),
                    stamp: ut,
                    by: by(1, 0),
                }],
            );
            t.read(SlotKind::Interrupt, ut, by(1, 0), &[]);
            t.completes(1, by(1, 1));
            until_over(&mut t);
            t.t
        },
    );
    add(
        "start-policy",
        "an `ignore` response interrupts its run for a start read while busy",
        changed(
            whenever_busy(Policy::Ignore).t,
            is_emitted(SignalKind::Dropped),
            |o| {
                *o = Obs::Cancelled {
                    inst: 0,
                    comp: R,
                    run: 1,
                }
            },
        ),
    );
    add(
        "a-start-not-taken-is-told",
        "a start ignored while busy is not announced on `dropped`",
        without(
            whenever_busy(Policy::Ignore).t,
            is_emitted(SignalKind::Dropped),
        ),
    );
    add(
        "every-start-taken-or-told",
        "a queued start replaced by a newer one is not announced",
        without(
            whenever_busy(Policy::QueueOne).t,
            is_emitted(SignalKind::Dropped),
        ),
    );
    add(
        "every-run-exits",
        "a run that never exits",
        cut_after(once_start().t, is_emitted(SignalKind::Started)),
    );
    add(
        "a-stop-ends-the-run",
        "a response told to stop lets its run go on",
        {
            let (mut t, _) = once_start_begun();
            t.step(&[Obs::Stopping { inst: 0, comp: R }]);
            t.completes(1, by(1, 1));
            t.step(&[Obs::Left {
                comp: R,
                instance: 0,
                crashed: false,
            }]);
            t.t
        },
    );
    add(
        "only-signals-for-the-run",
        "an interrupt emitted before the run began ends it",
        {
            let (mut t, _) = once_start_begun();
            let int = t.interrupted(1, by(1, 1));
            t.read(SlotKind::Interrupt, 1, None, &int);
            t.t
        },
    );
    add(
        "order-by-cause",
        "an exit sent after the start, read before it, does not end its run",
        {
            let (mut t, st) = exit_overtakes_start();
            let run = t.begins(1, by(1, 1));
            t.read(SlotKind::Start, st, by(1, 1), &run);
            t.completes(1, by(1, 1));
            t.t
        },
    );
    // ---------------------------------------------------------------- connections
    add(
        "not-before-armed",
        "a signal emitted before the statement began is delivered",
        changed(
            once_start().t,
            |o| matches!(o, Obs::Armed { .. }),
            |o| {
                if let Obs::Armed { since, .. } = o {
                    *since = 1_000;
                }
            },
        ),
    );
    add("once-at-most-one", "a `once` delivers a second signal", {
        let t = once_start().t;
        let st = t.records[find(&t, 0, is_emitted(SignalKind::Triggered))].at;
        with_after(
            t,
            is_sent,
            &[
                emitted(90, trig(E), st),
                Obs::ManagerRead { sig: 90, now: st },
                Obs::Sent {
                    stmt: 1,
                    sig: 90,
                    to: start(),
                    stamp: st,
                    by: by(1, 2),
                },
            ],
        )
    });
    add(
        "only-what-passes",
        "a payload the filter refuses is delivered",
        changed(
            once_start().t,
            |o| matches!(o, Obs::Armed { .. }),
            |o| {
                if let Obs::Armed { accepts, .. } = o {
                    *accepts = Accepts::Values(1 << 5);
                }
            },
        ),
    );
    add(
        "delivers-what-it-reads",
        "a live `once` reads its source and delivers nothing",
        cut_after(once_start().t, |o| matches!(o, Obs::ManagerRead { .. })),
    );
    add(
        "spent-once-ends",
        "a spent `once` never ends",
        without(once_start().t, |o| matches!(o, Obs::Ended { .. })),
    );
    add(
        "until-lasts-its-run",
        "a `once ... until` ends while the run its start began goes on",
        {
            let t = without(once_until().t, |o| matches!(o, Obs::Ended { .. }));
            with_after(t, is_sent, &[Obs::Ended { stmt: 1 }])
        },
    );
    add(
        "spent-lets-go",
        "a spent `once` goes on reading its source",
        without(once_start().t, |o| {
            matches!(o, Obs::Reading { on: false, .. })
        }),
    );
    add("scope", "a statement delivers after its scope ended", {
        let t = whenever_call().t;
        let at = t.records.last().unwrap().at;
        then(
            t,
            &[
                &[emitted(90, trig(E), at + 10)],
                &[
                    Obs::ManagerRead {
                        sig: 90,
                        now: at + 20,
                    },
                    Obs::Sent {
                        stmt: 1,
                        sig: 90,
                        to: Target::Call,
                        stamp: at + 10,
                        by: by(1, 2),
                    },
                    Obs::Called { stmt: 1, sig: 90 },
                ],
            ],
        )
    });
    add(
        "loss-seen",
        "a target that left is never seen lost",
        without(target_left().t, |o| matches!(o, Obs::LossSeen { .. })),
    );
    add(
        "no-loss-of-the-living",
        "the statement takes its target as lost when a second process of its name leaves",
        with_after(
            twin_came_and_went().t,
            |o| matches!(o, Obs::Left { .. }),
            &[Obs::LossSeen { stmt: 1, comp: R }],
        ),
    );
    add(
        "nothing-to-the-lost",
        "a statement sends to a target it has seen lost",
        {
            let t = target_left().t;
            let at = t.records.last().unwrap().at;
            then(
                t,
                &[
                    &[emitted(90, trig(E), at + 10)],
                    &[
                        Obs::ManagerRead {
                            sig: 90,
                            now: at + 20,
                        },
                        Obs::Sent {
                            stmt: 1,
                            sig: 90,
                            to: start(),
                            stamp: at + 10,
                            by: by(1, 1),
                        },
                    ],
                ],
            )
        },
    );
    add(
        "causes",
        "a start carries the wrong delivery number",
        changed(once_start().t, is_sent, |o| {
            if let Obs::Sent { by: b, .. } = o {
                *b = by(1, 2);
            }
        }),
    );
    add(
        "until-reaches-its-run",
        "U fires while the run goes on and nothing is sent to its interrupt",
        {
            let (mut t, u1, _) = once_until_fired();
            t.manager(u1, &[]);
            t.completes(1, by(1, 1));
            until_over(&mut t);
            t.t
        },
    );
    add(
        "until-reaches-its-run",
        "a whenever ... until: U fires while the statement's first run goes on, after its second start was \
         dropped, and nothing is sent to the interrupt",
        whenever_until_busy_where(false).t,
    );
    // ---------------------------------------------------------------- events
    add(
        "checks-only-while-listened",
        "an event goes on checking when it learns nobody listens",
        without(once_start().t, |o| {
            matches!(o, Obs::Checking { on: false, .. })
        }),
    );
    add(
        "checks-only-while-listened",
        "an event emits `triggered` before it checks",
        with_after(
            once_start().t,
            |o| matches!(o, Obs::Armed { .. }),
            &[emitted(90, trig(E), 10)],
        ),
    );
    add(
        "unheard-events-stop",
        "an event never learns its listener went",
        {
            let t = without(once_start().t, |o| {
                matches!(o, Obs::Checking { on: false, .. })
            });
            without(t, |o| matches!(o, Obs::Listeners { n: 0, .. }))
        },
    );
    out
}

#[test]
fn each_doctored_trace_breaks_the_rule_it_was_doctored_for() {
    let mut missed = Vec::new();
    for (rule, what, t) in doctored() {
        let found = judged(&t);
        if !found.contains(&rule) {
            missed.push(format!("{rule} ({what}): found {found:?}"));
        }
    }
    assert!(
        missed.is_empty(),
        "rules that missed their doctored trace:\n{}",
        missed.join("\n")
    );
}

#[test]
fn every_rule_has_a_doctored_trace() {
    let doctored: Vec<&str> = doctored().iter().map(|(r, ..)| *r).collect();
    let bare: Vec<&str> = ALL
        .iter()
        .map(|r| r.name)
        .filter(|n| !doctored.contains(n))
        .collect();
    assert!(bare.is_empty(), "rules no doctored trace breaks: {bare:?}");
    for name in doctored {
        assert!(ALL.iter().any(|r| r.name == name), "no rule named {name}");
    }
}
