//! The feed: what `radar view` reads from the ROS graph, put into the hub as [`Seen`]. Components as discovery
//! finds them (and loses them), each one's state topic, its signals (an event's `triggered` only observed, so
//! that viewing makes no event check), and every program's and manager's connection list.

use std::{collections::BTreeMap, time::Duration};

use radar_ros::{
    graph::Component,
    msg::{ConnectionList, EventState, ResponseState},
    Radar,
};
use serde_json::{json, Value};
use tokio::{sync::mpsc::UnboundedSender, task::JoinHandle};

use super::model::Seen;
use crate::{
    codec,
    common::{epoch_ns, Fallible},
    components::{forward, forward_signals, slot_topics},
    seen::{self, Seen as Traced},
};

/// How often the graph is looked at again for components and managers that came or went.
const RESCAN: Duration = Duration::from_millis(250);

/// What is followed: a component's or a manager's tasks, aborted when it leaves or the feed ends.
struct Tasks(Vec<JoinHandle<()>>);

impl Drop for Tasks {
    fn drop(&mut self) {
        for t in &self.0 {
            t.abort();
        }
    }
}

/// Follows the graph until `tx` closes.
pub(crate) async fn run(radar: Radar, tx: UnboundedSender<Seen>) {
    let mut components: BTreeMap<String, Tasks> = BTreeMap::new();
    let mut managers: BTreeMap<String, Tasks> = BTreeMap::new();
    let mut rescan = tokio::time::interval(RESCAN);
    rescan.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut listed_at = None;
    while !tx.is_closed() {
        rescan.tick().await;
        // listed again only when discovery reported something since
        let generation = radar.introspect().generation();
        if listed_at == Some(generation) {
            continue;
        }
        listed_at = Some(generation);
        let now = radar.components();
        let names: std::collections::BTreeSet<String> =
            now.iter().map(|c| c.name().fully_qualified()).collect();
        components.retain(|name, _| {
            let stays = names.contains(name);
            if !stays {
                let _ = tx.send(Seen::Gone { name: name.clone() });
            }
            stays
        });
        for c in now {
            let name = c.name().fully_qualified();
            if components.contains_key(&name) {
                continue;
            }
            match follow(&radar, &c, &name, &tx) {
                Ok(tasks) => {
                    components.insert(name, tasks);
                }
                Err(e) => tracing::warn!("radar view: cannot follow {name}: {e}"),
            }
        }
        let topics = radar.introspect().connection_topics();
        managers.retain(|topic, _| {
            let stays = topics.contains(topic);
            if !stays {
                let _ = tx.send(Seen::ManagerGone {
                    manager: manager_of(topic),
                });
            }
            stays
        });
        for topic in topics {
            if managers.contains_key(&topic) {
                continue;
            }
            match follow_connections(&radar, &topic, &tx) {
                Ok(tasks) => {
                    managers.insert(topic, tasks);
                }
                Err(e) => tracing::warn!("radar view: cannot follow {topic}: {e}"),
            }
        }
    }
}

/// `/robot/planner/connections` -> `/robot/planner`.
fn manager_of(topic: &str) -> String {
    topic
        .strip_suffix("/connections")
        .unwrap_or(topic)
        .to_owned()
}

/// A component's topics as the page shows them: `{slot or signal: {topic, type}}`.
fn topics_of(c: &Component) -> Value {
    let mut m = serde_json::Map::new();
    let mut put = |label: &str, topic: &str, ros_type: &str| {
        m.insert(label.into(), json!({ "topic": topic, "type": ros_type }));
    };
    match c {
        Component::Response(r) => {
            for (label, s) in [
                ("start", r.start_slot()),
                ("interrupt", r.interrupt_slot()),
                ("exit", r.exit_slot()),
            ] {
                put(label, s.topic(), s.ros_type());
            }
            for (label, s) in [
                ("started", r.started()),
                ("interrupted", r.interrupted()),
                ("exited", r.exited()),
            ] {
                put(label, s.topic(), s.ros_type());
            }
        }
        Component::Event(e) => put("triggered", e.triggered().topic(), e.triggered().ros_type()),
    }
    Value::Object(m)
}

/// Tells the hub about `c`, then follows its state and its signals.
fn follow(radar: &Radar, c: &Component, name: &str, tx: &UnboundedSender<Seen>) -> Fallible<Tasks> {
    let kind = match c {
        Component::Event(_) => "event",
        Component::Response(_) => "response",
    };
    let _ = tx.send(Seen::Component {
        name: name.to_owned(),
        kind,
        topics: topics_of(c),
    });
    let mut tasks = vec![follow_state(radar, c, name, tx)?];
    let component = name.to_owned();
    tasks.extend(forward_signals(radar, c, false, tx, move |s| {
        Seen::Signal {
            component: component.clone(),
            signal: s.label,
            payload: codec::decode(s.ros_type, &s.body),
            stamp: s.stamp,
            trace: Some(traced(&s)),
        }
    })?);
    // the slots and `dropped`, for the rules only
    tasks.extend(forward(radar, slot_topics(c), false, tx, |s| {
        Seen::Trace(traced(&s))
    })?);
    Ok(Tasks(tasks))
}

/// What the rules are judged on of a sample.
fn traced(s: &crate::components::SignalSample<'_>) -> Traced {
    Traced::Signal {
        topic: s.topic.to_owned(),
        stamp: s.stamp,
        log: epoch_ns() as i64,
        cause: seen::cause(s.cause),
        writer: seen::hex(&s.writer),
        len: s.body.len(),
    }
}

/// A time field of a message as JSON, in ns.
fn ns(v: &Value) -> i64 {
    v["sec"].as_i64().unwrap_or(0) * 1_000_000_000 + v["nanosec"].as_i64().unwrap_or(0)
}

/// What the rules are judged on of a state (as JSON).
fn traced_state(kind: &str, s: &Value) -> Traced {
    let text = |k: &str| s[k].as_str().unwrap_or_default().to_owned();
    match kind {
        "response" => Traced::ResponseState {
            name: text("name"),
            stamp: ns(&s["stamp"]),
            log: epoch_ns() as i64,
            state: text("state_label"),
            last_exit_reason: text("last_exit_reason"),
            policy: text("start_policy"),
            restarts: s["restarts"].as_u64().unwrap_or(0),
        },
        _ => Traced::EventState {
            name: text("name"),
            stamp: ns(&s["stamp"]),
            log: epoch_ns() as i64,
            active: s["active"].as_bool().unwrap_or(false),
            listeners: s["listeners"].as_u64().unwrap_or(0) as u32,
        },
    }
}

/// The task that forwards each sample of `c`'s state topic.
fn follow_state(
    radar: &Radar,
    c: &Component,
    name: &str,
    tx: &UnboundedSender<Seen>,
) -> Fallible<JoinHandle<()>> {
    let topic = c.name().topic("state");
    let name = name.to_owned();
    let kind = match c {
        Component::Response(_) => "response",
        Component::Event(_) => "event",
    };
    let seen = move |state: Value| Seen::State {
        name: name.clone(),
        trace: Some(traced_state(kind, &state)),
        state,
    };
    match c {
        Component::Response(_) => forward_state::<ResponseState>(radar, &topic, tx, seen),
        Component::Event(_) => forward_state::<EventState>(radar, &topic, tx, seen),
    }
}

/// The task that forwards each connection list published on `topic`.
fn follow_connections(radar: &Radar, topic: &str, tx: &UnboundedSender<Seen>) -> Fallible<Tasks> {
    let manager = manager_of(topic);
    let task = forward_state::<ConnectionList>(radar, topic, tx, move |list| {
        let connections = serde_json::from_value::<ConnectionList>(list.clone())
            .map(|l| l.connections.iter().map(seen::SeenConnection::of).collect())
            .unwrap_or_default();
        Seen::Connections {
            manager: manager.clone(),
            trace: Some(Traced::Connections {
                manager: manager.clone(),
                stamp: ns(&list["stamp"]),
                log: epoch_ns() as i64,
                connections,
            }),
            list: list["connections"].clone(),
        }
    })?;
    Ok(Tasks(vec![task]))
}

/// Subscribes to the transient-local `topic` and sends each sample, as JSON made into a [`Seen`] by `make`,
/// until `tx` closes.
fn forward_state<M: radar_ros::msg::RosMessage + serde::Serialize>(
    radar: &Radar,
    topic: &str,
    tx: &UnboundedSender<Seen>,
    make: impl Fn(Value) -> Seen + Send + 'static,
) -> Fallible<JoinHandle<()>> {
    let sub = radar
        .state_subscription::<M>(topic)
        .map_err(|e| e.to_string())?;
    let tx = tx.clone();
    Ok(tokio::spawn(async move {
        while let Ok(m) = sub.recv().await {
            let value = serde_json::to_value(&m).unwrap_or(Value::Null);
            if tx.send(make(value)).is_err() {
                break;
            }
        }
    }))
}
