//! The rules, each a named check over a whole trace.

mod connection;
mod event;
mod response;

use crate::trace::{Comp, End, SigId, Stmt, Time};
use crate::view::View;

/// Whether a rule says what must never happen or what must happen in the end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Broken by a finite prefix: judged at every point of a trace.
    Safety,
    /// Broken only by a trace that is over: judged at its end ([`End::Quiescent`], or what is older than the
    /// grace of [`End::Cut`]).
    Liveness,
}

/// One rule of RADAR: its number (as the documentation, the machines and the tests use it), a short name, the
/// rule as it is stated, and its class.
#[derive(Debug, PartialEq, Eq)]
pub struct Rule {
    /// `R3`, `C2`, ...
    pub id: &'static str,
    /// `once-at-most-one`.
    pub name: &'static str,
    /// The rule.
    pub text: &'static str,
    /// Safety or liveness.
    pub class: Class,
    /// Whether a recording of the topics can show it (else it needs what happens inside a component or a
    /// manager: what was read and when, which slot ran).
    pub wire: bool,
}

macro_rules! rules {
    ($($konst:ident = $id:literal $name:literal $class:ident $($wire:ident)? $text:literal;)*) => {
        $(
            #[doc = concat!("**", $id, " ", $name, ".** ", $text)]
            pub static $konst: Rule = Rule {
                id: $id,
                name: $name,
                text: $text,
                class: Class::$class,
                wire: rules!(@wire $($wire)?),
            };
        )*
        /// Every rule, in the order the documentation gives them.
        pub static ALL: &[&Rule] = &[$(&$konst),*];
    };
    (@wire wire) => { true };
    (@wire) => { false };
}

rules! {
    R1_RUNS_BEGIN_ON_A_START = "R1" "runs-begin-on-a-start" Safety
        "A run begins only when the response reads a `start` while idle (then at once, with that start's payload \
         and cause), or as the run before it ends (its `exited`): with the newest start it queued (R6), else \
         with the same payload and no cause if its exit slot asked for a restart (R8). Runs never overlap.";
    R1_STARTED_ANNOUNCES_ITS_RUN = "R1" "started-announces-its-run" Safety wire
        "`started` is emitted once per run, as the run begins and before anything else of it, with the run's \
         payload and cause; never outside a run.";
    R1_AN_IDLE_START_BEGINS_A_RUN = "R1" "an-idle-start-begins-a-run" Safety
        "A `start` read while the response is idle, and not stopping, begins a run at once; a run that ends with \
         a start queued or a restart asked for is followed at once by the next run.";
    R2_SLOTS_IN_ORDER = "R2" "slots-in-order" Safety wire
        "A run goes: its start behaviour; then, if it ended by itself, the exit slot for that reason (completed, \
         failed, panicked); if an interrupt ended it, `interrupted`, the interrupt slot, then the exit slot \
         (interrupted); if an exit signal or a stop ended it, the exit slot (exit signal) with no interrupt slot; \
         the exit slot runs once, then `exited` once, carrying the run's cause (R3, R4, R7).";
    R3_AN_INTERRUPT_FOR_THE_RUN_ENDS_IT = "R3" "an-interrupt-for-the-run-ends-it" Safety
        "An `interrupt` or `exit` read while a run's start behaviour goes on, and meant for that run (R11, R13), \
         ends the run at once.";
    R6_START_POLICY = "R6" "start-policy" Safety
        "A `start` read while not idle: `ignore` does nothing with it; `restart` interrupts a running start \
         behaviour at once and runs the newest start after `exited`; `queue_one` runs the newest start after \
         `exited`.";
    R6_A_START_NOT_TAKEN_IS_TOLD = "R6" "a-start-not-taken-is-told" Safety
        "A start a statement sent that the response does not take (ignored while busy, replaced in its queue, \
         dropped by a stop) is announced on `dropped` with its cause, and a start so announced never runs.";
    R6_EVERY_START_TAKEN_OR_TOLD = "R6" "every-start-taken-or-told" Liveness
        "In the end every start a statement sent that a response read has begun a run, or was announced on \
         `dropped`, unless the response was killed.";
    R7_EVERY_RUN_EXITS = "R7" "every-run-exits" Liveness wire
        "The exit slot always runs: every run of a response that was not killed ends with `exited`.";
    R7_STOP = "R7" "a-stop-ends-the-run" Safety
        "A response whose program is told to stop begins no run after that, and a start behaviour that runs then \
         is ended through the exit slot at once.";
    R11_ONLY_SIGNALS_FOR_THE_RUN = "R11" "only-signals-for-the-run" Safety
        "A run is ended by an `interrupt` or `exit` only if one meant for it was read: one that names no \
         statement, emitted at or after the run began (the later of its start's stamp and the end of the run \
         before); an `until`'s, only in a run its statement started, emitted at or after that start was sent \
         (R13, R14).";
    R12_ORDER_BY_CAUSE = "R12" "order-by-cause" Safety
        "An `interrupt` or `exit` read before the start it follows (sent after it, within HOLD) ends that start's \
         run as soon as it begins (at its first await), as if they had been read in the order they were sent: one \
         read while idle (R12); an `until`'s interrupt read before a run of its statement whose start was sent \
         before it, also when that run had to wait for another (R14).";
    C1_NOT_BEFORE_ARMED = "C1" "not-before-armed" Safety wire
        "A statement delivers only signals emitted at or after it began. A signal from a process whose clock is \
         ahead is dated by how far ahead that process's earlier signals were (T1): then only within the transit \
         time of the fastest of those its manager read.";
    C2_ONCE_AT_MOST_ONE = "C2" "once-at-most-one" Safety wire
        "A `once` delivers at most one signal of its source.";
    C2_ONLY_WHAT_PASSES = "C2" "only-what-passes" Safety
        "A statement delivers only payloads its filter lets through, and to a start slot or an anonymous slot \
         only payloads that slot can read: a signal refused is no delivery.";
    C2_DELIVERS_WHAT_IT_READS = "C2" "delivers-what-it-reads" Safety
        "A live statement delivers, when it reads it, a signal of its source emitted since it began that its \
         filter and target take: a `whenever` every one, a `once` the first; unless its target is lost or its \
         program is stopping (then it starts nothing).";
    C3_SPENT_ONCE_ENDS = "C3" "spent-once-ends" Liveness
        "A `once` that has delivered ends by itself (its guard's `closed()` resolves): at once without `until`; \
         with `until U`, once the run its start began has ended, or its response did not take the start (R's \
         `dropped`), or its response left.";
    C3_UNTIL_LASTS_ITS_RUN = "C3" "until-lasts-its-run" Safety
        "A `once ... until` does not end while the run its start began goes on: U is read until that run ends.";
    C3_SPENT_LETS_GO = "C3" "spent-lets-go" Liveness
        "The manager reads exactly what its live statements need: a statement's source until it is spent or its \
         target is lost, and with `until U` the signals of U and the response's `started`, `exited` and \
         `dropped` until the statement is over. What an ended statement read alone is let go (an event it alone \
         listened to deactivates).";
    C4_SCOPE = "C4" "scope" Safety
        "After a statement's scope ends, it delivers nothing more, and its anonymous slot begins no call.";
    C5_LOSS_SEEN = "C5" "loss-seen" Liveness
        "A component a live statement needs (its target, its source until it is spent) that leaves is seen as \
         lost by that statement.";
    C5_NO_LOSS_OF_THE_LIVING = "C5" "no-loss-of-the-living" Safety
        "A statement takes a component as lost only after the instance it was made with left: another live \
         process of that name beside it is not a loss.";
    C5_NOTHING_TO_THE_LOST = "C5" "nothing-to-the-lost" Safety
        "After a statement has seen its target lost, it sends that target nothing more.";
    C6_CAUSES = "C6" "causes" Safety wire
        "A start a statement delivers carries the statement and the delivery's number (from 1); an `until`'s \
         interrupt names the statement (delivery 0) and carries the stamp of U's signal.";
    C6_UNTIL_REACHES_ITS_RUN = "C6" "until-reaches-its-run" Safety
        "A signal of U read while a run of one of the statement's starts may be going (from a start delivery until \
         R's `exited` carrying it or a later delivery of the statement, or R's `dropped` carrying it: a later start \
         R drops does not end the run of an earlier one) is sent to R's `interrupt`; the newest one read while none \
         may be going is sent right after the next start, if that start's source was emitted before it, within \
         HOLD (C7).";
    E1_CHECKS_ONLY_WHILE_LISTENED = "E1" "checks-only-while-listened" Safety wire
        "An event checks its condition only while it knows of a listener to its `triggered`, stops as soon as it \
         knows of none, and emits `triggered` only while checking.";
    E1_UNHEARD_EVENTS_STOP = "E1" "unheard-events-stop" Liveness
        "In the end an event checks exactly when something reads its `triggered`.";
}

/// How long a signal that overtook the slot signal it follows is kept for it (R12, C7), in ns.
pub const HOLD: Time = 1_000_000_000;

/// How old a stamp may be and still be taken as it is (T1), in ns.
pub const LATE: Time = 2 * HOLD;

/// A stamp as a receiver whose clock reads `now` takes it (T1): never later than `now`, at most [`LATE`]
/// before it.
pub fn taken(stamp: Time, now: Time) -> Time {
    stamp.clamp(now.saturating_sub(LATE), now)
}

/// A rule broken: where, by whom, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    /// The rule.
    pub rule: &'static Rule,
    /// The record where it shows (the end of the trace for a liveness rule).
    pub index: usize,
    /// Its time.
    pub at: Time,
    /// The components involved.
    pub comps: Vec<Comp>,
    /// The statements involved.
    pub stmts: Vec<Stmt>,
    /// The signals involved.
    pub sigs: Vec<SigId>,
    /// What happened.
    pub why: String,
}

/// What a trace saw of the system.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sight {
    /// Everything: what components and managers read, when, and which slots ran (a model's trace).
    Inside,
    /// What crosses the topics (a recording): the rules that need more are not judged.
    Wire,
    /// What crosses the topics from some point in a run on (a live view's window of the latest samples): as
    /// [`Sight::Wire`], and what happened before the trace is not in it, so what a rule counts (a statement's
    /// deliveries) begins where the trace does.
    WireSince,
}

/// Collects the violations of one check.
pub(crate) struct Found<'v, 't> {
    pub(crate) view: &'v View<'t>,
    pub(crate) end: End,
    pub(crate) sight: Sight,
    pub(crate) out: Vec<Violation>,
}

impl Found<'_, '_> {
    /// A violation of `rule` at record `index`.
    pub(crate) fn add(
        &mut self,
        rule: &'static Rule,
        index: usize,
        comps: &[Comp],
        stmts: &[Stmt],
        sigs: &[SigId],
        why: String,
    ) {
        let at = self
            .view
            .trace
            .records
            .get(index)
            .or(self.view.trace.records.last())
            .map_or(0, |r| r.at);
        self.out.push(Violation {
            rule,
            index,
            at,
            comps: comps.to_vec(),
            stmts: stmts.to_vec(),
            sigs: sigs.to_vec(),
            why,
        });
    }

    /// The component's name.
    pub(crate) fn name(&self, c: Comp) -> &str {
        self.view.trace.name(c)
    }

    /// Whether liveness is judged for an obligation that arose at record `since`: at the end of a finished
    /// trace, or at the end of a cut one if `since` is older than its grace.
    pub(crate) fn judged(&self, since: usize) -> bool {
        match self.end {
            End::Open => false,
            End::Quiescent => true,
            End::Cut { grace } => {
                let last = self.view.trace.records.last().map_or(0, |r| r.at);
                let at = self.view.trace.records.get(since).map_or(last, |r| r.at);
                last - at > grace
            }
        }
    }
}

/// Runs every rule.
pub(crate) fn check_all(found: &mut Found<'_, '_>) {
    response::check(found);
    connection::check(found);
    event::check(found);
}
