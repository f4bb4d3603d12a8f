//! # radar_spec: RADAR's rules, checked over what a system did
//!
//! RADAR (Biggs & MacDonald) promises what happens when: events that check only while something listens,
//! responses whose exit slot always runs, `once` / `whenever` / `until` connections that deliver signals to
//! slots for as long as a block of code lives. This crate states those promises as named rules
//! ([`rules::ALL`]: the response rules R1-R14, the connection rules C1-C7, the event rule E1; T1 is in
//! [`rules::taken`]) and judges a [`Trace`], the whole history of a run, against them with [`check`].
//!
//! It is written from the rule text, not from the code that implements it, and in another shape. The machines
//! of `radar_semantics` keep incremental state (kept signals, held ones, bound ones, `until` windows) and decide
//! what to do next from it; this crate keeps nothing, and for each rule reads the finished history back: which
//! runs there were and what began and ended each, which statement delivered what and when it was alive, which
//! signals were read where, and asks whether what happened is what the rule says. It depends on nothing, and
//! shares with the machines only plain values (it has its own copies of them).
//!
//! Two kinds of rules: **safety** rules say what must never happen (a `once` delivering twice, an `until`
//! interrupting another statement's run) and are judged at every point of a trace; **liveness** rules say what
//! must happen in the end (every run exits, a spent statement ends, a lost component is seen) and are judged when
//! the trace is over ([`End::Quiescent`]: nothing is left to happen) or, for a recording cut off at some point,
//! for what is older than a grace at its end ([`End::Cut`]). Rules that oblige a component to act on what it
//! has just read (a response to take an interrupt meant for its run, a manager to deliver a signal it read) are
//! safety rules: once the step that read it is over, it is too late.
//!
//! ```
//! use radar_spec::{check, trace::*, End};
//! let mut t = Trace::new(vec![
//!     Component { name: "/tick".into(), role: Role::Event },
//!     Component { name: "/go".into(), role: Role::Response { policy: Policy::Ignore, causes: true } },
//! ]);
//! let (tick, go) = (Comp(0), Comp(1));
//! let source = Signal { comp: tick, kind: SignalKind::Triggered };
//! let start = Target::Slot(Slot { comp: go, kind: SlotKind::Start });
//! t.push(1, Obs::Armed { stmt: 1, kind: Kind::Once, source, target: start, until: None, since: 1, accepts: Accepts::All });
//! for (at, sig) in [(2, 10), (3, 11)] {
//!     t.push(at, Obs::Emitted { inst: 0, sig, signal: source, stamp: at, cause: None, payload: Payload::default() });
//!     t.push(at, Obs::ManagerRead { sig, now: at });
//!     // a manager that forgets that a `once` is spent
//!     t.push(at, Obs::Sent { stmt: 1, sig, to: start, stamp: at, by: Some(Cause { stmt: 1, delivery: 1 }) });
//! }
//! let report = check(&t, End::Open);
//! assert!(report.violations.iter().any(|v| v.rule.name == "once-at-most-one"));
//! ```

#![warn(missing_docs)]
#![forbid(unsafe_code)]

pub mod rules;
pub mod trace;
mod view;

pub use rules::{Rule, Sight, Violation};
pub use trace::{End, Trace};

/// What a check found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    /// Every rule broken, in the order of the records where it shows.
    pub violations: Vec<Violation>,
    /// How many signals were emitted.
    pub signals: usize,
    /// How many statements were armed.
    pub statements: usize,
    /// The rules not judged: what the trace saw cannot show them ([`Sight::Wire`]).
    pub unjudged: Vec<&'static Rule>,
}

impl Report {
    /// Whether no rule was broken.
    pub fn ok(&self) -> bool {
        self.violations.is_empty()
    }
}

/// Judges `trace`, which ends as `end` says, against every rule.
pub fn check(trace: &Trace, end: End) -> Report {
    check_records(&trace.components, &trace.records, end)
}

/// [`check`] for a trace held in two parts (a model keeps its components once and its records per state).
pub fn check_records(
    components: &[trace::Component],
    records: &[trace::Record],
    end: End,
) -> Report {
    check_seen(components, records, end, Sight::Inside)
}

/// [`check`] for a trace that saw what `sight` says: a recording's ([`Sight::Wire`]) is judged by the rules it
/// can show alone, and the report names the others.
pub fn check_seen(
    components: &[trace::Component],
    records: &[trace::Record],
    end: End,
    sight: Sight,
) -> Report {
    let view = view::View::of(view::TraceRef {
        components,
        records,
    });
    let mut found = rules::Found {
        view: &view,
        end,
        sight,
        out: Vec::new(),
    };
    rules::check_all(&mut found);
    let mut violations = found.out;
    let judged = |r: &Rule| sight == Sight::Inside || r.wire;
    violations.retain(|v| judged(v.rule));
    violations.sort_by_key(|v| v.index);
    Report {
        violations,
        signals: view.emitted.len(),
        statements: view.stmts.len(),
        unjudged: rules::ALL.iter().copied().filter(|r| !judged(r)).collect(),
    }
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.violations.is_empty() {
            return write!(
                f,
                "no violation in {} signals, {} statements",
                self.signals, self.statements
            );
        }
        writeln!(
            f,
            "{} violations in {} signals, {} statements:",
            self.violations.len(),
            self.signals,
            self.statements
        )?;
        for v in &self.violations {
            writeln!(f, "  {v}")?;
        }
        Ok(())
    }
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {} at {} (record {}): {}",
            self.rule.id, self.rule.name, self.at, self.index, self.why
        )?;
        if !self.sigs.is_empty() {
            write!(f, " [signals {:?}]", self.sigs)?;
        }
        Ok(())
    }
}
