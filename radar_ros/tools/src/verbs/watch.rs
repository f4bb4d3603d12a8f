//! `radar watch`: a live timeline of the signals and state changes of components (like rtprint), printed in
//! the order they were sent.

use std::time::Duration;

use radar_ros::{
    graph::Component,
    msg::{EventState, ResponseState},
    Radar,
};
use serde_json::{json, Value};

use crate::{
    codec,
    common::{epoch_ns, stamp_ns, Fallible, Out, Stop},
    components::{forward_signals, Following},
};

/// One line of the timeline.
struct Seen {
    component: String,
    what: String,
    payload: Value,
    /// When it was sent: the source timestamp (signals) or the state's stamp, ns since the epoch (0: unknown).
    stamp: i64,
}

/// How long `watch` holds what arrived, so that signals and states that came on different topics print in the
/// order they were sent.
const REORDER: Duration = Duration::from_millis(60);

pub(crate) async fn watch(
    radar: &Radar,
    out: &Out,
    names: Vec<String>,
    activate: bool,
    duration: Option<f64>,
) -> Fallible<()> {
    let mut stop = Stop::catch()?;
    let mut following = Following::new(radar, &names)?;
    let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<Seen>();
    let mut tasks = Vec::new();
    let end = stop.after(duration);
    tokio::pin!(end);
    let mut rescan = tokio::time::interval(Duration::from_millis(250));
    let mut flush = tokio::time::interval(REORDER / 3);
    let mut held: Vec<(tokio::time::Instant, Seen)> = Vec::new();
    let start_ns = epoch_ns() as i64;
    if !out.json {
        println!(
            "watching {} in ROS_DOMAIN_ID {} (Ctrl-C to stop)",
            if following.wanted.is_empty() {
                "every component".to_owned()
            } else {
                following.wanted.join(", ")
            },
            radar.domain_id()
        );
    }
    loop {
        tokio::select! {
            _ = &mut end => break,
            _ = rescan.tick() => {
                for c in following.new_components(radar) {
                    tasks.extend(follow(radar, &c, activate, tx.clone())?);
                }
            }
            Some(s) = rx.recv() => held.push((tokio::time::Instant::now(), s)),
            _ = flush.tick() => print_held(out, &mut held, start_ns, false),
        }
    }
    print_held(out, &mut held, start_ns, true);
    for t in tasks {
        t.abort();
    }
    Ok(())
}

/// Prints, in the order they were sent, the held lines that arrived at least [`REORDER`] ago (all, at the end);
/// times are relative to when watching began.
fn print_held(out: &Out, held: &mut Vec<(tokio::time::Instant, Seen)>, start_ns: i64, all: bool) {
    let now = tokio::time::Instant::now();
    let (mut due, keep): (Vec<_>, Vec<_>) = held
        .drain(..)
        .partition(|(arrived, _)| all || now.duration_since(*arrived) >= REORDER);
    *held = keep;
    // when it was sent; for what carries no stamp, when it arrived
    let sent = |(arrived, s): &(tokio::time::Instant, Seen)| match s.stamp {
        0 => epoch_ns() as i64 - arrived.elapsed().as_nanos() as i64,
        t => t,
    };
    due.sort_by_key(sent);
    for x in due {
        let t = (sent(&x) - start_ns) as f64 / 1e9;
        let s = x.1;
        if out.json {
            println!(
                "{}",
                json!({ "t": t, "component": s.component, "event": s.what, "payload": s.payload })
            );
        } else {
            println!(
                "[{t:8.3} s] {} {} {}",
                s.component,
                s.what,
                codec::inline(&s.payload)
            );
        }
    }
}

/// Subscribes to what shows `c`'s activity and forwards each to `tx`: a response's signals and state, an
/// event's state (or, with `activate`, its triggered signal).
fn follow(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: tokio::sync::mpsc::UnboundedSender<Seen>,
) -> Fallible<Vec<tokio::task::JoinHandle<()>>> {
    let name = c.name().fully_qualified();
    let mut tasks = forward_signals(radar, c, activate, &tx, move |s| Seen {
        component: name.clone(),
        what: s.label.into(),
        payload: codec::decode(s.ros_type, &s.body),
        stamp: s.stamp,
    })?;
    tasks.push(follow_state(radar, c, activate, tx)?);
    Ok(tasks)
}

/// The task that reports `c`'s state changes (and, for an event not activated, its triggers, counted).
fn follow_state(
    radar: &Radar,
    c: &Component,
    activate: bool,
    tx: tokio::sync::mpsc::UnboundedSender<Seen>,
) -> Fallible<tokio::task::JoinHandle<()>> {
    let state_topic = c.name().topic("state");
    let said = |component: &str, what: String, stamp| Seen {
        component: component.to_owned(),
        what,
        payload: Value::Object(Default::default()),
        stamp,
    };
    Ok(match c {
        Component::Response(_) => {
            let sub = radar.state_subscription::<ResponseState>(&state_topic)?;
            tokio::spawn(async move {
                let mut last = String::new();
                while let Ok(s) = sub.recv().await {
                    if s.state_label != last {
                        last = s.state_label.clone();
                        let seen =
                            said(&s.name, format!("is {}", s.state_label), stamp_ns(&s.stamp));
                        if tx.send(seen).is_err() {
                            break;
                        }
                    }
                }
            })
        }
        Component::Event(_) => {
            let sub = radar.state_subscription::<EventState>(&state_topic)?;
            tokio::spawn(async move {
                let mut last: Option<EventState> = None;
                while let Ok(s) = sub.recv().await {
                    let mut lines = Vec::new();
                    match &last {
                        None => lines.push(if s.active { "is active" } else { "is inactive" }),
                        Some(l) => {
                            if s.active != l.active {
                                lines.push(if s.active { "activated" } else { "deactivated" });
                            }
                            if !activate && s.triggers > l.triggers {
                                lines.push("triggered");
                            }
                        }
                    }
                    for what in lines {
                        if tx
                            .send(said(&s.name, what.into(), stamp_ns(&s.stamp)))
                            .is_err()
                        {
                            return;
                        }
                    }
                    last = Some(s);
                }
            })
        }
    })
}
