//! `radar ls`: the events and responses on the graph, by namespace (like rtls).

use std::{collections::BTreeMap, time::Duration};

use radar_ros::{graph::Component, Radar};
use serde_json::{json, Value};

use crate::common::{discover, state_of, state_summary, with_status, Fallible, Out};

pub(crate) async fn ls(
    radar: &Radar,
    out: &Out,
    discovery: Duration,
    namespace: Option<String>,
    long: bool,
) -> Fallible<()> {
    if let Some(ns) = &namespace {
        if !ns.starts_with('/') {
            return Err(format!("the namespace is absolute, e.g. /{ns}").into());
        }
    }
    with_status("discovering", discover(radar, discovery)).await;
    let components: Vec<Component> = radar
        .components()
        .into_iter()
        .filter(|c| in_namespace(&c.name().fully_qualified(), &namespace))
        .collect();
    let states: Vec<Option<Value>> = if long {
        let futs = components
            .iter()
            .map(|c| state_of(radar, c, Duration::from_secs(2)));
        futures::future::join_all(futs).await
    } else {
        vec![None; components.len()]
    };
    if out.json {
        println!("{}", list_json(&components, &states, long));
        return Ok(());
    }
    if components.is_empty() {
        println!(
            "no RADAR components in ROS_DOMAIN_ID {}{}",
            radar.domain_id(),
            namespace.map(|n| format!(" under {n}")).unwrap_or_default()
        );
        return Ok(());
    }
    print_by_namespace(out, &components, &states, long);
    Ok(())
}

fn list_json(components: &[Component], states: &[Option<Value>], long: bool) -> Value {
    let list: Vec<Value> = components
        .iter()
        .zip(states)
        .map(|(c, s)| {
            let mut v = json!({
                "name": c.name().fully_qualified(),
                "kind": c.kind(),
                "types": types_of(c),
            });
            if long {
                v["state"] = s.clone().unwrap_or(Value::Null);
            }
            v
        })
        .collect();
    Value::Array(list)
}

/// The components by namespace, one line each (with `long`, its state).
fn print_by_namespace(out: &Out, components: &[Component], states: &[Option<Value>], long: bool) {
    let mut by_ns: BTreeMap<String, Vec<(&Component, &Option<Value>)>> = BTreeMap::new();
    for (c, s) in components.iter().zip(states) {
        by_ns
            .entry(c.name().namespace().to_owned())
            .or_default()
            .push((c, s));
    }
    for (ns, cs) in by_ns {
        println!("{}", out.bold(&format!("{ns}:")));
        for (c, s) in cs {
            let types = match c {
                Component::Event(e) => e.triggered().ros_type().to_owned(),
                Component::Response(r) => {
                    format!("{} -> {}", r.start_slot().ros_type(), r.exited().ros_type())
                }
            };
            let mut line = format!("  {:<9} {:<28} {}", c.kind(), c.name().base(), types);
            if long {
                line.push_str(&format!(
                    "  [{}]",
                    s.as_ref()
                        .map(|s| state_summary(c, s))
                        .unwrap_or_else(|| "no state".into())
                ));
            }
            println!("{line}");
        }
    }
}

fn in_namespace(name: &str, ns: &Option<String>) -> bool {
    match ns {
        None => true,
        Some(ns) => {
            let ns = ns.trim_end_matches('/');
            ns.is_empty() || name.starts_with(&format!("{ns}/"))
        }
    }
}

fn types_of(c: &Component) -> Value {
    match c {
        Component::Event(e) => json!({ "triggered": e.triggered().ros_type() }),
        Component::Response(r) => json!({
            "start": r.start_slot().ros_type(),
            "exited": r.exited().ros_type(),
        }),
    }
}
