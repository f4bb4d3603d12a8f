//! The connection rules (C1-C7), judged from what each statement's manager read and sent.

use std::collections::BTreeSet;

use super::*;
use crate::trace::{Cause, Kind, Obs, Signal, SignalKind, Slot, SlotKind, Target};
use crate::view::StmtView;

pub(super) fn check(f: &mut Found<'_, '_>) {
    let stmts: Vec<(Stmt, StmtView)> = f.view.stmts.iter().map(|(k, s)| (*k, s.clone())).collect();
    for (k, st) in &stmts {
        let sends = source_sends(f, st);
        not_before_armed(f, *k, st, &sends);
        once_at_most_one(f, *k, st, &sends);
        only_what_passes(f, *k, st, &sends);
        causes(f, *k, st, &sends);
        scope(f, *k, st);
        spent_once_ends(f, *k, st, &sends);
        until_lasts_its_run(f, *k, st);
        loss_seen(f, *k, st);
        no_loss_of_the_living(f, *k, st);
        nothing_to_the_lost(f, *k, st);
        until_reaches_its_run(f, *k, st, &sends);
    }
    delivers_what_it_reads(f, &stmts);
    spent_lets_go(f);
}

/// What a statement delivered on its source (not its `until`'s interrupts), by record index.
fn source_sends(f: &Found<'_, '_>, st: &StmtView) -> Vec<usize> {
    st.sent
        .iter()
        .copied()
        .filter(|&i| !is_until_send(f, st, i))
        .collect()
}

fn is_until_send(f: &Found<'_, '_>, st: &StmtView, i: usize) -> bool {
    st.until.is_some()
        && matches!(
            f.view.obs(i),
            Obs::Sent {
                to: Target::Slot(Slot {
                    kind: SlotKind::Interrupt,
                    ..
                }),
                ..
            }
        )
}

fn sent(f: &Found<'_, '_>, i: usize) -> (SigId, Target, Time, Option<Cause>) {
    match f.view.obs(i) {
        Obs::Sent {
            sig, to, stamp, by, ..
        } => (sig, to, stamp, by),
        other => unreachable!("not a send: {other:?}"),
    }
}

/// Whether the target reads payloads (a start slot, an anonymous slot), rather than only counting signals.
fn reads_payloads(t: Target) -> bool {
    matches!(
        t,
        Target::Call
            | Target::Slot(Slot {
                kind: SlotKind::Start,
                ..
            })
    )
}

fn is_start(t: Target) -> bool {
    matches!(
        t,
        Target::Slot(Slot {
            kind: SlotKind::Start,
            ..
        })
    )
}

fn target_comp(st: &StmtView) -> Option<Comp> {
    match st.target {
        Target::Slot(s) => Some(s.comp),
        Target::Call => None,
    }
}

/// How precisely the manager can date the signals of the instance that emitted `e` by record `i` (T1): exactly
/// if its clock is the true one; if it is ahead, within the transit time of the fastest of its signals the
/// manager read before (none read yet: not at all).
fn dating_error(f: &Found<'_, '_>, e: &crate::view::Emission, i: usize) -> Time {
    if e.stamp <= e.at {
        return 0;
    }
    let v = f.view;
    (0..i)
        .filter_map(|j| match v.obs(j) {
            Obs::ManagerRead { sig, .. } => {
                let x = v.emission(sig)?;
                (x.signal.comp == e.signal.comp && x.inst == e.inst && x.stamp > x.at)
                    .then(|| v.trace.records[j].at - x.at)
            }
            _ => None,
        })
        .min()
        .unwrap_or(Time::MAX)
}

fn not_before_armed(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    for &i in sends {
        let (sig, ..) = sent(f, i);
        let Some(e) = f.view.emission(sig) else {
            continue;
        };
        if e.at < st.since && st.since - e.at > dating_error(f, &e, i) {
            f.add(
                &C1_NOT_BEFORE_ARMED,
                i,
                &[st.source.comp],
                &[k],
                &[sig],
                format!(
                    "statement {k} delivered a signal emitted at {}, before it began at {} (stamped {})",
                    e.at, st.since, e.stamp
                ),
            );
        }
    }
}

fn once_at_most_one(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    if st.kind != Kind::Once || sends.len() < 2 {
        return;
    }
    let sigs: Vec<SigId> = sends.iter().map(|&i| sent(f, i).0).collect();
    f.add(
        &C2_ONCE_AT_MOST_ONE,
        sends[1],
        &[st.source.comp],
        &[k],
        &sigs,
        format!("once statement {k} delivered {} signals", sends.len()),
    );
}

fn only_what_passes(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    for &i in sends {
        let (sig, to, ..) = sent(f, i);
        let Some(payload) = f.view.emission(sig).map(|e| e.payload) else {
            continue;
        };
        let refused = st.accepts.passes(payload) == Some(false);
        let unreadable = payload.unreadable && reads_payloads(to);
        if refused || unreadable {
            f.add(
                &C2_ONLY_WHAT_PASSES,
                i,
                &[st.source.comp],
                &[k],
                &[sig],
                format!(
                    "statement {k} delivered {}",
                    if unreadable {
                        "a payload its target cannot read".to_owned()
                    } else {
                        format!("payload {} that its filter refuses", payload.value)
                    }
                ),
            );
        }
    }
}

fn causes(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    // a trace that begins in the middle of a run counts the deliveries from the first it saw
    let first = sends.iter().copied().find(|&i| is_start(sent(f, i).1));
    let before = match (f.sight, first) {
        (Sight::WireSince, Some(i)) => match sent(f, i).3 {
            Some(c) if c.stmt == k => c.delivery.saturating_sub(1),
            _ => 0,
        },
        _ => 0,
    };
    for (n, &i) in sends.iter().enumerate() {
        let (sig, to, _, by) = sent(f, i);
        if is_start(to) {
            let want = Some(Cause {
                stmt: k,
                delivery: before + n as u64 + 1,
            });
            if by != want {
                f.add(
                    &C6_CAUSES,
                    i,
                    &[st.source.comp],
                    &[k],
                    &[sig],
                    format!(
                        "start {} of statement {k} carries {by:?}, not {want:?}",
                        n + 1
                    ),
                );
            }
        }
    }
    for &i in &st.sent {
        if !is_until_send(f, st, i) {
            continue;
        }
        let (sig, _, stamp, by) = sent(f, i);
        let want = Some(Cause {
            stmt: k,
            delivery: 0,
        });
        let read_stamp = manager_stamp(f, sig, i);
        if by != want || read_stamp.is_some_and(|s| s != stamp) {
            f.add(
                &C6_CAUSES,
                i,
                &[],
                &[k],
                &[sig],
                format!(
                    "the until interrupt of statement {k} carries {by:?} at {stamp}, not {want:?} at the stamp of U's signal ({read_stamp:?})"
                ),
            );
        }
    }
}

/// The stamp of `sig` as the manager took it when it last read it at or before record `i` (T1).
fn manager_stamp(f: &Found<'_, '_>, sig: SigId, i: usize) -> Option<Time> {
    let stamp = f.view.emission(sig)?.stamp;
    (0..=i).rev().find_map(|j| match f.view.obs(j) {
        Obs::ManagerRead { sig: s, now } if s == sig => Some(taken(stamp, now)),
        _ => None,
    })
}

fn scope(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView) {
    let Some(end) = st.scope_ended else {
        return;
    };
    for &i in st.sent.iter().chain(&st.called) {
        if i > end && !f.view.same_step(i, end) {
            let what = match f.view.obs(i) {
                Obs::Called { .. } => "its anonymous slot was called",
                _ => "it delivered a signal",
            };
            f.add(
                &C4_SCOPE,
                i,
                &[],
                &[k],
                &[],
                format!("statement {k}'s scope had ended, and {what}"),
            );
            return;
        }
    }
}

/// Whether a run of some live instance of `comp` whose cause is statement `k` goes on at the end.
fn run_of_going_at_end(f: &Found<'_, '_>, comp: Comp, k: Stmt) -> bool {
    let v = f.view;
    v.alive_at(comp, v.len()).into_iter().any(|inst| {
        v.run_at((comp, inst), v.len())
            .is_some_and(|r| r.exited.is_none() && r.cause.map(|c| c.stmt) == Some(k))
    })
}

fn spent_once_ends(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    let Some(&first) = sends.first() else {
        return;
    };
    let v = f.view;
    if st.kind != Kind::Once || st.over().is_some() || !f.judged(first) || v.program_left(v.len()) {
        return;
    }
    if let Some(r) = st.until_response() {
        if run_of_going_at_end(f, r, k) {
            return;
        }
    }
    f.add(
        &C3_SPENT_ONCE_ENDS,
        v.len().saturating_sub(1),
        target_comp(st).as_slice(),
        &[k],
        &[sent(f, first).0],
        format!(
            "once statement {k} delivered and never ended{}",
            if st.until.is_some() {
                " though no run of its start goes on"
            } else {
                ""
            }
        ),
    );
}

fn until_lasts_its_run(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView) {
    let (Some(e), Some(r)) = (st.ended, st.until_response()) else {
        return;
    };
    if st.kind != Kind::Once {
        return;
    }
    let v = f.view;
    // the manager knew, when it ended the statement, that the response it interrupts had left
    let lost = st
        .losses
        .iter()
        .any(|&j| j < e && matches!(v.obs(j), Obs::LossSeen { comp, .. } if comp == r));
    if lost {
        return;
    }
    // every run the statement's start began on an instance it was made with must have ended, as the manager
    // read it, before it ended
    let made_with = v.alive_at(r, st.armed);
    for (_, runs) in v
        .runs
        .iter()
        .filter(|(w, _)| w.0 == r && made_with.contains(&w.1))
    {
        for run in runs
            .iter()
            .filter(|run| run.cause.map(|c| c.stmt) == Some(k))
        {
            let exited = run.exited.and_then(|x| match v.obs(x) {
                Obs::Emitted { sig, .. } => Some(sig),
                _ => None,
            });
            let read = exited.is_some_and(|sig| {
                (0..e).any(|j| matches!(v.obs(j), Obs::ManagerRead { sig: s, .. } if s == sig))
            });
            if !read {
                let name = f.name(r).to_owned();
                f.add(
                    &C3_UNTIL_LASTS_ITS_RUN,
                    e,
                    &[r],
                    &[k],
                    &[],
                    format!(
                        "once ... until statement {k} ended before it had read the end of run {} of {name}, which its start began",
                        run.run
                    ),
                );
                return;
            }
        }
    }
}

/// Whether statement `st` has lost its target before record `i`.
fn target_lost_before(f: &Found<'_, '_>, st: &StmtView, i: usize) -> bool {
    let Some(t) = target_comp(st) else {
        return false;
    };
    st.losses
        .iter()
        .any(|&j| j < i && matches!(f.view.obs(j), Obs::LossSeen { comp, .. } if comp == t))
}

fn delivers_what_it_reads(f: &mut Found<'_, '_>, stmts: &[(Stmt, StmtView)]) {
    let v = f.view;
    let program = v.trace.program();
    for j in 0..v.len() {
        let Obs::ManagerRead { sig, now } = v.obs(j) else {
            continue;
        };
        let Some(em) = v.emission(sig) else {
            continue;
        };
        for (k, st) in stmts {
            if st.source != em.signal || st.armed >= j || st.over().is_some_and(|e| e < j) {
                continue;
            }
            let spent = st.kind == Kind::Once && source_sends(f, st).iter().any(|&i| i < j);
            let stopping =
                is_start(st.target) && program.is_some_and(|p| v.stopping_before((p, 0), j + 1));
            let source_lost = st.losses.iter().any(|&l| {
                l < j && matches!(v.obs(l), Obs::LossSeen { comp, .. } if comp == st.source.comp)
            });
            let takes = st.accepts.passes(em.payload) == Some(true)
                && !(em.payload.unreadable && reads_payloads(st.target));
            if spent
                || stopping
                || source_lost
                || !takes
                || em.at < st.since
                || target_lost_before(f, st, j)
            {
                continue;
            }
            let delivered = v.step_of(j).any(
                |i| matches!(v.obs(i), Obs::Sent { stmt, sig: s, .. } if stmt == *k && s == sig),
            );
            if !delivered {
                f.add(
                    &C2_DELIVERS_WHAT_IT_READS,
                    j,
                    &[em.signal.comp],
                    &[*k],
                    &[sig],
                    format!(
                        "statement {k} read a signal of its source emitted at {} (stamp {}) and did not deliver it",
                        em.at,
                        taken(em.stamp, now)
                    ),
                );
            }
        }
    }
}

fn spent_lets_go(f: &mut Found<'_, '_>) {
    let v = f.view;
    if !f.judged(v.len().saturating_sub(1)) || v.program_left(v.len()) {
        return;
    }
    let mut reading: BTreeSet<Signal> = BTreeSet::new();
    for i in 0..v.len() {
        if let Obs::Reading { signal, on } = v.obs(i) {
            if on {
                reading.insert(signal);
            } else {
                reading.remove(&signal);
            }
        }
    }
    let mut needed: BTreeSet<Signal> = BTreeSet::new();
    let end = v.len();
    let mut who: Vec<Stmt> = Vec::new();
    for (k, st) in &v.stmts {
        if st.over().is_some() {
            continue;
        }
        let spent = st.kind == Kind::Once && !source_sends(f, st).is_empty();
        if !spent && !target_lost_before(f, st, end) {
            needed.insert(st.source);
        }
        if let (Some(u), Some(r)) = (st.until, st.until_response()) {
            needed.insert(u);
            needed.insert(Signal {
                comp: r,
                kind: SignalKind::Started,
            });
            needed.insert(Signal {
                comp: r,
                kind: SignalKind::Exited,
            });
            needed.insert(Signal {
                comp: r,
                kind: SignalKind::Dropped,
            });
        }
        who.push(*k);
    }
    if reading != needed {
        let extra: Vec<String> = reading
            .difference(&needed)
            .map(|s| format!("{}/{:?}", v.trace.name(s.comp), s.kind))
            .collect();
        let missing: Vec<String> = needed
            .difference(&reading)
            .map(|s| format!("{}/{:?}", v.trace.name(s.comp), s.kind))
            .collect();
        let comps: Vec<Comp> = reading
            .symmetric_difference(&needed)
            .map(|s| s.comp)
            .collect();
        f.add(
            &C3_SPENT_LETS_GO,
            end.saturating_sub(1),
            &comps,
            &who,
            &[],
            format!("in the end the manager reads {extra:?} that no live statement needs, and not {missing:?} that one does"),
        );
    }
}

/// The components statement `st` needs at record `i`: its target, and its source until it is spent.
fn needs_at(f: &Found<'_, '_>, st: &StmtView, i: usize) -> Vec<Comp> {
    let mut v: Vec<Comp> = target_comp(st).into_iter().collect();
    let spent = st.kind == Kind::Once && source_sends(f, st).iter().any(|&s| s < i);
    if !spent && !v.contains(&st.source.comp) {
        v.push(st.source.comp);
    }
    v
}

fn loss_seen(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView) {
    let v = f.view;
    if st.over().is_some() || v.program_left(v.len()) {
        return;
    }
    let comps: BTreeSet<Comp> = needs_at(f, st, st.armed + 1).into_iter().collect();
    for c in comps {
        let instances = v.alive_at(c, st.armed);
        for l in st.armed + 1..v.len() {
            let Obs::Left { comp, instance, .. } = v.obs(l) else {
                continue;
            };
            if comp != c
                || !instances.contains(&instance)
                || !needs_at(f, st, l).contains(&comp)
                || !f.judged(l)
            {
                continue;
            }
            let seen = st
                .losses
                .iter()
                .any(|&j| j > l && matches!(v.obs(j), Obs::LossSeen { comp: x, .. } if x == comp));
            if !seen {
                let name = f.name(comp).to_owned();
                f.add(
                    &C5_LOSS_SEEN,
                    l,
                    &[comp],
                    &[k],
                    &[],
                    format!("{name} (instance {instance}) left and statement {k}, which needs it, never saw it lost"),
                );
            }
        }
    }
}

fn no_loss_of_the_living(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView) {
    let v = f.view;
    for &j in &st.losses {
        let Obs::LossSeen { comp, .. } = v.obs(j) else {
            continue;
        };
        let at_arming = v.alive_at(comp, st.armed);
        let now = v.alive_at(comp, j);
        // an instance the statement could have been made with has left
        if at_arming.iter().any(|n| !now.contains(n)) || at_arming.is_empty() {
            continue;
        }
        let name = f.name(comp).to_owned();
        f.add(
            &C5_NO_LOSS_OF_THE_LIVING,
            j,
            &[comp],
            &[k],
            &[],
            format!(
                "statement {k} took {name} as lost while the instances it was made with ({at_arming:?}) are alive"
            ),
        );
    }
}

fn nothing_to_the_lost(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView) {
    let Some(t) = target_comp(st) else {
        return;
    };
    let Some(&lost) = st
        .losses
        .iter()
        .find(|&&j| matches!(f.view.obs(j), Obs::LossSeen { comp, .. } if comp == t))
    else {
        return;
    };
    if let Some(&i) = st
        .sent
        .iter()
        .find(|&&i| i > lost && !f.view.same_step(i, lost))
    {
        let name = f.name(t).to_owned();
        f.add(
            &C5_NOTHING_TO_THE_LOST,
            i,
            &[t],
            &[k],
            &[sent(f, i).0],
            format!("statement {k} saw {name} lost, then sent it a signal"),
        );
    }
}

/// Record `j` is the manager's read of a signal of R, from an instance of R the statement was made with
/// (`made_with`), that says no run of statement `k`'s delivery `n` goes on: R's `exited` carrying `n` or a later
/// delivery of `k` (R takes starts one after another: the run of a later one began after `n`'s ended or was
/// dropped), or R's `dropped` carrying `n` itself (a later start dropped says nothing of `n`'s run).
fn closes(f: &Found<'_, '_>, j: usize, r: Comp, made_with: &[u32], k: Stmt, n: u64) -> bool {
    let Obs::ManagerRead { sig, .. } = f.view.obs(j) else {
        return false;
    };
    f.view.emission(sig).is_some_and(|e| {
        e.signal.comp == r
            && made_with.contains(&e.inst)
            && e.cause.is_some_and(|c| {
                c.stmt == k
                    && match e.signal.kind {
                        SignalKind::Exited => c.delivery >= n,
                        SignalKind::Dropped => c.delivery == n,
                        _ => false,
                    }
            })
    })
}

/// The manager's reads of `u`'s signals while statement `st` lived: each record, signal and the stamp it took.
fn u_reads(v: &crate::view::View<'_>, st: &StmtView, u: Signal) -> Vec<(usize, SigId, Time)> {
    let end = st.over().unwrap_or(v.len());
    (st.armed + 1..end)
        .filter_map(|j| match v.obs(j) {
            Obs::ManagerRead { sig, now } => match v.emission(sig) {
                Some(e) if e.signal == u => Some((j, sig, taken(e.stamp, now))),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

/// Whether statement `k` sent signal `sig` to an interrupt slot in record `j`'s step.
fn interrupt_sent_in_step(v: &crate::view::View<'_>, k: Stmt, j: usize, sig: SigId) -> bool {
    v.step_of(j).any(|i| {
        matches!(
            v.obs(i),
            Obs::Sent { stmt, sig: s, to: Target::Slot(Slot { kind: SlotKind::Interrupt, .. }), .. }
                if stmt == k && s == sig
        )
    })
}

fn until_reaches_its_run(f: &mut Found<'_, '_>, k: Stmt, st: &StmtView, sends: &[usize]) {
    let (Some(u), Some(r)) = (st.until, st.until_response()) else {
        return;
    };
    // C6 is the rule for responses that keep causes; C7's other case (rclpy) is judged by its own window
    if !f.view.trace.response(r).is_some_and(|(_, causes)| causes) {
        return;
    }
    let v = f.view;
    let lost = |j: usize| matches!(v.obs(j), Obs::LossSeen { comp, .. } if comp == r);
    let made_with = v.alive_at(r, st.armed);
    // whether a run of one of the statement's starts may be going at record `j`, as the manager can know it
    let open_at = |j: usize| -> bool {
        sends
            .iter()
            .enumerate()
            .filter(|(_, &d)| d < j)
            .any(|(n, &d)| {
                !(d + 1..j).any(|i| closes(f, i, r, &made_with, k, n as u64 + 1) || lost(i))
            })
    };
    let u_reads = u_reads(v, st, u);
    let sent_in_step = |j: usize, sig: SigId| interrupt_sent_in_step(v, k, j, sig);
    let name = f.name(r).to_owned();
    let mut out: Vec<(usize, SigId, String)> = Vec::new();
    for &(j, sig, stamp) in &u_reads {
        if open_at(j) && !sent_in_step(j, sig) {
            out.push((
                j,
                sig,
                format!(
                    "statement {k} read U's signal (stamp {stamp}) while a run of its start on {name} may go on, and did not send it to {name}'s interrupt"
                ),
            ));
        }
    }
    // C7 for a response that keeps causes: the newest U read while no run may go, sent right after the next start
    for (n, &d) in sends.iter().enumerate() {
        let from = sends[..n]
            .last()
            .copied()
            .max((st.armed..d).rev().find(|&i| lost(i)))
            .unwrap_or(st.armed);
        let newest = u_reads
            .iter()
            .filter(|(j, ..)| *j > from && *j < d && !open_at(*j))
            .max_by_key(|(_, _, stamp)| *stamp);
        let Some(&(_, sig, ustamp)) = newest else {
            continue;
        };
        let (_, _, sstamp, _) = sent(f, d);
        if ustamp > sstamp && ustamp - sstamp <= HOLD && !sent_in_step(d, sig) {
            out.push((
                d,
                sig,
                format!(
                    "statement {k} had read U's signal (stamp {ustamp}) before its start {} (source stamp {sstamp}) and did not send it to {name}'s interrupt after that start",
                    n + 1
                ),
            ));
        }
    }
    for (i, sig, why) in out {
        f.add(
            &C6_UNTIL_REACHES_ITS_RUN,
            i,
            &[u.comp, r],
            &[k],
            &[sig],
            why,
        );
    }
}
