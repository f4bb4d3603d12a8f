//! Model-based test of the served-action rules S1-S7: random sequences of goals, cancel requests, the
//! response's signals (its goal's run's, another statement's, an injected run's), state changes, time, the
//! response leaving and the server stopping, checked step by step against a reference model written from the
//! rules in `radar_semantics::served`'s documentation, and at the end against what a client must see: every
//! accepted goal ends exactly once, one goal at a time, canceled only if a cancel covered it.

use proptest::prelude::*;
use radar_semantics::{
    response::{Cause, ExitReason, Sent},
    served::{Effect, EndStatus, ResponseView, ServedAction, Timing},
};

const STATEMENT: u128 = 3 << 64;
const STARTED_WITHIN: i64 = 50;
const REASON_WITHIN: i64 = 20;

/// Whose run a `started` or `exited` belongs to.
#[derive(Clone, Copy, Debug)]
enum Run {
    /// The current goal's (it carries the goal's cause).
    Goal,
    /// Another statement's.
    Other,
    /// An injected run, or a response that carries no causes.
    Plain,
}

#[derive(Clone, Debug)]
enum Op {
    Goal {
        idle: bool,
        on_graph: bool,
    },
    Cancel {
        covers_current: bool,
        all: bool,
    },
    Started(Run),
    Exited(Run, u8),
    /// The response's state: a run ended (for this reason), or a start was ignored, or neither.
    State(Option<u8>, bool),
    Advance(i64),
    Gone,
}

fn run() -> impl Strategy<Value = Run> {
    prop_oneof![Just(Run::Goal), Just(Run::Other), Just(Run::Plain)]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => (any::<bool>(), any::<bool>()).prop_map(|(a, b)| Op::Goal { idle: a || b, on_graph: b || !a }),
        2 => (any::<bool>(), any::<bool>()).prop_map(|(c, a)| Op::Cancel { covers_current: c, all: a && c }),
        3 => run().prop_map(Op::Started),
        3 => (run(), 0u8..4).prop_map(|(r, x)| Op::Exited(r, x)),
        3 => (prop::option::of(0u8..4), any::<bool>()).prop_map(|(e, i)| Op::State(e, i)),
        2 => (1i64..40).prop_map(Op::Advance),
        1 => Just(Op::Gone),
    ]
}

fn reason(code: u8) -> ExitReason {
    match code {
        0 => ExitReason::Completed,
        1 => ExitReason::Interrupted,
        2 => ExitReason::ExitSignal,
        _ => ExitReason::Failed("no".into()),
    }
}

type Fx = Vec<Effect<u32, u8>>;

/// The goal the model follows.
#[derive(Clone, Debug)]
struct Goal {
    id: u32,
    delivery: u64,
    executing: bool,
    canceling: bool,
    exits_before: u64,
    ignored_before: u64,
    accepted_at: i64,
    /// Its run sent `exited` (with this result) at this time, and the reason is awaited.
    exited: Option<(u8, i64)>,
}

/// S1-S7 as the documentation states them.
struct Model {
    goal: Option<Goal>,
    deliveries: u64,
}

impl Model {
    fn interrupt(now: i64) -> Effect<u32, u8> {
        Effect::Interrupt(Sent::by(
            now,
            Cause {
                statement: STATEMENT,
                delivery: 0,
            },
        ))
    }

    fn end(&mut self, status: EndStatus, result: Option<u8>) -> Effect<u32, u8> {
        let g = self.goal.take().expect("a goal to end");
        Effect::Finish {
            goal: g.id,
            status,
            result,
        }
    }

    /// S4: how a goal whose run ended as `view` says ends.
    fn status(view: &ResponseView) -> EndStatus {
        if view.last_exit == Some(ExitReason::Completed) {
            EndStatus::Succeeded
        } else {
            EndStatus::Aborted
        }
    }

    /// Whether a signal of `run` is the goal's run's (S7).
    fn is_goals(run: Run, keeps_causes: bool) -> bool {
        match run {
            Run::Goal => true,
            Run::Other => false,
            Run::Plain => !keeps_causes,
        }
    }

    fn step(&mut self, op: &Op, view: &ResponseView, keeps_causes: bool, now: i64, id: u32) -> Fx {
        match op {
            // S1, S2
            Op::Goal { .. } => {
                if self.goal.is_some() || !view.idle || !view.on_graph {
                    return vec![Effect::Reject(id)];
                }
                self.deliveries += 1;
                self.goal = Some(Goal {
                    id,
                    delivery: self.deliveries,
                    executing: false,
                    canceling: false,
                    exits_before: view.exits,
                    ignored_before: view.ignored_starts,
                    accepted_at: now,
                    exited: None,
                });
                let cause = Cause {
                    statement: STATEMENT,
                    delivery: self.deliveries,
                };
                vec![Effect::Accept {
                    goal: id,
                    start: Sent::by(now, cause),
                }]
            }
            // S3
            Op::Cancel {
                covers_current,
                all,
            } => match self.goal.as_mut() {
                Some(g) if g.exited.is_none() && !g.canceling && (*covers_current || *all) => {
                    g.canceling = true;
                    vec![Effect::AnswerCancel(vec![g.id]), Self::interrupt(now)]
                }
                _ => vec![Effect::AnswerCancel(vec![])],
            },
            // S1, S3, S7
            Op::Started(run) => match self.goal.as_mut() {
                Some(g) if g.exited.is_none() && Self::is_goals(*run, keeps_causes) => {
                    let mut fx = Vec::new();
                    if !g.executing {
                        g.executing = true;
                        fx.push(Effect::Execute(g.id));
                    }
                    if g.canceling {
                        fx.push(Self::interrupt(now));
                    }
                    fx
                }
                _ => vec![],
            },
            // S3, S4, S7
            Op::Exited(run, result) => match self.goal.as_mut() {
                Some(g) if g.exited.is_none() && Self::is_goals(*run, keeps_causes) => {
                    if g.canceling {
                        return vec![self.end(EndStatus::Canceled, Some(*result))];
                    }
                    g.exited = Some((*result, now));
                    // the state that says why may have been read first (two topics)
                    if view.exits > g.exits_before {
                        return vec![self.end(Self::status(view), Some(*result))];
                    }
                    vec![]
                }
                _ => vec![],
            },
            // S4, S6
            Op::State(..) => match &self.goal {
                Some(g) if g.exited.is_some() && view.exits > g.exits_before => {
                    let result = g.exited.map(|e| e.0);
                    vec![self.end(Self::status(view), result)]
                }
                Some(g)
                    if g.exited.is_none()
                        && !g.executing
                        && view.ignored_starts > g.ignored_before =>
                {
                    vec![self.end(EndStatus::Aborted, None)]
                }
                _ => vec![],
            },
            // S4, S6
            Op::Advance(_) => match &self.goal {
                Some(g) => match g.exited {
                    Some((result, at)) if now >= at + REASON_WITHIN => {
                        vec![self.end(EndStatus::Aborted, Some(result))]
                    }
                    None if !g.executing && now >= g.accepted_at + STARTED_WITHIN => {
                        vec![self.end(EndStatus::Aborted, None)]
                    }
                    _ => vec![],
                },
                None => vec![],
            },
            // S6
            Op::Gone => match &self.goal {
                Some(g) if g.exited.is_none() => vec![self.end(EndStatus::Aborted, None)],
                _ => vec![],
            },
        }
    }

    fn stop(&mut self, now: i64) -> Fx {
        match &self.goal {
            None => vec![],
            Some(g) => match g.exited {
                Some((result, _)) => vec![self.end(EndStatus::Aborted, Some(result))],
                None => vec![Self::interrupt(now), self.end(EndStatus::Aborted, None)],
            },
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn served_actions_follow_s1_to_s7(ops in prop::collection::vec(op(), 1..60), keeps_causes in any::<bool>()) {
        let timing = Timing { started_within: STARTED_WITHIN, reason_within: REASON_WITHIN };
        let mut s = ServedAction::<u32, u8>::with_timing(STATEMENT, timing);
        let mut m = Model { goal: None, deliveries: 0 };
        let mut view = ResponseView { idle: true, on_graph: true, ..ResponseView::default() };
        let mut now = 1_000;
        let mut all = Vec::new();
        for (k, o) in ops.iter().enumerate() {
            let id = k as u32;
            // the response's side, as the wire shows it
            let cause = |delivery| Cause { statement: STATEMENT, delivery };
            let sent = |run: Run| match run {
                Run::Goal => Sent::by(now, cause(m.goal.as_ref().map_or(0, |g| g.delivery))),
                Run::Other => Sent::by(now, Cause { statement: 77, delivery: 1 }),
                Run::Plain => Sent::at(now),
            };
            let got = match o {
                Op::Goal { idle, on_graph } => {
                    view.idle = *idle;
                    view.on_graph = *on_graph;
                    s.goal(id, &view, now)
                }
                Op::Cancel { covers_current, all } => {
                    let current = s.current().copied();
                    s.cancel(|g| *all || (*covers_current && Some(*g) == current), now)
                }
                Op::Started(run) => s.started(&sent(*run), keeps_causes, now),
                Op::Exited(run, result) => s.exited(*result, &sent(*run), keeps_causes, &view, now),
                Op::State(ended, ignored) => {
                    if let Some(r) = ended {
                        view.exits += 1;
                        view.last_exit = Some(reason(*r));
                    }
                    if *ignored {
                        view.ignored_starts += 1;
                    }
                    s.state(&view, now)
                }
                Op::Advance(dt) => {
                    now += dt;
                    s.tick(now)
                }
                Op::Gone => s.response_gone(),
            };
            let want = m.step(o, &view, keeps_causes, now, id);
            prop_assert_eq!(&got, &want, "step {}: {:?}", k, o);
            all.extend(got);
            now += 1;
        }
        let got = s.stop(now);
        prop_assert_eq!(&got, &m.stop(now));
        all.extend(got);

        // what a client sees: one goal at a time, each accepted goal ends once, canceled only if covered
        let mut open: Option<u32> = None;
        let mut canceling = Vec::new();
        for fx in &all {
            match fx {
                Effect::Accept { goal, start } => {
                    prop_assert!(open.is_none(), "goal {} accepted while {:?} runs", goal, open);
                    prop_assert_eq!(start.by.map(|c| c.statement), Some(STATEMENT));
                    open = Some(*goal);
                }
                Effect::Finish { goal, status, .. } => {
                    prop_assert_eq!(open.take(), Some(*goal), "a goal ends once, after it was accepted");
                    if *status == EndStatus::Canceled {
                        prop_assert!(canceling.contains(goal), "goal {} canceled, no cancel covered it", goal);
                    }
                    if canceling.contains(goal) {
                        prop_assert_ne!(*status, EndStatus::Succeeded, "a canceled goal does not succeed");
                    }
                }
                Effect::AnswerCancel(goals) => {
                    for g in goals {
                        prop_assert_eq!(Some(*g), open);
                        canceling.push(*g);
                    }
                }
                Effect::Execute(goal) => prop_assert_eq!(Some(*goal), open),
                Effect::Interrupt(sent) => {
                    prop_assert_eq!(sent.by, Some(Cause { statement: STATEMENT, delivery: 0 }));
                }
                Effect::Reject(_) => {}
            }
        }
        prop_assert!(open.is_none(), "every accepted goal ended");
    }
}
