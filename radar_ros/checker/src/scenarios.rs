//! The bounded systems CI explores: the paper's listings, and each rule's corners (policies, restarts,
//! filters, anonymous calls, scopes that end at any step, processes that crash, respawn, run twice or stop).

use radar_spec::trace::{Accepts, Kind, Payload, Policy, SignalKind, StartEnd};

use crate::scenario::*;

fn resp_with(
    name: &'static str,
    proc: u8,
    policy: Policy,
    ends: Vec<StartEnd>,
    restarts: u8,
    done: bool,
) -> Component {
    Component {
        name,
        part: Part::Response {
            policy,
            ends,
            restarts,
            done,
        },
        proc,
    }
}

/// Listing 1: CountUp (its exit slot restarts it), StartEvent, EndEvent, `once start_event start count_up
/// until end_event`; `procs` gives the processes of the program, the events and the response.
fn listing_1(name: &'static str, procs: [u8; 3], faults: Vec<Fault>) -> Scenario {
    let mut s = Scenario {
        name,
        components: vec![
            program(procs[0]),
            event("/start_event", procs[1], 1),
            event("/end_event", procs[1], 1),
            resp_with(
                "/count_up",
                procs[2],
                Policy::Ignore,
                vec![StartEnd::Returned],
                1,
                false,
            ),
        ],
        statements: vec![],
        faults,
        skew: vec![],
    };
    let (se, ee, cu) = (
        s.comp("/start_event"),
        s.comp("/end_event"),
        s.comp("/count_up"),
    );
    s.statements = vec![stmt(
        Kind::Once,
        triggered(se),
        start(cu),
        Some(triggered(ee)),
    )];
    s
}

/// Listings 2 and 3: `whenever TestEvent start TestResponse`, and in `do_loop` a function-scoped `once
/// TestEvent2 interrupt TestResponse`, made and dropped at any step.
fn listing_2(name: &'static str, procs: [u8; 3], faults: Vec<Fault>) -> Scenario {
    let mut s = Scenario {
        name,
        components: vec![
            program(procs[0]),
            event("/test_event", procs[1], 2),
            event("/test_event2", procs[1], 1),
            response("/test_response", procs[2], Policy::Ignore),
        ],
        statements: vec![],
        faults,
        skew: vec![],
    };
    let (e1, e2, r) = (
        s.comp("/test_event"),
        s.comp("/test_event2"),
        s.comp("/test_response"),
    );
    s.statements = vec![
        stmt(Kind::Whenever, triggered(e1), start(r), None),
        Statement {
            arm: ArmAt::Any,
            scope_ends: true,
            ..stmt(Kind::Once, triggered(e2), interrupt(r), None)
        },
    ];
    s
}

/// A response busy with another statement's run when `once E start R until U` delivers (`policy`), the
/// manager, the response and the events each in a process of their own.
fn busy_until(name: &'static str, policy: Policy) -> Scenario {
    let mut s = Scenario {
        name,
        components: vec![
            program(0),
            event("/a", 2, 1),
            event("/e", 2, 1),
            event("/u", 2, 2),
            resp_with("/r", 1, policy, vec![StartEnd::Returned], 0, true),
        ],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let (a, e, u, r) = (s.comp("/a"), s.comp("/e"), s.comp("/u"), s.comp("/r"));
    s.statements = vec![
        stmt(Kind::Once, triggered(a), start(r), None),
        stmt(Kind::Once, triggered(e), start(r), Some(triggered(u))),
    ];
    s
}

/// `once E start R until U`, R in another process, with a fault on R's process.
fn until_with_fault(name: &'static str, faults: Vec<Fault>) -> Scenario {
    let mut s = Scenario {
        name,
        components: vec![
            program(0),
            event("/e", 0, 1),
            event("/u", 0, 1),
            response("/r", 1, Policy::Ignore),
        ],
        statements: vec![],
        faults,
        skew: vec![],
    };
    let (e, u, r) = (s.comp("/e"), s.comp("/u"), s.comp("/r"));
    s.statements = vec![stmt(Kind::Once, triggered(e), start(r), Some(triggered(u)))];
    s
}

/// Every scenario CI explores.
pub fn all() -> Vec<Scenario> {
    let mut v = vec![
        listing_1("listing-1", [0, 0, 0], vec![]),
        listing_1("listing-1-processes", [0, 1, 2], vec![]),
        listing_1("listing-1-manager-beside-the-response", [0, 1, 0], vec![]),
        listing_2("listing-2", [0, 1, 2], vec![]),
        listing_2("listing-2-manager-beside-the-events", [0, 0, 1], vec![]),
        busy_until("once-until-while-busy-ignore", Policy::Ignore),
        busy_until("once-until-while-busy-queue-one", Policy::QueueOne),
        busy_until("once-until-while-busy-restart", Policy::Restart),
        until_with_fault("once-until-response-killed", vec![Fault::Crash(1)]),
        until_with_fault(
            "once-until-response-respawned",
            vec![Fault::Crash(1), Fault::Respawn(1)],
        ),
        until_with_fault("once-until-response-twice", vec![Fault::Duplicate(1)]),
        until_with_fault("once-until-response-stops", vec![Fault::Stop(1)]),
        until_with_fault("once-until-program-stops", vec![Fault::Stop(0)]),
        until_with_fault("once-until-program-killed", vec![Fault::Crash(0)]),
    ];
    v.push(anon_call());
    v.push(filtered());
    v.push(unreadable());
    v.push(whenever_until_and_exit());
    v.push(whenever_until_while_busy());
    v.push(interrupt_beside_start(vec![]));
    v.push(interrupt_beside_start(vec![Fault::Wait]));
    v.push(clock_ahead());
    v.push(starts_while_busy(Policy::QueueOne, false));
    v.push(starts_while_busy(Policy::Restart, false));
    v.push(starts_while_busy(Policy::QueueOne, true));
    v
}

/// `whenever E start R`, E triggering three times (payloads 0, 1, 2) while R's first run goes on: R queues or
/// restarts with the newest start (R6), and runs it after `exited` (R1). With `stops`, E triggers twice and R's
/// process is told to stop at any step: a start it queued is announced on `dropped`, not lost (R6).
fn starts_while_busy(policy: Policy, stops: bool) -> Scenario {
    let mut s = Scenario {
        name: match (policy, stops) {
            (Policy::Restart, _) => "starts-while-busy-restart",
            (_, false) => "starts-while-busy-queue-one",
            (_, true) => "starts-while-busy-queue-one-stops",
        },
        components: vec![
            program(0),
            event("/e", 1, if stops { 2 } else { 3 }),
            response("/r", 2, policy),
        ],
        statements: vec![],
        faults: if stops { vec![Fault::Stop(2)] } else { vec![] },
        skew: vec![],
    };
    let (e, r) = (s.comp("/e"), s.comp("/r"));
    s.statements = vec![stmt(Kind::Whenever, triggered(e), start(r), None)];
    s
}

/// `whenever E start R until U` and `whenever X exit R`, R's start behaviour returning, failing or panicking,
/// R queueing one start; the manager beside R.
fn whenever_until_and_exit() -> Scenario {
    let mut s = Scenario {
        name: "whenever-until-and-exit",
        components: vec![
            program(0),
            event("/e", 1, 2),
            event("/u", 1, 1),
            event("/x", 2, 1),
            resp_with(
                "/r",
                0,
                Policy::QueueOne,
                vec![StartEnd::Returned, StartEnd::Failed, StartEnd::Panicked],
                0,
                true,
            ),
        ],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let (e, u, x, r) = (s.comp("/e"), s.comp("/u"), s.comp("/x"), s.comp("/r"));
    s.statements = vec![
        stmt(Kind::Whenever, triggered(e), start(r), Some(triggered(u))),
        stmt(Kind::Whenever, triggered(x), exit(r), None),
    ];
    s
}

/// `whenever E start R until U`, R ignoring starts while busy: E fires twice (R runs the first start and drops
/// the second, saying so on `dropped`) and U once, at any step; R and the events each in a process of their own.
/// U must still reach the first run, which the statement began (C6; the soak found it shut out).
fn whenever_until_while_busy() -> Scenario {
    let mut s = Scenario {
        name: "whenever-until-while-busy-ignore",
        components: vec![
            program(0),
            event("/e", 2, 2),
            event("/u", 2, 1),
            resp_with("/r", 1, Policy::Ignore, vec![StartEnd::Returned], 0, true),
        ],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let (e, u, r) = (s.comp("/e"), s.comp("/u"), s.comp("/r"));
    s.statements = vec![stmt(
        Kind::Whenever,
        triggered(e),
        start(r),
        Some(triggered(u)),
    )];
    s
}

/// `once E start R` and `whenever E interrupt R` in another process than R: the interrupt, sent after the start,
/// may be read first (R12); with `faults`, time may jump past HOLD between the two.
fn interrupt_beside_start(faults: Vec<Fault>) -> Scenario {
    let name = if faults.is_empty() {
        "interrupt-overtakes-its-start"
    } else {
        "interrupt-overtakes-its-start-after-hold"
    };
    let mut s = Scenario {
        name,
        components: vec![
            program(0),
            event("/e", 0, 2),
            response("/r", 1, Policy::Ignore),
        ],
        statements: vec![],
        faults,
        skew: vec![],
    };
    let (e, r) = (s.comp("/e"), s.comp("/r"));
    s.statements = vec![
        stmt(Kind::Once, triggered(e), start(r), None),
        stmt(Kind::Whenever, triggered(e), interrupt(r), None),
    ];
    s
}

/// `once E start R`, made while E already triggers, E in a process whose clock is `LATE` ahead (rule T1: its
/// stamps are dated by its lead); time may jump between a signal and its reading.
fn clock_ahead() -> Scenario {
    let mut s = Scenario {
        name: "source-clock-ahead",
        components: vec![
            program(0),
            event("/e", 1, 3),
            response("/r", 2, Policy::Ignore),
            stmt_holder(),
        ],
        statements: vec![],
        faults: vec![Fault::Wait],
        skew: vec![0, 2 * radar_spec::rules::LATE, 0],
    };
    s.components.pop();
    let (e, r) = (s.comp("/e"), s.comp("/r"));
    s.statements = vec![
        // a whenever that keeps E checking, then a once made at any step
        stmt(Kind::Whenever, triggered(e), interrupt(r), None),
        Statement {
            arm: ArmAt::Any,
            ..stmt(Kind::Once, triggered(e), start(r), None)
        },
    ];
    s
}

fn stmt_holder() -> Component {
    program(0)
}

/// `once E call`, its scope ending at any step.
fn anon_call() -> Scenario {
    let mut s = Scenario {
        name: "once-call-scope-ends",
        components: vec![program(0), event("/e", 1, 2)],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let e = s.comp("/e");
    s.statements = vec![Statement {
        scope_ends: true,
        ..stmt(
            Kind::Once,
            triggered(e),
            radar_spec::trace::Target::Call,
            None,
        )
    }];
    s
}

/// `whenever E start R` and `once E start Q` with filters that let only some payloads through.
fn filtered() -> Scenario {
    let mut s = Scenario {
        name: "filters",
        components: vec![
            program(0),
            event("/e", 1, 3),
            response("/r", 2, Policy::QueueOne),
            response("/q", 2, Policy::Ignore),
        ],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let (e, r, q) = (s.comp("/e"), s.comp("/r"), s.comp("/q"));
    s.statements = vec![
        Statement {
            accepts: Accepts::Values(0b101),
            ..stmt(Kind::Whenever, triggered(e), start(r), None)
        },
        Statement {
            accepts: Accepts::Values(0b110),
            ..stmt(Kind::Once, triggered(e), start(q), None)
        },
    ];
    s
}

/// `once E start R` where E's first payload is one R cannot read (a peer of another definition).
fn unreadable() -> Scenario {
    let mut s = Scenario {
        name: "once-unreadable-payload",
        components: vec![
            program(0),
            event_with(
                "/e",
                1,
                vec![
                    Payload {
                        value: 0,
                        unreadable: true,
                    },
                    Payload {
                        value: 1,
                        unreadable: false,
                    },
                ],
            ),
            response("/r", 2, Policy::Ignore),
        ],
        statements: vec![],
        faults: vec![],
        skew: vec![],
    };
    let (e, r) = (s.comp("/e"), s.comp("/r"));
    s.statements = vec![stmt(Kind::Once, triggered(e), start(r), None)];
    let _ = SignalKind::Started;
    s
}
