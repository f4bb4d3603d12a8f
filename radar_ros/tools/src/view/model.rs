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
    /// A component's state (its `state` topic's newest sample, as JSON).
    State { name: String, state: Value },
    /// A signal: which component, which signal, its payload decoded, when it was sent (ns since the epoch).
    Signal {
        component: String,
        signal: &'static str,
        payload: Value,
        stamp: i64,
    },
    /// A manager's (or program's) connection list, whole.
    Connections { manager: String, list: Value },
    /// A manager left the graph.
    ManagerGone { manager: String },
}

/// How much the model keeps and sends.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    /// Timeline lines a snapshot holds (the newest).
    pub(crate) kept_lines: usize,
    /// Timeline lines a changes message holds at most.
    pub(crate) lines_per_message: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            kept_lines: 500,
            lines_per_message: 200,
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
}

impl Pending {
    fn is_empty(&self) -> bool {
        self.components.is_empty()
            && self.gone.is_empty()
            && self.managers.is_empty()
            && self.managers_gone.is_empty()
            && self.lines.is_empty()
            && self.dropped == 0
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
            Seen::State { name, state } => {
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
            } => self.line(json!({
                "component": component, "signal": signal, "payload": payload, "t": stamp,
            })),
            Seen::Connections { manager, list } => {
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
        })
    }

    /// What changed since the last call, as the next changes message; `None` when nothing did.
    pub(crate) fn changes(&mut self) -> Option<Value> {
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
        }
    }

    fn signal(name: &str, k: i64) -> Seen {
        Seen::Signal {
            component: name.into(),
            signal: "started",
            payload: json!({ "data": k }),
            stamp: k,
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

    #[test]
    fn a_flood_of_signals_is_cut_at_the_bound_and_counted_and_the_lines_stay_numbered() {
        let limits = Limits {
            kept_lines: 50,
            lines_per_message: 10,
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
