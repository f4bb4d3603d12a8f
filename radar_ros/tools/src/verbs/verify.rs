//! `radar verify RUN.mcap`: RADAR's rules (`radar_spec`) as a monitor of a recorded run. Reads what `radar
//! record` saw (its `/radar/trace` channel), makes it a trace and names every rule the run broke, with the
//! time, the components and the signals involved; or says "no violation in N signals, M statements".
//!
//! A recording sees the topics: every signal with its stamp, its cause and its writer, the slot signals that
//! crossed processes, the states and the connection lists. It does not see what a component read and when,
//! nor which slot ran when, nor deliveries inside one process (they take no topic): the rules that need those
//! are listed as not judged. A run's slots are read back from its signals and states: `started` begins it,
//! `interrupted` ends its start behaviour through the interrupt slot, otherwise the state's exit reason says
//! how it ended, and `exited` ends it.

use std::collections::{BTreeMap, HashMap};

use radar_ros::graph::Endpoint;
use radar_spec::{
    trace::{
        Accepts, Cause, Comp, Component, ExitAction, ExitReason, Kind, Obs, Payload, Policy, Role,
        Signal, SignalKind, Slot, SlotKind, StartEnd, Target, Time, Trace,
    },
    End, Sight,
};

use crate::{
    common::{Fallible, Out},
    seen::{self, Seen},
};

/// Reads a recording's `/radar/trace` (or a file of its lines, `.jsonl`, as `--trace` prints them), in the
/// order its samples were sent.
pub(crate) fn read(path: &std::path::Path) -> Fallible<Vec<Seen>> {
    let bytes =
        std::fs::read(path).map_err(|e| crate::Error::io(format!("read {}", path.display()), e))?;
    if path.extension().is_some_and(|e| e == "jsonl") {
        let mut out = String::from_utf8_lossy(&bytes)
            .lines()
            .filter(|l| !l.trim().is_empty())
            .enumerate()
            .map(|(i, l)| {
                serde_json::from_str::<Seen>(l).map_err(|e| {
                    crate::Error::other(
                        format!(
                            "{} line {}: not a line of a recording's trace",
                            path.display(),
                            i + 1
                        ),
                        e,
                    )
                })
            })
            .collect::<Fallible<Vec<Seen>>>()?;
        out.sort_by_key(|s| (s.stamp(), s.log()));
        return Ok(out);
    }
    let stream = mcap::MessageStream::new(&bytes)
        .map_err(|e| crate::Error::other(format!("{} is not an MCAP file", path.display()), e))?;
    let mut out = Vec::new();
    for m in stream {
        let m = m.map_err(|e| {
            let what = match out.is_empty() {
                true => "is not an MCAP file, or one cut off before its first message",
                false => "is damaged or cut off (a recording cut off is read up to there)",
            };
            crate::Error::other(format!("{} {what}", path.display()), e)
        });
        let m = match m {
            Ok(m) => m,
            Err(e) if !out.is_empty() => {
                eprintln!("radar verify: {}", e.report());
                break;
            }
            Err(e) => return Err(e),
        };
        if m.channel.topic != seen::CHANNEL {
            continue;
        }
        let s: Seen = serde_json::from_slice(&m.data).map_err(|e| {
            crate::Error::other(
                format!(
                    "{}: a {} message that is not what radar record writes",
                    path.display(),
                    seen::CHANNEL
                ),
                e,
            )
        })?;
        out.push(s);
    }
    if out.is_empty() {
        return Err(format!(
            "{} has nothing on {}: record it with `radar record` (of this version)",
            path.display(),
            seen::CHANNEL
        )
        .into());
    }
    out.sort_by_key(|s| (s.stamp(), s.log()));
    Ok(out)
}

/// The trace a recording makes.
#[derive(Default)]
struct Making {
    trace: Trace,
    comps: HashMap<String, Comp>,
    /// Per component, its instances by the participant that writes for it.
    instances: HashMap<Comp, Vec<String>>,
    stmts: HashMap<String, u64>,
    next_sig: u64,
    next_run: u64,
    /// Per response instance: its current run, whether it was interrupted, the last exit reason its state said.
    runs: HashMap<(Comp, u32), (u64, bool)>,
    exit_reason: HashMap<Comp, String>,
    /// Emissions by (signal, stamp), for the slot signals that deliver them.
    emissions: HashMap<(Signal, Time), u64>,
    /// Per manager, the statements its last list held.
    listed: HashMap<String, BTreeMap<u64, String>>,
    /// The statements made: their sources and targets.
    made: HashMap<u64, (Signal, Target)>,
    /// Per event: checking as its state last said.
    checking: HashMap<Comp, bool>,
}

impl Making {
    fn comp(&mut self, name: &str, role: Role) -> Comp {
        if let Some(c) = self.comps.get(name) {
            if let (Role::Response { policy, .. }, Some(r)) =
                (&role, self.trace.components.get_mut(usize::from(c.0)))
            {
                if let Role::Response { policy: p, .. } = &mut r.role {
                    *p = *policy;
                }
            }
            return *c;
        }
        let c = Comp(self.trace.components.len() as u16);
        self.trace.components.push(Component {
            name: name.to_owned(),
            role,
        });
        self.comps.insert(name.to_owned(), c);
        c
    }

    fn response(&mut self, name: &str) -> Comp {
        match self.comps.get(name) {
            Some(c) => *c,
            None => self.comp(
                name,
                Role::Response {
                    policy: Policy::Ignore,
                    causes: true,
                },
            ),
        }
    }

    /// The instance of `c` whose participant wrote `writer`.
    fn instance(&mut self, c: Comp, writer: &str) -> u32 {
        let participant = writer.get(..24).unwrap_or(writer).to_owned();
        let list = self.instances.entry(c).or_default();
        match list.iter().position(|p| *p == participant) {
            Some(i) => i as u32,
            None => {
                list.push(participant);
                (list.len() - 1) as u32
            }
        }
    }

    fn stmt(&mut self, id: &str) -> u64 {
        let n = self.stmts.len() as u64 + 1;
        *self.stmts.entry(id.to_owned()).or_insert(n)
    }

    fn cause(&mut self, c: &Option<(String, u64)>) -> Option<Cause> {
        c.as_ref().map(|(s, d)| Cause {
            stmt: self.stmt(s),
            delivery: *d,
        })
    }

    fn at(&mut self, at: Time, obs: Obs) {
        self.trace.push(at, obs);
    }

    fn also(&mut self, at: Time, obs: Obs) {
        self.trace.push_to_step(at, obs);
    }

    /// A signal of `topic`'s component as a trace has it.
    fn signal_of(&mut self, topic: &str) -> Option<(Signal, Option<SlotKind>)> {
        let (name, e) = Endpoint::of_topic(topic)?;
        let (role, kind, slot) = match e {
            Endpoint::Triggered => (Some(Role::Event), SignalKind::Triggered, None),
            Endpoint::Started => (None, SignalKind::Started, None),
            Endpoint::Interrupted => (None, SignalKind::Interrupted, None),
            Endpoint::Exited => (None, SignalKind::Exited, None),
            Endpoint::Dropped => (None, SignalKind::Dropped, None),
            Endpoint::Start => (None, SignalKind::Started, Some(SlotKind::Start)),
            Endpoint::Interrupt => (None, SignalKind::Started, Some(SlotKind::Interrupt)),
            Endpoint::Exit => (None, SignalKind::Started, Some(SlotKind::Exit)),
            _ => return None,
        };
        let comp = match role {
            Some(r) => self.comp(name, r),
            None => self.response(name),
        };
        Some((Signal { comp, kind }, slot))
    }

    fn add(&mut self, s: &Seen) {
        match s {
            Seen::Signal {
                topic,
                stamp,
                cause,
                writer,
                ..
            } => {
                let Some((signal, slot)) = self.signal_of(topic) else {
                    return;
                };
                let cause = self.cause(cause);
                match slot {
                    Some(slot) => self.slot_signal(signal.comp, slot, *stamp, cause),
                    None => {
                        let inst = self.instance(signal.comp, writer);
                        self.emitted(signal, inst, *stamp, cause)
                    }
                }
            }
            Seen::ResponseState {
                name,
                last_exit_reason,
                policy,
                ..
            } => {
                let policy = match policy.as_str() {
                    "restart" => Policy::Restart,
                    "queue_one" => Policy::QueueOne,
                    _ => Policy::Ignore,
                };
                let c = self.comp(
                    name,
                    Role::Response {
                        policy,
                        causes: true,
                    },
                );
                self.exit_reason.insert(c, last_exit_reason.clone());
            }
            Seen::EventState {
                name,
                stamp,
                active,
                listeners,
                ..
            } => {
                let c = self.comp(name, Role::Event);
                let was = self.checking.insert(c, *active).unwrap_or(false);
                self.at(
                    *stamp,
                    Obs::Listeners {
                        comp: c,
                        inst: 0,
                        n: *listeners,
                    },
                );
                if was != *active {
                    self.also(
                        *stamp,
                        Obs::Checking {
                            comp: c,
                            inst: 0,
                            on: *active,
                        },
                    );
                }
            }
            Seen::Connections {
                manager,
                stamp,
                connections,
                ..
            } => self.list(manager, *stamp, connections),
        }
    }

    fn emitted(&mut self, signal: Signal, inst: u32, stamp: Time, cause: Option<Cause>) {
        self.next_sig += 1;
        let sig = self.next_sig;
        self.emissions.insert((signal, stamp), sig);
        let who = (signal.comp, inst);
        let emit = Obs::Emitted {
            sig,
            inst,
            signal,
            stamp,
            cause,
            payload: Payload::default(),
        };
        let comp = signal.comp;
        match signal.kind {
            SignalKind::Started => {
                self.next_run += 1;
                let run = self.next_run;
                self.runs.insert(who, (run, false));
                self.at(
                    stamp,
                    Obs::RunBegan {
                        comp,
                        inst,
                        run,
                        payload: 0,
                        cause,
                        now: stamp,
                    },
                );
                self.also(stamp, emit);
            }
            SignalKind::Interrupted => {
                let run = self.runs.get(&who).map_or(0, |r| r.0);
                self.runs.insert(who, (run, true));
                self.at(stamp, Obs::Cancelled { comp, inst, run });
                self.also(stamp, emit);
                self.also(stamp, Obs::InterruptBegan { comp, inst, run });
            }
            SignalKind::Exited => self.exited(who, stamp, emit),
            SignalKind::Triggered | SignalKind::Dropped => self.at(stamp, emit),
        }
    }

    /// A run's `exited`: how it ended, as its `interrupted` or its state's exit reason says, then its exit slot.
    fn exited(&mut self, who: (Comp, u32), stamp: Time, emit: Obs) {
        let (comp, inst) = who;
        let (run, interrupted) = self.runs.remove(&who).unwrap_or((0, false));
        let reason = if interrupted {
            self.at(stamp, Obs::InterruptEnded { comp, inst, run });
            ExitReason::Interrupted
        } else {
            let said = self.exit_reason.get(&comp).cloned().unwrap_or_default();
            let (first, reason) = match said.split(':').next().unwrap_or_default() {
                "exit_signal" | "interrupted" => {
                    (Obs::Cancelled { comp, inst, run }, ExitReason::ExitSignal)
                }
                "failed" => (
                    Obs::StartEnded {
                        comp,
                        inst,
                        run,
                        how: StartEnd::Failed,
                    },
                    ExitReason::Failed,
                ),
                "panicked" => (
                    Obs::StartEnded {
                        comp,
                        inst,
                        run,
                        how: StartEnd::Panicked,
                    },
                    ExitReason::Panicked,
                ),
                _ => (
                    Obs::StartEnded {
                        comp,
                        inst,
                        run,
                        how: StartEnd::Returned,
                    },
                    ExitReason::Completed,
                ),
            };
            self.at(stamp, first);
            reason
        };
        self.also(
            stamp,
            Obs::ExitBegan {
                comp,
                inst,
                run,
                reason,
            },
        );
        self.also(
            stamp,
            Obs::ExitEnded {
                comp,
                inst,
                run,
                action: ExitAction::Done,
                now: stamp,
            },
        );
        self.also(stamp, emit);
    }

    /// A slot signal a statement sent (its cause names it): a delivery of that statement.
    fn slot_signal(&mut self, comp: Comp, kind: SlotKind, stamp: Time, by: Option<Cause>) {
        let Some(c) = by else {
            return; // injected, or sent by a statement that carries no cause (an interrupt or exit target)
        };
        let sig = match (kind, self.made.get(&c.stmt)) {
            (SlotKind::Start, Some((source, _))) => self.emissions.get(&(*source, stamp)).copied(),
            _ => None,
        }
        .unwrap_or(0);
        self.at(
            stamp,
            Obs::Sent {
                stmt: c.stmt,
                sig,
                to: Target::Slot(Slot { comp, kind }),
                stamp,
                by: Some(c),
            },
        );
    }

    fn list(&mut self, manager: &str, stamp: Time, connections: &[seen::SeenConnection]) {
        let now: BTreeMap<u64, String> = connections
            .iter()
            .map(|c| (c.id, c.statement.clone()))
            .collect();
        let before = self
            .listed
            .insert(manager.to_owned(), now.clone())
            .unwrap_or_default();
        for c in connections.iter().filter(|c| !before.contains_key(&c.id)) {
            let Some((source, _)) = self.signal_of(&c.source) else {
                continue;
            };
            let target = match self.signal_of(&c.target) {
                Some((s, Some(kind))) => Target::Slot(Slot { comp: s.comp, kind }),
                _ => Target::Call,
            };
            let until = self.signal_of(&c.until).map(|(s, _)| s);
            let stmt = self.stmt(&c.statement);
            self.made.insert(stmt, (source, target));
            self.at(
                stamp,
                Obs::Armed {
                    stmt,
                    kind: if c.kind == "once" {
                        Kind::Once
                    } else {
                        Kind::Whenever
                    },
                    source,
                    target,
                    until,
                    since: c.since,
                    accepts: Accepts::Unknown,
                },
            );
        }
        for statement in before
            .iter()
            .filter(|(id, _)| !now.contains_key(id))
            .map(|(_, s)| s.clone())
        {
            let stmt = self.stmt(&statement);
            self.at(stamp, Obs::Ended { stmt });
        }
    }
}

/// The trace of what a recording saw.
pub(crate) fn trace_of(seen: &[Seen]) -> Trace {
    let mut m = Making::default();
    for s in seen {
        m.add(s);
    }
    m.trace
}

/// `radar verify`: judges the recording at `path`; obligations younger than `grace` at its end are not judged.
/// Fails (the program exits with 1) if a rule was broken.
pub(crate) fn verify(
    path: &std::path::Path,
    grace: f64,
    trace_only: bool,
    out: &Out,
) -> Fallible<()> {
    let seen = read(path)?;
    if trace_only {
        for s in &seen {
            println!("{}", serde_json::to_string(s)?);
        }
        return Ok(());
    }
    let trace = trace_of(&seen);
    let report = radar_spec::check_seen(
        &trace.components,
        &trace.records,
        End::Cut {
            grace: (grace.max(0.0) * 1e9) as Time,
        },
        Sight::Wire,
    );
    match out.json {
        true => print_json(path, &trace, &report),
        false => print_text(&trace, &report),
    }
    if report.ok() {
        Ok(())
    } else {
        Err(format!(
            "{}: {} rules broken",
            path.display(),
            report.violations.len()
        )
        .into())
    }
}

/// A report as one JSON object.
fn print_json(path: &std::path::Path, trace: &Trace, report: &radar_spec::Report) {
    let name = |c: &Comp| trace.name(*c).to_owned();
    let violations: Vec<serde_json::Value> = report
        .violations
        .iter()
        .map(|v| {
            serde_json::json!({
                "rule": v.rule.id, "name": v.rule.name, "at_ns": v.at,
                "components": v.comps.iter().map(name).collect::<Vec<_>>(),
                "statements": v.stmts, "signals": v.sigs, "why": v.why,
            })
        })
        .collect();
    println!(
        "{}",
        serde_json::json!({
            "file": path, "signals": report.signals, "statements": report.statements,
            "violations": violations,
            "not_judged": report.unjudged.iter().map(|r| format!("{} {}", r.id, r.name)).collect::<Vec<_>>(),
        })
    );
}

/// A report as lines: each violation, the count, the rules a recording cannot show.
fn print_text(trace: &Trace, report: &radar_spec::Report) {
    let name = |c: &Comp| trace.name(*c).to_owned();
    for v in &report.violations {
        let comps: Vec<String> = v.comps.iter().map(name).collect();
        println!(
            "{} {} broken at {:.3} s ({}): {} [signals {:?}]",
            v.rule.id,
            v.rule.name,
            v.at as f64 / 1e9,
            comps.join(", "),
            v.why,
            v.sigs
        );
    }
    if report.ok() {
        println!("{report}");
    } else {
        println!(
            "{} violations in {} signals, {} statements",
            report.violations.len(),
            report.signals,
            report.statements
        );
    }
    let unjudged: Vec<String> = report
        .unjudged
        .iter()
        .map(|r| format!("{} {}", r.id, r.name))
        .collect();
    println!(
        "not judged from a recording (they need what happens inside a process): {}",
        unjudged.join(", ")
    );
}
