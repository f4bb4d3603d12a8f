//! What `radar view` knows of the system, and what it tells the pages: a snapshot when a page connects, then
//! changes, at most `rate` messages a second however fast the system moves. Plain data, no I/O: the feed
//! (`feed.rs`) puts in what DDS brought, the hub (`hub.rs`) takes out the messages.
//!
//! The protocol, one JSON object per WebSocket text message:
//! - `{"type":"snapshot","seq":S,"components":[..],"managers":{..},"timeline":[..],"dropped":D,..}` first;
//! - then `{"type":"changes","seq":S+1,..}`, `S+2`, ...: the components whose state changed (their whole
//!   state, the newest only), the names of those gone, the connection lists of the managers that changed (each
//!   whole), the managers gone, and the timeline lines since the last message. A changes message carries at
//!   most [`Limits::lines_per_message`] lines; the rest are counted in `dropped` (never sent later, so that a
//!   flood cannot delay what comes after it).
//!
//! Both carry `violations`: the rules of RADAR (`radar_spec`, judged as `radar verify` judges a recording) that
//! what the view saw breaks, each once, as `{"rule","name","why","at","components"}` (a snapshot: all of them;
//! a changes message: the new ones).
//!
//! Every timeline line has a number `n`, one more than the line before it (dropped ones too): a page keeps the
//! lines with an `n` above the highest it has, because a snapshot may hold lines that the next changes message
//! sends again.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use serde_json::{json, Value};

/// What the feed saw on the graph.
#[derive(Clone, Debug)]
pub(crate) enum Seen {
    /// A component appeared: its fully qualified name, `event` or `response`, and its topics.
    Component {
        name: String,
        kind: &'static str,
        topics: Value,
    },
    /// A component left the graph.
    Gone { name: String },
    /// A component's state (its `state` topic's newest sample, as JSON), and what the rules keep of it.
    State {
        name: String,
        state: Value,
        trace: Option<crate::seen::Seen>,
    },
    /// A signal: which component, which signal, its payload decoded, when it was sent (ns since the epoch).
    Signal {
        component: String,
        signal: &'static str,
        payload: Value,
        stamp: i64,
        trace: Option<crate::seen::Seen>,
    },
    /// A manager's (or program's) connection list, whole, and what the rules keep of it.
    Connections {
        manager: String,
        list: Value,
        trace: Option<crate::seen::Seen>,
    },
    /// A manager left the graph.
    ManagerGone { manager: String },
    /// What `radar record` would keep of a sample (causes, writers): what the rules are judged on.
    Trace(crate::seen::Seen),
}

/// How long a sample waits before the rules judge it (ns; those read on other topics stamped before it come
/// first).
const SETTLE: i64 = 1_000_000_000;

/// How much the model keeps and sends.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    /// Timeline lines a snapshot holds (the newest).
    pub(crate) kept_lines: usize,
    /// Timeline lines a changes message holds at most.
    pub(crate) lines_per_message: usize,
    /// How many of the latest samples the rules are judged on (with the newest connection list of each manager
    /// from before them).
    pub(crate) judged: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            kept_lines: 500,
            lines_per_message: 200,
            judged: 3_000,
        }
    }
}

/// One component as the page shows it.
#[derive(Clone, Debug)]
struct Shown {
    kind: &'static str,
    topics: Value,
    state: Value,
}

impl Shown {
    fn json(&self, name: &str) -> Value {
        json!({ "name": name, "kind": self.kind, "topics": self.topics, "state": self.state })
    }
}

/// The model: components, connection lists, the timeline, and what changed since the last message.
pub(crate) struct Model {
    limits: Limits,
    components: BTreeMap<String, Shown>,
    managers: BTreeMap<String, Value>,
    timeline: VecDeque<Value>,
    /// The number of the next timeline line.
    next_line: u64,
    /// The last message's sequence number (the snapshot carries it too).
    seq: u64,
    /// Lines left out of changes messages so far (over the per-message bound).
    dropped: u64,
    pending: Pending,
    /// The latest samples, for the rules.
    trace: VecDeque<crate::seen::Seen>,
    /// How many of them (the oldest) the rules looked at last.
    ready: usize,
    /// A sample came in among those.
    redo: bool,
    /// The violations seen so far, each once.
    violations: Vec<Value>,
    told: BTreeSet<String>,
    /// The newest state of each component and list of each manager that left the window.
    before: BTreeMap<String, crate::seen::Seen>,
    /// Whether samples left the window (the rules count from the first they see).
    cut: bool,
}

/// What changed since the last changes message.
#[derive(Default)]
struct Pending {
    components: BTreeSet<String>,
    gone: BTreeSet<String>,
    managers: BTreeSet<String>,
    managers_gone: BTreeSet<String>,
    lines: Vec<Value>,
    dropped: u64,
    violations: Vec<Value>,
}

impl Pending {
    fn is_empty(&self) -> bool {
        self.components.is_empty()
            && self.gone.is_empty()
            && self.managers.is_empty()
            && self.managers_gone.is_empty()
            && self.lines.is_empty()
            && self.dropped == 0
            && self.violations.is_empty()
    }
}

impl Model {
    pub(crate) fn new(limits: Limits) -> Model {
        Model {
            limits,
            components: BTreeMap::new(),
            managers: BTreeMap::new(),
            timeline: VecDeque::new(),
            next_line: 1,
            seq: 0,
            dropped: 0,
            pending: Pending::default(),
            trace: VecDeque::new(),
            ready: 0,
            redo: false,
            violations: Vec::new(),
            told: BTreeSet::new(),
            before: BTreeMap::new(),
            cut: false,
        }
    }

    /// Judges the latest samples by RADAR's rules, if what it judges changed; new violations go with the next
    /// changes. (The safety rules only: the system is not over.) Samples come on many topics, each in its own
    /// order: those stamped in the last [`SETTLE`] are left for a later look, so that one stamped earlier but
    /// read later (an `exited` read before its `started`) is judged in its place.
    fn judge(&mut self, now: i64) {
        let ready = self.trace.partition_point(|s| s.stamp() <= now - SETTLE);
        if ready == self.ready && !self.redo {
            return;
        }
        self.ready = ready;
        self.redo = false;
        let mut seen: Vec<crate::seen::Seen> = self.before.values().cloned().collect();
        seen.sort_by_key(|s| (s.stamp(), s.log()));
        seen.extend(self.trace.range(..ready).cloned());
        let trace = crate::verbs::verify::trace_of(&seen);
        let report = radar_spec::check_seen(
            &trace.components,
            &trace.records,
            radar_spec::End::Open,
            if self.cut {
                radar_spec::Sight::WireSince
            } else {
                radar_spec::Sight::Wire
            },
        );
        for v in report.violations {
            let key = format!("{} {}", v.rule.name, v.why);
            if !self.told.insert(key) {
                continue;
            }
            let line = json!({
                "rule": v.rule.id, "name": v.rule.name, "why": v.why, "at": v.at,
                "components": v.comps.iter().map(|c| trace.name(*c).to_owned()).collect::<Vec<_>>(),
            });
            self.violations.push(line.clone());
            self.pending.violations.push(line);
        }
    }

    /// Takes in what the feed saw.
    pub(crate) fn apply(&mut self, seen: Seen) {
        match seen {
            Seen::Component { name, kind, topics } => {
                let shown = self.components.entry(name.clone()).or_insert(Shown {
                    kind,
                    topics: Value::Null,
                    state: Value::Null,
                });
                shown.kind = kind;
                shown.topics = topics;
                self.pending.gone.remove(&name);
                self.pending.components.insert(name);
            }
            Seen::Gone { name } => {
                if self.components.remove(&name).is_some() {
                    self.pending.components.remove(&name);
                    self.pending.gone.insert(name);
                }
            }
            Seen::State { name, state, trace } => {
                self.traced(trace);
                // a state may come before discovery says what the component is: it waits for that
                if let Some(shown) = self.components.get_mut(&name) {
                    if shown.state != state {
                        shown.state = state;
                        self.pending.components.insert(name);
                    }
                }
            }
            Seen::Signal {
                component,
                signal,
                payload,
                stamp,
                trace,
            } => {
                self.traced(trace);
                self.line(json!({
                    "component": component, "signal": signal, "payload": payload, "t": stamp,
                }))
            }
            Seen::Connections {
                manager,
                list,
                trace,
            } => {
                self.traced(trace);
                if self.managers.get(&manager) != Some(&list) {
                    self.managers.insert(manager.clone(), list);
                    self.pending.managers_gone.remove(&manager);
                    self.pending.managers.insert(manager);
                }
            }
            Seen::ManagerGone { manager } => {
                if self.managers.remove(&manager).is_some() {
                    self.pending.managers.remove(&manager);
                    self.pending.managers_gone.insert(manager);
                }
            }
            Seen::Trace(s) => self.traced(Some(s)),
        }
    }

    /// Keeps a sample for the rules, in the order of the stamps.
    fn traced(&mut self, s: Option<crate::seen::Seen>) {
        let Some(s) = s else {
            return;
        };
        let key = (s.stamp(), s.log());
        let at = self.trace.partition_point(|t| (t.stamp(), t.log()) <= key);
        self.redo |= at < self.ready;
        self.trace.insert(at, s);
        while self.trace.len() > self.limits.judged {
            self.cut = true;
            self.ready = self.ready.saturating_sub(1);
            // what a state or a list says holds until the next one: the newest from before the window is
            // judged with it (a run, a listener or a connection it began is not cut off)
            let key = match self.trace.front() {
                Some(
                    crate::seen::Seen::ResponseState { name, .. }
                    | crate::seen::Seen::EventState { name, .. },
                ) => Some(format!("s{name}")),
                Some(crate::seen::Seen::Connections { manager, .. }) => Some(format!("m{manager}")),
                _ => None,
            };
            if let (Some(key), Some(s)) = (key, self.trace.pop_front()) {
                self.before.insert(key, s);
            }
        }
    }

    /// A timeline line, numbered; kept for snapshots, and sent with the next changes unless over the bound.
    fn line(&mut self, mut line: Value) {
        line["n"] = json!(self.next_line);
        self.next_line += 1;
        if self.pending.lines.len() < self.limits.lines_per_message {
            self.pending.lines.push(line.clone());
        } else {
            self.pending.dropped += 1;
        }
        self.timeline.push_back(line);
        while self.timeline.len() > self.limits.kept_lines {
            self.timeline.pop_front();
        }
    }

    /// Everything, for a page that just connected; the changes that follow carry `seq` + 1 on.
    pub(crate) fn snapshot(&self) -> Value {
        json!({
            "type": "snapshot",
            "seq": self.seq,
            "components": self.components.iter().map(|(n, s)| s.json(n)).collect::<Vec<_>>(),
            "managers": self.managers,
            "timeline": self.timeline,
            "dropped": self.dropped,
            "violations": self.violations,
        })
    }

    /// What changed since the last call, as the next changes message; `None` when nothing did.
    pub(crate) fn changes(&mut self) -> Option<Value> {
        self.changes_at(crate::common::epoch_ns() as i64)
    }

    /// [`Model::changes`] at `now` (ns since the epoch).
    pub(crate) fn changes_at(&mut self, now: i64) -> Option<Value> {
        self.judge(now);
        if self.pending.is_empty() {
            return None;
        }
        let p = std::mem::take(&mut self.pending);
        self.seq += 1;
        self.dropped += p.dropped;
        Some(json!({
            "type": "changes",
            "seq": self.seq,
            "components": p.components.iter()
                .filter_map(|n| self.components.get(n).map(|s| s.json(n)))
                .collect::<Vec<_>>(),
            "gone": p.gone,
            "managers": p.managers.iter()
                .filter_map(|m| self.managers.get(m).map(|l| (m.clone(), l.clone())))
                .collect::<serde_json::Map<_, _>>(),
            "managers_gone": p.managers_gone,
            "timeline": p.lines,
            "dropped": p.dropped,
            "violations": p.violations,
        }))
    }

    /// How many components the model knows.
    #[cfg(test)]
    pub(crate) fn component_count(&self) -> usize {
        self.components.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn component(name: &str) -> Seen {
        Seen::Component {
            name: name.into(),
            kind: "response",
            topics: json!({}),
        }
    }

    fn state(name: &str, label: &str) -> Seen {
        Seen::State {
            name: name.into(),
            state: json!({ "state_label": label }),
            trace: None,
        }
    }

    fn traced(s: crate::seen::Seen) -> Seen {
        Seen::Trace(s)
    }

    /// A once whose start is sent twice (its causes say deliveries 1 and 2): C2 once-at-most-one, told once.
    #[test]
    fn a_rule_the_system_breaks_is_marked_once_and_in_the_snapshot() {
        use crate::seen::{Seen as S, SeenConnection};
        let mut m = Model::new(Limits::default());
        let statement = "00000000000000010000000000000001".to_owned();
        m.apply(traced(S::Connections {
            manager: "/planner".into(),
            stamp: 10,
            log: 10,
            connections: vec![SeenConnection {
                id: 1,
                kind: "once".into(),
                source: "/bumper/triggered".into(),
                target: "/dock/start".into(),
                until: String::new(),
                since: 5,
                statement: statement.clone(),
            }],
        }));
        let start = |n: u64, stamp: i64| {
            traced(S::Signal {
                topic: "/dock/start".into(),
                stamp,
                log: stamp,
                cause: Some((statement.clone(), n)),
                writer: "aa".repeat(16),
                len: 1,
            })
        };
        m.apply(start(1, 20));
        assert_eq!(
            m.changes(),
            None,
            "one start breaks nothing (and samples alone change nothing shown)"
        );
        m.apply(start(2, 30));
        let second = m.changes().expect("changes");
        let v = &second["violations"];
        assert_eq!(v.as_array().map(Vec::len), Some(1), "{second}");
        assert_eq!(v[0]["name"], "once-at-most-one");
        assert_eq!(v[0]["components"], json!(["/bumper"]));
        // the next look tells it no more; a page that connects later sees it in the snapshot
        m.apply(state("/dock", "idle"));
        assert_eq!(m.changes().map(|c| c["violations"].clone()), None);
        assert_eq!(m.snapshot()["violations"][0]["rule"], "C2");
    }

    fn signal(name: &str, k: i64) -> Seen {
        Seen::Signal {
            component: name.into(),
            signal: "started",
            payload: json!({ "data": k }),
            stamp: k,
            trace: None,
        }
    }

    #[test]
    fn a_component_changed_many_times_between_messages_is_sent_once_with_its_newest_state() {
        let mut m = Model::new(Limits::default());
        m.apply(component("/a"));
        m.apply(state("/a", "idle"));
        let first = m.changes().unwrap();
        assert_eq!(first["seq"], 1);
        assert_eq!(first["components"][0]["state"]["state_label"], "idle");
        for label in ["running", "interrupting", "exiting", "idle", "running"] {
            m.apply(state("/a", label));
        }
        let c = m.changes().unwrap();
        assert_eq!(c["seq"], 2);
        assert_eq!(c["components"].as_array().unwrap().len(), 1);
        assert_eq!(c["components"][0]["state"]["state_label"], "running");
        assert!(m.changes().is_none(), "nothing changed since");
        // the same state again is no change
        m.apply(state("/a", "running"));
        assert!(m.changes().is_none());
    }

    /// A whenever that works for many runs, judged on a window of a few samples: the window is cut before
    /// each sample in turn (between a trigger and its start, a start and its started, a started and its exit,
    /// and past the connection list itself), and no cut makes a violation of a run it does not see whole.
    #[test]
    fn a_window_cut_anywhere_in_a_run_that_keeps_the_rules_tells_no_violation() {
        use crate::seen::{Seen as S, SeenConnection};
        let statement = "00000000000000020000000000000007".to_owned();
        let event = "11".repeat(16);
        let response = "22".repeat(16);
        let sig = |topic: &str, stamp: i64, cause: Option<u64>, writer: &str| {
            traced(S::Signal {
                topic: topic.into(),
                stamp,
                log: stamp,
                cause: cause.map(|d| (statement.clone(), d)),
                writer: writer.into(),
                len: 1,
            })
        };
        for judged in [3, 4, 5, 6, 7, 11] {
            let mut m = Model::new(Limits {
                judged,
                ..Limits::default()
            });
            m.apply(traced(S::Connections {
                manager: "/planner".into(),
                stamp: 10,
                log: 10,
                connections: vec![SeenConnection {
                    id: 1,
                    kind: "whenever".into(),
                    source: "/bumper/triggered".into(),
                    target: "/dock/start".into(),
                    until: String::new(),
                    since: 5,
                    statement: statement.clone(),
                }],
            }));
            m.apply(traced(S::EventState {
                name: "/bumper".into(),
                stamp: 11,
                log: 11,
                active: true,
                listeners: 1,
            }));
            let mut told = Vec::new();
            for k in 1..=30u64 {
                let t = 1_000 * k as i64;
                let state = |stamp: i64, label: &str| {
                    traced(S::ResponseState {
                        name: "/dock".into(),
                        stamp,
                        log: stamp,
                        state: label.into(),
                        last_exit_reason: if label == "idle" {
                            "completed".into()
                        } else {
                            String::new()
                        },
                        policy: "ignore".into(),
                        restarts: 0,
                    })
                };
                for s in [
                    sig("/bumper/triggered", t, None, &event),
                    sig("/dock/start", t, Some(k), &event),
                    state(t + 10, "running"),
                    sig("/dock/started", t + 10, Some(k), &response),
                    state(t + 20, "idle"),
                    sig("/dock/exited", t + 20, Some(k), &response),
                ] {
                    m.apply(s);
                    if let Some(c) = m.changes() {
                        told.extend(c["violations"].as_array().cloned().unwrap_or_default());
                    }
                }
            }
            assert_eq!(told, Vec::<Value>::new(), "a window of {judged} samples");
            // and a cut window that holds the start before still sees one sent again with its delivery
            if judged < 7 {
                continue;
            }
            m.apply(sig("/dock/start", 40_000, Some(30), &event));
            let c = m.changes().expect("changes");
            assert_eq!(
                c["violations"][0]["rule"], "C6",
                "a window of {judged} samples: {c}"
            );
        }
    }

    /// An event's trigger read before its state that says it checks, stamped earlier (they come on two
    /// topics): judged a moment later, in the order of their stamps, it breaks nothing; judged as read it would
    /// break E1.
    #[test]
    fn a_signal_read_before_one_stamped_earlier_is_judged_in_its_place() {
        use crate::seen::Seen as S;
        let t: i64 = 1_800_000_000_000_000_000;
        let sig = |topic: &str, stamp: i64| {
            traced(S::Signal {
                topic: topic.into(),
                stamp,
                log: stamp + 5_000_000,
                cause: None,
                writer: "11".repeat(16),
                len: 1,
            })
        };
        let checking = |name: &str, stamp: i64| {
            traced(S::EventState {
                name: name.into(),
                stamp,
                log: stamp + 30_000_000,
                active: true,
                listeners: 1,
            })
        };
        let mut m = Model::new(Limits::default());
        let mut told = Vec::new();
        let look = |m: &mut Model, told: &mut Vec<Value>, now: i64| {
            if let Some(c) = m.changes_at(now) {
                told.extend(c["violations"].as_array().cloned().unwrap_or_default());
            }
        };
        m.apply(sig("/dock/triggered", t + 20_000_000));
        look(&mut m, &mut told, t + 30_000_000);
        m.apply(checking("/dock", t + 10_000_000));
        look(&mut m, &mut told, t + 40_000_000);
        look(&mut m, &mut told, t + 2_000_000_000);
        assert_eq!(told, Vec::<Value>::new());
        // and a trigger of an event that never said it checks (E1) is told, once it settled
        m.apply(sig("/bumper/triggered", t + 3_000_000_000));
        look(&mut m, &mut told, t + 3_100_000_000);
        assert_eq!(told, Vec::<Value>::new(), "not yet judged");
        look(&mut m, &mut told, t + 4_100_000_000);
        assert_eq!(told.len(), 1, "{told:?}");
        assert_eq!(told[0]["rule"], "E1");
    }

    #[test]
    fn a_flood_of_signals_is_cut_at_the_bound_and_counted_and_the_lines_stay_numbered() {
        let limits = Limits {
            kept_lines: 50,
            lines_per_message: 10,
            ..Limits::default()
        };
        let mut m = Model::new(limits);
        m.apply(component("/a"));
        for k in 0..35 {
            m.apply(signal("/a", k));
        }
        let c = m.changes().unwrap();
        let lines = c["timeline"].as_array().unwrap();
        assert_eq!(lines.len(), 10);
        assert_eq!(c["dropped"], 25);
        let ns: Vec<u64> = lines.iter().map(|l| l["n"].as_u64().unwrap()).collect();
        assert_eq!(ns, (1..=10).collect::<Vec<_>>());
        // the snapshot keeps the newest lines, all of them up to kept_lines, and the total dropped
        let s = m.snapshot();
        assert_eq!(s["timeline"].as_array().unwrap().len(), 35);
        assert_eq!(s["timeline"][34]["n"], 35);
        assert_eq!(s["dropped"], 25);
        for k in 0..60 {
            m.apply(signal("/a", k));
        }
        let s = m.snapshot();
        assert_eq!(s["timeline"].as_array().unwrap().len(), 50);
        assert_eq!(s["timeline"][49]["n"], 95);
    }

    #[test]
    fn a_snapshot_then_the_changes_after_it_give_the_model_as_it_is() {
        let mut m = Model::new(Limits::default());
        m.apply(component("/a"));
        m.apply(component("/b"));
        m.apply(state("/a", "idle"));
        m.changes();
        m.apply(state("/a", "running"));
        let snap = m.snapshot();
        assert_eq!(
            snap["seq"], 1,
            "the snapshot carries the last message's number"
        );
        // after the snapshot: /b leaves, a manager appears, /a changes again
        m.apply(Seen::Gone { name: "/b".into() });
        m.apply(Seen::Connections {
            manager: "/p".into(),
            list: json!([{ "id": 1 }]),
            trace: None,
        });
        m.apply(state("/a", "exiting"));
        let c = m.changes().unwrap();
        assert_eq!(c["seq"], 2);
        assert_eq!(c["gone"], json!(["/b"]));
        assert_eq!(c["managers"]["/p"], json!([{ "id": 1 }]));
        assert_eq!(c["components"][0]["state"]["state_label"], "exiting");
        assert_eq!(m.component_count(), 1);
        // a component that comes and goes between two messages is sent as gone only
        m.apply(component("/c"));
        m.apply(Seen::Gone { name: "/c".into() });
        let c = m.changes().unwrap();
        assert_eq!(c["components"], json!([]));
        assert_eq!(c["gone"], json!(["/c"]));
    }

    #[test]
    fn a_state_before_its_component_is_known_changes_nothing() {
        let mut m = Model::new(Limits::default());
        m.apply(state("/x", "idle"));
        assert!(m.changes().is_none());
        assert_eq!(m.snapshot()["components"], json!([]));
    }
}
