//! The response rules (R1-R14), judged from what each response instance read and did.

use super::*;
use crate::trace::{Cause, ExitAction, ExitReason, Obs, Policy, SignalKind, SlotKind, StartEnd};
use crate::view::{Ending, RunView, Who};

/// How a run came to begin, as the trace tells it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Begun {
    /// The start read while idle that began it, if it was one.
    read: Option<usize>,
    /// The queued start it runs, if it was one.
    queued: Option<usize>,
    /// The time its start was sent, as the response took it (T1; a restart: when it began).
    sent: Time,
    /// When it began (R11): the later of `sent` and the end of the run before.
    began: Time,
}

/// A slot signal read before a run began that the run may take at its first await (R12, R14).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    read: usize,
    exit: bool,
    stamp: Time,
    /// Sure to be kept for the run (else it may have been dropped: a run between, an expiry, a tie).
    must: bool,
}

pub(super) fn check(f: &mut Found<'_, '_>) {
    starts_taken_or_told(f);
    let v = f.view;
    for (who, runs) in &v.runs {
        for (k, r) in runs.iter().enumerate() {
            let prev = k.checked_sub(1).map(|p| &runs[p]);
            let begun = begun(f, r, prev);
            runs_begin_on_a_start(f, r, prev, begun);
            started_announces_its_run(f, r);
            slots_in_order(f, r);
            if let Some(b) = begun {
                only_signals_for_the_run(f, r, b, runs, k);
                order_by_cause(f, r, b, runs, k);
            }
            every_run_exits(f, r);
        }
        let _ = who;
    }
    for i in 0..v.len() {
        match v.obs(i) {
            Obs::Read {
                comp,
                inst,
                slot,
                payload,
                ..
            } if v.trace.response(comp).is_some() => match slot {
                SlotKind::Start if payload.unreadable => {}
                SlotKind::Start => {
                    an_idle_start_begins_a_run(f, (comp, inst), i);
                    start_policy(f, (comp, inst), i);
                }
                SlotKind::Interrupt | SlotKind::Exit => {
                    an_interrupt_for_the_run_ends_it(f, (comp, inst), i)
                }
            },
            Obs::Emitted { signal, inst, .. } if signal.kind == SignalKind::Started => {
                let inside = v
                    .run_at((signal.comp, inst), i)
                    .is_some_and(|r| r.records.get(1) == Some(&i));
                if !inside {
                    let name = f.name(signal.comp).to_owned();
                    f.add(
                        &R1_STARTED_ANNOUNCES_ITS_RUN,
                        i,
                        &[signal.comp],
                        &[],
                        &[],
                        format!("{name} emitted `started` that announces no run beginning"),
                    );
                }
            }
            Obs::Stopping { comp, inst } if v.trace.response(comp).is_some() => {
                a_stop_ends_the_run(f, (comp, inst), i)
            }
            _ => {}
        }
    }
}

/// The time the run before ended, by the response's clock (its exit slot's end), if there was one.
fn ended(f: &Found<'_, '_>, prev: Option<&RunView>) -> Option<Time> {
    prev?
        .records
        .iter()
        .rev()
        .find_map(|&i| match f.view.obs(i) {
            Obs::ExitEnded { now, .. } => Some(now),
            _ => None,
        })
}

fn exit_action(f: &Found<'_, '_>, run: &RunView) -> Option<ExitAction> {
    run.records.iter().find_map(|&i| match f.view.obs(i) {
        Obs::ExitEnded { action, .. } => Some(action),
        _ => None,
    })
}

/// The newest start read while `prev` went on (its queue, R6), unless the policy drops them or a stop did.
fn queued(f: &Found<'_, '_>, prev: &RunView) -> Option<usize> {
    let (policy, _) = f.view.trace.response(prev.comp)?;
    if policy == Policy::Ignore {
        return None;
    }
    let end = prev.exited.unwrap_or(f.view.len());
    f.view
        .reads_of(prev.who(), prev.began + 1..end)
        .filter(|(_, s, ..)| *s == SlotKind::Start)
        .map(|(j, ..)| j)
        .last()
}

fn read_at(f: &Found<'_, '_>, j: usize) -> (Time, Option<Cause>, u8, Time) {
    match f.view.obs(j) {
        Obs::Read {
            stamp,
            by,
            payload,
            now,
            ..
        } => (stamp, by, payload.value, now),
        other => unreachable!("not a read: {other:?}"),
    }
}

fn idle_at(f: &Found<'_, '_>, who: Who, j: usize) -> bool {
    f.view
        .run_at(who, j)
        .is_none_or(|r| r.exited.is_some_and(|e| e < j))
}

/// How run `r` began; `None` if nothing in the trace began it.
pub(super) fn begun(f: &Found<'_, '_>, r: &RunView, prev: Option<&RunView>) -> Option<Begun> {
    let v = f.view;
    let step = v.step_of(r.began);
    let end_before = ended(f, prev).unwrap_or(Time::MIN);
    let read = v
        .reads_of(r.who(), step.start..r.began)
        .filter(|(j, s, ..)| *s == SlotKind::Start && idle_at(f, r.who(), *j))
        .map(|(j, ..)| j)
        .last();
    if let Some(j) = read {
        let (stamp, _, _, now) = read_at(f, j);
        let sent = taken(stamp, now);
        return Some(Begun {
            read: Some(j),
            queued: None,
            sent,
            began: sent.max(end_before),
        });
    }
    let p = prev?;
    if !p
        .exited
        .is_some_and(|e| v.same_step(e, r.began) && e < r.began)
    {
        return None;
    }
    match queued(f, p) {
        Some(q) => {
            let (stamp, _, _, now) = read_at(f, q);
            let sent = taken(stamp, now);
            Some(Begun {
                read: None,
                queued: Some(q),
                sent,
                began: sent.max(end_before),
            })
        }
        None if exit_action(f, p) == Some(ExitAction::Restart) => Some(Begun {
            read: None,
            queued: None,
            sent: r.now,
            began: r.now.max(end_before),
        }),
        None => None,
    }
}

fn runs_begin_on_a_start(
    f: &mut Found<'_, '_>,
    r: &RunView,
    prev: Option<&RunView>,
    b: Option<Begun>,
) {
    let name = f.name(r.comp).to_owned();
    if let Some(p) = prev {
        if p.exited.is_none_or(|e| e >= r.began) {
            f.add(
                &R1_RUNS_BEGIN_ON_A_START,
                r.began,
                &[r.comp],
                &[],
                &[],
                format!(
                    "run {} of {name} began while run {} had not exited",
                    r.run, p.run
                ),
            );
            return;
        }
    }
    let Some(b) = b else {
        f.add(
            &R1_RUNS_BEGIN_ON_A_START,
            r.began,
            &[r.comp],
            &[],
            &[],
            format!(
                "run {} of {name} began with no start read while idle, no start queued and no restart",
                r.run
            ),
        );
        return;
    };
    let (payload, cause) = match (b.read.or(b.queued), prev) {
        (Some(j), _) => {
            let (_, by, value, _) = read_at(f, j);
            (value, by)
        }
        (None, Some(p)) => (p.payload, None),
        (None, None) => return,
    };
    if (payload, cause) != (r.payload, r.cause) {
        f.add(
            &R1_RUNS_BEGIN_ON_A_START,
            r.began,
            &[r.comp],
            cause.map(|c| c.stmt).as_slice(),
            &[],
            format!(
                "run {} of {name} began with payload {} and cause {:?}; its start ({}) has {payload} and {cause:?}",
                r.run,
                r.payload,
                r.cause,
                match (b.read, b.queued) {
                    (Some(_), _) => "read while idle",
                    (_, Some(_)) => "the newest one queued",
                    _ => "a restart",
                }
            ),
        );
    }
}

fn started_announces_its_run(f: &mut Found<'_, '_>, r: &RunView) {
    let v = f.view;
    let mut started = r.records.iter().filter(
        |&&i| matches!(v.obs(i), Obs::Emitted { signal, .. } if signal.kind == SignalKind::Started),
    );
    let first = started.next().copied();
    let second = started.next().copied();
    let name = f.name(r.comp).to_owned();
    match first {
        None if r.records.len() > 1 => f.add(
            &R1_STARTED_ANNOUNCES_ITS_RUN,
            r.began,
            &[r.comp],
            &[],
            &[],
            format!("run {} of {name} began without `started`", r.run),
        ),
        None => {}
        Some(i) => {
            if r.records.get(1) != Some(&i) {
                f.add(
                    &R1_STARTED_ANNOUNCES_ITS_RUN,
                    i,
                    &[r.comp],
                    &[],
                    &[],
                    format!(
                        "`started` of run {} of {name} is not the first thing of the run",
                        r.run
                    ),
                );
            }
            if let Obs::Emitted {
                cause,
                payload,
                sig,
                ..
            } = v.obs(i)
            {
                if cause != r.cause || payload.value != r.payload {
                    f.add(
                        &R1_STARTED_ANNOUNCES_ITS_RUN,
                        i,
                        &[r.comp],
                        &[],
                        &[sig],
                        format!(
                            "`started` of run {} of {name} carries payload {} and cause {cause:?}, the run {} and {:?}",
                            r.run, payload.value, r.payload, r.cause
                        ),
                    );
                }
            }
        }
    }
    if let Some(i) = second {
        f.add(
            &R1_STARTED_ANNOUNCES_ITS_RUN,
            i,
            &[r.comp],
            &[],
            &[],
            format!("run {} of {name} emitted `started` twice", r.run),
        );
    }
}

/// What a run's records must say next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Next {
    Started,
    StartEnds,
    /// Cancelled: `interrupted` (then the interrupt slot) or the exit slot for an exit signal.
    AfterCancel,
    InterruptBegins,
    InterruptEnds,
    ExitBegins(ExitReason),
    ExitEnds,
    Exited,
    Over,
}

fn slots_in_order(f: &mut Found<'_, '_>, r: &RunView) {
    let v = f.view;
    let name = f.name(r.comp).to_owned();
    let mut next = Next::Started;
    for &i in &r.records[1..] {
        let o = v.obs(i);
        let ok = match (next, o) {
            (Next::Started, Obs::Emitted { signal, .. }) if signal.kind == SignalKind::Started => {
                next = Next::StartEnds;
                true
            }
            (Next::Started | Next::StartEnds, Obs::StartEnded { how, .. }) => {
                next = Next::ExitBegins(match how {
                    StartEnd::Returned => ExitReason::Completed,
                    StartEnd::Failed => ExitReason::Failed,
                    StartEnd::Panicked => ExitReason::Panicked,
                });
                true
            }
            (Next::Started | Next::StartEnds, Obs::Cancelled { .. }) => {
                next = Next::AfterCancel;
                true
            }
            (Next::AfterCancel, Obs::Emitted { signal, cause, .. })
                if signal.kind == SignalKind::Interrupted =>
            {
                next = Next::InterruptBegins;
                cause == r.cause
            }
            (Next::AfterCancel, Obs::ExitBegan { reason, .. }) => {
                next = Next::ExitEnds;
                reason == ExitReason::ExitSignal
            }
            (Next::InterruptBegins, Obs::InterruptBegan { .. }) => {
                next = Next::InterruptEnds;
                true
            }
            (Next::InterruptEnds, Obs::InterruptEnded { .. }) => {
                next = Next::ExitBegins(ExitReason::Interrupted);
                true
            }
            (Next::ExitBegins(want), Obs::ExitBegan { reason, .. }) => {
                next = Next::ExitEnds;
                reason == want
            }
            (Next::ExitEnds, Obs::ExitEnded { .. }) => {
                next = Next::Exited;
                true
            }
            (Next::Exited, Obs::Emitted { signal, cause, .. })
                if signal.kind == SignalKind::Exited =>
            {
                next = Next::Over;
                cause == r.cause
            }
            _ => false,
        };
        if !ok {
            f.add(
                &R2_SLOTS_IN_ORDER,
                i,
                &[r.comp],
                r.cause.map(|c| c.stmt).as_slice(),
                &[],
                format!("run {} of {name}: {o:?} where {next:?} was due", r.run),
            );
            return;
        }
    }
}

fn every_run_exits(f: &mut Found<'_, '_>, r: &RunView) {
    if r.exited.is_some() || f.view.crashed_by(r.who(), f.view.len()) || !f.judged(r.began) {
        return;
    }
    let name = f.name(r.comp).to_owned();
    f.add(
        &R7_EVERY_RUN_EXITS,
        f.view.len().saturating_sub(1),
        &[r.comp],
        r.cause.map(|c| c.stmt).as_slice(),
        &[],
        format!("run {} of {name} never exited", r.run),
    );
}

/// Whether a slot signal read as `(stamp, by, now)` on `slot` is for run `r` begun as `b` (R11, R13).
fn for_run(
    slot: SlotKind,
    stamp: Time,
    by: Option<Cause>,
    now: Time,
    r: &RunView,
    b: Begun,
) -> bool {
    let x = taken(stamp, now);
    match (slot, by) {
        (SlotKind::Interrupt, Some(k)) => r.cause.map(|c| c.stmt) == Some(k.stmt) && x >= b.sent,
        _ => x >= b.began,
    }
}

/// The slot signals read before `runs[k]` began that it may take at its first await (R12, R14).
fn candidates(f: &Found<'_, '_>, runs: &[RunView], k: usize, b: Begun) -> Vec<Candidate> {
    let v = f.view;
    let r = &runs[k];
    if v.stopping_before(r.who(), r.began) {
        return Vec::new(); // a stop forgets what was kept
    }
    let mut out = Vec::new();
    for (j, slot, stamp, by, now) in v.reads_of(r.who(), 0..r.began) {
        if slot == SlotKind::Start {
            continue;
        }
        let x = taken(stamp, now);
        let until = match (slot, by) {
            (SlotKind::Interrupt, Some(k)) => Some(k.stmt),
            _ => None,
        };
        // runs that began between the read and this one, with when their starts were sent
        let between: Vec<(&RunView, Option<Begun>)> = (0..k)
            .filter(|&i| runs[i].began > j)
            .map(|i| {
                (
                    &runs[i],
                    begun(f, &runs[i], i.checked_sub(1).map(|p| &runs[p])),
                )
            })
            .collect();
        // a later look at the clock more than HOLD after it may have dropped it
        let late = (j + 1..r.began).any(|i| match v.obs(i) {
            Obs::Read {
                comp, inst, now, ..
            }
            | Obs::RunBegan {
                comp, inst, now, ..
            }
            | Obs::ExitEnded {
                comp, inst, now, ..
            } => (comp, inst) == r.who() && now > x + HOLD,
            _ => false,
        });
        let within = x > b.sent && x - b.sent <= HOLD;
        let (kept, must) = match until {
            None => {
                // kept only when read while idle, for a run begun by a start read while idle
                let idle = idle_at(f, r.who(), j);
                let kept = b.read.is_some() && idle && within && x >= b.began;
                (kept, kept && between.is_empty() && !late)
            }
            Some(stmt) => {
                let ours = r.cause.map(|c| c.stmt) == Some(stmt);
                // a run of the statement begun between, by a start sent at or after it, dropped it
                let dropped = between.iter().any(|(p, pb)| {
                    p.cause.map(|c| c.stmt) == Some(stmt) && pb.is_some_and(|pb| pb.sent >= x)
                });
                // read while this run's start waited in the queue: kept with it however long it waited
                let with_queued = b.queued.is_some_and(|q| q < j) && x >= b.sent;
                let kept = ours && !dropped && (within || with_queued);
                (kept, kept && !late && x != b.sent)
            }
        };
        if kept || (until.is_some() && r.cause.map(|c| c.stmt) == until && x >= b.sent) {
            out.push(Candidate {
                read: j,
                exit: slot == SlotKind::Exit,
                stamp: x,
                must,
            });
        }
    }
    out
}

/// What ended run `r` at record `k` (Cancelled): the exit slot for an exit signal (`true`), or an interrupt.
fn cancel_kind(f: &Found<'_, '_>, r: &RunView, k: usize) -> Option<bool> {
    let pos = r.records.iter().position(|&i| i == k)?;
    match f.view.obs(*r.records.get(pos + 1)?) {
        Obs::Emitted { signal, .. } if signal.kind == SignalKind::Interrupted => Some(false),
        Obs::ExitBegan { .. } => Some(true),
        _ => None,
    }
}

fn only_signals_for_the_run(
    f: &mut Found<'_, '_>,
    r: &RunView,
    b: Begun,
    runs: &[RunView],
    k: usize,
) {
    let Ending::Cancelled(at) = r.ending else {
        return;
    };
    let v = f.view;
    let Some(exit) = cancel_kind(f, r, at) else {
        return; // R2 says what is wrong
    };
    let c = r.comp;
    let step = v.step_of(at);
    // (i) a slot signal read in the step, for this run
    let read = v
        .reads_of(r.who(), step.start..at)
        .any(|(_, slot, stamp, by, now)| match slot {
            SlotKind::Start => false,
            _ => (slot == SlotKind::Exit) == exit && for_run(slot, stamp, by, now, r, b),
        });
    // (ii) the run's first await, taking a signal kept for it
    let kept = step.contains(&r.began)
        && candidates(f, runs, k, b)
            .iter()
            .any(|cand| cand.exit == exit);
    // (iii) a start read in the step by a response that restarts
    let restart = !exit
        && v.trace
            .response(c)
            .is_some_and(|(p, _)| p == Policy::Restart)
        && v.reads_of(r.who(), step.start..at)
            .any(|(_, slot, ..)| slot == SlotKind::Start);
    // (iv) a stop
    let stop = exit
        && step
            .clone()
            .any(|i| matches!(v.obs(i), Obs::Stopping { comp, inst } if (comp, inst) == r.who()));
    if !(read || kept || restart || stop) {
        let name = f.name(c).to_owned();
        f.add(
            &R11_ONLY_SIGNALS_FOR_THE_RUN,
            at,
            &[c],
            r.cause.map(|c| c.stmt).as_slice(),
            &[],
            format!(
                "run {} of {name} (cause {:?}, begun at {}) was ended by {} that no signal meant for it asked for",
                r.run,
                r.cause,
                b.began,
                if exit { "its exit slot" } else { "an interrupt" }
            ),
        );
    }
}

fn order_by_cause(f: &mut Found<'_, '_>, r: &RunView, b: Begun, runs: &[RunView], k: usize) {
    let mut cands = candidates(f, runs, k, b);
    cands.sort_by_key(|c| c.stamp);
    let Some(first_must) = cands.iter().position(|c| c.must) else {
        return;
    };
    // the earliest kept for it is the one taken; a "may" one before the first "must" one leaves the kind open
    let kinds: Vec<bool> = cands[..=first_must].iter().map(|c| c.exit).collect();
    let v = f.view;
    let taken = match r.ending {
        Ending::Cancelled(at) if v.same_step(at, r.began) => cancel_kind(f, r, at),
        _ => None,
    };
    let ok = taken.is_some_and(|exit| kinds.contains(&exit));
    if !ok && r.records.len() > 1 {
        let cand = cands[first_must];
        let name = f.name(r.comp).to_owned();
        f.add(
            &R12_ORDER_BY_CAUSE,
            r.began,
            &[r.comp],
            r.cause.map(|c| c.stmt).as_slice(),
            &[],
            format!(
                "run {} of {name} (start sent at {}) did not take the {} read before it (record {}, sent at {}) at its first await",
                r.run,
                b.sent,
                if cand.exit { "exit" } else { "interrupt" },
                cand.read,
                cand.stamp
            ),
        );
    }
}

fn an_idle_start_begins_a_run(f: &mut Found<'_, '_>, who: Who, j: usize) {
    let v = f.view;
    if !idle_at(f, who, j) || v.stopping_before(who, j + 1) || v.left_by(who, j) {
        return;
    }
    let step = v.step_of(j);
    let began = (j + 1..step.end)
        .any(|i| matches!(v.obs(i), Obs::RunBegan { comp, inst, .. } if (comp, inst) == who));
    if !began {
        let name = f.name(who.0).to_owned();
        f.add(
            &R1_AN_IDLE_START_BEGINS_A_RUN,
            j,
            &[who.0],
            &[],
            &[],
            format!("{name} read a start while idle and began no run"),
        );
    }
}

/// Whether run `r`'s start behaviour still went on at record `j`.
fn going_at(f: &Found<'_, '_>, r: &RunView, j: usize) -> bool {
    match r.ending {
        Ending::Running => true,
        Ending::ByItself => r
            .records
            .iter()
            .any(|&i| i > j && matches!(f.view.obs(i), Obs::StartEnded { .. })),
        Ending::Cancelled(k) => k > j,
    }
}

fn start_policy(f: &mut Found<'_, '_>, who: Who, j: usize) {
    let v = f.view;
    let Some(run) = v
        .run_at(who, j)
        .filter(|r| r.exited.is_none_or(|e| e > j) && r.began < j)
    else {
        return;
    };
    let Some((policy, _)) = v.trace.response(who.0) else {
        return;
    };
    let step = v.step_of(j);
    let cancelled = (j + 1..step.end)
        .find(|&i| matches!(v.obs(i), Obs::Cancelled { comp, inst, .. } if (comp, inst) == who));
    let began = (j + 1..step.end)
        .any(|i| matches!(v.obs(i), Obs::RunBegan { comp, inst, .. } if (comp, inst) == who));
    let running = going_at(f, run, j);
    let name = f.name(who.0).to_owned();
    let wrong = match policy {
        Policy::Ignore | Policy::QueueOne => (cancelled.is_some() || began)
            .then(|| format!("{name} ({policy:?}) read a start while busy and acted on it at once")),
        Policy::Restart if running && !v.stopping_before(who, j) => match cancelled {
            Some(k) if cancel_kind(f, run, k) == Some(false) => None,
            _ => Some(format!(
                "{name} (restart) read a start while its start behaviour ran, and did not interrupt it"
            )),
        },
        Policy::Restart => None,
    };
    if let Some(why) = wrong {
        f.add(&R6_START_POLICY, j, &[who.0], &[], &[], why);
    }
    // the run after: R1 checks which start it runs; here, that one runs at all
    if policy != Policy::Ignore {
        if let Some(e) = run.exited {
            let next = (e + 1..v.step_of(e).end).any(
                |i| matches!(v.obs(i), Obs::RunBegan { comp, inst, .. } if (comp, inst) == who),
            );
            if !v.stopping_before(who, e) && !next && !v.left_by(who, e) {
                f.add(
                    &R1_AN_IDLE_START_BEGINS_A_RUN,
                    e,
                    &[who.0],
                    &[],
                    &[],
                    format!(
                        "{name} ended run {} with a start queued and began no run after it",
                        run.run
                    ),
                );
            }
        }
    }
}

fn an_interrupt_for_the_run_ends_it(f: &mut Found<'_, '_>, who: Who, j: usize) {
    let v = f.view;
    let Some(run) = v.run_at(who, j) else {
        return;
    };
    if run.began >= j || !going_at(f, run, j) || v.stopping_before(who, j) {
        return;
    }
    let runs = &v.runs[&who];
    let k = runs
        .iter()
        .position(|r| r.began == run.began)
        .expect("a run of the instance");
    let Some(b) = begun(f, run, k.checked_sub(1).map(|p| &runs[p])) else {
        return;
    };
    let Obs::Read {
        slot,
        stamp,
        by,
        now,
        ..
    } = v.obs(j)
    else {
        return;
    };
    if !for_run(slot, stamp, by, now, run, b) {
        return;
    }
    let step = v.step_of(j);
    let ended = match run.ending {
        Ending::Cancelled(k) if step.contains(&k) => {
            cancel_kind(f, run, k) == Some(slot == SlotKind::Exit)
        }
        _ => false,
    };
    if !ended {
        let name = f.name(who.0).to_owned();
        f.add(
            &R3_AN_INTERRUPT_FOR_THE_RUN_ENDS_IT,
            j,
            &[who.0],
            by.map(|c| c.stmt).as_slice(),
            &[],
            format!(
                "{name} read {} meant for run {} (cause {:?}) while its start behaviour ran, and did not end it",
                if slot == SlotKind::Exit { "an exit" } else { "an interrupt" },
                run.run,
                run.cause
            ),
        );
    }
}

fn a_stop_ends_the_run(f: &mut Found<'_, '_>, who: Who, s: usize) {
    let v = f.view;
    let name = f.name(who.0).to_owned();
    if let Some(i) = (s + 1..v.len())
        .find(|&i| matches!(v.obs(i), Obs::RunBegan { comp, inst, .. } if (comp, inst) == who))
    {
        f.add(
            &R7_STOP,
            i,
            &[who.0],
            &[],
            &[],
            format!("{name} began a run after it was told to stop"),
        );
    }
    let Some(run) = v.run_at(who, s).filter(|r| r.began < s) else {
        return;
    };
    if !going_at(f, run, s) {
        return;
    }
    let step = v.step_of(s);
    let ok = matches!(run.ending, Ending::Cancelled(k) if step.contains(&k) && cancel_kind(f, run, k) == Some(true));
    if !ok {
        f.add(
            &R7_STOP,
            s,
            &[who.0],
            &[],
            &[],
            format!(
                "{name} was told to stop while run {} ran, and did not end it through its exit slot",
                run.run
            ),
        );
    }
}

/// R6: every start with a cause a response instance read began a run or was announced on `dropped`, and none
/// announced runs.
fn starts_taken_or_told(f: &mut Found<'_, '_>) {
    let v = f.view;
    let mut out: Vec<Finding> = Vec::new();
    for j in 0..v.len() {
        match v.obs(j) {
            Obs::Emitted {
                signal,
                inst,
                cause: Some(c),
                ..
            } if signal.kind == SignalKind::Dropped => {
                out.extend(dropped_was_read_and_not_run(f, j, (signal.comp, inst), c));
            }
            Obs::Read {
                comp,
                inst,
                slot: SlotKind::Start,
                by: Some(c),
                payload,
                ..
            } if !payload.unreadable && v.trace.response(comp).is_some() => {
                out.extend(read_start_taken_or_told(f, j, (comp, inst), c));
            }
            _ => {}
        }
    }
    for (rule, i, comp, why) in out {
        f.add(rule, i, &[comp], &[], &[], why);
    }
}

/// A rule broken at a record, by a component, and why.
type Finding = (&'static Rule, usize, Comp, String);

/// R6 for instance `who`'s `dropped` carrying cause `c` at record `j`: it had read that start, and never ran it.
fn dropped_was_read_and_not_run(
    f: &Found<'_, '_>,
    j: usize,
    who: Who,
    c: Cause,
) -> Option<Finding> {
    let v = f.view;
    let read = v
        .reads_of(who, 0..j)
        .any(|(_, slot, _, by, _)| slot == SlotKind::Start && by == Some(c));
    let runs = v
        .runs
        .get(&who)
        .is_some_and(|rs| rs.iter().any(|r| r.cause == Some(c) && r.began > j));
    (!read || runs).then(|| {
        (
            &R6_A_START_NOT_TAKEN_IS_TOLD,
            j,
            who.0,
            format!(
                "{} announced it dropped the start {c:?}, which it {}",
                f.name(who.0),
                if runs { "then ran" } else { "never read" }
            ),
        )
    })
}

/// R6 for the start with cause `c` instance `who` read at record `j`: one it could not take then (busy and
/// ignoring starts, or stopping) is announced within the step; any other begins a run or is announced.
fn read_start_taken_or_told(f: &Found<'_, '_>, j: usize, who: Who, c: Cause) -> Option<Finding> {
    let v = f.view;
    let comp = who.0;
    let step_end = v.step_of(j).end;
    let began = v
        .runs
        .get(&who)
        .is_some_and(|rs| rs.iter().any(|r| r.cause == Some(c) && r.began >= j));
    let told = (j..v.len()).any(|i| {
        matches!(v.obs(i), Obs::Emitted { signal, inst: n, cause: Some(d), .. }
            if signal.kind == SignalKind::Dropped && (signal.comp, n) == who && d == c)
    });
    // read while busy by a response that ignores starts, or while it stops: dropped at once
    let busy = v
        .run_at(who, j)
        .is_some_and(|r| r.began < j && r.exited.is_none_or(|e| e > j));
    let ignores = v
        .trace
        .response(comp)
        .is_some_and(|(p, _)| p == Policy::Ignore);
    let at_once = (busy && ignores) || v.stopping_before(who, j);
    if at_once && !told_in(v, who, c, j..step_end) {
        Some((
            &R6_A_START_NOT_TAKEN_IS_TOLD,
            j,
            comp,
            format!(
                "{} did not take the start {c:?} and did not announce it",
                f.name(comp)
            ),
        ))
    } else if !began && !told && !v.crashed_by(who, v.len()) && f.judged(j) {
        Some((
            &R6_EVERY_START_TAKEN_OR_TOLD,
            v.len().saturating_sub(1),
            comp,
            format!(
                "{} read the start {c:?}, and neither ran it nor announced it dropped",
                f.name(comp)
            ),
        ))
    } else {
        None
    }
}

/// Whether instance `who` announced `c` dropped within `range`.
fn told_in(v: &crate::view::View<'_>, who: Who, c: Cause, range: std::ops::Range<usize>) -> bool {
    range.into_iter().any(|i| {
        matches!(v.obs(i), Obs::Emitted { signal, inst, cause: Some(d), .. }
            if signal.kind == SignalKind::Dropped && (signal.comp, inst) == who && d == c)
    })
}
