//! `radar cat`: one component, its topics, state, and every program's connections touching it (like rtcat).

use std::time::Duration;

use radar_ros::{graph::Component, msg::ConnectionList, Radar};
use serde_json::{json, Value};

use crate::{
    common::{discover, latest, state_of, state_summary, with_status, Fallible, Out},
    components::{signal_topics, state_type},
};

/// What `radar cat` shows of one component.
struct Card {
    c: Component,
    fq: String,
    state: Option<Value>,
    /// (program or manager, connection) touching the component
    connections: Vec<(String, radar_ros::msg::Connection)>,
    params: Vec<(String, radar_ros::params::ParameterValue)>,
    /// (topic, role, type)
    topics: Vec<(String, &'static str, String)>,
}

pub(crate) async fn cat(radar: &Radar, out: &Out, discovery: Duration, name: &str) -> Fallible<()> {
    let c = with_status("discovering", find(radar, discovery, name)).await?;
    with_status("discovering", discover(radar, discovery)).await;
    let card = gather(radar, c).await?;
    if out.json {
        println!("{}", card_json(&card));
    } else {
        print_card(out, &card);
    }
    Ok(())
}

/// Everything the card shows: state, connections of every program and manager, parameters, topics.
async fn gather(radar: &Radar, c: Component) -> Fallible<Card> {
    let state = state_of(radar, &c, Duration::from_secs(2)).await;
    let fq = c.name().fully_qualified();
    let prefix = format!("{fq}/");
    let touches = |t: &str| t.starts_with(&prefix);
    // every program's and manager's connections
    let lists =
        futures::future::join_all(radar.introspect().connection_topics().into_iter().map(
            |t| async move { latest::<ConnectionList>(radar, &t, Duration::from_secs(3)).await },
        ))
        .await;
    let mut connections = Vec::new();
    for list in lists.into_iter().flatten() {
        for k in list.connections {
            if touches(&k.source) || touches(&k.target) || touches(&k.until) {
                connections.push((list.manager.clone(), k));
            }
        }
    }
    // its parameters, when it serves them (ros2 param dump)
    let params = if radar.introspect().serves_parameters(&fq) {
        radar
            .parameters_of(&fq)
            .timeout(Duration::from_secs(5))
            .await?
    } else {
        Vec::new()
    };
    let mut topics: Vec<(String, &'static str, String)> = Vec::new();
    if let Component::Response(r) = &c {
        for slot in [r.start_slot(), r.interrupt_slot(), r.exit_slot()] {
            topics.push((slot.topic().to_owned(), "slot", slot.ros_type().to_owned()));
        }
    }
    for (topic, ty, _) in signal_topics(&c) {
        topics.push((topic, "signal", ty));
    }
    topics.push((c.name().topic("state"), "state", state_type(&c).to_owned()));
    Ok(Card {
        c,
        fq,
        state,
        connections,
        params,
        topics,
    })
}

fn card_json(k: &Card) -> Value {
    json!({
        "name": k.fq,
        "kind": k.c.kind(),
        "topics": k.topics.iter().map(|(t, r, ty)| json!({"topic": t, "role": r, "type": ty})).collect::<Vec<_>>(),
        "state": k.state.clone().unwrap_or(Value::Null),
        "parameters": k.params.iter().map(|(n, v)| (n.clone(), param_json(v))).collect::<serde_json::Map<_, _>>(),
        "connections": k.connections.iter().map(|(p, c)| {
            let mut v = serde_json::to_value(c).unwrap_or(Value::Null);
            v["program"] = json!(p);
            v
        }).collect::<Vec<_>>(),
    })
}

fn print_card(out: &Out, k: &Card) {
    println!("{} ({})", out.bold(&k.fq), k.c.kind());
    for (t, r, ty) in &k.topics {
        println!("  {r:<6} {t:<36} {ty}");
    }
    match &k.state {
        Some(s) => {
            println!("  state: {}", state_summary(&k.c, s));
            if let Value::Object(m) = s {
                let counters: Vec<String> = m
                    .iter()
                    .filter(|(_, v)| v.is_u64())
                    .map(|(k, v)| format!("{k} {v}"))
                    .collect();
                println!("  counters: {}", counters.join(", "));
            }
        }
        None => println!("  state: none received"),
    }
    if k.params.is_empty() {
        println!("  parameters: none");
    }
    for (n, v) in &k.params {
        println!("  parameter {n} = {}", param_json(v));
    }
    if k.connections.is_empty() {
        println!("  connections: none");
    }
    for (program, c) in &k.connections {
        println!("  connection {} in {program}: {}", c.id, connection_line(c));
    }
}

/// `once /a -> /b/start until /c [armed], 3 delivered, 1 hop(s) on the wire`, and its panics if any.
fn connection_line(k: &radar_ros::msg::Connection) -> String {
    let until = if k.until.is_empty() {
        String::new()
    } else {
        format!(" until {}", k.until)
    };
    let panics = if k.panics == 0 {
        String::new()
    } else {
        format!(", {} panic(s), last: {}", k.panics, k.panic)
    };
    format!(
        "{} {} -> {}{} [{}], {} delivered, {} hop(s) on the wire{}",
        k.kind_label, k.source, k.target, until, k.state_label, k.delivered, k.hops, panics
    )
}

/// A parameter value as JSON (`ros2 param get` shows the same values).
pub(crate) fn param_json(v: &radar_ros::params::ParameterValue) -> Value {
    use radar_ros::params::ParameterValue as P;
    match v {
        P::NotSet => Value::Null,
        P::Boolean(b) => json!(b),
        P::Integer(i) => json!(i),
        P::Double(d) => json!(d),
        P::String(s) => json!(s),
        P::ByteArray(a) => json!(a),
        P::BooleanArray(a) => json!(a),
        P::IntegerArray(a) => json!(a),
        P::DoubleArray(a) => json!(a),
        P::StringArray(a) => json!(a),
    }
}

/// The component `name`, waiting for discovery.
async fn find(radar: &Radar, discovery: Duration, name: &str) -> Fallible<Component> {
    let fq = radar.resolve(name)?;
    let deadline = tokio::time::Instant::now() + discovery.max(Duration::from_secs(3));
    loop {
        if let Some(c) = radar.components().into_iter().find(|c| *c.name() == fq) {
            return Ok(c);
        }
        if tokio::time::Instant::now() >= deadline {
            let seen: Vec<String> = radar
                .components()
                .iter()
                .map(|c| c.name().fully_qualified())
                .collect();
            return Err(format!(
                "no event or response named {fq} on the graph (ROS_DOMAIN_ID {}); seen: {}",
                radar.domain_id(),
                if seen.is_empty() {
                    "none".to_owned()
                } else {
                    seen.join(", ")
                }
            )
            .into());
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}
